//! The ground link's checksum: CRC-32/ISO-HDLC (zlib, RFC 1952), as the original ground station
//! computes it with `java.util.zip.CRC32`.

use crc::{Crc, CRC_32_ISO_HDLC};

const ISO_HDLC: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes` (check value over `123456789`: `0xCBF43926`).
pub fn crc32(bytes: &[u8]) -> u32 {
    ISO_HDLC.checksum(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_value_of_the_catalogue() {
        // Catalogue of parametrised CRC algorithms, CRC-32/ISO-HDLC "check".
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }
}
