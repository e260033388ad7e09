//! Monitors: small pure state machines that judge one aspect of the inputs each cycle and
//! feed the safety state machine.
//!
//! - [`AnswerWindow`]: pairs a packet with this cycle's request (not sooner than its wire time,
//!   not later than the deadline);
//! - [`GnssFreshness`]: a fix counts only while it is valid and its iTOW advances past the
//!   newest fix used (modulo the week): a repeated or backward time of week is old data;
//! - [`ImuStuckDetector`]: identical words packet after packet from either IMU die (the
//!   accelerometer or the gyroscope, each on its own) are a sensor fault;
//! - [`OverrunWindow`]: late wake-ups within a sliding second, and the periods they missed;
//! - [`RolloverMonitor`]: the accelerometer's reading tilted beyond an angle for a time;
//! - [`FenceMonitor`]: each new fix judged against the [`Geofence`].

mod answer;
mod fence;
pub mod gnss;
mod imu;
mod overrun;
mod rollover;

pub use answer::{AnswerWindow, PacketVerdict};
pub use fence::{FenceMonitor, Geofence};
pub use gnss::{FreshFix, GnssEpoch, GnssFreshness};
pub use imu::ImuStuckDetector;
pub use overrun::{OverrunRule, OverrunWindow};
pub use rollover::{RolloverMonitor, RolloverRule};
