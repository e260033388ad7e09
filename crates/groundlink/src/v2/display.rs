//! Display frames v2: 126 bytes, robot -> ground station.
//!
//! Version 2 fields are big-endian; the embedded version 1 payload keeps its own little-endian
//! layout, byte for byte.
//!
//! | offset | content |
//! |---|---|
//! | 0-1 | start token `A5 44` |
//! | 2 | length, 126 |
//! | 3 | robot mode: 0 KILLED, 1 MANUAL, 2 AUTO, 3 FAILSAFE |
//! | 4 | failsafe cause: 0 none, 1 comms loss, 2 sensor loss, 3 IMU stuck, 4 overruns, 5 GNSS stale (other values: a cause this decoder does not name) |
//! | 5 | last revive refusal: 0 none, 1 sensor loss, 2 IMU stuck, 3 overruns, 4 realtime setup, 5 too soon after the last kill or revive |
//! | 6-9 | session id, u32 |
//! | 10-13 | downlink sequence number, u32 (starts at 1) |
//! | 14-17 | acknowledgement: sequence number of the last accepted command, u32 (0: none yet) |
//! | 18-53 | [`Health`]: nine u32 counters, in its field order |
//! | 54-117 | version 1 display payload (bytes 0-63 of a version 1 display frame: sensor values and GNSS) |
//! | 118-125 | SipHash-2-4 tag over bytes 0-117 |

use super::decoder::{AuthenticFrame, FrameDecoder, StreamStats};
use super::{be_u32, check_envelope, seal, FrameError, LinkKey};
use crate::display::{DisplayFrame as SensorPayload, PAYLOAD_LEN};

/// Length of a display frame v2 on the wire, in bytes.
pub const DISPLAY_FRAME_LEN: usize = 126;
/// Start token of a display frame v2.
pub const DISPLAY_START: [u8; 2] = [0xA5, 0x44];

const HEALTH_AT: usize = 18;
const HEALTH_COUNTERS: usize = 9;
const SENSORS_AT: usize = HEALTH_AT + 4 * HEALTH_COUNTERS;
const _: () = assert!(SENSORS_AT + PAYLOAD_LEN + super::TAG_LEN == DISPLAY_FRAME_LEN);

/// The robot's operating mode, as the ground station shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum RobotMode {
    /// Outputs safe; waiting for a revive (the start-up mode).
    #[default]
    Killed = 0,
    /// The operator drives throttle, steering and tail.
    Manual = 1,
    /// The controllers follow speed and heading setpoints.
    Auto = 2,
    /// Outputs safe after a fault; latched until a revive on a healthy link.
    Failsafe = 3,
}

impl RobotMode {
    /// The mode for a wire byte, `None` for values this version does not define.
    pub const fn from_byte(byte: u8) -> Option<RobotMode> {
        Some(match byte {
            0 => RobotMode::Killed,
            1 => RobotMode::Manual,
            2 => RobotMode::Auto,
            3 => RobotMode::Failsafe,
            _ => return None,
        })
    }
}

/// Why the robot is (or last was) in FAILSAFE.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FailsafeCause {
    /// No valid command frame for the comms-loss timeout.
    CommsLoss,
    /// Too many consecutive bad or missing sensor packets.
    SensorLoss,
    /// The IMU repeated identical words for too long.
    ImuStuck,
    /// Too many loop overruns.
    Overrun,
    /// No new GNSS solution for too long.
    GnssStale,
    /// The car rolled over (on its side or roof for too long).
    Rollover,
    /// A GNSS fix outside the geofence.
    Geofence,
    /// A cause this version of the decoder has no name for (its nonzero wire code).
    Other(u8),
}

impl FailsafeCause {
    /// The cause for a wire byte; 0 means none.
    pub const fn from_code(code: u8) -> Option<FailsafeCause> {
        Some(match code {
            0 => return None,
            1 => FailsafeCause::CommsLoss,
            2 => FailsafeCause::SensorLoss,
            3 => FailsafeCause::ImuStuck,
            4 => FailsafeCause::Overrun,
            5 => FailsafeCause::GnssStale,
            6 => FailsafeCause::Rollover,
            7 => FailsafeCause::Geofence,
            other => FailsafeCause::Other(other),
        })
    }

