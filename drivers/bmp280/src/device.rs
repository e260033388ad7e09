//! The driver, written once: `maybe_async_cfg` generates the blocking [`Bmp280`] from this
//! async source by dropping `async` and `.await`, and keeps the async [`Bmp280Async`] with the
//! `async` feature. Both issue the same register accesses with the same waits.

#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

use embedded_hal::delay::DelayNs;

use crate::calibration::Calibration;
use crate::compensation::{self, Measurement};
use crate::config::{Config, PowerMode};
#[cfg(feature = "async")]
use crate::interface::AsyncInterface;
use crate::interface::{I2cInterface, Interface, SpiInterface};
use crate::raw::RawSample;
use crate::register::{self, Status};
use crate::sequence;
use crate::types::{Chip, DeviceError, Error, I2cAddress};

crate::blocking_and_async! {
    /// A BMP280 on an SPI or I2C bus; `Bmp280Async` (feature `async`) is the same driver on
    /// embedded-hal-async with the same methods, each `async`.
    ///
    /// Create it with [`Bmp280::new_spi`] or [`Bmp280::new_i2c`], bring it up with
    /// [`Bmp280::init`], apply a [`Config`] with [`Bmp280::configure`], then read samples with
    /// [`Bmp280::measure`] (normal mode) or [`Bmp280::start_forced`] + [`Bmp280::poll_forced`]
    /// (forced mode).
    #[derive(Debug)]
    pub struct Bmp280<IFACE> {
        iface: IFACE,
        config: Config,
        calibration: Option<Calibration>,
        accept_bme280: bool,
    }
}

crate::blocking_and_async! {
    impl<SPI> Bmp280<SpiInterface<SPI>> {
        /// A driver on an embedded-hal [`SpiDevice`](embedded_hal::spi::SpiDevice) (SPI mode 0 or
        /// 3, up to 10 MHz). Nothing is sent until [`Bmp280::init`].
        pub const fn new_spi(spi: SPI) -> Self {
            Self::new(SpiInterface::new(spi))
        }

        /// Destroys the driver and gives the SPI device back.
        pub fn release(self) -> SPI {
            self.iface.release()
        }
    }
}

