//! Async magnetometer.

use crate::interface::{AsyncRegisterInterface, I2cInterface, SpiInterface};
use crate::mag::{
    compensate, compensate_f32, measurement_time_us, op_mode_bits, register as reg, MagAddress,
    MagConfig, MagOpMode, MagPacketWords, MagRaw, MagSelfTest, MagStatus, MagTrim,
    FORCED_POLL_ATTEMPTS, FORCED_POLL_INTERVAL_US, POWER_ON_WAIT_US, SELF_TEST_POLL_ATTEMPTS,
    SOFT_RESET_WAIT_US, TRIM_BURST_1, TRIM_BURST_2, TRIM_BURST_3,
};
use crate::types::Xyz;
use crate::Error;
use embedded_hal_async::delay::DelayNs;

/// Async BMX055 magnetometer driver; see [`Magnetometer`](crate::Magnetometer) for the
/// meaning of each method.
#[derive(Debug)]
pub struct AsyncMagnetometer<IFACE> {
    iface: IFACE,
    trim: MagTrim,
    config: MagConfig,
}

impl<SPI> AsyncMagnetometer<SpiInterface<SPI>> {
    /// Driver over the magnetometer's own SPI device.
    pub fn new_spi(spi: SPI) -> Self {
        Self::new(SpiInterface::new(spi))
    }
}

impl<I2C> AsyncMagnetometer<I2cInterface<I2C>> {
    /// Driver over I2C at the strapped address.
    pub fn new_i2c(i2c: I2C, address: MagAddress) -> Self {
        Self::new(I2cInterface::new(i2c, address as u8))
    }
}

impl<IFACE> AsyncMagnetometer<IFACE> {
    /// Driver over any async register interface (trim all zero until read).
    pub fn new(iface: IFACE) -> Self {
        Self {
            iface,
            trim: MagTrim::default(),
            config: MagConfig::DIMA,
        }
    }
    /// Give the interface back.
    pub fn release(self) -> IFACE {
        self.iface
    }
    /// The trim in use.
    pub fn trim(&self) -> &MagTrim {
        &self.trim
    }
    /// Use trim obtained elsewhere.
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

impl<IFACE: AsyncRegisterInterface> AsyncMagnetometer<IFACE> {
    async fn write(&mut self, r: u8, v: u8) -> Result<(), Error<IFACE::Error>> {
        self.iface.write_register(r, v).await.map_err(Error::Comm)
    }
    async fn read(&mut self, r: u8) -> Result<u8, Error<IFACE::Error>> {
        self.iface.read_register(r).await.map_err(Error::Comm)
    }
    async fn read_into(&mut self, r: u8, buf: &mut [u8]) -> Result<(), Error<IFACE::Error>> {
        self.iface.read_registers(r, buf).await.map_err(Error::Comm)
    }

