//! Fault injection per link: bit errors, byte drops and insertions, added delay and jitter,
//! silent periods and disconnects at given times; and faults of the devices themselves: a
//! frozen or lost GNSS solution, a stuck IMU, and extra work inside the application's realtime
//! cycle.
//!
//! A [`FaultSpec`] is plain data (from the command line: `--fault sensor:ber=1e-3`); a
//! [`FaultInjector`] applies it to each frame a simulated device sends and counts what it did,
//! so tests can compare what the application accepted with what arrived intact.

use std::fmt;
use std::str::FromStr;
use std::time::Duration;

use crate::rng::SimRng;

/// A time window of a run, seconds from the start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// Start, s.
    pub start_s: f64,
    /// Length, s.
    pub duration_s: f64,
}

impl Window {
    /// Whether `t_s` falls inside.
    pub fn contains(&self, t_s: f64) -> bool {
        t_s >= self.start_s && t_s < self.start_s + self.duration_s
    }
}

impl FromStr for Window {
    type Err = FaultParseError;

    /// `START+DURATION` in seconds, e.g. `5+2`.
    fn from_str(s: &str) -> Result<Window, FaultParseError> {
        let bad = || FaultParseError(format!("window `{s}`: expected START+DURATION seconds"));
        let (a, b) = s.split_once('+').ok_or_else(bad)?;
        let start_s: f64 = a.trim().parse().map_err(|_| bad())?;
        let duration_s: f64 = b.trim().parse().map_err(|_| bad())?;
        if !(start_s >= 0.0 && duration_s > 0.0) {
            return Err(bad());
        }
        Ok(Window {
            start_s,
            duration_s,
        })
    }
}

/// Which link a fault applies to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Link {
    /// Sensor board -> application (UART).
    Sensor,
    /// Ground station -> application (XBee).
    Ground,
    /// Application -> Maestro (USB serial).
    Maestro,
}

/// What can go wrong on one link.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FaultSpec {
    /// Probability that any one bit is flipped.
    pub ber: f64,
    /// Probability that any one byte is lost.
    pub drop_rate: f64,
    /// Probability that a random byte is inserted before any one byte.
    pub insert_rate: f64,
    /// Delay added to every frame, ms.
    pub delay_ms: f64,
    /// Uniform extra delay `0..jitter_ms` per frame, ms.
    pub jitter_ms: f64,
    /// Windows in which the device sends nothing.
    pub silences: Vec<Window>,
    /// Windows in which the device is unplugged (pty closed, reopened at the end).
    pub disconnects: Vec<Window>,
}

/// A `--fault` argument that could not be understood.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct FaultParseError(pub String);

impl FaultSpec {
    /// Whether this spec changes anything.
    pub fn is_nominal(&self) -> bool {
        *self == FaultSpec::default()
    }

    /// Applies one `KEY=VALUE` setting: `ber`, `drop`, `insert` (probabilities), `delay`,
    /// `jitter` (ms), `silence`, `disconnect` (`START+DURATION` s, repeatable).
    pub fn set(&mut self, setting: &str) -> Result<(), FaultParseError> {
        let (key, value) = setting
            .split_once('=')
            .ok_or_else(|| FaultParseError(format!("`{setting}`: expected KEY=VALUE")))?;
        let number = |v: &str| -> Result<f64, FaultParseError> {
            v.parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && *x >= 0.0)
                .ok_or_else(|| FaultParseError(format!("`{setting}`: not a number >= 0")))
        };
        let probability = |v: &str| -> Result<f64, FaultParseError> {
            let p = number(v)?;
            if p > 1.0 {
                return Err(FaultParseError(format!("`{setting}`: probability above 1")));
            }
            Ok(p)
        };
        match key.trim() {
            "ber" => self.ber = probability(value)?,
            "drop" => self.drop_rate = probability(value)?,
            "insert" => self.insert_rate = probability(value)?,
            "delay" => self.delay_ms = number(value)?,
            "jitter" => self.jitter_ms = number(value)?,
            "silence" => self.silences.push(value.parse()?),
            "disconnect" => self.disconnects.push(value.parse()?),
            other => {
                return Err(FaultParseError(format!(
                "unknown fault `{other}` (ber, drop, insert, delay, jitter, silence, disconnect)"
            )))
            }
        }
        Ok(())
    }

    /// Whether the device is silent at `t_s`.
    pub fn silent_at(&self, t_s: f64) -> bool {
        self.silences.iter().any(|w| w.contains(t_s))
    }

    /// Whether the device is unplugged at `t_s`.
    pub fn disconnected_at(&self, t_s: f64) -> bool {
        self.disconnects.iter().any(|w| w.contains(t_s))
    }
}

