//! Accelerometer die (BMA2x2-class, 12 bit, chip id 0xFA).
//!
//! [`Accelerometer`] owns the bus interface; configuration, data, interrupts, FIFO, self-test
//! and offset compensation are methods on it, split over this module's files.

mod fifo;
mod interrupt;
mod offset;
pub mod register;
mod selftest;
mod types;

pub use fifo::{decode_accel_fifo_frame, AccelFifoConfig, ACCEL_FIFO_FRAMES};
pub use interrupt::{AccelInterruptConfig, AccelInterruptStatus, SlopeConfig};
pub use offset::{offset_setting, OffsetTarget, FOC_POLL_ATTEMPTS, OFFSET_MG_PER_LSB};
pub use selftest::{AccelSelfTest, SELF_TEST_MIN_MG, SELF_TEST_SETTLE_MS};
pub use types::*;

use crate::interface::{I2cInterface, RegisterInterface, SpiInterface};
use crate::Error;
use embedded_hal::delay::DelayNs;
use register as reg;

/// Wait after a soft reset before the die answers (datasheet: 1.8 ms).
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

/// BMX055 accelerometer driver.
#[derive(Debug)]
pub struct Accelerometer<IFACE> {
    pub(crate) iface: IFACE,
    pub(crate) range: AccelRange,
    pub(crate) fifo_data: crate::types::FifoData,
}

impl<SPI> Accelerometer<SpiInterface<SPI>> {
    /// Driver over the accelerometer's own SPI device (chip select CSB1).
    pub fn new_spi(spi: SPI) -> Self {
        Self::new(SpiInterface::new(spi))
    }
}

impl<I2C> Accelerometer<I2cInterface<I2C>> {
    /// Driver over I2C at the strapped address.
    pub fn new_i2c(i2c: I2C, address: AccelAddress) -> Self {
        Self::new(I2cInterface::new(i2c, address as u8))
    }
}

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
    /// Give the interface back.
    pub fn release(self) -> IFACE {
        self.iface
    }
    /// The range used to scale samples (the last one written).
    pub fn range(&self) -> AccelRange {
        self.range
    }
}

impl<IFACE: RegisterInterface> Accelerometer<IFACE> {
    pub(crate) fn write(&mut self, r: u8, v: u8) -> Result<(), Error<IFACE::Error>> {
        self.iface.write_register(r, v).map_err(Error::Comm)
    }
    pub(crate) fn read(&mut self, r: u8) -> Result<u8, Error<IFACE::Error>> {
        self.iface.read_register(r).map_err(Error::Comm)
    }
    pub(crate) fn read_into(&mut self, r: u8, buf: &mut [u8]) -> Result<(), Error<IFACE::Error>> {
        self.iface.read_registers(r, buf).map_err(Error::Comm)
    }

    /// Read the chip-id register (0xFA on a healthy die).
    pub fn chip_id(&mut self) -> Result<u8, Error<IFACE::Error>> {
        self.read(reg::BGW_CHIPID)
    }

    /// Read the chip id up to `attempts` times (1 ms apart) until it is 0xFA.
    pub fn check_chip_id(
        &mut self,
        delay: &mut impl DelayNs,
        attempts: u8,
    ) -> Result<(), Error<IFACE::Error>> {
        let mut found = 0;
        for i in 0..attempts.max(1) {
            if i > 0 {
                delay.delay_ms(1);
            }
            found = self.chip_id()?;
            if found == reg::CHIP_ID_VALUE {
                return Ok(());
            }
        }
        Err(Error::InvalidChipId { found })
    }

    /// Soft reset (all registers to their defaults), then wait until the die answers.
    pub fn soft_reset(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::BGW_SOFTRESET, reg::SOFT_RESET_CMD)?;
        delay.delay_us(SOFT_RESET_WAIT_US);
        self.range = AccelRange::G2;
        self.fifo_data = crate::types::FifoData::Xyz;
        Ok(())
    }

    /// Soft reset, check the chip id (up to 3 attempts), apply `config`.
    ///
    /// With [`AccelConfig::DIMA`] the bus sees exactly: write 0x14 = 0xB6, read 0x00,
    /// write 0x0F = 0x03, write 0x10 = 0x0F, write 0x11 = 0x00.
    pub fn init(
        &mut self,
        delay: &mut impl DelayNs,
        config: &AccelConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        self.soft_reset(delay)?;
        self.check_chip_id(delay, 3)?;
        self.configure(config)
    }

    /// Apply range, bandwidth and power mode (three register writes).
    pub fn configure(&mut self, config: &AccelConfig) -> Result<(), Error<IFACE::Error>> {
        for (r, v) in config.register_writes() {
            self.write(r, v)?;
        }
        self.range = config.range;
        Ok(())
    }

    /// Change the range only.
    pub fn set_range(&mut self, range: AccelRange) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::PMU_RANGE, range.bits())?;
        self.range = range;
        Ok(())
    }

    /// Change the filter bandwidth only.
    pub fn set_bandwidth(&mut self, bw: AccelBandwidth) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::PMU_BW, bw.bits())
    }

    /// Change the power mode only.
    pub fn set_power_mode(&mut self, mode: AccelPowerMode) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::PMU_LPW, mode.bits())
    }

    /// Read X, Y, Z in one burst (shadowing keeps LSB/MSB pairs consistent).
    pub fn read_raw(&mut self) -> Result<AccelRaw, Error<IFACE::Error>> {
        let mut b = [0u8; 6];
        self.read_into(reg::ACCD_X_LSB, &mut b)?;
        Ok(AccelRaw::from_registers(&b))
    }

    /// Read one sample in mg, scaled with the current range.
    pub fn read_mg(&mut self) -> Result<crate::Xyz<f32>, Error<IFACE::Error>> {
        let range = self.range;
        Ok(self.read_raw()?.mg(range))
    }

    /// Read one sample in m/s², scaled with the current range.
    pub fn read_m_s2(&mut self) -> Result<crate::Xyz<f32>, Error<IFACE::Error>> {
        let range = self.range;
        Ok(self.read_raw()?.m_s2(range))
    }

    /// Die temperature in °C (0.5 K resolution).
    pub fn temperature_celsius(&mut self) -> Result<f32, Error<IFACE::Error>> {
        Ok(accel_temperature_celsius(self.read(reg::ACCD_TEMP)?))
    }
}
