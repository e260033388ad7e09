//! A PCA9685 16-channel PWM board on I2C as the servo output (`servo.kind = "pca9685"`),
//! through the `pwm-pca9685` driver.
//!
//! The chip makes every channel's pulses at one frequency, `pca9685.pwm_frequency_hz` (up to
//! 1526 Hz): at 250 Hz, servo targets can change every cycle of a 250 Hz loop, which the
//! Maestro's 50 Hz pulse train cannot. A pulse of `t` µs is `t * 4096 * f / 1e6` counts of the
//! 12-bit counter, with `f` the frequency the prescaler really gives; target 0 ("no pulses")
//! sets the channel's full-off bit.
//!
//! Setting the chip up assumes nothing about its state: at power-up it is asleep with every
//! channel off, but after a reopen or a restart of the application it may be awake and still
//! making the last pulses. [`Pca9685Output::new`] therefore turns every channel off, stops the
//! oscillator, writes the prescaler (the chip ignores PRE_SCALE writes while awake), wakes the
//! chip and, after the oscillator's 500 µs, writes RESTART; the first pulses are the loop's
//! first targets.

use anyhow::Context;
use embedded_hal::delay::DelayNs;
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

/// MODE1 register.
const MODE1: u8 = 0x00;
/// ALL_LED_OFF_H register: writes go to every channel's LEDn_OFF_H.
const ALL_LED_OFF_H: u8 = 0xFD;
/// PRE_SCALE register.
const PRE_SCALE: u8 = 0xFE;
/// MODE1.RESTART: written as 1 to clear a pending restart.
const MODE1_RESTART: u8 = 1 << 7;
/// MODE1.SLEEP: oscillator off.
const MODE1_SLEEP: u8 = 1 << 4;
/// MODE1.ALLCALL: answer the all-call address (set at reset, kept).
const MODE1_ALLCALL: u8 = 1 << 0;
/// LEDn_OFF_H full-off bit.
const FULL_OFF: u8 = 1 << 4;
/// Time the oscillator needs after SLEEP is cleared, before RESTART may be written, µs.
const OSCILLATOR_START_US: u32 = 500;

/// The PCA9685 as the loop's servo output.
pub struct Pca9685Output<I2C> {
    chip: Pca9685<I2C>,
    oscillator_hz: u32,
    prescale: u8,
}

