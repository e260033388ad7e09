//! The radio channel, one direction: frames queue behind each other at the link's baud rate
//! and then cross the air with a delay; some are lost (alone or in bursts) and some arrive
//! with a damaged byte. Delivery keeps the order the frames were sent in (one serial line).

use std::collections::VecDeque;

use crate::rng::SimRng;
use dima_core::Nanos;

/// Nanoseconds per byte on a UART at `baud` with 8N1 framing (10 bits a byte).
pub fn byte_time_ns(baud: u32) -> Nanos {
    10 * 1_000_000_000 / u64::from(baud.max(1))
}

/// How one direction of the radio misbehaves during a run (drawn from the seed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelParams {
    /// Time per byte on the UART, ns (960 bytes/s at 9600 baud 8N1).
    pub byte_ns: Nanos,
    /// Probability that a frame is lost outside a burst.
    pub loss: f64,
    /// Probability per frame that a burst of loss starts.
    pub burst_start: f64,
    /// Longest burst of loss, ns.
    pub burst_max_ns: Nanos,
    /// Probability that one byte of a frame is damaged.
    pub corruption: f64,
    /// Shortest and longest air delay after the last byte left the UART, ns.
    pub delay_ns: (Nanos, Nanos),
}

impl ChannelParams {
    /// Random parameters for one run at `baud`.
    pub fn draw(rng: &mut SimRng, baud: u32) -> ChannelParams {
        let min_delay = 2_000_000 + rng.below(10_000_000);
        ChannelParams {
            byte_ns: byte_time_ns(baud),
            loss: rng.uniform() * 0.08,
            burst_start: rng.uniform() * 0.004,
            burst_max_ns: 500_000_000 + rng.below(2_500_000_000),
            corruption: rng.uniform() * 0.02,
            delay_ns: (min_delay, min_delay + rng.below(80_000_000)),
        }
    }
}

/// A frame in flight with what the harness knows about it.
#[derive(Debug, Clone)]
pub struct InFlight<T> {
    /// When its last byte arrives, ns.
    pub arrives_ns: Nanos,
    /// Its bytes as they arrive (perhaps damaged).
    pub bytes: Vec<u8>,
    /// Whether a byte was damaged on the way.
    pub damaged: bool,
    /// What the sender sent (for the invariants, never for the receiver).
    pub meta: T,
}

/// What the channel did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChannelStats {
    /// Frames sent.
    pub sent: u64,
    /// Frames lost.
    pub lost: u64,
    /// Frames delivered with a damaged byte.
    pub damaged: u64,
}

/// One direction of the radio.
#[derive(Debug, Clone)]
pub struct Channel<T> {
    params: ChannelParams,
    rng: SimRng,
    /// When the UART is free for the next frame, ns.
    uart_free_ns: Nanos,
    /// Arrival of the last frame delivered (the order is kept), ns.
    last_arrival_ns: Nanos,
    burst_until_ns: Nanos,
    queue: VecDeque<InFlight<T>>,
    stats: ChannelStats,
}

impl<T> Channel<T> {
    /// An idle channel.
    pub fn new(params: ChannelParams, rng: SimRng) -> Channel<T> {
        Channel {
            params,
            rng,
            uart_free_ns: 0,
            last_arrival_ns: 0,
            burst_until_ns: 0,
            queue: VecDeque::new(),
            stats: ChannelStats::default(),
        }
    }

    /// Counters so far.
    pub fn stats(&self) -> ChannelStats {
        self.stats
    }

    /// Sends `bytes` at `now`: they leave the UART after what is queued before them.
    pub fn send(&mut self, bytes: &[u8], meta: T, now: Nanos) {
        self.stats.sent += 1;
        let start = now.max(self.uart_free_ns);
        let done = start + self.params.byte_ns * bytes.len() as u64;
        self.uart_free_ns = done;
        if self.rng.chance(self.params.burst_start) {
            self.burst_until_ns = now + self.rng.below(self.params.burst_max_ns);
        }
        if now < self.burst_until_ns || self.rng.chance(self.params.loss) {
            self.stats.lost += 1;
            return;
        }
        let (lo, hi) = self.params.delay_ns;
        let delay = lo + self.rng.below(hi - lo + 1);
        let arrives_ns = (done + delay).max(self.last_arrival_ns);
        self.last_arrival_ns = arrives_ns;
        let mut bytes = bytes.to_vec();
        let damaged = !bytes.is_empty() && self.rng.chance(self.params.corruption);
        if damaged {
            let at = self.rng.below(bytes.len() as u64) as usize;
            bytes[at] ^= 1 << self.rng.below(8);
            self.stats.damaged += 1;
        }
        self.queue.push_back(InFlight {
            arrives_ns,
            bytes,
            damaged,
            meta,
        });
    }

    /// When the next frame arrives, if one is on its way.
    pub fn next_arrival(&self) -> Option<Nanos> {
        self.queue.front().map(|f| f.arrives_ns)
    }

    /// The next frame if it has arrived by `now`.
    pub fn receive(&mut self, now: Nanos) -> Option<InFlight<T>> {
        if self.queue.front()?.arrives_ns <= now {
            self.queue.pop_front()
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clean(byte_ns: Nanos) -> ChannelParams {
        ChannelParams {
            byte_ns,
            loss: 0.0,
            burst_start: 0.0,
            burst_max_ns: 0,
            corruption: 0.0,
            delay_ns: (1_000, 1_000),
        }
    }

    #[test]
    fn frames_queue_behind_each_other_at_the_baud_rate() {
        let byte_ns = byte_time_ns(9600);
        assert_eq!(byte_ns, 1_041_666);
        let mut c: Channel<u8> = Channel::new(clean(byte_ns), SimRng::new(1));
        c.send(&[0; 24], 1, 0);
        c.send(&[0; 24], 2, 0);
        let a = c.receive(u64::MAX).unwrap();
        let b = c.receive(u64::MAX).unwrap();
        assert_eq!(a.arrives_ns, 24 * byte_ns + 1_000);
        assert_eq!(
            b.arrives_ns,
            48 * byte_ns + 1_000,
            "the second waits for the first"
        );
        assert_eq!((a.meta, b.meta), (1, 2));
    }

    #[test]
    fn loss_and_damage_are_counted_and_order_is_kept() {
        let params = ChannelParams {
            loss: 0.3,
            corruption: 0.5,
            delay_ns: (0, 50_000_000),
            ..clean(1_000)
        };
        let mut c: Channel<u32> = Channel::new(params, SimRng::new(9));
        for i in 0..1_000 {
            c.send(&[1, 2, 3, 4], i, u64::from(i) * 10_000_000);
        }
        let mut last = (0, 0);
        let mut got = 0;
        while let Some(f) = c.receive(u64::MAX) {
            assert!(f.arrives_ns >= last.0 && (got == 0 || f.meta > last.1));
            last = (f.arrives_ns, f.meta);
            got += 1;
        }
        let s = c.stats();
        assert_eq!(s.sent, 1_000);
        assert_eq!(got + s.lost, 1_000);
        assert!(s.lost > 200 && s.damaged > 200, "{s:?}");
    }
}