/// Faults of the sensor board's sensors, in time windows of the run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SensorFaults {
    /// `gnss:freeze`: the board repeats the last NAV-PVT unchanged (a receiver gone quiet).
    pub gnss_freezes: Vec<Window>,
    /// `gnss:loss`: the receiver reports no fix (fix type 0, gnssFixOK clear).
    pub gnss_losses: Vec<Window>,
    /// `imu:stuck`: the accelerometer and gyroscope words stay frozen (failed reads).
    pub imu_stuck: Vec<Window>,
    /// `vehicle:rollover`: the car lies on its side; the accelerometer says so, the rest of
    /// the model goes on as it was.
    pub rollovers: Vec<Window>,
}

impl SensorFaults {
    /// Whether the GNSS solution is frozen at `t_s`.
    pub fn gnss_frozen_at(&self, t_s: f64) -> bool {
        self.gnss_freezes.iter().any(|w| w.contains(t_s))
    }

    /// Whether the receiver has no fix at `t_s`.
    pub fn gnss_lost_at(&self, t_s: f64) -> bool {
        self.gnss_losses.iter().any(|w| w.contains(t_s))
    }

    /// Whether the IMU is stuck at `t_s`.
    pub fn imu_stuck_at(&self, t_s: f64) -> bool {
        self.imu_stuck.iter().any(|w| w.contains(t_s))
    }

    /// Whether the car lies on its side at `t_s`.
    pub fn rolled_over_at(&self, t_s: f64) -> bool {
        self.rollovers.iter().any(|w| w.contains(t_s))
    }
}

/// Faults inside the application: its log disk and its writes to the Maestro.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AppFaults {
    /// `log:stall`: the logger thread stops draining the loop's record ring.
    pub log_stalls: Vec<Window>,
    /// `log:full`: every write to the log file fails with ENOSPC.
    pub log_full: Vec<Window>,
    /// `maestro:write_error`: the application's writes to the Maestro fail (an I/O error).
    pub maestro_write_errors: Vec<Window>,
}

/// `loop:busy`: extra work inside every realtime cycle of the application during a window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopBusy {
    /// When, s from the start.
    pub window: Window,
    /// Work added per cycle, ms.
    pub busy_ms: f64,
}

/// Faults for every link and device.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Faults {
    /// Sensor-board UART.
    pub sensor: FaultSpec,
    /// Ground link.
    pub ground: FaultSpec,
    /// Maestro port.
    pub maestro: FaultSpec,
    /// GNSS and IMU on the sensor board.
    pub sensors: SensorFaults,
    /// Overload of the application's realtime loop.
    pub loop_busy: Option<LoopBusy>,
    /// Log disk and Maestro writes inside the application.
    pub app: AppFaults,
}

impl Faults {
    /// The spec of one link.
    pub fn link_mut(&mut self, link: Link) -> &mut FaultSpec {
        match link {
            Link::Sensor => &mut self.sensor,
            Link::Ground => &mut self.ground,
            Link::Maestro => &mut self.maestro,
        }
    }

    /// Applies a `LINK:KEY=VALUE[,KEY=VALUE...]` argument, e.g. `sensor:ber=1e-3,drop=1e-4`,
    /// `gnss:freeze=5+2`, `imu:stuck=5+2`, `vehicle:rollover=8+2` or `loop:busy=5+2,busy_ms=6`.
    pub fn apply_arg(&mut self, arg: &str) -> Result<(), FaultParseError> {
        let (link, settings) = arg.split_once(':').ok_or_else(|| {
            FaultParseError(format!(
                "`{arg}`: expected LINK:KEY=VALUE (sensor, ground, maestro, gnss, imu, vehicle, \
                 loop, log)"
            ))
        })?;
        let link = match link.trim() {
            "sensor" => Link::Sensor,
            "ground" | "xbee" => Link::Ground,
            "maestro" if settings.trim_start().starts_with("write_error") => {
                return self.apply_write_error(settings)
            }
            "maestro" => Link::Maestro,
            "gnss" | "imu" | "vehicle" => return self.apply_sensor_fault(link.trim(), settings),
            "loop" => return self.apply_loop_fault(settings),
            "log" => return self.apply_log_fault(settings),
            other => {
                return Err(FaultParseError(format!(
                    "unknown link `{other}` (sensor, ground, maestro, gnss, imu, vehicle, loop, \
                     log)"
                )))
            }
        };
        for setting in settings.split(',').filter(|s| !s.trim().is_empty()) {
            self.link_mut(link).set(setting)?;
        }
        Ok(())
    }
}

