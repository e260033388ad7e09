//! Display frames v3: 156 bytes, robot -> ground station. Everything a display frame v2
//! carries, plus what the robot does: the servo targets it commanded, the AUTO setpoints in
//! force (or none), its speed and heading estimates, the speed error and the configured
//! controller kinds.
//!
//! Bytes 3-117 are those of a display frame v2, byte for byte; v3 fields are big-endian.
//!
//! | offset | content |
//! |---|---|
//! | 0-1 | start token `A5 46` |
//! | 2 | length, 156 |
//! | 3-117 | as in a display frame v2: mode, cause, refusal, session, sequence number, acknowledgement, health, version 1 payload |
//! | 118-119 | throttle servo target the robot commanded this cycle, u16, quarter-microseconds (the Maestro's unit; 0: nothing commanded yet) |
//! | 120-121 | steering servo target, u16, quarter-microseconds |
//! | 122-123 | tail servo target, u16, quarter-microseconds |
//! | 124 | presence bits: 0 speed setpoint, 1 heading setpoint, 2 speed estimate, 3 heading estimate, 4 speed error (other bits 0, ignored) |
//! | 125-128 | AUTO speed setpoint, i32, mm/s (0 when absent) |
//! | 129-132 | AUTO heading setpoint, i32, 1e-5 degrees (0 when absent) |
//! | 133-136 | estimated ground speed, i32, mm/s (0 when absent) |
//! | 137-140 | estimated heading, i32, 1e-5 degrees clockwise from north (0 when absent) |
//! | 141-144 | speed error, i32, mm/s: setpoint minus estimate (0 when absent) |
//! | 145-147 | controller kind of throttle, steering, tail: 0 none (neutral), 1 speed PID, 2 heading PID, 3 yaw rate (other values: a kind this decoder does not name) |
//! | 148-155 | SipHash-2-4 tag over bytes 0-147 |

use super::decoder::{AuthenticFrame, FrameDecoder, StreamStats};
use super::display::{DisplayFrame, DISPLAY_FRAME_LEN, DISPLAY_START};
use super::{be_u32, check_envelope, seal, FrameError, LinkKey, TAG_LEN};

/// Length of a display frame v3 on the wire, in bytes.
pub const DISPLAY_V3_FRAME_LEN: usize = 156;
/// Start token of a display frame v3.
pub const DISPLAY_V3_START: [u8; 2] = [0xA5, 0x46];

/// Where the fields a v2 frame carries end (exclusive): the v2 frame's tag offset.
const V2_FIELDS_END: usize = DISPLAY_FRAME_LEN - TAG_LEN;
const OUTPUTS_AT: usize = V2_FIELDS_END;
const PRESENT_AT: usize = OUTPUTS_AT + 6;
const SPEED_SETPOINT_AT: usize = PRESENT_AT + 1;
const HEADING_SETPOINT_AT: usize = SPEED_SETPOINT_AT + 4;
const SPEED_ESTIMATE_AT: usize = HEADING_SETPOINT_AT + 4;
const HEADING_ESTIMATE_AT: usize = SPEED_ESTIMATE_AT + 4;
const SPEED_ERROR_AT: usize = HEADING_ESTIMATE_AT + 4;
const KINDS_AT: usize = SPEED_ERROR_AT + 4;
const _: () = assert!(KINDS_AT + 3 + TAG_LEN == DISPLAY_V3_FRAME_LEN);

/// The optional i32 fields in wire order, each with its presence bit.
const OPTIONAL_AT: [usize; 5] = [
    SPEED_SETPOINT_AT,
    HEADING_SETPOINT_AT,
    SPEED_ESTIMATE_AT,
    HEADING_ESTIMATE_AT,
    SPEED_ERROR_AT,
];

/// The controller kind configured on a channel, as display frames v3 carry it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControllerCode {
    /// `none`: the channel stays neutral in AUTO.
    #[default]
    Neutral,
    /// `speed_pid`: PID on the ground-speed error.
    SpeedPid,
    /// `heading_pid`: PID on the heading error.
    HeadingPid,
    /// `yaw_rate`: PI on the yaw rate the steering demand asks for.
    YawRate,
    /// A kind this version of the decoder has no name for (its wire code, 4 or more).
    Other(u8),
}

impl ControllerCode {
    /// The kind for a wire byte.
    pub const fn from_code(code: u8) -> ControllerCode {
        match code {
            0 => ControllerCode::Neutral,
            1 => ControllerCode::SpeedPid,
            2 => ControllerCode::HeadingPid,
            3 => ControllerCode::YawRate,
            other => ControllerCode::Other(other),
        }
    }

