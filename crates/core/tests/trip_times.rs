//! Every failsafe that counts packets or periods trips within about a second, whatever the loop
//! rate. For loop rates across the range the configuration accepts, each protection is set to
//! the most lenient value `Config::validate` accepts at that rate (found by searching, not
//! copied from the validator), its fault is driven through `Core::step` in virtual time, and
//! the time to FAILSAFE is measured. The overrun rule, besides, lets one short stall of the
//! host pass.

use dima_core::config::{Config, ConfigError};
use dima_core::step::{CycleInputs, CycleOutputs, SensorInput};
use dima_core::{Command, Core, CoreState, FailsafeCause, Mode, Nanos, ReceivedCommand};
use dima_sensorboard::{RawPacket, SensorPacket};
use proptest::prelude::*;

const MS: Nanos = 1_000_000;
/// "About a second": no protection may take longer to trip.
const TRIP_BOUND: Nanos = 1_000 * MS;
/// A protection that has not tripped after this long is reported as never tripping.
const GIVE_UP: Nanos = 60_000 * MS;

/// A configuration at `rate` Hz with a sensor link that fits its period where one can (460 800
/// baud 8N2 up to 250 Hz, 3 Mbaud 8N1 above), and every counted protection at its strictest.
fn strict_config(rate: u32) -> Config {
    let mut c = Config::default();
    c.realtime.loop_rate_hz = rate;
    c.maestro.servo_refresh_hz = c.maestro.servo_refresh_hz.min(rate);
    let period_us = 1_000_000 / rate.max(1);
    if period_us < 4_000 {
        // 132 bytes at 3 Mbaud 8N1: 440 µs on the wire.
        c.sensor.baud = 3_000_000;
        c.sensor.stop_bits = 1;
        c.sensor.packet_deadline_us = 460;
        c.maestro.write_budget_us = period_us.saturating_sub(460).max(1);
    }
    c.safety.sensor_loss_packets = 1;
    c.safety.imu_stuck_packets = 2;
    c.safety.overrun_limit = 1;
    c
}

/// The strict configuration at `rate`, or `None` when the configuration refuses the rate
/// itself (too slow, or no sensor link fits its period).
fn allowed(rate: u32) -> Option<Config> {
    let c = strict_config(rate);
    match c.validate() {
        Ok(()) => Some(c),
        Err(ConfigError::Invalid { key, .. })
            if key == "realtime.loop_rate_hz" || key == "sensor.packet_deadline_us" =>
        {
            None
        }
        Err(e) => panic!("{rate} Hz: the strict configuration is refused: {e}"),
    }
}

