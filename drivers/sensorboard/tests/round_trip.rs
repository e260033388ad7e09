//! Property tests: encode/decode round trips and total decoders.

mod common;

use dima_sensorboard::crc32_bitwise;
use dima_sensorboard::{GnssFrame, RawPacket, SensorPacket, PACKET_LEN};
use proptest::prelude::*;

fn array<const N: usize>(v: &[u8]) -> [u8; N] {
    let mut out = [0u8; N];
    out.copy_from_slice(v);
    out
}

proptest! {
    #[test]
    fn packet_encode_decode(p in common::sensor_packet()) {
        let bytes = p.encode();
        prop_assert_eq!(&bytes[..2], b"$$");
        prop_assert_eq!(
            crc32_bitwise(&bytes[..128]).to_le_bytes(),
            [bytes[128], bytes[129], bytes[130], bytes[131]]
        );
        prop_assert_eq!(SensorPacket::decode(&bytes), Ok(p));
        prop_assert_eq!(RawPacket::new(bytes).map(|r| r.decode()), Ok(p));
    }

    #[test]
    fn canonical_bytes_survive_decode_encode(p in common::sensor_packet()) {
        // Bytes written by the encoder come back unchanged after a decode.
        let bytes = p.encode();
        let again = SensorPacket::decode(&bytes).map(|q| q.encode());
        prop_assert_eq!(again, Ok(bytes));
    }

    #[test]
    fn nav_pvt_frame_round_trip(payload in proptest::collection::vec(any::<u8>(), 92)) {
        let frame = common::nav_pvt_frame(array(&payload));
        // Every payload byte, reserved ones included, survives decode and encode.
        let pvt = GnssFrame::from_bytes(frame).nav_pvt();
        prop_assert!(pvt.is_some());
        prop_assert_eq!(pvt.map(|p| *p.to_frame().as_bytes()), Some(frame));
    }

    #[test]
    fn decode_is_total(bytes in proptest::collection::vec(any::<u8>(), PACKET_LEN)) {
        let mut bytes: [u8; PACKET_LEN] = array(&bytes);
        let _ = SensorPacket::decode(&bytes);
        let _ = SensorPacket::decode_unchecked(&bytes).nav_pvt();
        // With a matching start token and CRC, any contents decode.
        bytes[0] = b'$';
        bytes[1] = b'$';
        let crc = crc32_bitwise(&bytes[..128]);
        bytes[128..].copy_from_slice(&crc.to_le_bytes());
        prop_assert!(SensorPacket::decode(&bytes).is_ok());
    }

    #[test]
    fn nav_pvt_parse_is_total(bytes in proptest::collection::vec(any::<u8>(), 100)) {
        let mut frame: [u8; 100] = array(&bytes);
        let _ = GnssFrame::from_bytes(frame).nav_pvt();
        frame[..6].copy_from_slice(&[0xB5, 0x62, 0x01, 0x07, 92, 0]);
        let _ = GnssFrame::from_bytes(frame).nav_pvt();
    }
}
