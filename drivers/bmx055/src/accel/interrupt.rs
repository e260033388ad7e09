//! Accelerometer interrupts: data ready, slope (any-motion) and FIFO on INT1/INT2.

#[cfg(feature = "async")]
use super::AsyncAccelerometer;
use super::{register as reg, Accelerometer};
#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::Registers;
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::RegisterInterface;
use crate::types::{InterruptPin, PinConfig, Xyz};
use crate::Error;

/// Slope (any-motion) detector settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SlopeConfig {
    /// Threshold on the slope between consecutive samples: 3.91 mg/LSB at ±2 g, scaling with
    /// the range (7.81 mg at ±4 g, ...).
    pub threshold: u8,
    /// Consecutive samples above the threshold before the interrupt fires, minus one (0..=3).
    pub duration: u8,
    /// Axes that take part.
    pub axes: Xyz<bool>,
}

impl Default for SlopeConfig {
    /// The reset threshold (0x14) and duration (0), all axes.
    fn default() -> Self {
        Self {
            threshold: 0x14,
            duration: 0,
            axes: Xyz::new(true, true, true),
        }
    }
}

/// Which accelerometer interrupts go to which pin, and how the pins behave.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelInterruptConfig {
    /// New data ready (fires at the data rate).
    pub data_ready: Option<InterruptPin>,
    /// Slope (any-motion) detection and its settings.
    pub slope: Option<(InterruptPin, SlopeConfig)>,
    /// FIFO watermark reached.
    pub fifo_watermark: Option<InterruptPin>,
    /// FIFO full.
    pub fifo_full: Option<InterruptPin>,
    /// INT1 electrical behaviour.
    pub int1: PinConfig,
    /// INT2 electrical behaviour.
    pub int2: PinConfig,
    /// `true`: interrupts stay asserted until cleared; `false`: non-latched.
    pub latched: bool,
}

impl AccelInterruptConfig {
    /// The register writes that apply this configuration, in order: slope duration and
    /// threshold, pin behaviour, latch mode, maps, enables (enables last so nothing fires
    /// half-configured).
    pub fn register_writes(&self) -> [(u8, u8); 9] {
        let slope = self.slope.map(|(_, s)| s).unwrap_or_default();
        let mut map0 = 0;
        let mut map1 = 0;
        let mut map2 = 0;
        let mut en0 = 0;
        let mut en1 = 0;
        if let Some((pin, s)) = self.slope {
            match pin {
                InterruptPin::Int1 => map0 |= reg::MAP_SLOPE,
                InterruptPin::Int2 => map2 |= reg::MAP_SLOPE,
            }
            if s.axes.x {
                en0 |= reg::SLOPE_EN_X;
            }
            if s.axes.y {
                en0 |= reg::SLOPE_EN_Y;
            }
            if s.axes.z {
                en0 |= reg::SLOPE_EN_Z;
            }
        }
        let mut route = |pin: Option<InterruptPin>, int1: u8, int2: u8, enable: u8| {
            if let Some(p) = pin {
                map1 |= match p {
                    InterruptPin::Int1 => int1,
                    InterruptPin::Int2 => int2,
                };
                en1 |= enable;
            }
        };
        route(
            self.data_ready,
            reg::INT1_DATA,
            reg::INT2_DATA,
            reg::DATA_EN,
        );
        route(
            self.fifo_watermark,
            reg::INT1_FWM,
            reg::INT2_FWM,
            reg::INT_FWM_EN,
        );
        route(
            self.fifo_full,
            reg::INT1_FFULL,
            reg::INT2_FFULL,
            reg::INT_FFULL_EN,
        );
        let pin_bits = |p: PinConfig, lvl: u8, od: u8| {
            (if p.active_high { lvl } else { 0 }) | (if p.open_drain { od } else { 0 })
        };
        let out_ctrl = pin_bits(self.int1, reg::INT1_LVL, reg::INT1_OD)
            | pin_bits(self.int2, reg::INT2_LVL, reg::INT2_OD);
        [
            (reg::INT_5, slope.duration & 0x03),
            (reg::INT_6, slope.threshold),
            (reg::INT_OUT_CTRL, out_ctrl),
            (reg::INT_RST_LATCH, if self.latched { 0x0F } else { 0x00 }),
            (reg::INT_MAP_0, map0),
            (reg::INT_MAP_1, map1),
            (reg::INT_MAP_2, map2),
            (reg::INT_EN_0, en0),
            (reg::INT_EN_1, en1),
        ]
    }
}

/// Interrupt flags read from `INT_STATUS_0` and `INT_STATUS_1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelInterruptStatus {
    /// New data ready.
    pub data_ready: bool,
    /// Slope (any-motion) detected.
    pub slope: bool,
    /// FIFO watermark reached.
    pub fifo_watermark: bool,
    /// FIFO full.
    pub fifo_full: bool,
}

impl AccelInterruptStatus {
    /// Decode `INT_STATUS_0` and `INT_STATUS_1`.
    pub const fn from_registers(status0: u8, status1: u8) -> Self {
        Self {
            data_ready: status1 & reg::STATUS_DATA != 0,
            slope: status0 & reg::STATUS_SLOPE != 0,
            fifo_watermark: status1 & reg::STATUS_FWM != 0,
            fifo_full: status1 & reg::STATUS_FFULL != 0,
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Accelerometer<IFACE> {
        /// Route and enable interrupts (nine register writes, see
        /// [`AccelInterruptConfig::register_writes`]).
        pub async fn configure_interrupts(
            &mut self,
            config: &AccelInterruptConfig,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface.write_all(config.register_writes()).await?;
            Ok(())
        }

        /// Read the interrupt flags.
        pub async fn interrupt_status(&mut self) -> Result<AccelInterruptStatus, Error<IFACE::Error>> {
            let mut b = [0u8; 2];
            self.iface.read_into(reg::INT_STATUS_0, &mut b).await?;
            Ok(AccelInterruptStatus::from_registers(b[0], b[1]))
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
    }
}
