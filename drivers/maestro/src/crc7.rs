//! The Maestro's CRC-7: generator x⁷ + x³ + 1, message bits LSB first, initial value 0.
//!
//! The Pololu guide describes it as the polynomial 0x91 applied LSB first; in Rocksoft terms
//! that is width 7, poly 0x09, reflected in and out, no final XOR. When CRC mode is enabled in the
//! Maestro, this byte follows every compact and Pololu protocol packet (never Mini SSC).

use crc::{Algorithm, Crc};

/// The Maestro CRC-7 parameters for the [`crc`] crate.
pub const MAESTRO_CRC7: Algorithm<u8> = Algorithm {
    width: 7,
    poly: 0x09,
    init: 0x00,
    refin: true,
    refout: true,
    xorout: 0x00,
    check: 0x25,
    residue: 0x00,
};

const CRC7: Crc<u8> = Crc::<u8>::new(&MAESTRO_CRC7);

/// The CRC-7 of `bytes` (always `< 0x80`, so it is a valid data byte).
pub fn crc7(bytes: &[u8]) -> u8 {
    CRC7.checksum(bytes)
}