impl Faults {
    /// `gnss:freeze=W`, `gnss:loss=W`, `imu:stuck=W`, `vehicle:rollover=W` (windows
    /// `START+DURATION`).
    fn apply_sensor_fault(&mut self, device: &str, settings: &str) -> Result<(), FaultParseError> {
        for setting in settings.split(',').filter(|s| !s.trim().is_empty()) {
            let (key, value) = setting
                .split_once('=')
                .ok_or_else(|| FaultParseError(format!("`{setting}`: expected KEY=VALUE")))?;
            let window: Window = value.parse()?;
            let s = &mut self.sensors;
            match (device, key.trim()) {
                ("gnss", "freeze") => s.gnss_freezes.push(window),
                ("gnss", "loss") => s.gnss_losses.push(window),
                ("imu", "stuck") => s.imu_stuck.push(window),
                ("vehicle", "rollover") => s.rollovers.push(window),
                ("vehicle", other) => {
                    return Err(FaultParseError(format!(
                        "unknown vehicle fault `{other}` (rollover)"
                    )))
                }
                ("gnss", other) => {
                    return Err(FaultParseError(format!(
                        "unknown gnss fault `{other}` (freeze, loss)"
                    )))
                }
                (_, other) => {
                    return Err(FaultParseError(format!(
                        "unknown imu fault `{other}` (stuck)"
                    )))
                }
            }
        }
        Ok(())
    }

    /// `log:stall=W`, `log:full=W` (windows `START+DURATION`).
    fn apply_log_fault(&mut self, settings: &str) -> Result<(), FaultParseError> {
        for setting in settings.split(',').filter(|s| !s.trim().is_empty()) {
            let (key, value) = setting
                .split_once('=')
                .ok_or_else(|| FaultParseError(format!("`{setting}`: expected KEY=VALUE")))?;
            let window: Window = value.parse()?;
            match key.trim() {
                "stall" => self.app.log_stalls.push(window),
                "full" => self.app.log_full.push(window),
                other => {
                    return Err(FaultParseError(format!(
                        "unknown log fault `{other}` (stall, full)"
                    )))
                }
            }
        }
        Ok(())
    }

    /// `maestro:write_error=W`.
    fn apply_write_error(&mut self, settings: &str) -> Result<(), FaultParseError> {
        for setting in settings.split(',').filter(|s| !s.trim().is_empty()) {
            match setting.split_once('=').map(|(k, v)| (k.trim(), v)) {
                Some(("write_error", v)) => self.app.maestro_write_errors.push(v.parse()?),
                _ => {
                    return Err(FaultParseError(format!(
                        "`{setting}`: expected write_error=START+DURATION"
                    )))
                }
            }
        }
        Ok(())
    }

    /// `loop:busy=START+DURATION,busy_ms=MS`.
    fn apply_loop_fault(&mut self, settings: &str) -> Result<(), FaultParseError> {
        let (mut window, mut busy_ms) = (None, None);
        for setting in settings.split(',').filter(|s| !s.trim().is_empty()) {
            match setting.split_once('=').map(|(k, v)| (k.trim(), v.trim())) {
                Some(("busy", v)) => window = Some(v.parse::<Window>()?),
                Some(("busy_ms", v)) => {
                    busy_ms = Some(
                        v.parse::<f64>()
                            .ok()
                            .filter(|x| x.is_finite() && *x > 0.0 && *x <= 1_000.0)
                            .ok_or_else(|| {
                                FaultParseError(format!("`{setting}`: expected 0 < MS <= 1000"))
                            })?,
                    )
                }
                _ => {
                    return Err(FaultParseError(format!(
                        "`{setting}`: expected busy=START+DURATION or busy_ms=MS"
                    )))
                }
            }
        }
        match (window, busy_ms) {
            (Some(window), Some(busy_ms)) => {
                self.loop_busy = Some(LoopBusy { window, busy_ms });
                Ok(())
            }
            _ => Err(FaultParseError(
                "loop: expected busy=START+DURATION,busy_ms=MS".into(),
            )),
        }
    }
}

