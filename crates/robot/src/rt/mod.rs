//! Realtime plumbing: thread setup with its read-back report, and the periodic clock.

pub mod clock;
pub mod setup;

pub use clock::{monotonic_ns, PeriodicClock, Tick};
pub use setup::{RtSettings, RtSetup, RtSetupReport};
