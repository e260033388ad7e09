//! The fault plan of a run: windows of virtual time, drawn from the seed, in which the sensor
//! board misbehaves.

use crate::rng::SimRng;
use dima_core::Nanos;

/// A fault of the sensor board or its sensors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Fault {
    /// The accelerometer die keeps its last words while the gyroscope goes on.
    AccelFrozen,
    /// The gyroscope die keeps its last words while the accelerometer goes on.
    GyroFrozen,
    /// The GNSS solution stops changing (the same NAV-PVT again and again).
    GnssFrozen,
    /// New epochs carry no fix.
    GnssLost,
    /// The receiver replays its last two epochs alternately: the time of week goes back and
    /// forth.
    ItowBackwards,
    /// New epochs carry a negative ground speed.
    NegativeSpeed,
    /// The position jumps by tens to hundreds of metres.
    PositionJump,
    /// Answers complete after the packet deadline.
    LateAnswers,
    /// Requests go unanswered.
    MissingAnswers,
    /// The board resets: no answers for a while, then a fresh board.
    BoardReset,
}

impl Fault {
    /// Every fault.
    pub const ALL: [Fault; 10] = [
        Fault::AccelFrozen,
        Fault::GyroFrozen,
        Fault::GnssFrozen,
        Fault::GnssLost,
        Fault::ItowBackwards,
        Fault::NegativeSpeed,
        Fault::PositionJump,
        Fault::LateAnswers,
        Fault::MissingAnswers,
        Fault::BoardReset,
    ];

    /// Shortest and longest window, ms.
    fn duration_ms(self) -> (u64, u64) {
        match self {
            Fault::AccelFrozen | Fault::GyroFrozen => (300, 6_000),
            Fault::GnssFrozen | Fault::GnssLost => (200, 4_000),
            Fault::ItowBackwards | Fault::NegativeSpeed => (500, 8_000),
            Fault::PositionJump => (200, 5_000),
            Fault::LateAnswers | Fault::MissingAnswers => (20, 1_500),
            Fault::BoardReset => (300, 3_000),
        }
    }
}

/// The windows of every fault, with a cursor per fault for a clock that only goes forward.
#[derive(Debug, Clone)]
pub struct FaultPlan {
    windows: Vec<Vec<(Nanos, Nanos)>>,
    cursor: Vec<usize>,
}

impl FaultPlan {
    /// Windows between `start_ns` and `end_ns`: for each fault a random mean gap (20 s to
    /// 3 min) and windows of random length one after another. Each fault draws from its own
    /// stream, so a longer run has the same windows as a shorter one, and more.
    pub fn draw(rng: &SimRng, start_ns: Nanos, end_ns: Nanos) -> FaultPlan {
        let ms = 1_000_000;
        let windows = Fault::ALL
            .iter()
            .map(|f| {
                let rng = &mut rng.fork(*f as u64);
                let mean_gap = (20_000 + rng.below(160_000)) * ms;
                let (lo, hi) = f.duration_ms();
                let mut out = Vec::new();
                let mut t = start_ns + rng.below(2 * mean_gap);
                while t < end_ns {
                    let length = (lo + rng.below(hi - lo + 1)) * ms;
                    out.push((t, t + length));
                    t += length + rng.below(2 * mean_gap);
                }
                out
            })
            .collect();
        FaultPlan {
            windows,
            cursor: vec![0; Fault::ALL.len()],
        }
    }

    /// A plan without faults.
    pub fn none() -> FaultPlan {
        FaultPlan {
            windows: vec![Vec::new(); Fault::ALL.len()],
            cursor: vec![0; Fault::ALL.len()],
        }
    }

    /// Whether `fault` is on at `t` (times must not go back between calls).
    pub fn active(&mut self, fault: Fault, t: Nanos) -> bool {
        let i = fault as usize;
        let windows = &self.windows[i];
        while self.cursor[i] < windows.len() && windows[self.cursor[i]].1 <= t {
            self.cursor[i] += 1;
        }
        windows
            .get(self.cursor[i])
            .is_some_and(|&(start, _)| start <= t)
    }

    /// Windows of `fault`.
    pub fn windows(&self, fault: Fault) -> &[(Nanos, Nanos)] {
        &self.windows[fault as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_are_ordered_and_found() {
        let s = 1_000_000_000;
        let mut plan = FaultPlan::draw(&SimRng::new(5), 0, 1_200 * s);
        for f in Fault::ALL {
            let w = plan.windows(f).to_vec();
            assert!(!w.is_empty(), "{f:?}");
            assert!(w.windows(2).all(|p| p[0].1 <= p[1].0));
            let (a, b) = w[0];
            assert!(!plan.active(f, a.saturating_sub(1)) || a == 0);
            assert!(plan.active(f, a));
            assert!(plan.active(f, b - 1));
            assert!(!plan.active(f, b) || w.get(1).is_some_and(|n| n.0 == b));
        }
    }
}