/// One kind of fault that `--random-faults` puts in a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultKind {
    /// `sensor:silence`: the sensor board answers nothing.
    SensorSilence,
    /// `sensor:disconnect`: the sensor board is unplugged.
    SensorDisconnect,
    /// `ground:silence`: the ground station sends nothing (comms loss when long enough).
    GroundSilence,
    /// `maestro:disconnect`: the Maestro is unplugged.
    MaestroDisconnect,
    /// `gnss:freeze`: the receiver repeats its last solution.
    GnssFreeze,
    /// `gnss:loss`: the receiver has no fix.
    GnssLoss,
    /// `imu:stuck`: accelerometer and gyroscope words frozen.
    ImuStuck,
    /// `loop:busy`: 6 ms of extra work in every cycle (at most once per run).
    LoopBusy,
    /// `log:stall`: the logger stops draining its ring.
    LogStall,
    /// `log:full`: log writes fail as on a full disk.
    LogFull,
    /// `maestro:write_error`: writes to the Maestro fail.
    MaestroWriteError,
}

impl FaultKind {
    /// Every kind, in the order the draw indexes them.
    pub const ALL: [FaultKind; 11] = [
        FaultKind::SensorSilence,
        FaultKind::SensorDisconnect,
        FaultKind::GroundSilence,
        FaultKind::MaestroDisconnect,
        FaultKind::GnssFreeze,
        FaultKind::GnssLoss,
        FaultKind::ImuStuck,
        FaultKind::LoopBusy,
        FaultKind::LogStall,
        FaultKind::LogFull,
        FaultKind::MaestroWriteError,
    ];

    /// The `--fault` form of this kind in `window`, e.g. `sensor:silence=12.5+1.2`.
    pub fn arg(self, window: Window) -> String {
        let w = format!("{}+{}", window.start_s, window.duration_s);
        match self {
            FaultKind::SensorSilence => format!("sensor:silence={w}"),
            FaultKind::SensorDisconnect => format!("sensor:disconnect={w}"),
            FaultKind::GroundSilence => format!("ground:silence={w}"),
            FaultKind::MaestroDisconnect => format!("maestro:disconnect={w}"),
            FaultKind::GnssFreeze => format!("gnss:freeze={w}"),
            FaultKind::GnssLoss => format!("gnss:loss={w}"),
            FaultKind::ImuStuck => format!("imu:stuck={w}"),
            FaultKind::LoopBusy => format!("loop:busy={w},busy_ms=6"),
            FaultKind::LogStall => format!("log:stall={w}"),
            FaultKind::LogFull => format!("log:full={w}"),
            FaultKind::MaestroWriteError => format!("maestro:write_error={w}"),
        }
    }
}

/// A fault in its window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultWindow {
    /// What.
    pub kind: FaultKind,
    /// When.
    pub window: Window,
}

/// Seconds from the end of one random fault window to the start of the next: room for the
/// link to recover, a revive, and driving that must not be interrupted.
pub const RANDOM_GAP_S: (f64, f64) = (5.0, 7.0);

/// Length of a random fault window, s.
pub const RANDOM_LENGTH_S: (f64, f64) = (0.5, 3.0);

