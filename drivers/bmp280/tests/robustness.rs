//! The driver never panics and never waits without bound, whatever the bus returns.

use std::cell::Cell;
use std::rc::Rc;

use bosch_bmp280::{Bmp280, Config, Error, Interface, Resolution};
use embedded_hal_mock::eh1::delay::NoopDelay;
use proptest::prelude::*;

/// A device that answers every read with the next bytes of a random stream and accepts every
/// write; it counts accesses so a test can bound them.
struct RandomDevice {
    bytes: Vec<u8>,
    pos: usize,
    accesses: Rc<Cell<usize>>,
}

impl Interface for RandomDevice {
    type Error = ();

    fn read_registers(&mut self, _register: u8, buf: &mut [u8]) -> Result<(), ()> {
        self.accesses.set(self.accesses.get() + 1);
        for b in buf {
            *b = self.bytes.get(self.pos).copied().unwrap_or(0xFF);
            self.pos += 1;
        }
        Ok(())
    }

    fn write_register(&mut self, _register: u8, _value: u8) -> Result<(), ()> {
        self.accesses.set(self.accesses.get() + 1);
        Ok(())
    }
}

proptest! {
    #[test]
    fn any_bus_bytes_give_a_result_or_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..200), accept in any::<bool>()) {
        let accesses = Rc::new(Cell::new(0));
        let device = RandomDevice { bytes, pos: 0, accesses: Rc::clone(&accesses) };
        let mut bmp = Bmp280::new(device).accept_bme280(accept);
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
        // The polls cover the maximum time plus 2 ms in steps of 0.5 ms.
        let config = Config::forced(Resolution::UltraHigh);
        let polls = (config.measurement_time_max_us() - config.measurement_time_typ_us() + 2000) / 500 + 1;
        let bound = 1 + 1 + 5 + 1 + 3 + 1 + polls as usize + 1 + 5;
        prop_assert!(accesses.get() <= bound);
    }
}
