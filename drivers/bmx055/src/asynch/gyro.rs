//! Async gyroscope.

use crate::accel::accel_temperature_celsius;
use crate::gyro::{
    decode_gyro_fifo_frame, register as reg, GyroAddress, GyroBandwidth, GyroConfig,
    GyroFifoConfig, GyroInterruptConfig, GyroInterruptStatus, GyroPowerMode, GyroRange, GyroRaw,
    GyroSelfTest, BIST_POLL_ATTEMPTS, SOFT_RESET_WAIT_MS,
};
use crate::interface::{AsyncRegisterInterface, I2cInterface, SpiInterface};
use crate::types::{FifoData, FifoStatus, Xyz};
use crate::Error;
use embedded_hal_async::delay::DelayNs;

/// Async BMX055 gyroscope driver; see [`Gyroscope`](crate::Gyroscope) for the meaning of
/// each method.
#[derive(Debug)]
pub struct AsyncGyroscope<IFACE> {
    iface: IFACE,
    range: GyroRange,
    fifo_data: FifoData,
}

impl<SPI> AsyncGyroscope<SpiInterface<SPI>> {
    /// Driver over the gyroscope's own SPI device.
    pub fn new_spi(spi: SPI) -> Self {
        Self::new(SpiInterface::new(spi))
    }
}

impl<I2C> AsyncGyroscope<I2cInterface<I2C>> {
    /// Driver over I2C at the strapped address.
    pub fn new_i2c(i2c: I2C, address: GyroAddress) -> Self {
        Self::new(I2cInterface::new(i2c, address as u8))
    }
}

impl<IFACE> AsyncGyroscope<IFACE> {
    /// Driver over any async register interface (reset range ±2000 °/s assumed).
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
    /// The range used to scale samples.
    pub fn range(&self) -> GyroRange {
        self.range
    }
}

impl<IFACE: AsyncRegisterInterface> AsyncGyroscope<IFACE> {
    async fn write(&mut self, r: u8, v: u8) -> Result<(), Error<IFACE::Error>> {
        self.iface.write_register(r, v).await.map_err(Error::Comm)
    }
    async fn read(&mut self, r: u8) -> Result<u8, Error<IFACE::Error>> {
        self.iface.read_register(r).await.map_err(Error::Comm)
    }
    async fn read_into(&mut self, r: u8, buf: &mut [u8]) -> Result<(), Error<IFACE::Error>> {
        self.iface.read_registers(r, buf).await.map_err(Error::Comm)
    }

    /// Chip id (0x0F).
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

