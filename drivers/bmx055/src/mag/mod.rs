//! Magnetometer die (BMM150-class, chip id 0x32) with Bosch's trim compensation.
//!
//! The die powers up in suspend, where only the power-control register answers: call
//! [`Magnetometer::power_on`] (or [`Magnetometer::init`]) before anything else.

pub mod compensation;
#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
pub mod inverse;
pub(crate) mod register;
mod trim;
mod types;

pub use compensation::{
    compensate, compensate_f32, compensate_x, compensate_x_f32, compensate_y, compensate_y_f32,
    compensate_z, compensate_z_f32, OVERFLOW_OUTPUT, OVERFLOW_OUTPUT_F32,
};
#[cfg(feature = "sim")]
pub use inverse::{raw_x_for_ut, raw_y_for_ut, raw_z_for_ut};
pub use trim::{MagTrim, TRIM_BURST_1, TRIM_BURST_2, TRIM_BURST_3};
pub use types::*;

#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::Registers;
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::{I2cInterface, RegisterInterface, SpiInterface};
use crate::types::Xyz;
use crate::Error;
use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;
use register as reg;

/// Wait after leaving suspend before the chip id is readable, in µs (Bosch BMM150 SensorAPI
/// `bmm150_init`: `BMM150_START_UP_TIME`, "start-up time delay of 3ms").
pub const POWER_ON_WAIT_US: u32 = 3_000;
/// Wait after a soft reset, in µs (Bosch BMM150 SensorAPI `bmm150_soft_reset`:
/// `BMM150_SOFT_RESET_DELAY` = 1 ms).
pub const SOFT_RESET_WAIT_US: u32 = 1_000;
/// Polling interval for data ready after the expected measurement time.
pub const FORCED_POLL_INTERVAL_US: u32 = 200;
/// Polls of data ready after the expected measurement time before `Timeout` (10 ms grace).
pub const FORCED_POLL_ATTEMPTS: u32 = 50;
/// Polls of the normal self-test bit (1 ms apart) before `Timeout`.
pub const SELF_TEST_POLL_ATTEMPTS: u32 = 20;

/// I2C address of the magnetometer, set by the CSB3 and SDO3 straps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MagAddress {
    /// CSB3 low, SDO3 low: 0x10.
    #[default]
    Csb3LowSdo3Low = 0x10,
    /// CSB3 low, SDO3 high: 0x11.
    Csb3LowSdo3High = 0x11,
    /// CSB3 high, SDO3 low: 0x12.
    Csb3HighSdo3Low = 0x12,
    /// CSB3 high, SDO3 high: 0x13.
    Csb3HighSdo3High = 0x13,
}

/// Interrupt status flags of the magnetometer (`INT_STATUS`, 0x4A).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MagStatus {
    /// A measurement overflowed.
    pub overflow: bool,
    /// A sample was overwritten before it was read.
    pub overrun: bool,
}

/// Per-axis result of the normal self-test (`true` = pass).
pub type MagSelfTest = Xyz<bool>;

crate::blocking_and_async! {
    /// BMX055 magnetometer driver. Holds the trim read at [`init`](Self::init) so it can return
    /// compensated µT.
    #[derive(Debug)]
    pub struct Magnetometer<IFACE> {
        pub(crate) iface: IFACE,
        pub(crate) trim: MagTrim,
        pub(crate) config: MagConfig,
    }
}

