//! Loop metrics: a wake-up latency histogram with 1 µs buckets (written in cyclictest's `-h`
//! format), running min/avg/max of the per-cycle durations, and counters for every drop and
//! error. Fixed-size, no allocation after construction.

use std::fmt::Write as _;

use dima_log::schema::{DurationStats, SummaryRecord};
use serde::Serialize;

/// Histogram of durations in 1 µs buckets up to a fixed bound; longer ones are overflows.
#[derive(Debug, Clone)]
pub struct LatencyHistogram {
    buckets: Box<[u64]>,
    overflows: u64,
    count: u64,
    sum_ns: u128,
    min_ns: u64,
    max_ns: u64,
}

impl LatencyHistogram {
    /// `max_us` buckets of 1 µs (cyclictest's `-h max_us`).
    pub fn new(max_us: usize) -> LatencyHistogram {
        LatencyHistogram {
            buckets: vec![0; max_us.max(1)].into_boxed_slice(),
            overflows: 0,
            count: 0,
            sum_ns: 0,
            min_ns: u64::MAX,
            max_ns: 0,
        }
    }

    /// Records one duration in nanoseconds.
    pub fn record(&mut self, ns: u64) {
        let us = (ns / 1_000) as usize;
        match self.buckets.get_mut(us) {
            Some(b) => *b += 1,
            None => self.overflows += 1,
        }
        self.count += 1;
        self.sum_ns += u128::from(ns);
        self.min_ns = self.min_ns.min(ns);
        self.max_ns = self.max_ns.max(ns);
    }

    /// Samples recorded.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Samples beyond the last bucket.
    pub fn overflows(&self) -> u64 {
        self.overflows
    }

    /// Minimum, ns (0 when empty).
    pub fn min_ns(&self) -> u64 {
        if self.count == 0 {
            0
        } else {
            self.min_ns
        }
    }

    /// Maximum, ns.
    pub fn max_ns(&self) -> u64 {
        self.max_ns
    }

    /// Mean, ns (0 when empty).
    pub fn avg_ns(&self) -> u64 {
        if self.count == 0 {
            0
        } else {
            (self.sum_ns / u128::from(self.count)) as u64
        }
    }

    /// The count in bucket `us`.
    pub fn bucket(&self, us: usize) -> u64 {
        self.buckets.get(us).copied().unwrap_or(0)
    }

    /// cyclictest `-h` output for one thread: `%06d %06lu` per bucket, then the summary
    /// comments, in microseconds.
    pub fn cyclictest_format(&self) -> String {
        let mut s = String::new();
        s.push_str("# Histogram\n");
        for (us, n) in self.buckets.iter().enumerate() {
            let _ = writeln!(s, "{us:06} {n:06}");
        }
        let _ = writeln!(s, "# Total: {:09}", self.count);
        let _ = writeln!(s, "# Min Latencies: {:05}", self.min_ns() / 1_000);
        let _ = writeln!(s, "# Avg Latencies: {:05}", self.avg_ns() / 1_000);
        let _ = writeln!(s, "# Max Latencies: {:05}", self.max_ns / 1_000);
        let _ = writeln!(s, "# Histogram Overflows: {:05}", self.overflows);
        s
    }
}

/// Minimum, mean and maximum of a per-cycle duration.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Stat {
    /// Samples.
    pub count: u64,
    /// Smallest, ns.
    pub min_ns: u64,
    /// Largest, ns.
    pub max_ns: u64,
    /// Sum, ns (mean = sum / count).
    pub sum_ns: u64,
}

impl Stat {
    /// Adds a sample.
    pub fn record(&mut self, ns: u64) {
        if self.count == 0 || ns < self.min_ns {
            self.min_ns = ns;
        }
        self.max_ns = self.max_ns.max(ns);
        self.sum_ns = self.sum_ns.saturating_add(ns);
        self.count += 1;
    }

    /// Mean, ns.
    pub fn mean_ns(&self) -> u64 {
        self.sum_ns.checked_div(self.count).unwrap_or(0)
    }
}

pub use dima_core::counters::Counters;

/// Metrics owned by the realtime thread.
#[derive(Debug, Clone)]
pub struct LoopMetrics {
    /// Wake-up latency.
    pub wake_latency: LatencyHistogram,
    /// Request to complete packet.
    pub request_to_packet: Stat,
    /// Packet (or deadline) to outputs computed.
    pub compute: Stat,
    /// Maestro write.
    pub servo_write: Stat,
    /// Counters (a copy of the control state's, updated every cycle).
    pub counters: Counters,
}

