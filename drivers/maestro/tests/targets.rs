//! The sans-IO checked target encoder (the per-cycle path of an application).

use pololu_maestro::{
    Channel, ChannelLimits, Error, Framing, Limits, Micro6, Mini12, QuarterMicros, TargetEncoder,
    TargetError,
};

fn us(v: u16) -> QuarterMicros {
    QuarterMicros::from_micros(v).unwrap()
}

fn dima() -> TargetEncoder<Micro6> {
    let ch = |n| Channel::new::<Micro6>(n).unwrap();
    TargetEncoder::new(Micro6, Framing::COMPACT).with_limits(
        Limits::new()
            .with(ch(0), ChannelLimits::from_micros(1000, 2000, 1500).unwrap())
            .with(ch(1), ChannelLimits::from_micros(1250, 1840, 1545).unwrap())
            .with(ch(2), ChannelLimits::from_micros(1000, 2000, 1500).unwrap()),
    )
}

// Targets of the DIMA car's three channels: throttle 1500 µs, steering 1840 µs, tail 2000 µs.
#[test]
fn dima_cycle_frame() {
    let ch = |n| Channel::new::<Micro6>(n).unwrap();
    let frame = dima()
        .encode_targets(&[(ch(0), us(1500)), (ch(1), us(1840)), (ch(2), us(2000))])
        .unwrap();
    assert_eq!(
        &*frame,
        &[0x84, 0x00, 0x70, 0x2E, 0x84, 0x01, 0x40, 0x39, 0x84, 0x02, 0x40, 0x3E]
    );
    assert_eq!(
        &*dima().encode_target(ch(1), us(1840)).unwrap(),
        &[0x84, 0x01, 0x40, 0x39]
    );
    assert_eq!(
        &*dima().encode_stop_pulses(ch(0)).unwrap(),
        &[0x84, 0x00, 0x00, 0x00]
    );
}

#[test]
fn refusals() {
    let ch = |n| Channel::new::<Micro6>(n).unwrap();
    assert_eq!(
        dima().encode_target(ch(1), us(1841)),
        Err(TargetError::OutOfRange {
            channel: 1,
            target: 7364,
            min: 5000,
            max: 7360
        })
    );
    let big = Channel::new::<Mini12>(7).unwrap();
    assert_eq!(
        dima().encode_targets(&[(ch(0), us(1500)), (big, us(1500))]),
        Err(TargetError::InvalidChannel {
            channel: 7,
            channels: 6
        })
    );
    // 25 targets do not fit any Maestro.
    let many = [(ch(0), us(1500)); 25];
    assert_eq!(dima().encode_targets(&many), Err(TargetError::InvalidInput));
    // Converts into the driver error.
    let e: Error<()> = TargetError::InvalidInput.into();
    assert_eq!(e, Error::Target(pololu_maestro::TargetError::InvalidInput));
}

#[test]
fn mini_multiple_targets() {
    let ch = |n| Channel::new::<Mini12>(n).unwrap();
    let enc = TargetEncoder::new(Mini12, Framing::COMPACT);
    // Pololu guide: Set Multiple Targets ch 3 = 0, ch 4 = 6000 -> 9F 02 03 00 00 70 2E
    assert_eq!(
        &*enc
            .encode_multiple_targets(
                ch(3),
                &[
                    QuarterMicros::new(0).unwrap(),
                    QuarterMicros::new(6000).unwrap()
                ]
            )
            .unwrap(),
        &[0x9F, 0x02, 0x03, 0x00, 0x00, 0x70, 0x2E]
    );
    assert_eq!(
        enc.encode_multiple_targets(ch(11), &[us(1500), us(1500)]),
        Err(TargetError::InvalidChannel {
            channel: 12,
            channels: 12
        })
    );
    assert_eq!(
        enc.encode_multiple_targets(ch(0), &[]),
        Err(TargetError::InvalidInput)
    );
}

mod properties {
    use super::*;
    use pololu_maestro::{Command, CommandDecoder, DecoderConfig, MAX_14_BIT};
    use proptest::prelude::*;

    proptest! {
        /// Whatever the limits and targets, the encoder either refuses or produces bytes that
        /// a Maestro decodes to exactly the requested, in-range targets.
        #[test]
        fn never_encodes_an_out_of_range_target(
            bounds in prop::collection::vec((0u16..=MAX_14_BIT, 0u16..=MAX_14_BIT), 6),
            requests in prop::collection::vec((0u8..6, 0u16..=MAX_14_BIT), 0..12),
            crc: bool,
        ) {
            let ch = |n| Channel::new::<Micro6>(n).unwrap();
            let q = |v| QuarterMicros::new(v).unwrap();
            let mut limits = Limits::new();
            for (i, &(a, b)) in bounds.iter().enumerate() {
                let (lo, hi) = (a.min(b), a.max(b));
                limits.set(ch(i as u8), ChannelLimits::new(q(lo), q(hi), q(lo)).ok());
            }
            let framing = Framing::COMPACT.with_crc(crc);
            let encoder = TargetEncoder::new(Micro6, framing).with_limits(limits);
            let targets: Vec<_> = requests.iter().map(|&(c, t)| (ch(c), q(t))).collect();
            let in_range = targets
                .iter()
                .all(|&(c, t)| limits.get(c).unwrap().contains(t));
            match encoder.encode_targets(&targets) {
                Ok(frame) => {
                    prop_assert!(in_range);
                    let mut maestro = CommandDecoder::new(DecoderConfig { crc, ..Default::default() });
                    let decoded: Vec<_> = maestro
                        .decode(&frame)
                        .map(|c| match c {
                            Command::SetTarget { channel, target } => (channel, target),
                            other => panic!("unexpected {other:?}"),
                        })
                        .collect();
                    prop_assert_eq!(decoded, targets);
                }
                Err(TargetError::OutOfRange { .. }) => prop_assert!(!in_range),
                Err(other) => prop_assert!(false, "unexpected {:?}", other),
            }
        }
    }
}
