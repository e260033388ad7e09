//! `dima log export FILE --format csv|jsonl|parquet`: one row per cycle (channel `cycle`), per
//! GNSS fix (`gnss`), per state change (`state`) or per replayed cycle of a comparison file
//! (`replay`), every value in physical units with the unit in its column name. The cycle rows
//! end with the GNSS values the cycle's packet carried (`gnss_speed_m_s`, `gnss_heading_deg`,
//! `gnss_lat_deg`, `gnss_lon_deg`) and the state estimate (`est_speed_m_s`,
//! `est_heading_deg`, see [`recorded_estimates`]), so a speed meets its setpoint in one row. The CSV opens in a spreadsheet and in PlotJuggler (first column `t_s`);
//! the same rows go to Parquet through [`parquet`](super::parquet).

use std::collections::BTreeMap;
use std::io::Write;

use bosch_bmp280::compensation::{pressure_pa_f32, temperature_celsius_f32};
use bosch_bmp280::Calibration;
use bosch_bmx055::mag::{compensate_x_f32, compensate_y_f32, compensate_z_f32, MagTrim};
use dima_core::estimate::StateEstimate;
use dima_log::schema::{CycleMessage, ReplayMessage, SensorInfoMessage};
use dima_sensorboard::units;
use serde_json::{json, Value};

use super::read::LoggedRun;

/// Output format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Comma-separated values with a header row.
    Csv,
    /// One JSON object per line.
    Jsonl,
    /// Apache Parquet with a first column `run`, for querying many runs together (needs -o).
    Parquet,
}

/// What rows to export.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Channel {
    /// One row per control cycle.
    Cycle,
    /// One row per new GNSS fix.
    Gnss,
    /// One row per mode change or event.
    State,
    /// One row per replayed cycle of a comparison file written by `dima log replay --config
    /// NEW -o FILE` (`/replay/cycle`), beside the recorded outputs, setpoints and GNSS.
    Replay,
}

/// Calibration from the sensor board's info frame, for physical units.
pub struct Calibrations {
    bmp280: Option<Calibration>,
    trim: Option<MagTrim>,
}

impl Calibrations {
    /// From the first info frame of a log (none: raw values stay empty).
    pub fn from_info(info: Option<&SensorInfoMessage>) -> Calibrations {
        let bmp280 = info
            .and_then(|i| <[u8; 24]>::try_from(i.bmp280_calibration.as_slice()).ok())
            .map(|b| Calibration::from_bytes(&b));
        let trim = info
            .and_then(|i| <[u8; 16]>::try_from(i.bmm150_trim.as_slice()).ok())
            .map(|t| {
                MagTrim::from_bursts(
                    &[t[0], t[1]],
                    &[t[2], t[3], t[4], t[5]],
                    &[
                        t[6], t[7], t[8], t[9], t[10], t[11], t[12], t[13], t[14], t[15],
                    ],
                )
            });
        Calibrations { bmp280, trim }
    }
}

fn opt<T: Into<Value>>(v: Option<T>) -> Value {
    v.map_or(Value::Null, Into::into)
}

/// Rounds to 6 significant decimals (f32 values printed without float noise).
fn num(v: f32) -> Value {
    json!((f64::from(v) * 1e6).round() / 1e6)
}

