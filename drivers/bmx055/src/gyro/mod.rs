//! Gyroscope die (BMG160-class, 16 bit, chip id 0x0F).

mod fifo;
mod interrupt;
pub(crate) mod register;
mod selftest;
mod types;

pub use fifo::{decode_gyro_fifo_frame, GyroFifoConfig, GYRO_FIFO_FRAMES};
pub use interrupt::{GyroInterruptConfig, GyroInterruptStatus};
pub use selftest::{GyroSelfTest, BIST_POLL_ATTEMPTS};
pub use types::*;

#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::Registers;
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::{I2cInterface, RegisterInterface, SpiInterface};
use crate::types::FifoData;
use crate::Error;
use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;
use register as reg;

/// Wait after a soft reset or power-up before the die answers, in ms (BMX055 datasheet key
/// features, gyroscope: "30ms start-up time").
pub const SOFT_RESET_WAIT_MS: u32 = 30;

/// I2C address of the gyroscope, set by the SDO2 strap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GyroAddress {
    /// SDO2 low: 0x68.
    #[default]
    Sdo2Low = 0x68,
    /// SDO2 high: 0x69.
    Sdo2High = 0x69,
}

crate::blocking_and_async! {
    /// BMX055 gyroscope driver.
    #[derive(Debug)]
    pub struct Gyroscope<IFACE> {
        pub(crate) iface: IFACE,
        pub(crate) range: GyroRange,
        pub(crate) fifo_data: FifoData,
    }
}

crate::blocking_and_async! {
    impl<SPI> Gyroscope<SpiInterface<SPI>> {
        /// Driver over the gyroscope's own SPI device (chip select CSB2).
        pub fn new_spi(spi: SPI) -> Self {
            Self::new(SpiInterface::new(spi))
        }
        /// Gives the SPI device back (what [`new_spi`](Self::new_spi) was given).
        pub fn release(self) -> SPI {
            self.iface.release()
        }
    }
}

crate::blocking_and_async! {
    impl<I2C> Gyroscope<I2cInterface<I2C>> {
        /// Driver over I2C at the strapped address.
        pub fn new_i2c(i2c: I2C, address: GyroAddress) -> Self {
            Self::new(I2cInterface::new(i2c, address as u8))
        }
        /// Gives the I2C bus back (what [`new_i2c`](Self::new_i2c) was given).
        pub fn release(self) -> I2C {
            self.iface.release()
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE> Gyroscope<IFACE> {
        /// Driver over any register interface; assumes the reset range (±2000 °/s).
        pub fn new(iface: IFACE) -> Self {
            Self {
                iface,
                range: GyroRange::Dps2000,
                fifo_data: FifoData::Xyz,
            }
        }
        /// Gives the interface back (what [`new`](Self::new) was given; drivers made with
        /// `new_spi` or `new_i2c` give the bus back with `release`).
        pub fn into_interface(self) -> IFACE {
            self.iface
        }
        /// The range used to scale samples (the last one written).
        pub fn range(&self) -> GyroRange {
            self.range
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Gyroscope<IFACE> {
        /// Read the chip-id register (0x0F on a healthy die).
        pub async fn chip_id(&mut self) -> Result<u8, Error<IFACE::Error>> {
            self.iface.read(reg::CHIP_ID).await
        }

        /// Read the chip id up to `attempts` times (1 ms apart) until it is 0x0F.
        pub async fn check_chip_id(
            &mut self,
            delay: &mut impl DelayNs,
            attempts: u8,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface
                .check_chip_id(delay, reg::CHIP_ID, reg::CHIP_ID_VALUE, attempts)
                .await
        }

        /// Soft reset, then wait [`SOFT_RESET_WAIT_MS`].
        pub async fn soft_reset(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface
                .write(reg::BGW_SOFTRESET, reg::SOFT_RESET_CMD)
                .await?;
            delay.delay_ms(SOFT_RESET_WAIT_MS).await;
            self.range = GyroRange::Dps2000;
            self.fifo_data = FifoData::Xyz;
            Ok(())
        }

        /// Soft reset, check the chip id (up to 3 attempts), apply `config`.
        ///
        /// With ±2000 °/s, 2000 Hz / 230 Hz and normal mode the bus sees exactly: write 0x14 = 0xB6, read 0x00,
        /// write 0x0F = 0x00, write 0x10 = 0x81, write 0x11 = 0x00.
        pub async fn init(
            &mut self,
            delay: &mut impl DelayNs,
            config: &GyroConfig,
        ) -> Result<(), Error<IFACE::Error>> {
            self.soft_reset(delay).await?;
            self.check_chip_id(delay, 3).await?;
            self.configure(config).await
        }

        /// Apply range, data rate / filter and power mode (three register writes).
        pub async fn configure(&mut self, config: &GyroConfig) -> Result<(), Error<IFACE::Error>> {
            self.iface.write_all(config.register_writes()).await?;
            self.range = config.range;
            Ok(())
        }

        /// Change the range only.
        pub async fn set_range(&mut self, range: GyroRange) -> Result<(), Error<IFACE::Error>> {
            self.iface.write(reg::RANGE, range.bits()).await?;
            self.range = range;
            Ok(())
        }

        /// Change the data rate / filter only.
        pub async fn set_bandwidth(&mut self, bw: GyroBandwidth) -> Result<(), Error<IFACE::Error>> {
            self.iface.write(reg::BW, bw.bits()).await
        }

        /// Change the power mode only.
        pub async fn set_power_mode(&mut self, mode: GyroPowerMode) -> Result<(), Error<IFACE::Error>> {
            self.iface.write(reg::LPM1, mode.bits()).await
        }

        /// Read X, Y, Z in one burst.
        pub async fn read_raw(&mut self) -> Result<GyroRaw, Error<IFACE::Error>> {
            let mut b = [0u8; 6];
            self.iface.read_into(reg::RATE_X_LSB, &mut b).await?;
            Ok(GyroRaw::from_registers(&b))
        }

        /// Read one sample in °/s, scaled with the current range.
        pub async fn read_dps(&mut self) -> Result<crate::Xyz<f32>, Error<IFACE::Error>> {
            let range = self.range;
            Ok(self.read_raw().await?.dps(range))
        }

        /// Read one sample in rad/s, scaled with the current range.
        pub async fn read_rad_s(&mut self) -> Result<crate::Xyz<f32>, Error<IFACE::Error>> {
            let range = self.range;
            Ok(self.read_raw().await?.rad_s(range))
        }

        /// Die temperature in °C (0.5 K resolution).
        pub async fn temperature_celsius(&mut self) -> Result<f32, Error<IFACE::Error>> {
            Ok(crate::accel::accel_temperature_celsius(
                self.iface.read(reg::TEMP).await?,
            ))
        }
    }
}
