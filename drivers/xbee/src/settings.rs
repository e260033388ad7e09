//! AT request builders and reply parsers for the common settings (the typed values are at the
//! crate root: [`BaudRate`], [`ApiMode`], [`PowerLevel`], [`Role`]).
//!
//! These are plain functions without I/O: the blocking [`CommandSession`](crate::CommandSession)
//! uses them, and so can a caller that drives [`XBee::poll`](crate::XBee::poll)
//! with its own clock (build the request here, parse [`XBee::reply`](crate::XBee::reply)
//! here).

use crate::at::{parse_hex, AtCommand, AtRequest, Parameter};
use crate::setting_types::{
    ApiMode, BaudRate, PowerLevel, Role, MAX_CHANNEL, MAX_NODE_IDENTIFIER_LEN, MIN_CHANNEL,
};
/// `ATID<id>`: PAN id.
pub const fn set_pan_id(id: u64) -> AtRequest<'static> {
    AtRequest::set(AtCommand::ID, Parameter::Number(id))
}

/// `ATCH<ch>`: operating channel 0x0B to 0x1A (802.15.4 and DigiMesh firmware; Zigbee
/// coordinators pick the channel from `SC`). `None` outside the range.
pub fn set_channel(channel: u8) -> Option<AtRequest<'static>> {
    (MIN_CHANNEL..=MAX_CHANNEL)
        .contains(&channel)
        .then(|| AtRequest::set(AtCommand::CH, Parameter::Number(channel.into())))
}

/// `ATNI<text>`: node identifier. `None` if longer than 20 characters, starting with a space,
/// or holding a comma or a non-printable character.
pub fn set_node_identifier(name: &str) -> Option<AtRequest<'_>> {
    let bytes = name.as_bytes();
    let printable = bytes
        .iter()
        .all(|&b| (b == b' ' || b.is_ascii_graphic()) && b != b',');
    (bytes.len() <= MAX_NODE_IDENTIFIER_LEN && printable && bytes.first() != Some(&b' '))
        .then_some(AtRequest::set(AtCommand::NI, Parameter::Text(bytes)))
}

/// `ATBD<code>`: UART baud rate. It takes effect when command mode ends (or after `AC`): switch
/// the host's serial port to [`BaudRate::bps`] then.
pub const fn set_baud_rate(rate: BaudRate) -> AtRequest<'static> {
    AtRequest::set(AtCommand::BD, Parameter::Number(rate.code() as u64))
}

/// `ATAP<mode>`: serial operating mode.
pub const fn set_api_mode(mode: ApiMode) -> AtRequest<'static> {
    AtRequest::set(AtCommand::AP, Parameter::Number(mode.code() as u64))
}

/// `ATPL<level>`: transmit power.
pub const fn set_power_level(level: PowerLevel) -> AtRequest<'static> {
    AtRequest::set(AtCommand::PL, Parameter::Number(level.code() as u64))
}

/// `ATEE<0|1>`: encryption enable.
pub const fn set_encryption(enabled: bool) -> AtRequest<'static> {
    AtRequest::set(AtCommand::EE, Parameter::Number(enabled as u64))
}

/// `ATKY<key>`: 128-bit AES key, written as 32 hexadecimal digits. The module never reads it
/// back; both modules of a pair need the same key and `EE = 1`.
pub const fn set_encryption_key(key: &[u8; 16]) -> AtRequest<'_> {
    AtRequest::set(AtCommand::KY, Parameter::Bytes(key))
}

/// `ATCE<0|1>`: network role.
pub const fn set_role(role: Role) -> AtRequest<'static> {
    let ce = match role {
        Role::Coordinator => 1,
        Role::Router => 0,
    };
    AtRequest::set(AtCommand::CE, Parameter::Number(ce))
}

/// Reads a numeric reply; `None` if it is not 1 to 16 hexadecimal digits.
pub fn parse_number(reply: &[u8]) -> Option<u64> {
    parse_hex(reply)
}

/// Reads a `CH` reply.
pub fn parse_channel(reply: &[u8]) -> Option<u8> {
    parse_hex(reply).and_then(|v| u8::try_from(v).ok())
}

/// Reads a `BD` reply.
pub fn parse_baud_rate(reply: &[u8]) -> Option<BaudRate> {
    parse_hex(reply)
        .and_then(|v| u32::try_from(v).ok())
        .map(BaudRate::from_code)
}

