//! Packet v1 layout, checked against bytes written by hand from the layout table (the v1 layout table in the crate docs)
//! and against golden vectors from datasheets and the Bosch SensorAPI.

use dima_sensorboard::crc32_bitwise;
use dima_sensorboard::{decode_adc20, encode_adc20};
use dima_sensorboard::{
    GnssFrame, PacketBuilder, PacketError, RawPacket, SensorPacket, Stm32Crc, PACKET_LEN,
};

/// A packet written byte by byte: every field chosen so that sign handling and the shifts
/// matter. The CRC is appended by the bitwise reference model.
fn hand_packet() -> [u8; PACKET_LEN] {
    let mut p = [0u8; PACKET_LEN];
    p[0] = 0x24;
    p[1] = 0x24;
    // accel X = +1000 (1000 << 4 = 0x3E80), Y = -1 (0xFFF0), Z = -2048 (0x8000); the low
    // nibble of each LSB is the masked status area.
    p[2..8].copy_from_slice(&[0x80, 0x3E, 0xF0, 0xFF, 0x00, 0x80]);
    // gyro X = 0x1234, Y = -2, Z = 32767
    p[8..14].copy_from_slice(&[0x34, 0x12, 0xFE, 0xFF, 0xFF, 0x7F]);
    // mag: BMM150 data registers 0x42..=0x49 `80 02 20 FE F4 FE 61 6D`
    // (Bosch SensorAPI vector: raw x 80, y -60, z -134, rhall 7000), with the data-ready bit
    // in the RHALL LSB (0x61) masked off by the board (0x61 & 0xFC = 0x60).
    p[14..22].copy_from_slice(&[0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x60, 0x6D]);
    // BMP280 registers 0xF7..=0xFC `65 5A C0 7E ED 00`
    // (datasheet example: adc_P 415148, adc_T 519888)
    p[22..28].copy_from_slice(&[0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00]);
    // GNSS area: zeros (no NAV-PVT yet).
    let crc = crc32_bitwise(&p[..128]);
    p[128..].copy_from_slice(&crc.to_le_bytes());
    p
}

#[test]
fn hand_written_packet_decodes_to_its_fields() {
    let bytes = hand_packet();
    let packet = SensorPacket::decode(&bytes).expect("valid packet");
    assert_eq!(packet.accel, [1000, -1, -2048]);
    assert_eq!(packet.gyro, [0x1234, -2, 32767]);
    assert_eq!(packet.mag, [80, -60, -134]);
    assert_eq!(packet.rhall, 7000);
    assert_eq!(packet.press_raw, 415_148);
    assert_eq!(packet.temp_raw, 519_888);
    assert_eq!(packet.gnss, GnssFrame::ABSENT);
    assert!(packet.nav_pvt().is_none());
}

#[test]
fn hand_written_packet_is_what_the_encoder_writes() {
    let packet = SensorPacket {
        accel: [1000, -1, -2048],
        gyro: [0x1234, -2, 32767],
        mag: [80, -60, -134],
        rhall: 7000,
        press_raw: 415_148,
        temp_raw: 519_888,
        gnss: GnssFrame::ABSENT,
    };
    assert_eq!(packet.encode(), hand_packet());
}

#[test]
fn register_setters_write_the_hand_written_packet() {
    let mut builder = PacketBuilder::new();
    builder
        // Accelerometer LSBs with the new-data bit set: masked off with 0xF0.
        .accel_registers([0x81, 0x3E, 0xF1, 0xFF, 0x01, 0x80])
        .gyro_registers([0x34, 0x12, 0xFE, 0xFF, 0xFF, 0x7F])
        // The Bosch SensorAPI registers verbatim (data-ready bit set in the RHALL LSB).
        .mag_registers([0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D])
        .bmp280_registers([0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00]);
    assert_eq!(builder.build(&mut Stm32Crc), &hand_packet());
    // Every status bit below the magnetometer values set: masked with 0xF8 / 0xFE / 0xFC.
    builder.mag_registers([0x87, 0x02, 0x27, 0xFE, 0xF5, 0xFE, 0x63, 0x6D]);
    assert_eq!(builder.build(&mut Stm32Crc), &hand_packet());
}

