//! Display frames v3: round trips, and the stream decoder of both display versions on any
//! bytes (total: never a panic, never a frame from bytes the key did not tag).

use dima_groundlink::v2::{
    Actuation, ControllerCode, DisplayFrame, DisplayFrameV3, Downlink, DownlinkDecoder,
    FailsafeCause, FrameError, Health, LinkKey, RobotMode, DISPLAY_FRAME_LEN, DISPLAY_V3_FRAME_LEN,
};
use dima_groundlink::DisplayFrame as SensorPayload;
use proptest::prelude::*;

const KEY: LinkKey = LinkKey::from_bytes([0x5A; 16]);

fn actuation() -> impl Strategy<Value = Actuation> {
    (
        prop::array::uniform3(any::<u16>()),
        prop::array::uniform5(any::<Option<i32>>()),
        prop::array::uniform3(any::<u8>()),
    )
        .prop_map(|(servo_quarter_us, o, kinds)| Actuation {
            servo_quarter_us,
            speed_setpoint_mm_s: o[0],
            heading_setpoint_deg_e5: o[1],
            speed_estimate_mm_s: o[2],
            heading_estimate_deg_e5: o[3],
            speed_error_mm_s: o[4],
            controllers: kinds.map(ControllerCode::from_code),
        })
}

fn frame() -> impl Strategy<Value = DisplayFrameV3> {
    (0u8..4, any::<u8>(), any::<u32>(), any::<u32>(), actuation()).prop_map(
        |(mode, cause, session, seq, actuation)| DisplayFrameV3 {
            status: DisplayFrame {
                mode: RobotMode::from_byte(mode).unwrap(),
                failsafe_cause: FailsafeCause::from_code(cause),
                session,
                seq,
                health: Health {
                    commands: seq ^ session,
                    ..Health::default()
                },
                sensors: SensorPayload {
                    acc: [1, -2, 3],
                    ..SensorPayload::default()
                },
                ..DisplayFrame::default()
            },
            actuation,
        },
    )
}

#[test]
fn one_stream_of_both_versions_decodes_in_order() {
    let v3 = DisplayFrameV3 {
        status: DisplayFrame {
            mode: RobotMode::Failsafe,
            failsafe_cause: Some(FailsafeCause::CommsLoss),
            seq: 7,
            ..DisplayFrame::default()
        },
        actuation: Actuation {
            servo_quarter_us: [6000; 3],
            ..Actuation::default()
        },
    };
    let v2 = DisplayFrame {
        seq: 8,
        ..v3.status
    };
    let mut stream = vec![0xA5, 0x44, 3];
    stream.extend(v3.encode(&KEY));
    stream.extend(v2.encode(&KEY));
    stream.extend([0xA5, 0x46]);
    let mut decoder = DownlinkDecoder::new(KEY);
    let got: Vec<_> = decoder.feed(&stream).collect();
    assert_eq!(got, vec![Ok(Downlink::V3(v3)), Ok(Downlink::V2(v2))]);
    assert_eq!(got[1].as_ref().unwrap().actuation(), None);
    assert_eq!(got[0].as_ref().unwrap().status().seq, 7);
    let stats = decoder.stats();
    assert_eq!(stats.frames, 2);
    assert_eq!(decoder.pending(), 2);
    assert_eq!(stats.skipped_bytes, 3);
}

proptest! {
    #[test]
    fn v3_round_trip(frame in frame()) {
        prop_assert_eq!(DisplayFrameV3::decode(&frame.encode(&KEY), &KEY), Ok(frame));
    }

    #[test]
    fn v3_under_another_key_never_verifies(frame in frame(), other in any::<[u8; 16]>()) {
        let other = LinkKey::from_bytes(other);
        prop_assume!(other != KEY);
        prop_assert_eq!(
            DisplayFrameV3::decode(&frame.encode(&other), &KEY),
            Err(FrameError::BadTag)
        );
    }

    /// Any bytes: no panic, no frame (nothing is tagged), nothing lost from the count.
    #[test]
    fn downlink_decoder_is_total(
        bytes in prop::collection::vec(
            prop_oneof![any::<u8>(), Just(0xA5), Just(0x44), Just(0x46),
                        Just(DISPLAY_FRAME_LEN as u8), Just(DISPLAY_V3_FRAME_LEN as u8)],
            0..4000,
        ),
    ) {
        let mut decoder = DownlinkDecoder::new(KEY);
        prop_assert_eq!(decoder.feed(&bytes).filter(|r| r.is_ok()).count(), 0);
        prop_assert!(decoder.pending() < DISPLAY_V3_FRAME_LEN);
        let stats = decoder.stats();
        prop_assert_eq!(stats.skipped_bytes as usize + decoder.pending(), bytes.len());
    }

    /// Good frames of both versions between garbage, cut anywhere: every one comes out, in
    /// order.
    #[test]
    fn frames_of_both_versions_survive_garbage(
        items in prop::collection::vec(
            (frame(), any::<bool>(), prop::collection::vec(any::<u8>(), 0..40)),
            1..8,
        ),
    ) {
        let mut stream = Vec::new();
        let mut sent = Vec::new();
        for (frame, as_v2, junk) in &items {
            stream.extend_from_slice(junk);
            if *as_v2 {
                stream.extend(frame.status.encode(&KEY));
                sent.push(Downlink::V2(frame.status));
            } else {
                stream.extend(frame.encode(&KEY));
                sent.push(Downlink::V3(*frame));
            }
        }
        let mut decoder = DownlinkDecoder::new(KEY);
        let got: Vec<Downlink> = decoder.feed(&stream).filter_map(Result::ok).collect();
        prop_assert_eq!(got, sent);
    }
}
