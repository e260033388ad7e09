//! What the station shows, built from a log's events: the link status and the telemetry the
//! panels draw, as the live link builds them. Bytes go through the decoders the link uses
//! (display frames v1 without a key; v2 and v3 under the key, numbered by a station's
//! downlink bookkeeping), with the same counting.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use dima_groundlink::station::Station;
use dima_groundlink::v2::{self, Downlink, LinkKey};
use dima_groundlink::{Command, CommandType, DisplayDecoder, DisplayFrame};

use crate::downlink::V2TokenSpotter;
use crate::link::{authentic_frames, LinkState, LinkStatus, RATE_WINDOW};
use crate::recording::{CommandRecord, DisplayRecord, LinkRecord, RobotRecord};
use crate::telemetry::Telemetry;
use crate::units::{Physical, SensorCalibration};

use super::source::{LogKind, ReplayEvent};

/// The decoders of the version the session spoke.
#[derive(Clone)]
enum Decoders {
    /// Ground link v1 (no key).
    V1 {
        decoder: DisplayDecoder,
        spotter: V2TokenSpotter,
        resyncing: bool,
    },
    /// Ground link v2 (a key): display frames v2 and v3.
    V2 {
        decoder: Box<v2::DownlinkDecoder>,
        station: Box<Station>,
    },
}

/// The station's state at a log time. Log time `t` is the instant `base + t`, so the panels
/// judge ages and freshness against [`ReplayState::instant`] of the replay's position.
#[derive(Clone)]
pub struct ReplayState {
    base: Instant,
    /// The link status the panels show.
    pub status: LinkStatus,
    /// The telemetry the plots and the onboard panel show (plot time: log seconds).
    pub telemetry: Telemetry,
    /// The record of the last display frame shown, as the live link records it.
    pub last_display: Option<DisplayRecord>,
    decoders: Decoders,
    calibration: Option<SensorCalibration>,
    recent_frames: VecDeque<Instant>,
}

impl ReplayState {
    /// Nothing seen yet. A robot log's reports come as authentic reports (the robot wrote
    /// them); a station log's bytes are decoded with `key` (v2) or as v1 without it.
    pub fn new(
        base: Instant,
        kind: LogKind,
        key: Option<LinkKey>,
        calibration: Option<SensorCalibration>,
    ) -> ReplayState {
        let authenticated = kind == LogKind::Robot || key.is_some();
        let decoders = match key {
            Some(key) => Decoders::V2 {
                decoder: Box::new(v2::DownlinkDecoder::new(key)),
                station: Box::default(),
            },
            None => Decoders::V1 {
                decoder: DisplayDecoder::new(),
                spotter: V2TokenSpotter::default(),
                resyncing: false,
            },
        };
        let mut status = LinkStatus {
            authenticated,
            ..LinkStatus::default()
        };
        if kind == LogKind::Robot {
            // The robot's own log: its reports arrive over a link that is always up.
            status.state = LinkState::Connected;
            status.connected_at = Some(base);
        }
        ReplayState {
            base,
            status,
            telemetry: Telemetry::new(base, calibration.clone()),
            last_display: None,
            decoders,
            calibration,
            recent_frames: VecDeque::new(),
        }
    }

    /// The instant that stands for log time `t`.
    pub fn instant(&self, t: Duration) -> Instant {
        self.base + t
    }

    /// Applies one event at log time `at`.
    pub fn apply(&mut self, at: Duration, event: &ReplayEvent) {
        let now = self.instant(at);
        match event {
            ReplayEvent::Bytes(bytes) => self.take_bytes(at, bytes),
            ReplayEvent::Link(record) => self.link_event(now, record),
            ReplayEvent::Sent(record) => self.sent(now, record),
            ReplayEvent::Report(downlink) => {
                self.status.bytes_in += v2::DISPLAY_V3_FRAME_LEN as u64;
                self.status.last_byte_at = Some(now);
                self.report(now, downlink);
            }
        }
        self.update_rate(now);
    }

