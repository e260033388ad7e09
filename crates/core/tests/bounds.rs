//! Bounds of the control step under anything the world can send: random command streams (any
//! command, any data including out of range, at any time), interleaved with sensor packets good
//! and bad (random IMU, GNSS with any speed, heading and fix, missing, late, stale answers,
//! device errors), missed periods and clock jumps, over random channel tables. Whatever
//! happens, every output stays within its channel's `min_us..=max_us` or is its safe value,
//! and in KILLED and FAILSAFE every output is the safe value.

use dima_core::config::{ChannelConfig, Config, OffKeyword, SafeOutput};
use dima_core::step::{CycleInputs, SensorInput};
use dima_core::{Command, Core, CoreState, Mode, Nanos, ReceivedCommand};
use dima_groundlink::Percent;
use dima_sensorboard::nav_pvt::FLAG_GNSS_FIX_OK;
use dima_sensorboard::{GnssFrame, NavPvt, RawPacket, SensorPacket};
use proptest::prelude::*;

const MS: Nanos = 1_000_000;

/// Any command, with any data its type can carry: percentages are a checked type (0..=100
/// by construction), speeds and headings any `i32`.
fn command() -> impl Strategy<Value = Command> {
    prop_oneof![
        3 => Just(Command::Heartbeat),
        1 => Just(Command::Kill),
        2 => Just(Command::Revive),
        2 => (0u8..=100).prop_map(|p| Command::Throttle(Percent::new(p).unwrap())),
        2 => (0u8..=100).prop_map(|p| Command::Steering(Percent::new(p).unwrap())),
        2 => (0u8..=100).prop_map(|p| Command::Tail(Percent::new(p).unwrap())),
        2 => prop_oneof![any::<i32>(), -1_000..60_000i32]
            .prop_map(|mm_s| Command::SpeedSetpoint { mm_s }),
        2 => prop_oneof![any::<i32>(), -1_000..37_000_000i32]
            .prop_map(|deg_e5| Command::HeadingSetpoint { deg_e5 }),
    ]
}

/// What the sensor board gave this cycle.
#[derive(Debug, Clone)]
enum Sensor {
    /// A valid packet with these contents (and a healthy GNSS solution), complete this
    /// long after the request.
    Packet {
        packet: Box<SensorPacket>,
        healthy_gnss: bool,
        after_ns: Nanos,
    },
    NoAnswer,
    DeviceError,
    NotRequested,
}

/// IMU words and a GNSS solution; `None` GNSS: a healthy receiver (3-D fix, good accuracy,
/// a new epoch every 100 ms of the cycle clock), so AUTO can last.
fn sensor_packet() -> impl Strategy<Value = (SensorPacket, bool)> {
    (
        // Mostly a car on its wheels (a tilted one refuses every revive), sometimes any word.
        prop_oneof![
            9 => (-700i16..=700, -700i16..=700, 600i16..=2047).prop_map(|(x, y, z)| [x, y, z]),
            1 => prop::array::uniform3(-2048i16..=2047),
        ],
        prop::array::uniform3(any::<i16>()),
        any::<u32>(),
        prop_oneof![Just(0u8), Just(2), Just(3), any::<u8>()],
        any::<i32>(),
        prop_oneof![any::<i32>(), 0..36_000_000i32],
        prop_oneof![0u32..2_000, any::<u32>()],
        prop::bool::weighted(0.8),
    )
        .prop_map(
            |(accel, gyro, itow_ms, fix_type, g_speed, head, s_acc, healthy)| {
                let pvt = NavPvt {
                    itow_ms,
                    fix_type,
                    flags: if fix_type == 0 { 0 } else { FLAG_GNSS_FIX_OK },
                    g_speed_mm_s: g_speed,
                    head_mot_deg_e5: head,
                    s_acc_mm_s: s_acc,
                    ..NavPvt::default()
                };
                let packet = SensorPacket {
                    accel,
                    gyro,
                    gnss: GnssFrame::from_nav_pvt(&pvt),
                    ..SensorPacket::default()
                };
                (packet, healthy)
            },
        )
}

