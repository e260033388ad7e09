//! Golden vectors for the magnetometer trim decode and compensation.
//!
//! Source: Bosch's BMM150 SensorAPI, its integer and float compensation paths run on these trim
//! registers and raw values. Values copied verbatim.

// The expected values are kept exactly as published, digits and all.
#![allow(clippy::excessive_precision)]

use bosch_bmx055::mag::{compensate, compensate_f32, MagPacketWords, MagRaw, MagTrim};

// Trim bursts: 0x5D `00 00`; 0x62 `00 00 1A 1A`; 0x68 `FB 02 AB 60 8D 1B 00 00 FD 1D`.
const B1: [u8; 2] = [0x00, 0x00];
const B2: [u8; 4] = [0x00, 0x00, 0x1A, 0x1A];
const B3: [u8; 10] = [0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D];

fn trim() -> MagTrim {
    MagTrim::from_bursts(&B1, &B2, &B3)
}

#[test]
fn trim_decodes_with_bosch_types() {
    // -> x1 0, y1 0, z4 0, x2 26, y2 26, z2 763, z1 24747, xyz1 7053, z3 0, xy2 -3, xy1 29.
    let t = trim();
    assert_eq!(t.dig_x1, 0);
    assert_eq!(t.dig_y1, 0);
    assert_eq!(t.dig_z4, 0);
    assert_eq!(t.dig_x2, 26);
    assert_eq!(t.dig_y2, 26);
    assert_eq!(t.dig_z2, 763);
    assert_eq!(t.dig_z1, 24747);
    assert_eq!(t.dig_xyz1, 7053);
    assert_eq!(t.dig_z3, 0);
    assert_eq!(t.dig_xy2, -3);
    assert_eq!(t.dig_xy1, 29);
}

#[test]
fn trim_round_trips_through_bursts() {
    let (b1, b2, b3) = trim().to_bursts();
    assert_eq!((b1, b2, b3), (B1, B2, B3));
}

#[test]
fn xyz1_is_masked_to_15_bits() {
    let mut b3 = B3;
    b3[5] |= 0x80;
    assert_eq!(MagTrim::from_bursts(&B1, &B2, &b3).dig_xyz1, 7053);
}

struct Row {
    data: [u8; 8],
    raw: (i16, i16, i16, u16),
    int_ut: (i16, i16, i16),
    float_ut: (f32, f32, f32),
}

const ROWS: [Row; 3] = [
    Row {
        data: [0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D],
        raw: (80, -60, -134, 7000),
        int_ut: (29, -21, -45),
        float_ut: (29.0874, -21.8156, -45.3642),
    },
    Row {
        data: [0x68, 0x0A, 0x30, 0xF8, 0x45, 0xDC, 0x35, 0x6E],
        raw: (333, -250, -4574, 7053),
        int_ut: (120, -90, -1538),
        float_ut: (120.9727, -90.8203, -1538.2980),
    },
    // overflow
    Row {
        data: [0x00, 0x80, 0x00, 0x80, 0x00, 0xC0, 0x34, 0x6E],
        raw: (-4096, -4096, -8192, 7053),
        int_ut: (-32768, -32768, -2047),
        float_ut: (0.0, 0.0, -2755.0803),
    },
];

#[test]
fn data_registers_decode_to_raw() {
    for row in &ROWS {
        let raw = MagRaw::from_registers(&row.data);
        assert_eq!((raw.x, raw.y, raw.z, raw.rhall), row.raw);
    }
}

#[test]
fn packet_words_decode_to_the_same_raw() {
    for row in &ROWS {
        let raw = MagPacketWords::from_registers(&row.data).to_raw();
        assert_eq!((raw.x, raw.y, raw.z, raw.rhall), row.raw);
    }
}

#[test]
fn integer_compensation_matches_bosch() {
    for row in &ROWS {
        let raw = MagRaw::from_registers(&row.data);
        let ut = compensate(&raw, &trim());
        assert_eq!((ut.x, ut.y, ut.z), row.int_ut, "row {:02X?}", row.data);
    }
}

#[test]
fn float_compensation_matches_bosch() {
    for row in &ROWS {
        let raw = MagRaw::from_registers(&row.data);
        let ut = compensate_f32(&raw, &trim());
        let (x, y, z) = row.float_ut;
        for (got, want) in [(ut.x, x), (ut.y, y), (ut.z, z)] {
            assert!(
                (got - want).abs() < 1e-3,
                "got {got}, want {want} for {:02X?}",
                row.data
            );
        }
    }
}

#[test]
fn overflow_row_is_flagged() {
    assert!(MagRaw::from_registers(&ROWS[2].data).is_overflow());
    assert!(!MagRaw::from_registers(&ROWS[0].data).is_overflow());
}
