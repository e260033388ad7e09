//! Async accelerometer.

use crate::accel::{
    accel_temperature_celsius, decode_accel_fifo_frame, offset_setting, register as reg,
    AccelAddress, AccelBandwidth, AccelConfig, AccelFifoConfig, AccelInterruptConfig,
    AccelInterruptStatus, AccelPowerMode, AccelRange, AccelRaw, AccelSelfTest, OffsetTarget,
    ACCEL_FIFO_REGISTERS, FOC_POLL_ATTEMPTS, SELF_TEST_SETTLE_MS, SOFT_RESET_WAIT_US,
};
use crate::asynch::access::AsyncRegisters;
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
    /// Chip id (0xFA).
    pub async fn chip_id(&mut self) -> Result<u8, Error<IFACE::Error>> {
        self.iface.read(reg::BGW_CHIPID).await
    }

    /// Chip id check with up to `attempts` reads 1 ms apart.
    pub async fn check_chip_id(
        &mut self,
        delay: &mut impl DelayNs,
        attempts: u8,
    ) -> Result<(), Error<IFACE::Error>> {
        self.iface
            .check_chip_id(delay, reg::BGW_CHIPID, reg::CHIP_ID_VALUE, attempts)
            .await
    }

    /// Soft reset and wait.
    pub async fn soft_reset(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<(), Error<IFACE::Error>> {
        self.iface
            .write(reg::BGW_SOFTRESET, reg::SOFT_RESET_CMD)
            .await?;
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
        self.iface.write_all(config.register_writes()).await?;
        self.range = config.range;
        Ok(())
    }

    /// Change the range only.
    pub async fn set_range(&mut self, range: AccelRange) -> Result<(), Error<IFACE::Error>> {
        self.iface.write(reg::PMU_RANGE, range.bits()).await?;
        self.range = range;
        Ok(())
    }

    /// Read X, Y, Z in one burst.
    pub async fn read_raw(&mut self) -> Result<AccelRaw, Error<IFACE::Error>> {
        let mut b = [0u8; 6];
        self.iface.read_into(reg::ACCD_X_LSB, &mut b).await?;
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
        Ok(accel_temperature_celsius(
            self.iface.read(reg::ACCD_TEMP).await?,
        ))
    }

    /// Route and enable interrupts.
    pub async fn configure_interrupts(
        &mut self,
        config: &AccelInterruptConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        self.iface.write_all(config.register_writes()).await?;
        Ok(())
    }

    /// Interrupt flags.
    pub async fn interrupt_status(&mut self) -> Result<AccelInterruptStatus, Error<IFACE::Error>> {
        let mut b = [0u8; 2];
        self.iface.read_into(reg::INT_STATUS_0, &mut b).await?;
        Ok(AccelInterruptStatus::from_registers(b[0], b[1]))
    }

    /// Configure the FIFO (`InvalidInput` above 31 frames).
    pub async fn configure_fifo(
        &mut self,
        config: &AccelFifoConfig,
    ) -> Result<(), Error<IFACE::Error>> {
        let writes = config.register_writes().ok_or(Error::InvalidInput)?;
        self.iface.write_all(writes).await?;
        self.fifo_data = config.data;
        Ok(())
    }

    /// FIFO fill level.
    pub async fn fifo_status(&mut self) -> Result<FifoStatus, Error<IFACE::Error>> {
        Ok(FifoStatus::from_register(
            self.iface.read(reg::FIFO_STATUS).await?,
        ))
    }

    /// Read up to `out.len()` waiting frames; returns how many were read.
    pub async fn read_fifo(&mut self, out: &mut [AccelRaw]) -> Result<usize, Error<IFACE::Error>> {
        self.iface
            .read_fifo(
                ACCEL_FIFO_REGISTERS,
                self.fifo_data,
                out,
                decode_accel_fifo_frame,
            )
            .await
    }

    /// Fast offset compensation (bounded polling of `cal_rdy`).
    pub async fn fast_offset_compensation(
        &mut self,
        delay: &mut impl DelayNs,
        targets: Xyz<OffsetTarget>,
    ) -> Result<(), Error<IFACE::Error>> {
        self.iface
            .write(reg::OFC_SETTING, offset_setting(targets))
            .await?;
        for axis in 1..=3u8 {
            self.iface
                .write(reg::OFC_CTRL, axis << reg::CAL_TRIGGER_SHIFT)
                .await?;
            let mut ready = false;
            for _ in 0..FOC_POLL_ATTEMPTS {
                delay.delay_ms(1).await;
                if self.iface.read(reg::OFC_CTRL).await? & reg::CAL_RDY != 0 {
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

    /// Self-test at ±4 g with high deflection amplitude, ending with a soft reset.
    pub async fn self_test(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<AccelSelfTest, Error<IFACE::Error>> {
        self.set_range(AccelRange::G4).await?;
        let mut diff = [0f32; 3];
        for axis in 1..=3u8 {
            self.iface
                .write(
                    reg::PMU_SELF_TEST,
                    axis | reg::SELF_TEST_SIGN | reg::SELF_TEST_AMP,
                )
                .await?;
            delay.delay_ms(SELF_TEST_SETTLE_MS).await;
            let pos = self.read_raw().await?.mg(AccelRange::G4).to_array();
            self.iface
                .write(reg::PMU_SELF_TEST, axis | reg::SELF_TEST_AMP)
                .await?;
            delay.delay_ms(SELF_TEST_SETTLE_MS).await;
            let neg = self.read_raw().await?.mg(AccelRange::G4).to_array();
            let i = usize::from(axis - 1);
            diff[i] = pos[i] - neg[i];
        }
        self.iface.write(reg::PMU_SELF_TEST, 0).await?;
        self.soft_reset(delay).await?;
        Ok(AccelSelfTest {
            difference_mg: Xyz::new(diff[0], diff[1], diff[2]),
        })
    }

    /// Change the filter bandwidth only.
    pub async fn set_bandwidth(&mut self, bw: AccelBandwidth) -> Result<(), Error<IFACE::Error>> {
        self.iface.write(reg::PMU_BW, bw.bits()).await
    }

    /// Change the power mode only.
    pub async fn set_power_mode(
        &mut self,
        mode: AccelPowerMode,
    ) -> Result<(), Error<IFACE::Error>> {
        self.iface.write(reg::PMU_LPW, mode.bits()).await
    }

    /// Clear latched interrupts, keeping the latch mode given by `latched`.
    pub async fn clear_latched_interrupts(
        &mut self,
        latched: bool,
    ) -> Result<(), Error<IFACE::Error>> {
        let mode = if latched { 0x0F } else { 0x00 };
        self.iface
            .write(reg::INT_RST_LATCH, reg::RESET_INT | mode)
            .await
    }

    /// Current offsets (7.8125 mg/LSB).
    pub async fn offsets(&mut self) -> Result<Xyz<i8>, Error<IFACE::Error>> {
        let mut b = [0u8; 3];
        self.iface.read_into(reg::OFC_OFFSET_X, &mut b).await?;
        Ok(Xyz::new(b[0] as i8, b[1] as i8, b[2] as i8))
    }

    /// Write offsets (7.8125 mg/LSB).
    pub async fn set_offsets(&mut self, offsets: Xyz<i8>) -> Result<(), Error<IFACE::Error>> {
        self.iface.write(reg::OFC_OFFSET_X, offsets.x as u8).await?;
        self.iface.write(reg::OFC_OFFSET_Y, offsets.y as u8).await?;
        self.iface.write(reg::OFC_OFFSET_Z, offsets.z as u8).await
    }

    /// Set all offsets to zero.
    pub async fn reset_offsets(&mut self) -> Result<(), Error<IFACE::Error>> {
        self.iface.write(reg::OFC_CTRL, reg::OFFSET_RESET).await
    }
}
