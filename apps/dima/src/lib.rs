//! The DIMA robot's realtime control application.
//!
//! `main` only parses the command line and the configuration and wires the parts together:
//! - [`config`]: the TOML configuration with documented defaults;

#![deny(missing_docs)]

pub mod app;
pub mod cli;
pub mod config;
pub mod control;
pub mod devices;
pub mod logging;
pub mod metrics;
pub mod rt;
pub mod telemetry;
