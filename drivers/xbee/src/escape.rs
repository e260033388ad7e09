//! API 2 byte escaping (`AP = 2`), pure functions without I/O.
//!
//! After the start delimiter, every 0x7E, 0x7D, 0x11 (XON) and 0x13 (XOFF) of the length,
//! frame data and checksum is sent as [`ESCAPE`] followed by the byte XOR [`ESCAPE_XOR`]. The
//! length and checksum are computed on the unescaped bytes.

/// Start delimiter of every API frame.
pub const START_DELIMITER: u8 = 0x7E;
/// Escape marker of API 2.
pub const ESCAPE: u8 = 0x7D;
/// Software flow control "resume" byte, escaped in API 2.
pub const XON: u8 = 0x11;
/// Software flow control "pause" byte, escaped in API 2.
pub const XOFF: u8 = 0x13;
/// An escaped byte is sent XOR this value.
pub const ESCAPE_XOR: u8 = 0x20;

/// Whether `byte` must be escaped in API 2.
pub const fn needs_escape(byte: u8) -> bool {
    matches!(byte, START_DELIMITER | ESCAPE | XON | XOFF)
}

/// Errors of the slice escaping functions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EscapeError {
    /// The output slice is too short.
    BufferTooSmall,
    /// The input ends with a lone escape byte.
    DanglingEscape,
}

/// Escapes `input` into `out`; returns the number of bytes written (between `input.len()` and
/// twice that).
pub fn escape(input: &[u8], out: &mut [u8]) -> Result<usize, EscapeError> {
    let mut n = 0;
    for &byte in input {
        if needs_escape(byte) {
            put(out, &mut n, ESCAPE)?;
            put(out, &mut n, byte ^ ESCAPE_XOR)?;
        } else {
            put(out, &mut n, byte)?;
        }
    }
    Ok(n)
}

/// Reverses [`escape`]: returns the number of bytes written to `out` (at most `input.len()`).
pub fn unescape(input: &[u8], out: &mut [u8]) -> Result<usize, EscapeError> {
    let mut n = 0;
    let mut bytes = input.iter();
    while let Some(&byte) = bytes.next() {
        let value = if byte == ESCAPE {
            match bytes.next() {
                Some(&next) => next ^ ESCAPE_XOR,
                None => return Err(EscapeError::DanglingEscape),
            }
        } else {
            byte
        };
        put(out, &mut n, value)?;
    }
    Ok(n)
}

fn put(out: &mut [u8], n: &mut usize, byte: u8) -> Result<(), EscapeError> {
    let slot = out.get_mut(*n).ok_or(EscapeError::BufferTooSmall)?;
    *slot = byte;
    *n += 1;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaped_set_is_exactly_four_bytes() {
        let escaped: usize = (0..=255u8).filter(|&b| needs_escape(b)).count();
        assert_eq!(escaped, 4);
        for b in [0x7E, 0x7D, 0x11, 0x13] {
            assert!(needs_escape(b));
        }
    }

    #[test]
    fn escape_example_from_digi() {
        // 0x13 -> 7D 33, 0x7D -> 7D 5D (see the receive-packet vector).
        let mut out = [0u8; 8];
        let n = escape(&[0x00, 0x13, 0x7D, 0x84], &mut out).unwrap();
        assert_eq!(&out[..n], &[0x00, 0x7D, 0x33, 0x7D, 0x5D, 0x84]);
    }

    #[test]
    fn errors() {
        let mut out = [0u8; 1];
        assert_eq!(escape(&[0x7E], &mut out), Err(EscapeError::BufferTooSmall));
        assert_eq!(
            unescape(&[0x7D], &mut out),
            Err(EscapeError::DanglingEscape)
        );
    }
}
