//! The DIMA robot's deterministic core: everything the robot decides, with no I/O, no threads
//! and no clocks, so the realtime loop, the simulator, the tests and log replays run the very
//! same code.
//!
//! - [`config`]: the TOML configuration with documented defaults and bounds;
//! - [`safety`]: the safety state machine (KILLED, MANUAL, AUTO, FAILSAFE) and its causes;
//! - [`monitor`]: request/answer pairing, GNSS freshness, stuck IMU, overruns by rate;
//! - [`estimate`]: the state estimate (speed, heading, yaw rate, accelerations) the controllers
//!   read;
//! - [`mission`]: waypoint missions from QGroundControl plan files and the path follower;
//! - [`control`]: the [`Controller`](control::Controller) trait, the controllers by name, and
//!   the mapping from modes to servo targets;
//! - [`step`]: [`Core::step`], one cycle as a pure function of state, inputs, time and
//!   configuration;
//! - [`counters`]: the counters the loop keeps (the typed log messages that carry them, and
//!   their JSON schemas, are in the `dima-log` crate).
//!
//! ```
//! use dima_core::config::Config;
//! use dima_core::step::{CycleInputs, SensorInput};
//! use dima_core::{Command, Core, CoreState, Mode, ReceivedCommand};
//!
//! let mut core = Core::new(&Config::default()).expect("the default configuration is valid");
//! let mut state = CoreState::new();
//! let inputs = CycleInputs {
//!     missed_periods: 0,
//!     // A revive that arrived 1 ms before the cycle.
//!     commands: &[ReceivedCommand::new(Command::Revive, 3_000_000)],
//!     sensor: SensorInput::NotRequested,
//!     stale_packets: 0,
//! };
//! let out = core.step(&mut state, &inputs, 4_000_000);
//! // No sensor packet has arrived yet: the revive is refused and the outputs stay safe.
//! assert_eq!(out.mode, Mode::Killed);
//! assert_eq!(out.refused, Some(dima_core::ReviveRefusal::SensorLoss));
//! assert_eq!(out.targets.pulse_us, [1500, 1545, 1500]);
//! ```
#![deny(missing_docs)]

pub mod config;
pub mod control;
pub mod counters;
pub mod estimate;
pub mod geo;
pub mod mission;
pub mod monitor;
pub mod safety;
pub mod step;
pub mod wire;

pub use dima_groundlink::Command;
pub use safety::{FailsafeCause, Mode, ReceivedCommand, ReviveRefusal};
pub use step::{Core, CoreState, CycleInputs, CycleOutputs, SensorInput};

/// Monotonic time in nanoseconds (CLOCK_MONOTONIC in the application, anything in tests).
pub type Nanos = u64;