/// A healthy receiver's solution at `now`: a new epoch every 100 ms, moving at a random speed
/// and heading from the packet's own solution.
fn set_healthy_gnss(packet: &mut SensorPacket, now: Nanos) {
    let random = packet.gnss.nav_pvt();
    let pvt = NavPvt {
        itow_ms: (now / (100 * MS) * 100) as u32,
        fix_type: 3,
        flags: FLAG_GNSS_FIX_OK,
        g_speed_mm_s: random.map_or(1_000, |p| p.g_speed_mm_s.rem_euclid(8_000)),
        head_mot_deg_e5: random.map_or(0, |p| p.head_mot_deg_e5.rem_euclid(36_000_000)),
        s_acc_mm_s: 150,
        ..NavPvt::default()
    };
    packet.gnss = GnssFrame::from_nav_pvt(&pvt);
}

fn sensor() -> impl Strategy<Value = Sensor> {
    prop_oneof![
        // Mostly healthy answers (3.3 ms), some stale (too soon) or late (past the deadline).
        8 => (sensor_packet(), prop_oneof![8 => Just(3_300_000u64), 1 => 0..10_000_000u64])
            .prop_map(|((p, healthy_gnss), after_ns)| Sensor::Packet {
                packet: Box::new(p),
                healthy_gnss,
                after_ns
            }),
        2 => Just(Sensor::NoAnswer),
        1 => Just(Sensor::DeviceError),
        1 => Just(Sensor::NotRequested),
    ]
}

/// One cycle: time since the last one, missed periods, commands (arrived spread evenly over
/// the time since the last cycle: after a stall, some longer ago than the comms timeout), the
/// sensor input.
#[derive(Debug, Clone)]
struct Cycle {
    dt_ns: Nanos,
    missed: u32,
    commands: Vec<Command>,
    sensor: Sensor,
    stale_packets: u32,
}

fn cycle() -> impl Strategy<Value = Cycle> {
    (
        // Mostly the 4 ms period, sometimes any gap up to 3 s (a stalled machine).
        prop_oneof![20 => Just(4 * MS), 3 => 0..20 * MS, 1 => 0..3_000 * MS],
        prop_oneof![10 => Just(0u32), 1 => 0..5u32, 1 => any::<u32>()],
        prop::collection::vec(command(), 0..4),
        sensor(),
        prop_oneof![5 => Just(0u32), 1 => 0..3u32],
    )
        .prop_map(|(dt_ns, missed, commands, sensor, stale_packets)| Cycle {
            dt_ns,
            missed,
            commands,
            sensor,
            stale_packets,
        })
}

/// A channel table that passes validation: any limits within 1..=4000 µs, neutral and safe
/// inside them (or, with `allow_off`, safe "off" on steering and tail; a throttle safe pulse
/// other than neutral with `allow_safe_not_neutral`).
fn channel(number: u8, may_be_off: bool) -> impl Strategy<Value = ChannelConfig> {
    (
        500u16..2_000,
        50u16..1_500,
        0.0f64..=1.0,
        0.0f64..=1.0,
        any::<bool>(),
    )
        .prop_map(move |(min_us, span, n, s, off)| {
            let max_us = min_us + span;
            let at = |f: f64| min_us + (f64::from(span) * f).round() as u16;
            let off = off && may_be_off;
            ChannelConfig {
                channel: number,
                min_us,
                max_us,
                neutral_us: at(n),
                safe: if off {
                    SafeOutput::Off(OffKeyword::Off)
                } else {
                    SafeOutput::PulseUs(at(s))
                },
                allow_off: off,
                allow_safe_not_neutral: at(s) != at(n),
            }
        })
}

fn config() -> impl Strategy<Value = Config> {
    (
        channel(0, false),
        channel(1, true),
        channel(2, true),
        any::<bool>(),
    )
        .prop_map(|(throttle, steering, tail, default_channels)| {
            let mut c = Config::default();
            if !default_channels {
                c.channels.throttle = throttle;
                c.channels.steering = steering;
                c.channels.tail = tail;
            }
            c
        })
}