/// Reads an `AP` reply.
pub fn parse_api_mode(reply: &[u8]) -> Option<ApiMode> {
    parse_hex(reply).and_then(ApiMode::from_code)
}

/// Reads a `PL` reply.
pub fn parse_power_level(reply: &[u8]) -> Option<PowerLevel> {
    parse_hex(reply).and_then(PowerLevel::from_code)
}

/// Reads an `EE` reply.
pub fn parse_encryption(reply: &[u8]) -> Option<bool> {
    match parse_hex(reply)? {
        0 => Some(false),
        1 => Some(true),
        _ => None,
    }
}

/// Reads a `CE` reply.
pub fn parse_role(reply: &[u8]) -> Option<Role> {
    match parse_hex(reply)? {
        0 => Some(Role::Router),
        1 => Some(Role::Coordinator),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::at::{format_line, MAX_LINE_LEN};

    fn assert_line(req: AtRequest<'_>, expected: &[u8]) {
        let mut out = [0u8; MAX_LINE_LEN];
        let n = format_line(&req, &mut out).expect("fits");
        assert_eq!(&out[..n], expected);
    }

    #[test]
    fn baud_rate_codes_match_digi_table() {
        // XBee 3 user guide, BD: 0 = 1200 ... 3 = 9600 (default) ... 0x0A = 921600.
        let table = [
            (0, 1200),
            (1, 2400),
            (2, 4800),
            (3, 9600),
            (4, 19200),
            (5, 38400),
            (6, 57600),
            (7, 115200),
            (8, 230400),
            (9, 460800),
            (0x0A, 921600),
        ];
        for (code, bps) in table {
            let rate = BaudRate::from_code(code);
            assert_eq!(rate.code(), code);
            assert_eq!(rate.bps(), bps);
            assert_eq!(BaudRate::from_bps(bps), rate);
        }
        assert_eq!(BaudRate::from_bps(250_000), BaudRate::Custom(250_000));
        assert_eq!(BaudRate::from_code(0x3D090).bps(), 250_000);
    }

    #[test]
    fn request_lines() {
        assert_line(set_pan_id(0x7FFF), b"ATID7FFF\r");
        assert_line(set_channel(0x0C).unwrap(), b"ATCHC\r");
        assert_line(set_baud_rate(BaudRate::Bps115200), b"ATBD7\r");
        assert_line(set_api_mode(ApiMode::Transparent), b"ATAP0\r");
        assert_line(set_power_level(PowerLevel::Highest), b"ATPL4\r");
        assert_line(set_encryption(true), b"ATEE1\r");
        assert_line(set_role(Role::Coordinator), b"ATCE1\r");
        assert_line(set_role(Role::Router), b"ATCE0\r");
        let key = [
            0x00, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88, 0x99, 0xAA, 0xBB, 0xCC, 0xDD,
            0xEE, 0xFF,
        ];
        assert_line(
            set_encryption_key(&key),
            b"ATKY00112233445566778899AABBCCDDEEFF\r",
        );
        assert_line(
            set_node_identifier("DIMA ROBOT").unwrap(),
            b"ATNIDIMA ROBOT\r",
        );
    }

    #[test]
    fn invalid_settings_are_refused() {
        assert!(set_channel(0x0A).is_none());
        assert!(set_channel(0x1B).is_none());
        assert!(set_node_identifier("123456789012345678901").is_none());
        assert!(set_node_identifier(" LEADING").is_none());
        assert!(set_node_identifier("A,B").is_none());
        assert!(set_node_identifier("12345678901234567890").is_some());
    }

    #[test]
    fn replies() {
        assert_eq!(parse_channel(b"C"), Some(0x0C));
        assert_eq!(parse_channel(b"100"), None);
        assert_eq!(parse_baud_rate(b"3"), Some(BaudRate::Bps9600));
        assert_eq!(parse_api_mode(b"2"), Some(ApiMode::ApiEscaped));
        assert_eq!(parse_api_mode(b"3"), None);
        assert_eq!(parse_power_level(b"4"), Some(PowerLevel::Highest));
        assert_eq!(parse_encryption(b"1"), Some(true));
        assert_eq!(parse_role(b"0"), Some(Role::Router));
        assert_eq!(parse_number(b"ERROR"), None);
    }
}
