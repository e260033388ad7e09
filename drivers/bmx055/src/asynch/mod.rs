//! Async twins of the three drivers (feature `async`), over `embedded-hal-async`.
//!
//! Same configuration types, decoders and register sequences as the blocking drivers (those
//! live in plain functions such as [`AccelConfig::register_writes`](crate::accel::AccelConfig::register_writes));
//! only the I/O awaits. Separate types keep the blocking API intact when both are in use.

mod accel;
mod facade;
mod gyro;
mod mag;

pub use accel::AsyncAccelerometer;
pub use facade::AsyncBmx055;
pub use gyro::AsyncGyroscope;
pub use mag::AsyncMagnetometer;
