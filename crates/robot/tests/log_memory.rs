//! The MCAP log's memory is small and bounded, and the logger compresses on its own thread: a
//! global allocator tracks the bytes in use and their peak while a log file takes ten seconds
//! of 250 Hz cycle records, flushed every second as the logger thread does. The robot's
//! resident memory must stay flat for hours (the soak), and on the Jetson Nano a logger that
//! spawned compression workers would compete with the control loop for the cores.
//!
//! One test in this file, so no other test allocates beside it.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use dima_core::config::Config;
use dima_core::step::{CycleInputs, SensorInput};
use dima_core::{Command, Core, CoreState, ReceivedCommand};
use dima_robot::app::rt_loop::MAX_COMMANDS_PER_CYCLE;
use dima_robot::app::CycleRecord;
use dima_robot::logging::{CycleLog, McapLog};
use dima_robot::rt::{monotonic_ns, Tick};

struct PeakAllocator;

static IN_USE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn grew(bytes: usize) {
    let now = IN_USE.fetch_add(bytes, Ordering::Relaxed) + bytes;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

// SAFETY: forwards to the system allocator; the bookkeeping is two atomics.
unsafe impl GlobalAlloc for PeakAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        grew(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() {
            grew(new_size - layout.size());
        } else {
            IN_USE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        IN_USE.fetch_sub(layout.size(), Ordering::Relaxed);
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: PeakAllocator = PeakAllocator;

/// Resident memory of this process, KiB, from /proc.
fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

/// Threads of this process, from /proc.
fn threads() -> usize {
    std::fs::read_dir("/proc/self/task").unwrap().count()
}

/// A cycle record from the real control step (AUTO would need a sensor: MANUAL outputs).
fn record(core: &mut Core, state: &mut CoreState, cycle: u64) -> CycleRecord {
    let now_ns = monotonic_ns();
    let commands = [
        Command::Revive,
        Command::Throttle(dima_groundlink::Percent::new(60).unwrap()),
    ];
    let received = commands.map(|c| ReceivedCommand::new(c, now_ns));
    let applied: &[ReceivedCommand] = if cycle == 0 { &received } else { &[] };
    let outputs = core.step(
        state,
        &CycleInputs {
            missed_periods: 0,
            commands: applied,
            sensor: SensorInput::DeviceError,
            stale_packets: 0,
        },
        now_ns,
    );
    CycleRecord {
        cycle,
        tick: Tick {
            deadline_ns: now_ns,
            wake_ns: now_ns,
            latency_ns: cycle % 97 * 1_000,
            missed: 0,
        },
        t_request_ns: now_ns,
        t_packet_ns: now_ns + 3_000_000,
        t_compute_ns: now_ns + 3_100_000,
        t_write_ns: now_ns + 3_200_000,
        raw: None,
        info: None,
        outputs,
        setpoints: state.safety.setpoints,
        commands: [ReceivedCommand::new(Command::Heartbeat, 0); MAX_COMMANDS_PER_CYCLE],
        n_commands: 0,
        stale_passed: 0,
        counters: state.counters,
        link: Default::default(),
        events: 0,
    }
}

#[test]
fn a_log_file_takes_little_memory_and_no_threads() {
    const CYCLES: u64 = 2_500;
    const CYCLES_PER_FLUSH: u64 = 250;
    let dir = std::env::temp_dir().join(format!("dima-log-memory-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut core = Core::new(&Config::default()).unwrap();
    let mut state = CoreState::new();
    let records: Vec<CycleRecord> = (0..CYCLES)
        .map(|i| record(&mut core, &mut state, i))
        .collect();
    let threads_before = threads();
    let in_use_before = IN_USE.load(Ordering::Relaxed);
    let rss_before = rss_kib();
    PEAK.store(in_use_before, Ordering::Relaxed);

    let mut log = McapLog::create_file(&dir.join("memory.mcap")).unwrap();
    let mut threads_while_logging = 0;
    for r in &records {
        log.record(r, true).unwrap();
        if (r.cycle + 1) % CYCLES_PER_FLUSH == 0 {
            log.flush().unwrap();
            threads_while_logging = threads_while_logging.max(threads());
        }
    }
    let rss_while_logging = rss_kib();
    let path = log.finish().unwrap();
    let peak = PEAK.load(Ordering::Relaxed) - in_use_before;
    let size = std::fs::metadata(&path).unwrap().len();
    eprintln!(
        "{CYCLES} records in {size} bytes; peak Rust heap while logging {} KiB; resident memory \
         {rss_before} KiB before, {rss_while_logging} KiB while logging; threads \
         {threads_before} before, {threads_while_logging} while logging",
        peak / 1024
    );

    assert!(size > 10_000, "the records reached the file");
    assert_eq!(
        threads_while_logging, threads_before,
        "the log started threads of its own"
    );
    assert!(
        peak < 8 << 20,
        "{} KiB of heap for one log file",
        peak / 1024
    );
    let _ = std::fs::remove_dir_all(&dir);
}