#[test]
fn crc_sits_little_endian_in_the_last_four_bytes() {
    // Golden vector (original DIMA board): bytes 0x00..=0x7F give 0x6557DE1A,
    // on the wire `1A DE 57 65`.
    let mut bytes = [0u8; PACKET_LEN];
    for (i, b) in bytes.iter_mut().take(128).enumerate() {
        *b = i as u8;
    }
    bytes[128..].copy_from_slice(&[0x1A, 0xDE, 0x57, 0x65]);
    let raw = RawPacket::new(bytes);
    // Bytes 0-1 are 00 01, not `$$`: the start token check comes first.
    assert_eq!(raw, Err(PacketError::StartToken));
    assert_eq!(crc32_bitwise(&bytes[..128]), 0x6557_DE1A);

    // With the start token written in, the CRC the decoder reports as computed must be the
    // bitwise model's, and the received one must be read little-endian.
    bytes[0] = 0x24;
    bytes[1] = 0x24;
    match RawPacket::new(bytes) {
        Err(PacketError::Checksum { computed, received }) => {
            assert_eq!(received, 0x6557_DE1A);
            assert_eq!(computed, crc32_bitwise(&bytes[..128]));
        }
        other => panic!("expected a checksum error, got {other:?}"),
    }
    let crc = crc32_bitwise(&bytes[..128]);
    bytes[128..].copy_from_slice(&crc.to_le_bytes());
    let raw = RawPacket::new(bytes).expect("valid");
    assert_eq!(raw.crc(), crc);
}

#[test]
fn ascending_bytes_decode_field_by_field() {
    // Bytes 0x00..=0x7F: each field's value follows from the layout table by hand.
    let mut bytes = [0u8; PACKET_LEN];
    for (i, b) in bytes.iter_mut().take(128).enumerate() {
        *b = i as u8;
    }
    let p = SensorPacket::decode_unchecked(&bytes);
    assert_eq!(p.accel, [0x0302 >> 4, 0x0504 >> 4, 0x0706 >> 4]);
    assert_eq!(p.accel, [48, 80, 112]);
    assert_eq!(p.gyro, [0x0908, 0x0B0A, 0x0D0C]);
    assert_eq!(p.mag, [0x0F0E >> 3, 0x1110 >> 3, 0x1312 >> 1]);
    assert_eq!(p.mag, [481, 546, 2441]);
    assert_eq!(p.rhall, 0x1514 >> 2);
    assert_eq!(p.press_raw, (0x16 << 12) | (0x17 << 4) | (0x18 >> 4));
    assert_eq!(p.press_raw, 90_481);
    assert_eq!(p.temp_raw, (0x19 << 12) | (0x1A << 4) | (0x1B >> 4));
    assert_eq!(p.gnss.as_bytes()[0], 28);
    assert_eq!(p.gnss.as_bytes()[99], 127);
    assert!(p.nav_pvt().is_none());
}

#[test]
fn negative_counts_keep_their_sign() {
    // The original decoder lost the sign of acc and mag (a defect this crate does not copy).
    let mut builder = PacketBuilder::new();
    builder
        .accel([-1, -2048, 2047])
        .mag([-4096, 4095, -16384], 0x3FFF);
    let p = RawPacket::new(*builder.build(&mut Stm32Crc))
        .expect("valid")
        .decode();
    assert_eq!(p.accel, [-1, -2048, 2047]);
    assert_eq!(p.mag, [-4096, 4095, -16384]);
    assert_eq!(p.rhall, 0x3FFF);
}

#[test]
fn out_of_range_counts_saturate() {
    let packet = SensorPacket {
        accel: [3000, -3000, 0],
        mag: [5000, -5000, 20000],
        rhall: u16::MAX,
        press_raw: u32::MAX,
        temp_raw: 0x10_0000,
        ..SensorPacket::default()
    };
    let p = SensorPacket::decode(&packet.encode()).expect("valid");
    assert_eq!(p.accel, [2047, -2048, 0]);
    assert_eq!(p.mag, [4095, -4096, 16383]);
    assert_eq!(p.rhall, 0x3FFF);
    assert_eq!(p.press_raw, 0xF_FFFF);
    assert_eq!(p.temp_raw, 0xF_FFFF);
}

#[test]
fn adc20_registers() {
    // BMP280 datasheet example: `65 5A C0` -> 415148, `7E ED 00` -> 519888.
    assert_eq!(decode_adc20([0x65, 0x5A, 0xC0]), 415_148);
    assert_eq!(decode_adc20([0x7E, 0xED, 0x00]), 519_888);
    assert_eq!(encode_adc20(415_148), [0x65, 0x5A, 0xC0]);
    assert_eq!(encode_adc20(519_888), [0x7E, 0xED, 0x00]);
}

#[test]
fn start_token_is_checked() {
    let mut bytes = hand_packet();
    bytes[1] = b'I';
    assert_eq!(SensorPacket::decode(&bytes), Err(PacketError::StartToken));
}