/// The cells of one cycle row, in column order.
///
/// The GNSS columns (`gnss_*`) hold the NAV-PVT the cycle's packet carried (empty without
/// one); the estimate columns (`est_*`) hold `estimate`, the state estimate the controllers
/// read in this cycle (empty when unknown or not valid).
pub fn cycle_row(
    t_s: f64,
    t_ns: u64,
    c: &CycleMessage,
    cal: &Calibrations,
    estimate: Option<&StateEstimate>,
) -> Vec<(&'static str, Value)> {
    let s = c.sensor.as_ref();
    let axis = |i: usize, f: fn(i16) -> f32| opt(s.map(|s| num(f(s.accel[i]))));
    let gyro = |i: usize| opt(s.map(|s| num(units::gyro_dps_2000(s.gyro[i]))));
    let mag = |f: fn(i16, u16, &MagTrim) -> f32, i: usize| {
        opt(s
            .zip(cal.trim.as_ref())
            .map(|(s, t)| num(f(s.mag[i], s.rhall, t))))
    };
    let baro = s.zip(cal.bmp280.as_ref()).map(|(s, cal)| {
        let (celsius, t_fine) = temperature_celsius_f32(cal, s.temp_raw);
        (pressure_pa_f32(cal, t_fine, s.press_raw), celsius)
    });
    let sp = &c.setpoints;
    vec![
        ("t_s", json!((t_s * 1e6).round() / 1e6)),
        ("log_time_ns", json!(t_ns)),
        ("cycle", json!(c.cycle)),
        ("mode", json!(c.mode.name())),
        ("cause", opt(c.cause.map(|c| format!("{c:?}")))),
        ("packet", json!(c.packet)),
        ("missed_periods", json!(c.missed_periods)),
        ("wake_latency_us", json!(c.wake_latency_us)),
        ("request_to_packet_us", opt(c.request_to_packet_us)),
        ("compute_us", json!(c.compute_us)),
        ("servo_write_us", opt(c.servo_write_us)),
        ("accel_x_m_s2", axis(0, units::accel_m_s2_2g)),
        ("accel_y_m_s2", axis(1, units::accel_m_s2_2g)),
        ("accel_z_m_s2", axis(2, units::accel_m_s2_2g)),
        ("gyro_x_dps", gyro(0)),
        ("gyro_y_dps", gyro(1)),
        ("gyro_z_dps", gyro(2)),
        ("mag_x_ut", mag(compensate_x_f32, 0)),
        ("mag_y_ut", mag(compensate_y_f32, 1)),
        ("mag_z_ut", mag(compensate_z_f32, 2)),
        ("pressure_pa", opt(baro.and_then(|(p, _)| p).map(num))),
        ("temperature_c", opt(baro.map(|(_, t)| num(t)))),
        ("gnss_age_ms", opt(c.gnss_age_ms)),
        ("throttle_pct", opt(sp.throttle_pct)),
        ("steering_pct", opt(sp.steering_pct)),
        ("tail_pct", opt(sp.tail_pct)),
        ("speed_setpoint_mm_s", opt(sp.speed_mm_s)),
        ("heading_setpoint_deg", opt(sp.heading_deg)),
        ("action_throttle", num(c.action.throttle)),
        ("action_steering", num(c.action.steering)),
        ("action_tail", num(c.action.tail)),
        ("target_throttle_us", json!(c.targets_us[0])),
        ("target_steering_us", json!(c.targets_us[1])),
        ("target_tail_us", json!(c.targets_us[2])),
        (
            "gnss_speed_m_s",
            opt(s.and_then(|s| s.g_speed_mm_s).map(|v| f64::from(v) / 1e3)),
        ),
        ("gnss_heading_deg", opt(s.and_then(|s| s.head_mot_deg))),
        ("gnss_lat_deg", opt(s.and_then(|s| s.lat_deg))),
        ("gnss_lon_deg", opt(s.and_then(|s| s.lon_deg))),
        ("est_speed_m_s", opt(est_speed_m_s(estimate))),
        ("est_heading_deg", opt(est_heading_deg(estimate))),
    ]
}

/// The estimated ground speed, m/s, when valid.
fn est_speed_m_s(estimate: Option<&StateEstimate>) -> Option<Value> {
    estimate
        .and_then(|e| e.speed_mm_s)
        .map(|m| num(m.value / 1e3))
}

/// The estimated heading, degrees from north, when valid.
fn est_heading_deg(estimate: Option<&StateEstimate>) -> Option<Value> {
    estimate.and_then(|e| e.heading_deg).map(|m| num(m.value))
}

/// The state estimate of every cycle of `run`, by cycle number: recomputed by replaying the
/// recorded inputs through the control step with the recorded configuration (the robot does
/// not log its estimate; the replay computes the same one, bit for bit). Empty when the run
/// cannot be replayed as recorded (no configuration, not every cycle logged, or a replay that
/// does not reproduce the recorded outputs).
pub fn recorded_estimates(run: &LoggedRun) -> BTreeMap<u64, StateEstimate> {
    let Some(config) = &run.config else {
        return BTreeMap::new();
    };
    match super::replay::replay(run, config) {
        Ok(r) if r.first_difference.is_none() => r
            .cycles
            .iter()
            .map(|c| (c.message.cycle, c.message.estimate))
            .collect(),
        _ => BTreeMap::new(),
    }
}