/// The largest value of a key (set by `set`) that the configuration accepts, starting from
/// `config`'s value, which it accepts; acceptance is assumed to be a range.
fn most_lenient(config: &Config, set: impl Fn(&mut Config, u32), start: u32) -> Config {
    let with = |v: u32| {
        let mut c = config.clone();
        set(&mut c, v);
        c
    };
    let ok = |v: u32| with(v).validate().is_ok();
    assert!(ok(start), "the starting value {start} is refused");
    let (mut lo, mut hi) = (start, 10_000_000u32);
    if ok(hi) {
        return with(hi);
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    with(lo)
}

/// The realtime loop around the step at the configured rate, in virtual time: a heartbeat
/// every cycle, the board answering with changing IMU words, revived into MANUAL.
struct Rig {
    core: Core,
    state: CoreState,
    now: Nanos,
    period: Nanos,
    answer_after: Nanos,
    noise: i16,
    imu_running: bool,
    answering: bool,
}

impl Rig {
    fn revived(config: &Config) -> Rig {
        let deadline = u64::from(config.sensor.packet_deadline_us) * 1_000;
        let mut rig = Rig {
            core: Core::new(config).expect("a valid configuration"),
            state: CoreState::new(),
            now: 1_000 * MS,
            period: config.period_ns(),
            answer_after: (config.packet_wire_ns() + deadline) / 2,
            noise: 0,
            imu_running: true,
            answering: true,
        };
        for _ in 0..config.safety.revive_good_packets {
            rig.cycle(0, &[]);
        }
        let out = rig.cycle(0, &[Command::Revive]);
        assert_eq!(out.mode, Mode::Manual, "revive: {:?}", out.refused);
        rig
    }

    /// One cycle whose wake-up skipped `missed` periods.
    fn cycle(&mut self, missed: u32, commands: &[Command]) -> CycleOutputs {
        self.now += self.period * (1 + u64::from(missed));
        if self.imu_running {
            self.noise = self.noise.wrapping_add(1);
        }
        let sensor = if self.answering {
            let p = SensorPacket {
                accel: [self.noise % 7, -3, 1_000],
                gyro: [1, self.noise % 5, -2],
                ..SensorPacket::default()
            };
            SensorInput::Packet {
                raw: RawPacket::new(p.encode()).expect("a valid packet"),
                t_request_ns: self.now,
                t_complete_ns: self.now + self.answer_after,
            }
        } else {
            SensorInput::NoAnswer {
                t_request_ns: self.now,
            }
        };
        // Every command arrived just before this cycle.
        let received: Vec<ReceivedCommand> = commands
            .iter()
            .map(|&c| ReceivedCommand::new(c, self.now))
            .collect();
        let inputs = CycleInputs {
            missed_periods: missed,
            commands: &received,
            sensor,
            stale_packets: 0,
        };
        self.core.step(&mut self.state, &inputs, self.now)
    }

    /// Cycles (the k-th skipping `missed(k)` periods) until the robot leaves MANUAL: the time
    /// from the last cycle before them and the cause, or `None` within [`GIVE_UP`].
    fn time_to_failsafe(&mut self, missed: impl Fn(u64) -> u32) -> Option<(Nanos, FailsafeCause)> {
        let start = self.now;
        for k in 0.. {
            let out = self.cycle(missed(k), &[Command::Heartbeat]);
            if out.mode != Mode::Manual {
                assert_eq!(out.mode, Mode::Failsafe);
                return Some((self.now - start, out.cause.expect("a failsafe has a cause")));
            }
            if self.now - start > GIVE_UP {
                return None;
            }
        }
        unreachable!()
    }
}

/// Checks that `fault`, driven into a revived robot with `config`, trips `cause` within
/// [`TRIP_BOUND`].
fn assert_trips(
    config: &Config,
    what: &str,
    cause: FailsafeCause,
    fault: impl FnOnce(&mut Rig),
    missed: impl Fn(u64) -> u32,
) {
    let rate = config.realtime.loop_rate_hz;
    let mut rig = Rig::revived(config);
    fault(&mut rig);
    match rig.time_to_failsafe(missed) {
        Some((t, c)) => {
            assert_eq!(c, cause, "{rate} Hz, {what}");
            assert!(
                t <= TRIP_BOUND,
                "{rate} Hz, {what}: {cause:?} after {} ms",
                t / MS
            );
        }
        None => panic!(
            "{rate} Hz, {what}: no failsafe within {} s",
            GIVE_UP / 1_000 / MS
        ),
    }
}

/// Every protection at its most lenient accepted value trips within about a second at `rate`;
/// false when the rate itself is refused.
fn check_rate(rate: u32) -> bool {
    let Some(strict) = allowed(rate) else {
        return false;
    };
    let c = most_lenient(&strict, |c, v| c.safety.sensor_loss_packets = v, 1);
    let what = format!("sensor_loss_packets = {}", c.safety.sensor_loss_packets);
    assert_trips(
        &c,
        &what,
        FailsafeCause::SensorLoss,
        |rig| rig.answering = false,
        |_| 0,
    );

    let c = most_lenient(&strict, |c, v| c.safety.imu_stuck_packets = v, 2);
    let what = format!("imu_stuck_packets = {}", c.safety.imu_stuck_packets);
    assert_trips(
        &c,
        &what,
        FailsafeCause::ImuStuck,
        |rig| rig.imu_running = false,
        |_| 0,
    );

    // The overrun rule with both its keys at their most lenient.
    let c = most_lenient(&strict, |c, v| c.safety.overrun_limit = v, 1);
    let c = most_lenient(&c, |c, v| c.safety.max_stall_ms = v, c.safety.max_stall_ms);
    let s = &c.safety;
    let what = format!(
        "overrun_limit = {}, max_stall_ms = {}",
        s.overrun_limit, s.max_stall_ms
    );
    // Sustained overload, 1.5 periods of work per cycle (6 ms at 250 Hz): the wake-ups
    // alternate between one that skips a period and one that does not.
    assert_trips(
        &c,
        &format!("{what}, alternating skips"),
        FailsafeCause::Overrun,
        |_| {},
        |k| (k % 2) as u32,
    );
    // The most periods one stall may skip without tripping by itself.
    let period = c.period_ns();
    let stall = (u64::from(s.max_stall_ms) * MS / period) as u32;
    // One stall just longer.
    assert_trips(
        &c,
        &format!("{what}, one stall of {} periods", stall + 1),
        FailsafeCause::Overrun,
        |_| {},
        |k| if k == 0 { stall + 1 } else { 0 },
    );
    // Stalls just shorter, back to back.
    assert_trips(
        &c,
        &format!("{what}, stalls of {stall} periods"),
        FailsafeCause::Overrun,
        |_| {},
        |_| stall,
    );
    true
}

#[test]
fn every_counted_failsafe_trips_within_a_second_at_the_edges_of_the_rate_range() {
    let mut checked = Vec::new();
    for rate in [
        1, 2, 5, 9, 10, 11, 25, 50, 99, 100, 101, 200, 250, 251, 333, 500, 999, 1_000, 1_500,
        2_000, 2_100, 2_300, 5_000, 10_000,
    ] {
        if check_rate(rate) {
            checked.push(rate);
        }
    }
    // The table means something only if the usual rates are among those allowed.
    for rate in [10, 100, 250, 500, 1_000, 2_000] {
        assert!(checked.contains(&rate), "{rate} Hz refused: {checked:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn every_counted_failsafe_trips_within_a_second_at_any_allowed_rate(rate in 1u32..=10_000) {
        check_rate(rate);
    }
}

/// The default configuration at `rate` Hz (with a sensor link that fits), with `safety`
/// keys set from `(key, value)` pairs as a file would set them.
fn config_at(rate: u32, safety: &[(&str, i64)]) -> Config {
    let mut c = strict_config(rate);
    let defaults = Config::default();
    c.safety = defaults.safety.clone();
    c.safety.overrun_limit = c.safety.overrun_limit.min(rate / 10);
    let mut table = toml::Table::try_from(&c).expect("a configuration is a table");
    let section = table
        .get_mut("safety")
        .and_then(toml::Value::as_table_mut)
        .expect("a [safety] section");
    for &(key, value) in safety {
        section.insert(key.into(), toml::Value::Integer(value));
    }
    Config::from_toml(&toml::to_string(&table).unwrap(), "test").expect("a valid configuration")
}

/// Runs `cycles` cycles of (missed periods, commands) after a revive; the first mode other
/// than MANUAL and its cause, if any.
fn run_pattern(config: &Config, missed: impl Fn(u64) -> u32, cycles: u64) -> Option<FailsafeCause> {
    let mut rig = Rig::revived(config);
    for k in 0..cycles {
        let out = rig.cycle(missed(k), &[Command::Heartbeat]);
        if out.mode != Mode::Manual {
            return Some(out.cause.expect("a failsafe has a cause"));
        }
    }
    None
}

#[test]
fn one_host_stall_of_73_ms_at_250_hz_does_not_trip() {
    // Woke 73 ms late: 18 periods skipped at once, then on time.
    let config = config_at(250, &[]);
    assert_eq!(
        run_pattern(&config, |k| if k == 100 { 18 } else { 0 }, 500),
        None
    );
}

#[test]
fn one_8_ms_stall_among_a_few_late_wake_ups_at_1_khz_does_not_trip() {
    // At 1 kHz: one wake-up 8 ms late, and three that skip a single period, within a second.
    let config = config_at(1_000, &[]);
    let missed = |k: u64| match k {
        100 => 8,
        300 | 500 | 700 => 1,
        _ => 0,
    };
    assert_eq!(run_pattern(&config, missed, 1_500), None);
}

#[test]
fn sustained_overload_trips_within_a_second_at_250_hz_and_at_1_khz() {
    for rate in [250, 1_000] {
        // 1.5 periods of work per cycle (6 ms at 250 Hz): alternating skips.
        let config = config_at(rate, &[]);
        assert_trips(
            &config,
            "alternating skips",
            FailsafeCause::Overrun,
            |_| {},
            |k| (k % 2) as u32,
        );
        // Every wake-up 20 periods late (80 ms at 250 Hz): each stall is short, together they
        // are most of the time.
        assert_trips(
            &config,
            "stalls of 20 periods",
            FailsafeCause::Overrun,
            |_| {},
            |_| 20,
        );
    }
}

#[test]
fn a_stall_longer_than_max_stall_ms_trips() {
    // 250 Hz: 25 periods are 100 ms, 26 are 104 ms.
    let config = config_at(250, &[("max_stall_ms", 100)]);
    let stall = |periods: u32| move |k: u64| if k == 100 { periods } else { 0 };
    assert_eq!(run_pattern(&config, stall(25), 500), None);
    assert_eq!(
        run_pattern(&config, stall(26), 500),
        Some(FailsafeCause::Overrun)
    );
    // The default, 250 ms: 62 periods (248 ms) pass, 63 (252 ms) trip.
    let config = config_at(250, &[]);
    assert_eq!(run_pattern(&config, stall(62), 500), None);
    assert_eq!(
        run_pattern(&config, stall(63), 500),
        Some(FailsafeCause::Overrun)
    );
}
