//! Float helpers that `core` lacks on stable (`f32::round` lives in `std`).

/// Round half away from zero; saturates at the `i32` range, NaN gives 0.
pub(crate) fn round(x: f32) -> f32 {
    if x >= 0.0 {
        (x + 0.5) as i32 as f32
    } else {
        (x - 0.5) as i32 as f32
    }
}

/// Absolute value (`f32::abs` is not in `core` on the minimum supported Rust).
#[cfg(feature = "sim")]
pub(crate) fn abs(x: f32) -> f32 {
    if x < 0.0 {
        -x
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::round;

    #[test]
    fn rounds_half_away_from_zero() {
        assert_eq!(round(1.4), 1.0);
        assert_eq!(round(1.5), 2.0);
        assert_eq!(round(-1.5), -2.0);
        assert_eq!(round(-1.4), -1.0);
        assert_eq!(round(f32::NAN), 0.0);
    }
}
