//! The compute path of one cycle (`dima_core::Core::step` with the controllers, as `dima bench
//! cycle` measures it) never allocates: a counting global allocator counts every allocation,
//! reallocation and deallocation the measuring thread makes.

#[path = "../../robot/tests/common/mod.rs"]
mod common;

use common::counting_alloc::{CountingAllocator, COUNTING, EVENTS};
use common::packet;
use dima_groundlink::{Command, Percent};

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

#[test]
fn the_cycle_compute_path_never_allocates() {
    use dima_core::{Core, CoreState, Mode, ReceivedCommand};
    use dima_tools::bench::measured_cycles;
    use dima_tools::logtools::replay::{RecordedCycle, RecordedSensor};
    let config = dima_robot::config::Config::default();
    let mut core = Core::new(&config).expect("the default configuration is valid");
    let period = 4_000_000u64;
    // Revive once the link is healthy, drive, AUTO: the controllers run in most cycles.
    let cycles: Vec<RecordedCycle> = (0..2_000u64)
        .map(|i| RecordedCycle {
            t_ns: i * period,
            cycle: i,
            wake_ns: 1_000_000_000 + i * period,
            missed_periods: 0,
            // Each command arrived 1 ms before the cycle that takes it.
            commands: match i {
                30 => vec![
                    Command::Revive,
                    Command::Throttle(Percent::new(60).unwrap()),
                ],
                32 => vec![
                    Command::SpeedSetpoint { mm_s: 2_000 },
                    Command::HeadingSetpoint { deg_e5: 9_000_000 },
                ],
                _ if i % 25 == 0 => vec![Command::Heartbeat],
                _ => Vec::new(),
            }
            .into_iter()
            .map(|c| ReceivedCommand::new(c, 1_000_000_000 + i * period - 1_000_000))
            .collect(),
            sensor: RecordedSensor::Packet {
                bytes: packet(i).encode(),
                t_request_ns: 1_000_000_000 + i * period,
                t_complete_ns: 1_000_000_000 + i * period + 3_300_000,
            },
            stale_packets: 0,
            mode: Mode::Killed,
            targets_us: [0; 3],
        })
        .collect();
    let mut state = CoreState::new();
    COUNTING.with(|c| c.set(true));
    let sink = measured_cycles(&mut core, &mut state, &cycles, [0, 1, 2]);
    COUNTING.with(|c| c.set(false));
    std::hint::black_box(sink);
    assert_eq!(
        EVENTS.with(|n| n.get()),
        0,
        "allocations in the compute path"
    );
    assert_eq!(state.safety.mode, Mode::Auto, "the controller ran");
    assert!(state.counters.packets_ok >= 1_999);
}
