//! A PCA9685 16-channel PWM board on I2C as the servo output (`servo.kind = "pca9685"`),
//! through the `pwm-pca9685` driver.
//!
//! The chip makes every channel's pulses at one frequency, `pca9685.pwm_frequency_hz` (up to
//! 1526 Hz): at 250 Hz, servo targets can change every cycle of a 250 Hz loop, which the
//! Maestro's 50 Hz pulse train cannot. A pulse of `t` µs is `t * 4096 * f / 1e6` counts of the
//! 12-bit counter, with `f` the frequency the prescaler really gives; target 0 ("no pulses")
//! sets the channel's full-off bit.

use anyhow::Context;
use embedded_hal::i2c::I2c;
use linux_embedded_hal::I2cdev;
use pwm_pca9685::{Address, Channel, Pca9685};

use super::servo::{ServoError, ServoOutput};
use crate::config::Pca9685Config;
use crate::rt::monotonic_ns;
use dima_core::Nanos;

/// The prescaler value for `frequency_hz` with the oscillator at `oscillator_hz` (datasheet
/// 7.3.5: `round(osc / (4096 * f)) - 1`, within the register's 3..=255).
pub fn prescale(oscillator_hz: u32, frequency_hz: u32) -> u8 {
    let divisor = 4_096 * u64::from(frequency_hz.max(1));
    let rounded = (u64::from(oscillator_hz) + divisor / 2) / divisor;
    rounded.saturating_sub(1).clamp(3, 255) as u8
}

/// Counter value at which a pulse of `quarter_us` quarter-microseconds ends, at the frequency
/// `prescale` gives (`osc / (4096 * (prescale + 1))`), rounded to the nearest count.
pub fn pulse_counts(quarter_us: u16, oscillator_hz: u32, prescale: u8) -> u16 {
    let divisor = 4_000_000 * (u64::from(prescale) + 1);
    let counts = (u64::from(quarter_us) * u64::from(oscillator_hz) + divisor / 2) / divisor;
    counts.min(4_095) as u16
}

/// The PCA9685 as the loop's servo output.
pub struct Pca9685Output<I2C> {
    chip: Pca9685<I2C>,
    oscillator_hz: u32,
    prescale: u8,
}

impl<I2C: I2c> Pca9685Output<I2C> {
    /// Sets the PWM frequency and wakes the chip up, with every channel's pulses off until the
    /// first targets.
    pub fn new(i2c: I2C, config: &Pca9685Config) -> Result<Self, pwm_pca9685::Error<I2C::Error>> {
        let mut chip = Pca9685::new(i2c, Address::from(config.address))?;
        let prescale = prescale(config.oscillator_hz, config.pwm_frequency_hz);
        chip.set_prescale(prescale)?;
        chip.enable()?;
        Ok(Pca9685Output {
            chip,
            oscillator_hz: config.oscillator_hz,
            prescale,
        })
    }

    /// The PWM frequency the prescaler gives, Hz.
    pub fn frequency_hz(&self) -> f64 {
        f64::from(self.oscillator_hz) / (4_096.0 * (f64::from(self.prescale) + 1.0))
    }

    /// The I2C bus back.
    pub fn release(self) -> I2C {
        self.chip.destroy()
    }

    fn write_one(&mut self, channel: u8, quarter_us: u16) -> Result<(), ServoError> {
        let channel = Channel::try_from(channel).map_err(|_| ServoError::InvalidInput)?;
        let result = if quarter_us == 0 {
            self.chip.set_channel_full_off(channel)
        } else {
            let off = pulse_counts(quarter_us, self.oscillator_hz, self.prescale);
            self.chip.set_channel_on_off(channel, 0, off)
        };
        result.map_err(|e| match e {
            pwm_pca9685::Error::I2C(_) => ServoError::Device,
            _ => ServoError::InvalidInput,
        })
    }
}

impl Pca9685Output<I2cdev> {
    /// Opens the configured I2C bus and sets the chip up.
    pub fn open(config: &Pca9685Config) -> anyhow::Result<Self> {
        let bus = I2cdev::new(&config.device).with_context(|| {
            format!(
                "PCA9685: cannot open {} (I2C enabled, and in the i2c group?)",
                config.device.display()
            )
        })?;
        Pca9685Output::new(bus, config).map_err(|e| {
            anyhow::anyhow!(
                "PCA9685: no answer at address {:#04x} on {}: {e:?}",
                config.address,
                config.device.display()
            )
        })
    }
}

