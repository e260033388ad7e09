//! GNSS freshness: a NAV-PVT solution counts only while it is valid (gnssFixOK with a 2-D, 3-D
//! or GNSS + dead-reckoning fix, a ground speed that is a magnitude (never negative), and a
//! speed accuracy within bounds) and its time of week advances past the newest epoch received
//! with gnssFixOK, used or not. The sensor board repeats its last NAV-PVT when the receiver goes
//! quiet, so an unchanged iTOW is old data, however valid it looks; an iTOW that steps back (or
//! jumps ahead by half a week or more) is no newer than what was already received, so it does
//! not refresh either: alternating between two epochs cannot pass for a live receiver, and
//! neither can a replay of epochs that were received but not used (a negative ground speed, a
//! poor speed accuracy). An epoch without gnssFixOK says nothing reliable about the time and
//! raises no bar, nor does an unused one more than [`MAX_UNUSED_STEP_MS`] ahead. The iTOW wraps from 604 799 999 to 0 at the end of the week: a forward step of
//! less than half a week, across the wrap or not, advances.

use dima_sensorboard::{FixType, NavPvt};

use crate::Nanos;

/// Milliseconds in a GPS week: the time of week runs `0..WEEK_MS`.
pub const WEEK_MS: u32 = 604_800_000;

/// The largest step of the time of week an epoch that is not used may take the newest time
/// received forward by, ms. A corrupt epoch far in the future must not keep the receiver's
/// real epochs out for hours; a receiver that really jumps ahead is believed at its next valid
/// fix.
pub const MAX_UNUSED_STEP_MS: u32 = 10_000;

/// A fix the controllers may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FreshFix {
    /// GNSS time of week, ms.
    pub itow_ms: u32,
    /// Ground speed, mm/s.
    pub g_speed_mm_s: i32,
    /// Heading of motion, 1e-5 degrees.
    pub head_mot_deg_e5: i32,
    /// Latitude, 1e-7 degrees.
    pub lat_deg_e7: i32,
    /// Longitude, 1e-7 degrees.
    pub lon_deg_e7: i32,
    /// When the packet carrying it was judged, ns.
    pub at_ns: Nanos,
}

/// What became of one packet's NAV-PVT.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GnssEpoch {
    /// The packet carried no NAV-PVT.
    Absent,
    /// The same time of week as the previous epoch: the board repeating itself.
    Repeated,
    /// A time of week other than the previous epoch's that does not advance past the newest
    /// epoch received with gnssFixOK: the receiver's time stepped back (or jumped half a week
    /// or more ahead), or it replays epochs it sent before.
    NotAdvancing,
    /// A new epoch, but not a valid solution.
    Invalid,
    /// A new valid fix.
    New(FreshFix),
}

impl GnssEpoch {
    /// The fix, when the epoch is a new valid one.
    pub fn fix(self) -> Option<FreshFix> {
        match self {
            GnssEpoch::New(fix) => Some(fix),
            _ => None,
        }
    }
}

/// Tracks the newest valid fix with an advancing time of week.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GnssFreshness {
    last_itow_ms: Option<u32>,
    /// The newest time of week of an epoch the receiver flagged gnssFixOK, used or not (its
    /// time is a solution's): a later epoch must advance past it.
    newest_itow_ms: Option<u32>,
    fix: Option<FreshFix>,
}

/// Whether `pvt` is a usable position and velocity solution. NAV-PVT's ground speed is a
/// magnitude: a negative one is a corrupt solution, whatever its flags say.
pub fn is_valid(pvt: &NavPvt, max_speed_accuracy_mm_s: u32) -> bool {
    pvt.gnss_fix_ok()
        && matches!(
            pvt.fix(),
            FixType::Fix2D | FixType::Fix3D | FixType::GnssDeadReckoning
        )
        && pvt.g_speed_mm_s >= 0
        && pvt.s_acc_mm_s <= max_speed_accuracy_mm_s
}