    /// The wire byte of `cause` (0 for none).
    pub const fn code(cause: Option<FailsafeCause>) -> u8 {
        match cause {
            None => 0,
            Some(FailsafeCause::CommsLoss) => 1,
            Some(FailsafeCause::SensorLoss) => 2,
            Some(FailsafeCause::ImuStuck) => 3,
            Some(FailsafeCause::Overrun) => 4,
            Some(FailsafeCause::GnssStale) => 5,
            Some(FailsafeCause::Rollover) => 6,
            Some(FailsafeCause::Geofence) => 7,
            Some(FailsafeCause::Other(code)) => code,
        }
    }
}

/// Why the robot refused the last revive.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ReviveRefusal {
    /// Sensor packets are bad or missing.
    SensorLoss,
    /// The IMU is stuck.
    ImuStuck,
    /// The loop overruns too often.
    Overrun,
    /// The realtime setup (priority, memory locking) failed and the configuration requires it.
    RealtimeSetup,
    /// Too soon after the last kill or revive (the robot rate-limits revives).
    TooSoon,
    /// The car is not on its wheels.
    RolledOver,
    /// Outside the geofence, or no fresh GNSS fix to tell.
    OutsideFence,
    /// A reason this version of the decoder has no name for (its nonzero wire code).
    Other(u8),
}

impl ReviveRefusal {
    /// The refusal for a wire byte; 0 means none.
    pub const fn from_code(code: u8) -> Option<ReviveRefusal> {
        Some(match code {
            0 => return None,
            1 => ReviveRefusal::SensorLoss,
            2 => ReviveRefusal::ImuStuck,
            3 => ReviveRefusal::Overrun,
            4 => ReviveRefusal::RealtimeSetup,
            5 => ReviveRefusal::TooSoon,
            6 => ReviveRefusal::RolledOver,
            7 => ReviveRefusal::OutsideFence,
            other => ReviveRefusal::Other(other),
        })
    }

    /// The wire byte of `refusal` (0 for none).
    pub const fn code(refusal: Option<ReviveRefusal>) -> u8 {
        match refusal {
            None => 0,
            Some(ReviveRefusal::SensorLoss) => 1,
            Some(ReviveRefusal::ImuStuck) => 2,
            Some(ReviveRefusal::Overrun) => 3,
            Some(ReviveRefusal::RealtimeSetup) => 4,
            Some(ReviveRefusal::TooSoon) => 5,
            Some(ReviveRefusal::RolledOver) => 6,
            Some(ReviveRefusal::OutsideFence) => 7,
            Some(ReviveRefusal::Other(code)) => code,
        }
    }
}

/// Health counters since the robot started (each saturates at `u32::MAX`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Control periods missed (loop overruns).
    pub missed_periods: u32,
    /// Sensor packets rejected (CRC, stale or late).
    pub sensor_bad: u32,
    /// Cycles without a sensor packet.
    pub sensor_missing: u32,
    /// Commands accepted.
    pub commands: u32,
    /// Command frames rejected: tag did not match.
    pub bad_tag: u32,
    /// Command frames rejected: sequence number not newer than the last accepted one.
    pub replayed: u32,
    /// Command frames rejected: authentic but for another session.
    pub stale_session: u32,
    /// Command frames rejected: wrong length, unknown type or out-of-range data.
    pub malformed: u32,
    /// Version 1 command frames ignored because the robot requires authentication.
    pub v1_ignored: u32,
}

impl Health {
    fn to_array(self) -> [u32; HEALTH_COUNTERS] {
        [
            self.missed_periods,
            self.sensor_bad,
            self.sensor_missing,
            self.commands,
            self.bad_tag,
            self.replayed,
            self.stale_session,
            self.malformed,
            self.v1_ignored,
        ]
    }

