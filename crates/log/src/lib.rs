//! The DIMA MCAP log in one place: what is written, how it is written, how the files of a run
//! are named, and how it is read back.
//!
//! - [`schema`]: the channels, metadata names and typed JSON messages, whose JSON schemas are
//!   generated from the structs;
//! - [`writer`]: [`McapLog`], one MCAP file, and
//!   [`RunWriter`], a run across files (split by duration, resumed after a
//!   full disk), with a [`Tap`] seam for a live view;
//! - [`naming`]: `dima-<UTC>.mcap`, `NAME-1.mcap`, ... written and parsed back;
//! - [`records`]: the bounded walk over a file's records;
//! - [`reader`]: one file, typed ([`LoggedRun`]) or as it is
//!   ([`messages`](reader::messages), [`metadata`](reader::metadata));
//! - [`run`]: every file of a run, read as one.
#![deny(missing_docs)]

pub mod naming;
pub mod reader;
pub mod records;
pub mod run;
pub mod schema;
pub mod writer;

pub use reader::LoggedRun;
pub use writer::{McapLog, RunWriter, Tap};
