//! A run's trace as an MCAP file with a robot log's channels, written by the application's
//! own logger code, so `dima log info|plot|replay` read it like any robot log.

use std::path::Path;

use dima_core::Nanos;
use dima_log::schema;

use super::runner::Simulation;
use dima_robot::logging::{CycleLog, McapLog};

/// Log time of virtual time 0: 2026-01-01T00:00:00Z, ns (a fixed instant: the file does not
/// depend on when it was written).
pub const TRACE_EPOCH_NS: i128 = 1_767_225_600_000_000_000;

/// The mission the run's robot follows in AUTO, as `lat_deg,lon_deg` waypoints separated by
/// `;` (empty: none; the fence is in the configuration).
fn mission_text(sim: &Simulation) -> String {
    let Some(mission) = sim.navigation().and_then(|n| n.mission.as_ref()) else {
        return String::new();
    };
    let points: Vec<String> = mission
        .waypoints
        .iter()
        .map(|w| format!("{:.7},{:.7}", w.lat_deg, w.lon_deg))
        .collect();
    points.join(";")
}

/// Runs `sim` until `end_ns` (or `stop_after` past its first violation), writing every cycle
/// to `path`; the seed, the mission and the violations go into metadata.
pub fn write(
    path: &Path,
    seed: u64,
    duration_s: f64,
    sim: &mut Simulation,
    end_ns: Nanos,
    stop_after: Option<Nanos>,
) -> anyhow::Result<()> {
    let mut log = McapLog::create_file(path)?;
    log.set_time_offset(TRACE_EPOCH_NS);
    log.metadata(
        schema::METADATA_DIMA,
        &[
            ("version", env!("CARGO_PKG_VERSION").to_owned()),
            ("config", toml::to_string(sim.config())?),
        ],
    )?;
    // The mission and fence as the robot's own logs record them, so `dima log replay` follows
    // the same mission and `dima log plot --what track` draws it.
    let navigation = sim.navigation().cloned().unwrap_or_default();
    log.metadata(
        schema::METADATA_NAVIGATION,
        &[("json", serde_json::to_string(&navigation)?)],
    )?;
    log.metadata(
        "dst",
        &[
            ("seed", seed.to_string()),
            ("duration_s", duration_s.to_string()),
            ("mission", mission_text(sim)),
        ],
    )?;
    let mut failed = None;
    sim.run_until(
        end_ns,
        stop_after,
        Some(&mut |record| {
            if failed.is_none() {
                failed = log.record(record, true).err();
            }
        }),
    );
    if let Some(error) = failed {
        return Err(error);
    }
    let violations: Vec<String> = sim
        .violations()
        .iter()
        .map(|v| format!("{} at cycle {}: {}", v.invariant.name(), v.cycle, v.detail))
        .collect();
    log.metadata(
        "dst_result",
        &[
            ("violations", violations.len().to_string()),
            ("first", violations.first().cloned().unwrap_or_default()),
        ],
    )?;
    log.finish()?;
    Ok(())
}
