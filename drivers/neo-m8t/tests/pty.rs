//! End to end on Linux: the driver on linux-embedded-hal's `Serial` over a pseudo-terminal,
//! a simulated receiver on the other end that answers configuration and streams NAV-PVT.
#![cfg(target_os = "linux")]

use linux_embedded_hal::serialport::{SerialPort, TTYPort};
use linux_embedded_hal::{Delay, Serial};
use neo_m8t::encode_frame;
use neo_m8t::{Config, NavPvt, NeoM8t, UbxFramer};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

fn frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; payload.len() + 8];
    encode_frame(class, id, payload, &mut out).unwrap();
    out
}

/// A MON-VER payload: software, hardware and two extensions.
fn mon_ver_payload() -> Vec<u8> {
    let mut p = vec![0u8; 100];
    p[..22].copy_from_slice(b"ROM CORE 3.01 (107888)");
    p[30..38].copy_from_slice(b"00080000");
    p[40..52].copy_from_slice(b"FWVER=TIM 1.");
    p[52..54].copy_from_slice(b"10");
    p[70..83].copy_from_slice(b"PROTVER=20.30");
    p
}

/// Answers MON-VER and CFG-PRT polls, acknowledges every other CFG message, and streams
/// NAV-PVT every 10 ms once NAV-PVT output was switched on. Returns the (class, id) of every
/// message it received.
fn simulated_receiver(mut port: TTYPort, stop: Arc<AtomicBool>) -> Vec<(u8, u8)> {
    port.set_timeout(Duration::from_millis(1)).unwrap();
    let mut framer = UbxFramer::<512>::with_capacity();
    let mut seen = Vec::new();
    let mut streaming = false;
    let mut itow_ms = 0u32;
    let mut last = Instant::now();
    let mut buf = [0u8; 256];
    while !stop.load(Ordering::Relaxed) {
        let n = port.read(&mut buf).unwrap_or(0);
        let mut frames = Vec::new();
        framer.push_slice(&buf[..n], |f| {
            frames.push((f.class(), f.id(), f.payload().to_vec()))
        });
        for (class, id, payload) in frames {
            seen.push((class, id));
            let answer = match (class, id, payload.len()) {
                (0x0A, 0x04, 0) => frame(0x0A, 0x04, &mon_ver_payload()),
                (0x06, 0x00, 1) => {
                    let mut a = frame(0x06, 0x00, &[0x01; 20]);
                    a.extend(frame(0x05, 0x01, &[0x06, 0x00]));
                    a
                }
                (0x06, _, _) => {
                    if id == 0x01 && payload[..2] == [0x01, 0x07] {
                        streaming = payload[3] == 1;
                    }
                    frame(0x05, 0x01, &[class, id])
                }
                _ => Vec::new(),
            };
            port.write_all(&answer).unwrap();
        }
        if streaming && last.elapsed() >= Duration::from_millis(10) {
            last = Instant::now();
            itow_ms += 100;
            let pvt = NavPvt {
                itow_ms,
                fix_type: 3,
                num_sv: 12,
                ..NavPvt::default()
            };
            port.write_all(pvt.to_frame().as_bytes()).unwrap();
        }
    }
    seen
}

#[test]
fn configure_and_stream_over_a_pseudo_terminal() {
    let (master, mut slave) = TTYPort::pair().expect("pseudo-terminal");
    slave.set_timeout(Duration::from_millis(1)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let receiver = {
        let stop = stop.clone();
        thread::spawn(move || simulated_receiver(master, stop))
    };

    let mut gnss: NeoM8t<Serial> = NeoM8t::with_capacity(Serial(slave));
    let mut switches = Vec::new();
    let version = gnss
        .configure_blocking(
            Config::default().with_baud_rate(115_200),
            9_600,
            &mut Delay,
            |serial, baud| {
                switches.push(baud);
                serial.0.set_baud_rate(baud).unwrap();
            },
        )
        .expect("configuration");
    assert_eq!(switches, vec![115_200]);
    assert_eq!(version.software.as_str(), "ROM CORE 3.01 (107888)");
    assert_eq!(version.firmware.as_str(), "TIM 1.10");
    assert_eq!(
        version.protocol.map(|p| p.to_string()),
        Some("20.30".into())
    );

    let mut itows = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(5);
    while itows.len() < 5 && Instant::now() < deadline {
        match gnss.poll_nav_pvt().expect("read") {
            Some(frame) => itows.push(frame.to_nav_pvt().itow_ms),
            None => thread::sleep(Duration::from_millis(2)),
        }
    }
    stop.store(true, Ordering::Relaxed);
    let seen = receiver.join().unwrap();

    assert_eq!(itows.len(), 5, "NAV-PVT frames received: {itows:?}");
    assert!(itows.windows(2).all(|w| w[1] > w[0]), "{itows:?}");
    assert_eq!(gnss.stream().stats().checksum_errors, 0);
    // MON-VER, CFG-PRT (its ACK confirms the switch, so no CFG-PRT poll), CFG-MSG...
    assert_eq!(&seen[..3], &[(0x0A, 0x04), (0x06, 0x00), (0x06, 0x01)]);
    assert_eq!(seen.iter().filter(|m| **m == (0x06, 0x01)).count(), 9);
    let last = seen.iter().rposition(|m| m.0 == 0x06).unwrap();
    assert_eq!(
        seen[last],
        (0x06, 0x31),
        "CFG-TP5 is the last message: {seen:?}"
    );
}
