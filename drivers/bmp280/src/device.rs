//! The blocking driver.

use embedded_hal::delay::DelayNs;

use crate::calibration::Calibration;
use crate::compensation::{self, Measurement};
use crate::config::Config;
use crate::interface::{I2cInterface, Interface, SpiInterface};
use crate::raw::RawSample;
use crate::register::{self, Status};
use crate::sequence;
use crate::types::{Chip, DeviceError, Error, I2cAddress};

/// A BMP280 on an SPI or I2C bus (blocking API).
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
    /// temperature part; by default a BME280 is rejected with [`Error::Bme280NotAccepted`].
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

    /// Destroys the driver and gives the interface back.
    pub fn into_interface(self) -> IFACE {
        self.iface
    }
}

impl<IFACE, E> Bmp280<IFACE>
where
    IFACE: Interface<Error = E>,
{
    /// Brings the device up: soft reset, start-up wait, chip id check, wait for the NVM copy
    /// (`im_update`), and one read of the 24 calibration bytes. Afterwards the device is in
    /// sleep mode; call [`Bmp280::configure`].
    ///
    /// Takes 2 to 7 ms. Fails with [`Error::InvalidChipId`] or [`Error::Bme280NotAccepted`] for
    /// the wrong chip, [`Error::Timeout`] if the NVM copy never ends, and
    /// [`Error::InvalidCalibration`] if the calibration would make the pressure formula divide
    /// by zero.
    pub fn init(&mut self, delay: &mut impl DelayNs) -> Result<Chip, Error<E>> {
        self.soft_reset(delay)?;
        let chip = Chip::from_id(self.chip_id()?, self.accept_bme280)?;
        self.wait_nvm_copy(delay)?;
        self.read_calibration()?;
        Ok(chip)
    }

    /// Soft reset (0xE0 <- 0xB6), then the 2 ms start-up wait. All registers return to their
    /// reset values (sleep mode); the calibration is kept.
    pub fn soft_reset(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<E>> {
        self.write(register::RESET, register::RESET_COMMAND)?;
        self.config = sequence::reset_config();
        delay.delay_us(sequence::STARTUP_US);
        Ok(())
    }

    /// Reads the chip id register (0xD0).
    pub fn chip_id(&mut self) -> Result<u8, Error<E>> {
        self.read_byte(register::CHIP_ID)
    }

    /// Reads the status register (0xF3).
    pub fn status(&mut self) -> Result<Status, Error<E>> {
        Ok(Status::from_bits_retain(self.read_byte(register::STATUS)?))
    }

    /// Reads and stores the calibration (0x88..=0x9F in one burst).
    pub fn read_calibration(&mut self) -> Result<Calibration, Error<E>> {
        let mut bytes = [0u8; register::CALIB_LEN];
        self.read(register::CALIB_START, &mut bytes)?;
        let calibration = Calibration::from_bytes(&bytes);
        if calibration.dig_p1 == 0 {
            return Err(DeviceError::InvalidCalibration.into());
        }
        self.calibration = Some(calibration);
        Ok(calibration)
    }

    /// Applies `config`: sleep first (so the `config` register write is not ignored), then
    /// `config` (0xF5), then `ctrl_meas` (0xF4) with the requested mode. Three register writes.
    pub fn configure(&mut self, config: Config) -> Result<(), Error<E>> {
        for (reg, value) in sequence::config_writes(&config) {
            self.write(reg, value)?;
        }
        self.config = config;
        Ok(())
    }

    /// Reads `ctrl_meas` and `config` back from the device.
    pub fn read_config(&mut self) -> Result<Config, Error<E>> {
        let mut regs = [0u8; 2];
        self.read(register::CTRL_MEAS, &mut regs)?;
        Ok(Config::from_registers(regs[0], regs[1]))
    }

    /// Starts one forced measurement with the configured oversampling and filter. Poll with
    /// [`Bmp280::poll_forced`]; the result is ready after
    /// [`Config::measurement_time_typ_us`] to [`Config::measurement_time_max_us`].
    pub fn start_forced(&mut self) -> Result<(), Error<E>> {
        self.write(register::CTRL_MEAS, sequence::forced_start(&self.config))
    }

    /// True while a conversion runs (`status` bit 3).
    pub fn is_measuring(&mut self) -> Result<bool, Error<E>> {
        Ok(sequence::measuring(self.read_byte(register::STATUS)?))
    }

    /// Polls a forced measurement: `WouldBlock` while `measuring` is set, else the compensated
    /// sample. Fails with [`Error::NotCalibrated`] before reading anything if the calibration is
    /// unknown.
    ///
    /// The bit is set from the `ctrl_meas` write until the results are in the data registers,
    /// so any poll after [`Bmp280::start_forced`] returned is valid; polling only after
    /// [`Config::measurement_time_typ_us`] saves bus traffic. Without a started measurement the
    /// bit is clear and the previous sample is returned.
    pub fn poll_forced(&mut self) -> nb::Result<Measurement, Error<E>> {
        let calibration = self.calibration.ok_or(Error::NotCalibrated)?;
        let raw = self.poll_forced_raw()?;
        Ok(compensation::compensate(&calibration, raw).map_err(Error::from)?)
    }

    /// Polls a forced measurement for the raw values only (no calibration needed).
    pub fn poll_forced_raw(&mut self) -> nb::Result<RawSample, Error<E>> {
        if self.is_measuring()? {
            return Err(nb::Error::WouldBlock);
        }
        Ok(self.read_raw()?)
    }

    /// One forced measurement, start to result: waits the typical time, then polls `measuring`
    /// every 0.5 ms until the datasheet's maximum time plus 2 ms has passed
    /// ([`Error::Timeout`] after that).
    pub fn measure_forced(&mut self, delay: &mut impl DelayNs) -> Result<Measurement, Error<E>> {
        if self.calibration.is_none() {
            return Err(Error::NotCalibrated);
        }
        self.start_forced()?;
        delay.delay_us(self.config.measurement_time_typ_us());
        for _ in 0..sequence::forced_polls(&self.config) {
            match self.poll_forced() {
                Ok(m) => return Ok(m),
                Err(nb::Error::Other(e)) => return Err(e),
                Err(nb::Error::WouldBlock) => delay.delay_us(sequence::FORCED_POLL_INTERVAL_US),
            }
        }
        Err(Error::Timeout)
    }

    /// Reads the 6 data registers 0xF7..=0xFC in one burst, in register order (pressure MSB,
    /// LSB, XLSB, temperature MSB, LSB, XLSB): the bytes the DIMA sensor packet carries.
    pub fn read_raw_bytes(&mut self) -> Result<[u8; 6], Error<E>> {
        let mut bytes = [0u8; register::DATA_LEN];
        self.read(register::DATA_START, &mut bytes)?;
        Ok(bytes)
    }

    /// Reads one raw sample (one burst of 0xF7..=0xFC).
    pub fn read_raw(&mut self) -> Result<RawSample, Error<E>> {
        Ok(RawSample::from_register_bytes(&self.read_raw_bytes()?))
    }

    /// Reads the latest sample and compensates it (normal mode, or after a finished forced
    /// measurement). The result keeps the raw values.
    pub fn measure(&mut self) -> Result<Measurement, Error<E>> {
        let calibration = self.calibration.ok_or(Error::NotCalibrated)?;
        let raw = self.read_raw()?;
        Ok(compensation::compensate(&calibration, raw)?)
    }

    fn wait_nvm_copy(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<E>> {
        for _ in 0..sequence::NVM_POLLS {
            if !sequence::nvm_busy(self.read_byte(register::STATUS)?) {
                return Ok(());
            }
            delay.delay_us(sequence::NVM_POLL_INTERVAL_US);
        }
        Err(Error::Timeout)
    }

    fn read_byte(&mut self, reg: u8) -> Result<u8, Error<E>> {
        let mut byte = [0u8];
        self.read(reg, &mut byte)?;
        Ok(byte[0])
    }

    fn read(&mut self, reg: u8, buf: &mut [u8]) -> Result<(), Error<E>> {
        self.iface.read_registers(reg, buf).map_err(Error::Comm)
    }

    fn write(&mut self, reg: u8, value: u8) -> Result<(), Error<E>> {
        self.iface.write_register(reg, value).map_err(Error::Comm)
    }
}
