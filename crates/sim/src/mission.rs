//! `--scenario mission`: what the run saw of the mission (waypoints reached, how close, the
//! cross-track error on the straights, the lap time) and its verdict.

use dima_core::mission::AutoSource;
use dima_core::{CycleOutputs, FailsafeCause, Mode, Nanos};

use crate::board::EARTH_RADIUS_M;
use crate::model::VehicleState;

/// A latitude and longitude in the model's frame around (`lat0_deg`, `lon0_deg`): metres
/// north and east, as the simulated receiver converts the other way.
pub fn model_frame(lat0_deg: f64, lon0_deg: f64, lat_deg: f64, lon_deg: f64) -> (f64, f64) {
    (
        (lat_deg - lat0_deg).to_radians() * EARTH_RADIUS_M,
        (lon_deg - lon0_deg).to_radians() * EARTH_RADIUS_M * lat0_deg.to_radians().cos(),
    )
}

/// The model's true distance from the legs between `waypoints` (model frame) on their
/// straights: RMS and largest, m, over the samples of `truth` on a straight.
pub fn true_straights(truth: &[VehicleState], waypoints: &[(f64, f64)]) -> Option<(f64, f64)> {
    let (mut sum_sq, mut n, mut max) = (0.0, 0usize, 0.0f64);
    for s in truth {
        for leg in waypoints.windows(2) {
            let ((n0, e0), (n1, e1)) = (leg[0], leg[1]);
            let length = (n1 - n0).hypot(e1 - e0);
            if length < f64::from(STRAIGHT_MIN_LEG_M) {
                continue;
            }
            let (un, ue) = ((n1 - n0) / length, (e1 - e0) / length);
            let (dn, de) = (s.north_m - n0, s.east_m - e0);
            let along = dn * un + de * ue;
            let cross = -dn * ue + de * un;
            let on_straight = along > f64::from(STRAIGHT_FROM_M)
                && along < length - f64::from(STRAIGHT_BEFORE_END_M)
                && cross.abs() < f64::from(STRAIGHT_FROM_M) / 2.0;
            if on_straight {
                sum_sq += cross * cross;
                n += 1;
                max = max.max(cross.abs());
                break;
            }
        }
    }
    (n > 0).then(|| ((sum_sq / n as f64).sqrt(), max))
}

/// A leg counts as a straight from this far past its start...
pub const STRAIGHT_FROM_M: f32 = 10.0;
/// ...to this far before its end, on legs at least [`STRAIGHT_MIN_LEG_M`] long.
pub const STRAIGHT_BEFORE_END_M: f32 = 5.0;
/// Shortest leg with a straight, m.
pub const STRAIGHT_MIN_LEG_M: f32 = 20.0;

/// What the application's cycles showed of the mission.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MissionTrack {
    /// First cycle following the mission, ns.
    pub started_ns: Option<Nanos>,
    /// Cycle at which the last waypoint was reached, ns.
    pub finished_ns: Option<Nanos>,
    /// Closest approach to each waypoint while it was current, m (by index): at most the
    /// distance at which it was reached (the follower's last output before the next became
    /// current); infinite for one reached before the first output (the car started on it).
    pub closest_m: Vec<f32>,
    /// A failsafe while the mission was followed: its cause.
    pub failsafe: Option<Option<FailsafeCause>>,
    /// Cross-track samples on the straights: sum of squares, count, largest magnitude.
    straight_sum_sq: f64,
    straight_samples: u64,
    straight_max_m: f32,
}

