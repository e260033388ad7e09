//! GNSS freshness: a NAV-PVT solution counts only while it is valid (gnssFixOK with a 2-D, 3-D
//! or GNSS + dead-reckoning fix, and a speed accuracy within bounds) and its time of week
//! advances. The sensor board repeats its last NAV-PVT when the receiver goes quiet, so an
//! unchanged iTOW is old data, however valid it looks.

use dima_sensorboard::{FixType, NavPvt};

use crate::Nanos;

/// A fix the controllers may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FreshFix {
    /// GNSS time of week, ms.
    pub itow_ms: u32,
    /// Ground speed, mm/s.
    pub g_speed_mm_s: i32,
    /// Heading of motion, 1e-5 degrees.
    pub head_mot_deg_e5: i32,
    /// When the packet carrying it was judged, ns.
    pub at_ns: Nanos,
}

/// Tracks the newest valid fix with an advancing time of week.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GnssFreshness {
    last_itow_ms: Option<u32>,
    fix: Option<FreshFix>,
}

/// Whether `pvt` is a usable position and velocity solution.
pub fn is_valid(pvt: &NavPvt, max_speed_accuracy_mm_s: u32) -> bool {
    pvt.gnss_fix_ok()
        && matches!(
            pvt.fix(),
            FixType::Fix2D | FixType::Fix3D | FixType::GnssDeadReckoning
        )
        && pvt.s_acc_mm_s <= max_speed_accuracy_mm_s
}

impl GnssFreshness {
    /// Looks at the packet's NAV-PVT at `now`; returns the fix when it is new and valid.
    pub fn update(
        &mut self,
        pvt: Option<&NavPvt>,
        max_speed_accuracy_mm_s: u32,
        now: Nanos,
    ) -> Option<FreshFix> {
        let pvt = pvt?;
        let advanced = self.last_itow_ms != Some(pvt.itow_ms);
        self.last_itow_ms = Some(pvt.itow_ms);
        if !(advanced && is_valid(pvt, max_speed_accuracy_mm_s)) {
            return None;
        }
        let fix = FreshFix {
            itow_ms: pvt.itow_ms,
            g_speed_mm_s: pvt.g_speed_mm_s,
            head_mot_deg_e5: pvt.head_mot_deg_e5,
            at_ns: now,
        };
        self.fix = Some(fix);
        Some(fix)
    }

    /// The newest fresh fix, if it is at most `timeout_ns` old at `now`.
    pub fn current(&self, now: Nanos, timeout_ns: Nanos) -> Option<FreshFix> {
        self.fix
            .filter(|f| now.saturating_sub(f.at_ns) <= timeout_ns)
    }

    /// Age of the newest fresh fix at `now`, ns (`None`: none yet).
    pub fn age_ns(&self, now: Nanos) -> Option<Nanos> {
        self.fix.map(|f| now.saturating_sub(f.at_ns))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_sensorboard::nav_pvt::FLAG_GNSS_FIX_OK;

    const MS: Nanos = 1_000_000;

    fn pvt(itow_ms: u32, fix_type: u8, flags: u8, s_acc_mm_s: u32) -> NavPvt {
        NavPvt {
            itow_ms,
            fix_type,
            flags,
            s_acc_mm_s,
            g_speed_mm_s: 2_000,
            ..NavPvt::default()
        }
    }

    #[test]
    fn a_fix_counts_only_when_flagged_ok_positional_and_accurate() {
        for fix_type in [2, 3, 4] {
            assert!(is_valid(&pvt(1, fix_type, FLAG_GNSS_FIX_OK, 150), 1_000));
        }
        for fix_type in [0, 1, 5, 6] {
            assert!(!is_valid(&pvt(1, fix_type, FLAG_GNSS_FIX_OK, 150), 1_000));
        }
        assert!(!is_valid(&pvt(1, 3, 0, 150), 1_000), "gnssFixOK clear");
        assert!(
            !is_valid(&pvt(1, 3, FLAG_GNSS_FIX_OK, 1_001), 1_000),
            "sAcc"
        );
    }

    #[test]
    fn a_repeated_itow_is_not_a_new_fix_and_ages_out() {
        let mut g = GnssFreshness::default();
        let p = pvt(100, 3, FLAG_GNSS_FIX_OK, 150);
        assert!(g.update(Some(&p), 1_000, 0).is_some());
        // The board repeats the same NAV-PVT: valid-looking, but frozen.
        for i in 1..200 {
            assert_eq!(g.update(Some(&p), 1_000, i * 4 * MS), None);
        }
        assert!(g.current(500 * MS, 500 * MS).is_some());
        assert_eq!(g.current(501 * MS, 500 * MS), None);
        assert_eq!(g.age_ns(796 * MS), Some(796 * MS));
        // The next epoch is fresh again.
        let next = pvt(200, 3, FLAG_GNSS_FIX_OK, 150);
        assert!(g.update(Some(&next), 1_000, 800 * MS).is_some());
        assert!(g.current(800 * MS, 500 * MS).is_some());
    }

    #[test]
    fn an_invalid_epoch_does_not_refresh() {
        let mut g = GnssFreshness::default();
        assert!(g
            .update(Some(&pvt(100, 3, FLAG_GNSS_FIX_OK, 150)), 1_000, 0)
            .is_some());
        assert_eq!(g.update(Some(&pvt(200, 0, 0, 150)), 1_000, 100 * MS), None);
        assert_eq!(g.update(None, 1_000, 200 * MS), None);
        assert_eq!(g.current(600 * MS, 500 * MS), None);
    }
}