    /// Leave suspend and wait for the die to answer.
    pub async fn power_on(&mut self, delay: &mut impl DelayNs) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::POWER_CONTROL, reg::POWER_ON).await?;
        delay.delay_us(POWER_ON_WAIT_US).await;
        Ok(())
    }

    /// Back to suspend.
    pub async fn suspend(&mut self) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::POWER_CONTROL, 0x00).await
    }

    /// Soft reset keeping power, then wait.
    pub async fn soft_reset(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::POWER_CONTROL, reg::SOFT_RESET | reg::POWER_ON)
            .await?;
        delay.delay_us(SOFT_RESET_WAIT_US).await;
        Ok(())
    }

    /// Chip id (0x32 once powered on).
    pub async fn chip_id(&mut self) -> Result<u8, Error<IFACE::Error>> {
        self.read(reg::CHIP_ID).await
    }

    /// Chip id check with up to `attempts` reads 1 ms apart.
    pub async fn check_chip_id(
        &mut self,
        delay: &mut impl DelayNs,
        attempts: u8,
    ) -> Result<(), Error<IFACE::Error>> {
        let mut found = 0;
        for i in 0..attempts.max(1) {
            if i > 0 {
                delay.delay_ms(1).await;
            }
            found = self.chip_id().await?;
            if found == reg::CHIP_ID_VALUE {
                return Ok(());
            }
        }
        Err(Error::InvalidChipId { found })
    }

    /// Read the trim in three bursts and keep it.
    pub async fn read_trim(&mut self) -> Result<MagTrim, Error<IFACE::Error>> {
        let mut b1 = [0u8; 2];
        let mut b2 = [0u8; 4];
        let mut b3 = [0u8; 10];
        self.read_into(TRIM_BURST_1.0, &mut b1).await?;
        self.read_into(TRIM_BURST_2.0, &mut b2).await?;
        self.read_into(TRIM_BURST_3.0, &mut b3).await?;
        self.trim = MagTrim::from_bursts(&b1, &b2, &b3);
        Ok(self.trim)
    }

    /// Power on, soft reset, chip id check (3 attempts), trim, configuration.
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

    /// Write repetitions and operation mode.
    pub async fn configure(&mut self, config: &MagConfig) -> Result<(), Error<IFACE::Error>> {
        for (r, v) in config.register_writes() {
            self.write(r, v).await?;
        }
        self.config = *config;
        Ok(())
    }

    /// Set the operation mode, keeping the data rate.
    pub async fn set_op_mode(&mut self, mode: MagOpMode) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::OP_MODE, op_mode_bits(mode, self.config.data_rate))
            .await
    }

    /// Read the eight data registers.
    pub async fn read_raw(&mut self) -> Result<MagRaw, Error<IFACE::Error>> {
        let mut b = [0u8; 8];
        self.read_into(reg::DATA_X_LSB, &mut b).await?;
        Ok(MagRaw::from_registers(&b))
    }

    /// Read the data registers as DIMA packet words.
    pub async fn read_packet_words(&mut self) -> Result<MagPacketWords, Error<IFACE::Error>> {
        let mut b = [0u8; 8];
        self.read_into(reg::DATA_X_LSB, &mut b).await?;
        Ok(MagPacketWords::from_registers(&b))
    }

    /// Start a forced measurement and wait (bounded) for data ready.
    pub async fn read_forced(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<MagRaw, Error<IFACE::Error>> {
        self.set_op_mode(MagOpMode::Forced).await?;
        self.wait_data(delay).await
    }

    /// Wait (bounded) for a measurement already started.
    pub async fn wait_data(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<MagRaw, Error<IFACE::Error>> {
        delay.delay_us(self.measurement_time_us()).await;
        for attempt in 0..FORCED_POLL_ATTEMPTS {
            if attempt > 0 {
                delay.delay_us(FORCED_POLL_INTERVAL_US).await;
            }
            let raw = self.read_raw().await?;
            if raw.data_ready {
                return Ok(raw);
            }
        }
        Err(Error::Timeout)
    }

    /// Forced measurement in µT, integer path.
    pub async fn read_forced_ut(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<Xyz<i16>, Error<IFACE::Error>> {
        let raw = self.read_forced(delay).await?;
        Ok(compensate(&raw, &self.trim))
    }

    /// Forced measurement in µT, float path.
    pub async fn read_forced_ut_f32(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<Xyz<f32>, Error<IFACE::Error>> {
        let raw = self.read_forced(delay).await?;
        Ok(compensate_f32(&raw, &self.trim))
    }

    /// Overflow and overrun flags.
    pub async fn status(&mut self) -> Result<MagStatus, Error<IFACE::Error>> {
        let s = self.read(reg::INT_STATUS).await?;
        Ok(MagStatus {
            overflow: s & reg::STATUS_OVERFLOW != 0,
            overrun: s & reg::STATUS_OVERRUN != 0,
        })
    }

    /// Drive the DRDY pin on new data; `false` for `enable` restores the reset state.
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
        self.write(reg::INT_CONTROL, v).await
    }

    /// Normal self-test (bounded polling); leaves the die in sleep mode.
    pub async fn self_test(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<MagSelfTest, Error<IFACE::Error>> {
        let sleep = op_mode_bits(MagOpMode::Sleep, self.config.data_rate);
        self.write(reg::OP_MODE, sleep).await?;
        self.write(reg::OP_MODE, sleep | 0x01).await?;
        for _ in 0..SELF_TEST_POLL_ATTEMPTS {
            delay.delay_ms(1).await;
            if self.read(reg::OP_MODE).await? & 0x01 == 0 {
                let mut b = [0u8; 6];
                self.read_into(reg::DATA_X_LSB, &mut b).await?;
                return Ok(Xyz::new(b[0] & 1 != 0, b[2] & 1 != 0, b[4] & 1 != 0));
            }
        }
        Err(Error::Timeout)
    }
}
