//! Realtime thread setup: SCHED_FIFO, CPU affinity, locked memory, a prefaulted stack,
//! `/dev/cpu_dma_latency` held at 0, and timer slack 1 ns when FIFO is refused. Every setting is
//! read back into an [`RtSetupReport`], printed once and stored in the log.
//!
//! Setup runs on the thread that will become realtime, before its first cycle: it may allocate,
//! the loop may not.

use std::fmt;
use std::fs::File;
use std::io::{Read, Write};

use nix::sched::{sched_getaffinity, sched_setaffinity, CpuSet};
use nix::sys::mman::{mlockall, MlockAllFlags};
use nix::unistd::Pid;
use serde::Serialize;

use crate::config::RealtimeConfig;

/// What to ask for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RtSettings {
    /// SCHED_FIFO priority, 0 for SCHED_OTHER.
    pub priority: u8,
    /// CPUs to pin to; empty: no pinning.
    pub cpus: Vec<usize>,
    /// `mlockall` current and future pages.
    pub lock_memory: bool,
    /// Stack to prefault, KiB.
    pub prefault_stack_kib: usize,
    /// Hold `/dev/cpu_dma_latency` at 0.
    pub cpu_dma_latency: bool,
    /// SCHED_FIFO, pinning and memory locking must succeed (see [`RtSetupReport::failures`]).
    pub required: bool,
}

impl From<&RealtimeConfig> for RtSettings {
    fn from(c: &RealtimeConfig) -> RtSettings {
        RtSettings {
            priority: c.priority,
            cpus: c.cpus.clone(),
            lock_memory: c.lock_memory,
            prefault_stack_kib: c.prefault_stack_kib,
            cpu_dma_latency: c.cpu_dma_latency,
            required: c.required,
        }
    }
}

/// What the kernel actually gave, read back after asking.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RtSetupReport {
    /// Thread name.
    pub thread: String,
    /// Policy read back (`SCHED_FIFO`, `SCHED_OTHER`, ...).
    pub policy: String,
    /// Priority read back.
    pub priority: i32,
    /// Why FIFO was not applied, if it was asked for and refused.
    pub fifo_error: Option<String>,
    /// CPUs the thread may run on, read back.
    pub cpus: Vec<usize>,
    /// Why pinning failed, if it did.
    pub affinity_error: Option<String>,
    /// `VmLck` from `/proc/self/status`, KiB (None when unreadable).
    pub locked_kib: Option<u64>,
    /// Why `mlockall` failed, if it did.
    pub mlock_error: Option<String>,
    /// Stack prefaulted, KiB.
    pub prefaulted_stack_kib: usize,
    /// The value read back from `/dev/cpu_dma_latency` while held, µs.
    pub cpu_dma_latency_us: Option<i32>,
    /// Why `/dev/cpu_dma_latency` could not be held, if it was asked for.
    pub cpu_dma_latency_error: Option<String>,
    /// Timer slack read back, ns.
    pub timer_slack_ns: i64,
    /// The kernel's `uname -v` (shows `PREEMPT RT` on a realtime kernel).
    pub kernel: String,
}

impl RtSetupReport {
    /// What of the realtime setup that was asked for failed (SCHED_FIFO, CPU pinning,
    /// `mlockall`), joined into one line; `None` when all of it holds.
    pub fn failures(&self) -> Option<String> {
        let failed: Vec<&str> = [&self.fifo_error, &self.affinity_error, &self.mlock_error]
            .into_iter()
            .flatten()
            .map(String::as_str)
            .collect();
        (!failed.is_empty()).then(|| failed.join("; "))
    }
}

/// Holds what must stay alive for the settings to hold (the `/dev/cpu_dma_latency` file).
#[derive(Debug)]
pub struct RtSetup {
    /// The read-back report.
    pub report: RtSetupReport,
    _dma_latency: Option<File>,
}

