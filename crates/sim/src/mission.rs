
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
        assert!(!t.record(&outputs(Mode::Manual, None), 0));
        assert!(!t.record(&outputs(Mode::Auto, Some(status(1, 2.0, 0.5, false))), 1_000_000_000));
        assert!(!t.record(&outputs(Mode::Auto, Some(status(1, 20.0, 0.3, false))), 2_000_000_000));
        assert!(!t.record(&outputs(Mode::Auto, Some(status(1, 30.0, -0.4, false))), 3_000_000_000));
        assert!(t.verdict(2, 3.0).unwrap_err().starts_with("timeout"));
        assert!(t.record(&outputs(Mode::Auto, Some(status(1, 39.5, 0.0, true))), 11_000_000_000));
        assert_eq!(t.verdict(2, 11.0), Ok(()));
        assert_eq!(t.lap_s(), Some(10.0));
        // Only the samples 10 m past the start and 5 m before the end count.
        let (rms, max) = t.straights().unwrap();
        assert!((rms - (0.25f64 / 2.0).sqrt()).abs() < 1e-6, "{rms}");
        assert_eq!(max, 0.4);
        assert_eq!(t.closest_m, vec![f32::INFINITY, 0.5]);
        assert!(t.summary(2).contains("0: at the start, 1: 0.50 m"), "{}", t.summary(2));
    }

    #[test]
    fn a_failsafe_during_the_mission_ends_the_run_and_fails_it() {
        let mut t = MissionTrack::default();
        // A failsafe before the mission started is not the mission's.
        assert!(!t.record(&outputs(Mode::Failsafe, None), 0));
        assert!(t.verdict(3, 1.0).unwrap_err().contains("never started"));
        t.record(&outputs(Mode::Auto, Some(status(1, 2.0, 0.0, false))), 1);
        let mut out = outputs(Mode::Failsafe, None);
        out.cause = Some(FailsafeCause::GnssLoss);
        assert!(t.record(&out, 2));
        assert!(t.ended());
        let why = t.verdict(3, 1.0).unwrap_err();
        assert!(why.starts_with("failsafe (GnssLoss)"), "{why}");
    }
}
