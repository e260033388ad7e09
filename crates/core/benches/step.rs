//! Cost of one control step (commands, pairing, monitors, safety, controller, output mapping)
//! per cycle, in MANUAL and in AUTO, and of a Maestro Set Target frame for three channels.
//!
//! ```text
//! cargo bench -p dima-core -- --warm-up-time 1 --measurement-time 3
//! ```

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use dima_core::config::Config;
use dima_core::step::{CycleInputs, SensorInput};
use dima_core::{Command, Core, CoreState, ReceivedCommand};
use dima_groundlink::Percent;
use dima_sensorboard::nav_pvt::FLAG_GNSS_FIX_OK;
use dima_sensorboard::{GnssFrame, NavPvt, RawPacket, SensorPacket};

const CYCLES: u64 = 1_000;
/// The cycle of the revive and setpoints: after the good packets a revive needs.
const SETUP_CYCLE: usize = 30;
const PERIOD: u64 = 4_000_000;

fn packets() -> Vec<RawPacket> {
    (0..CYCLES)
        .map(|i| {
            let pvt = NavPvt {
                itow_ms: (i / 25 * 100) as u32,
                fix_type: 3,
                flags: FLAG_GNSS_FIX_OK,
                g_speed_mm_s: 1_800,
                head_mot_deg_e5: 8_000_000,
                s_acc_mm_s: 150,
                ..NavPvt::default()
            };
            let p = SensorPacket {
                accel: [(i % 7) as i16, -3, 1_000],
                gyro: [1, (i % 5) as i16, -40],
                gnss: GnssFrame::from_nav_pvt(&pvt),
                ..SensorPacket::default()
            };
            RawPacket::new(p.encode()).expect("valid")
        })
        .collect()
}

/// `CYCLES` steps, with `setup` commands once the sensor link is healthy enough for a revive.
fn run(core: &mut Core, packets: &[RawPacket], setup: &[Command]) -> u64 {
    let mut state = CoreState::new();
    let mut sum = 0u64;
    for (i, raw) in packets.iter().enumerate() {
        let now = 1_000_000_000 + i as u64 * PERIOD;
        let commands: &[Command] = match i {
            SETUP_CYCLE => setup,
            _ if i % 25 == 0 => &[Command::Heartbeat],
            _ => &[],
        };
        let mut received = [ReceivedCommand::new(Command::Heartbeat, now); 4];
        for (r, &command) in received.iter_mut().zip(commands) {
            r.command = command;
        }
        let out = core.step(
            &mut state,
            &CycleInputs {
                missed_periods: 0,
                commands: &received[..commands.len()],
                sensor: SensorInput::Packet {
                    raw: *raw,
                    t_request_ns: now,
                    t_complete_ns: now + 3_300_000,
                },
                stale_packets: 0,
            },
            now,
        );
        sum += u64::from(out.targets.pulse_us[0]);
    }
    sum
}

fn step(c: &mut Criterion) {
    let mut core = Core::new(&Config::default()).expect("the default configuration is valid");
    let packets = packets();
    let mut group = c.benchmark_group("control_step");
    group.throughput(Throughput::Elements(CYCLES));
    group.bench_function("manual", |b| {
        let setup = [
            Command::Revive,
            Command::Throttle(Percent::new(60).unwrap()),
        ];
        b.iter(|| run(&mut core, black_box(&packets), &setup));
    });
    group.bench_function("auto", |b| {
        let setup = [
            Command::Revive,
            Command::SpeedSetpoint { mm_s: 2_500 },
            Command::HeadingSetpoint { deg_e5: 9_000_000 },
        ];
        b.iter(|| run(&mut core, black_box(&packets), &setup));
    });
    group.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
