//! Real-time check on Linux: linux-embedded-hal's `Serial` on a pseudo-terminal, with a
//! simulated module on the other end that enforces the guard times on a real clock and records
//! which bytes it would have sent over the radio. Nothing but the application's data may reach
//! the radio, and `+++` must be surrounded by `GT` of silence.
#![cfg(target_os = "linux")]

use std::io::{Read as _, Write as _};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use embedded_hal_nb::serial::Write;
use linux_embedded_hal::serialport::{SerialPort, TTYPort};
use linux_embedded_hal::{Delay, Serial};
use xbee_driver::DeviceError;
use xbee_driver::{CommandOutcome, CommandTiming, Error, Transparent, XBee};

const GT: Duration = Duration::from_millis(100);

fn timing() -> CommandTiming {
    CommandTiming::default()
        .with_guard_time_ms(100)
        .with_command_timeout_ms(2000)
        .with_reply_timeout_ms(500)
}

#[derive(Debug, Default)]
struct Seen {
    /// Bytes the module would have transmitted over the radio.
    radio: Vec<u8>,
    /// Command lines it executed.
    commands: Vec<String>,
    /// Silence before each accepted `+++`.
    silence_before: Vec<Duration>,
}

/// A module in transparent mode with `GT` = 100 ms and `CT` = 2 s.
fn simulated_module(mut port: TTYPort, stop: Arc<AtomicBool>) -> Seen {
    enum Mode {
        Data,
        AfterPlus(Instant),
        Command(Instant),
    }
    port.set_timeout(Duration::from_millis(2)).unwrap();
    let mut seen = Seen::default();
    let mut mode = Mode::Data;
    let mut last_rx = Instant::now();
    let mut pluses = 0;
    let mut line = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let mut buf = [0u8; 64];
        let n = port.read(&mut buf).unwrap_or(0);
        let now = Instant::now();
        match mode {
            Mode::AfterPlus(t) if n == 0 && now - t >= GT => {
                port.write_all(b"OK\r").unwrap();
                mode = Mode::Command(now);
            }
            Mode::Command(t) if now - t >= Duration::from_secs(2) => mode = Mode::Data,
            _ => {}
        }
        for &b in &buf[..n] {
            match mode {
                Mode::Data => {
                    if b == b'+' && (pluses > 0 || now - last_rx >= GT) {
                        if pluses == 0 {
                            seen.silence_before.push(now - last_rx);
                        }
                        pluses += 1;
                        if pluses == 3 {
                            pluses = 0;
                            mode = Mode::AfterPlus(now);
                        }
                    } else {
                        seen.radio.extend(std::iter::repeat_n(b'+', pluses));
                        pluses = 0;
                        seen.radio.push(b);
                    }
                }
                Mode::AfterPlus(_) => {
                    // Guard time broken: the pluses were data after all.
                    seen.radio.extend_from_slice(b"+++");
                    seen.radio.push(b);
                    mode = Mode::Data;
                }
                Mode::Command(_) => {
                    if b != b'\r' {
                        line.push(b);
                        continue;
                    }
                    let text = String::from_utf8_lossy(&line).into_owned();
                    line.clear();
                    let reply: &[u8] = match text.as_str() {
                        "ATVR" => b"100D\r",
                        "ATCN" => b"OK\r",
                        t if t.len() > 4 && t.starts_with("AT") => b"OK\r",
                        _ => b"ERROR\r",
                    };
                    port.write_all(reply).unwrap();
                    mode = if text == "ATCN" {
                        Mode::Data
                    } else {
                        Mode::Command(now)
                    };
                    seen.commands.push(text);
                }
            }
            last_rx = now;
        }
    }
    seen
}

fn start() -> (
    XBee<Serial, Transparent>,
    Arc<AtomicBool>,
    thread::JoinHandle<Seen>,
) {
    let (master, mut slave) = TTYPort::pair().expect("pseudo-terminal");
    slave.set_timeout(Duration::ZERO).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let module = {
        let stop = stop.clone();
        thread::spawn(move || simulated_module(master, stop))
    };
    (XBee::with_timing(Serial(slave), timing()), stop, module)
}

fn finish(stop: Arc<AtomicBool>, module: thread::JoinHandle<Seen>) -> Seen {
    thread::sleep(Duration::from_millis(50));
    stop.store(true, Ordering::Relaxed);
    module.join().unwrap()
}

fn send(radio: &mut XBee<Serial, Transparent>, data: &[u8]) {
    for &b in data {
        nb::block!(radio.write(b)).unwrap();
    }
    nb::block!(radio.flush()).unwrap();
}

#[test]
fn blocking_session_keeps_the_radio_stream_clean() {
    let (mut radio, stop, module) = start();
    send(&mut radio, b"$abc");
    let mut delay = Delay;
    let mut session = radio.command_mode(&mut delay).unwrap();
    assert_eq!(session.firmware_version().unwrap(), 0x100D);
    session.set_pan_id(0x7FFF).unwrap();
    session.exit().unwrap();
    send(&mut radio, b"xyz");

    let seen = finish(stop, module);
    assert_eq!(seen.radio, b"$abcxyz");
    assert_eq!(seen.commands, ["ATVR", "ATID7FFF", "ATCN"]);
    assert_eq!(seen.silence_before.len(), 1);
    assert!(seen.silence_before[0] >= GT);
}

#[test]
fn caller_clocked_session_keeps_the_radio_stream_clean() {
    let (mut radio, stop, module) = start();
    let t0 = Instant::now();
    let now_ms = || t0.elapsed().as_millis() as u32;
    let poll_until_done = |radio: &mut XBee<Serial, Transparent>| loop {
        match radio.poll(now_ms()) {
            Err(nb::Error::WouldBlock) => thread::sleep(Duration::from_micros(200)),
            other => return other,
        }
    };

    send(&mut radio, b"$abc");
    radio.start_command_mode().unwrap();
    // A control loop keeps writing while the radio is busy: refused, never sent.
    assert_eq!(
        radio.write(b'!'),
        Err(nb::Error::Other(Error::Device(
            DeviceError::CommandModeActive
        )))
    );
    assert_eq!(poll_until_done(&mut radio), Ok(CommandOutcome::Entered));
    radio
        .start_command(&xbee_driver::settings::set_pan_id(0x7FFF))
        .unwrap();
    assert_eq!(poll_until_done(&mut radio), Ok(CommandOutcome::Reply));
    assert_eq!(radio.reply(), b"OK");
    radio.start_exit().unwrap();
    assert_eq!(poll_until_done(&mut radio), Ok(CommandOutcome::Exited));
    send(&mut radio, b"xyz");

    let seen = finish(stop, module);
    assert_eq!(seen.radio, b"$abcxyz");
    assert_eq!(seen.commands, ["ATID7FFF", "ATCN"]);
    assert!(seen.silence_before[0] >= GT);
}