fn policy_name(policy: i32) -> String {
    match policy {
        libc::SCHED_FIFO => "SCHED_FIFO".into(),
        libc::SCHED_RR => "SCHED_RR".into(),
        libc::SCHED_OTHER => "SCHED_OTHER".into(),
        libc::SCHED_BATCH => "SCHED_BATCH".into(),
        libc::SCHED_IDLE => "SCHED_IDLE".into(),
        other => format!("policy {other}"),
    }
}

/// Sets SCHED_FIFO at `priority` on the calling thread (0: SCHED_OTHER).
pub fn set_fifo(priority: u8) -> std::io::Result<()> {
    let (policy, prio) = if priority == 0 {
        (libc::SCHED_OTHER, 0)
    } else {
        (libc::SCHED_FIFO, i32::from(priority))
    };
    let param = libc::sched_param {
        sched_priority: prio,
    };
    // SAFETY: pthread_self() is the calling thread; `param` is a valid sched_param.
    #[allow(unsafe_code)]
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), policy, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(std::io::Error::from_raw_os_error(rc))
    }
}

/// Policy and priority of the calling thread.
pub fn current_policy() -> (i32, i32) {
    let mut policy = 0;
    let mut param = libc::sched_param { sched_priority: 0 };
    // SAFETY: both out-pointers are valid for writes.
    #[allow(unsafe_code)]
    let rc = unsafe { libc::pthread_getschedparam(libc::pthread_self(), &mut policy, &mut param) };
    if rc == 0 {
        (policy, param.sched_priority)
    } else {
        (-1, -1)
    }
}

/// Prepares glibc's allocator for locked memory; call before any thread is spawned. One arena
/// (each thread's own arena would reserve and, under `mlockall(MCL_FUTURE)`, lock 64 MiB), no
/// `mmap` for large blocks and no trimming, so memory freed and reused never faults again.
/// Returns whether it applied (glibc only).
pub fn prepare_allocator_for_locking() -> bool {
    #[cfg(target_env = "gnu")]
    {
        // SAFETY: mallopt only changes allocator parameters.
        #[allow(unsafe_code)]
        unsafe {
            libc::mallopt(libc::M_ARENA_MAX, 1) == 1
                && libc::mallopt(libc::M_MMAP_MAX, 0) == 1
                && libc::mallopt(libc::M_TRIM_THRESHOLD, -1) == 1
        }
    }
    #[cfg(not(target_env = "gnu"))]
    {
        false
    }
}

/// Below this size glibc serves a block from its heaps; from it on a block is mapped on its
/// own and returned to the system when freed ([`map_large_blocks`]).
pub const MMAP_THRESHOLD: usize = 128 * 1024;

/// Without locked memory: blocks of [`MMAP_THRESHOLD`] or more are always mapped on their own
/// and unmapped when freed. glibc otherwise raises that threshold to the size of the largest
/// block freed so far, after which such blocks come from a heap that keeps every page it ever
/// touched: each log file's zstd context (about 2.5 MB, a new one per file) then made a long
/// run's resident memory grow in steps. Returns whether it applied (glibc only).
pub fn map_large_blocks() -> bool {
    #[cfg(target_env = "gnu")]
    {
        // SAFETY: mallopt only changes an allocator parameter; a fixed M_MMAP_THRESHOLD also
        // turns off its dynamic adjustment.
        #[allow(unsafe_code)]
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD as libc::c_int) == 1
        }
    }
    #[cfg(not(target_env = "gnu"))]
    {
        false
    }
}

/// Sets the calling thread's timer slack, ns (the default 50 µs delays SCHED_OTHER wake-ups).
pub fn set_timer_slack(ns: u64) -> std::io::Result<()> {
    // SAFETY: PR_SET_TIMERSLACK takes one unsigned long argument.
    #[allow(unsafe_code)]
    let rc = unsafe { libc::prctl(libc::PR_SET_TIMERSLACK, ns as libc::c_ulong, 0, 0, 0) };
    if rc == 0 {
        Ok(())
    } else {
        Err(std::io::Error::last_os_error())
    }
}

