//! The async driver (feature `async`): the blocking driver's logic over embedded-hal-async.
//!
//! Same sequences, same register accesses, same timing (see [`crate::sequence`]); only the
//! waiting differs. The blocking [`Bmp280`](crate::Bmp280) stays available.

use embedded_hal_async::delay::DelayNs;

use crate::calibration::Calibration;
use crate::compensation::{self, Measurement};
use crate::config::Config;
use crate::interface::{AsyncInterface, I2cInterface, SpiInterface};
use crate::raw::RawSample;
use crate::register::{self, Status};
use crate::sequence;
use crate::types::{Chip, DeviceError, Error, I2cAddress};

/// A BMP280 on an async SPI or I2C bus. See [`Bmp280`](crate::Bmp280) for the blocking twin;
/// the methods mean the same.
#[derive(Debug)]
pub struct Bmp280Async<IFACE> {
    iface: IFACE,
    config: Config,
    calibration: Option<Calibration>,
    accept_bme280: bool,
}

impl<SPI> Bmp280Async<SpiInterface<SPI>> {
    /// A driver on an embedded-hal-async `SpiDevice`.
    pub const fn new_spi(spi: SPI) -> Self {
        Self::new(SpiInterface::new(spi))
    }

    /// Destroys the driver and gives the SPI device back.
    pub fn release(self) -> SPI {
        self.iface.release()
    }
}

impl<I2C> Bmp280Async<I2cInterface<I2C>> {
    /// A driver on an embedded-hal-async `I2c` bus at the address selected by the SDO pin.
    pub const fn new_i2c(i2c: I2C, address: I2cAddress) -> Self {
        Self::new(I2cInterface::new(i2c, address))
    }

    /// Destroys the driver and gives the I2C bus back.
    pub fn release(self) -> I2C {
        self.iface.release()
    }
}

impl<IFACE> Bmp280Async<IFACE> {
    /// A driver on any [`AsyncInterface`] implementation.
    pub const fn new(iface: IFACE) -> Self {
        Self {
            iface,
            config: sequence::reset_config(),
            calibration: None,
            accept_bme280: false,
        }
    }

    /// Lets [`Bmp280Async::init`] accept a BME280 (chip id 0x60).
    pub const fn accept_bme280(mut self, accept: bool) -> Self {
        self.accept_bme280 = accept;
        self
    }

    /// The calibration read by [`Bmp280Async::init`] or set by
    /// [`Bmp280Async::set_calibration`].
    pub const fn calibration(&self) -> Option<&Calibration> {
        self.calibration.as_ref()
    }

    /// Uses a known calibration instead of reading it.
    pub fn set_calibration(&mut self, calibration: Calibration) {
        self.calibration = Some(calibration);
    }

    /// The configuration last written by this driver (the reset state before any).
    pub const fn config(&self) -> Config {
        self.config
    }

    /// Destroys the driver and gives the interface back.
    pub fn into_interface(self) -> IFACE {
        self.iface
    }
}

