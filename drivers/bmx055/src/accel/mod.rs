//! Accelerometer die (BMA2x2-class, 12 bit, chip id 0xFA).
//!
//! [`Accelerometer`] owns the bus interface; configuration, data, interrupts, FIFO, self-test
//! and offset compensation are methods on it, split over this module's files.

mod fifo;
mod interrupt;
mod offset;
pub(crate) mod register;
mod selftest;
mod types;

pub use fifo::{decode_accel_fifo_frame, AccelFifoConfig, ACCEL_FIFO_FRAMES};
pub use interrupt::{AccelInterruptConfig, AccelInterruptStatus, SlopeConfig};
pub use offset::{offset_setting, OffsetTarget, FOC_POLL_ATTEMPTS, OFFSET_MG_PER_LSB};
pub use selftest::{AccelSelfTest, SELF_TEST_MIN_MG, SELF_TEST_SETTLE_MS};
pub use types::*;

#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::Registers;
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::{I2cInterface, RegisterInterface, SpiInterface};
use crate::Error;
use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;
use register as reg;

/// Wait after a soft reset before the die answers, in µs: Bosch's BMA2 SensorAPI waits
/// `BMA2_DELAY_SOFT_RESET` = 1800 µs in `bma2_soft_reset`; rounded up to 2 ms.
pub const SOFT_RESET_WAIT_US: u32 = 2_000;

/// I2C address of the accelerometer, set by the SDO1 strap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AccelAddress {
    /// SDO1 low: 0x18.
    #[default]
    Sdo1Low = 0x18,
    /// SDO1 high: 0x19.
    Sdo1High = 0x19,
}

crate::blocking_and_async! {
    /// BMX055 accelerometer driver.
    #[derive(Debug)]
    pub struct Accelerometer<IFACE> {
        pub(crate) iface: IFACE,
        pub(crate) range: AccelRange,
        pub(crate) fifo_data: crate::types::FifoData,
    }
}

crate::blocking_and_async! {
    impl<SPI> Accelerometer<SpiInterface<SPI>> {
        /// Driver over the accelerometer's own SPI device (chip select CSB1).
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
    impl<I2C> Accelerometer<I2cInterface<I2C>> {
        /// Driver over I2C at the strapped address.
        pub fn new_i2c(i2c: I2C, address: AccelAddress) -> Self {
            Self::new(I2cInterface::new(i2c, address as u8))
        }
        /// Gives the I2C bus back (what [`new_i2c`](Self::new_i2c) was given).
        pub fn release(self) -> I2C {
            self.iface.release()
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE> Accelerometer<IFACE> {
        /// Driver over any register interface. Assumes the reset range (±2 g) until
        /// [`configure`](Self::configure) or [`set_range`](Self::set_range) is called.
        pub fn new(iface: IFACE) -> Self {
            Self {
                iface,
                range: AccelRange::G2,
                fifo_data: crate::types::FifoData::Xyz,
            }
        }
        /// Gives the interface back (what [`new`](Self::new) was given; drivers made with
        /// `new_spi` or `new_i2c` give the bus back with `release`).
        pub fn into_interface(self) -> IFACE {
            self.iface
        }
        /// The range used to scale samples (the last one written).
        pub fn range(&self) -> AccelRange {
            self.range
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Accelerometer<IFACE> {
        /// Read the chip-id register (0xFA on a healthy die).
        pub async fn chip_id(&mut self) -> Result<u8, Error<IFACE::Error>> {
            self.iface.read(reg::BGW_CHIPID).await
        }

        /// Read the chip id up to `attempts` times (1 ms apart) until it is 0xFA.
        pub async fn check_chip_id(
            &mut self,
            delay: &mut impl DelayNs,
            attempts: u8,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface
                .check_chip_id(delay, reg::BGW_CHIPID, reg::CHIP_ID_VALUE, attempts)
                .await
        }

        /// Soft reset (all registers to their defaults), then wait until the die answers.
        pub async fn soft_reset(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface
                .write(reg::BGW_SOFTRESET, reg::SOFT_RESET_CMD)
                .await?;
            delay.delay_us(SOFT_RESET_WAIT_US).await;
            self.range = AccelRange::G2;
            self.fifo_data = crate::types::FifoData::Xyz;
            Ok(())
        }

        /// Soft reset, check the chip id (up to 3 attempts), apply `config`.
        ///
        /// With ±2 g, 1000 Hz and normal mode the bus sees exactly: write 0x14 = 0xB6, read 0x00,
        /// write 0x0F = 0x03, write 0x10 = 0x0F, write 0x11 = 0x00.
        pub async fn init(
            &mut self,
            delay: &mut impl DelayNs,
            config: &AccelConfig,
        ) -> Result<(), Error<IFACE::Error>> {
            self.soft_reset(delay).await?;
            self.check_chip_id(delay, 3).await?;
            self.configure(config).await
        }

        /// Apply range, bandwidth and power mode (three register writes).
        pub async fn configure(&mut self, config: &AccelConfig) -> Result<(), Error<IFACE::Error>> {
            self.iface.write_all(config.register_writes()).await?;
            self.range = config.range;
            Ok(())
        }

        /// Change the range only.
        pub async fn set_range(&mut self, range: AccelRange) -> Result<(), Error<IFACE::Error>> {
            self.iface.write(reg::PMU_RANGE, range.bits()).await?;
            self.range = range;
            Ok(())
        }

        /// Change the filter bandwidth only.
        pub async fn set_bandwidth(&mut self, bw: AccelBandwidth) -> Result<(), Error<IFACE::Error>> {
            self.iface.write(reg::PMU_BW, bw.bits()).await
        }

        /// Change the power mode only.
        pub async fn set_power_mode(
            &mut self,
            mode: AccelPowerMode,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface.write(reg::PMU_LPW, mode.bits()).await
        }

        /// Read X, Y, Z in one burst (shadowing keeps LSB/MSB pairs consistent).
        pub async fn read_raw(&mut self) -> Result<AccelRaw, Error<IFACE::Error>> {
            let mut b = [0u8; 6];
            self.iface.read_into(reg::ACCD_X_LSB, &mut b).await?;
            Ok(AccelRaw::from_registers(&b))
        }

        /// Read one sample in mg, scaled with the current range.
        pub async fn read_mg(&mut self) -> Result<crate::Xyz<f32>, Error<IFACE::Error>> {
            let range = self.range;
            Ok(self.read_raw().await?.mg(range))
        }

        /// Read one sample in m/s², scaled with the current range.
        pub async fn read_m_s2(&mut self) -> Result<crate::Xyz<f32>, Error<IFACE::Error>> {
            let range = self.range;
            Ok(self.read_raw().await?.m_s2(range))
        }

        /// Die temperature in °C (0.5 K resolution).
        pub async fn temperature_celsius(&mut self) -> Result<f32, Error<IFACE::Error>> {
            Ok(accel_temperature_celsius(
                self.iface.read(reg::ACCD_TEMP).await?,
            ))
        }
    }
}
