//! Gyroscope built-in self-test (BIST).

#[cfg(feature = "async")]
use super::AsyncGyroscope;
use super::{register as reg, Gyroscope};
#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::Registers;
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::RegisterInterface;
use crate::Error;
use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

/// Polls (1 ms apart) of `bist_rdy` before the self-test gives up with `Timeout`.
pub const BIST_POLL_ATTEMPTS: u8 = 50;

/// Outcome of [`Gyroscope::self_test`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroSelfTest {
    /// `rate_ok`: the continuous plausibility check of the rate output.
    pub rate_ok: bool,
    /// `bist_fail` was clear when `bist_rdy` was set.
    pub bist_ok: bool,
}

impl GyroSelfTest {
    /// Both checks passed.
    pub const fn passed(&self) -> bool {
        self.rate_ok && self.bist_ok
    }
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Gyroscope<IFACE> {
        /// Run the built-in self-test: read `rate_ok`, set `trig_bist`, poll `bist_rdy` (at most
        /// [`BIST_POLL_ATTEMPTS`] ms), read `bist_fail`.
        pub async fn self_test(
            &mut self,
            delay: &mut impl DelayNs,
        ) -> Result<GyroSelfTest, Error<IFACE::Error>> {
            let rate_ok = self.iface.read(reg::BIST).await? & reg::RATE_OK != 0;
            self.iface.write(reg::BIST, reg::TRIG_BIST).await?;
            for _ in 0..BIST_POLL_ATTEMPTS {
                delay.delay_ms(1).await;
                let bist = self.iface.read(reg::BIST).await?;
                if bist & reg::BIST_RDY != 0 {
                    return Ok(GyroSelfTest {
                        rate_ok,
                        bist_ok: bist & reg::BIST_FAIL == 0,
                    });
                }
            }
            Err(Error::Device(crate::DeviceError::Timeout))
        }
    }
}