    /// The wire byte of this kind.
    pub const fn code(self) -> u8 {
        match self {
            ControllerCode::Neutral => 0,
            ControllerCode::SpeedPid => 1,
            ControllerCode::HeadingPid => 2,
            ControllerCode::YawRate => 3,
            ControllerCode::Other(code) => code,
        }
    }

    /// The kind for a configuration name (`kind = "..."`); an unknown name is `Other(255)`.
    pub fn from_name(name: &str) -> ControllerCode {
        match name {
            "none" => ControllerCode::Neutral,
            "speed_pid" => ControllerCode::SpeedPid,
            "heading_pid" => ControllerCode::HeadingPid,
            "yaw_rate" => ControllerCode::YawRate,
            _ => ControllerCode::Other(255),
        }
    }

    /// The configuration name, `None` for a kind this version does not name.
    pub const fn name(self) -> Option<&'static str> {
        match self {
            ControllerCode::Neutral => Some("none"),
            ControllerCode::SpeedPid => Some("speed_pid"),
            ControllerCode::HeadingPid => Some("heading_pid"),
            ControllerCode::YawRate => Some("yaw_rate"),
            ControllerCode::Other(_) => None,
        }
    }
}

/// What the robot does this cycle: its outputs, its setpoints and its controllers' view.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Actuation {
    /// Servo targets the robot commanded the Maestro this cycle, throttle, steering, tail, in
    /// quarter-microseconds (the safe targets in KILLED and FAILSAFE; 0 before the robot's
    /// first cycle: nothing commanded yet).
    pub servo_quarter_us: [u16; 3],
    /// AUTO speed setpoint in force, mm/s; `None`: no speed setpoint.
    pub speed_setpoint_mm_s: Option<i32>,
    /// AUTO heading setpoint in force, 1e-5 degrees; `None`: no heading setpoint.
    pub heading_setpoint_deg_e5: Option<i32>,
    /// Estimated ground speed, mm/s; `None`: no valid estimate.
    pub speed_estimate_mm_s: Option<i32>,
    /// Estimated heading, 1e-5 degrees clockwise from north; `None`: no valid estimate.
    pub heading_estimate_deg_e5: Option<i32>,
    /// Speed setpoint minus estimated speed, mm/s; `None` unless both are known.
    pub speed_error_mm_s: Option<i32>,
    /// Configured controller kinds: throttle, steering, tail (they act only in AUTO).
    pub controllers: [ControllerCode; 3],
}

impl Actuation {
    /// The servo targets in microseconds (quarter-microseconds rounded to the nearest).
    pub fn servo_us(&self) -> [u16; 3] {
        self.servo_quarter_us
            .map(|q| ((u32::from(q) + 2) / 4) as u16)
    }

    fn optional(&self) -> [Option<i32>; 5] {
        [
            self.speed_setpoint_mm_s,
            self.heading_setpoint_deg_e5,
            self.speed_estimate_mm_s,
            self.heading_estimate_deg_e5,
            self.speed_error_mm_s,
        ]
    }
}

/// What the robot tells the ground station in each display frame v3.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DisplayFrameV3 {
    /// Everything a display frame v2 carries.
    pub status: DisplayFrame,
    /// What the robot does.
    pub actuation: Actuation,
}

impl DisplayFrameV3 {
    /// The 156-byte frame, tagged with `key`.
    pub fn encode(&self, key: &LinkKey) -> [u8; DISPLAY_V3_FRAME_LEN] {
        let mut frame = [0u8; DISPLAY_V3_FRAME_LEN];
        let v2 = self.status.encode(key);
        frame[3..V2_FIELDS_END].copy_from_slice(&v2[3..V2_FIELDS_END]);
        let a = &self.actuation;
        for (i, q) in a.servo_quarter_us.iter().enumerate() {
            let at = OUTPUTS_AT + 2 * i;
            frame[at..at + 2].copy_from_slice(&q.to_be_bytes());
        }
        let mut present = 0u8;
        for (bit, (value, at)) in a.optional().iter().zip(OPTIONAL_AT).enumerate() {
            if let Some(v) = value {
                present |= 1 << bit;
                frame[at..at + 4].copy_from_slice(&v.to_be_bytes());
            }
        }
        frame[PRESENT_AT] = present;
        for (i, kind) in a.controllers.iter().enumerate() {
            frame[KINDS_AT + i] = kind.code();
        }
        seal(&mut frame, DISPLAY_V3_START, key);
        frame
    }

