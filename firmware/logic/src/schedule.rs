//! The sampling schedule: which sensor is read on which tick of the sampling timer.
//!
//! The timer ticks every [`ScheduleConfig::period_us`] (1 ms by default). On every tick the
//! accelerometer and the gyroscope are read and a packet is published. The magnetometer runs in
//! forced mode: a measurement is triggered, its data-ready flag is polled on the following
//! ticks, and the data are read only once ready (the original read right after triggering and
//! so sent data one request old); a measurement that never becomes ready is counted and
//! retriggered. The BMP280 measures continuously in normal mode and is read every
//! [`ScheduleConfig::baro_every`] ticks.

/// Sampling schedule settings, in ticks of the sampling timer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScheduleConfig {
    /// Tick period in microseconds (the accelerometer/gyroscope sampling period).
    pub period_us: u32,
    /// Ticks from one magnetometer trigger to the next (10 = 100 Hz at 1 ms ticks).
    pub mag_every: u16,
    /// Ticks after a trigger without data-ready before the measurement is given up and counted.
    pub mag_timeout: u16,
    /// Ticks between two BMP280 reads (its normal mode at x1/x1 and t_sb 0.5 ms gives a new
    /// result about every 6 ms; reading more often just repeats it).
    pub baro_every: u16,
}

impl ScheduleConfig {
    /// The DIMA settings: 1 kHz accelerometer and gyroscope, 100 Hz magnetometer, BMP280 read
    /// at 200 Hz.
    pub const DEFAULT: Self = Self {
        period_us: 1000,
        mag_every: 10,
        mag_timeout: 50,
        baro_every: 5,
    };

    /// Sampling rate in hertz.
    #[must_use]
    pub const fn rate_hz(&self) -> u32 {
        1_000_000 / self.period_us
    }
}

impl Default for ScheduleConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// What to do with the magnetometer on this tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MagAction {
    /// Nothing this tick.
    None,
    /// Start a forced-mode measurement.
    Trigger,
    /// Check data-ready; if set, read the data. Report the result with
    /// [`Schedule::mag_polled`].
    Poll,
}

/// The work of one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TickPlan {
    /// Read the accelerometer and the gyroscope.
    pub read_inertial: bool,
    /// Magnetometer step.
    pub mag: MagAction,
    /// Read the BMP280 result registers.
    pub read_baro: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MagPhase {
    /// Waiting for the next trigger slot, `ticks` since the last trigger.
    Waiting { ticks: u16 },
    /// Triggered `ticks` ago, data not ready yet.
    Measuring { ticks: u16 },
}

/// The sampling schedule state.
#[derive(Debug, Clone)]
pub struct Schedule {
    config: ScheduleConfig,
    tick: u32,
    mag: MagPhase,
    mag_timeouts: u32,
}

impl Schedule {
    /// A schedule that triggers the magnetometer on its first tick.
    #[must_use]
    pub const fn new(config: ScheduleConfig) -> Self {
        let mag_every = if config.mag_every == 0 {
            1
        } else {
            config.mag_every
        };
        Self {
            config: ScheduleConfig {
                mag_every,
                ..config
            },
            tick: 0,
            mag: MagPhase::Waiting { ticks: mag_every },
            mag_timeouts: 0,
        }
    }

    /// The settings in use.
    #[must_use]
    pub const fn config(&self) -> &ScheduleConfig {
        &self.config
    }

    /// Plans the next tick and advances the schedule.
    pub fn next_tick(&mut self) -> TickPlan {
        let baro_every = u32::from(self.config.baro_every.max(1));
        let read_baro = self.tick.is_multiple_of(baro_every);
        self.tick = self.tick.wrapping_add(1);

        let mag = match self.mag {
            MagPhase::Waiting { ticks } if ticks >= self.config.mag_every => {
                self.mag = MagPhase::Measuring { ticks: 0 };
                MagAction::Trigger
            }
            MagPhase::Waiting { ticks } => {
                self.mag = MagPhase::Waiting { ticks: ticks + 1 };
                MagAction::None
            }
            MagPhase::Measuring { ticks } if ticks >= self.config.mag_timeout => {
                // Never became ready: count it and trigger again.
                self.mag_timeouts = self.mag_timeouts.wrapping_add(1);
                self.mag = MagPhase::Measuring { ticks: 0 };
                MagAction::Trigger
            }
            MagPhase::Measuring { ticks } => {
                self.mag = MagPhase::Measuring { ticks: ticks + 1 };
                MagAction::Poll
            }
        };

        TickPlan {
            read_inertial: true,
            mag,
            read_baro,
        }
    }