/// Random fault windows for a run of `duration_s`, drawn from `rng`: one after another from
/// `first_s`, each of a random [`FaultKind`] and length, separated by [`RANDOM_GAP_S`], none
/// ending later than `duration_s - 5` s (the run ends with recovery, driving and a kill).
pub fn random_windows(rng: &mut SimRng, first_s: f64, duration_s: f64) -> Vec<FaultWindow> {
    let mut windows = Vec::new();
    let mut t = first_s;
    let mut loop_busy_used = false;
    let between = |rng: &mut SimRng, (lo, hi): (f64, f64)| {
        // Tenths of a second, so the windows print exactly as `--fault` arguments.
        ((lo + (hi - lo) * rng.uniform()) * 10.0).round() / 10.0
    };
    loop {
        let duration_s_w = between(rng, RANDOM_LENGTH_S);
        if t + duration_s_w > duration_s - 5.0 {
            break;
        }
        let mut kind = FaultKind::ALL[rng.below(FaultKind::ALL.len() as u64) as usize];
        while kind == FaultKind::LoopBusy && loop_busy_used {
            kind = FaultKind::ALL[rng.below(FaultKind::ALL.len() as u64) as usize];
        }
        loop_busy_used |= kind == FaultKind::LoopBusy;
        let window = Window {
            start_s: (t * 10.0).round() / 10.0,
            duration_s: duration_s_w,
        };
        windows.push(FaultWindow { kind, window });
        t = window.start_s + window.duration_s + between(rng, RANDOM_GAP_S);
    }
    windows
}

impl Faults {
    /// Adds a fault in its window.
    pub fn add_window(&mut self, w: FaultWindow) -> Result<(), FaultParseError> {
        self.apply_arg(&w.kind.arg(w.window))
    }
}

/// What an injector did to the frames it passed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FaultStats {
    /// Frames handed to the injector.
    pub frames: u64,
    /// Frames that went out unchanged.
    pub intact: u64,
    /// Bits flipped.
    pub bits_flipped: u64,
    /// Bytes dropped.
    pub bytes_dropped: u64,
    /// Bytes inserted.
    pub bytes_inserted: u64,
}

impl fmt::Display for FaultStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} frames, {} intact, {} bits flipped, {} bytes dropped, {} inserted",
            self.frames, self.intact, self.bits_flipped, self.bytes_dropped, self.bytes_inserted
        )
    }
}

/// Applies a [`FaultSpec`] to a device's outgoing frames.
#[derive(Debug, Clone)]
pub struct FaultInjector {
    spec: FaultSpec,
    rng: SimRng,
    stats: FaultStats,
}

impl FaultInjector {
    /// An injector for `spec` drawing from `rng`.
    pub fn new(spec: FaultSpec, rng: SimRng) -> FaultInjector {
        FaultInjector {
            spec,
            rng,
            stats: FaultStats::default(),
        }
    }

    /// The spec.
    pub fn spec(&self) -> &FaultSpec {
        &self.spec
    }

    /// What was done so far.
    pub fn stats(&self) -> FaultStats {
        self.stats
    }

    /// Copies `frame` into `out` with bit errors, drops and insertions; returns whether it went
    /// out unchanged.
    pub fn mangle(&mut self, frame: &[u8], out: &mut Vec<u8>) -> bool {
        out.clear();
        let intact = self.mangle_part(frame, out);
        self.end_frame(intact);
        intact
    }

    /// Appends `part` of a frame to `out` with bit errors, drops and insertions, as
    /// [`FaultInjector::mangle`] does for a whole frame (the same draws in the same order), and
    /// returns whether it went out unchanged; the frame is counted by
    /// [`FaultInjector::end_frame`]. For frames relayed as their bytes arrive.
    pub fn mangle_part(&mut self, part: &[u8], out: &mut Vec<u8>) -> bool {
        let before = self.stats;
        let s = &self.spec;
        for &byte in part {
            if self.rng.chance(s.insert_rate) {
                out.push(self.rng.next_u64() as u8);
                self.stats.bytes_inserted += 1;
            }
            if self.rng.chance(s.drop_rate) {
                self.stats.bytes_dropped += 1;
                continue;
            }
            let mut b = byte;
            if s.ber > 0.0 {
                for bit in 0..8 {
                    if self.rng.chance(s.ber) {
                        b ^= 1 << bit;
                        self.stats.bits_flipped += 1;
                    }
                }
            }
            out.push(b);
        }
        self.stats.bits_flipped == before.bits_flipped
            && self.stats.bytes_dropped == before.bytes_dropped
            && self.stats.bytes_inserted == before.bytes_inserted
    }

    /// Counts a frame whose parts went through [`FaultInjector::mangle_part`]; `intact` when
    /// every part went out unchanged.
    pub fn end_frame(&mut self, intact: bool) {
        self.stats.frames += 1;
        if intact {
            self.stats.intact += 1;
        }
    }

