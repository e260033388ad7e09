//! Pairing a sensor packet with the request it answers.
//!
//! The board starts sending only after the request edge, so the answer to this cycle's request
//! cannot be complete before its bytes have crossed the wire: a packet that completes sooner is
//! an earlier request's answer arriving late (`stale`). One that completes after the deadline is
//! `late`. Both are treated as missing: they feed the sensor-loss failsafe and block a revive.

use crate::Nanos;

/// What became of this cycle's packet. In logs in snake case, e.g. `stale`.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Hash,
    serde::Serialize,
    serde::Deserialize,
    schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum PacketVerdict {
    /// A valid packet, paired with this cycle's request, in time.
    Ok,
    /// A valid packet that completed sooner than its wire time after the request: an earlier
    /// request's answer.
    Stale,
    /// A valid packet that completed after the deadline.
    Late,
    /// Requested, but no valid packet by the deadline.
    Missing,
    /// Not requested: the sensor board is not connected (or, ahead mode, nothing pending).
    NotRequested,
    /// The port or the request line failed this cycle.
    DeviceError,
}

impl PacketVerdict {
    /// Whether the packet is used.
    pub fn is_ok(self) -> bool {
        self == PacketVerdict::Ok
    }
}

/// The time window, after its request, in which a packet counts as the answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnswerWindow {
    /// Earliest completion after the request, ns (wire time less the tolerance).
    pub earliest_ns: Nanos,
    /// Latest completion after the request, ns (the packet deadline).
    pub deadline_ns: Nanos,
}

impl AnswerWindow {
    /// From the packet's wire time, the tolerance and the deadline.
    pub fn new(wire_ns: Nanos, tolerance_ns: Nanos, deadline_ns: Nanos) -> AnswerWindow {
        AnswerWindow {
            earliest_ns: wire_ns.saturating_sub(tolerance_ns),
            deadline_ns,
        }
    }

    /// The verdict on a packet completed at `t_complete_ns` for a request at `t_request_ns`.
    pub fn judge(&self, t_request_ns: Nanos, t_complete_ns: Nanos) -> PacketVerdict {
        match t_complete_ns.checked_sub(t_request_ns) {
            None => PacketVerdict::Stale,
            Some(dt) if dt < self.earliest_ns => PacketVerdict::Stale,
            Some(dt) if dt > self.deadline_ns => PacketVerdict::Late,
            Some(_) => PacketVerdict::Ok,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const US: Nanos = 1_000;

    #[test]
    fn only_answers_inside_wire_time_to_deadline_count() {
        // 460 800 baud 8N2: 3 151 µs on the wire, 100 µs tolerance, 3 700 µs deadline.
        let w = AnswerWindow::new(3_151 * US, 100 * US, 3_700 * US);
        let t0 = 1_000_000 * US;
        assert_eq!(w.judge(t0, t0 + 3_051 * US), PacketVerdict::Ok);
        assert_eq!(w.judge(t0, t0 + 3_700 * US), PacketVerdict::Ok);
        assert_eq!(w.judge(t0, t0 + 3_050 * US), PacketVerdict::Stale);
        // An answer 5 ms late at a 4 ms period completes 1 ms after the next request.
        assert_eq!(w.judge(t0, t0 + 1_000 * US), PacketVerdict::Stale);
        assert_eq!(w.judge(t0, t0 - 1), PacketVerdict::Stale);
        assert_eq!(w.judge(t0, t0 + 3_701 * US), PacketVerdict::Late);
    }
}
