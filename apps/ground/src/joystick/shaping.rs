//! A raw gamepad axis value to the deflection that drives, as pure functions applied in this
//! order:
//!
//! 1. **Centre and range** ([`normalise`]): the raw value `r` becomes `x` in -1..=1, linear on
//!    each side of the centre: `(r - centre) / (max - centre)` above it, `(r - centre) /
//!    (centre - min)` below it, clamped to -1..=1 (a stick past its calibrated end reads ±1).
//! 2. **Inversion** ([`invert`]): `-x` when the axis is inverted.
//! 3. **Dead zone** ([`dead_zone`]): `|x| <= dead_zone` counts as released (no value at all,
//!    so a stick lying still never holds a channel); outside, the rest of the travel is
//!    stretched back to 0..=1 (`sign(x) · (|x| - dead_zone) / (1 - dead_zone)`), so the output
//!    starts at 0 at the edge of the dead zone instead of jumping.
//! 4. **Expo** ([`expo`]), the usual RC curve: `out = (1 - e) · x + e · x³`, `e` in 0..=1.
//!    `e = 0` is linear; larger `e` makes the centre gentler (finer control of small
//!    deflections) while full deflection still reaches ±1. It keeps 0 → 0 and ±1 → ±1 and is
//!    monotonic (its slope `(1 - e) + 3e·x²` is never negative).
//!
//! The deflection then becomes a percentage around the channel's neutral
//! ([`percent_around`]): +1 is 100 %, -1 is 0 %, linear on each side of neutral.

use dima_groundlink::Percent;

use super::names::{AxesSample, StickAxis};

/// Below this a calibrated half-range counts as none (a degenerate calibration reads 0).
const MIN_HALF_RANGE: f32 = 1e-3;

/// One channel's gamepad axis and how it is read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisCalibration {
    /// The gamepad axis; `None`: this channel is not on the gamepad.
    pub axis: Option<StickAxis>,
    /// The raw value with the stick released.
    pub centre: f32,
    /// The raw value at the stick's lower end (down or left).
    pub min: f32,
    /// The raw value at the stick's upper end (up or right).
    pub max: f32,
    /// Normalised deflection (0..1) that counts as released.
    pub dead_zone: f32,
    /// Reverse the direction.
    pub invert: bool,
    /// The expo `e` of [`expo`], 0..=1 (0: linear).
    pub expo: f32,
}

impl AxisCalibration {
    /// A full-range axis centred on 0 with the default dead zone and no expo.
    pub const fn on(axis: Option<StickAxis>) -> AxisCalibration {
        AxisCalibration {
            axis,
            centre: 0.0,
            min: -1.0,
            max: 1.0,
            dead_zone: 0.12,
            invert: false,
            expo: 0.0,
        }
    }

    /// The deflection a raw value gives (steps 1 to 4 above); `None` when released (inside
    /// the dead zone) or not a number.
    pub fn shape(&self, raw: f32) -> Option<f32> {
        if !raw.is_finite() {
            return None;
        }
        let x = invert(normalise(raw, self.centre, self.min, self.max), self.invert);
        dead_zone(x, self.dead_zone).map(|x| expo(x, self.expo))
    }

    /// The deflection of this channel's axis in `sample`; `None` when the channel is not on
    /// the gamepad, the gamepad has no such axis, or the stick is released.
    pub fn read(&self, sample: &AxesSample) -> Option<f32> {
        self.axis
            .and_then(|a| a.value_in(sample))
            .and_then(|raw| self.shape(raw))
    }
}

/// Step 1: the raw value relative to the calibrated centre and ends, in -1..=1.
pub fn normalise(raw: f32, centre: f32, min: f32, max: f32) -> f32 {
    let half = if raw >= centre {
        max - centre
    } else {
        centre - min
    };
    if half.is_nan() || half <= MIN_HALF_RANGE {
        return 0.0;
    }
    ((raw - centre) / half).clamp(-1.0, 1.0)
}

/// Step 2: reversed when `inverted`.
pub fn invert(x: f32, inverted: bool) -> f32 {
    if inverted {
        -x
    } else {
        x
    }
}

/// Step 3: `None` inside the dead zone (`|x| <= dead_zone`), else the deflection beyond it
/// stretched to 0..=1 on each side. `dead_zone` is clamped to 0..0.99.
pub fn dead_zone(x: f32, dead_zone: f32) -> Option<f32> {
    let dz = dead_zone.clamp(0.0, 0.99);
    if x.abs() <= dz {
        return None;
    }
    Some((x.signum() * (x.abs() - dz) / (1.0 - dz)).clamp(-1.0, 1.0))
}

/// Step 4, the RC expo curve `(1 - e) · x + e · x³` on `x` in -1..=1; `e` is clamped to
/// 0..=1.
pub fn expo(x: f32, e: f32) -> f32 {
    let e = e.clamp(0.0, 1.0);
    (1.0 - e) * x + e * x * x * x
}