crate::blocking_and_async! {
    impl<I2C> Bmp280<I2cInterface<I2C>> {
        /// A driver on an embedded-hal [`I2c`](embedded_hal::i2c::I2c) bus at the address selected
        /// by the SDO pin. Nothing is sent until [`Bmp280::init`].
        pub const fn new_i2c(i2c: I2C, address: I2cAddress) -> Self {
            Self::new(I2cInterface::new(i2c, address))
        }

        /// Destroys the driver and gives the I2C bus back.
        pub fn release(self) -> I2C {
            self.iface.release()
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE> Bmp280<IFACE> {
        /// A driver on any [`Interface`] implementation.
        pub const fn new(iface: IFACE) -> Self {
            Self {
                iface,
                config: sequence::reset_config(),
                calibration: None,
                accept_bme280: false,
            }
        }

        /// Lets [`Bmp280::init`] accept a BME280 (chip id 0x60) and drive its pressure and
        /// temperature part; by default a BME280 is rejected with [`DeviceError::Bme280NotAccepted`].
        /// On a BME280 the two longest standby codes mean 10 ms and 20 ms (see [`Chip::Bme280`]).
        pub const fn accept_bme280(mut self, accept: bool) -> Self {
            self.accept_bme280 = accept;
            self
        }

        /// The calibration read by [`Bmp280::init`] or set by [`Bmp280::set_calibration`], for
        /// sending to a host that compensates raw samples itself.
        pub const fn calibration(&self) -> Option<&Calibration> {
            self.calibration.as_ref()
        }

        /// Uses a known calibration instead of reading it (e.g. one stored from an earlier read).
        pub fn set_calibration(&mut self, calibration: Calibration) {
            self.calibration = Some(calibration);
        }

        /// The configuration last written by this driver (the reset state before any).
        pub const fn config(&self) -> Config {
            self.config
        }

        /// Gives the interface back (what [`Bmp280::new`] was given; a driver made with
        /// `new_spi` or `new_i2c` gives the bus back with `release`).
        pub fn into_interface(self) -> IFACE {
            self.iface
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE, E> Bmp280<IFACE>
    where
        IFACE: Interface<Error = E>,
    {
        /// Brings the device up: soft reset, start-up wait, chip id check, wait for the NVM copy
        /// (`im_update`), and one read of the 24 calibration bytes. Afterwards the device is in
        /// sleep mode; call [`Bmp280::configure`].
        ///
        /// Takes 2 to 7 ms. Fails with [`DeviceError::InvalidChipId`] or [`DeviceError::Bme280NotAccepted`] for
        /// the wrong chip, [`DeviceError::Timeout`] if the NVM copy never ends, and
        /// [`DeviceError::InvalidCalibration`] if the calibration would make the pressure formula divide
        /// by zero.
        pub async fn init(&mut self, delay: &mut impl DelayNs) -> Result<Chip, Error<E>> {
            self.soft_reset(delay).await?;
            let chip = Chip::from_id(self.chip_id().await?, self.accept_bme280)?;
            self.wait_nvm_copy(delay).await?;
            self.read_calibration().await?;
            Ok(chip)
        }

        /// Soft reset (0xE0 <- 0xB6), then the 2 ms start-up wait. All registers return to their
        /// reset values (sleep mode); the calibration is kept.
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

        /// Applies `config`: sleep first (so the `config` register write is not ignored), then
        /// `config` (0xF5), then `ctrl_meas` (0xF4) with the requested mode. Three register writes.
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

        /// Starts one forced measurement with the configured oversampling and filter. Poll with
        /// [`Bmp280::poll_forced`]; the result is ready after
        /// [`Config::measurement_time_typ_us`] to [`Config::measurement_time_max_us`].
        ///
        /// This leaves normal mode if it was configured: afterwards [`Bmp280::config`] reports
        /// forced mode, and the device sleeps once the measurement is done.
        pub async fn start_forced(&mut self) -> Result<(), Error<E>> {
            self.write(register::CTRL_MEAS, sequence::forced_start(&self.config))
                .await?;
            self.config.mode = PowerMode::Forced;
            Ok(())
        }

        /// True while a conversion runs (`status` bit 3).
        pub async fn is_measuring(&mut self) -> Result<bool, Error<E>> {
            Ok(sequence::measuring(self.read_byte(register::STATUS).await?))
        }

        /// Polls a forced measurement: `WouldBlock` while it runs, else the compensated
        /// sample. Fails with [`DeviceError::NotCalibrated`] before reading anything if the calibration is
        /// unknown, and with [`DeviceError::NoConversion`] if no measurement has ever ended (the
        /// data registers hold their reset value).
        ///
        /// Each poll reads `status` and `ctrl_meas` in one burst; the measurement runs while
        /// `measuring` (status bit 3) is set or the mode bits still read forced (the device returns
        /// to sleep when done). The mode bits cover the moment right after the start when
        /// `measuring` can still read 0 , so any poll after
        /// [`Bmp280::start_forced`] returned is valid; polling only after
        /// [`Config::measurement_time_typ_us`] saves bus traffic. Without a started measurement
        /// the previous sample is returned.
        pub async fn poll_forced(&mut self) -> nb::Result<Measurement, Error<E>> {
            let calibration = self
                .calibration
                .ok_or(Error::Device(DeviceError::NotCalibrated))?;
            let raw = self.poll_forced_raw().await?;
            Ok(compensate_conversion(&calibration, raw).map_err(Error::from)?)
        }

        /// Polls a forced measurement for the raw values only (no calibration needed).
        pub async fn poll_forced_raw(&mut self) -> nb::Result<RawSample, Error<E>> {
            let mut regs = [0u8; 2];
            self.read(register::STATUS, &mut regs).await?;
            if sequence::forced_busy(regs[0], regs[1]) {
                return Err(nb::Error::WouldBlock);
            }
            Ok(self.read_raw().await?)
        }

        /// One forced measurement, start to result: waits the typical time, then polls
        /// ([`Bmp280::poll_forced`]) every 0.5 ms until the datasheet's maximum time plus 2 ms has
        /// passed ([`DeviceError::Timeout`] after that).
        pub async fn measure_forced(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<Measurement, Error<E>> {
            if self.calibration.is_none() {
                return Err(DeviceError::NotCalibrated.into());
            }
            self.start_forced().await?;
            delay.delay_us(self.config.measurement_time_typ_us()).await;
            for _ in 0..sequence::forced_polls(&self.config) {
                match self.poll_forced().await {
                    Ok(m) => return Ok(m),
                    Err(nb::Error::Other(e)) => return Err(e),
                    Err(nb::Error::WouldBlock) => {
                        delay.delay_us(sequence::FORCED_POLL_INTERVAL_US).await
                    }
                }
            }
            Err(DeviceError::Timeout.into())
        }

        /// Reads the 6 data registers 0xF7..=0xFC in one burst, in register order (pressure MSB,
        /// LSB, XLSB, temperature MSB, LSB, XLSB): the bytes a raw-sample link (e.g. a sensor board packet) carries.
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

        /// Reads the latest sample and compensates it (normal mode, or after a finished forced
        /// measurement). The result keeps the raw values.
        ///
        /// Fails with [`DeviceError::NoConversion`] while the data registers still hold their
        /// reset value: straight after [`Bmp280::configure`] (the first conversion ends up to
        /// [`Config::measurement_time_max_us`] later, about 5.5 ms with [`Config::default`]) or
        /// in sleep mode. [`Bmp280::measure_when_ready`] waits for the first conversion instead.
        pub async fn measure(&mut self) -> Result<Measurement, Error<E>> {
            let calibration = self
                .calibration
                .ok_or(Error::Device(DeviceError::NotCalibrated))?;
            let raw = self.read_raw().await?;
            Ok(compensate_conversion(&calibration, raw)?)
        }

        /// [`Bmp280::measure`], waiting for the first conversion: while the data registers hold
        /// their reset value it waits 0.5 ms and reads again, until the configured maximum
        /// measurement time plus 2 ms has passed ([`DeviceError::Timeout`] after that). Once a
        /// conversion has ended it costs one read, like [`Bmp280::measure`]. In sleep mode no
        /// conversion comes, so it fails at once with [`DeviceError::NoConversion`].
        pub async fn measure_when_ready(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<Measurement, Error<E>> {
            for _ in 0..sequence::first_conversion_polls(&self.config) {
                match self.measure().await {
                    Err(Error::Device(DeviceError::NoConversion))
                        if !matches!(self.config.mode, PowerMode::Sleep) =>
                    {
                        delay.delay_us(sequence::FORCED_POLL_INTERVAL_US).await
                    }
                    other => return other,
                }
            }
            Err(DeviceError::Timeout.into())
        }

        async fn wait_nvm_copy(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<E>> {
            for _ in 0..sequence::NVM_POLLS {
                if !sequence::nvm_busy(self.read_byte(register::STATUS).await?) {
                    return Ok(());
                }
                delay.delay_us(sequence::NVM_POLL_INTERVAL_US).await;
            }
            Err(DeviceError::Timeout.into())
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
}

/// Compensates `raw`, unless the data registers it came from hold no conversion yet.
fn compensate_conversion(
    calibration: &Calibration,
    raw: RawSample,
) -> Result<Measurement, DeviceError> {
    if raw.holds_no_conversion() {
        return Err(DeviceError::NoConversion);
    }
    compensation::compensate(calibration, raw)
}
