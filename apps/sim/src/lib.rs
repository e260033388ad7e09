//! Simulated DIMA devices over real pseudo-terminals, and the runner behind `dima sim`.

#![deny(missing_docs)]

pub mod board;
pub mod cli;
pub mod devices;
pub mod faults;
pub mod logcheck;
pub mod model;
pub mod pty;
pub mod request;
pub mod rng;
pub mod runner;
pub mod scenario;
pub mod world;
