//! Async twin of [`Bmx055`](crate::Bmx055).

use super::{AsyncAccelerometer, AsyncGyroscope, AsyncMagnetometer};
use crate::facade::{Bmx055Config, ImuSample};
use crate::interface::{AsyncRegisterInterface, SpiInterface};
use crate::mag::{MagOpMode, MagPacketWords, MagTrim};
use crate::Error;
use embedded_hal_async::delay::DelayNs;

/// The BMX055 as one async device: owns the three async drivers. See
/// [`Bmx055`](crate::Bmx055) for the behaviour of each method.
#[derive(Debug)]
pub struct AsyncBmx055<AI, GI, MI> {
    /// Accelerometer driver.
    pub accel: AsyncAccelerometer<AI>,
    /// Gyroscope driver.
    pub gyro: AsyncGyroscope<GI>,
    /// Magnetometer driver.
    pub mag: AsyncMagnetometer<MI>,
    last_mag: MagPacketWords,
}

impl<ASPI, GSPI, MSPI> AsyncBmx055<SpiInterface<ASPI>, SpiInterface<GSPI>, SpiInterface<MSPI>> {
    /// The three dies over their own SPI devices.
    pub fn new_spi(accel: ASPI, gyro: GSPI, mag: MSPI) -> Self {
        Self::new(
            AsyncAccelerometer::new_spi(accel),
            AsyncGyroscope::new_spi(gyro),
            AsyncMagnetometer::new_spi(mag),
        )
    }
}

impl<AI, GI, MI> AsyncBmx055<AI, GI, MI> {
    /// Combine three async drivers.
    pub fn new(
        accel: AsyncAccelerometer<AI>,
        gyro: AsyncGyroscope<GI>,
        mag: AsyncMagnetometer<MI>,
    ) -> Self {
        Self {
            accel,
            gyro,
            mag,
            last_mag: MagPacketWords::default(),
        }
    }

    /// Give the three drivers back.
    pub fn release(
        self,
    ) -> (
        AsyncAccelerometer<AI>,
        AsyncGyroscope<GI>,
        AsyncMagnetometer<MI>,
    ) {
        (self.accel, self.gyro, self.mag)
    }
}

impl<E, AI, GI, MI> AsyncBmx055<AI, GI, MI>
where
    AI: AsyncRegisterInterface<Error = E>,
    GI: AsyncRegisterInterface<Error = E>,
    MI: AsyncRegisterInterface<Error = E>,
{
    /// Initialise the three dies; returns the magnetometer trim.
    pub async fn init(
        &mut self,
        delay: &mut impl DelayNs,
        config: &Bmx055Config,
    ) -> Result<MagTrim, Error<E>> {
        self.accel.init(delay, &config.accel).await?;
        self.gyro.init(delay, &config.gyro).await?;
        self.mag.init(delay, &config.mag).await
    }

    /// Read all three dies without waiting (see [`Bmx055::sample`](crate::Bmx055::sample)).
    pub async fn sample(&mut self) -> Result<ImuSample, Error<E>> {
        let accel = self.accel.read_raw().await?;
        let gyro = self.gyro.read_raw().await?;
        let mag = self.mag.read_raw().await?;
        let mag_fresh = mag.data_ready;
        if mag_fresh {
            self.last_mag = mag.packet_words();
            if self.mag.config().forced {
                self.mag.set_op_mode(MagOpMode::Forced).await?;
            }
        }
        Ok(ImuSample {
            accel,
            gyro,
            mag: self.last_mag,
            mag_fresh,
        })
    }
}
