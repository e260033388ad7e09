//! [`Bmx055`]: the three dies as one device, for boards that use all of them.

use crate::accel::{AccelConfig, AccelRaw, Accelerometer};
use crate::gyro::{GyroConfig, GyroRaw, Gyroscope};
use crate::interface::{RegisterInterface, SpiInterface};
use crate::mag::{MagConfig, MagOpMode, MagPacketWords, MagTrim, Magnetometer};
use crate::packet::ImuPacketWords;
use crate::Error;
use embedded_hal::delay::DelayNs;

/// Configuration of all three dies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Bmx055Config {
    /// Accelerometer.
    pub accel: AccelConfig,
    /// Gyroscope.
    pub gyro: GyroConfig,
    /// Magnetometer.
    pub mag: MagConfig,
}

impl Bmx055Config {
    /// The DIMA sensor-board configuration (DESIGN section 3).
    pub const DIMA: Self = Self {
        accel: AccelConfig::DIMA,
        gyro: GyroConfig::DIMA,
        mag: MagConfig::DIMA,
    };
}

/// One sample of all three dies, as [`Bmx055::sample`] returns it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImuSample {
    /// Accelerometer registers (words and new-data flags).
    pub accel: AccelRaw,
    /// Gyroscope registers.
    pub gyro: GyroRaw,
    /// Latest complete magnetometer measurement.
    pub mag: MagPacketWords,
    /// `true` if `mag` was measured since the previous `sample` call; `false` if the
    /// measurement is still running and `mag` repeats the previous one.
    pub mag_fresh: bool,
}

impl ImuSample {
    /// The packet words of this sample.
    pub const fn packet_words(&self) -> ImuPacketWords {
        ImuPacketWords::from_raw(&self.accel, &self.gyro, self.mag)
    }
}

/// The BMX055 as one device: owns the three drivers.
///
/// The three error types must agree, which they do when the dies share one bus through
/// `embedded-hal-bus` (the usual wiring). Use the drivers directly otherwise.
#[derive(Debug)]
pub struct Bmx055<AI, GI, MI> {
    /// Accelerometer driver.
    pub accel: Accelerometer<AI>,
    /// Gyroscope driver.
    pub gyro: Gyroscope<GI>,
    /// Magnetometer driver.
    pub mag: Magnetometer<MI>,
    last_mag: MagPacketWords,
}

impl<ASPI, GSPI, MSPI> Bmx055<SpiInterface<ASPI>, SpiInterface<GSPI>, SpiInterface<MSPI>> {
    /// The three dies over their own SPI devices (CSB1 accel, CSB2 gyro, CSB3 mag).
    pub fn new_spi(accel: ASPI, gyro: GSPI, mag: MSPI) -> Self {
        Self::new(
            Accelerometer::new_spi(accel),
            Gyroscope::new_spi(gyro),
            Magnetometer::new_spi(mag),
        )
    }
}

impl<AI, GI, MI> Bmx055<AI, GI, MI> {
    /// Combine three drivers.
    pub fn new(accel: Accelerometer<AI>, gyro: Gyroscope<GI>, mag: Magnetometer<MI>) -> Self {
        Self {
            accel,
            gyro,
            mag,
            last_mag: MagPacketWords::default(),
        }
    }

    /// Give the three drivers back.
    pub fn release(self) -> (Accelerometer<AI>, Gyroscope<GI>, Magnetometer<MI>) {
        (self.accel, self.gyro, self.mag)
    }
}

impl<E, AI, GI, MI> Bmx055<AI, GI, MI>
where
    AI: RegisterInterface<Error = E>,
    GI: RegisterInterface<Error = E>,
    MI: RegisterInterface<Error = E>,
{
    /// Initialise the three dies (accel, gyro, then magnetometer; each soft-reset, chip id
    /// checked with bounded retries, configured). Returns the magnetometer trim, which the
    /// host needs to compensate packet data.
    pub fn init(
        &mut self,
        delay: &mut impl DelayNs,
        config: &Bmx055Config,
    ) -> Result<MagTrim, Error<E>> {
        self.accel.init(delay, &config.accel)?;
        self.gyro.init(delay, &config.gyro)?;
        self.mag.init(delay, &config.mag)
    }

    /// Read all three dies without waiting: accel and gyro registers, and the magnetometer
    /// registers. If the magnetometer has a new measurement (data ready) it is returned and,
    /// in forced mode, the next one is started; otherwise the previous one is repeated with
    /// `mag_fresh = false`. Call it from a periodic task: no sleeps, four to five transfers.
    pub fn sample(&mut self) -> Result<ImuSample, Error<E>> {
        let accel = self.accel.read_raw()?;
        let gyro = self.gyro.read_raw()?;
        let mag = self.mag.read_raw()?;
        let mag_fresh = mag.data_ready;
        if mag_fresh {
            self.last_mag = mag.packet_words();
            if self.mag.config().forced {
                self.mag.set_op_mode(MagOpMode::Forced)?;
            }
        }
        Ok(ImuSample {
            accel,
            gyro,
            mag: self.last_mag,
            mag_fresh,
        })
    }

    /// Run the three self-tests (accel deflection, gyro BIST, magnetometer normal
    /// self-test), then re-apply `config` (the accelerometer test ends with a soft reset and
    /// the magnetometer test leaves sleep mode). `Error::SelfTestFailed` if any die failed;
    /// the dies are reconfigured either way.
    pub fn self_test(
        &mut self,
        delay: &mut impl DelayNs,
        config: &Bmx055Config,
    ) -> Result<(), Error<E>> {
        let accel_ok = self.accel.self_test(delay)?.passed();
        self.accel.configure(&config.accel)?;
        let gyro_ok = self.gyro.self_test(delay)?.passed();
        let mag = self.mag.self_test(delay)?;
        self.mag.configure(&config.mag)?;
        if accel_ok && gyro_ok && mag.x && mag.y && mag.z {
            Ok(())
        } else {
            Err(Error::SelfTestFailed)
        }
    }
}
