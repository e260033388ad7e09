//! The scale bar: the longest round length (1, 2 or 5 times a power of ten metres) that fits.

/// The shortest scale bar, m.
pub const MIN_SCALE_M: f64 = 1.0;

/// The longest length of 1, 2 or 5 × 10ⁿ metres (at least [`MIN_SCALE_M`]) no longer than
/// `max_px` pixels at `metres_per_px`; [`MIN_SCALE_M`] when even that is longer.
pub fn scale_bar_m(metres_per_px: f64, max_px: f64) -> f64 {
    let max_m = metres_per_px * max_px;
    if !(max_m.is_finite() && max_m >= MIN_SCALE_M) {
        return MIN_SCALE_M;
    }
    let decade = 10f64.powf(max_m.log10().floor());
    [5.0, 2.0, 1.0]
        .into_iter()
        .map(|k| k * decade)
        .find(|&m| m <= max_m * (1.0 + 1e-12))
        .unwrap_or(decade)
}

/// The scale bar's length as text: "5 m", "200 m", "2 km".
pub fn scale_label(metres: f64) -> String {
    if metres >= 1000.0 {
        format!("{} km", metres / 1000.0)
    } else {
        format!("{metres} m")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bar_is_the_longest_round_length_that_fits() {
        // 0.1 m per pixel, 120 px: 12 m fits, so 10 m.
        assert_eq!(scale_bar_m(0.1, 120.0), 10.0);
        assert_eq!(scale_bar_m(0.1, 250.0), 20.0);
        assert_eq!(scale_bar_m(0.1, 499.0), 20.0);
        assert_eq!(scale_bar_m(0.1, 500.0), 50.0);
        assert_eq!(scale_bar_m(1.0, 150.0), 100.0);
        assert_eq!(scale_bar_m(20.0, 150.0), 2000.0);
        assert_eq!(scale_bar_m(0.02, 150.0), 2.0);
        // Zoomed in further than a metre fits: the shortest bar.
        assert_eq!(scale_bar_m(0.001, 150.0), MIN_SCALE_M);
        assert_eq!(scale_bar_m(f64::NAN, 150.0), MIN_SCALE_M);
        for mpp in [0.013, 0.37, 2.9, 41.0] {
            let m = scale_bar_m(mpp, 150.0);
            assert!(m / mpp <= 150.0 && m / mpp > 150.0 / 2.5, "{mpp}: {m}");
        }
    }

    #[test]
    fn labels_switch_to_kilometres() {
        assert_eq!(scale_label(5.0), "5 m");
        assert_eq!(scale_label(500.0), "500 m");
        assert_eq!(scale_label(2000.0), "2 km");
    }
}
