//! Configure a NEO-M8T on a Linux serial port, then print every fix.
//!
//! ```text
//! cargo run -p neo-m8t --example linux -- /dev/ttyUSB0 9600 115200
//! ```
//! Arguments: port, the receiver's current UART1 baud rate (9600 from the factory), the rate
//! to switch to.

use linux_embedded_hal::serialport::{self, SerialPort};
use linux_embedded_hal::{Delay, Serial};
use neo_m8t::{Config, NeoM8t};
use std::time::Duration;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "/dev/ttyUSB0".into());
    let current: u32 = args.next().map(|s| s.parse()).transpose()?.unwrap_or(9_600);
    let target: u32 = args
        .next()
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(115_200);

    // A 1 ms read timeout makes reads non-blocking for the driver (timeout = WouldBlock).
    let port = Serial::open_from_builder(
        serialport::new(&path, current).timeout(Duration::from_millis(1)),
    )?;
    let mut gnss: NeoM8t<Serial> = NeoM8t::with_capacity(port);

    let config = Config::default().with_baud_rate(target);
    let version = gnss.configure_blocking(config, current, &mut Delay, |serial, baud| {
        if let Err(e) = serial.0.set_baud_rate(baud) {
            eprintln!("cannot set {path} to {baud} baud: {e}");
        }
    })?;
    println!(
        "receiver: {} / {} / firmware {} / protocol {}",
        version.software,
        version.hardware,
        version.firmware,
        version
            .protocol
            .map_or_else(|| "unknown".into(), |p| p.to_string())
    );

    loop {
        match gnss.poll_nav_pvt()? {
            Some(frame) => {
                let f = frame.to_nav_pvt();
                println!(
                    "iTOW {} ms  fix {:?}  sv {}  lat {:.7}  lon {:.7}  hMSL {:.3} m  speed {:.3} m/s  hAcc {} mm",
                    f.itow_ms,
                    f.fix(),
                    f.num_sv,
                    f64::from(f.lat_deg_e7) * 1e-7,
                    f64::from(f.lon_deg_e7) * 1e-7,
                    f64::from(f.h_msl_mm) * 1e-3,
                    f64::from(f.g_speed_mm_s) * 1e-3,
                    f.h_acc_mm,
                );
            }
            None => std::thread::sleep(Duration::from_millis(5)),
        }
    }
}