/// The percentage a deflection (-1..=1) asks for around `neutral`: +1 is 100 %, -1 is 0 %,
/// linear on each side of neutral (an off-centre neutral scales each side to its own end).
pub fn percent_around(x: f32, neutral: Percent) -> Percent {
    let x = if x.is_finite() {
        x.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let n = f32::from(neutral.get());
    let p = if x > 0.0 {
        n + x * (100.0 - n)
    } else {
        n + x * n
    };
    Percent::new(p.round().clamp(0.0, 100.0) as u8).unwrap_or(neutral)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() < 1e-5
    }

    #[test]
    fn normalise_scales_each_side_of_the_centre_and_clamps() {
        // A stick resting at 0.1 that reaches -0.8 and 0.9.
        let n = |r| normalise(r, 0.1, -0.8, 0.9);
        assert!(close(n(0.1), 0.0));
        assert!(close(n(0.9), 1.0));
        assert!(close(n(-0.8), -1.0));
        assert!(close(n(0.5), 0.5));
        assert!(close(n(-0.35), -0.5));
        // Past the calibrated ends: clamped.
        assert_eq!(n(1.0), 1.0);
        assert_eq!(n(-1.0), -1.0);
        assert_eq!(normalise(5.0, 0.0, -1.0, 1.0), 1.0);
        assert_eq!(normalise(-5.0, 0.0, -1.0, 1.0), -1.0);
        // A side without range reads 0, never infinity.
        assert_eq!(normalise(0.5, 0.5, -1.0, 0.5), 0.0);
        assert_eq!(normalise(0.7, 0.5, -1.0, 0.5), 0.0);
    }

    #[test]
    fn inversion_reverses_the_direction() {
        assert_eq!(invert(0.4, true), -0.4);
        assert_eq!(invert(-1.0, true), 1.0);
        assert_eq!(invert(0.4, false), 0.4);
        let mut axis = AxisCalibration::on(Some(StickAxis::LeftStickY));
        axis.dead_zone = 0.0;
        assert_eq!(axis.shape(0.75), Some(0.75));
        axis.invert = true;
        assert_eq!(axis.shape(0.75), Some(-0.75));
    }

    #[test]
    fn dead_zone_releases_inside_and_stretches_outside() {
        assert_eq!(dead_zone(0.0, 0.1), None);
        assert_eq!(dead_zone(0.1, 0.1), None);
        assert_eq!(dead_zone(-0.05, 0.1), None);
        assert!(close(dead_zone(1.0, 0.1).unwrap(), 1.0));
        assert!(close(dead_zone(-1.0, 0.1).unwrap(), -1.0));
        assert!(close(dead_zone(0.55, 0.1).unwrap(), 0.5));
        assert!(close(dead_zone(-0.55, 0.1).unwrap(), -0.5));
        // Just outside the dead zone the output starts near 0, not at the edge.
        assert!(dead_zone(0.101, 0.1).unwrap() < 0.01);
        // No dead zone: only an exact 0 is released.
        assert_eq!(dead_zone(0.0, 0.0), None);
        assert_eq!(dead_zone(0.01, 0.0), Some(0.01));
    }

    #[test]
    fn expo_keeps_its_ends_and_is_monotonic() {
        for e in [0.0, 0.2, 0.5, 0.8, 1.0] {
            assert_eq!(expo(0.0, e), 0.0, "e = {e}");
            assert!(close(expo(1.0, e), 1.0), "e = {e}");
            assert!(close(expo(-1.0, e), -1.0), "e = {e}");
            let mut last = f32::NEG_INFINITY;
            for i in -100..=100 {
                let y = expo(i as f32 / 100.0, e);
                assert!(y > last, "e = {e}: not increasing at {i}");
                assert!((-1.0..=1.0).contains(&y));
                last = y;
            }
        }
        // Linear at 0, gentler around the centre as e grows, odd.
        assert_eq!(expo(0.5, 0.0), 0.5);
        assert!(close(expo(0.5, 0.5), 0.5 * 0.5 + 0.5 * 0.125));
        assert!(expo(0.3, 0.6) < expo(0.3, 0.3));
        assert_eq!(expo(-0.3, 0.4), -expo(0.3, 0.4));
    }

    #[test]
    fn shape_applies_every_step_in_order() {
        let axis = AxisCalibration {
            axis: Some(StickAxis::RightStickX),
            centre: 0.1,
            min: -0.8,
            max: 0.9,
            dead_zone: 0.2,
            invert: true,
            expo: 0.5,
        };
        assert_eq!(axis.shape(0.1), None, "the calibrated centre is released");
        assert_eq!(axis.shape(0.2), None, "inside the dead zone");
        assert_eq!(axis.shape(f32::NAN), None);
        // 0.9 is the upper end: normalised 1, inverted -1, beyond the dead zone -1, expo -1.
        assert!(close(axis.shape(0.9).unwrap(), -1.0));
        assert!(close(axis.shape(-0.8).unwrap(), 1.0));
        // Half way down: -0.5 normalised, 0.5 inverted, (0.5-0.2)/0.8 = 0.375, then expo.
        let x: f32 = 0.375;
        assert!(close(axis.shape(-0.35).unwrap(), 0.5 * x + 0.5 * x * x * x));
        let mut sample: AxesSample = [None; StickAxis::COUNT];
        assert_eq!(axis.read(&sample), None, "the gamepad has no such axis");
        sample[StickAxis::RightStickX as usize] = Some(0.9);
        assert!(close(axis.read(&sample).unwrap(), -1.0));
        let unassigned = AxisCalibration { axis: None, ..axis };
        assert_eq!(unassigned.read(&sample), None);
    }

    #[test]
    fn deflections_map_around_neutral() {
        assert_eq!(percent_around(0.0, pct(50)), pct(50));
        assert_eq!(percent_around(1.0, pct(50)), pct(100));
        assert_eq!(percent_around(-1.0, pct(50)), pct(0));
        assert_eq!(percent_around(0.5, pct(50)), pct(75));
        // An off-centre neutral: each side scales to its own end.
        assert_eq!(percent_around(0.5, pct(20)), pct(60));
        assert_eq!(percent_around(-0.5, pct(20)), pct(10));
        assert_eq!(percent_around(3.0, pct(50)), pct(100));
        assert_eq!(percent_around(f32::NAN, pct(30)), pct(30));
    }
}
