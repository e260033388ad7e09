//! The status LED pattern.
//!
//! A sensor that never answered at boot must not hang the board; it is reported in the info
//! frame's status bits and on the status LED. The pattern repeats forever: one blink per sensor
//! in the order accelerometer, gyroscope, magnetometer, BMP280, short if the sensor answered and
//! long if it did not, then a pause. With every sensor present the LED gives four short blinks.
//!
//! A second group follows with the outcome of the NEO-M8T configuration at boot ([`gnss`]):
//! nothing while it runs, one short blink when the receiver acknowledged everything, one long
//! blink for an ACK-NAK, two long blinks for a timeout or a failed port, then a pause (nothing
//! at all when the firmware was built without boot-time configuration).

/// Status bit of the accelerometer (bit 0 of the info frame's status byte).
pub const ACCEL_OK: u8 = 1 << 0;
/// Status bit of the gyroscope.
pub const GYRO_OK: u8 = 1 << 1;
/// Status bit of the magnetometer.
pub const MAG_OK: u8 = 1 << 2;
/// Status bit of the BMP280.
pub const BARO_OK: u8 = 1 << 3;
/// Status bit: at least one checksum-valid GNSS frame was received.
pub const GNSS_SEEN: u8 = 1 << 4;
/// Status bit: the last reset was caused by the independent watchdog.
pub const WATCHDOG_RESET: u8 = 1 << 5;

/// On time of a blink for a sensor that answered, in milliseconds.
pub const SHORT_MS: u32 = 100;
/// On time of a blink for a sensor that did not answer, in milliseconds.
pub const LONG_MS: u32 = 600;
/// Off time between blinks, in milliseconds.
pub const GAP_MS: u32 = 300;
/// Off time after the fourth blink, in milliseconds.
pub const PAUSE_MS: u32 = 1500;

/// One blink: LED on for `on_ms`, then off for `off_ms`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Blink {
    /// On time in milliseconds.
    pub on_ms: u32,
    /// Off time in milliseconds.
    pub off_ms: u32,
}

/// The four blinks of one round of the pattern for the given status bits.
#[must_use]
pub fn pattern(status: u8) -> [Blink; 4] {
    let bits = [ACCEL_OK, GYRO_OK, MAG_OK, BARO_OK];
    core::array::from_fn(|i| Blink {
        on_ms: if status & bits[i] != 0 {
            SHORT_MS
        } else {
            LONG_MS
        },
        off_ms: if i == 3 { PAUSE_MS } else { GAP_MS },
    })
}

/// The blinks after the sensor group for the GNSS configuration outcome. A blink with
/// `on_ms == 0` is not shown (and takes no time when its `off_ms` is 0 too).
#[must_use]
pub fn gnss(outcome: crate::gnss_setup::Outcome) -> [Blink; 2] {
    use crate::gnss_setup::Outcome;
    const NONE: Blink = Blink {
        on_ms: 0,
        off_ms: 0,
    };
    let last = |on_ms| Blink {
        on_ms,
        off_ms: PAUSE_MS,
    };
    match outcome {
        Outcome::Pending | Outcome::Skipped => [NONE, NONE],
        Outcome::Configured => [last(SHORT_MS), NONE],
        Outcome::Nak => [last(LONG_MS), NONE],
        Outcome::Timeout | Outcome::Failed => [
            Blink {
                on_ms: LONG_MS,
                off_ms: GAP_MS,
            },
            last(LONG_MS),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_bits_follow_the_info_frame_contract() {
        assert_eq!(
            [
                ACCEL_OK,
                GYRO_OK,
                MAG_OK,
                BARO_OK,
                GNSS_SEEN,
                WATCHDOG_RESET
            ],
            [0x01, 0x02, 0x04, 0x08, 0x10, 0x20]
        );
    }

    #[test]
    fn all_sensors_present_gives_four_short_blinks() {
        let round = pattern(0x0F);
        assert!(round.iter().all(|blink| blink.on_ms == SHORT_MS));
        assert_eq!(round[3].off_ms, PAUSE_MS);
        assert_eq!(round[0].off_ms, GAP_MS);
    }

    #[test]
    fn a_missing_magnetometer_gives_a_long_third_blink() {
        let on: [u32; 4] = pattern(ACCEL_OK | GYRO_OK | BARO_OK | GNSS_SEEN).map(|b| b.on_ms);
        assert_eq!(on, [SHORT_MS, SHORT_MS, LONG_MS, SHORT_MS]);
    }

    #[test]
    fn gnss_outcome_blinks() {
        use crate::gnss_setup::Outcome;
        let shown = |outcome| {
            gnss(outcome)
                .iter()
                .filter(|b| b.on_ms > 0)
                .map(|b| b.on_ms)
                .collect::<heapless::Vec<u32, 2>>()
        };
        assert!(shown(Outcome::Pending).is_empty());
        assert!(shown(Outcome::Skipped).is_empty());
        assert_eq!(shown(Outcome::Configured).as_slice(), &[SHORT_MS]);
        assert_eq!(shown(Outcome::Nak).as_slice(), &[LONG_MS]);
        assert_eq!(shown(Outcome::Timeout).as_slice(), &[LONG_MS, LONG_MS]);
        assert_eq!(shown(Outcome::Failed).as_slice(), &[LONG_MS, LONG_MS]);
        assert_eq!(
            gnss(Outcome::Pending),
            [Blink {
                on_ms: 0,
                off_ms: 0
            }; 2]
        );
        // A group that shows anything ends in the pause.
        for outcome in [Outcome::Configured, Outcome::Nak, Outcome::Timeout] {
            let total_off: u32 = gnss(outcome).iter().map(|b| b.off_ms).sum();
            assert!(total_off >= PAUSE_MS);
        }
    }
}