/// Whether the time of week `itow_ms` is later than `newest_ms`: a forward step of less than
/// half a week, across the end of the week or not. A time of week outside the week never is.
pub fn itow_advanced(newest_ms: u32, itow_ms: u32) -> bool {
    if newest_ms >= WEEK_MS || itow_ms >= WEEK_MS {
        return false;
    }
    let forward_ms = (itow_ms + (WEEK_MS - newest_ms)) % WEEK_MS;
    forward_ms > 0 && forward_ms < WEEK_MS / 2
}

impl GnssFreshness {
    /// Looks at the packet's NAV-PVT at `now`: a new valid fix, or why not.
    pub fn update(
        &mut self,
        pvt: Option<&NavPvt>,
        max_speed_accuracy_mm_s: u32,
        now: Nanos,
    ) -> GnssEpoch {
        let Some(pvt) = pvt else {
            return GnssEpoch::Absent;
        };
        let previous = self.last_itow_ms.replace(pvt.itow_ms);
        if previous == Some(pvt.itow_ms) {
            return GnssEpoch::Repeated;
        }
        if self
            .newest_itow_ms
            .is_some_and(|newest| !itow_advanced(newest, pvt.itow_ms))
        {
            return GnssEpoch::NotAdvancing;
        }
        if !is_valid(pvt, max_speed_accuracy_mm_s) {
            // A flagged solution that is not used (a negative ground speed, a poor speed
            // accuracy) still dates what follows, when its time is a plausible next epoch.
            let plausible = self.newest_itow_ms.is_some_and(|newest| {
                itow_advanced(newest, pvt.itow_ms)
                    && (pvt.itow_ms + WEEK_MS - newest) % WEEK_MS <= MAX_UNUSED_STEP_MS
            });
            if pvt.gnss_fix_ok() && plausible {
                self.newest_itow_ms = Some(pvt.itow_ms);
            }
            return GnssEpoch::Invalid;
        }
        self.newest_itow_ms = Some(pvt.itow_ms);
        let fix = FreshFix {
            itow_ms: pvt.itow_ms,
            g_speed_mm_s: pvt.g_speed_mm_s,
            head_mot_deg_e5: pvt.head_mot_deg_e5,
            lat_deg_e7: pvt.lat_deg_e7,
            lon_deg_e7: pvt.lon_deg_e7,
            at_ns: now,
        };
        self.fix = Some(fix);
        GnssEpoch::New(fix)
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
        let reversing = NavPvt {
            g_speed_mm_s: -1,
            ..pvt(1, 3, FLAG_GNSS_FIX_OK, 150)
        };
        assert!(!is_valid(&reversing, 1_000), "negative gSpeed");
        let standing = NavPvt {
            g_speed_mm_s: 0,
            ..reversing
        };
        assert!(is_valid(&standing, 1_000));
    }

    #[test]
    fn a_repeated_itow_is_not_a_new_fix_and_ages_out() {
        let mut g = GnssFreshness::default();
        let p = pvt(100, 3, FLAG_GNSS_FIX_OK, 150);
        assert!(g.update(Some(&p), 1_000, 0).fix().is_some());
        // The board repeats the same NAV-PVT: valid-looking, but frozen.
        for i in 1..200 {
            assert_eq!(g.update(Some(&p), 1_000, i * 4 * MS), GnssEpoch::Repeated);
        }
        assert!(g.current(500 * MS, 500 * MS).is_some());
        assert_eq!(g.current(501 * MS, 500 * MS), None);
        assert_eq!(g.age_ns(796 * MS), Some(796 * MS));
        // The next epoch is fresh again.
        let next = pvt(200, 3, FLAG_GNSS_FIX_OK, 150);
        assert!(g.update(Some(&next), 1_000, 800 * MS).fix().is_some());
        assert!(g.current(800 * MS, 500 * MS).is_some());
    }

    #[test]
    fn an_invalid_epoch_does_not_refresh() {
        let mut g = GnssFreshness::default();
        assert!(g
            .update(Some(&pvt(100, 3, FLAG_GNSS_FIX_OK, 150)), 1_000, 0)
            .fix()
            .is_some());
        assert_eq!(
            g.update(Some(&pvt(200, 0, 0, 150)), 1_000, 100 * MS),
            GnssEpoch::Invalid
        );
        assert_eq!(g.update(None, 1_000, 200 * MS), GnssEpoch::Absent);
        assert_eq!(g.current(600 * MS, 500 * MS), None);
    }