crate::blocking_and_async! {
    impl<SPI> Magnetometer<SpiInterface<SPI>> {
        /// Driver over the magnetometer's own SPI device (chip select CSB3).
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
    impl<I2C> Magnetometer<I2cInterface<I2C>> {
        /// Driver over I2C at the strapped address.
        pub fn new_i2c(i2c: I2C, address: MagAddress) -> Self {
            Self::new(I2cInterface::new(i2c, address as u8))
        }
        /// Gives the I2C bus back (what [`new_i2c`](Self::new_i2c) was given).
        pub fn release(self) -> I2C {
            self.iface.release()
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE> Magnetometer<IFACE> {
        /// Driver over any register interface. The trim is all zero (compensation reports
        /// overflow) until [`read_trim`](Self::read_trim) or [`set_trim`](Self::set_trim).
        pub fn new(iface: IFACE) -> Self {
            Self {
                iface,
                trim: MagTrim::default(),
                config: MagConfig::forced(MagPreset::LowPower),
            }
        }
        /// Gives the interface back (what [`new`](Self::new) was given; drivers made with
        /// `new_spi` or `new_i2c` give the bus back with `release`).
        pub fn into_interface(self) -> IFACE {
            self.iface
        }
        /// The trim in use.
        pub fn trim(&self) -> &MagTrim {
            &self.trim
        }
        /// Use trim obtained elsewhere (e.g. a simulator or a stored copy).
        pub fn set_trim(&mut self, trim: MagTrim) {
            self.trim = trim;
        }
        /// The configuration last applied.
        pub fn config(&self) -> &MagConfig {
            &self.config
        }
        /// Longest time one measurement of the current preset takes, in µs.
        pub fn measurement_time_us(&self) -> u32 {
            measurement_time_us(self.config.preset.rep_xy(), self.config.preset.rep_z())
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Magnetometer<IFACE> {
        /// Leave suspend (set the power-control bit) and wait [`POWER_ON_WAIT_US`]; the die is
        /// then in sleep mode and its registers answer.
        pub async fn power_on(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<IFACE::Error>> {
            self.iface.write(reg::POWER_CONTROL, reg::POWER_ON).await?;
            delay.delay_us(POWER_ON_WAIT_US).await;
            Ok(())
        }

        /// Back to suspend (lowest current; configuration lost).
        pub async fn suspend(&mut self) -> Result<(), Error<IFACE::Error>> {
            self.iface.write(reg::POWER_CONTROL, 0x00).await
        }

        /// Soft reset, keeping the die powered (writes 0x83), then wait [`SOFT_RESET_WAIT_US`].
        /// The die comes back in sleep mode with default registers.
        pub async fn soft_reset(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface
                .write(reg::POWER_CONTROL, reg::SOFT_RESET | reg::POWER_ON)
                .await?;
            delay.delay_us(SOFT_RESET_WAIT_US).await;
            Ok(())
        }

        /// Read the chip-id register (0x32 once powered on; 0x00 in suspend).
        pub async fn chip_id(&mut self) -> Result<u8, Error<IFACE::Error>> {
            self.iface.read(reg::CHIP_ID).await
        }

        /// Read the chip id up to `attempts` times (1 ms apart) until it is 0x32.
        pub async fn check_chip_id(
            &mut self,
            delay: &mut impl DelayNs,
            attempts: u8,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface
                .check_chip_id(delay, reg::CHIP_ID, reg::CHIP_ID_VALUE, attempts)
                .await
        }

        /// Read the trim registers in three bursts and keep them for compensation.
        pub async fn read_trim(&mut self) -> Result<MagTrim, Error<IFACE::Error>> {
            let mut b1 = [0u8; 2];
            let mut b2 = [0u8; 4];
            let mut b3 = [0u8; 10];
            self.iface.read_into(TRIM_BURST_1.0, &mut b1).await?;
            self.iface.read_into(TRIM_BURST_2.0, &mut b2).await?;
            self.iface.read_into(TRIM_BURST_3.0, &mut b3).await?;
            self.trim = MagTrim::from_bursts(&b1, &b2, &b3);
            Ok(self.trim)
        }

        /// Power on, soft reset, check the chip id (up to 3 attempts), read trim, apply `config`.
        ///
        /// With `MagConfig::forced(MagPreset::LowPower)` the bus sees exactly: write 0x4B = 0x01, write 0x4B = 0x83,
        /// read 0x40, read 0x5D (2), read 0x62 (4), read 0x68 (10), write 0x51 = 0x01,
        /// write 0x52 = 0x02, write 0x4C = 0x02 (forced: the first measurement starts).
        pub async fn init(
            &mut self,
            delay: &mut impl DelayNs,
            config: &MagConfig,
        ) -> Result<MagTrim, Error<IFACE::Error>> {
            self.power_on(delay).await?;
            self.soft_reset(delay).await?;
            self.check_chip_id(delay, 3).await?;
            let trim = self.read_trim().await?;
            self.configure(config).await?;
            Ok(trim)
        }

        /// Write repetitions and operation mode (three register writes).
        pub async fn configure(&mut self, config: &MagConfig) -> Result<(), Error<IFACE::Error>> {
            self.iface.write_all(config.register_writes()).await?;
            self.config = *config;
            Ok(())
        }

        /// Set the operation mode, keeping the configured data rate.
        pub async fn set_op_mode(&mut self, mode: MagOpMode) -> Result<(), Error<IFACE::Error>> {
            self.iface
                .write(reg::OP_MODE, op_mode_bits(mode, self.config.data_rate))
                .await
        }

        /// Start one forced measurement; poll with [`poll_data`](Self::poll_data).
        pub async fn start_forced(&mut self) -> Result<(), Error<IFACE::Error>> {
            self.set_op_mode(MagOpMode::Forced).await
        }

        /// Read the data registers; `WouldBlock` until the data-ready bit (0x48 bit 0) is set,
        /// so a forced read never returns the previous sample. Reading clears the bit.
        pub async fn poll_data(&mut self) -> nb::Result<MagRaw, Error<IFACE::Error>> {
            let raw = self.read_raw().await?;
            if raw.data_ready {
                Ok(raw)
            } else {
                Err(nb::Error::WouldBlock)
            }
        }

        /// Start a forced measurement, wait the preset's measurement time, then poll data ready
        /// every [`FORCED_POLL_INTERVAL_US`] at most [`FORCED_POLL_ATTEMPTS`] times.
        pub async fn read_forced(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<MagRaw, Error<IFACE::Error>> {
            self.start_forced().await?;
            self.wait_data(delay).await
        }

        /// Wait (bounded) for a measurement already started (forced mode configured by
        /// [`init`](Self::init), or normal mode).
        pub async fn wait_data(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<MagRaw, Error<IFACE::Error>> {
            delay.delay_us(self.measurement_time_us()).await;
            for attempt in 0..FORCED_POLL_ATTEMPTS {
                if attempt > 0 {
                    delay.delay_us(FORCED_POLL_INTERVAL_US).await;
                }
                match self.poll_data().await {
                    Ok(raw) => return Ok(raw),
                    Err(nb::Error::WouldBlock) => {}
                    Err(nb::Error::Other(e)) => return Err(e),
                }
            }
            Err(Error::Device(crate::DeviceError::Timeout))
        }

        /// Read the eight data registers as they are (data-ready flag included).
        pub async fn read_raw(&mut self) -> Result<MagRaw, Error<IFACE::Error>> {
            let mut b = [0u8; 8];
            self.iface.read_into(reg::DATA_X_LSB, &mut b).await?;
            Ok(MagRaw::from_registers(&b))
        }

        /// Read the data registers as DIMA packet words (status bits masked).
        pub async fn read_packet_words(&mut self) -> Result<MagPacketWords, Error<IFACE::Error>> {
            let mut b = [0u8; 8];
            self.iface.read_into(reg::DATA_X_LSB, &mut b).await?;
            Ok(MagPacketWords::from_registers(&b))
        }

        /// Forced measurement compensated to µT (integer path; -32768 marks overflow).
        pub async fn read_forced_ut(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<Xyz<i16>, Error<IFACE::Error>> {
            let raw = self.read_forced(delay).await?;
            Ok(compensate(&raw, &self.trim))
        }

        /// Forced measurement compensated to µT (float path; 0.0 marks overflow).
        pub async fn read_forced_ut_f32(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<Xyz<f32>, Error<IFACE::Error>> {
            let raw = self.read_forced(delay).await?;
            Ok(compensate_f32(&raw, &self.trim))
        }

        /// Overflow and overrun flags.
        pub async fn status(&mut self) -> Result<MagStatus, Error<IFACE::Error>> {
            let s = self.iface.read(reg::INT_STATUS).await?;
            Ok(MagStatus {
                overflow: s & reg::STATUS_OVERFLOW != 0,
                overrun: s & reg::STATUS_OVERRUN != 0,
            })
        }

        /// Drive the DRDY pin on new data (`active_high` selects its polarity); `false` for
        /// `enable` restores the reset state of `INT_CONTROL`.
        pub async fn set_data_ready_pin(
            &mut self,
            enable: bool,
            active_high: bool,
        ) -> Result<(), Error<IFACE::Error>> {
            let mut v = reg::INT_CONTROL_RESET & !reg::DR_POLARITY;
            if active_high {
                v |= reg::DR_POLARITY;
            }
            if enable {
                v |= reg::DR_PIN_EN;
            }
            self.iface.write(reg::INT_CONTROL, v).await
        }

        /// Normal self-test: in sleep mode set the self-test bit, poll until the die clears it
        /// (bounded), read the per-axis result bits (bit 0 of the X, Y and Z LSB registers).
        /// Leaves the die in sleep mode.
        pub async fn self_test(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<MagSelfTest, Error<IFACE::Error>> {
            let sleep = op_mode_bits(MagOpMode::Sleep, self.config.data_rate);
            self.iface.write(reg::OP_MODE, sleep).await?;
            self.iface.write(reg::OP_MODE, sleep | 0x01).await?;
            for _ in 0..SELF_TEST_POLL_ATTEMPTS {
                delay.delay_ms(1).await;
                if self.iface.read(reg::OP_MODE).await? & 0x01 == 0 {
                    let mut b = [0u8; 6];
                    self.iface.read_into(reg::DATA_X_LSB, &mut b).await?;
                    return Ok(Xyz::new(b[0] & 1 != 0, b[2] & 1 != 0, b[4] & 1 != 0));
                }
            }
            Err(Error::Device(crate::DeviceError::Timeout))
        }
    }
}
