//! Gyroscope interrupts: data ready and FIFO on INT1/INT2 (INT3/INT4 on the BMX055 pinout).

#[cfg(feature = "async")]
use super::AsyncGyroscope;
use super::{register as reg, Gyroscope};
#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::Registers;
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::RegisterInterface;
use crate::types::{InterruptPin, PinConfig};
use crate::Error;

/// Which gyroscope interrupts go to which pin, and how the pins behave.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroInterruptConfig {
    /// New data ready.
    pub data_ready: Option<InterruptPin>,
    /// FIFO interrupt (watermark reached, when a watermark is set).
    pub fifo_watermark: Option<InterruptPin>,
    /// INT1 electrical behaviour.
    pub int1: PinConfig,
    /// INT2 electrical behaviour.
    pub int2: PinConfig,
    /// `true`: interrupts stay asserted until cleared; `false`: non-latched.
    pub latched: bool,
}

impl GyroInterruptConfig {
    /// The register writes, in order: pin behaviour, latch mode, map, watermark enable,
    /// interrupt enables (last).
    pub fn register_writes(&self) -> [(u8, u8); 5] {
        let mut map1 = 0;
        let mut en0 = 0;
        let mut wm = 0;
        if let Some(p) = self.data_ready {
            map1 |= match p {
                InterruptPin::Int1 => reg::INT1_DATA,
                InterruptPin::Int2 => reg::INT2_DATA,
            };
            en0 |= reg::DATA_EN;
        }
        if let Some(p) = self.fifo_watermark {
            map1 |= match p {
                InterruptPin::Int1 => reg::INT1_FIFO,
                InterruptPin::Int2 => reg::INT2_FIFO,
            };
            en0 |= reg::FIFO_EN;
            wm = reg::FIFO_WM_ENABLE;
        }
        let pin_bits = |p: PinConfig, lvl: u8, od: u8| {
            (if p.active_high { lvl } else { 0 }) | (if p.open_drain { od } else { 0 })
        };
        [
            (
                reg::INT_EN_1,
                pin_bits(self.int1, reg::INT1_LVL, reg::INT1_OD)
                    | pin_bits(self.int2, reg::INT2_LVL, reg::INT2_OD),
            ),
            (reg::INT_RST_LATCH, if self.latched { 0x0F } else { 0x00 }),
            (reg::INT_MAP_1, map1),
            (reg::FIFO_WM_EN, wm),
            (reg::INT_EN_0, en0),
        ]
    }
}

/// Interrupt flags read from `INT_STATUS_0` and `INT_STATUS_1`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroInterruptStatus {
    /// New data ready.
    pub data_ready: bool,
    /// FIFO interrupt.
    pub fifo: bool,
    /// Any-motion detected.
    pub any_motion: bool,
}

impl GyroInterruptStatus {
    /// Decode `INT_STATUS_0` and `INT_STATUS_1`.
    pub const fn from_registers(status0: u8, status1: u8) -> Self {
        Self {
            data_ready: status1 & reg::STATUS_DATA != 0,
            fifo: status1 & reg::STATUS_FIFO != 0,
            any_motion: status0 & reg::STATUS_ANY != 0,
        }
    }
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Gyroscope<IFACE> {
        /// Route and enable interrupts (five register writes).
        pub async fn configure_interrupts(
            &mut self,
            config: &GyroInterruptConfig,
        ) -> Result<(), Error<IFACE::Error>> {
            self.iface.write_all(config.register_writes()).await?;
            Ok(())
        }

        /// Read the interrupt flags.
        pub async fn interrupt_status(&mut self) -> Result<GyroInterruptStatus, Error<IFACE::Error>> {
            let mut b = [0u8; 2];
            self.iface.read_into(reg::INT_STATUS_0, &mut b).await?;
            Ok(GyroInterruptStatus::from_registers(b[0], b[1]))
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
