//! The driver never panics and never waits without bound, whatever the bus returns.

use bosch_bmp280::{Bmp280, Config, Error, Interface, Resolution};
use embedded_hal_mock::eh1::delay::NoopDelay;
use proptest::prelude::*;

/// A device that answers every read with the next bytes of a random stream and accepts every
/// write; it counts accesses so a test can bound them.
struct RandomDevice {
    bytes: Vec<u8>,
    pos: usize,
    accesses: usize,
}

impl Interface for RandomDevice {
    type Error = ();

    fn read_registers(&mut self, _register: u8, buf: &mut [u8]) -> Result<(), ()> {
        self.accesses += 1;
        for b in buf {
            *b = self.bytes.get(self.pos).copied().unwrap_or(0xFF);
            self.pos += 1;
        }
        Ok(())
    }

    fn write_register(&mut self, _register: u8, _value: u8) -> Result<(), ()> {
        self.accesses += 1;
        Ok(())
    }
}

proptest! {
    #[test]
    fn any_bus_bytes_give_a_result_or_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..200), accept in any::<bool>()) {
        let mut bmp = Bmp280::new(RandomDevice { bytes, pos: 0, accesses: 0 }).accept_bme280(accept);
        let mut delay = NoopDelay::new();
        match bmp.init(&mut delay) {
            Ok(_) => {
                bmp.configure(Config::forced(Resolution::UltraHigh)).unwrap();
                let _ = bmp.measure_forced(&mut delay);
                let _ = bmp.measure();
                let _ = bmp.poll_forced();
            }
            Err(Error::Comm(())) => prop_assert!(false, "the fake bus never fails"),
            Err(_) => {}
        }
        let _ = bmp.read_raw();
        let _ = bmp.read_config();
        // init: 1 write + id + at most 5 status reads + calibration; configure: 3 writes;
        // measure_forced: 1 write + at most forced_polls status reads + 1 data read; then a
        // handful of single reads. Anything above that would be an unbounded wait.
        let polls = bosch_bmp280::sequence::forced_polls(&Config::forced(Resolution::UltraHigh));
        let bound = 1 + 1 + 5 + 1 + 3 + 1 + polls as usize + 1 + 5;
        prop_assert!(bmp.into_interface().accesses <= bound);
    }
}