    /// A command frame the session sent: counted and listed as the link lists it.
    fn sent(&mut self, now: Instant, record: &CommandRecord) {
        self.status.frames_out += 1;
        self.status.bytes_out += record.frame_hex.len() as u64 / 2;
        let command = CommandType::from_byte(record.kind)
            .and_then(|kind| Command::from_parts(kind, record.data).ok());
        if let Some(command) = command {
            self.status.last_sent[command.command_type() as usize] = Some((now, command));
        }
    }

    fn link_event(&mut self, now: Instant, record: &LinkRecord) {
        match record.event.as_str() {
            "connected" => {
                self.status.state = LinkState::Connected;
                self.status.connected_at = Some(now);
                self.status.opens += 1;
                self.status.port = record.port.as_ref().map(Into::into);
                self.status.baud = record.baud.unwrap_or(self.status.baud);
                self.status.last_error = None;
                match &mut self.decoders {
                    Decoders::V1 {
                        decoder, resyncing, ..
                    } => {
                        decoder.reset();
                        *resyncing = false;
                    }
                    Decoders::V2 { decoder, .. } => decoder.reset(),
                }
            }
            "disconnected" => {
                self.status.state = LinkState::Disconnected;
                self.status.connected_at = None;
            }
            "lost" => {
                self.status.state = LinkState::Waiting;
                self.status.connected_at = None;
                self.status.last_error = record.detail.clone();
            }
            "error" => self.status.last_error = record.detail.clone(),
            _ => {}
        }
    }

    /// Bytes as the link thread takes them.
    fn take_bytes(&mut self, at: Duration, bytes: &[u8]) {
        let now = self.instant(at);
        self.status.bytes_in += bytes.len() as u64;
        self.status.last_byte_at = Some(now);
        match &mut self.decoders {
            Decoders::V1 {
                decoder,
                spotter,
                resyncing,
            } => {
                if spotter.feed(bytes) {
                    self.status.v2_token_at = Some(now);
                }
                let mut frames = Vec::new();
                for &b in bytes {
                    let skipped_before = decoder.stats().skipped_bytes;
                    let result = decoder.push(b);
                    if decoder.stats().skipped_bytes > skipped_before && !*resyncing {
                        *resyncing = true;
                        self.status.crc_errors += 1;
                    }
                    match result {
                        Some(Ok(frame)) => {
                            *resyncing = false;
                            frames.push(frame);
                        }
                        Some(Err(_)) => *resyncing = false,
                        None => {}
                    }
                }
                let stats = decoder.stats();
                self.status.skipped_bytes = u64::from(stats.skipped_bytes);
                self.status.out_of_range = u64::from(stats.out_of_range);
                for frame in frames {
                    self.deliver(now, frame, None);
                }
            }
            Decoders::V2 { decoder, station } => {
                let frames = authentic_frames(decoder, station, bytes, at);
                self.status.count_v2_decoding(decoder.stats(), now);
                for downlink in frames {
                    self.report(now, &downlink);
                }
            }
        }
    }

    /// An authentic report: the robot's state, then its sensors.
    fn report(&mut self, now: Instant, downlink: &Downlink) {
        let record = self.status.take_report(now, downlink);
        self.deliver(now, downlink.status().sensors, Some(record));
    }

    /// A valid display frame: counted, recorded as the link records it, and shown.
    fn deliver(&mut self, now: Instant, frame: DisplayFrame, robot: Option<RobotRecord>) {
        self.status.frames_in += 1;
        self.status.last_frame_at = Some(now);
        self.recent_frames.push_back(now);
        let physical = Physical::from_frame(&frame, self.calibration.as_ref());
        let mut record = DisplayRecord::new(&frame, &physical);
        record.robot = robot;
        self.last_display = Some(record);
        self.telemetry.ingest(now, frame);
    }

    /// Frames per second over the last [`RATE_WINDOW`] of log time.
    fn update_rate(&mut self, now: Instant) {
        while self
            .recent_frames
            .front()
            .is_some_and(|t| now.saturating_duration_since(*t) > RATE_WINDOW)
        {
            self.recent_frames.pop_front();
        }
        let span = self
            .status
            .connected_at
            .map_or(RATE_WINDOW, |t| now.saturating_duration_since(t))
            .clamp(Duration::from_secs(1), RATE_WINDOW);
        self.status.frames_per_s = self.recent_frames.len() as f64 / span.as_secs_f64();
    }
}
