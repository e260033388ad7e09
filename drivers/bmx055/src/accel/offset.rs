//! Accelerometer offset compensation: fast (FOC) calibration and manual offsets.

#[cfg(feature = "async")]
use super::AsyncAccelerometer;
use super::{register as reg, Accelerometer};
#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::Registers;
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::RegisterInterface;
use crate::types::Xyz;
use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

use crate::Error;

/// Offset register resolution in mg per LSB (independent of the range).
pub const OFFSET_MG_PER_LSB: f32 = 7.8125;
/// Polls (1 ms apart) of `cal_rdy` before a fast compensation gives up with `Timeout`.
pub const FOC_POLL_ATTEMPTS: u16 = 100;

/// What an axis should read once the fast offset compensation has run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OffsetTarget {
    /// 0 g (axis horizontal).
    #[default]
    Zero = 0,
    /// +1 g (axis pointing up).
    PlusOneG = 1,
    /// -1 g (axis pointing down).
    MinusOneG = 2,
}

/// `OFC_SETTING` value for the given targets (cut-off bit 0 left clear).
pub const fn offset_setting(targets: Xyz<OffsetTarget>) -> u8 {
    ((targets.x as u8) << 1) | ((targets.y as u8) << 3) | ((targets.z as u8) << 5)
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Accelerometer<IFACE> {
        /// Fast offset compensation with the device at rest: the die averages samples per axis and
        /// writes the offset registers so each axis reads its target. Runs X, Y then Z, polling
        /// `cal_rdy` at most [`FOC_POLL_ATTEMPTS`] times per axis. Needs normal power mode.
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
                    return Err(Error::Device(crate::DeviceError::Timeout));
                }
            }
            Ok(())
        }

        /// Current offsets (7.8125 mg/LSB).
        pub async fn offsets(&mut self) -> Result<Xyz<i8>, Error<IFACE::Error>> {
            let mut b = [0u8; 3];
            self.iface.read_into(reg::OFC_OFFSET_X, &mut b).await?;
            Ok(Xyz::new(b[0] as i8, b[1] as i8, b[2] as i8))
        }

        /// Write offsets (7.8125 mg/LSB), e.g. values saved from an earlier calibration.
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
}
