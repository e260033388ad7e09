//! The GNSS area: a NAV-PVT frame written by hand from the u-blox M8 protocol specification
//! (UBX-NAV-PVT, class 0x01, id 0x07, 92-byte payload, 8-bit Fletcher checksum over class,
//! id, length and payload), carried in the packet's GNSS area, read back through the
//! packet codec and cross-checked with the `ublox` crate's floating-point accessors.

use dima_sensorboard::nav_pvt::{FLAG_GNSS_FIX_OK, VALID_DATE, VALID_FULLY_RESOLVED, VALID_TIME};
use dima_sensorboard::{FixType, GnssFrame, NavPvt, PacketBuilder, SensorPacket, Stm32Crc};
use ublox::proto23::{PacketRef, Proto23};
use ublox::{FixedBuffer, GnssFixType, Parser, UbxPacket};

/// Writes little-endian values at the payload offsets of the specification.
struct Payload([u8; 92]);

impl Payload {
    fn at(&mut self, offset: usize, bytes: &[u8]) -> &mut Self {
        self.0[offset..offset + bytes.len()].copy_from_slice(bytes);
        self
    }
}

/// The Fletcher checksum of the specification, written out independently of the crates.
fn fletcher(bytes: &[u8]) -> [u8; 2] {
    let mut a: u32 = 0;
    let mut b: u32 = 0;
    for &byte in bytes {
        a = (a + u32::from(byte)) % 256;
        b = (b + a) % 256;
    }
    [a as u8, b as u8]
}

fn hand_frame() -> [u8; 100] {
    let mut p = Payload([0; 92]);
    p.at(0, &123_456_000u32.to_le_bytes()) // iTOW, ms
        .at(4, &2026u16.to_le_bytes()) // year
        .at(6, &[11, 22, 7, 30, 15]) // month, day, hour, min, sec
        .at(11, &[0x07]) // valid: date, time, fully resolved
        .at(12, &25u32.to_le_bytes()) // tAcc, ns
        .at(16, &(-12_345i32).to_le_bytes()) // nano, ns
        .at(20, &[3, 0x01, 0xE0, 11]) // fixType 3D, flags gnssFixOK, flags2, numSV
        .at(24, &85_465_123i32.to_le_bytes()) // lon, 1e-7 deg
        .at(28, &473_976_543i32.to_le_bytes()) // lat, 1e-7 deg
        .at(32, &508_123i32.to_le_bytes()) // height, mm
        .at(36, &460_456i32.to_le_bytes()) // hMSL, mm
        .at(40, &1_234u32.to_le_bytes()) // hAcc, mm
        .at(44, &2_345u32.to_le_bytes()) // vAcc, mm
        .at(48, &(-1_500i32).to_le_bytes()) // velN, mm/s
        .at(52, &2_500i32.to_le_bytes()) // velE, mm/s
        .at(56, &100i32.to_le_bytes()) // velD, mm/s
        .at(60, &2_915i32.to_le_bytes()) // gSpeed, mm/s
        .at(64, &12_345_678i32.to_le_bytes()) // headMot, 1e-5 deg
        .at(68, &150u32.to_le_bytes()) // sAcc, mm/s
        .at(72, &2_500_000u32.to_le_bytes()) // headAcc, 1e-5 deg
        .at(76, &135u16.to_le_bytes()) // pDOP, 0.01
        .at(78, &[0x00]) // flags3; 79..=83 reserved
        .at(84, &(-4_200_000i32).to_le_bytes()) // headVeh, 1e-5 deg
        .at(88, &(-250i16).to_le_bytes()) // magDec, 0.01 deg
        .at(90, &75u16.to_le_bytes()); // magAcc, 0.01 deg
    let mut frame = [0u8; 100];
    frame[..6].copy_from_slice(&[0xB5, 0x62, 0x01, 0x07, 92, 0]);
    frame[6..98].copy_from_slice(&p.0);
    let ck = fletcher(&frame[2..98]);
    frame[98..].copy_from_slice(&ck);
    frame
}

fn expected() -> NavPvt {
    NavPvt {
        itow_ms: 123_456_000,
        year: 2026,
        month: 11,
        day: 22,
        hour: 7,
        min: 30,
        sec: 15,
        valid: VALID_DATE | VALID_TIME | VALID_FULLY_RESOLVED,
        t_acc_ns: 25,
        nano_ns: -12_345,
        fix_type: 3,
        flags: FLAG_GNSS_FIX_OK,
        flags2: 0xE0,
        num_sv: 11,
        lon_deg_e7: 85_465_123,
        lat_deg_e7: 473_976_543,
        height_mm: 508_123,
        h_msl_mm: 460_456,
        h_acc_mm: 1_234,
        v_acc_mm: 2_345,
        vel_n_mm_s: -1_500,
        vel_e_mm_s: 2_500,
        vel_d_mm_s: 100,
        g_speed_mm_s: 2_915,
        head_mot_deg_e5: 12_345_678,
        s_acc_mm_s: 150,
        head_acc_deg_e5: 2_500_000,
        p_dop_e2: 135,
        reserved1: [0; 6],
        head_veh_deg_e5: -4_200_000,
        mag_dec_deg_e2: -250,
        mag_acc_deg_e2: 75,
    }
}

