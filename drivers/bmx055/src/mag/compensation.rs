//! Bosch's BMM150 compensation (SensorAPI `bmm150.c`), integer and float paths, as pure
//! functions of raw values so the host can compensate packet data.
//!
//! The integer path reproduces C's narrowing casts (`(uint16_t)`, `(int16_t)`) with `as` and
//! its 32-bit arithmetic with wrapping operations, so every input gives the C result where C
//! is defined and never panics where C would be undefined (overflow, division by zero).

use super::trim::MagTrim;
use super::types::{MagRaw, OVERFLOW_XY, OVERFLOW_Z};
use crate::types::Xyz;

/// Integer output for an overflowed or uncompensatable axis.
pub const OVERFLOW_OUTPUT: i16 = -32768;
/// Float output for an overflowed or uncompensatable axis.
pub const OVERFLOW_OUTPUT_F32: f32 = 0.0;

/// Shared by X and Y (Bosch `compensate_x` / `compensate_y`), integer µT.
fn compensate_xy(raw: i16, rhall: u16, trim: &MagTrim, dig_1: i8, dig_2: i8) -> i16 {
    if raw == OVERFLOW_XY {
        return OVERFLOW_OUTPUT;
    }
    let x0: u16 = if rhall != 0 {
        rhall
    } else if trim.dig_xyz1 != 0 {
        trim.dig_xyz1
    } else {
        return OVERFLOW_OUTPUT;
    };
    let x1 = i32::from(trim.dig_xyz1).wrapping_mul(16384);
    let x2 = ((x1.wrapping_div(i32::from(x0)) as u16) as i32).wrapping_sub(0x4000) as u16;
    let retval = x2 as i16;
    let x3 = i32::from(retval).wrapping_mul(i32::from(retval));
    let x4 = i32::from(trim.dig_xy2).wrapping_mul(x3 / 128);
    let x5 = i32::from((trim.dig_xy1 as i16).wrapping_mul(128));
    let x6 = i32::from(retval).wrapping_mul(x5);
    let x7 = (x4.wrapping_add(x6) / 512).wrapping_add(0x10_0000);
    let x8 = i32::from(i16::from(dig_2).wrapping_add(0xA0));
    let x9 = x7.wrapping_mul(x8) / 4096;
    let x10 = i32::from(raw).wrapping_mul(x9);
    let retval = (x10 / 8192) as i16;
    (i32::from(retval).wrapping_add(i32::from(i16::from(dig_1).wrapping_mul(8))) / 16) as i16
}

/// X in µT (integer path); [`OVERFLOW_OUTPUT`] on overflow.
pub fn compensate_x(raw_x: i16, rhall: u16, trim: &MagTrim) -> i16 {
    compensate_xy(raw_x, rhall, trim, trim.dig_x1, trim.dig_x2)
}

/// Y in µT (integer path); [`OVERFLOW_OUTPUT`] on overflow.
pub fn compensate_y(raw_y: i16, rhall: u16, trim: &MagTrim) -> i16 {
    compensate_xy(raw_y, rhall, trim, trim.dig_y1, trim.dig_y2)
}

/// Z in µT (integer path), saturated to ±2047 µT before scaling as Bosch does;
/// [`OVERFLOW_OUTPUT`] on overflow, on missing trim or rhall, and where C would divide by 0.
pub fn compensate_z(raw_z: i16, rhall: u16, trim: &MagTrim) -> i16 {
    if raw_z == OVERFLOW_Z
        || trim.dig_z2 == 0
        || trim.dig_z1 == 0
        || rhall == 0
        || trim.dig_xyz1 == 0
    {
        return OVERFLOW_OUTPUT;
    }
    let z0 = (rhall as i16).wrapping_sub(trim.dig_xyz1 as i16);
    let z1 = i32::from(trim.dig_z3).wrapping_mul(i32::from(z0)) / 4;
    let z2 = (i32::from(raw_z).wrapping_sub(i32::from(trim.dig_z4))).wrapping_mul(32768);
    let z3 = i32::from(trim.dig_z1).wrapping_mul(i32::from(rhall as i16).wrapping_mul(2));
    let z4 = (z3.wrapping_add(32768) / 65536) as i16;
    let divisor = i32::from(trim.dig_z2).wrapping_add(i32::from(z4));
    if divisor == 0 {
        return OVERFLOW_OUTPUT;
    }
    let retval = z2.wrapping_sub(z1).wrapping_div(divisor);
    (retval.clamp(-32767, 32767) / 16) as i16
}

/// X in µT (float path); 0.0 on overflow.
pub fn compensate_x_f32(raw_x: i16, rhall: u16, trim: &MagTrim) -> f32 {
    compensate_xy_f32(raw_x, rhall, trim, trim.dig_x1, trim.dig_x2)
}

/// Y in µT (float path); 0.0 on overflow.
pub fn compensate_y_f32(raw_y: i16, rhall: u16, trim: &MagTrim) -> f32 {
    compensate_xy_f32(raw_y, rhall, trim, trim.dig_y1, trim.dig_y2)
}

fn compensate_xy_f32(raw: i16, rhall: u16, trim: &MagTrim, dig_1: i8, dig_2: i8) -> f32 {
    if raw == OVERFLOW_XY || rhall == 0 || trim.dig_xyz1 == 0 {
        return OVERFLOW_OUTPUT_F32;
    }
    let x0 = f32::from(trim.dig_xyz1) * 16384.0 / f32::from(rhall);
    let r = x0 - 16384.0;
    let x1 = f32::from(trim.dig_xy2) * (r * r / 268_435_456.0);
    let x2 = x1 + r * f32::from(trim.dig_xy1) / 16384.0;
    let x3 = f32::from(dig_2) + 160.0;
    let x4 = f32::from(raw) * ((x2 + 256.0) * x3);
    ((x4 / 8192.0) + (f32::from(dig_1) * 8.0)) / 16.0
}

/// Z in µT (float path); 0.0 on overflow, missing trim or rhall.
pub fn compensate_z_f32(raw_z: i16, rhall: u16, trim: &MagTrim) -> f32 {
    if raw_z == OVERFLOW_Z
        || trim.dig_z2 == 0
        || trim.dig_z1 == 0
        || trim.dig_xyz1 == 0
        || rhall == 0
    {
        return OVERFLOW_OUTPUT_F32;
    }
    let z0 = f32::from(raw_z) - f32::from(trim.dig_z4);
    let z1 = f32::from(rhall) - f32::from(trim.dig_xyz1);
    let z2 = f32::from(trim.dig_z3) * z1;
    let z3 = f32::from(trim.dig_z1) * f32::from(rhall) / 32768.0;
    let z4 = f32::from(trim.dig_z2) + z3;
    let z5 = (z0 * 131_072.0) - z2;
    (z5 / (z4 * 4.0)) / 16.0
}

/// All three axes in µT, integer path (-32768 marks an overflowed axis).
pub fn compensate(raw: &MagRaw, trim: &MagTrim) -> Xyz<i16> {
    Xyz::new(
        compensate_x(raw.x, raw.rhall, trim),
        compensate_y(raw.y, raw.rhall, trim),
        compensate_z(raw.z, raw.rhall, trim),
    )
}

/// All three axes in µT, float path (0.0 marks an overflowed axis).
pub fn compensate_f32(raw: &MagRaw, trim: &MagTrim) -> Xyz<f32> {
    Xyz::new(
        compensate_x_f32(raw.x, raw.rhall, trim),
        compensate_y_f32(raw.y, raw.rhall, trim),
        compensate_z_f32(raw.z, raw.rhall, trim),
    )
}
