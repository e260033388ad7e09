//! Simulated DIMA devices over real pseudo-terminals, and the runner behind `dima sim`.

#![deny(missing_docs)]

pub mod board;
pub mod faults;
pub mod model;
pub mod pty;
pub mod request;
pub mod rng;