    /// The delay before this frame goes out.
    pub fn delay(&mut self) -> Duration {
        let ms = self.spec.delay_ms + self.spec.jitter_ms * self.rng.uniform();
        Duration::from_secs_f64(ms / 1e3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_command_line_form() {
        let mut f = Faults::default();
        f.apply_arg("sensor:ber=1e-3,drop=0.001").unwrap();
        f.apply_arg("maestro:disconnect=4+1.5").unwrap();
        f.apply_arg("ground:silence=3+2,delay=20,jitter=5").unwrap();
        assert_eq!(f.sensor.ber, 1e-3);
        assert_eq!(f.sensor.drop_rate, 1e-3);
        assert_eq!(
            f.maestro.disconnects,
            vec![Window {
                start_s: 4.0,
                duration_s: 1.5
            }]
        );
        assert!(f.ground.silent_at(4.9) && !f.ground.silent_at(5.0) && !f.ground.silent_at(2.9));
        assert_eq!(f.ground.delay_ms, 20.0);
        for bad in [
            "sensor",
            "usb:ber=1",
            "sensor:ber=2",
            "sensor:ber=x",
            "sensor:silence=5",
            "sensor:noise=1",
            "sensor:delay=-1",
        ] {
            assert!(Faults::default().apply_arg(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn device_faults_parse() {
        let mut f = Faults::default();
        f.apply_arg("gnss:freeze=5+2").unwrap();
        f.apply_arg("gnss:loss=1+0.5").unwrap();
        f.apply_arg("imu:stuck=3+4").unwrap();
        f.apply_arg("loop:busy=2+1,busy_ms=6").unwrap();
        f.apply_arg("log:stall=1+5").unwrap();
        f.apply_arg("log:full=2+3,full=9+1").unwrap();
        f.apply_arg("maestro:write_error=4+2").unwrap();
        f.apply_arg("vehicle:rollover=8+2").unwrap();
        assert!(f.sensors.rolled_over_at(8.0) && f.sensors.rolled_over_at(9.9));
        assert!(!f.sensors.rolled_over_at(7.9) && !f.sensors.rolled_over_at(10.0));
        assert_eq!(f.app.log_stalls.len(), 1);
        assert_eq!(f.app.log_full.len(), 2);
        assert!(f.app.maestro_write_errors[0].contains(5.9));
        assert!(f.maestro.is_nominal());
        assert!(f.sensors.gnss_frozen_at(6.9) && !f.sensors.gnss_frozen_at(7.0));
        assert!(f.sensors.gnss_lost_at(1.2) && !f.sensors.gnss_lost_at(2.0));
        assert!(f.sensors.imu_stuck_at(3.0) && !f.sensors.imu_stuck_at(2.9));
        assert_eq!(
            f.loop_busy,
            Some(LoopBusy {
                window: Window {
                    start_s: 2.0,
                    duration_s: 1.0
                },
                busy_ms: 6.0
            })
        );
        for bad in [
            "gnss:thaw=1+1",
            "gnss:freeze=1",
            "imu:stuck",
            "loop:busy=1+1",
            "loop:busy_ms=3",
            "loop:busy=1+1,busy_ms=0",
            "loop:busy=1+1,busy_ms=x",
            "log:stall",
            "log:slow=1+1",
            "log:full=1",
            "maestro:write_error=x",
            "maestro:write_error=1+1,ber=0.1",
            "vehicle:rollover",
            "vehicle:rollover=8",
            "vehicle:flip=8+2",
        ] {
            assert!(Faults::default().apply_arg(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn random_windows_are_separated_reproducible_and_parse() {
        let a = random_windows(&mut SimRng::new(7), 3.0, 600.0);
        let b = random_windows(&mut SimRng::new(7), 3.0, 600.0);
        let c = random_windows(&mut SimRng::new(8), 3.0, 600.0);
        assert_eq!(a, b);
        assert_ne!(a, c);
        // 600 s with windows of 0.5..3 s and gaps of 5..7 s: about 70.
        assert!((60..90).contains(&a.len()), "{}", a.len());
        let mut faults = Faults::default();
        for pair in a.windows(2) {
            let end = pair[0].window.start_s + pair[0].window.duration_s;
            let gap = pair[1].window.start_s - end;
            assert!(gap >= RANDOM_GAP_S.0 - 0.11, "{pair:?}");
        }
        for w in &a {
            assert!(w.window.start_s >= 3.0);
            assert!(w.window.start_s + w.window.duration_s <= 595.0);
            faults.add_window(*w).unwrap();
        }
        let busy = a.iter().filter(|w| w.kind == FaultKind::LoopBusy).count();
        assert!(busy <= 1);
        for kind in FaultKind::ALL.iter().filter(|k| **k != FaultKind::LoopBusy) {
            assert!(a.iter().any(|w| w.kind == *kind), "{kind:?} never drawn");
        }
        assert!(random_windows(&mut SimRng::new(1), 3.0, 5.0).is_empty());
    }

    #[test]
    fn nominal_spec_passes_frames_unchanged() {
        let mut inj = FaultInjector::new(FaultSpec::default(), SimRng::new(1));
        let mut out = Vec::new();
        let frame: Vec<u8> = (0..=255).collect();
        for _ in 0..100 {
            assert!(inj.mangle(&frame, &mut out));
            assert_eq!(out, frame);
        }
        assert_eq!(inj.stats().intact, 100);
        assert_eq!(inj.delay(), Duration::ZERO);
    }

    #[test]
    fn bit_error_rate_and_intact_count_agree() {
        let spec = FaultSpec {
            ber: 1e-3,
            ..FaultSpec::default()
        };
        let mut inj = FaultInjector::new(spec, SimRng::new(42));
        let frame = [0x55u8; 132];
        let mut out = Vec::new();
        let mut intact = 0;
        let mut flipped = 0u64;
        for _ in 0..2_000 {
            if inj.mangle(&frame, &mut out) {
                intact += 1;
                assert_eq!(out, frame);
            } else {
                flipped += out
                    .iter()
                    .zip(frame)
                    .map(|(a, b)| u64::from((a ^ b).count_ones()))
                    .sum::<u64>();
            }
        }
        let s = inj.stats();
        assert_eq!(s.intact, intact);
        assert_eq!(s.bits_flipped, flipped);
        // 2000 * 1056 bits * 1e-3 = 2112 expected flips; P(intact) = (1 - 1e-3)^1056 = 0.348.
        assert!((1_800..2_400).contains(&flipped), "{flipped}");
        assert!((600..800).contains(&intact), "{intact}");
    }

    #[test]
    fn drops_and_insertions_change_the_length() {
        let spec = FaultSpec {
            drop_rate: 0.01,
            insert_rate: 0.01,
            jitter_ms: 4.0,
            delay_ms: 1.0,
            ..FaultSpec::default()
        };
        let mut inj = FaultInjector::new(spec, SimRng::new(3));
        let mut out = Vec::new();
        for _ in 0..1_000 {
            inj.mangle(&[0u8; 100], &mut out);
            let d = inj.delay();
            assert!(d >= Duration::from_millis(1) && d < Duration::from_millis(5));
        }
        let s = inj.stats();
        assert!((700..1_300).contains(&s.bytes_dropped), "{s:?}");
        assert!((700..1_300).contains(&s.bytes_inserted), "{s:?}");
    }

    #[test]
    fn a_frame_mangled_in_parts_goes_out_as_if_whole() {
        let mut spec = FaultSpec::default();
        for setting in ["ber=0.01", "drop=0.01", "insert=0.01"] {
            spec.set(setting).unwrap();
        }
        let frame: Vec<u8> = (0..=255u8).cycle().take(2_000).collect();
        let mut whole = FaultInjector::new(spec.clone(), SimRng::new(3));
        let mut parts = FaultInjector::new(spec, SimRng::new(3));
        for _ in 0..20 {
            let mut a = Vec::new();
            let intact_a = whole.mangle(&frame, &mut a);
            let mut b = Vec::new();
            let mut intact_b = true;
            for part in frame.chunks(7) {
                intact_b &= parts.mangle_part(part, &mut b);
            }
            parts.end_frame(intact_b);
            assert_eq!(a, b);
            assert_eq!(intact_a, intact_b);
        }
        assert_eq!(whole.stats(), parts.stats());
        assert!(whole.stats().bits_flipped > 0);
    }
}
