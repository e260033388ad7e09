//! The servo controller as the loop sees it.

use crate::control::Nanos;

/// Writes servo targets. Implementations write all channels in as few writes as the device
/// allows and give up at `deadline_ns`.
pub trait ServoOutput {
    /// Why a write failed.
    type Error: core::fmt::Debug;

    /// Sets `targets_qus[i]` (quarter-microseconds, 0 = no pulses) on `channels[i]`.
    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), Self::Error>;
}
