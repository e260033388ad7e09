//! Accelerometer self-test: electrostatic deflection in both directions per axis.

#[cfg(feature = "async")]
use super::AsyncAccelerometer;
use super::{register as reg, AccelRange, AccelRaw, Accelerometer};
#[cfg(feature = "async")]
use crate::access::AsyncRegisters;
use crate::access::Registers;
#[cfg(feature = "async")]
use crate::interface::AsyncRegisterInterface;
use crate::interface::RegisterInterface;
use crate::types::Xyz;
use crate::Error;
use embedded_hal::delay::DelayNs;
#[cfg(feature = "async")]
use embedded_hal_async::delay::DelayNs as AsyncDelayNs;

/// Minimum deflection difference (positive minus negative) for a pass, in mg, at ±4 g with
/// high amplitude: X and Y 800 mg, Z 400 mg (Bosch BMA2 SensorAPI `bma2_defs.h`,
/// `BMA2_ST_ACC_{X,Y,Z}_AXIS_SIGNAL_DIFF`, "resulting minimum difference signal in mg").
pub const SELF_TEST_MIN_MG: Xyz<f32> = Xyz::new(800.0, 800.0, 400.0);
/// Settling time after each self-test excitation change, in ms (Bosch BMA2 SensorAPI
/// `self_test_excitation_data`: "wait 50ms before interpreting the acceleration data").
pub const SELF_TEST_SETTLE_MS: u32 = 50;

/// Outcome of [`Accelerometer::self_test`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AccelSelfTest {
    /// Positive minus negative deflection per axis, in mg.
    pub difference_mg: Xyz<f32>,
}

impl AccelSelfTest {
    /// Every axis deflected at least [`SELF_TEST_MIN_MG`].
    pub fn passed(&self) -> bool {
        self.difference_mg.x >= SELF_TEST_MIN_MG.x
            && self.difference_mg.y >= SELF_TEST_MIN_MG.y
            && self.difference_mg.z >= SELF_TEST_MIN_MG.z
    }
}

fn axis_mg(raw: &AccelRaw, axis: u8, range: AccelRange) -> f32 {
    let mg = raw.mg(range);
    match axis {
        1 => mg.x,
        2 => mg.y,
        _ => mg.z,
    }
}

crate::blocking_and_async! {
    impl<IFACE: RegisterInterface> Accelerometer<IFACE> {
        /// Run the self-test at ±4 g with high deflection amplitude (`self_test_amp` = 1, as
        /// Bosch's BMA2 SensorAPI does): per axis, excite positive then negative, wait 50 ms each,
        /// and measure the difference. Ends with a soft reset (as the datasheet asks), so call
        /// [`configure`](Self::configure) again afterwards. Returns the measured differences;
        /// check [`AccelSelfTest::passed`] (the call itself only fails on bus errors).
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
                let pos = self.read_raw().await?;
                self.iface
                    .write(reg::PMU_SELF_TEST, axis | reg::SELF_TEST_AMP)
                    .await?;
                delay.delay_ms(SELF_TEST_SETTLE_MS).await;
                let neg = self.read_raw().await?;
                diff[usize::from(axis - 1)] =
                    axis_mg(&pos, axis, AccelRange::G4) - axis_mg(&neg, axis, AccelRange::G4);
            }
            self.iface.write(reg::PMU_SELF_TEST, 0).await?;
            self.soft_reset(delay).await?;
            Ok(AccelSelfTest {
                difference_mg: Xyz::new(diff[0], diff[1], diff[2]),
            })
        }
    }
}