    fn from_array(c: [u32; HEALTH_COUNTERS]) -> Health {
        Health {
            missed_periods: c[0],
            sensor_bad: c[1],
            sensor_missing: c[2],
            commands: c[3],
            bad_tag: c[4],
            replayed: c[5],
            stale_session: c[6],
            malformed: c[7],
            v1_ignored: c[8],
        }
    }
}

/// What the robot tells the ground station in each display frame v2.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DisplayFrame {
    /// The robot's mode.
    pub mode: RobotMode,
    /// Why the robot is (or last was) in FAILSAFE; `None` if it never was since the last revive.
    pub failsafe_cause: Option<FailsafeCause>,
    /// Why the last revive was refused, if it was.
    pub revive_refusal: Option<ReviveRefusal>,
    /// The robot's session id for this boot (command frames must carry it).
    pub session: u32,
    /// Downlink sequence number: increases by one per display frame.
    pub seq: u32,
    /// Sequence number of the last accepted command of this session (0: none yet).
    pub ack_seq: u32,
    /// Health counters.
    pub health: Health,
    /// Sensor values and the GNSS solution (the version 1 display payload).
    pub sensors: SensorPayload,
}

impl DisplayFrame {
    /// The 126-byte frame, tagged with `key`.
    pub fn encode(&self, key: &LinkKey) -> [u8; DISPLAY_FRAME_LEN] {
        let mut frame = [0u8; DISPLAY_FRAME_LEN];
        frame[3] = self.mode as u8;
        frame[4] = FailsafeCause::code(self.failsafe_cause);
        frame[5] = ReviveRefusal::code(self.revive_refusal);
        frame[6..10].copy_from_slice(&self.session.to_be_bytes());
        frame[10..14].copy_from_slice(&self.seq.to_be_bytes());
        frame[14..18].copy_from_slice(&self.ack_seq.to_be_bytes());
        for (i, counter) in self.health.to_array().iter().enumerate() {
            let at = HEALTH_AT + 4 * i;
            frame[at..at + 4].copy_from_slice(&counter.to_be_bytes());
        }
        frame[SENSORS_AT..SENSORS_AT + PAYLOAD_LEN].copy_from_slice(&self.sensors.payload());
        seal(&mut frame, DISPLAY_START, key);
        frame
    }

    /// Decodes one complete frame: start token, length, tag, then mode and sensor ranges.
    pub fn decode(
        frame: &[u8; DISPLAY_FRAME_LEN],
        key: &LinkKey,
    ) -> Result<DisplayFrame, FrameError> {
        check_envelope(frame, DISPLAY_START, key)?;
        let mode =
            RobotMode::from_byte(frame[3]).ok_or(FrameError::UnknownMode { found: frame[3] })?;
        let mut counters = [0u32; HEALTH_COUNTERS];
        for (i, counter) in counters.iter_mut().enumerate() {
            *counter = be_u32(frame, HEALTH_AT + 4 * i);
        }
        let mut payload = [0u8; PAYLOAD_LEN];
        payload.copy_from_slice(&frame[SENSORS_AT..SENSORS_AT + PAYLOAD_LEN]);
        let sensors = SensorPayload::from_payload(&payload).map_err(FrameError::Display)?;
        Ok(DisplayFrame {
            mode,
            failsafe_cause: FailsafeCause::from_code(frame[4]),
            revive_refusal: ReviveRefusal::from_code(frame[5]),
            session: be_u32(frame, 6),
            seq: be_u32(frame, 10),
            ack_seq: be_u32(frame, 14),
            health: Health::from_array(counters),
            sensors,
        })
    }
}

/// What a [`DisplayDecoder`] has seen since it was created.
pub type DisplayStats = StreamStats;

/// Finds authentic display frames v2 in a byte stream, whatever the read boundaries are
/// (see [`FrameDecoder`] for how it resynchronises and what it counts).
pub type DisplayDecoder = FrameDecoder<DisplayFrame, DISPLAY_FRAME_LEN>;

