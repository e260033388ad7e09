//! The request line between the application and the simulated sensor board.
//!
//! [`RequestPin`] is an embedded-hal [`OutputPin`] the application's device layer drives like
//! the GPIO line on the robot; a rising edge counts a request and wakes the board thread. It is
//! lock-free and allocation-free, so the realtime loop can use it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

use embedded_hal::digital::{ErrorType, OutputPin};

/// The shared line: an edge counter, the time of the last edge and the board thread to wake.
#[derive(Debug)]
pub struct RequestLine {
    edges: AtomicU64,
    base: Instant,
    last_edge_ns: AtomicU64,
    board: OnceLock<Thread>,
}

impl RequestLine {
    /// A line nobody listens to yet.
    pub fn new() -> Arc<RequestLine> {
        Arc::new(RequestLine {
            edges: AtomicU64::new(0),
            base: Instant::now(),
            last_edge_ns: AtomicU64::new(0),
            board: OnceLock::new(),
        })
    }

    /// Time since the last rising edge (since creation before the first).
    pub fn since_last_edge(&self) -> Duration {
        let now = self.base.elapsed().as_nanos() as u64;
        Duration::from_nanos(now.saturating_sub(self.last_edge_ns.load(Ordering::Acquire)))
    }

    /// Makes the calling thread the one woken by rising edges (the board's thread).
    pub fn listen(&self) {
        let _ = self.board.set(std::thread::current());
    }

    /// Rising edges so far.
    pub fn edges(&self) -> u64 {
        self.edges.load(Ordering::Acquire)
    }

    /// Waits (on the listening thread) until the edge count differs from `seen` or `timeout`
    /// passes; returns the current count.
    pub fn wait_edge(&self, seen: u64, timeout: Duration) -> u64 {
        let now = self.edges();
        if now != seen {
            return now;
        }
        std::thread::park_timeout(timeout);
        self.edges()
    }

    fn rise(&self) {
        self.last_edge_ns
            .store(self.base.elapsed().as_nanos() as u64, Ordering::Release);
        self.edges.fetch_add(1, Ordering::AcqRel);
        if let Some(t) = self.board.get() {
            t.unpark();
        }
    }
}

/// The application's end of the request line.
#[derive(Debug, Clone)]
pub struct RequestPin {
    line: Arc<RequestLine>,
    high: bool,
}

impl RequestPin {
    /// A pin driving `line`, starting low.
    pub fn new(line: Arc<RequestLine>) -> RequestPin {
        RequestPin { line, high: false }
    }
}

impl ErrorType for RequestPin {
    type Error = core::convert::Infallible;
}

impl OutputPin for RequestPin {
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.high = false;
        Ok(())
    }

    fn set_high(&mut self) -> Result<(), Self::Error> {
        if !self.high {
            self.line.rise();
        }
        self.high = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_rising_edges_count_and_wake_the_board() {
        let line = RequestLine::new();
        let l = line.clone();
        let board = std::thread::spawn(move || {
            l.listen();
            let mut seen = 0;
            let mut woken = 0;
            while seen < 2 {
                let now = l.wait_edge(seen, Duration::from_secs(5));
                if now != seen {
                    woken += 1;
                    seen = now;
                }
            }
            woken
        });
        while line.board.get().is_none() {
            std::thread::yield_now();
        }
        let mut pin = RequestPin::new(line.clone());
        pin.set_high().unwrap();
        pin.set_high().unwrap(); // still high: no new edge
        pin.set_low().unwrap();
        pin.set_high().unwrap();
        assert!(board.join().unwrap() >= 1);
        assert_eq!(line.edges(), 2);
    }
}
