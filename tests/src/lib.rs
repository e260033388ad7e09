//! End-to-end tests of the DIMA application: the real application (threads, loop, drivers,
//! decoders, logger) against the simulated devices of `dima-sim` on pseudo-terminals.
//!
//! [`run_app`] starts the application for a simulation exactly as `dima sim` does (it is the
//! same function).

pub use dima::sim::run_app;
pub use dima_sim::app_config::app_config;