impl<I2C: I2c> ServoOutput for Pca9685Output<I2C> {
    /// One register write per channel; between writes, a passed deadline stops the rest (they
    /// go out with the next write). A single write cannot be given a deadline: Linux I2C
    /// transfers block until they end or the bus adapter's own timeout (on the Nano's Tegra
    /// adapter, about a second) fails them, so a hung bus stalls the loop that long, and the
    /// overrun failsafe then trips.
    fn write_targets(
        &mut self,
        channels: &[u8; 3],
        targets_qus: &[u16; 3],
        deadline_ns: Nanos,
    ) -> Result<(), ServoError> {
        for (i, (&channel, &target)) in channels.iter().zip(targets_qus).enumerate() {
            if i > 0 && monotonic_ns() > deadline_ns {
                return Err(ServoError::Timeout);
            }
            self.write_one(channel, target)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    //! Register-level transactions against the PCA9685 datasheet (NXP, rev. 4): MODE1 at 0x00
    //! (SLEEP bit 4, AI bit 5, ALLCALL bit 0, 0x11 at reset), PRE_SCALE at 0xFE, LEDn_ON_L at
    //! 0x06 + 4n followed by ON_H, OFF_L, OFF_H, full-off as bit 4 of OFF_H.

    use embedded_hal_mock::eh1::i2c::{Mock, Transaction};

    use super::*;

    const ADDR: u8 = 0x40;

    fn config(frequency_hz: u32) -> Pca9685Config {
        Pca9685Config {
            pwm_frequency_hz: frequency_hz,
            ..Pca9685Config::default()
        }
    }

    #[test]
    fn prescale_matches_the_datasheet() {
        // Datasheet 7.3.5: 200 Hz -> 30 (0x1E); the 50 Hz servo rate -> 121; limits 1526 Hz
        // (3) and 24 Hz (255).
        assert_eq!(prescale(25_000_000, 200), 0x1E);
        assert_eq!(prescale(25_000_000, 50), 121);
        assert_eq!(prescale(25_000_000, 1_526), 3);
        assert_eq!(prescale(25_000_000, 24), 253);
        assert_eq!(prescale(25_000_000, 1), 255);
    }

    #[test]
    fn pulse_widths_in_counts() {
        // 50 Hz: prescale 121 gives 25e6 / (4096 x 122) = 50.03 Hz, 4.88 µs per count.
        assert_eq!(pulse_counts(1_500 * 4, 25_000_000, 121), 307);
        assert_eq!(pulse_counts(1_000 * 4, 25_000_000, 121), 205);
        assert_eq!(pulse_counts(2_000 * 4, 25_000_000, 121), 410);
        // 250 Hz: prescale 23, 254.3 Hz, 0.96 µs per count.
        assert_eq!(prescale(25_000_000, 250), 23);
        assert_eq!(pulse_counts(1_500 * 4, 25_000_000, 23), 1_563);
    }

    #[test]
    fn setup_sets_the_frequency_asleep_then_wakes_the_chip() {
        let expected = [
            Transaction::write(ADDR, vec![0xFE, 23]),
            // MODE1: SLEEP cleared, ALLCALL kept.
            Transaction::write(ADDR, vec![0x00, 0x01]),
        ];
        let mut bus = Mock::new(&expected);
        let out = Pca9685Output::new(bus.clone(), &config(250)).unwrap();
        assert!((out.frequency_hz() - 254.3).abs() < 0.1);
        out.release();
        bus.done();
    }

    #[test]
    fn targets_are_one_write_per_channel_and_zero_is_full_off() {
        let expected = [
            Transaction::write(ADDR, vec![0xFE, 121]),
            Transaction::write(ADDR, vec![0x00, 0x01]),
            // Auto-increment on (MODE1 AI), then channel 0: ON = 0, OFF = 307 (0x133).
            Transaction::write(ADDR, vec![0x00, 0x21]),
            Transaction::write(ADDR, vec![0x06, 0x00, 0x00, 0x33, 0x01]),
            // Channel 1 at 1545 µs: 316.6 -> 317 counts (0x13D), registers at 0x0A.
            Transaction::write(ADDR, vec![0x0A, 0x00, 0x00, 0x3D, 0x01]),
            // Channel 15, no pulses: full-off bit in LED15_OFF_H (0x45).
            Transaction::write(ADDR, vec![0x44, 0x00, 0x10]),
        ];
        let mut bus = Mock::new(&expected);
        let mut out = Pca9685Output::new(bus.clone(), &config(50)).unwrap();
        out.write_targets(&[0, 1, 15], &[1_500 * 4, 1_545 * 4, 0], u64::MAX)
            .unwrap();
        out.release();
        bus.done();
    }

    #[test]
    fn a_bus_error_is_a_device_failure_and_a_bad_channel_is_refused() {
        let expected = [
            Transaction::write(ADDR, vec![0xFE, 121]),
            Transaction::write(ADDR, vec![0x00, 0x01]),
            Transaction::write(ADDR, vec![0x00, 0x21])
                .with_error(embedded_hal::i2c::ErrorKind::Other),
        ];
        let mut bus = Mock::new(&expected);
        let mut out = Pca9685Output::new(bus.clone(), &config(50)).unwrap();
        assert_eq!(
            out.write_targets(&[16, 1, 2], &[6_000; 3], u64::MAX),
            Err(ServoError::InvalidInput)
        );
        assert_eq!(
            out.write_targets(&[0, 1, 2], &[6_000; 3], u64::MAX),
            Err(ServoError::Device)
        );
        out.release();
        bus.done();
    }
}