impl LoopMetrics {
    /// Histogram up to `max_latency_us` (allocated here, before the loop).
    pub fn new(max_latency_us: usize) -> LoopMetrics {
        LoopMetrics {
            wake_latency: LatencyHistogram::new(max_latency_us),
            request_to_packet: Stat::default(),
            compute: Stat::default(),
            servo_write: Stat::default(),
            counters: Counters::default(),
        }
    }

    /// The run's totals for the log's summary record.
    pub fn summary_record(&self) -> SummaryRecord {
        let stats = |s: &Stat| DurationStats {
            count: s.count,
            min_us: s.min_ns as f64 / 1e3,
            mean_us: s.mean_ns() as f64 / 1e3,
            max_us: s.max_ns as f64 / 1e3,
        };
        let h = &self.wake_latency;
        SummaryRecord {
            counters: self.counters,
            wake_latency: DurationStats {
                count: h.count(),
                min_us: h.min_ns() as f64 / 1e3,
                mean_us: h.avg_ns() as f64 / 1e3,
                max_us: h.max_ns() as f64 / 1e3,
            },
            request_to_packet: stats(&self.request_to_packet),
            compute: stats(&self.compute),
            servo_write: stats(&self.servo_write),
            link: Default::default(),
        }
    }

    /// The one-line summary printed at exit.
    pub fn summary(&self) -> String {
        let c = &self.counters;
        let h = &self.wake_latency;
        format!(
            "cycles {} missed {} | wake latency min/avg/max {}/{}/{} µs (overflows {}) | \
             request->packet avg/max {}/{} µs | compute avg/max {}/{} µs | servo write avg/max \
             {}/{} µs | packets ok {} missing {} stale {} late {} crc {} skipped-bytes {} | \
             sensor errors {} | gnss fixes {} | \
             servo writes {} errors {} missing {} | commands {} (setpoints rejected {}, revives \
             refused {}) | log dropped {} | failsafes {} | stale commands dropped {}",
            c.cycles,
            c.missed_periods,
            h.min_ns() / 1_000,
            h.avg_ns() / 1_000,
            h.max_ns() / 1_000,
            h.overflows(),
            self.request_to_packet.mean_ns() / 1_000,
            self.request_to_packet.max_ns / 1_000,
            self.compute.mean_ns() / 1_000,
            self.compute.max_ns / 1_000,
            self.servo_write.mean_ns() / 1_000,
            self.servo_write.max_ns / 1_000,
            c.packets_ok,
            c.packets_missing,
            c.packets_stale,
            c.packets_late,
            c.packet_crc_errors,
            c.packet_bytes_skipped,
            c.sensor_errors,
            c.gnss_fixes,
            c.servo_writes,
            c.servo_errors,
            c.servo_missing,
            c.commands,
            c.setpoints_rejected,
            c.revives_refused,
            c.log_dropped,
            c.failsafes,
            c.commands_stale,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_microsecond_buckets_and_overflows() {
        let mut h = LatencyHistogram::new(100);
        for ns in [0, 999, 1_000, 1_999, 99_999, 100_000, 5_000_000] {
            h.record(ns);
        }
        assert_eq!(h.bucket(0), 2);
        assert_eq!(h.bucket(1), 2);
        assert_eq!(h.bucket(99), 1);
        assert_eq!(h.overflows(), 2);
        assert_eq!(h.count(), 7);
        assert_eq!(h.max_ns(), 5_000_000);
        assert_eq!(h.min_ns(), 0);
    }

    #[test]
    fn cyclictest_layout() {
        let mut h = LatencyHistogram::new(3);
        h.record(1_500);
        h.record(2_100);
        h.record(10_000);
        let text = h.cyclictest_format();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[1], "000000 000000");
        assert_eq!(lines[2], "000001 000001");
        assert_eq!(lines[3], "000002 000001");
        assert!(text.contains("# Total: 000000003\n"));
        assert!(text.contains("# Max Latencies: 00010\n"));
        assert!(text.contains("# Histogram Overflows: 00001\n"));
    }

    #[test]
    fn stat() {
        let mut s = Stat::default();
        for v in [5, 1, 9] {
            s.record(v);
        }
        assert_eq!((s.min_ns, s.max_ns, s.mean_ns()), (1, 9, 5));
    }
}