    /// Soft reset and wait.
    pub async fn soft_reset(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::BGW_SOFTRESET, reg::SOFT_RESET_CMD).await?;
        delay.delay_ms(SOFT_RESET_WAIT_MS).await;
        self.range = GyroRange::Dps2000;
        self.fifo_data = FifoData::Xyz;
        Ok(())
    }

    /// Soft reset, chip id check (3 attempts), configuration.
    pub async fn init(
        &mut self,
        delay: &mut impl DelayNs,
        config: &GyroConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        self.soft_reset(delay).await?;
        self.check_chip_id(delay, 3).await?;
        self.configure(config).await
    }

    /// Apply range, data rate / filter and power mode.
    pub async fn configure(&mut self, config: &GyroConfig) -> Result<(), Error<IFACE::Error>> {
        for (r, v) in config.register_writes() {
            self.write(r, v).await?;
        }
        self.range = config.range;
        Ok(())
    }

    /// Read X, Y, Z in one burst.
    pub async fn read_raw(&mut self) -> Result<GyroRaw, Error<IFACE::Error>> {
        let mut b = [0u8; 6];
        self.read_into(reg::RATE_X_LSB, &mut b).await?;
        Ok(GyroRaw::from_registers(&b))
    }

    /// One sample in °/s.
    pub async fn read_dps(&mut self) -> Result<Xyz<f32>, Error<IFACE::Error>> {
        let range = self.range;
        Ok(self.read_raw().await?.dps(range))
    }

    /// One sample in rad/s.
    pub async fn read_rad_s(&mut self) -> Result<Xyz<f32>, Error<IFACE::Error>> {
        let range = self.range;
        Ok(self.read_raw().await?.rad_s(range))
    }

    /// Die temperature in °C.
    pub async fn temperature_celsius(&mut self) -> Result<f32, Error<IFACE::Error>> {
        Ok(accel_temperature_celsius(self.read(reg::TEMP).await?))
    }

    /// Route and enable interrupts.
    pub async fn configure_interrupts(
        &mut self,
        config: &GyroInterruptConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        for (r, v) in config.register_writes() {
            self.write(r, v).await?;
        }
        Ok(())
    }

    /// Interrupt flags.
    pub async fn interrupt_status(&mut self) -> Result<GyroInterruptStatus, Error<IFACE::Error>> {
        let mut b = [0u8; 2];
        self.read_into(reg::INT_STATUS_0, &mut b).await?;
        Ok(GyroInterruptStatus::from_registers(b[0], b[1]))
    }

    /// Configure the FIFO (`InvalidInput` above 99 frames).
    pub async fn configure_fifo(
        &mut self,
        config: &GyroFifoConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        let writes = config.register_writes().ok_or(Error::InvalidInput)?;
        for (r, v) in writes {
            self.write(r, v).await?;
        }
        self.fifo_data = config.data;
        Ok(())
    }

    /// FIFO fill level.
    pub async fn fifo_status(&mut self) -> Result<FifoStatus, Error<IFACE::Error>> {
        Ok(FifoStatus::from_register(
            self.read(reg::FIFO_STATUS).await?,
        ))
    }

    /// Read up to `out.len()` waiting frames; returns how many were read.
    pub async fn read_fifo(&mut self, out: &mut [GyroRaw]) -> Result<usize, Error<IFACE::Error>> {
        let want = usize::from(self.fifo_status().await?.frames).min(out.len());
        let data = self.fifo_data;
        let len = data.frame_len();
        let mut buf = [0u8; 48];
        let per_burst = buf.len() / len;
        let mut done = 0;
        while done < want {
            let n = (want - done).min(per_burst);
            let bytes = &mut buf[..n * len];
            self.read_into(reg::FIFO_DATA, bytes).await?;
            for (slot, frame) in out[done..done + n].iter_mut().zip(bytes.chunks_exact(len)) {
                *slot = decode_gyro_fifo_frame(data, frame);
            }
            done += n;
        }
        Ok(done)
    }

    /// Built-in self-test (bounded polling of `bist_rdy`).
    pub async fn self_test(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<GyroSelfTest, Error<IFACE::Error>> {
        let rate_ok = self.read(reg::BIST).await? & reg::RATE_OK != 0;
        self.write(reg::BIST, reg::TRIG_BIST).await?;
        for _ in 0..BIST_POLL_ATTEMPTS {
            delay.delay_ms(1).await;
            let bist = self.read(reg::BIST).await?;
            if bist & reg::BIST_RDY != 0 {
                return Ok(GyroSelfTest {
                    rate_ok,
                    bist_ok: bist & reg::BIST_FAIL == 0,
                });
            }
        }
        Err(Error::Timeout)
    }

    /// Change the range only.
    pub async fn set_range(&mut self, range: GyroRange) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::RANGE, range.bits()).await?;
        self.range = range;
        Ok(())
    }

    /// Change the data rate / filter only.
    pub async fn set_bandwidth(&mut self, bw: GyroBandwidth) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::BW, bw.bits()).await
    }

    /// Change the power mode only.
    pub async fn set_power_mode(&mut self, mode: GyroPowerMode) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::LPM1, mode.bits()).await
    }

    /// Clear latched interrupts, keeping the latch mode given by `latched`.
    pub async fn clear_latched_interrupts(
        &mut self,
        latched: bool,
    ) -> Result<(), Error<IFACE::Error>> {
        let mode = if latched { 0x0F } else { 0x00 };
        self.write(reg::INT_RST_LATCH, reg::RESET_INT | mode).await
    }
}