fn timer_slack() -> i64 {
    // SAFETY: PR_GET_TIMERSLACK takes no argument and returns the slack.
    #[allow(unsafe_code)]
    let rc = unsafe { libc::prctl(libc::PR_GET_TIMERSLACK, 0, 0, 0, 0) };
    i64::from(rc)
}

/// Touches `kib` KiB of stack so the loop never takes a page fault growing it.
#[inline(never)]
pub fn prefault_stack(kib: usize) {
    const CHUNK: usize = 16 * 1024;
    #[inline(never)]
    fn touch(remaining: usize) {
        let mut buf = [0u8; CHUNK];
        for i in (0..CHUNK).step_by(4096) {
            // Volatile so the compiler keeps the writes.
            #[allow(unsafe_code)]
            // SAFETY: `i` is within `buf`.
            unsafe {
                std::ptr::write_volatile(buf.as_mut_ptr().add(i), 1)
            };
        }
        std::hint::black_box(&buf);
        if remaining > CHUNK {
            touch(remaining - CHUNK);
        }
    }
    if kib > 0 {
        touch(kib * 1024);
    }
}

fn locked_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmLck:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn hold_dma_latency() -> std::io::Result<(File, i32)> {
    let mut f = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open("/dev/cpu_dma_latency")?;
    f.write_all(&0i32.to_ne_bytes())?;
    let mut back = [0u8; 4];
    f.read_exact(&mut back)?;
    Ok((f, i32::from_ne_bytes(back)))
}

impl RtSetup {
    /// Applies `settings` to the calling thread (and process-wide memory locking) and reads
    /// everything back. Failures are reported, not fatal: a development machine without
    /// privileges still runs, and the report says what it got.
    pub fn apply(settings: &RtSettings) -> RtSetup {
        let thread = std::thread::current().name().unwrap_or("?").to_owned();
        let fifo_error = set_fifo(settings.priority)
            .err()
            .map(|e| format!("SCHED_FIFO {}: {e}", settings.priority));
        if fifo_error.is_some() || settings.priority == 0 {
            let _ = set_timer_slack(1);
        }
        let mut affinity_error = None;
        if !settings.cpus.is_empty() {
            let mut set = CpuSet::new();
            for &cpu in &settings.cpus {
                if let Err(e) = set.set(cpu) {
                    affinity_error = Some(format!("CPU {cpu}: {e}"));
                }
            }
            if affinity_error.is_none() {
                if let Err(e) = sched_setaffinity(Pid::from_raw(0), &set) {
                    affinity_error = Some(format!("sched_setaffinity {:?}: {e}", settings.cpus));
                }
            }
        }
        let cpus = sched_getaffinity(Pid::from_raw(0))
            .map(|set| {
                (0..CpuSet::count())
                    .filter(|&c| set.is_set(c).unwrap_or(false))
                    .collect()
            })
            .unwrap_or_default();
        let mlock_error = if settings.lock_memory {
            mlockall(MlockAllFlags::MCL_CURRENT | MlockAllFlags::MCL_FUTURE)
                .err()
                .map(|e| format!("mlockall: {e}"))
        } else {
            None
        };
        prefault_stack(settings.prefault_stack_kib);
        let (dma, cpu_dma_latency_us, cpu_dma_latency_error) = if settings.cpu_dma_latency {
            match hold_dma_latency() {
                Ok((f, v)) => (Some(f), Some(v), None),
                Err(e) => (None, None, Some(format!("/dev/cpu_dma_latency: {e}"))),
            }
        } else {
            (None, None, None)
        };
        let (policy, priority) = current_policy();
        let kernel = nix::sys::utsname::uname()
            .map(|u| {
                format!(
                    "{} {}",
                    u.release().to_string_lossy(),
                    u.version().to_string_lossy()
                )
            })
            .unwrap_or_default();
        RtSetup {
            report: RtSetupReport {
                thread,
                policy: policy_name(policy),
                priority,
                fifo_error,
                cpus,
                affinity_error,
                locked_kib: locked_kib(),
                mlock_error,
                prefaulted_stack_kib: settings.prefault_stack_kib,
                cpu_dma_latency_us,
                cpu_dma_latency_error,
                timer_slack_ns: timer_slack(),
                kernel,
            },
            _dma_latency: dma,
        }
    }
}

