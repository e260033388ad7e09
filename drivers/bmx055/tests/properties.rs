//! Property tests: decoders and compensation are total, and the simulator inverses round-trip.

use bosch_bmx055::accel::{accel_mg_to_word, accel_word_to_mg, AccelRange, AccelRaw};
use bosch_bmx055::gyro::{gyro_dps_to_word, gyro_word_to_dps, GyroRange};
use bosch_bmx055::mag::{compensate, compensate_f32, MagPacketWords, MagRaw, MagTrim};
// The inverse compensation is the simulator's, behind the `sim` feature.
#[cfg(feature = "sim")]
use bosch_bmx055::mag::{
    compensate_x_f32, compensate_y_f32, compensate_z_f32, raw_x_for_ut, raw_y_for_ut, raw_z_for_ut,
};
use proptest::prelude::*;

fn any_trim() -> impl Strategy<Value = MagTrim> {
    (any::<[u8; 2]>(), any::<[u8; 4]>(), any::<[u8; 10]>())
        .prop_map(|(a, b, c)| MagTrim::from_bursts(&a, &b, &c))
}

/// Trim in the neighbourhood real parts ship with (vector trim +- spread).
#[cfg(feature = "sim")]
fn plausible_trim() -> impl Strategy<Value = MagTrim> {
    (
        -10i8..10,
        -10i8..10,
        10i8..40,
        10i8..40,
        20000u16..30000,
        500i16..1000,
        -100i16..100,
        -100i16..100,
        0u8..60,
        -10i8..10,
        6000u16..8000,
    )
        .prop_map(|(x1, y1, x2, y2, z1, z2, z3, z4, xy1, xy2, xyz1)| MagTrim {
            dig_x1: x1,
            dig_y1: y1,
            dig_x2: x2,
            dig_y2: y2,
            dig_z1: z1,
            dig_z2: z2,
            dig_z3: z3,
            dig_z4: z4,
            dig_xy1: xy1,
            dig_xy2: xy2,
            dig_xyz1: xyz1,
        })
}