impl<IFACE, E> Bmp280Async<IFACE>
where
    IFACE: AsyncInterface<Error = E>,
{
    /// Soft reset, start-up wait, chip id check, NVM-copy wait, calibration read
    /// (see [`Bmp280::init`](crate::Bmp280::init)).
    pub async fn init(&mut self, delay: &mut impl DelayNs) -> Result<Chip, Error<E>> {
        self.soft_reset(delay).await?;
        let chip = Chip::from_id(self.chip_id().await?, self.accept_bme280)?;
        self.wait_nvm_copy(delay).await?;
        self.read_calibration().await?;
        Ok(chip)
    }

    /// Soft reset (0xE0 <- 0xB6), then the 2 ms start-up wait.
    pub async fn soft_reset(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<E>> {
        self.write(register::RESET, register::RESET_COMMAND).await?;
        self.config = sequence::reset_config();
        delay.delay_us(sequence::STARTUP_US).await;
        Ok(())
    }

    /// Reads the chip id register (0xD0).
    pub async fn chip_id(&mut self) -> Result<u8, Error<E>> {
        self.read_byte(register::CHIP_ID).await
    }

    /// Reads the status register (0xF3).
    pub async fn status(&mut self) -> Result<Status, Error<E>> {
        Ok(Status::from_bits_retain(
            self.read_byte(register::STATUS).await?,
        ))
    }

    /// Reads and stores the calibration (0x88..=0x9F in one burst).
    pub async fn read_calibration(&mut self) -> Result<Calibration, Error<E>> {
        let mut bytes = [0u8; register::CALIB_LEN];
        self.read(register::CALIB_START, &mut bytes).await?;
        let calibration = Calibration::from_bytes(&bytes);
        if calibration.dig_p1 == 0 {
            return Err(DeviceError::InvalidCalibration.into());
        }
        self.calibration = Some(calibration);
        Ok(calibration)
    }

    /// Applies `config` with the same three writes as [`Bmp280::configure`](crate::Bmp280::configure).
    pub async fn configure(&mut self, config: Config) -> Result<(), Error<E>> {
        for (reg, value) in sequence::config_writes(&config) {
            self.write(reg, value).await?;
        }
        self.config = config;
        Ok(())
    }

    /// Reads `ctrl_meas` and `config` back from the device.
    pub async fn read_config(&mut self) -> Result<Config, Error<E>> {
        let mut regs = [0u8; 2];
        self.read(register::CTRL_MEAS, &mut regs).await?;
        Ok(Config::from_registers(regs[0], regs[1]))
    }

    /// Starts one forced measurement with the configured oversampling and filter.
    pub async fn start_forced(&mut self) -> Result<(), Error<E>> {
        self.write(register::CTRL_MEAS, sequence::forced_start(&self.config))
            .await
    }

    /// True while a conversion runs (`status` bit 3).
    pub async fn is_measuring(&mut self) -> Result<bool, Error<E>> {
        Ok(sequence::measuring(self.read_byte(register::STATUS).await?))
    }

    /// One forced measurement, start to result, with the same waits and deadline as
    /// [`Bmp280::measure_forced`](crate::Bmp280::measure_forced).
    pub async fn measure_forced(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<Measurement, Error<E>> {
        let calibration = self.calibration.ok_or(Error::NotCalibrated)?;
        self.start_forced().await?;
        delay.delay_us(self.config.measurement_time_typ_us()).await;
        for _ in 0..sequence::forced_polls(&self.config) {
            if !self.is_measuring().await? {
                let raw = self.read_raw().await?;
                return Ok(compensation::compensate(&calibration, raw)?);
            }
            delay.delay_us(sequence::FORCED_POLL_INTERVAL_US).await;
        }
        Err(Error::Timeout)
    }

    /// Reads the 6 data registers 0xF7..=0xFC in one burst, in register order.
    pub async fn read_raw_bytes(&mut self) -> Result<[u8; 6], Error<E>> {
        let mut bytes = [0u8; register::DATA_LEN];
        self.read(register::DATA_START, &mut bytes).await?;
        Ok(bytes)
    }

    /// Reads one raw sample (one burst of 0xF7..=0xFC).
    pub async fn read_raw(&mut self) -> Result<RawSample, Error<E>> {
        Ok(RawSample::from_register_bytes(
            &self.read_raw_bytes().await?,
        ))
    }

    /// Reads the latest sample and compensates it.
    pub async fn measure(&mut self) -> Result<Measurement, Error<E>> {
        let calibration = self.calibration.ok_or(Error::NotCalibrated)?;
        let raw = self.read_raw().await?;
        Ok(compensation::compensate(&calibration, raw)?)
    }

    async fn wait_nvm_copy(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<E>> {
        for _ in 0..sequence::NVM_POLLS {
            if !sequence::nvm_busy(self.read_byte(register::STATUS).await?) {
                return Ok(());
            }
            delay.delay_us(sequence::NVM_POLL_INTERVAL_US).await;
        }
        Err(Error::Timeout)
    }

    async fn read_byte(&mut self, reg: u8) -> Result<u8, Error<E>> {
        let mut byte = [0u8];
        self.read(reg, &mut byte).await?;
        Ok(byte[0])
    }

    async fn read(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), Error<E>> {
        self.iface
            .read_registers(reg, buf)
            .await
            .map_err(Error::Comm)
    }

    async fn write(&mut self, reg: u8, value: u8) -> Result<(), Error<E>> {
        self.iface
            .write_register(reg, value)
            .await
            .map_err(Error::Comm)
    }
}
