//! Checked value types and per-channel limits.

use pololu_maestro::{
    Channel, ChannelLimits, Deadline, DelayDeadline, DeviceNumber, InvalidInput, Limits, Micro6,
    Mini18, Mini24, MiniSscValue, Model, PwmTiming, QuarterMicros, ScriptParameter, Speed,
    Subroutine,
};

#[test]
fn quarter_micros_conversions() {
    assert_eq!(QuarterMicros::from_micros(1500).unwrap().get(), 6000);
    assert_eq!(QuarterMicros::from_micros(4095).unwrap().get(), 16380);
    assert!(QuarterMicros::from_micros(4096).is_err());
    assert!(QuarterMicros::new(16384).is_err());
    assert_eq!(QuarterMicros::new(16383).unwrap(), QuarterMicros::MAX);
    // 1500.1 µs rounds to 6000, 1500.2 µs to 6001 quarter-µs.
    assert_eq!(QuarterMicros::from_nanos(1_500_100).unwrap().get(), 6000);
    assert_eq!(QuarterMicros::from_nanos(1_500_200).unwrap().get(), 6001);
    assert!(QuarterMicros::from_nanos(4_095_900).is_err());
    assert_eq!(QuarterMicros::new(7361).unwrap().as_micros(), 1840);
}

#[test]
fn channel_counts() {
    assert_eq!(
        [
            Micro6::CHANNELS,
            pololu_maestro::Mini12::CHANNELS,
            Mini18::CHANNELS,
            Mini24::CHANNELS
        ],
        [6, 12, 18, 24]
    );
    assert!(Channel::new::<Micro6>(5).is_ok());
    assert!(Channel::new::<Micro6>(6).is_err());
    assert!(Channel::new::<Mini18>(17).is_ok());
    assert!(Channel::new::<Mini18>(18).is_err());
    assert!(Channel::any_model(23).is_ok());
    assert!(Channel::any_model(24).is_err());
}

#[test]
fn other_ranges() {
    assert!(Speed::new(16383).is_ok() && Speed::new(16384).is_err());
    assert!(ScriptParameter::new(16383).is_ok() && ScriptParameter::new(16384).is_err());
    assert!(Subroutine::new(127).is_ok() && Subroutine::new(128).is_err());
    assert!(DeviceNumber::new(127).is_ok() && DeviceNumber::new(128).is_err());
    assert!(MiniSscValue::new(254).is_ok() && MiniSscValue::new(255).is_err());
    assert!(PwmTiming::new(10, 10).is_ok());
    assert!(PwmTiming::new(11, 10).is_err());
    assert!(PwmTiming::new(0, 16384).is_err());
}

#[test]
fn limits_check_and_clamp() {
    let steering = Channel::new::<Micro6>(1).unwrap();
    let other = Channel::new::<Micro6>(3).unwrap();
    let l = ChannelLimits::from_micros(1250, 1840, 1545).unwrap();
    let limits = Limits::new().with(steering, l);
    let us = |v| QuarterMicros::from_micros(v).unwrap();

    assert!(limits.check(steering, us(1250)).is_ok());
    assert!(limits.check(steering, us(1840)).is_ok());
    let err = limits.check(steering, us(1841)).unwrap_err();
    assert_eq!(
        (err.channel, err.target, err.limits),
        (steering, us(1841), l)
    );
    assert!(limits.check(steering, us(1249)).is_err());
    assert!(limits.check(steering, QuarterMicros::OFF).is_err());
    // Channels without limits accept anything.
    assert!(limits.check(other, QuarterMicros::MAX).is_ok());

    assert_eq!(limits.clamp(steering, us(2000)), us(1840));
    assert_eq!(limits.clamp(steering, us(1000)), us(1250));
    assert_eq!(limits.clamp(steering, us(1500)), us(1500));
    assert_eq!(limits.neutral(steering), Some(us(1545)));
    assert_eq!(limits.neutral(other), None);

    assert!(ChannelLimits::from_micros(1500, 1000, 1200) == Err(InvalidInput));
    assert!(ChannelLimits::from_micros(1000, 2000, 2500) == Err(InvalidInput));
    assert!(ChannelLimits::from_micros(1000, 5000, 1500) == Err(InvalidInput));

    let mut limits = limits;
    limits.set(steering, None);
    assert!(limits.check(steering, us(2500)).is_ok());
}

struct CountingDelay(u64);

impl embedded_hal::delay::DelayNs for CountingDelay {
    fn delay_ns(&mut self, ns: u32) {
        self.0 += u64::from(ns);
    }
}

#[test]
fn delay_deadline_counts_time() {
    let mut delay = CountingDelay(0);
    let mut deadline = DelayDeadline::new(&mut delay, 1000, 300);
    let mut polls = 0;
    while !deadline.expired() {
        polls += 1;
    }
    // 300 + 300 + 300 + 100 µs.
    assert_eq!(polls, 4);
    assert_eq!(delay.0, 1_000_000);
}
