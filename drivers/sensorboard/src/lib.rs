//! The DIMA sensor-board link.
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

pub mod crc;
