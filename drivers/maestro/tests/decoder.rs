//! Device-side decoder: encode -> decode round trips, resynchronisation, CRC, counters.

use pololu_maestro::{
    crc7, encode, join_14, split_14, Acceleration, Channel, Command, CommandDecoder, DecoderConfig,
    DeviceNumber, ErrorFlags, Framing, MiniSscServo, MiniSscValue, MultiTargets, PwmTiming,
    QuarterMicros, ScriptParameter, Speed, Subroutine, MAX_14_BIT,
};
use proptest::prelude::*;

fn channel() -> impl Strategy<Value = Channel> {
    (0u8..24).prop_map(|c| Channel::any_model(c).unwrap())
}

fn target() -> impl Strategy<Value = QuarterMicros> {
    (0u16..=MAX_14_BIT).prop_map(|t| QuarterMicros::new(t).unwrap())
}

fn command() -> impl Strategy<Value = Command> {
    prop_oneof![
        (channel(), target()).prop_map(|(channel, target)| Command::SetTarget { channel, target }),
        (0u8..24)
            .prop_flat_map(|first| (
                Just(first),
                prop::collection::vec(target(), 1..=(24 - first as usize))
            ))
            .prop_map(|(first, targets)| Command::SetMultipleTargets(
                MultiTargets::new(Channel::any_model(first).unwrap(), &targets).unwrap()
            )),
        (channel(), 0u16..=MAX_14_BIT).prop_map(|(channel, s)| Command::SetSpeed {
            channel,
            speed: Speed::new(s).unwrap()
        }),
        (channel(), any::<u8>()).prop_map(|(channel, a)| Command::SetAcceleration {
            channel,
            acceleration: Acceleration::new(a)
        }),
        (0u16..=MAX_14_BIT)
            .prop_flat_map(|period| (0..=period, Just(period)))
            .prop_map(|(on, period)| Command::SetPwm(PwmTiming::new(on, period).unwrap())),
        channel().prop_map(|channel| Command::GetPosition { channel }),
        Just(Command::GetMovingState),
        Just(Command::GetErrors),
        Just(Command::GoHome),
        Just(Command::StopScript),
        (0u8..=127).prop_map(|s| Command::RestartScript(Subroutine::new(s).unwrap())),
        (0u8..=127, 0u16..=MAX_14_BIT).prop_map(|(s, p)| Command::RestartScriptWithParameter {
            subroutine: Subroutine::new(s).unwrap(),
            parameter: ScriptParameter::new(p).unwrap()
        }),
        Just(Command::GetScriptStatus),
        (0u8..=254, 0u8..=254).prop_map(|(s, v)| Command::MiniSsc {
            servo: MiniSscServo::new(s).unwrap(),
            value: MiniSscValue::new(v).unwrap()
        }),
    ]
}

fn framing() -> impl Strategy<Value = Framing> {
    (any::<bool>(), any::<bool>(), 0u8..=127).prop_map(|(pololu, crc, device)| {
        let f = if pololu {
            Framing::pololu(DeviceNumber::new(device).unwrap())
        } else {
            Framing::COMPACT
        };
        f.with_crc(crc)
    })
}

fn decoder_for(framing: Framing) -> CommandDecoder {
    let device = match framing.protocol {
        pololu_maestro::Protocol::Pololu(d) => d,
        pololu_maestro::Protocol::Compact => DeviceNumber::DEFAULT,
    };
    CommandDecoder::new(DecoderConfig {
        device,
        crc: framing.crc,
    })
}

