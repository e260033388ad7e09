//! Bus addresses, chip identities and the driver's error type.

use core::fmt;

/// I2C slave address, selected by the level of the SDO pin (datasheet 5.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum I2cAddress {
    /// SDO tied to GND: 0x76.
    #[default]
    SdoLow,
    /// SDO tied to VDDIO: 0x77.
    SdoHigh,
}

impl I2cAddress {
    /// The 7-bit address.
    pub const fn addr(self) -> u8 {
        match self {
            I2cAddress::SdoLow => 0x76,
            I2cAddress::SdoHigh => 0x77,
        }
    }
}

/// Which chip answered the `id` register.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Chip {
    /// A production BMP280, id 0x58.
    Bmp280,
    /// An early engineering sample of the BMP280, id 0x56 or 0x57.
    Bmp280Sample(u8),
    /// A BME280 (id 0x60), accepted only when the driver was told to: its pressure and
    /// temperature registers and formulas are the BMP280's, humidity is ignored. One field
    /// differs: the `t_sb` codes 0b110 and 0b111 ([`Standby::Ms2000`](crate::Standby::Ms2000),
    /// [`Standby::Ms4000`](crate::Standby::Ms4000)) mean 10 ms and 20 ms on a BME280.
    Bme280,
}

impl Chip {
    /// Production BMP280 id.
    pub const BMP280_ID: u8 = 0x58;
    /// Engineering-sample BMP280 ids.
    pub const BMP280_SAMPLE_IDS: [u8; 2] = [0x56, 0x57];
    /// BME280 id.
    pub const BME280_ID: u8 = 0x60;

    /// Classifies an `id` register value. A BME280 is an error unless `accept_bme280` is set,
    /// so a board fitted with the wrong part is noticed at bring-up.
    pub const fn from_id(id: u8, accept_bme280: bool) -> Result<Self, DeviceError> {
        match id {
            Self::BMP280_ID => Ok(Chip::Bmp280),
            0x56 | 0x57 => Ok(Chip::Bmp280Sample(id)),
            Self::BME280_ID if accept_bme280 => Ok(Chip::Bme280),
            Self::BME280_ID => Err(DeviceError::Bme280NotAccepted),
            found => Err(DeviceError::InvalidChipId { found }),
        }
    }

    /// The `id` register value of this chip.
    pub const fn id(self) -> u8 {
        match self {
            Chip::Bmp280 => Self::BMP280_ID,
            Chip::Bmp280Sample(id) => id,
            Chip::Bme280 => Self::BME280_ID,
        }
    }
}

/// Device-level failures, independent of the bus; [`Error::Device`] carries them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceError {
    /// The `id` register held neither a BMP280 nor a BME280 id: wrong chip, wrong chip select
    /// or I2C address, or a dead bus (0x00 / 0xFF).
    InvalidChipId {
        /// The value read from 0xD0.
        found: u8,
    },
    /// A BME280 (id 0x60) answered and the driver was not told to accept one.
    Bme280NotAccepted,
    /// A compensated value was asked for before the calibration was read (`init`) or set.
    NotCalibrated,
    /// The calibration makes the pressure formula divide by zero (`dig_P1` = 0): the NVM copy
    /// was not read correctly.
    InvalidCalibration,
    /// The device did not finish in the time the datasheet allows (NVM copy after reset, a
    /// forced measurement, or the first conversion after [`Bmp280::configure`](crate::Bmp280::configure)).
    Timeout,
    /// The data registers still hold their reset value 0x80000 (see
    /// [`RawSample::holds_no_conversion`](crate::RawSample::holds_no_conversion)): no conversion
    /// has ended yet. After [`Bmp280::configure`](crate::Bmp280::configure) the first one takes
    /// up to [`Config::measurement_time_max_us`](crate::Config::measurement_time_max_us) (about
    /// 5.5 ms with the default configuration); in sleep mode none comes.
    /// [`Bmp280::measure_when_ready`](crate::Bmp280::measure_when_ready) waits for it.
    NoConversion,
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceError::InvalidChipId { found } => write!(
                f,
                "BMP280 chip id register 0xD0 read {found:#04x}, expected 0x58 (check wiring, chip select or I2C address)"
            ),
            DeviceError::Bme280NotAccepted => {
                f.write_str("a BME280 (chip id 0x60) answered where a BMP280 was expected")
            }
            DeviceError::NotCalibrated => {
                f.write_str("BMP280 calibration not read yet: call init() first")
            }
            DeviceError::InvalidCalibration => {
                f.write_str("BMP280 calibration invalid: pressure formula would divide by zero")
            }
            DeviceError::Timeout => f.write_str("BMP280 did not finish within the datasheet time"),
            DeviceError::NoConversion => f.write_str(
                "BMP280 data registers hold their reset value: no conversion has finished yet (measure too soon after configure, or sleep mode)",
            ),
        }
    }
}

impl core::error::Error for DeviceError {}

/// Errors of the driver: the bus error `E`, or a [`DeviceError`] nested whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error<E> {
    /// The SPI or I2C transfer failed.
    Comm(E),
    /// The device answered, but not as a working BMP280 does.
    Device(DeviceError),
}

impl<E> From<DeviceError> for Error<E> {
    fn from(e: DeviceError) -> Self {
        Error::Device(e)
    }
}

impl<E: fmt::Debug> fmt::Display for Error<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Comm(e) => write!(f, "BMP280 bus error: {e:?}"),
            Error::Device(e) => fmt::Display::fmt(e, f),
        }
    }
}

impl<E: fmt::Debug> core::error::Error for Error<E> {
    fn source(&self) -> Option<&(dyn core::error::Error + 'static)> {
        match self {
            Error::Comm(_) => None,
            Error::Device(e) => Some(e),
        }
    }
}
