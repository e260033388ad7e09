//! From the loop's fixed-size [`CycleRecord`] to the typed log messages of
//! [`dima_log::schema`] (on the logger thread, never on the realtime thread).

use dima_log::schema::{
    ActionMessage, CommandMessage, CycleMessage, SensorInfoMessage, SensorMessage,
    SetpointsMessage, StateMessage,
};
use dima_sensorboard::SensorPacket;

use crate::app::record::{event_list, CycleRecord};

fn us(ns: u64) -> f64 {
    ns as f64 / 1_000.0
}

/// The decoded packet used this cycle.
pub fn sensor_message(p: &SensorPacket, gyro_z_dps: f32, gnss_fix_ok: bool) -> SensorMessage {
    let pvt = p.nav_pvt();
    SensorMessage {
        accel: p.accel,
        gyro: p.gyro,
        mag: p.mag,
        rhall: p.rhall,
        press_raw: p.press_raw,
        temp_raw: p.temp_raw,
        gyro_z_dps,
        gnss_fix_ok,
        itow_ms: pvt.map(|v| v.itow_ms),
        lat_deg: pvt.map(|v| v.lat_deg()),
        lon_deg: pvt.map(|v| v.lon_deg()),
        g_speed_mm_s: pvt.map(|v| v.g_speed_mm_s),
        head_mot_deg: pvt.map(|v| v.head_mot_deg()),
        num_sv: pvt.map(|v| v.num_sv),
    }
}

/// The `/dima/cycle` message of a record.
pub fn cycle_message(r: &CycleRecord) -> CycleMessage {
    let out = &r.outputs;
    let since = |a: u64, b: u64| (a != 0 && b != 0).then(|| us(a.saturating_sub(b)));
    let compute_from = if r.t_packet_ns != 0 {
        r.t_packet_ns
    } else {
        r.tick.wake_ns
    };
    let sp = &r.setpoints;
    let nonzero = |t: u64| (t != 0).then_some(t);
    CycleMessage {
        cycle: r.cycle,
        wake_ns: r.tick.wake_ns,
        mode: out.mode,
        cause: out.cause,
        wake_latency_us: us(r.tick.latency_ns),
        missed_periods: r.tick.missed,
        packet: out.verdict,
        packet_ok: out.verdict.is_ok(),
        request_to_packet_us: out.request_to_packet_ns.map(us),
        t_request_ns: nonzero(r.t_request_ns),
        t_complete_ns: nonzero(r.t_packet_ns),
        stale_passed: r.stale_passed,
        commands: r
            .commands()
            .iter()
            .map(|&c| CommandMessage::from(c))
            .collect(),
        compute_us: us(r.t_compute_ns.saturating_sub(compute_from)),
        servo_write_us: since(r.t_write_ns, r.t_compute_ns),
        sensor: out.packet.as_ref().map(|p| {
            let fix_ok = p
                .nav_pvt()
                .is_some_and(|pvt| dima_core::monitor::gnss::is_valid(&pvt, u32::MAX));
            sensor_message(p, out.values.gyro_z_dps, fix_ok)
        }),
        gnss_age_ms: out.gnss_age_ns.map(|ns| ns as f64 / 1e6),
        setpoints: SetpointsMessage {
            throttle_pct: sp.throttle.map(|p| p.get()),
            steering_pct: sp.steering.map(|p| p.get()),
            tail_pct: sp.tail.map(|p| p.get()),
            speed_mm_s: sp.speed_mm_s,
            heading_deg: sp.heading_deg_e5.map(|d| f64::from(d) * 1e-5),
        },
        action: ActionMessage {
            throttle: out.action.throttle,
            steering: out.action.steering,
            tail: out.action.tail,
        },
        targets_us: out.targets.pulse_us,
        counters: r.counters,
        link: r.link,
        auto_source: out.auto_source,
        waypoint: out.mission.map(|m| m.waypoint),
        cross_track_m: out.mission.map(|m| f64::from(m.cross_track_m)),
    }
}

/// The `/dima/state` message of a record with events.
pub fn state_message(r: &CycleRecord) -> StateMessage {
    StateMessage {
        cycle: r.cycle,
        mode: r.outputs.mode,
        cause: r.outputs.cause,
        refused: r.outputs.refused,
        events: event_list(r.events).collect(),
    }
}

/// The `/sensor/info` message of an info frame.
pub fn info_message(info: &dima_sensorboard::InfoFrame) -> SensorInfoMessage {
    SensorInfoMessage::from(info)
}