impl<I2C: I2c> Pca9685Output<I2C> {
    /// Turns every channel off, sets the PWM frequency asleep and wakes the chip up, whatever
    /// state it was in; the channels stay off until the first targets. `delay` waits for the
    /// oscillator (500 µs, on the device thread, never in the loop).
    pub fn new(
        i2c: I2C,
        config: &Pca9685Config,
        delay: &mut impl DelayNs,
    ) -> Result<Self, pwm_pca9685::Error<I2C::Error>> {
        let address = config.address;
        // The driver refuses an address the chip cannot have; ask before writing to it.
        let mut i2c = Pca9685::new(i2c, Address::from(address))?.destroy();
        let prescale = prescale(config.oscillator_hz, config.pwm_frequency_hz);
        let mut write = |register: u8, value: u8| {
            i2c.write(address, &[register, value])
                .map_err(pwm_pca9685::Error::I2C)
        };
        write(ALL_LED_OFF_H, FULL_OFF)?;
        write(MODE1, MODE1_SLEEP | MODE1_ALLCALL)?;
        write(PRE_SCALE, prescale)?;
        write(MODE1, MODE1_ALLCALL)?;
        delay.delay_us(OSCILLATOR_START_US);
        write(MODE1, MODE1_RESTART | MODE1_ALLCALL)?;
        // The driver starts from the reset value of MODE1 (asleep): make its copy match the
        // chip (awake), or its next MODE1 write (auto-increment) would put the chip to sleep.
        let mut chip = Pca9685::new(i2c, Address::from(address))?;
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
        Pca9685Output::new(bus, config, &mut linux_embedded_hal::Delay).map_err(|e| {
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
    //! (RESTART bit 7, AI bit 5, SLEEP bit 4, ALLCALL bit 0, 0x11 at reset), PRE_SCALE at 0xFE
    //! (writes ignored while SLEEP = 0), ALL_LED_OFF_H at 0xFD, LEDn_ON_L at 0x06 + 4n followed
    //! by ON_H, OFF_L, OFF_H, full-off as bit 4 of OFF_H.

    use std::cell::RefCell;
    use std::rc::Rc;

    use embedded_hal::i2c::{ErrorType, Operation};
    use embedded_hal_mock::eh1::i2c::{Mock, Transaction};

    use super::*;

    const ADDR: u8 = 0x40;

    fn config(frequency_hz: u32) -> Pca9685Config {
        Pca9685Config {
            pwm_frequency_hz: frequency_hz,
            ..Pca9685Config::default()
        }
    }

    /// The set-up writes for `prescale`, in order.
    fn setup(prescale: u8) -> Vec<Transaction> {
        vec![
            // Every channel full-off at once (stops pulses an awake chip is still making).
            Transaction::write(ADDR, vec![0xFD, 0x10]),
            // MODE1: SLEEP (oscillator off) with ALLCALL, so PRE_SCALE takes the write.
            Transaction::write(ADDR, vec![0x00, 0x11]),
            Transaction::write(ADDR, vec![0xFE, prescale]),
            // Wake; after 500 µs RESTART (write-1-to-clear a restart left pending).
            Transaction::write(ADDR, vec![0x00, 0x01]),
            Transaction::write(ADDR, vec![0x00, 0x81]),
            // The driver's own copy of MODE1 is brought in line (same value, no effect).
            Transaction::write(ADDR, vec![0x00, 0x01]),
        ]
    }

    /// What happened on the bus and the delay, in order.
    #[derive(Clone, Default)]
    struct Trace(Rc<RefCell<Vec<String>>>);

    /// The mock bus, noting each write in the trace.
    struct TracedBus {
        bus: Mock,
        trace: Trace,
    }

    impl ErrorType for TracedBus {
        type Error = embedded_hal::i2c::ErrorKind;
    }

    impl I2c for TracedBus {
        fn transaction(
            &mut self,
            address: u8,
            operations: &mut [Operation<'_>],
        ) -> Result<(), Self::Error> {
            // The set-up makes single writes only; anything else fails the test.
            for op in operations.iter_mut() {
                let Operation::Write(bytes) = op else {
                    panic!("unexpected read at {address:#04x}");
                };
                self.trace
                    .0
                    .borrow_mut()
                    .push(format!("write {bytes:02x?}"));
                self.bus.write(address, bytes)?;
            }
            Ok(())
        }
    }

    impl DelayNs for Trace {
        fn delay_ns(&mut self, ns: u32) {
            self.0.borrow_mut().push(format!("wait {ns} ns"));
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
    fn setup_turns_every_channel_off_and_sleeps_before_the_prescaler() {
        // Whatever state the chip is in (power-up: asleep, channels off; a reopen or a restart
        // of the application: awake, last pulses running), every channel is turned off and
        // the oscillator stopped before PRE_SCALE is written; then the chip wakes and RESTART
        // is written.
        let mut bus = Mock::new(&setup(23));
        let out = Pca9685Output::new(bus.clone(), &config(250), &mut Trace::default()).unwrap();
        assert!((out.frequency_hz() - 254.3).abs() < 0.1);
        out.release();
        bus.done();
    }

    #[test]
    fn restart_waits_500_us_after_the_wake_up() {
        let trace = Trace::default();
        let mut mock = Mock::new(&setup(121));
        let bus = TracedBus {
            bus: mock.clone(),
            trace: trace.clone(),
        };
        let out = Pca9685Output::new(bus, &config(50), &mut trace.clone()).unwrap();
        drop(out.release());
        mock.done();
        let steps = trace.0.borrow().clone();
        assert_eq!(
            steps,
            [
                "write [fd, 10]",
                "write [00, 11]",
                "write [fe, 79]",
                "write [00, 01]",
                "wait 500000 ns",
                "write [00, 81]",
                "write [00, 01]",
            ]
        );
    }

    #[test]
    fn a_bad_address_is_refused_before_any_write() {
        let mut bus = Mock::new(&[]);
        let bad = Pca9685Config {
            address: 0x70, // the all-call address
            ..config(50)
        };
        assert!(Pca9685Output::new(bus.clone(), &bad, &mut Trace::default()).is_err());
        bus.done();
    }

    #[test]
    fn targets_are_one_write_per_channel_and_zero_is_full_off() {
        let mut expected = setup(121);
        expected.extend([
            // Auto-increment on (MODE1 AI), then channel 0: ON = 0, OFF = 307 (0x133).
            Transaction::write(ADDR, vec![0x00, 0x21]),
            Transaction::write(ADDR, vec![0x06, 0x00, 0x00, 0x33, 0x01]),
            // Channel 1 at 1545 µs: 316.6 -> 317 counts (0x13D), registers at 0x0A.
            Transaction::write(ADDR, vec![0x0A, 0x00, 0x00, 0x3D, 0x01]),
            // Channel 15, no pulses: full-off bit in LED15_OFF_H (0x45).
            Transaction::write(ADDR, vec![0x44, 0x00, 0x10]),
        ]);
        let mut bus = Mock::new(&expected);
        let mut out = Pca9685Output::new(bus.clone(), &config(50), &mut Trace::default()).unwrap();
        out.write_targets(&[0, 1, 15], &[1_500 * 4, 1_545 * 4, 0], u64::MAX)
            .unwrap();
        out.release();
        bus.done();
    }

    #[test]
    fn a_bus_error_is_a_device_failure_and_a_bad_channel_is_refused() {
        let mut expected = setup(121);
        expected.push(
            Transaction::write(ADDR, vec![0x00, 0x21])
                .with_error(embedded_hal::i2c::ErrorKind::Other),
        );
        let mut bus = Mock::new(&expected);
        let mut out = Pca9685Output::new(bus.clone(), &config(50), &mut Trace::default()).unwrap();
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

    #[test]
    fn a_bus_error_during_setup_fails_the_open() {
        let mut expected = setup(121);
        expected.truncate(2);
        expected[1] = Transaction::write(ADDR, vec![0x00, 0x11])
            .with_error(embedded_hal::i2c::ErrorKind::Other);
        let mut bus = Mock::new(&expected);
        assert!(matches!(
            Pca9685Output::new(bus.clone(), &config(50), &mut Trace::default()),
            Err(pwm_pca9685::Error::I2C(_))
        ));
        bus.done();
    }
}