    /// Decodes one complete frame: start token, length, tag, then the fields a v2 frame
    /// carries (checked as a v2 decoder checks them) and the v3 fields.
    pub fn decode(
        frame: &[u8; DISPLAY_V3_FRAME_LEN],
        key: &LinkKey,
    ) -> Result<DisplayFrameV3, FrameError> {
        check_envelope(frame, DISPLAY_V3_START, key)?;
        // The v2 fields, judged by the v2 decoder: rebuild a v2 frame around them.
        let mut v2 = [0u8; DISPLAY_FRAME_LEN];
        v2[3..V2_FIELDS_END].copy_from_slice(&frame[3..V2_FIELDS_END]);
        seal(&mut v2, DISPLAY_START, key);
        let status = DisplayFrame::decode(&v2, key)?;
        let mut servo_quarter_us = [0u16; 3];
        for (i, q) in servo_quarter_us.iter_mut().enumerate() {
            let at = OUTPUTS_AT + 2 * i;
            *q = u16::from_be_bytes([frame[at], frame[at + 1]]);
        }
        let present = frame[PRESENT_AT];
        let optional = |bit: usize| {
            let at = OPTIONAL_AT[bit];
            (present & (1 << bit) != 0).then(|| be_u32(frame, at) as i32)
        };
        Ok(DisplayFrameV3 {
            status,
            actuation: Actuation {
                servo_quarter_us,
                speed_setpoint_mm_s: optional(0),
                heading_setpoint_deg_e5: optional(1),
                speed_estimate_mm_s: optional(2),
                heading_estimate_deg_e5: optional(3),
                speed_error_mm_s: optional(4),
                controllers: [0, 1, 2].map(|i| ControllerCode::from_code(frame[KINDS_AT + i])),
            },
        })
    }
}

/// Finds authentic display frames v3 in a byte stream (see [`FrameDecoder`]).
pub type DisplayV3Decoder = FrameDecoder<DisplayFrameV3, DISPLAY_V3_FRAME_LEN>;

impl AuthenticFrame<DISPLAY_V3_FRAME_LEN> for DisplayFrameV3 {
    const START: [u8; 2] = DISPLAY_V3_START;

    fn decode_frame(
        frame: &[u8; DISPLAY_V3_FRAME_LEN],
        key: &LinkKey,
    ) -> Result<DisplayFrameV3, FrameError> {
        DisplayFrameV3::decode(frame, key)
    }
}

/// One authentic display frame of either version the robot may send.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Downlink {
    /// A display frame v2: mode, health and sensors, but not what the robot does.
    V2(DisplayFrame),
    /// A display frame v3: also the outputs, setpoints and controllers.
    V3(DisplayFrameV3),
}

impl Downlink {
    /// The fields every version carries.
    pub fn status(&self) -> &DisplayFrame {
        match self {
            Downlink::V2(frame) => frame,
            Downlink::V3(frame) => &frame.status,
        }
    }

    /// What the robot does, if its frame says (v3).
    pub fn actuation(&self) -> Option<&Actuation> {
        match self {
            Downlink::V2(_) => None,
            Downlink::V3(frame) => Some(&frame.actuation),
        }
    }
}

/// Finds authentic display frames v2 and v3 in one byte stream: a [`DisplayDecoder`] and a
/// [`DisplayV3Decoder`] see every byte, each finds its own frames.
///
/// [`DisplayDecoder`]: super::DisplayDecoder
#[derive(Debug, Clone)]
pub struct DownlinkDecoder {
    v2: super::DisplayDecoder,
    v3: DisplayV3Decoder,
    fed: u64,
}

impl DownlinkDecoder {
    /// An empty decoder that checks tags with `key`.
    pub fn new(key: LinkKey) -> DownlinkDecoder {
        DownlinkDecoder {
            v2: super::DisplayDecoder::new(key.clone()),
            v3: DisplayV3Decoder::new(key),
            fed: 0,
        }
    }

    /// Feeds one byte: at most one result per version (in stream order, v2 first).
    pub fn push(&mut self, byte: u8) -> [Option<Result<Downlink, FrameError>>; 2] {
        self.fed = self.fed.saturating_add(1);
        [
            self.v2.push(byte).map(|r| r.map(Downlink::V2)),
            self.v3.push(byte).map(|r| r.map(Downlink::V3)),
        ]
    }

