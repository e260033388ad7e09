//! Sweep one servo between 1000 µs and 2000 µs on a Maestro connected over USB.
//!
//! ```text
//! cargo run -p pololu-maestro --example sweep -- /dev/ttyACM0 0
//! ```
//!
//! The Maestro's "Command Port" (usually `/dev/ttyACM0`) must be in "USB Dual Port" or
//! "USB Chained" serial mode; the baud rate does not matter over USB. Reads the position and
//! the error register each step, with a 50 ms deadline per reply.

use std::time::{Duration, Instant};

use linux_embedded_hal::Serial;
use pololu_maestro::{Channel, ChannelLimits, Framing, Limits, Maestro, Micro6, QuarterMicros};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "/dev/ttyACM0".into());
    let index: u8 = args.next().as_deref().unwrap_or("0").parse()?;

    let channel = Channel::new::<Micro6>(index).map_err(|e| format!("channel {index}: {e}"))?;
    let limits = Limits::new().with(
        channel,
        ChannelLimits::from_micros(1000, 2000, 1500).map_err(|_| "bad limits")?,
    );
    let serial = Serial::open(path.clone(), 115_200).map_err(|e| format!("{path}: {e}"))?;
    let mut maestro = Maestro::new_serial(serial, Micro6, Framing::COMPACT).with_limits(limits);

    let errors = maestro.get_errors(&mut deadline(50))?;
    println!("error register at start: {errors:?}");

    for step in (0..=20).chain((0..20).rev()) {
        let target = QuarterMicros::from_micros(1000 + 50 * step)?;
        maestro.set_target(channel, target)?;
        std::thread::sleep(Duration::from_millis(50));
        let position = maestro.get_position(channel, &mut deadline(50))?;
        println!(
            "target {:4} µs, position {:7.2} µs",
            target.as_micros(),
            f32::from(position.get()) / 4.0
        );
    }
    maestro.set_neutral(channel)?;
    println!("errors: {:?}", maestro.get_errors(&mut deadline(50))?);
    Ok(())
}

/// A deadline `ms` milliseconds from now, for replies.
fn deadline(ms: u64) -> impl FnMut() -> bool {
    let end = Instant::now() + Duration::from_millis(ms);
    move || {
        std::thread::sleep(Duration::from_micros(100));
        Instant::now() >= end
    }
}