proptest! {
    #[test]
    fn compensation_never_panics(trim in any_trim(), x: i16, y: i16, z: i16, rhall: u16) {
        let raw = MagRaw { x, y, z, rhall, data_ready: true };
        let _ = compensate(&raw, &trim);
        let _ = compensate_f32(&raw, &trim);
    }

    #[test]
    fn register_decoders_never_panic(b: [u8; 8], a: [u8; 6]) {
        let raw = MagRaw::from_registers(&b);
        prop_assert!((-4096..=4095).contains(&raw.x));
        prop_assert!((-16384..=16383).contains(&raw.z));
        prop_assert!(raw.rhall < 1 << 14);
        prop_assert_eq!(raw.packet_words(), MagPacketWords::from_registers(&b));
        let acc = AccelRaw::from_registers(&a);
        prop_assert_eq!(acc.words.x & 0x0F, 0);
    }

    #[test]
    fn accel_word_round_trips(counts in -2048i16..=2047, r in 0usize..4) {
        let range = [AccelRange::G2, AccelRange::G4, AccelRange::G8, AccelRange::G16][r];
        let word = counts << 4;
        prop_assert_eq!(accel_mg_to_word(accel_word_to_mg(word, range), range), word);
    }

    #[test]
    fn accel_mg_to_word_is_nearest_and_saturates(mg in -40000f32..40000f32) {
        let range = AccelRange::G2;
        let word = accel_mg_to_word(mg, range);
        prop_assert_eq!(word & 0x0F, 0);
        let back = accel_word_to_mg(word, range);
        let lsb = range.mg_per_count();
        prop_assert!((back - mg).abs() <= lsb / 2.0 + 1e-3 || word == 2047 << 4 || word == -2048 << 4);
    }

    #[test]
    fn gyro_word_round_trips(word: i16, r in 0usize..5) {
        let range = [GyroRange::Dps2000, GyroRange::Dps1000, GyroRange::Dps500,
                     GyroRange::Dps250, GyroRange::Dps125][r];
        prop_assert_eq!(gyro_dps_to_word(gyro_word_to_dps(word, range), range), word);
    }

    #[cfg(feature = "sim")]
    #[test]
    fn mag_inverse_finds_the_raw_value(trim in plausible_trim(), rhall in 6000u16..8000,
                                       x in -4095i16..=4095, z in -16383i16..=16383) {
        let tx = compensate_x_f32(x, rhall, &trim);
        let rx = raw_x_for_ut(tx, rhall, &trim).unwrap();
        prop_assert!((compensate_x_f32(rx, rhall, &trim) - tx).abs() <= 1e-3 * tx.abs().max(1.0));
        let ty = compensate_y_f32(x, rhall, &trim);
        let ry = raw_y_for_ut(ty, rhall, &trim).unwrap();
        prop_assert!((compensate_y_f32(ry, rhall, &trim) - ty).abs() <= 1e-3 * ty.abs().max(1.0));
        let tz = compensate_z_f32(z, rhall, &trim);
        let rz = raw_z_for_ut(tz, rhall, &trim).unwrap();
        prop_assert!((compensate_z_f32(rz, rhall, &trim) - tz).abs() <= 1e-3 * tz.abs().max(1.0));
    }

    #[cfg(feature = "sim")]
    #[test]
    fn mag_inverse_is_closest(trim in plausible_trim(), rhall in 6000u16..8000,
                              target in -3000f32..3000f32) {
        let f = |r: i16| compensate_z_f32(r, rhall, &trim);
        let r = raw_z_for_ut(target, rhall, &trim).unwrap();
        let err = (f(r) - target).abs();
        for n in [r.saturating_sub(1).max(-16383), r.saturating_add(1).min(16383)] {
            prop_assert!(err <= (f(n) - target).abs() + 1e-3);
        }
        let g = |r: i16| compensate_x_f32(r, rhall, &trim);
        let r = raw_x_for_ut(target / 4.0, rhall, &trim).unwrap();
        let err = (g(r) - target / 4.0).abs();
        for n in [r.saturating_sub(1).max(-4095), r.saturating_add(1).min(4095)] {
            prop_assert!(err <= (g(n) - target / 4.0).abs() + 1e-3);
        }
    }

    #[cfg(feature = "sim")]
    #[test]
    fn mag_inverse_never_panics(trim in any_trim(), rhall: u16, t in proptest::num::f32::ANY) {
        let _ = raw_x_for_ut(t, rhall, &trim);
        let _ = raw_y_for_ut(t, rhall, &trim);
        let _ = raw_z_for_ut(t, rhall, &trim);
    }
}

#[cfg(feature = "sim")]
#[test]
fn mag_inverse_rejects_uninvertible_inputs() {
    let trim = MagTrim::default();
    assert_eq!(raw_x_for_ut(10.0, 7000, &trim), None);
    assert_eq!(raw_z_for_ut(10.0, 0, &trim), None);
}

#[cfg(feature = "sim")]
#[test]
fn mag_inverse_hits_the_vector_sample() {
    // Trim and sample from the shared BMM150 vectors (Bosch SensorAPI): raw 333, -250, -4574 at
    // rhall 7053 compensates to 120.9727, -90.8203, -1538.2980 µT.
    let trim = MagTrim::from_bursts(
        &[0x00, 0x00],
        &[0x00, 0x00, 0x1A, 0x1A],
        &[0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D],
    );
    assert_eq!(raw_x_for_ut(120.9727, 7053, &trim), Some(333));
    assert_eq!(raw_y_for_ut(-90.8203, 7053, &trim), Some(-250));
    assert_eq!(raw_z_for_ut(-1538.298, 7053, &trim), Some(-4574));
    // Beyond the axis' reach: the end of the raw range, never the overflow code.
    assert_eq!(raw_x_for_ut(-1e6, 7053, &trim), Some(-4095));
}
