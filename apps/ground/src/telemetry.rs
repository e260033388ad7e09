//! The onboard data the station shows: the latest display frame in physical units, the
//! scrolling plot series and the GNSS track.

use std::time::Instant;

use dima_groundlink::DisplayFrame;

use crate::plots::{TimeSeries, Track};
use crate::units::{Physical, SensorCalibration};

/// Seconds of history in the plots.
pub const PLOT_WINDOW_S: f64 = 120.0;
/// Points kept per series (display frames come at 2 Hz by default, at most 100 Hz).
pub const SERIES_CAPACITY: usize = 12_000;
/// Positions kept in the track.
pub const TRACK_CAPACITY: usize = 20_000;

/// The latest frame and the history built from the frames.
#[derive(Debug, Clone)]
pub struct Telemetry {
    t0: Instant,
    calibration: Option<SensorCalibration>,
    /// The latest frame, its arrival and its physical values.
    pub latest: Option<(Instant, DisplayFrame, Physical)>,
    /// Acceleration X, Y, Z, m/s².
    pub acc: [TimeSeries; 3],
    /// Angular rate X, Y, Z, °/s.
    pub gyro: [TimeSeries; 3],
    /// Ground speed, m/s.
    pub speed: TimeSeries,
    /// Heading of motion, degrees.
    pub heading: TimeSeries,
    /// GNSS positions in local metres.
    pub track: Track,
}

impl Telemetry {
    /// Empty; plot times are seconds since `t0`.
    pub fn new(t0: Instant, calibration: Option<SensorCalibration>) -> Telemetry {
        let series = || TimeSeries::new(PLOT_WINDOW_S, SERIES_CAPACITY);
        Telemetry {
            t0,
            calibration,
            latest: None,
            acc: [series(), series(), series()],
            gyro: [series(), series(), series()],
            speed: series(),
            heading: series(),
            track: Track::new(TRACK_CAPACITY),
        }
    }

    /// The calibration in use.
    pub fn calibration(&self) -> Option<&SensorCalibration> {
        self.calibration.as_ref()
    }

    /// Plot time of `at`, s.
    pub fn t_s(&self, at: Instant) -> f64 {
        at.saturating_duration_since(self.t0).as_secs_f64()
    }

    /// Takes one frame received at `at`.
    pub fn ingest(&mut self, at: Instant, frame: DisplayFrame) {
        let p = Physical::from_frame(&frame, self.calibration.as_ref());
        let t = self.t_s(at);
        for i in 0..3 {
            self.acc[i].push(t, f64::from(p.acc_m_s2[i]));
            self.gyro[i].push(t, f64::from(p.gyro_dps[i]));
        }
        self.speed.push(t, p.ground_speed_m_s);
        self.heading.push(t, p.heading_deg);
        if p.has_position() {
            self.track.push(p.lat_deg, p.lon_deg);
        }
        self.latest = Some((at, frame, p));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn frames_fill_series_and_track() {
        let t0 = Instant::now();
        let mut tm = Telemetry::new(t0, None);
        let mut frame = DisplayFrame {
            acc: [0, 0, 1020],
            g_speed_mm_s: 2_000,
            head_mot_deg_e5: 9_000_000,
            lat_e7: 473_769_000,
            lon_e7: 85_417_000,
            ..DisplayFrame::default()
        };
        tm.ingest(t0 + Duration::from_millis(500), frame);
        frame.lat_e7 += 1_000; // 0.0001° north: 11.1 m
        tm.ingest(t0 + Duration::from_millis(1_000), frame);
        tm.ingest(t0 + Duration::from_millis(1_500), DisplayFrame::default());
        assert_eq!(tm.speed.points()[..2], [[0.5, 2.0], [1.0, 2.0]]);
        assert!((tm.heading.points()[1][1] - 90.0).abs() < 1e-9);
        // 1020 counts at ±2 g (2 g over 2048 counts): 996.1 mg.
        assert!((tm.acc[2].points()[0][1] - 9.768).abs() < 0.001);
        let track = tm.track.points();
        assert_eq!(
            track.len(),
            2,
            "a frame without a position is not a track point"
        );
        assert!((track[1][1] - 11.12).abs() < 0.01, "{track:?}");
        assert_eq!(tm.latest.unwrap().1, DisplayFrame::default());
    }
}
