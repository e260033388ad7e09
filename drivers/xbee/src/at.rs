//! AT command names, parameters and the text form used in command mode (pure, no I/O).

use core::fmt;

/// A two-letter AT command name, such as `ID` or `NI`.
///
/// Any two bytes are accepted (API frames carry whatever the module sends); the constants cover
/// the commands this driver has helpers for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AtCommand(pub [u8; 2]);

impl AtCommand {
    /// PAN id (64-bit on Zigbee, 16-bit on 802.15.4 and DigiMesh).
    pub const ID: Self = Self(*b"ID");
    /// Operating channel (read-only on Zigbee, where `SC` selects the scanned channels).
    pub const CH: Self = Self(*b"CH");
    /// Scan channels bit mask (Zigbee).
    pub const SC: Self = Self(*b"SC");
    /// Node identifier, up to 20 printable characters.
    pub const NI: Self = Self(*b"NI");
    /// UART baud rate.
    pub const BD: Self = Self(*b"BD");
    /// API mode: 0 transparent, 1 API, 2 API with escaping.
    pub const AP: Self = Self(*b"AP");
    /// Transmit power level, 0 (lowest) to 4 (highest).
    pub const PL: Self = Self(*b"PL");
    /// Encryption enable.
    pub const EE: Self = Self(*b"EE");
    /// AES encryption key (write-only: the module never reads it back).
    pub const KY: Self = Self(*b"KY");
    /// Coordinator enable.
    pub const CE: Self = Self(*b"CE");
    /// Sleep mode (0 for routers).
    pub const SM: Self = Self(*b"SM");
    /// Firmware version.
    pub const VR: Self = Self(*b"VR");
    /// Hardware version.
    pub const HV: Self = Self(*b"HV");
    /// Serial number high 32 bits.
    pub const SH: Self = Self(*b"SH");
    /// Serial number low 32 bits.
    pub const SL: Self = Self(*b"SL");
    /// Destination address high 32 bits (transparent mode).
    pub const DH: Self = Self(*b"DH");
    /// Destination address low 32 bits (transparent mode).
    pub const DL: Self = Self(*b"DL");
    /// 16-bit network address.
    pub const MY: Self = Self(*b"MY");
    /// Guard time around the command sequence, in ms.
    pub const GT: Self = Self(*b"GT");
    /// Command-mode timeout, in units of 100 ms.
    pub const CT: Self = Self(*b"CT");
    /// Command sequence character.
    pub const CC: Self = Self(*b"CC");
    /// Exit command mode.
    pub const CN: Self = Self(*b"CN");
    /// Write the settings to non-volatile memory.
    pub const WR: Self = Self(*b"WR");
    /// Apply queued changes now.
    pub const AC: Self = Self(*b"AC");

    /// Builds a command name from its two ASCII letters.
    pub const fn new(name: [u8; 2]) -> Self {
        Self(name)
    }
}

impl fmt::Display for AtCommand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for &b in &self.0 {
            if b.is_ascii_graphic() {
                write!(f, "{}", b as char)?;
            } else {
                write!(f, "\\x{b:02X}")?;
            }
        }
        Ok(())
    }
}

/// The parameter of an AT command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Parameter<'a> {
    /// No parameter: a query (`ATID\r`) or an action (`ATWR\r`).
    None,
    /// A number. Command mode writes it as upper-case hexadecimal without leading zeros
    /// (`ATID7FFF\r`); API frames carry it big-endian in as few bytes as it needs (`7F FF`).
    Number(u64),
    /// Text, such as a node identifier: printable ASCII without commas.
    Text(&'a [u8]),
    /// Raw bytes (an encryption key): hexadecimal digits in command mode, bytes in API frames.
    Bytes(&'a [u8]),
}

impl Parameter<'_> {
    /// Writes the binary form used by API frames into `out`; returns its length.
    ///
    /// Returns `None` if `out` is too small.
    pub fn to_api_bytes(&self, out: &mut [u8]) -> Option<usize> {
        match *self {
            Parameter::None => Some(0),
            Parameter::Number(n) => {
                let bytes = n.to_be_bytes();
                let skip = (n.leading_zeros() / 8).min(7) as usize;
                copy(bytes.get(skip..)?, out)
            }
            Parameter::Text(t) | Parameter::Bytes(t) => copy(t, out),
        }
    }
}