impl MissionTrack {
    /// One cycle's outputs at `wake_ns`; true when the run can end (the mission finished, or
    /// a failsafe stopped it).
    pub fn record(&mut self, out: &CycleOutputs, wake_ns: Nanos) -> bool {
        if self.started_ns.is_some() && out.mode == Mode::Failsafe && self.failsafe.is_none() {
            self.failsafe = Some(out.cause);
            return true;
        }
        let Some(m) = out
            .mission
            .filter(|_| out.auto_source == Some(AutoSource::Mission))
        else {
            return false;
        };
        self.started_ns.get_or_insert(wake_ns);
        let i = m.waypoint as usize;
        if self.closest_m.len() <= i {
            self.closest_m.resize(i + 1, f32::INFINITY);
        }
        self.closest_m[i] = self.closest_m[i].min(m.to_go_m);
        if m.leg_length_m >= STRAIGHT_MIN_LEG_M
            && m.along_track_m > STRAIGHT_FROM_M
            && m.along_track_m < m.leg_length_m - STRAIGHT_BEFORE_END_M
            && !m.finished
        {
            self.straight_sum_sq += f64::from(m.cross_track_m).powi(2);
            self.straight_samples += 1;
            self.straight_max_m = self.straight_max_m.max(m.cross_track_m.abs());
        }
        if m.finished && self.finished_ns.is_none() {
            self.finished_ns = Some(wake_ns);
            return true;
        }
        false
    }

    /// The run ended because of the mission (finished or failsafe).
    pub fn ended(&self) -> bool {
        self.finished_ns.is_some() || self.failsafe.is_some()
    }

    /// RMS and largest cross-track error on the straights, m.
    pub fn straights(&self) -> Option<(f64, f32)> {
        (self.straight_samples > 0).then(|| {
            (
                (self.straight_sum_sq / self.straight_samples as f64).sqrt(),
                self.straight_max_m,
            )
        })
    }

    /// Start to last waypoint, s.
    pub fn lap_s(&self) -> Option<f64> {
        Some(self.finished_ns?.saturating_sub(self.started_ns?) as f64 * 1e-9)
    }

    /// The last of `waypoints` reached in a run of `ran_s`: or why not.
    pub fn verdict(&self, waypoints: usize, ran_s: f64) -> Result<(), String> {
        if let Some(cause) = self.failsafe {
            return Err(format!(
                "failsafe ({}) at waypoint {} of {waypoints}",
                cause.map_or_else(|| "unknown".to_owned(), |c| format!("{c:?}")),
                self.closest_m.len().saturating_sub(1)
            ));
        }
        if self.started_ns.is_none() {
            return Err("the mission never started (AUTO was not entered)".into());
        }
        if self.finished_ns.is_none() {
            return Err(format!(
                "timeout: the last waypoint not reached after {ran_s:.1} s (waypoint {} of {waypoints} current)",
                self.closest_m.len().saturating_sub(1)
            ));
        }
        Ok(())
    }

