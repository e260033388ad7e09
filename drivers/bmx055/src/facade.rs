//! [`Bmx055`]: the three dies as one device, for boards that use all of them.

#[cfg(feature = "async")]
use crate::accel::AsyncAccelerometer;
use crate::accel::{AccelConfig, AccelRaw, Accelerometer};
#[cfg(feature = "async")]
use crate::gyro::AsyncGyroscope;
use crate::gyro::{GyroConfig, GyroRaw, Gyroscope};
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::{RegisterInterface, SpiInterface};
#[cfg(feature = "async")]
use crate::mag::AsyncMagnetometer;
use crate::mag::{MagConfig, MagOpMode, MagPacketWords, MagTrim, Magnetometer};
use crate::Error;
use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

/// Configuration of all three dies. [`Default`] is each die's default: accelerometer ±2 g,
/// 1000 Hz bandwidth, normal mode; gyroscope ±2000 °/s, 2000 Hz with the 523 Hz filter, normal
/// mode; magnetometer low-power preset in normal mode at 10 Hz.
///
/// A worked example, fast inertial data for a small vehicle's control loop with the
/// magnetometer measuring on request:
/// ```
/// use bosch_bmx055::accel::{AccelBandwidth, AccelConfig, AccelPowerMode, AccelRange};
/// use bosch_bmx055::gyro::{GyroBandwidth, GyroConfig, GyroPowerMode, GyroRange};
/// use bosch_bmx055::mag::{MagConfig, MagPreset};
/// use bosch_bmx055::Bmx055Config;
///
/// let config = Bmx055Config {
///     accel: AccelConfig {
///         range: AccelRange::G2,
///         bandwidth: AccelBandwidth::Hz1000,
///         power: AccelPowerMode::Normal,
///     },
///     gyro: GyroConfig {
///         range: GyroRange::Dps2000,
///         bandwidth: GyroBandwidth::Odr2000Bw230,
///         power: GyroPowerMode::Normal,
///     },
///     mag: MagConfig::forced(MagPreset::LowPower),
/// };
/// assert_eq!(config.accel.register_writes(), [(0x0F, 0x03), (0x10, 0x0F), (0x11, 0x00)]);
/// ```
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

crate::blocking_and_async! {
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
}

crate::blocking_and_async! {
    impl<ASPI, GSPI, MSPI> Bmx055<SpiInterface<ASPI>, SpiInterface<GSPI>, SpiInterface<MSPI>> {
        /// The three dies over their own SPI devices (CSB1 accel, CSB2 gyro, CSB3 mag).
        pub fn new_spi(accel: ASPI, gyro: GSPI, mag: MSPI) -> Self {
            Self::new(
                Accelerometer::new_spi(accel),
                Gyroscope::new_spi(gyro),
                Magnetometer::new_spi(mag),
            )
        }

        /// Gives the three SPI devices back (what [`new_spi`](Self::new_spi) was given).
        pub fn release(self) -> (ASPI, GSPI, MSPI) {
            (self.accel.release(), self.gyro.release(), self.mag.release())
        }
    }
}

crate::blocking_and_async! {
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

        /// Gives the three drivers back (what [`new`](Self::new) was given; a facade made with
        /// `new_spi` gives the three SPI devices back with `release`).
        pub fn into_drivers(self) -> (Accelerometer<AI>, Gyroscope<GI>, Magnetometer<MI>) {
            (self.accel, self.gyro, self.mag)
        }
    }
}

crate::blocking_and_async! {
    impl<E, AI, GI, MI> Bmx055<AI, GI, MI>
    where
        AI: RegisterInterface<Error = E>,
        GI: RegisterInterface<Error = E>,
        MI: RegisterInterface<Error = E>,
    {
        /// Initialise the three dies (accel, gyro, then magnetometer; each soft-reset, chip id
        /// checked with bounded retries, configured). Returns the magnetometer trim, which the
        /// host needs to compensate packet data.
        pub async fn init(
            &mut self,
            delay: &mut impl DelayNs,
            config: &Bmx055Config,
        ) -> Result<MagTrim, Error<E>> {
            self.accel.init(delay, &config.accel).await?;
            self.gyro.init(delay, &config.gyro).await?;
            self.mag.init(delay, &config.mag).await
        }

        /// Read all three dies without waiting: accel and gyro registers, and the magnetometer
        /// registers. If the magnetometer has a new measurement (data ready) it is returned and,
        /// in forced mode, the next one is started; otherwise the previous one is repeated with
        /// `mag_fresh = false`. Call it from a periodic task: no sleeps, four to five transfers.
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

        /// Run the three self-tests (accel deflection, gyro BIST, magnetometer normal
        /// self-test), then re-apply `config` (the accelerometer test ends with a soft reset and
        /// the magnetometer test leaves sleep mode). [`DeviceError::SelfTestFailed`](crate::DeviceError::SelfTestFailed) if any die failed;
        /// the dies are reconfigured either way.
        pub async fn self_test(
            &mut self,
            delay: &mut impl DelayNs,
            config: &Bmx055Config,
        ) -> Result<(), Error<E>> {
            let accel_ok = self.accel.self_test(delay).await?.passed();
            self.accel.configure(&config.accel).await?;
            let gyro_ok = self.gyro.self_test(delay).await?.passed();
            let mag = self.mag.self_test(delay).await?;
            self.mag.configure(&config.mag).await?;
            if accel_ok && gyro_ok && mag.x && mag.y && mag.z {
                Ok(())
            } else {
                Err(Error::Device(crate::DeviceError::SelfTestFailed))
            }
        }
    }
}
