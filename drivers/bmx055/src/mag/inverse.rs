//! Best-effort inverse of the float compensation, for simulators that must produce raw
//! magnetometer words from a field in µT.
//!
//! For a fixed trim and Hall resistance, Bosch's float compensation is affine in the raw
//! value of each axis (X: `raw · k + c`, Z: `(raw − z4) · k − c`), so it is monotonic and
//! bisection finds the raw value whose compensation is closest to the target in at most
//! [`MAX_BISECTION_STEPS`] steps. Limits:
//! - the result is quantised: one raw step is about 0.35 µT on every axis with typical
//!   trim (0.36 µT on X and 0.34 µT on Z with the trim of Bosch's example), so the best match
//!   can be off by half a step;
//! - a target outside what the axis can express gives the end of the raw range (±4095 on X/Y,
//!   ±16383 on Z; the overflow codes -4096 / -16384 are never produced);
//! - `None` when the compensation cannot be inverted: `rhall` is 0, required trim is 0, the
//!   slope is 0 (all raw values compensate alike), or the values are not finite;
//! - it inverts the float path; the integer path truncates, so its result may differ by 1 µT.

use super::compensation::{compensate_x_f32, compensate_y_f32, compensate_z_f32};
use super::trim::MagTrim;
use crate::maths::abs;

/// Upper bound on bisection steps (the 15-bit Z range needs 15).
pub const MAX_BISECTION_STEPS: u32 = 16;

/// Raw X (13-bit, -4095..=4095) whose float compensation is closest to `target_ut`.
pub fn raw_x_for_ut(target_ut: f32, rhall: u16, trim: &MagTrim) -> Option<i16> {
    if rhall == 0 || trim.dig_xyz1 == 0 {
        return None;
    }
    closest(-4095, 4095, target_ut, |r| compensate_x_f32(r, rhall, trim))
}

/// Raw Y (13-bit, -4095..=4095) whose float compensation is closest to `target_ut`.
pub fn raw_y_for_ut(target_ut: f32, rhall: u16, trim: &MagTrim) -> Option<i16> {
    if rhall == 0 || trim.dig_xyz1 == 0 {
        return None;
    }
    closest(-4095, 4095, target_ut, |r| compensate_y_f32(r, rhall, trim))
}

/// Raw Z (15-bit, -16383..=16383) whose float compensation is closest to `target_ut`.
pub fn raw_z_for_ut(target_ut: f32, rhall: u16, trim: &MagTrim) -> Option<i16> {
    if rhall == 0 || trim.dig_xyz1 == 0 || trim.dig_z1 == 0 || trim.dig_z2 == 0 {
        return None;
    }
    closest(-16383, 16383, target_ut, |r| {
        compensate_z_f32(r, rhall, trim)
    })
}

/// Bisection over a monotonic `f` on `lo..=hi` (non-strict); `None` if `f` is flat or not
/// finite at the ends, or `target` is NaN.
fn closest(lo: i16, hi: i16, target: f32, f: impl Fn(i16) -> f32) -> Option<i16> {
    let (f_lo, f_hi) = (f(lo), f(hi));
    if !f_lo.is_finite() || !f_hi.is_finite() || target.is_nan() || f_lo == f_hi {
        return None;
    }
    let sign = if f_hi > f_lo { 1.0 } else { -1.0 };
    let g = |r: i16| sign * f(r);
    let t = sign * target;
    // Smallest r in lo..=hi with g(r) >= t (g non-decreasing), or hi.
    let (mut a, mut b) = (i32::from(lo), i32::from(hi));
    let mut steps = 0;
    while a < b && steps < MAX_BISECTION_STEPS {
        let mid = a + (b - a) / 2;
        if g(mid as i16) >= t {
            b = mid;
        } else {
            a = mid + 1;
        }
        steps += 1;
    }
    let r = a as i16;
    if r > lo && abs(g(r - 1) - t) <= abs(g(r) - t) {
        Some(r - 1)
    } else {
        Some(r)
    }
}