impl AuthenticFrame<DISPLAY_FRAME_LEN> for DisplayFrame {
    const START: [u8; 2] = DISPLAY_START;

    fn decode_frame(
        frame: &[u8; DISPLAY_FRAME_LEN],
        key: &LinkKey,
    ) -> Result<DisplayFrame, FrameError> {
        DisplayFrame::decode(frame, key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KEY: LinkKey = LinkKey::from_bytes([0x5A; 16]);

    #[test]
    fn layout_offsets() {
        let sensors = SensorPayload {
            acc: [-1, 2, -3],
            lat_e7: -340_885_000,
            head_mot_deg_e5: 16,
            ..SensorPayload::default()
        };
        let frame = DisplayFrame {
            mode: RobotMode::Failsafe,
            failsafe_cause: Some(FailsafeCause::CommsLoss),
            revive_refusal: Some(ReviveRefusal::RealtimeSetup),
            session: 0x1122_3344,
            seq: 5,
            ack_seq: 0x0A0B_0C0D,
            health: Health {
                missed_periods: 1,
                v1_ignored: 0x0102_0304,
                ..Health::default()
            },
            sensors,
        };
        let bytes = frame.encode(&KEY);
        assert_eq!(&bytes[..6], &[0xA5, 0x44, 126, 3, 1, 4]);
        assert_eq!(&bytes[6..10], &[0x11, 0x22, 0x33, 0x44]);
        assert_eq!(&bytes[10..14], &[0, 0, 0, 5]);
        assert_eq!(&bytes[14..18], &[0x0A, 0x0B, 0x0C, 0x0D]);
        assert_eq!(&bytes[18..22], &[0, 0, 0, 1]);
        assert_eq!(&bytes[50..54], &[1, 2, 3, 4]);
        // The version 1 payload, byte for byte.
        assert_eq!(&bytes[54..118], &sensors.encode()[..64]);
        assert_eq!(&bytes[118..], &KEY.tag(&bytes[..118]));
        assert_eq!(DisplayFrame::decode(&bytes, &KEY), Ok(frame));
    }

    #[test]
    fn every_cause_and_refusal_has_its_own_code_and_comes_back() {
        use FailsafeCause as C;
        use ReviveRefusal as R;
        let causes = [
            (C::CommsLoss, 1),
            (C::SensorLoss, 2),
            (C::ImuStuck, 3),
            (C::Overrun, 4),
            (C::GnssStale, 5),
            (C::Rollover, 6),
            (C::Geofence, 7),
        ];
        for (cause, code) in causes {
            assert_eq!(C::code(Some(cause)), code, "{cause:?}");
            assert_eq!(C::from_code(code), Some(cause));
        }
        let refusals = [
            (R::SensorLoss, 1),
            (R::ImuStuck, 2),
            (R::Overrun, 3),
            (R::RealtimeSetup, 4),
            (R::TooSoon, 5),
            (R::RolledOver, 6),
            (R::OutsideFence, 7),
        ];
        for (refusal, code) in refusals {
            assert_eq!(R::code(Some(refusal)), code, "{refusal:?}");
            assert_eq!(R::from_code(code), Some(refusal));
        }
        assert_eq!(C::from_code(8), Some(C::Other(8)));
        assert_eq!(R::from_code(8), Some(R::Other(8)));
    }

    #[test]
    fn unknown_causes_survive_and_unknown_modes_are_malformed() {
        let frame = DisplayFrame {
            failsafe_cause: Some(FailsafeCause::Other(200)),
            ..DisplayFrame::default()
        };
        let decoded = DisplayFrame::decode(&frame.encode(&KEY), &KEY).unwrap();
        assert_eq!(decoded.failsafe_cause, Some(FailsafeCause::Other(200)));

        let mut bytes = frame.encode(&KEY);
        bytes[3] = 4;
        seal(&mut bytes, DISPLAY_START, &KEY);
        assert_eq!(
            DisplayFrame::decode(&bytes, &KEY),
            Err(FrameError::UnknownMode { found: 4 })
        );
    }
}
