//! The DIMA robot's realtime application: everything `dima run` starts on the robot.
//!
//! The `dima` program parses the command line and the configuration and hands over to
//! [`app::run()`]; this library holds the parts it wires together:
//! - [`config`]: the TOML configuration (from `dima-core`) and reading it from a file;
//! - [`control`]: the AUTO controllers and the output mapping, and [`dima_core`] under them:
//!   the safety state machine, the monitors and the pure control step (inputs and time in,
//!   outputs out);
//! - [`rt`]: realtime thread setup with its read-back report, and the absolute-deadline clock;
//! - [`metrics`]: the wake-up latency histogram (cyclictest format) and counters;
//! - [`devices`]: raw termios serial ports, the sensor board and Maestro as the loop sees them,
//!   and the supervisor that opens and reopens devices off the realtime thread;
//! - [`app`]: the realtime loop, the fixed-size records it hands over, and [`app::run()`], which
//!   starts every thread for a given set of device openers;
//! - [`telemetry`], [`logging`]: the ground-link thread and the MCAP logger thread, which
//!   writes the typed messages of [`log_messages`], and [`live`], the live view the logger
//!   thread also serves them on (Foxglove WebSocket protocol, `[foxglove] listen`);
//! - [`terminal`]: what the programs write to the terminal (fatal errors in one style, colour
//!   only where it belongs).
//!
//! The simulator (`dima-sim`) and the log tools (`dima-tools`) depend on this crate, never the
//! reverse: the robot's binary builds without them.
#![deny(missing_docs)]

pub mod app;
pub mod config;
pub use dima_core::control;
pub mod devices;
pub mod live;
pub mod log_messages;
pub mod logging;
pub mod metrics;
pub mod rt;
pub mod telemetry;
pub mod terminal;