    /// Feeds a chunk of bytes, yielding what [`push`](Self::push) yields for each of them.
    pub fn feed<'a>(
        &'a mut self,
        bytes: &'a [u8],
    ) -> impl Iterator<Item = Result<Downlink, FrameError>> + 'a {
        bytes
            .iter()
            .flat_map(move |&b| self.push(b).into_iter().flatten())
    }

    /// Forgets partial frames (e.g. after the port was reopened).
    pub fn reset(&mut self) {
        self.v2.reset();
        self.v3.reset();
    }

    /// Bytes held while waiting for the rest of a frame (the longer of the two).
    pub fn pending(&self) -> usize {
        self.v2.pending().max(self.v3.pending())
    }

    /// Counters of both versions: frames, bad tags and malformed frames added up; skipped
    /// bytes are those fed that are neither in a delivered frame nor pending.
    pub fn stats(&self) -> StreamStats {
        let (a, b) = (self.v2.stats(), self.v3.stats());
        let in_frames = u64::from(a.frames) * DISPLAY_FRAME_LEN as u64
            + u64::from(b.frames) * DISPLAY_V3_FRAME_LEN as u64;
        let skipped = self
            .fed
            .saturating_sub(in_frames)
            .saturating_sub(self.pending() as u64);
        StreamStats {
            frames: a.frames.saturating_add(b.frames),
            bad_tag: a.bad_tag.saturating_add(b.bad_tag),
            malformed: a.malformed.saturating_add(b.malformed),
            skipped_bytes: u32::try_from(skipped).unwrap_or(u32::MAX),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{FailsafeCause, Health, RobotMode};
    use super::*;
    use crate::display::DisplayFrame as SensorPayload;

    const KEY: LinkKey = LinkKey::from_bytes([0x5A; 16]);

    fn failsafe_with_safe_outputs() -> DisplayFrameV3 {
        DisplayFrameV3 {
            status: DisplayFrame {
                mode: RobotMode::Failsafe,
                failsafe_cause: Some(FailsafeCause::CommsLoss),
                session: 0x1122_3344,
                seq: 7,
                ack_seq: 3,
                health: Health {
                    commands: 9,
                    ..Health::default()
                },
                sensors: SensorPayload {
                    lat_e7: -340_885_000,
                    ..SensorPayload::default()
                },
                ..DisplayFrame::default()
            },
            actuation: Actuation {
                servo_quarter_us: [6000, 6004, 0x1234],
                speed_setpoint_mm_s: Some(1500),
                heading_setpoint_deg_e5: None,
                speed_estimate_mm_s: Some(-1),
                heading_estimate_deg_e5: None,
                speed_error_mm_s: Some(1501),
                controllers: [
                    ControllerCode::SpeedPid,
                    ControllerCode::Neutral,
                    ControllerCode::Other(9),
                ],
            },
        }
    }

    #[test]
    fn layout_offsets() {
        let frame = failsafe_with_safe_outputs();
        let bytes = frame.encode(&KEY);
        assert_eq!(&bytes[..3], &[0xA5, 0x46, 156]);
        // The v2 fields, byte for byte.
        let v2 = frame.status.encode(&KEY);
        assert_eq!(&bytes[3..118], &v2[3..118]);
        assert_eq!(&bytes[118..124], &[0x17, 0x70, 0x17, 0x74, 0x12, 0x34]);
        assert_eq!(bytes[124], 0b1_0101);
        assert_eq!(&bytes[125..129], &[0, 0, 0x05, 0xDC]);
        assert_eq!(&bytes[129..133], &[0; 4]);
        assert_eq!(&bytes[133..137], &[0xFF; 4]);
        assert_eq!(&bytes[141..145], &[0, 0, 0x05, 0xDD]);
        assert_eq!(&bytes[145..148], &[1, 0, 9]);
        assert_eq!(&bytes[148..], &KEY.tag(&bytes[..148]));
        assert_eq!(DisplayFrameV3::decode(&bytes, &KEY), Ok(frame));
        assert_eq!(frame.actuation.servo_us(), [1500, 1501, 1165]);
    }

    #[test]
    fn a_zero_setpoint_is_not_an_absent_one() {
        let mut frame = failsafe_with_safe_outputs();
        frame.actuation.speed_setpoint_mm_s = Some(0);
        frame.actuation.heading_setpoint_deg_e5 = Some(0);
        let decoded = DisplayFrameV3::decode(&frame.encode(&KEY), &KEY).unwrap();
        assert_eq!(decoded.actuation.speed_setpoint_mm_s, Some(0));
        assert_eq!(decoded.actuation.heading_setpoint_deg_e5, Some(0));
        frame.actuation.heading_setpoint_deg_e5 = None;
        let decoded = DisplayFrameV3::decode(&frame.encode(&KEY), &KEY).unwrap();
        assert_eq!(decoded.actuation.heading_setpoint_deg_e5, None);
    }

    #[test]
    fn unknown_mode_in_an_authentic_frame_is_malformed() {
        let mut bytes = failsafe_with_safe_outputs().encode(&KEY);
        bytes[3] = 9;
        seal(&mut bytes, DISPLAY_V3_START, &KEY);
        assert_eq!(
            DisplayFrameV3::decode(&bytes, &KEY),
            Err(FrameError::UnknownMode { found: 9 })
        );
    }
}
