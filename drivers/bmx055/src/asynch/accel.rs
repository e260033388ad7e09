//! Async accelerometer.

use crate::accel::{
    accel_temperature_celsius, decode_accel_fifo_frame, offset_setting, register as reg,
    AccelAddress, AccelBandwidth, AccelConfig, AccelFifoConfig, AccelInterruptConfig,
    AccelInterruptStatus, AccelPowerMode, AccelRange, AccelRaw, AccelSelfTest, OffsetTarget,
    FOC_POLL_ATTEMPTS, SELF_TEST_SETTLE_MS, SOFT_RESET_WAIT_US,
};
use crate::interface::{AsyncRegisterInterface, I2cInterface, SpiInterface};
use crate::types::{FifoData, FifoStatus, Xyz};
use crate::Error;
use embedded_hal_async::delay::DelayNs;

/// Async BMX055 accelerometer driver; see [`Accelerometer`](crate::Accelerometer) for the
/// meaning of each method.
#[derive(Debug)]
pub struct AsyncAccelerometer<IFACE> {
    iface: IFACE,
    range: AccelRange,
    fifo_data: FifoData,
}

impl<SPI> AsyncAccelerometer<SpiInterface<SPI>> {
    /// Driver over the accelerometer's own SPI device.
    pub fn new_spi(spi: SPI) -> Self {
        Self::new(SpiInterface::new(spi))
    }
}

impl<I2C> AsyncAccelerometer<I2cInterface<I2C>> {
    /// Driver over I2C at the strapped address.
    pub fn new_i2c(i2c: I2C, address: AccelAddress) -> Self {
        Self::new(I2cInterface::new(i2c, address as u8))
    }
}

impl<IFACE> AsyncAccelerometer<IFACE> {
    /// Driver over any async register interface (reset range ±2 g assumed).
    pub fn new(iface: IFACE) -> Self {
        Self {
            iface,
            range: AccelRange::G2,
            fifo_data: FifoData::Xyz,
        }
    }
    /// Give the interface back.
    pub fn release(self) -> IFACE {
        self.iface
    }
    /// The range used to scale samples.
    pub fn range(&self) -> AccelRange {
        self.range
    }
}

impl<IFACE: AsyncRegisterInterface> AsyncAccelerometer<IFACE> {
    async fn write(&mut self, r: u8, v: u8) -> Result<(), Error<IFACE::Error>> {
        self.iface.write_register(r, v).await.map_err(Error::Comm)
    }
    async fn read(&mut self, r: u8) -> Result<u8, Error<IFACE::Error>> {
        self.iface.read_register(r).await.map_err(Error::Comm)
    }
    async fn read_into(&mut self, r: u8, buf: &mut [u8]) -> Result<(), Error<IFACE::Error>> {
        self.iface.read_registers(r, buf).await.map_err(Error::Comm)
    }

    /// Chip id (0xFA).
    pub async fn chip_id(&mut self) -> Result<u8, Error<IFACE::Error>> {
        self.read(reg::BGW_CHIPID).await
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
        delay.delay_us(SOFT_RESET_WAIT_US).await;
        self.range = AccelRange::G2;
        self.fifo_data = FifoData::Xyz;
        Ok(())
    }

    /// Soft reset, chip id check (3 attempts), configuration.
    pub async fn init(
        &mut self,
        delay: &mut impl DelayNs,
        config: &AccelConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        self.soft_reset(delay).await?;
        self.check_chip_id(delay, 3).await?;
        self.configure(config).await
    }

    /// Apply range, bandwidth and power mode.
    pub async fn configure(&mut self, config: &AccelConfig) -> Result<(), Error<IFACE::Error>> {
        for (r, v) in config.register_writes() {
            self.write(r, v).await?;
        }
        self.range = config.range;
        Ok(())
    }

