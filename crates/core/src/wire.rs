//! The core's modes, failsafe causes and revive refusals as the ground link's display frames
//! carry them: one mapping for the robot that sends them and for a tool that rebuilds them
//! from a log (the station's replay).

use dima_groundlink::v2;

use crate::safety::{FailsafeCause, Mode, ReviveRefusal};

impl From<Mode> for v2::RobotMode {
    fn from(mode: Mode) -> v2::RobotMode {
        match mode {
            Mode::Killed => v2::RobotMode::Killed,
            Mode::Manual => v2::RobotMode::Manual,
            Mode::Auto => v2::RobotMode::Auto,
            Mode::Failsafe => v2::RobotMode::Failsafe,
        }
    }
}

impl From<FailsafeCause> for v2::FailsafeCause {
    fn from(cause: FailsafeCause) -> v2::FailsafeCause {
        match cause {
            FailsafeCause::CommsLoss => v2::FailsafeCause::CommsLoss,
            FailsafeCause::SensorLoss => v2::FailsafeCause::SensorLoss,
            FailsafeCause::ImuStuck => v2::FailsafeCause::ImuStuck,
            FailsafeCause::Overrun => v2::FailsafeCause::Overrun,
            FailsafeCause::GnssStale => v2::FailsafeCause::GnssStale,
            FailsafeCause::Rollover => v2::FailsafeCause::Rollover,
            FailsafeCause::Geofence => v2::FailsafeCause::Geofence,
        }
    }
}

impl From<ReviveRefusal> for v2::ReviveRefusal {
    fn from(refusal: ReviveRefusal) -> v2::ReviveRefusal {
        match refusal {
            ReviveRefusal::SensorLoss => v2::ReviveRefusal::SensorLoss,
            ReviveRefusal::ImuStuck => v2::ReviveRefusal::ImuStuck,
            ReviveRefusal::Overrun => v2::ReviveRefusal::Overrun,
            ReviveRefusal::RealtimeSetup => v2::ReviveRefusal::RealtimeSetup,
            ReviveRefusal::TooSoon => v2::ReviveRefusal::TooSoon,
            ReviveRefusal::RolledOver => v2::ReviveRefusal::RolledOver,
            ReviveRefusal::OutsideFence => v2::ReviveRefusal::OutsideFence,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_cause_and_refusal_goes_out_under_its_own_code() {
        let causes = [
            (FailsafeCause::CommsLoss, 1),
            (FailsafeCause::SensorLoss, 2),
            (FailsafeCause::ImuStuck, 3),
            (FailsafeCause::Overrun, 4),
            (FailsafeCause::GnssStale, 5),
            (FailsafeCause::Rollover, 6),
            (FailsafeCause::Geofence, 7),
        ];
        for (cause, code) in causes {
            assert_eq!(
                v2::FailsafeCause::code(Some(cause.into())),
                code,
                "{cause:?}"
            );
        }
        let refusals = [
            (ReviveRefusal::SensorLoss, 1),
            (ReviveRefusal::ImuStuck, 2),
            (ReviveRefusal::Overrun, 3),
            (ReviveRefusal::RealtimeSetup, 4),
            (ReviveRefusal::TooSoon, 5),
            (ReviveRefusal::RolledOver, 6),
            (ReviveRefusal::OutsideFence, 7),
        ];
        for (refusal, code) in refusals {
            assert_eq!(
                v2::ReviveRefusal::code(Some(refusal.into())),
                code,
                "{refusal:?}"
            );
        }
        assert_eq!(v2::RobotMode::from(Mode::Failsafe) as u8, 3);
    }
}
