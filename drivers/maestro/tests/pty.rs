//! End to end on Linux: the driver on linux-embedded-hal's `Serial` talks to a simulated
//! Maestro (the device-side decoder plus the reply encoders) over a pseudo-terminal, the way
//! the DIMA simulator plays the Maestro.
#![cfg(target_os = "linux")]

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use linux_embedded_hal::Serial;
use pololu_maestro::{
    reply, Channel, Command, CommandDecoder, DecoderConfig, Error, ErrorFlags, Framing, Maestro,
    Micro6, QuarterMicros, ScriptStatus,
};
use serialport::{SerialPort, TTYPort};

/// A minimal Maestro: remembers targets, answers queries; answers Get Script Status late.
fn simulate(mut port: TTYPort, stop: Arc<AtomicBool>, late_reply: Duration) -> CommandDecoder {
    port.set_timeout(Duration::from_millis(10)).unwrap();
    let mut decoder = CommandDecoder::new(DecoderConfig::default());
    let mut targets = [0u16; 24];
    let mut buf = [0u8; 64];
    while !stop.load(Ordering::Relaxed) {
        let n = match port.read(&mut buf) {
            Ok(n) => n,
            Err(_) => continue,
        };
        for &byte in &buf[..n] {
            let Some(command) = decoder.push(byte) else {
                continue;
            };
            match command {
                Command::SetTarget { channel, target } => {
                    targets[channel.index() as usize] = target.get()
                }
                Command::GetPosition { channel } => port
                    .write_all(&reply::encode_position(targets[channel.index() as usize]))
                    .unwrap(),
                Command::GetErrors => port
                    .write_all(&reply::encode_errors(decoder.take_errors()))
                    .unwrap(),
                Command::GetScriptStatus => {
                    thread::sleep(late_reply);
                    port.write_all(&[reply::encode_script_status(ScriptStatus::Stopped)])
                        .unwrap();
                }
                _ => {}
            }
        }
    }
    decoder
}

fn deadline(ms: u64) -> impl FnMut() -> bool {
    let end = Instant::now() + Duration::from_millis(ms);
    move || {
        thread::sleep(Duration::from_micros(200));
        Instant::now() >= end
    }
}

#[test]
fn driver_and_simulated_maestro_over_a_pty() {
    let (master, mut slave) = TTYPort::pair().expect("pseudo-terminal");
    slave.set_timeout(Duration::from_millis(1)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let sim = {
        let stop = stop.clone();
        thread::spawn(move || simulate(master, stop, Duration::from_millis(200)))
    };

    let mut maestro = Maestro::new_serial(Serial(slave), Micro6, Framing::COMPACT);
    let ch = |n| Channel::new::<Micro6>(n).unwrap();
    let us = |v| QuarterMicros::from_micros(v).unwrap();

    // DIMA: throttle 1500 µs, steering 1840 µs, tail 2000 µs in one write.
    maestro
        .set_targets(&[(ch(0), us(1500)), (ch(1), us(1840)), (ch(2), us(2000))])
        .unwrap();
    assert_eq!(
        maestro
            .get_position(ch(1), &mut deadline(2000))
            .unwrap()
            .get(),
        7360
    );
    assert_eq!(
        maestro
            .get_position(ch(2), &mut deadline(2000))
            .unwrap()
            .get(),
        8000
    );

    // An interrupted packet is a protocol error on the device side.
    maestro
        .interface()
        .inner()
        .0
        .write_all(&[0x84, 0x01])
        .unwrap();
    assert_eq!(
        maestro.get_errors(&mut deadline(2000)).unwrap(),
        ErrorFlags::SERIAL_PROTOCOL
    );
    assert_eq!(
        maestro.get_errors(&mut deadline(2000)).unwrap(),
        ErrorFlags::empty()
    );

    // A reply later than the deadline is a timeout ...
    assert_eq!(
        maestro.get_script_status(&mut deadline(20)),
        Err(Error::Device(pololu_maestro::DeviceError::Timeout))
    );
    // ... and when it finally arrives it is discarded, not taken for the next answer.
    thread::sleep(Duration::from_millis(600));
    assert_eq!(
        maestro
            .get_position(ch(0), &mut deadline(2000))
            .unwrap()
            .get(),
        6000
    );
    assert_eq!(maestro.stale_bytes(), 1);

    stop.store(true, Ordering::Relaxed);
    let decoder = sim.join().unwrap();
    let stats = decoder.stats();
    assert_eq!(stats.invalid_packets, 1);
    assert_eq!(stats.dropped_bytes, 2);
    assert_eq!(stats.crc_errors, 0);
}
