//! Reads packets from a real sensor board on Linux (Jetson Nano: UART on /dev/ttyTHS1,
//! request line on a GPIO character device).
//!
//! ```text
//! cargo run --example linux -- /dev/ttyTHS1 460800 /dev/gpiochip0 79
//! ```
//!
//! Arguments: serial port, baud rate, GPIO chip, line offset of the request line. Each cycle
//! raises and lowers the request line, then polls for the answer with a 10 ms deadline.

use std::error::Error;
use std::thread;
use std::time::{Duration, Instant};

use dima_sensorboard::{Frame, SensorBoard};
use linux_embedded_hal::gpio_cdev::{Chip, LineRequestFlags};
use linux_embedded_hal::{serialport, CdevPin, Serial};

fn main() -> Result<(), Box<dyn Error>> {
    let mut args = std::env::args().skip(1);
    let port = args.next().unwrap_or_else(|| "/dev/ttyTHS1".into());
    let baud: u32 = args.next().map_or(Ok(460_800), |s| s.parse())?;
    let chip = args.next().unwrap_or_else(|| "/dev/gpiochip0".into());
    let line: u32 = args.next().map_or(Ok(79), |s| s.parse())?;

    // 8N2 as the board sends; a zero timeout makes every read non-blocking (WouldBlock when
    // the port has nothing), so `poll` never waits.
    let builder = serialport::new(port.as_str(), baud)
        .stop_bits(serialport::StopBits::Two)
        .timeout(Duration::ZERO);
    let serial = Serial::open_from_builder(builder)
        .map_err(|e| format!("cannot open serial port {port}: {e}"))?;
    let handle = Chip::new(&chip)
        .and_then(|mut c| c.get_line(line))
        .and_then(|l| l.request(LineRequestFlags::OUTPUT, 0, "dima-sensorboard"))
        .map_err(|e| format!("cannot claim request line {chip}:{line}: {e}"))?;
    let pin = CdevPin::new(handle)?;

    let mut board = SensorBoard::new(pin, serial);
    for _ in 0..250 {
        board.request()?;
        board.end_request()?;
        let deadline = Instant::now() + Duration::from_millis(10);
        loop {
            match board.poll() {
                Ok(Frame::Packet(raw)) => {
                    let p = raw.decode();
                    println!(
                        "acc {:?} gyro {:?} mag {:?} gnss {}",
                        p.accel,
                        p.gyro,
                        p.mag,
                        p.nav_pvt().map_or("absent".into(), |g| format!(
                            "{} sv, {:.7} {:.7}",
                            g.num_sv,
                            g.lat_deg(),
                            g.lon_deg()
                        ))
                    );
                    break;
                }
                Ok(Frame::Info(info)) => println!("info frame: {info:?}"),
                Err(nb::Error::WouldBlock) if Instant::now() < deadline => {
                    thread::sleep(Duration::from_micros(200));
                }
                Err(nb::Error::WouldBlock) => {
                    eprintln!("no answer within 10 ms");
                    break;
                }
                Err(nb::Error::Other(e)) => eprintln!("{e}"),
            }
        }
        thread::sleep(Duration::from_millis(4));
    }
    eprintln!("{:?}", board.stats());
    Ok(())
}
