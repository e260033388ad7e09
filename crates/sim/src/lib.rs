//! Simulated DIMA devices over real pseudo-terminals, and the runner behind `dima sim`.
//!
//! The application runs unchanged (its threads, loop, drivers, decoders and logger) against
//! devices that speak the real byte protocols, built with the project's own codecs:
//!
//! - [`board`]: the sensor board. Each rising edge of the request line ([`request`]) is
//!   answered with a v1 packet, and with the info frame by the board's trigger rule, from the
//!   vehicle model ([`model`], [`world`]): BMX055 words with bias and noise, BMP280 raw values
//!   through inverse compensation of the datasheet calibration, NAV-PVT at 10 Hz;
//! - [`devices`]: the device threads on their [`pty`]s: the board, a Maestro that decodes
//!   commands with `pololu-maestro` and drives the model, a scripted ground station (or a relay
//!   to a GUI's pty);
//! - [`firmware`]: `dima sim --firmware`: the board's real firmware (its `qemu` build) under
//!   `qemu-system-arm` in place of [`board`], fed by the same model;
//! - [`faults`]: bit errors, drops, insertions, delay, jitter, silence and disconnects per link;
//! - [`scenario`]: scripts and the checks a run must pass, judged on the outputs at the Maestro,
//!   the model, and the application's MCAP log ([`logcheck`]);
//! - [`runner`] and [`cli`]: a whole run with a live status line and a verdict, against the
//!   application configured by [`app_config`].
//!
//! - [`robot`]: the robot's application (`dima-robot`) against these devices: `dima sim`;
//! - [`dst`]: `dima dst`, deterministic simulation testing of the robot's composed parts in
//!   virtual time.
//!
//! The runner itself takes the function that starts the application against an
//! [`runner::AppLaunch`] ([`robot::run_app`] is the robot's); the simulator depends on the
//! robot, never the reverse.
//!
//! ```no_run
//! use dima_sim::runner::{run_simulation, AppOutcome, SimOptions};
//! use dima_sim::scenario::Scenario;
//!
//! let options = SimOptions::new(Scenario::manual_drive(5.0));
//! let report = run_simulation(&options, |launch| {
//!     // Start the application on launch.sensor_port, launch.maestro_port,
//!     // launch.xbee_port with launch.request as the request line, until launch.stop.
//!     # let _ = launch;
//!     Ok(AppOutcome::default())
//! })?;
//! println!("{}", report.summary());
//! # Ok::<(), anyhow::Error>(())
//! ```

#![deny(missing_docs)]

pub mod app_config;
pub mod board;
pub mod cli;
pub mod devices;
pub mod dst;
pub mod faults;
pub mod firmware;
pub mod host_load;
pub mod logcheck;
pub mod mission;
pub mod model;
pub mod pty;
pub mod request;
pub mod rng;
pub mod robot;
pub mod runner;
pub mod scenario;
pub mod world;
