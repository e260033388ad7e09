//! Driver for the Bosch BMX055 9-axis IMU.
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

pub mod accel;
#[cfg(feature = "async")]
pub mod asynch;
mod error;
mod facade;
pub mod gyro;
pub mod interface;
pub mod mag;
mod maths;
pub mod packet;
mod types;

pub use accel::Accelerometer;
#[cfg(feature = "async")]
pub use asynch::{AsyncAccelerometer, AsyncGyroscope, AsyncMagnetometer};
pub use error::Error;
pub use facade::{Bmx055, Bmx055Config, ImuSample};
pub use gyro::Gyroscope;
pub use mag::Magnetometer;
pub use packet::ImuPacketWords;
pub use types::{FifoData, FifoMode, FifoStatus, InterruptPin, PinConfig, Xyz};
