//! The receiver's golden frames and the replies a scripted receiver gives, shared by the
//! blocking and the async tests of the configuration sequence.
#![allow(dead_code)] // each test file uses its part

use neo_m8t::commands::{self, Command};
use neo_m8t::{encode_frame, Config};

/// Golden UBX frames on which the ublox 0.10 builders and pyubx2 agree, verbatim.
pub const MON_VER_POLL: [u8; 8] = [0xB5, 0x62, 0x0A, 0x04, 0x00, 0x00, 0x0E, 0x34];
pub const CFG_PRT_UART1_115200: [u8; 28] = [
    0xB5, 0x62, 0x06, 0x00, 0x14, 0x00, 0x01, 0x00, 0x00, 0x00, 0xC0, 0x08, 0x00, 0x00, 0x00, 0xC2,
    0x01, 0x00, 0x01, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0xA8, 0x42,
];
pub const CFG_MSG_NAV_PVT_UART1: [u8; 16] = [
    0xB5, 0x62, 0x06, 0x01, 0x08, 0x00, 0x01, 0x07, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x18, 0xE1,
];
pub const CFG_RATE_200MS: [u8; 14] = [
    0xB5, 0x62, 0x06, 0x08, 0x06, 0x00, 0xC8, 0x00, 0x01, 0x00, 0x01, 0x00, 0xDE, 0x6A,
];

/// MON-VER payload of a NEO-M8L (flash firmware ADR 4.11), from the `ublox` crate's own test
/// data (`mon_ver_flash_m8l_interpret`), verbatim.
pub const MON_VER_M8L_PAYLOAD: [u8; 250] = [
    69, 88, 84, 32, 67, 79, 82, 69, 32, 51, 46, 48, 49, 32, 40, 100, 49, 56, 57, 102, 102, 41, 0,
    0, 0, 0, 0, 0, 0, 0, 48, 48, 48, 56, 48, 48, 48, 48, 0, 0, 82, 79, 77, 32, 66, 65, 83, 69, 32,
    51, 46, 48, 49, 32, 40, 49, 48, 55, 56, 56, 56, 41, 0, 0, 0, 0, 0, 0, 0, 0, 70, 87, 86, 69, 82,
    61, 65, 68, 82, 32, 52, 46, 49, 49, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 80, 82, 79,
    84, 86, 69, 82, 61, 49, 57, 46, 49, 48, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 77,
    79, 68, 61, 78, 69, 79, 45, 77, 56, 76, 45, 48, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    0, 70, 73, 83, 61, 48, 120, 69, 70, 52, 48, 49, 53, 32, 40, 49, 48, 48, 49, 49, 49, 41, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 71, 80, 83, 59, 71, 76, 79, 59, 71, 65, 76, 59, 66, 68, 83, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 83, 66, 65, 83, 59, 73, 77, 69, 83, 59, 81, 90, 83, 83, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
];

pub fn frame(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; payload.len() + 8];
    encode_frame(class, id, payload, &mut out).unwrap();
    out
}

pub fn mon_ver_reply() -> Vec<u8> {
    frame(0x0A, 0x04, &MON_VER_M8L_PAYLOAD)
}

pub fn ack(cmd: &[u8]) -> Vec<u8> {
    frame(0x05, 0x01, &[cmd[2], cmd[3]])
}

pub fn nak(cmd: &[u8]) -> Vec<u8> {
    frame(0x05, 0x00, &[cmd[2], cmd[3]])
}

/// The commands after CFG-PRT for `config`, in order.
pub fn cfg_commands(config: &Config) -> Vec<Command> {
    let mut out = vec![commands::cfg_msg_uart1(0x01, 0x07, 1)];
    for (class, id) in commands::DEFAULT_NMEA {
        out.push(commands::cfg_msg_uart1(class, id, 0));
    }
    out.push(commands::cfg_msg_uart1(0x0D, 0x01, u8::from(config.tim_tp)));
    out.push(commands::cfg_msg_uart1(
        0x0D,
        0x03,
        u8::from(config.tim_tm2),
    ));
    out.push(commands::cfg_rate(
        config.measurement_period_ms,
        config.nav_rate,
        config.time_ref,
    ));
    out.push(commands::cfg_nav5(config.dynamic_model));
    if let Some(tp) = &config.time_pulse {
        out.push(commands::cfg_tp5(tp));
    }
    if let Some(mode) = &config.time_mode {
        out.push(commands::cfg_tmode2(mode));
    }
    out
}
