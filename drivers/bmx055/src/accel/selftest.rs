//! Accelerometer self-test: electrostatic deflection in both directions per axis.

use super::{register as reg, AccelRange, AccelRaw, Accelerometer};
use crate::interface::RegisterInterface;
use crate::types::Xyz;
use crate::Error;
use embedded_hal::delay::DelayNs;

/// Minimum deflection difference (positive minus negative) for a pass, in mg
/// (datasheet self-test limits: X and Y 800 mg, Z 400 mg).
pub const SELF_TEST_MIN_MG: Xyz<f32> = Xyz::new(800.0, 800.0, 400.0);
/// Settling time after each self-test excitation change (datasheet: 50 ms).
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

impl<IFACE: RegisterInterface> Accelerometer<IFACE> {
    /// Run the self-test at ±4 g: per axis, excite positive then negative, wait 50 ms each,
    /// and measure the difference. Ends with a soft reset (as the datasheet asks), so call
    /// [`configure`](Self::configure) again afterwards. Returns the measured differences;
    /// check [`AccelSelfTest::passed`] (the call itself only fails on bus errors).
    pub fn self_test(
        &mut self,
        delay: &mut impl DelayNs,
    ) -> Result<AccelSelfTest, Error<IFACE::Error>> {
        self.set_range(AccelRange::G4)?;
        let mut diff = [0f32; 3];
        for axis in 1..=3u8 {
            self.write(reg::PMU_SELF_TEST, axis | reg::SELF_TEST_SIGN)?;
            delay.delay_ms(SELF_TEST_SETTLE_MS);
            let pos = self.read_raw()?;
            self.write(reg::PMU_SELF_TEST, axis)?;
            delay.delay_ms(SELF_TEST_SETTLE_MS);
            let neg = self.read_raw()?;
            diff[usize::from(axis - 1)] =
                axis_mg(&pos, axis, AccelRange::G4) - axis_mg(&neg, axis, AccelRange::G4);
        }
        self.write(reg::PMU_SELF_TEST, 0)?;
        self.soft_reset(delay)?;
        Ok(AccelSelfTest {
            difference_mg: Xyz::new(diff[0], diff[1], diff[2]),
        })
    }
}
