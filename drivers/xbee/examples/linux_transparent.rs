//! Transparent XBee link on Linux (Jetson or ground station), with linux-embedded-hal.
//!
//! ```text
//! cargo run -p xbee-driver --example linux_transparent -- /dev/ttyUSB0
//! cargo run -p xbee-driver --example linux_transparent -- /dev/ttyUSB0 coordinator 00112233445566778899AABBCCDDEEFF 0013A20040A1B2C3
//! cargo run -p xbee-driver --example linux_transparent -- /dev/ttyUSB0 router 00112233445566778899AABBCCDDEEFF
//! ```
//!
//! With a role and a key it first configures the module as one half of a DIMA pair (PAN id
//! 0x7FFF, transparent mode, 9600 baud, encryption on, destination, settings saved). The
//! coordinator (ground station) also needs the robot module's 64-bit address (`SH` `SL`, on its
//! label) as its destination; the router (robot) sends to the coordinator (`DH` `DL` = 0 0).
//! Then it sends the DIMA heartbeat command frame every 100 ms for 5 s and prints every byte
//! received.

use std::time::{Duration, Instant};

use embedded_hal_nb::serial::{Read, Write};
use linux_embedded_hal::{Delay, Serial};
use xbee_driver::{Address64, ApiMode, AtCommand, BaudRate, Parameter, Role, XBee};

/// The DIMA ground link's heartbeat command frame (10 bytes, ground link v1).
const HEARTBEAT: [u8; 10] = [0x24, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC6, 0x22, 0xF7, 0x1D];

fn parse_key(hex: &str) -> Result<[u8; 16], String> {
    if hex.len() != 32 || !hex.is_ascii() {
        return Err(format!(
            "key must be 32 hexadecimal digits, got {} bytes",
            hex.len()
        ));
    }
    let mut key = [0u8; 16];
    for (i, byte) in key.iter_mut().enumerate() {
        *byte = u8::from_str_radix(&hex[2 * i..2 * i + 2], 16)
            .map_err(|e| format!("key digit pair {i}: {e}"))?;
    }
    Ok(key)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let device = args.next().unwrap_or_else(|| "/dev/ttyUSB0".into());
    let role = match args.next().as_deref() {
        None => None,
        Some("coordinator") => Some(Role::Coordinator),
        Some("router") => Some(Role::Router),
        Some(other) => {
            return Err(format!("role must be coordinator or router, not {other}").into())
        }
    };

    let serial = Serial::open(device.clone(), BaudRate::Bps9600.bps())
        .map_err(|e| format!("cannot open {device}: {e}"))?;
    let mut radio = XBee::new(serial);

    if let Some(role) = role {
        let key = parse_key(
            &args
                .next()
                .ok_or("a 128-bit key (32 hex digits) is required")?,
        )?;
        // Where this module sends in transparent mode: the robot from the ground station, the
        // coordinator (address 0) from the robot.
        let destination = match role {
            Role::Coordinator => {
                let hex = args
                    .next()
                    .ok_or("the coordinator needs the robot module's SH SL (16 hex digits)")?;
                Address64(
                    u64::from_str_radix(&hex, 16)
                        .map_err(|e| format!("robot address {hex:?}: {e}"))?,
                )
            }
            Role::Router => Address64::COORDINATOR,
        };
        let mut delay = Delay;
        let mut session = radio
            .command_mode(&mut delay)
            .map_err(|e| format!("{device}: {e}"))?;
        println!("firmware {:04X}", session.firmware_version()?);
        session.set_pan_id(0x7FFF)?;
        session.set_role(role)?;
        session.set_api_mode(ApiMode::Transparent)?;
        session.set_baud_rate(BaudRate::Bps9600)?;
        session.set_encryption(true)?;
        session.set_encryption_key(&key)?;
        session.set_raw(AtCommand::DH, Parameter::Number(destination.0 >> 32))?;
        session.set_raw(
            AtCommand::DL,
            Parameter::Number(destination.0 & 0xFFFF_FFFF),
        )?;
        session.write_settings()?;
        session.exit()?;
        println!("configured as {role:?}");
    }

    let start = Instant::now();
    let mut next_send = start;
    while start.elapsed() < Duration::from_secs(5) {
        if Instant::now() >= next_send {
            for byte in HEARTBEAT {
                nb::block!(radio.write(byte))?;
            }
            next_send += Duration::from_millis(100);
        }
        match radio.read() {
            Ok(byte) => print!("{byte:02X} "),
            Err(nb::Error::WouldBlock) => std::thread::sleep(Duration::from_millis(1)),
            Err(nb::Error::Other(e)) => return Err(e.into()),
        }
    }
    println!();
    Ok(())
}