/// The cells of one row of `--channel replay`: the replayed cycle `r`, and from the recorded
/// cycle `c` of the same number (when there is one) the recorded outputs, the setpoints and
/// the GNSS values, so a new controller is judged against its setpoints in one table.
pub fn replay_row(
    t_s: f64,
    t_ns: u64,
    r: &ReplayMessage,
    c: Option<&CycleMessage>,
) -> Vec<(&'static str, Value)> {
    let sp = c.map(|c| c.setpoints);
    let s = c.and_then(|c| c.sensor.as_ref());
    let e = Some(&r.estimate);
    vec![
        ("t_s", json!((t_s * 1e6).round() / 1e6)),
        ("log_time_ns", json!(t_ns)),
        ("cycle", json!(r.cycle)),
        ("mode", json!(r.mode.name())),
        ("cause", opt(r.cause.map(|c| format!("{c:?}")))),
        ("recorded_mode", json!(r.recorded_mode.name())),
        ("speed_setpoint_mm_s", opt(sp.and_then(|s| s.speed_mm_s))),
        ("heading_setpoint_deg", opt(sp.and_then(|s| s.heading_deg))),
        (
            "gnss_speed_m_s",
            opt(s.and_then(|s| s.g_speed_mm_s).map(|v| f64::from(v) / 1e3)),
        ),
        ("gnss_heading_deg", opt(s.and_then(|s| s.head_mot_deg))),
        ("est_speed_m_s", opt(est_speed_m_s(e))),
        ("est_heading_deg", opt(est_heading_deg(e))),
        (
            "est_yaw_rate_dps",
            opt(r.estimate.yaw_rate_dps.map(|m| num(m.value))),
        ),
        ("action_throttle", num(r.action.throttle)),
        ("action_steering", num(r.action.steering)),
        ("action_tail", num(r.action.tail)),
        (
            "recorded_action_throttle",
            opt(c.map(|c| num(c.action.throttle))),
        ),
        (
            "recorded_action_steering",
            opt(c.map(|c| num(c.action.steering))),
        ),
        ("recorded_action_tail", opt(c.map(|c| num(c.action.tail)))),
        ("target_throttle_us", json!(r.targets_us[0])),
        ("target_steering_us", json!(r.targets_us[1])),
        ("target_tail_us", json!(r.targets_us[2])),
        (
            "recorded_target_throttle_us",
            json!(r.recorded_targets_us[0]),
        ),
        (
            "recorded_target_steering_us",
            json!(r.recorded_targets_us[1]),
        ),
        ("recorded_target_tail_us", json!(r.recorded_targets_us[2])),
    ]
}