fn copy(src: &[u8], out: &mut [u8]) -> Option<usize> {
    out.get_mut(..src.len())?.copy_from_slice(src);
    Some(src.len())
}

/// A complete AT command: name and parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AtRequest<'a> {
    /// The command name.
    pub command: AtCommand,
    /// Its parameter.
    pub parameter: Parameter<'a>,
}

impl<'a> AtRequest<'a> {
    /// A query (or parameterless action): `AT<cmd>\r`.
    pub const fn query(command: AtCommand) -> Self {
        Self {
            command,
            parameter: Parameter::None,
        }
    }

    /// A command with a parameter.
    pub const fn set(command: AtCommand, parameter: Parameter<'a>) -> Self {
        Self { command, parameter }
    }
}

/// Longest command-mode line the driver builds or accepts, `\r` included. The longest line it
/// builds is `ATKY` + 32 hexadecimal digits + `\r` = 37 bytes.
pub const MAX_LINE_LEN: usize = 48;

/// Writes the command-mode text line `AT<cmd><param>\r` into `out`; returns its length.
///
/// Returns `None` if the parameter cannot be carried in command mode (text with a comma, a
/// carriage return or a non-printable byte) or the line does not fit `out`.
pub fn format_line(request: &AtRequest<'_>, out: &mut [u8]) -> Option<usize> {
    let mut n = 0;
    let mut put = |b: u8| -> Option<()> {
        *out.get_mut(n)? = b;
        n += 1;
        Some(())
    };
    put(b'A')?;
    put(b'T')?;
    put(request.command.0[0])?;
    put(request.command.0[1])?;
    match request.parameter {
        Parameter::None => {}
        Parameter::Number(value) => {
            let digits = if value == 0 {
                1
            } else {
                (64 - value.leading_zeros()).div_ceil(4)
            };
            for i in (0..digits).rev() {
                put(hex_digit((value >> (4 * i)) as u8))?;
            }
        }
        Parameter::Text(text) => {
            for &b in text {
                if !(b == b' ' || b.is_ascii_graphic()) || b == b',' {
                    return None;
                }
                put(b)?;
            }
        }
        Parameter::Bytes(bytes) => {
            for &b in bytes {
                put(hex_digit(b >> 4))?;
                put(hex_digit(b))?;
            }
        }
    }
    put(b'\r')?;
    Some(n)
}

const fn hex_digit(nibble: u8) -> u8 {
    let nibble = nibble & 0x0F;
    if nibble < 10 {
        b'0' + nibble
    } else {
        b'A' + nibble - 10
    }
}

/// Parses a command-mode reply holding a hexadecimal number (`7FFF`), as the module answers
/// numeric queries. Accepts 1 to 16 digits of either case; anything else gives `None`.
pub fn parse_hex(reply: &[u8]) -> Option<u64> {
    if reply.is_empty() || reply.len() > 16 {
        return None;
    }
    reply.iter().try_fold(0u64, |acc, &b| {
        let digit = (b as char).to_digit(16)?;
        Some((acc << 4) | u64::from(digit))
    })
}

/// Whether a reply line (without its `\r`) is the module's `OK`.
pub fn is_ok(reply: &[u8]) -> bool {
    reply == b"OK"
}