proptest! {
    #[test]
    fn seven_bit_encoding_round_trips(value in 0u16..=MAX_14_BIT) {
        let [low, high] = split_14(value);
        prop_assert!(low < 0x80 && high < 0x80);
        prop_assert_eq!(join_14(low, high), value);
    }

    #[test]
    fn quarter_micros_accepts_exactly_14_bits(value: u16) {
        prop_assert_eq!(QuarterMicros::new(value).is_ok(), value <= MAX_14_BIT);
    }

    #[test]
    fn packets_have_one_command_byte(cmd in command(), framing in framing()) {
        let packet = encode(&cmd, framing);
        prop_assert!(packet[0] & 0x80 != 0);
        if !matches!(cmd, Command::MiniSsc { .. }) {
            prop_assert!(packet[1..].iter().all(|b| b & 0x80 == 0));
            if framing.crc {
                let (body, crc) = packet.split_at(packet.len() - 1);
                prop_assert_eq!(crc[0], crc7(body));
            }
        }
    }

    #[test]
    fn encode_decode_round_trip(cmd in command(), framing in framing()) {
        let mut decoder = decoder_for(framing);
        let packet = encode(&cmd, framing);
        let decoded: Vec<Command> = decoder.decode(&packet).collect();
        prop_assert_eq!(decoded, vec![cmd]);
        let stats = decoder.stats();
        prop_assert_eq!(stats.dropped_bytes, 0);
        prop_assert_eq!(stats.invalid_packets, 0);
        prop_assert_eq!(decoder.take_errors(), ErrorFlags::empty());
    }

    /// Data-byte garbage between packets is dropped, counted, and costs no command.
    #[test]
    fn data_byte_garbage_is_skipped(
        items in prop::collection::vec((prop::collection::vec(0u8..0x80, 0..8), command()), 1..10),
        framing in framing(),
    ) {
        let mut decoder = decoder_for(framing);
        let mut stream = Vec::new();
        let mut garbage = 0u32;
        for (junk, cmd) in &items {
            stream.extend_from_slice(junk);
            garbage += junk.len() as u32;
            stream.extend_from_slice(&encode(cmd, framing));
        }
        let decoded: Vec<Command> = decoder.decode(&stream).collect();
        let expected: Vec<Command> = items.into_iter().map(|(_, c)| c).collect();
        prop_assert_eq!(decoded, expected);
        prop_assert_eq!(decoder.stats().dropped_bytes, garbage);
    }

    /// After any garbage (without 0xFF, which opens an 8-bit Mini SSC packet), the next
    /// command is decoded: resynchronisation costs at most the interrupted packet.
    #[test]
    fn resynchronises_after_arbitrary_garbage(
        junk in prop::collection::vec(0u8..0xFF, 0..64),
        cmd in command().prop_filter("not Mini SSC", |c| !matches!(c, Command::MiniSsc { .. })),
        framing in framing(),
    ) {
        let mut decoder = decoder_for(framing);
        let _ = decoder.decode(&junk).count();
        let decoded: Vec<Command> = decoder.decode(&encode(&cmd, framing)).collect();
        prop_assert_eq!(decoded, vec![cmd]);
    }

    #[test]
    fn never_panics(bytes in prop::collection::vec(any::<u8>(), 0..512), crc: bool, device in 0u8..=127) {
        let mut decoder = CommandDecoder::new(DecoderConfig {
            device: DeviceNumber::new(device).unwrap(),
            crc,
        });
        let n = decoder.decode(&bytes).count() as u32;
        prop_assert_eq!(decoder.stats().commands, n);
        prop_assert!(decoder.stats().dropped_bytes as usize <= bytes.len());
    }

    /// A single-bit error in a data or CRC byte fails the CRC and the packet is dropped, not decoded wrongly.
    #[test]
    fn crc_rejects_a_corrupted_byte(
        cmd in command().prop_filter("has data", |c| {
            !matches!(c, Command::MiniSsc { .. }) && encode(c, Framing::COMPACT).len() > 1
        }),
        flip in 0u8..7,
        index: prop::sample::Index,
    ) {
        let framing = Framing::COMPACT.with_crc(true);
        let mut packet = encode(&cmd, framing).to_vec();
        let i = 1 + index.index(packet.len() - 1);
        // The count of Set Multiple Targets sets the packet length: a flip there makes the
        // packet wait for more bytes instead (covered by the resynchronisation tests).
        prop_assume!(!(matches!(cmd, Command::SetMultipleTargets(_)) && i == 1));
        packet[i] ^= 1 << flip;
        let mut decoder = decoder_for(framing);
        let decoded: Vec<Command> = decoder.decode(&packet).collect();
        prop_assert!(decoded.is_empty());
        let stats = decoder.stats();
        prop_assert_eq!(stats.crc_errors + stats.invalid_packets, 1);
    }
}

#[test]
fn interrupted_packet_is_a_protocol_error() {
    let mut d = CommandDecoder::new(DecoderConfig::default());
    // Set Target cut after the channel, then a complete Get Errors.
    let out: Vec<Command> = d.decode(&[0x84, 0x02, 0x70, 0xA1]).collect();
    assert_eq!(out, vec![Command::GetErrors]);
    let s = d.stats();
    assert_eq!((s.dropped_bytes, s.invalid_packets), (3, 1));
    assert_eq!(d.take_errors(), ErrorFlags::SERIAL_PROTOCOL);
    assert_eq!(d.take_errors(), ErrorFlags::empty());
}

#[test]
fn wrong_crc_is_counted() {
    let mut d = CommandDecoder::new(DecoderConfig {
        device: DeviceNumber::DEFAULT,
        crc: true,
    });
    // Pololu guide: CRC-7 of 84 02 70 2E is 18; 19 is wrong.
    assert_eq!(d.decode(&[0x84, 0x02, 0x70, 0x2E, 0x19]).count(), 0);
    assert_eq!(d.stats().crc_errors, 1);
    assert_eq!(d.take_errors(), ErrorFlags::SERIAL_CRC);
    assert_eq!(
        d.decode(&[0x84, 0x02, 0x70, 0x2E, 0x18])
            .collect::<Vec<_>>(),
        vec![Command::SetTarget {
            channel: Channel::any_model(2).unwrap(),
            target: QuarterMicros::new(6000).unwrap()
        }]
    );
}

#[test]
fn other_device_is_skipped() {
    let mut d = CommandDecoder::new(DecoderConfig::default());
    // Device 13's Set Target, then device 12's (Pololu guide example).
    let out: Vec<Command> = d
        .decode(&[
            0xAA, 0x0D, 0x04, 0x00, 0x70, 0x2E, 0xAA, 0x0C, 0x04, 0x00, 0x70, 0x2E,
        ])
        .collect();
    assert_eq!(out.len(), 1);
    let s = d.stats();
    assert_eq!(
        (s.other_device_packets, s.dropped_bytes, s.invalid_packets),
        (1, 0, 0)
    );
}

#[test]
fn unknown_command_and_bad_channel() {
    let mut d = CommandDecoder::new(DecoderConfig::default());
    // 0x80 is no command; channel 24 does not exist on any Maestro.
    assert_eq!(d.decode(&[0x80, 0x84, 0x18, 0x70, 0x2E]).count(), 0);
    assert_eq!(d.stats().invalid_packets, 2);
    assert_eq!(d.stats().dropped_bytes, 5);
}
