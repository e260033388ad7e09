//! Gyroscope die (BMG160-class, 16 bit, chip id 0x0F).

mod fifo;
mod interrupt;
pub mod register;
mod selftest;
mod types;

pub use fifo::{decode_gyro_fifo_frame, GyroFifoConfig, GYRO_FIFO_FRAMES};
pub use interrupt::{GyroInterruptConfig, GyroInterruptStatus};
pub use selftest::{GyroSelfTest, BIST_POLL_ATTEMPTS};
pub use types::*;

use crate::interface::{I2cInterface, RegisterInterface, SpiInterface};
use crate::types::FifoData;
use crate::Error;
use embedded_hal::delay::DelayNs;
use register as reg;

/// Wait after a soft reset or power-up before the die answers (datasheet start-up: 30 ms).
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

/// BMX055 gyroscope driver.
#[derive(Debug)]
pub struct Gyroscope<IFACE> {
    pub(crate) iface: IFACE,
    pub(crate) range: GyroRange,
    pub(crate) fifo_data: FifoData,
}

impl<SPI> Gyroscope<SpiInterface<SPI>> {
    /// Driver over the gyroscope's own SPI device (chip select CSB2).
    pub fn new_spi(spi: SPI) -> Self {
        Self::new(SpiInterface::new(spi))
    }
}

impl<I2C> Gyroscope<I2cInterface<I2C>> {
    /// Driver over I2C at the strapped address.
    pub fn new_i2c(i2c: I2C, address: GyroAddress) -> Self {
        Self::new(I2cInterface::new(i2c, address as u8))
    }
}

impl<IFACE> Gyroscope<IFACE> {
    /// Driver over any register interface; assumes the reset range (±2000 °/s).
    pub fn new(iface: IFACE) -> Self {
        Self {
            iface,
            range: GyroRange::Dps2000,
            fifo_data: FifoData::Xyz,
        }
    }
    /// Give the interface back.
    pub fn release(self) -> IFACE {
        self.iface
    }
    /// The range used to scale samples (the last one written).
    pub fn range(&self) -> GyroRange {
        self.range
    }
}

impl<IFACE: RegisterInterface> Gyroscope<IFACE> {
    pub(crate) fn write(&mut self, r: u8, v: u8) -> Result<(), Error<IFACE::Error>> {
        self.iface.write_register(r, v).map_err(Error::Comm)
    }
    pub(crate) fn read(&mut self, r: u8) -> Result<u8, Error<IFACE::Error>> {
        self.iface.read_register(r).map_err(Error::Comm)
    }
    pub(crate) fn read_into(&mut self, r: u8, buf: &mut [u8]) -> Result<(), Error<IFACE::Error>> {
        self.iface.read_registers(r, buf).map_err(Error::Comm)
    }

    /// Read the chip-id register (0x0F on a healthy die).
    pub fn chip_id(&mut self) -> Result<u8, Error<IFACE::Error>> {
        self.read(reg::CHIP_ID)
    }

    /// Read the chip id up to `attempts` times (1 ms apart) until it is 0x0F.
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

    /// Soft reset, then wait [`SOFT_RESET_WAIT_MS`].
    pub fn soft_reset(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::BGW_SOFTRESET, reg::SOFT_RESET_CMD)?;
        delay.delay_ms(SOFT_RESET_WAIT_MS);
        self.range = GyroRange::Dps2000;
        self.fifo_data = FifoData::Xyz;
        Ok(())
    }

    /// Soft reset, check the chip id (up to 3 attempts), apply `config`.
    ///
    /// With [`GyroConfig::DIMA`] the bus sees exactly: write 0x14 = 0xB6, read 0x00,
    /// write 0x0F = 0x00, write 0x10 = 0x81, write 0x11 = 0x00.
    pub fn init(
        &mut self,
        delay: &mut impl DelayNs,
        config: &GyroConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        self.soft_reset(delay)?;
        self.check_chip_id(delay, 3)?;
        self.configure(config)
    }

    /// Apply range, data rate / filter and power mode (three register writes).
    pub fn configure(&mut self, config: &GyroConfig) -> Result<(), Error<IFACE::Error>> {
        for (r, v) in config.register_writes() {
            self.write(r, v)?;
        }
        self.range = config.range;
        Ok(())
    }

    /// Change the range only.
    pub fn set_range(&mut self, range: GyroRange) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::RANGE, range.bits())?;
        self.range = range;
        Ok(())
    }

    /// Change the data rate / filter only.
    pub fn set_bandwidth(&mut self, bw: GyroBandwidth) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::BW, bw.bits())
    }

    /// Change the power mode only.
    pub fn set_power_mode(&mut self, mode: GyroPowerMode) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::LPM1, mode.bits())
    }

    /// Read X, Y, Z in one burst.
    pub fn read_raw(&mut self) -> Result<GyroRaw, Error<IFACE::Error>> {
        let mut b = [0u8; 6];
        self.read_into(reg::RATE_X_LSB, &mut b)?;
        Ok(GyroRaw::from_registers(&b))
    }

    /// Read one sample in °/s, scaled with the current range.
    pub fn read_dps(&mut self) -> Result<crate::Xyz<f32>, Error<IFACE::Error>> {
        let range = self.range;
        Ok(self.read_raw()?.dps(range))
    }

    /// Read one sample in rad/s, scaled with the current range.
    pub fn read_rad_s(&mut self) -> Result<crate::Xyz<f32>, Error<IFACE::Error>> {
        let range = self.range;
        Ok(self.read_raw()?.rad_s(range))
    }

    /// Die temperature in °C (0.5 K resolution).
    pub fn temperature_celsius(&mut self) -> Result<f32, Error<IFACE::Error>> {
        Ok(crate::accel::accel_temperature_celsius(
            self.read(reg::TEMP)?,
        ))
    }
}