    /// Reports the result of a [`MagAction::Poll`]: `ready` if the data were ready and read.
    pub fn mag_polled(&mut self, ready: bool) {
        if let (true, MagPhase::Measuring { ticks }) = (ready, self.mag) {
            // `ticks` counts the polls since the trigger, the trigger tick itself included.
            self.mag = MagPhase::Waiting { ticks: ticks + 1 };
        }
    }

    /// Magnetometer measurements that never became ready.
    #[must_use]
    pub fn mag_timeouts(&self) -> u32 {
        self.mag_timeouts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_one_kilohertz() {
        assert_eq!(ScheduleConfig::default().rate_hz(), 1000);
    }

    #[test]
    fn inertial_sensors_are_read_every_tick() {
        let mut schedule = Schedule::new(ScheduleConfig::DEFAULT);
        for _ in 0..100 {
            assert!(schedule.next_tick().read_inertial);
        }
    }

    #[test]
    fn baro_is_read_every_fifth_tick() {
        let mut schedule = Schedule::new(ScheduleConfig::DEFAULT);
        let reads: [bool; 11] = core::array::from_fn(|_| schedule.next_tick().read_baro);
        assert_eq!(
            reads,
            [true, false, false, false, false, true, false, false, false, false, true]
        );
    }

    #[test]
    fn mag_triggers_then_polls_until_ready_then_waits_for_the_slot() {
        let mut schedule = Schedule::new(ScheduleConfig::DEFAULT);
        assert_eq!(schedule.next_tick().mag, MagAction::Trigger); // tick 0
        assert_eq!(schedule.next_tick().mag, MagAction::Poll); // tick 1
        schedule.mag_polled(false);
        assert_eq!(schedule.next_tick().mag, MagAction::Poll); // tick 2
        schedule.mag_polled(false);
        assert_eq!(schedule.next_tick().mag, MagAction::Poll); // tick 3
        schedule.mag_polled(true);
        // Ticks 4..=9 wait, tick 10 triggers again: one trigger every 10 ticks.
        for tick in 4..10 {
            assert_eq!(schedule.next_tick().mag, MagAction::None, "tick {tick}");
        }
        assert_eq!(schedule.next_tick().mag, MagAction::Trigger);
        assert_eq!(schedule.mag_timeouts(), 0);
    }

    #[test]
    fn slow_mag_is_read_once_ready_and_retriggered_right_away() {
        let config = ScheduleConfig {
            mag_every: 3,
            ..ScheduleConfig::DEFAULT
        };
        let mut schedule = Schedule::new(config);
        assert_eq!(schedule.next_tick().mag, MagAction::Trigger);
        for _ in 0..5 {
            assert_eq!(schedule.next_tick().mag, MagAction::Poll);
            schedule.mag_polled(false);
        }
        assert_eq!(schedule.next_tick().mag, MagAction::Poll);
        schedule.mag_polled(true);
        // The slot has long passed: trigger on the next tick.
        assert_eq!(schedule.next_tick().mag, MagAction::Trigger);
    }

    #[test]
    fn a_mag_that_never_answers_is_counted_and_retriggered() {
        let config = ScheduleConfig {
            mag_timeout: 4,
            ..ScheduleConfig::DEFAULT
        };
        let mut schedule = Schedule::new(config);
        let actions: [MagAction; 11] = core::array::from_fn(|_| {
            let action = schedule.next_tick().mag;
            if action == MagAction::Poll {
                schedule.mag_polled(false);
            }
            action
        });
        use MagAction::{Poll, Trigger};
        assert_eq!(
            actions,
            [Trigger, Poll, Poll, Poll, Poll, Trigger, Poll, Poll, Poll, Poll, Trigger]
        );
        assert_eq!(schedule.mag_timeouts(), 2);
    }

    #[test]
    fn ready_report_outside_a_measurement_is_ignored() {
        let mut schedule = Schedule::new(ScheduleConfig::DEFAULT);
        schedule.mag_polled(true);
        assert_eq!(schedule.next_tick().mag, MagAction::Trigger);
    }

    #[test]
    fn zero_settings_do_not_divide_by_zero() {
        let config = ScheduleConfig {
            period_us: 1000,
            mag_every: 0,
            mag_timeout: 0,
            baro_every: 0,
        };
        let mut schedule = Schedule::new(config);
        for _ in 0..10 {
            let plan = schedule.next_tick();
            assert!(plan.read_baro);
        }
    }
}