    /// Change the range only.
    pub async fn set_range(&mut self, range: AccelRange) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::PMU_RANGE, range.bits()).await?;
        self.range = range;
        Ok(())
    }

    /// Read X, Y, Z in one burst.
    pub async fn read_raw(&mut self) -> Result<AccelRaw, Error<IFACE::Error>> {
        let mut b = [0u8; 6];
        self.read_into(reg::ACCD_X_LSB, &mut b).await?;
        Ok(AccelRaw::from_registers(&b))
    }

    /// One sample in mg.
    pub async fn read_mg(&mut self) -> Result<Xyz<f32>, Error<IFACE::Error>> {
        let range = self.range;
        Ok(self.read_raw().await?.mg(range))
    }

    /// One sample in m/s².
    pub async fn read_m_s2(&mut self) -> Result<Xyz<f32>, Error<IFACE::Error>> {
        let range = self.range;
        Ok(self.read_raw().await?.m_s2(range))
    }

    /// Die temperature in °C.
    pub async fn temperature_celsius(&mut self) -> Result<f32, Error<IFACE::Error>> {
        Ok(accel_temperature_celsius(self.read(reg::ACCD_TEMP).await?))
    }

    /// Route and enable interrupts.
    pub async fn configure_interrupts(
        &mut self,
        config: &AccelInterruptConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        for (r, v) in config.register_writes() {
            self.write(r, v).await?;
        }
        Ok(())
    }

    /// Interrupt flags.
    pub async fn interrupt_status(&mut self) -> Result<AccelInterruptStatus, Error<IFACE::Error>> {
        let mut b = [0u8; 2];
        self.read_into(reg::INT_STATUS_0, &mut b).await?;
        Ok(AccelInterruptStatus::from_registers(b[0], b[1]))
    }

    /// Configure the FIFO (`InvalidInput` above 31 frames).
    pub async fn configure_fifo(
        &mut self,
        config: &AccelFifoConfig,
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
    pub async fn read_fifo(&mut self, out: &mut [AccelRaw]) -> Result<usize, Error<IFACE::Error>> {
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
                *slot = decode_accel_fifo_frame(data, frame);
            }
            done += n;
        }
        Ok(done)
    }

    /// Fast offset compensation (bounded polling of `cal_rdy`).
    pub async fn fast_offset_compensation(
        &mut self,
        delay: &mut impl DelayNs,
        targets: Xyz<OffsetTarget>,
    ) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::OFC_SETTING, offset_setting(targets))
            .await?;
        for axis in 1..=3u8 {
            self.write(reg::OFC_CTRL, axis << reg::CAL_TRIGGER_SHIFT)
                .await?;
            let mut ready = false;
            for _ in 0..FOC_POLL_ATTEMPTS {
                delay.delay_ms(1).await;
                if self.read(reg::OFC_CTRL).await? & reg::CAL_RDY != 0 {
                    ready = true;
                    break;
                }
            }
            if !ready {
                return Err(Error::Timeout);
            }
        }
        Ok(())
    }

    /// Self-test at ±4 g, ending with a soft reset.
    pub async fn self_test(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<AccelSelfTest, Error<IFACE::Error>> {
        self.set_range(AccelRange::G4).await?;
        let mut diff = [0f32; 3];
        for axis in 1..=3u8 {
            self.write(reg::PMU_SELF_TEST, axis | reg::SELF_TEST_SIGN)
                .await?;
            delay.delay_ms(SELF_TEST_SETTLE_MS).await;
            let pos = self.read_raw().await?.mg(AccelRange::G4).to_array();
            self.write(reg::PMU_SELF_TEST, axis).await?;
            delay.delay_ms(SELF_TEST_SETTLE_MS).await;
            let neg = self.read_raw().await?.mg(AccelRange::G4).to_array();
            let i = usize::from(axis - 1);
            diff[i] = pos[i] - neg[i];
        }
        self.write(reg::PMU_SELF_TEST, 0).await?;
        self.soft_reset(delay).await?;
        Ok(AccelSelfTest {
            difference_mg: Xyz::new(diff[0], diff[1], diff[2]),
        })
    }

    /// Change the filter bandwidth only.
    pub async fn set_bandwidth(&mut self, bw: AccelBandwidth) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::PMU_BW, bw.bits()).await
    }

    /// Change the power mode only.
    pub async fn set_power_mode(
        &mut self,
        mode: AccelPowerMode,
    ) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::PMU_LPW, mode.bits()).await
    }

    /// Clear latched interrupts, keeping the latch mode given by `latched`.
    pub async fn clear_latched_interrupts(
        &mut self,
        latched: bool,
    ) -> Result<(), Error<IFACE::Error>> {
        let mode = if latched { 0x0F } else { 0x00 };
        self.write(reg::INT_RST_LATCH, reg::RESET_INT | mode).await
    }

    /// Current offsets (7.8125 mg/LSB).
    pub async fn offsets(&mut self) -> Result<Xyz<i8>, Error<IFACE::Error>> {
        let mut b = [0u8; 3];
        self.read_into(reg::OFC_OFFSET_X, &mut b).await?;
        Ok(Xyz::new(b[0] as i8, b[1] as i8, b[2] as i8))
    }

    /// Write offsets (7.8125 mg/LSB).
    pub async fn set_offsets(&mut self, offsets: Xyz<i8>) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::OFC_OFFSET_X, offsets.x as u8).await?;
        self.write(reg::OFC_OFFSET_Y, offsets.y as u8).await?;
        self.write(reg::OFC_OFFSET_Z, offsets.z as u8).await
    }

    /// Set all offsets to zero.
    pub async fn reset_offsets(&mut self) -> Result<(), Error<IFACE::Error>> {
        self.write(reg::OFC_CTRL, reg::OFFSET_RESET).await
    }
}
