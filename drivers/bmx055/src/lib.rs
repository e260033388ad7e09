//! Driver for the Bosch BMX055 9-axis IMU.
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

pub mod accel;
#[cfg(feature = "async")]
pub mod asynch;
mod error;
pub mod gyro;
pub mod interface;
pub mod mag;
mod maths;
mod types;

pub use accel::Accelerometer;
#[cfg(feature = "async")]
pub use asynch::{AsyncAccelerometer, AsyncGyroscope, AsyncMagnetometer};
pub use error::Error;
pub use gyro::Gyroscope;
pub use mag::Magnetometer;
pub use types::{FifoData, FifoMode, FifoStatus, InterruptPin, PinConfig, Xyz};