#[test]
fn hand_frame_parses_to_its_fields() {
    let pvt = GnssFrame::from_bytes(hand_frame())
        .nav_pvt()
        .expect("valid NAV-PVT");
    assert_eq!(pvt, expected());
    assert_eq!(pvt.fix(), FixType::Fix3D);
    assert!(pvt.gnss_fix_ok());
    assert!((pvt.lat_deg() - 47.397_654_3).abs() < 1e-9);
    assert!((pvt.lon_deg() - 8.546_512_3).abs() < 1e-9);
    assert!((pvt.head_mot_deg() - 123.456_78).abs() < 1e-9);
}

#[test]
fn encoder_writes_the_hand_frame() {
    assert_eq!(expected().to_frame().as_bytes(), &hand_frame());
    assert_eq!(
        GnssFrame::from_nav_pvt(&expected()).as_bytes(),
        &hand_frame()
    );
}

#[test]
fn ublox_crate_reads_the_same_values() {
    let frame = hand_frame();
    let mut parser = Parser::<FixedBuffer<128>, Proto23>::with_fixed_buffer();
    let mut it = parser.consume_ubx(&frame);
    let Some(Ok(UbxPacket::Proto23(PacketRef::NavPvt(pvt)))) = it.next() else {
        panic!("the ublox crate did not parse the hand-built frame");
    };
    let ours = expected();
    assert_eq!(pvt.itow(), ours.itow_ms);
    assert_eq!(pvt.fix_type(), GnssFixType::Fix3D);
    assert_eq!(pvt.num_satellites(), ours.num_sv);
    assert!((pvt.latitude() - ours.lat_deg()).abs() < 1e-12);
    assert!((pvt.longitude() - ours.lon_deg()).abs() < 1e-12);
    assert!((pvt.height_msl() - 460.456).abs() < 1e-9);
    assert!((pvt.vel_north() - -1.5).abs() < 1e-9);
    assert!((pvt.ground_speed_2d() - 2.915).abs() < 1e-9);
    assert!((pvt.heading_motion() - 123.456_78).abs() < 1e-9);
    assert!((pvt.pdop() - 1.35).abs() < 1e-9);
}

#[test]
fn absent_when_zero_or_damaged() {
    assert!(GnssFrame::from_bytes([0; 100]).nav_pvt().is_none());
    assert!(GnssFrame::ABSENT.nav_pvt().is_none());
    assert!(GnssFrame::ABSENT.is_zero());

    let mut bad = hand_frame();
    bad[99] ^= 0x01; // CK_B
    assert!(GnssFrame::from_bytes(bad).nav_pvt().is_none());

    let mut bad = hand_frame();
    bad[40] ^= 0x10; // payload byte
    assert!(GnssFrame::from_bytes(bad).nav_pvt().is_none());

    // A well-formed frame of another message (NAV-POSLLH id, same length) is not NAV-PVT.
    let mut other = hand_frame();
    other[3] = 0x02;
    let ck = fletcher(&other[2..98]);
    other[98..].copy_from_slice(&ck);
    assert!(GnssFrame::from_bytes(other).nav_pvt().is_none());
}

#[test]
fn every_bit_flip_makes_gnss_absent() {
    let frame = hand_frame();
    for bit in 0..frame.len() * 8 {
        let mut bad = frame;
        bad[bit / 8] ^= 1 << (bit % 8);
        assert!(
            GnssFrame::from_bytes(bad).nav_pvt().is_none(),
            "bit {bit} not detected"
        );
    }
}

#[test]
fn packet_with_damaged_gnss_still_decodes() {
    let mut bad = hand_frame();
    bad[50] ^= 0xFF;
    let mut builder = PacketBuilder::new();
    builder.gyro([1, 2, 3]).gnss_frame(&bad);
    let packet = SensorPacket::decode(builder.build(&mut Stm32Crc)).expect("packet CRC is fine");
    assert_eq!(packet.gyro, [1, 2, 3]);
    assert!(packet.nav_pvt().is_none());
    // The bytes are kept as they came, for logs and replay.
    assert_eq!(packet.gnss.as_bytes(), &bad);
}