    #[test]
    fn a_time_of_week_that_steps_back_does_not_refresh_even_when_it_changes() {
        let mut g = GnssFreshness::default();
        let at = |itow_ms| pvt(itow_ms, 3, FLAG_GNSS_FIX_OK, 150);
        assert!(g.update(Some(&at(1_000)), 1_000, 0).fix().is_some());
        for (i, itow_ms) in [900, 1_000, 900, 1_000, 500].into_iter().enumerate() {
            let now = (i as Nanos + 1) * 100 * MS;
            assert_eq!(
                g.update(Some(&at(itow_ms)), 1_000, now),
                GnssEpoch::NotAdvancing,
                "{itow_ms}"
            );
        }
        assert_eq!(g.current(501 * MS, 500 * MS), None, "aged out");
        // Past the newest fix used: fresh again.
        assert!(g.update(Some(&at(1_100)), 1_000, 600 * MS).fix().is_some());
    }

    #[test]
    fn an_epoch_older_than_one_already_received_is_old_data_even_if_none_was_used() {
        // The receiver's solutions arrive with a negative ground speed (invalid, not used),
        // then it replays two of them with valid data: they are newer than the newest fix
        // used, but older than epochs already received, so they are seconds old.
        let mut g = GnssFreshness::default();
        let at = |itow_ms| pvt(itow_ms, 3, FLAG_GNSS_FIX_OK, 150);
        assert!(g.update(Some(&at(1_000)), 1_000, 0).fix().is_some());
        for (i, itow_ms) in [1_100, 1_200, 1_300].into_iter().enumerate() {
            let reversing = NavPvt {
                g_speed_mm_s: -3_000,
                ..at(itow_ms)
            };
            let now = (i as Nanos + 1) * 100 * MS;
            assert_eq!(g.update(Some(&reversing), 1_000, now), GnssEpoch::Invalid);
        }
        for (i, itow_ms) in [1_100, 1_200, 1_100, 1_200].into_iter().enumerate() {
            let now = (i as Nanos + 4) * 100 * MS;
            assert_eq!(
                g.update(Some(&at(itow_ms)), 1_000, now),
                GnssEpoch::NotAdvancing,
                "{itow_ms} after 1 300 was received"
            );
        }
        // An epoch without a fix says nothing about the time: it does not raise the bar.
        assert_eq!(
            g.update(Some(&pvt(9_000, 0, 0, 150)), 1_000, 800 * MS),
            GnssEpoch::Invalid
        );
        assert!(g.update(Some(&at(1_400)), 1_000, 900 * MS).fix().is_some());
    }

    #[test]
    fn the_time_of_week_wraps_at_the_end_of_the_week() {
        let last = WEEK_MS - 1;
        assert!(itow_advanced(last - 99, last));
        assert!(itow_advanced(last, 0), "604 799 999 -> 0");
        assert!(itow_advanced(WEEK_MS - 50, 50));
        assert!(!itow_advanced(50, WEEK_MS - 50), "back across the wrap");
        assert!(!itow_advanced(1_000, 1_000));
        assert!(!itow_advanced(1_000, 900));
        // Forward by just under half a week advances; by half a week or more it is a step back.
        assert!(itow_advanced(0, WEEK_MS / 2 - 1));
        assert!(!itow_advanced(0, WEEK_MS / 2));
        assert!(!itow_advanced(0, WEEK_MS), "outside the week");
        assert!(!itow_advanced(WEEK_MS, 5));
        // Through the freshness monitor: epochs across the wrap are new fixes.
        let mut g = GnssFreshness::default();
        for (i, itow_ms) in [WEEK_MS - 200, WEEK_MS - 100, 0, 100]
            .into_iter()
            .enumerate()
        {
            let epoch = g.update(
                Some(&pvt(itow_ms, 3, FLAG_GNSS_FIX_OK, 150)),
                1_000,
                i as Nanos * 100 * MS,
            );
            assert!(epoch.fix().is_some(), "{itow_ms}: {epoch:?}");
        }
    }
}