impl fmt::Display for RtSetupReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "RT setup report ({})", self.thread)?;
        writeln!(
            f,
            "  scheduler:          {} priority {}",
            self.policy, self.priority
        )?;
        if let Some(e) = &self.fifo_error {
            writeln!(f, "    refused:          {e}")?;
        }
        writeln!(f, "  cpus:               {:?}", self.cpus)?;
        if let Some(e) = &self.affinity_error {
            writeln!(f, "    refused:          {e}")?;
        }
        match self.locked_kib {
            Some(kib) => writeln!(f, "  locked memory:      {kib} KiB")?,
            None => writeln!(f, "  locked memory:      unknown")?,
        }
        if let Some(e) = &self.mlock_error {
            writeln!(f, "    refused:          {e}")?;
        }
        writeln!(f, "  prefaulted stack:   {} KiB", self.prefaulted_stack_kib)?;
        match (self.cpu_dma_latency_us, &self.cpu_dma_latency_error) {
            (Some(v), _) => writeln!(f, "  cpu_dma_latency:    {v} µs (held)")?,
            (None, Some(e)) => writeln!(f, "  cpu_dma_latency:    not held: {e}")?,
            (None, None) => writeln!(f, "  cpu_dma_latency:    not requested")?,
        }
        writeln!(f, "  timer slack:        {} ns", self.timer_slack_ns)?;
        write!(f, "  kernel:             {}", self.kernel)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn report_reads_back_what_it_got() {
        let handle = std::thread::Builder::new()
            .name("rt-test".into())
            .spawn(|| {
                RtSetup::apply(&RtSettings {
                    priority: 0,
                    cpus: vec![0],
                    lock_memory: false,
                    prefault_stack_kib: 64,
                    cpu_dma_latency: false,
                    required: false,
                })
            })
            .unwrap();
        let setup = handle.join().unwrap();
        let r = &setup.report;
        assert_eq!(r.thread, "rt-test");
        assert_eq!(r.policy, "SCHED_OTHER");
        assert_eq!(r.cpus, vec![0]);
        assert_eq!(r.timer_slack_ns, 1, "SCHED_OTHER gets 1 ns slack");
        let text = r.to_string();
        assert!(text.contains("RT setup report"), "{text}");
        assert!(text.contains("timer slack:        1 ns"), "{text}");
    }

    #[test]
    fn fifo_is_applied_or_the_refusal_reported() {
        let r = std::thread::spawn(|| {
            RtSetup::apply(&RtSettings {
                priority: 10,
                cpus: vec![],
                lock_memory: false,
                prefault_stack_kib: 0,
                cpu_dma_latency: false,
                required: false,
            })
            .report
        })
        .join()
        .unwrap();
        if r.fifo_error.is_none() {
            assert_eq!((r.policy.as_str(), r.priority), ("SCHED_FIFO", 10));
        } else {
            assert_eq!(r.policy, "SCHED_OTHER");
            assert_eq!(r.timer_slack_ns, 1);
        }
    }

    #[test]
    fn failures_name_what_was_asked_for_and_refused() {
        let mut r = RtSetup::apply(&RtSettings {
            priority: 0,
            cpus: vec![],
            lock_memory: false,
            prefault_stack_kib: 0,
            cpu_dma_latency: false,
            required: true,
        })
        .report;
        assert_eq!(r.failures(), None, "nothing asked, nothing failed");
        r.fifo_error = Some("SCHED_FIFO 80: EPERM".into());
        r.mlock_error = Some("mlockall: ENOMEM".into());
        assert_eq!(
            r.failures().as_deref(),
            Some("SCHED_FIFO 80: EPERM; mlockall: ENOMEM")
        );
    }
}
