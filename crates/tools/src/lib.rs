//! The DIMA tools that read what the robot wrote and measure how it runs:
//! - [`logtools`]: `dima log info|export|plot|replay` and `dima inspect`;
//! - [`bench`](mod@bench): `dima bench wakeup` (the loop skeleton against cyclictest) and
//!   `dima bench cycle`.
//!
//! They depend on the robot's library (`dima-robot`), never the reverse.
#![deny(missing_docs)]

pub mod bench;
pub mod logtools;