#[test]
fn packet_carries_the_frame_verbatim() {
    let mut builder = PacketBuilder::new();
    builder.gnss_frame(&hand_frame());
    let bytes = *builder.build(&mut Stm32Crc);
    assert_eq!(&bytes[28..128], &hand_frame());
    let packet = SensorPacket::decode(&bytes).expect("valid");
    assert_eq!(packet.nav_pvt(), Some(expected()));
    assert_eq!(packet.gnss.into_bytes(), hand_frame());
    assert_eq!(packet.encode(), bytes);
}

/// NAV-PVT serialised by pyubx2 1.4.0 (`UBXMessage("NAV", "NAV-PVT", GET, iTOW=28548000,
/// year=2026, month=11, day=22, hour=7, min=55, second=30, validDate=1, validTime=1,
/// fullyResolved=1, tAcc=21, nano=-12345, fixType=3, gnssFixOk=1, confirmedAvai=1,
/// confirmedDate=1, confirmedTime=1, numSV=11, lon=8.5417, lat=47.3769, height=470123,
/// hMSL=422456, hAcc=1800, vAcc=2700, velN=1234, velE=-5678, velD=90, gSpeed=5810,
/// headMot=282.27, sAcc=350, headAcc=1.5, pDOP=1.32, headVeh=282.27).serialize()`), copied
/// verbatim. pyubx2 truncates the scaled 282.27 deg to 28226999 (1e-5 deg).
const PYUBX2_NAV_PVT: [u8; 100] = [
    0xB5, 0x62, 0x01, 0x07, 0x5C, 0x00, 0xA0, 0x9B, 0xB3, 0x01, 0xEA, 0x07, 0x0B, 0x16, 0x07, 0x37,
    0x1E, 0x07, 0x15, 0x00, 0x00, 0x00, 0xC7, 0xCF, 0xFF, 0xFF, 0x03, 0x01, 0xE0, 0x0B, 0x28, 0x5C,
    0x17, 0x05, 0x28, 0x24, 0x3D, 0x1C, 0x6B, 0x2C, 0x07, 0x00, 0x38, 0x72, 0x06, 0x00, 0x08, 0x07,
    0x00, 0x00, 0x8C, 0x0A, 0x00, 0x00, 0xD2, 0x04, 0x00, 0x00, 0xD2, 0xE9, 0xFF, 0xFF, 0x5A, 0x00,
    0x00, 0x00, 0xB2, 0x16, 0x00, 0x00, 0xB7, 0xB5, 0xAE, 0x01, 0x5E, 0x01, 0x00, 0x00, 0xF0, 0x49,
    0x02, 0x00, 0x84, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xB7, 0xB5, 0xAE, 0x01, 0x00, 0x00,
    0x00, 0x00, 0x9D, 0x06,
];

#[test]
fn pyubx2_frame_in_packet_bytes_28_to_127_decodes_to_its_fields() {
    // An independent serialiser's frame at the packet offsets of the v1 layout, through the
    // whole packet codec.
    let mut bytes = [0u8; 132];
    bytes[..2].copy_from_slice(b"$$");
    bytes[28..128].copy_from_slice(&PYUBX2_NAV_PVT);
    let crc = dima_sensorboard::crc32_bitwise(&bytes[..128]);
    bytes[128..].copy_from_slice(&crc.to_le_bytes());
    let pvt = SensorPacket::decode(&bytes)
        .expect("valid packet")
        .nav_pvt()
        .expect("valid NAV-PVT");
    // The values pyubx2 was given.
    assert_eq!(pvt.itow_ms, 28_548_000);
    assert_eq!((pvt.year, pvt.month, pvt.day), (2026, 11, 22));
    assert_eq!((pvt.hour, pvt.min, pvt.sec), (7, 55, 30));
    assert_eq!(pvt.fix(), FixType::Fix3D);
    assert!(pvt.gnss_fix_ok());
    assert_eq!(pvt.num_sv, 11);
    assert_eq!((pvt.lat_deg_e7, pvt.lon_deg_e7), (473_769_000, 85_417_000));
    assert_eq!((pvt.height_mm, pvt.h_msl_mm), (470_123, 422_456));
    assert_eq!(
        (pvt.vel_n_mm_s, pvt.vel_e_mm_s, pvt.vel_d_mm_s),
        (1_234, -5_678, 90)
    );
    assert_eq!(pvt.g_speed_mm_s, 5_810);
    assert_eq!(pvt.head_mot_deg_e5, 28_226_999);
    assert_eq!(pvt.p_dop_e2, 132);
    // And the encoder writes pyubx2's bytes back.
    assert_eq!(pvt.to_frame().as_bytes(), &PYUBX2_NAV_PVT);
}