/// Runs `cycles` through a core built from `config`, checking every cycle's outputs against
/// the bounds; `seen` gets each cycle's mode.
fn run_case(
    config: &Config,
    cycles: &[Cycle],
    mut seen: impl FnMut(Mode),
) -> Result<(), TestCaseError> {
    config.validate().expect("the strategy builds valid tables");
    let mut core = Core::new(config).expect("valid");
    let mut state = CoreState::new();
    let channels = [
        &config.channels.throttle,
        &config.channels.steering,
        &config.channels.tail,
    ];
    let safe = core.outputs().safe().pulse_us;
    let mut now: Nanos = 1_000 * MS;
    for (i, c) in cycles.iter().enumerate() {
        now += c.dt_ns;
        let sensor = match &c.sensor {
            Sensor::Packet {
                packet,
                healthy_gnss,
                after_ns,
            } => {
                let mut packet = **packet;
                if *healthy_gnss {
                    set_healthy_gnss(&mut packet, now);
                }
                SensorInput::Packet {
                    raw: RawPacket::new(packet.encode()).expect("a valid packet"),
                    t_request_ns: now,
                    t_complete_ns: now + after_ns,
                }
            }
            Sensor::NoAnswer => SensorInput::NoAnswer { t_request_ns: now },
            Sensor::DeviceError => SensorInput::DeviceError,
            Sensor::NotRequested => SensorInput::NotRequested,
        };
        let n = c.commands.len() as Nanos;
        let commands: Vec<ReceivedCommand> = (1..)
            .zip(&c.commands)
            .map(|(k, &command)| {
                ReceivedCommand::new(command, now - c.dt_ns * (n + 1 - k) / (n + 1))
            })
            .collect();
        let inputs = CycleInputs {
            missed_periods: c.missed,
            commands: &commands,
            sensor,
            stale_packets: c.stale_packets,
        };
        let out = core.step(&mut state, &inputs, now);
        seen(out.mode);
        let us = out.targets.pulse_us;
        if out.mode.is_safe() {
            prop_assert_eq!(
                us,
                safe,
                "cycle {}: {:?} with outputs {:?}",
                i,
                out.mode,
                us
            );
        } else {
            for (k, ch) in channels.iter().enumerate() {
                prop_assert!(
                    (ch.min_us..=ch.max_us).contains(&us[k]) || us[k] == safe[k],
                    "cycle {}: {:?} channel {} at {} µs outside {}..={}",
                    i,
                    out.mode,
                    k,
                    us[k],
                    ch.min_us,
                    ch.max_us
                );
            }
        }
        prop_assert_eq!(out.mode, state.safety.mode);
        if i == 0 && !c.commands.contains(&Command::Revive) {
            prop_assert_eq!(out.mode, Mode::Killed);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    #[test]
    fn outputs_never_leave_their_bounds(config in config(), cycles in prop::collection::vec(cycle(), 1..400)) {
        run_case(&config, &cycles, |_| {})?;
    }
}

/// The property above means something only if its random streams drive the robot: over the
/// same number of cases (a fixed seed), many cycles are in MANUAL and in AUTO.
#[test]
fn the_random_streams_reach_manual_and_auto() {
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let case = (config(), prop::collection::vec(cycle(), 1..400));
    let mut cycles_in = std::collections::HashMap::new();
    for _ in 0..128 {
        let (config, cycles) = case.new_tree(&mut runner).unwrap().current();
        run_case(&config, &cycles, |mode| {
            *cycles_in.entry(mode).or_insert(0) += 1
        })
        .unwrap();
    }
    eprintln!("cycles per mode: {cycles_in:?}");
    for mode in [Mode::Manual, Mode::Auto, Mode::Killed, Mode::Failsafe] {
        assert!(
            cycles_in.get(&mode).copied().unwrap_or(0) > 100,
            "{mode:?}: {cycles_in:?}"
        );
    }
}