    /// The report's lines.
    pub fn summary(&self, waypoints: usize) -> String {
        let closest: Vec<String> = self
            .closest_m
            .iter()
            .enumerate()
            .map(|(i, d)| {
                if d.is_finite() {
                    format!("{i}: {d:.2} m")
                } else {
                    format!("{i}: at the start")
                }
            })
            .collect();
        let mut s = format!(
            "mission: {} of {waypoints} waypoints current in turn; distance to each when last \
             current {}",
            self.closest_m.len(),
            closest.join(", ")
        );
        if let Some((rms, max)) = self.straights() {
            s += &format!(
                "\nmission: cross-track error on the straights (>= {STRAIGHT_FROM_M} m past a \
                 waypoint, >= {STRAIGHT_BEFORE_END_M} m before the next): RMS {rms:.3} m, max \
                 {max:.3} m"
            );
        }
        if let Some(lap) = self.lap_s() {
            s += &format!("\nmission: lap {lap:.1} s");
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_core::config::Config;
    use dima_core::mission::MissionStatus;
    use dima_core::{Core, CoreState, CycleInputs, SensorInput};

    /// The outputs of a real step, with `mode` and `mission` put in.
    fn outputs(mode: Mode, mission: Option<MissionStatus>) -> CycleOutputs {
        let mut core = Core::new(&Config::default()).unwrap();
        let mut out = core.step(
            &mut CoreState::new(),
            &CycleInputs {
                missed_periods: 0,
                commands: &[],
                sensor: SensorInput::NotRequested,
                stale_packets: 0,
            },
            1_000_000_000,
        );
        out.mode = mode;
        out.auto_source = (mode == Mode::Auto).then_some(if mission.is_some() {
            AutoSource::Mission
        } else {
            AutoSource::Setpoints
        });
        out.mission = mission;
        out
    }

    fn status(waypoint: u32, along_m: f32, cross_m: f32, finished: bool) -> MissionStatus {
        MissionStatus {
            waypoint,
            cross_track_m: cross_m,
            along_track_m: along_m,
            leg_length_m: 40.0,
            to_go_m: 40.0 - along_m,
            heading_deg: 0.0,
            speed_m_s: 3.0,
            finished,
        }
    }

    #[test]
    fn a_finished_mission_ends_the_run_with_its_lap_and_straights() {
        let mut t = MissionTrack::default();
        let auto = |w, along, cross, finished| {
            outputs(Mode::Auto, Some(status(w, along, cross, finished)))
        };
        assert!(!t.record(&outputs(Mode::Manual, None), 0));
        assert!(!t.record(&auto(1, 2.0, 0.5, false), 1_000_000_000));
        assert!(!t.record(&auto(1, 20.0, 0.3, false), 2_000_000_000));
        assert!(!t.record(&auto(1, 30.0, -0.4, false), 3_000_000_000));
        assert!(t.verdict(2, 3.0).unwrap_err().starts_with("timeout"));
        assert!(t.record(&auto(1, 39.5, 0.0, true), 11_000_000_000));
        assert_eq!(t.verdict(2, 11.0), Ok(()));
        assert_eq!(t.lap_s(), Some(10.0));
        // Only the samples 10 m past the start and 5 m before the end count.
        let (rms, max) = t.straights().unwrap();
        assert!((rms - (0.25f64 / 2.0).sqrt()).abs() < 1e-6, "{rms}");
        assert_eq!(max, 0.4);
        assert_eq!(t.closest_m, vec![f32::INFINITY, 0.5]);
        assert!(
            t.summary(2).contains("0: at the start, 1: 0.50 m"),
            "{}",
            t.summary(2)
        );
    }

    #[test]
    fn the_true_distance_is_taken_on_the_straights_only() {
        let at = |north_m, east_m| VehicleState {
            north_m,
            east_m,
            ..VehicleState::default()
        };
        let square = [(0.0, 0.0), (40.0, 0.0), (40.0, 40.0)];
        // Off the straights: near the start, the corner, and 5 m or more off the track.
        let off = [at(2.0, 0.3), at(39.0, 1.0), at(20.0, 6.0)];
        assert_eq!(true_straights(&off, &square), None);
        let on = [at(20.0, 0.3), at(40.4, 20.0), at(0.0, 0.0)];
        let (rms, max) = true_straights(&on, &square).unwrap();
        assert!((rms - (0.25f64 / 2.0).sqrt()).abs() < 1e-9, "{rms}");
        assert!((max - 0.4).abs() < 1e-9);
        let (n, e) = model_frame(
            48.0,
            11.0,
            48.0 + (40.0 / EARTH_RADIUS_M).to_degrees(),
            11.0,
        );
        assert!((n - 40.0).abs() < 1e-9 && e == 0.0);
    }

    #[test]
    fn a_failsafe_during_the_mission_ends_the_run_and_fails_it() {
        let mut t = MissionTrack::default();
        // A failsafe before the mission started is not the mission's.
        assert!(!t.record(&outputs(Mode::Failsafe, None), 0));
        assert!(t.verdict(3, 1.0).unwrap_err().contains("never started"));
        t.record(&outputs(Mode::Auto, Some(status(1, 2.0, 0.0, false))), 1);
        let mut out = outputs(Mode::Failsafe, None);
        out.cause = Some(FailsafeCause::GnssStale);
        assert!(t.record(&out, 2));
        assert!(t.ended());
        let why = t.verdict(3, 1.0).unwrap_err();
        assert!(why.starts_with("failsafe (GnssStale)"), "{why}");
    }
}