/// Whether a reply line (without its `\r`) is the module's `ERROR`.
pub fn is_error(reply: &[u8]) -> bool {
    reply == b"ERROR"
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(req: AtRequest<'_>) -> ([u8; MAX_LINE_LEN], usize) {
        let mut out = [0u8; MAX_LINE_LEN];
        let n = format_line(&req, &mut out).expect("fits");
        (out, n)
    }

    #[test]
    fn lines() {
        let (out, n) = line(AtRequest::query(AtCommand::NI));
        assert_eq!(&out[..n], b"ATNI\r");
        let (out, n) = line(AtRequest::set(AtCommand::ID, Parameter::Number(0x7FFF)));
        assert_eq!(&out[..n], b"ATID7FFF\r");
        let (out, n) = line(AtRequest::set(AtCommand::CH, Parameter::Number(0)));
        assert_eq!(&out[..n], b"ATCH0\r");
        let (out, n) = line(AtRequest::set(
            AtCommand::NI,
            Parameter::Text(b"DIMA ROBOT"),
        ));
        assert_eq!(&out[..n], b"ATNIDIMA ROBOT\r");
        let (out, n) = line(AtRequest::set(
            AtCommand::KY,
            Parameter::Bytes(&[0x01, 0xAB]),
        ));
        assert_eq!(&out[..n], b"ATKY01AB\r");
        let (out, n) = line(AtRequest::set(AtCommand::ID, Parameter::Number(u64::MAX)));
        assert_eq!(&out[..n], b"ATIDFFFFFFFFFFFFFFFF\r");
    }

    #[test]
    fn longest_line_fits() {
        let key = [0xFFu8; 16];
        let (_, n) = line(AtRequest::set(AtCommand::KY, Parameter::Bytes(&key)));
        assert_eq!(n, 37);
    }

    #[test]
    fn text_that_command_mode_cannot_carry_is_refused() {
        let mut out = [0u8; MAX_LINE_LEN];
        for bad in [&b"A,B"[..], b"A\rB", b"\x00"] {
            let req = AtRequest::set(AtCommand::NI, Parameter::Text(bad));
            assert_eq!(format_line(&req, &mut out), None);
        }
        let mut tiny = [0u8; 4];
        assert_eq!(
            format_line(&AtRequest::query(AtCommand::NI), &mut tiny),
            None
        );
    }

    #[test]
    fn command_names_are_pinned() {
        let pinned: [(AtCommand, &[u8; 2]); 24] = [
            (AtCommand::ID, b"ID"),
            (AtCommand::CH, b"CH"),
            (AtCommand::SC, b"SC"),
            (AtCommand::NI, b"NI"),
            (AtCommand::BD, b"BD"),
            (AtCommand::AP, b"AP"),
            (AtCommand::PL, b"PL"),
            (AtCommand::EE, b"EE"),
            (AtCommand::KY, b"KY"),
            (AtCommand::CE, b"CE"),
            (AtCommand::SM, b"SM"),
            (AtCommand::VR, b"VR"),
            (AtCommand::HV, b"HV"),
            (AtCommand::SH, b"SH"),
            (AtCommand::SL, b"SL"),
            (AtCommand::DH, b"DH"),
            (AtCommand::DL, b"DL"),
            (AtCommand::MY, b"MY"),
            (AtCommand::GT, b"GT"),
            (AtCommand::CT, b"CT"),
            (AtCommand::CC, b"CC"),
            (AtCommand::CN, b"CN"),
            (AtCommand::WR, b"WR"),
            (AtCommand::AC, b"AC"),
        ];
        for (command, name) in pinned {
            assert_eq!(&command.0, name);
        }
    }

    #[test]
    fn hex_replies() {
        assert_eq!(parse_hex(b"7FFF"), Some(0x7FFF));
        assert_eq!(parse_hex(b"c"), Some(0xC));
        assert_eq!(parse_hex(b"FFFFFFFFFFFFFFFF"), Some(u64::MAX));
        assert_eq!(parse_hex(b"10000000000000000"), None);
        assert_eq!(parse_hex(b""), None);
        assert_eq!(parse_hex(b"OK"), None);
        assert_eq!(parse_hex(b"12 3"), None);
    }

    #[test]
    fn api_bytes_are_minimal_big_endian() {
        let mut out = [0u8; 8];
        let n = Parameter::Number(0x7FFF).to_api_bytes(&mut out).unwrap();
        assert_eq!(&out[..n], &[0x7F, 0xFF]);
        let n = Parameter::Number(0).to_api_bytes(&mut out).unwrap();
        assert_eq!(&out[..n], &[0x00]);
        let n = Parameter::Number(u64::MAX).to_api_bytes(&mut out).unwrap();
        assert_eq!(n, 8);
        assert_eq!(Parameter::Text(b"ABC").to_api_bytes(&mut out[..2]), None);
    }
}