/// Rows of `channel` between `from_s` and `to_s` (seconds since the first cycle). The rows of
/// [`Channel::Replay`] are read from the files the run was read from (none for a run read from
/// bytes).
pub fn rows(
    run: &LoggedRun,
    channel: Channel,
    from_s: f64,
    to_s: f64,
) -> Vec<Vec<(&'static str, Value)>> {
    let cal = Calibrations::from_info(run.infos.first().map(|i| &i.msg));
    let within = |t_ns: u64| (from_s..=to_s).contains(&run.seconds(t_ns));
    match channel {
        Channel::Cycle => {
            let estimates = recorded_estimates(run);
            run.cycles
                .iter()
                .filter(|c| within(c.t_ns))
                .map(|c| {
                    let estimate = estimates.get(&c.msg.cycle);
                    cycle_row(run.seconds(c.t_ns), c.t_ns, &c.msg, &cal, estimate)
                })
                .collect()
        }
        Channel::Replay => {
            let replayed = super::replay::read_replayed(run).unwrap_or_default();
            let recorded: BTreeMap<u64, &CycleMessage> =
                run.cycles.iter().map(|c| (c.msg.cycle, &c.msg)).collect();
            replayed
                .iter()
                .filter(|r| within(r.t_ns))
                .map(|r| {
                    let c = recorded.get(&r.msg.cycle).copied();
                    replay_row(run.seconds(r.t_ns), r.t_ns, &r.msg, c)
                })
                .collect()
        }
        Channel::Gnss => {
            let mut last_itow = None;
            let mut out = Vec::new();
            for c in run.cycles.iter().filter(|c| within(c.t_ns)) {
                let Some(s) = &c.msg.sensor else { continue };
                if s.itow_ms.is_none() || s.itow_ms == last_itow {
                    continue;
                }
                last_itow = s.itow_ms;
                out.push(vec![
                    ("t_s", json!((run.seconds(c.t_ns) * 1e6).round() / 1e6)),
                    ("itow_ms", opt(s.itow_ms)),
                    ("fix_ok", json!(s.gnss_fix_ok)),
                    ("lat_deg", opt(s.lat_deg)),
                    ("lon_deg", opt(s.lon_deg)),
                    (
                        "ground_speed_m_s",
                        opt(s.g_speed_mm_s.map(|v| f64::from(v) / 1e3)),
                    ),
                    ("heading_of_motion_deg", opt(s.head_mot_deg)),
                    ("satellites", opt(s.num_sv)),
                ]);
            }
            out
        }
        Channel::State => run
            .states
            .iter()
            .filter(|s| within(s.t_ns))
            .map(|s| {
                let events: Vec<String> = s
                    .msg
                    .events
                    .iter()
                    .map(|e| {
                        serde_json::to_value(e)
                            .map_or(String::new(), |v| v.as_str().unwrap_or("").to_owned())
                    })
                    .collect();
                vec![
                    ("t_s", json!((run.seconds(s.t_ns) * 1e6).round() / 1e6)),
                    ("cycle", json!(s.msg.cycle)),
                    ("mode", json!(s.msg.mode.name())),
                    ("cause", opt(s.msg.cause.map(|c| format!("{c:?}")))),
                    ("refused", opt(s.msg.refused.map(|c| format!("{c:?}")))),
                    ("events", json!(events.join(" "))),
                ]
            })
            .collect(),
    }
}

fn csv_cell(v: &Value) -> String {
    match v {
        Value::Null => String::new(),
        Value::String(s) if s.contains([',', '"', '\n']) => {
            format!("\"{}\"", s.replace('"', "\"\""))
        }
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// Writes `rows` in `format`.
pub fn write(
    rows: &[Vec<(&'static str, Value)>],
    format: Format,
    out: &mut impl Write,
) -> std::io::Result<()> {
    match format {
        Format::Csv => {
            if let Some(first) = rows.first() {
                let header: Vec<&str> = first.iter().map(|(k, _)| *k).collect();
                writeln!(out, "{}", header.join(","))?;
            }
            for row in rows {
                let cells: Vec<String> = row.iter().map(|(_, v)| csv_cell(v)).collect();
                writeln!(out, "{}", cells.join(","))?;
            }
        }
        Format::Jsonl => {
            for row in rows {
                let object: serde_json::Map<String, Value> = row
                    .iter()
                    .map(|(k, v)| ((*k).to_owned(), v.clone()))
                    .collect();
                writeln!(out, "{}", Value::Object(object))?;
            }
        }
        Format::Parquet => {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "Parquet is written to a file by logtools::parquet::write",
            ))
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_quotes_what_needs_it_and_leaves_absent_values_empty() {
        let rows = vec![vec![
            ("t_s", json!(0.5)),
            ("name", json!("a,b")),
            ("none", Value::Null),
        ]];
        let mut out = Vec::new();
        write(&rows, Format::Csv, &mut out).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "t_s,name,none\n0.5,\"a,b\",\n"
        );
        let mut out = Vec::new();
        write(&rows, Format::Jsonl, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(text.lines().count(), 1);
        let value: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(value, json!({"t_s": 0.5, "name": "a,b", "none": null}));
    }

    /// The columns of the cycle export before the GNSS and estimate columns, in order.
    const FIRST_COLUMNS: [&str; 34] = [
        "t_s",
        "log_time_ns",
        "cycle",
        "mode",
        "cause",
        "packet",
        "missed_periods",
        "wake_latency_us",
        "request_to_packet_us",
        "compute_us",
        "servo_write_us",
        "accel_x_m_s2",
        "accel_y_m_s2",
        "accel_z_m_s2",
        "gyro_x_dps",
        "gyro_y_dps",
        "gyro_z_dps",
        "mag_x_ut",
        "mag_y_ut",
        "mag_z_ut",
        "pressure_pa",
        "temperature_c",
        "gnss_age_ms",
        "throttle_pct",
        "steering_pct",
        "tail_pct",
        "speed_setpoint_mm_s",
        "heading_setpoint_deg",
        "action_throttle",
        "action_steering",
        "action_tail",
        "target_throttle_us",
        "target_steering_us",
        "target_tail_us",
    ];

    #[test]
    fn a_cycle_row_holds_gnss_and_the_estimate_beside_the_setpoint() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/auto-pid-before-plugins.mcap"
        );
        let run = LoggedRun::read(std::path::Path::new(path)).unwrap();
        let rows = rows(&run, Channel::Cycle, 0.0, f64::INFINITY);
        assert_eq!(rows.len(), run.cycles.len());
        let names: Vec<&str> = rows[0].iter().map(|(k, _)| *k).collect();
        assert_eq!(
            names[..FIRST_COLUMNS.len()],
            FIRST_COLUMNS,
            "kept, in order"
        );
        assert_eq!(
            names[FIRST_COLUMNS.len()..],
            [
                "gnss_speed_m_s",
                "gnss_heading_deg",
                "gnss_lat_deg",
                "gnss_lon_deg",
                "est_speed_m_s",
                "est_heading_deg"
            ],
            "appended"
        );
        let cell = |row: &Vec<(&'static str, Value)>, name: &str| {
            row.iter().find(|(k, _)| *k == name).unwrap().1.clone()
        };
        // In AUTO with a speed setpoint, one row holds the setpoint, GNSS and the estimate.
        let auto = rows
            .iter()
            .zip(&run.cycles)
            .filter(|(_, c)| c.msg.mode == dima_core::Mode::Auto)
            .find(|(_, c)| {
                c.msg.setpoints.speed_mm_s.is_some()
                    && c.msg
                        .sensor
                        .as_ref()
                        .is_some_and(|s| s.g_speed_mm_s.is_some())
            })
            .expect("an AUTO cycle with a setpoint and GNSS");
        let (row, c) = auto;
        let s = c.msg.sensor.as_ref().unwrap();
        assert_eq!(
            cell(row, "gnss_speed_m_s"),
            json!(f64::from(s.g_speed_mm_s.unwrap()) / 1e3)
        );
        assert_eq!(cell(row, "gnss_heading_deg"), json!(s.head_mot_deg));
        assert_eq!(cell(row, "gnss_lat_deg"), json!(s.lat_deg));
        assert_eq!(cell(row, "gnss_lon_deg"), json!(s.lon_deg));
        let est = cell(row, "est_speed_m_s")
            .as_f64()
            .expect("an estimate in AUTO");
        assert!((0.0..10.0).contains(&est), "{est}");
        assert!(cell(row, "est_heading_deg").is_number(), "{row:?}");
        // The estimate is the one the replay computes for that cycle.
        let replayed = crate::logtools::replay::replay(&run, run.config.as_ref().unwrap()).unwrap();
        let e = replayed.cycles[usize::try_from(c.msg.cycle).unwrap()]
            .message
            .estimate;
        assert_eq!(
            est,
            num(e.speed_mm_s.unwrap().value / 1e3).as_f64().unwrap()
        );
        // A log without its configuration cannot be replayed: the estimate stays empty.
        let mut bare = run.clone();
        bare.config = None;
        let rows = super::rows(&bare, Channel::Cycle, 0.0, 0.1);
        assert!(rows.iter().all(|r| cell(r, "est_speed_m_s").is_null()));
    }
}
