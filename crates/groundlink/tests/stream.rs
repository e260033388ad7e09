//! Stream properties of both decoders: any chunking, garbage between frames, never a panic.

use dima_groundlink::{
    Command, CommandDecoder, DisplayDecoder, DisplayFrame, Percent, HEADING_FULL_TURN_DEG_E5,
    MAX_SPEED_MM_S,
};
use proptest::prelude::*;

fn command() -> impl Strategy<Value = Command> {
    let percent = (0u8..=100).prop_map(|p| Percent::new(p).unwrap());
    prop_oneof![
        Just(Command::Heartbeat),
        Just(Command::Kill),
        Just(Command::Revive),
        percent.clone().prop_map(Command::Throttle),
        percent.clone().prop_map(Command::Steering),
        percent.prop_map(Command::Tail),
        (-MAX_SPEED_MM_S..=MAX_SPEED_MM_S).prop_map(|mm_s| Command::SpeedSetpoint { mm_s }),
        (0..HEADING_FULL_TURN_DEG_E5).prop_map(|deg_e5| Command::HeadingSetpoint { deg_e5 }),
    ]
}

fn display_frame() -> impl Strategy<Value = DisplayFrame> {
    (
        prop::array::uniform3(-2048i16..=2047),
        prop::array::uniform3(any::<i16>()),
        (-4096i16..=4095, -4096i16..=4095, -16384i16..=16383),
        0u16..(1 << 14),
        0u32..(1 << 20),
        0u32..(1 << 20),
        (
            -900_000_000i32..=900_000_000,
            -1_800_000_000i32..=1_800_000_000,
        ),
        prop::array::uniform5(any::<i32>()),
        0i32..=i32::MAX,
        0i32..36_000_000,
    )
        .prop_map(
            |(acc, gyro, mag, mag_hall, press, temp, (lat, lon), v, gs, hm)| DisplayFrame {
                acc,
                gyro,
                mag: [mag.0, mag.1, mag.2],
                mag_hall,
                baro_press: press,
                baro_temp: temp,
                lat_e7: lat,
                lon_e7: lon,
                vel_n_mm_s: v[0],
                vel_e_mm_s: v[1],
                vel_d_mm_s: v[2],
                height_mm: v[3],
                h_msl_mm: v[4],
                g_speed_mm_s: gs,
                head_mot_deg_e5: hm,
            },
        )
}

/// Splits `bytes` at the given cut points (taken modulo the length).
fn chunks(bytes: &[u8], cuts: &[usize]) -> Vec<Vec<u8>> {
    let mut points: Vec<usize> = cuts.iter().map(|c| c % (bytes.len() + 1)).collect();
    points.push(0);
    points.push(bytes.len());
    points.sort_unstable();
    points
        .windows(2)
        .map(|w| bytes[w[0]..w[1]].to_vec())
        .collect()
}

proptest! {
    #[test]
    fn command_round_trip(cmd in command()) {
        prop_assert_eq!(Command::decode(&cmd.encode()), Ok(cmd));
    }

    #[test]
    fn commands_survive_any_chunking(
        cmds in prop::collection::vec(command(), 0..20),
        cuts in prop::collection::vec(any::<usize>(), 0..30),
    ) {
        let stream: Vec<u8> = cmds.iter().flat_map(|c| c.encode()).collect();
        let mut decoder = CommandDecoder::new();
        let mut got = Vec::new();
        for chunk in chunks(&stream, &cuts) {
            got.extend(decoder.feed(&chunk));
        }
        let expected: Vec<_> = cmds.iter().map(|c| Ok(*c)).collect();
        prop_assert_eq!(got, expected);
        prop_assert_eq!(decoder.stats().rejected(), 0);
    }

    /// Garbage between frames (which may contain `$` and even look like a frame start) never
    /// costs a real frame that follows it.
    #[test]
    fn commands_survive_garbage_between_frames(
        items in prop::collection::vec(
            (command(), prop::collection::vec(any::<u8>(), 0..25)), 0..12),
    ) {
        let mut stream = Vec::new();
        for (cmd, garbage) in &items {
            stream.extend_from_slice(garbage);
            stream.extend_from_slice(&cmd.encode());
        }
        let mut decoder = CommandDecoder::new();
        let got: Vec<Command> = decoder.feed(&stream).filter_map(Result::ok).collect();
        // Every sent command is found, in order; garbage only yields a command if it happens
        // to contain a CRC-valid frame (2^-32 per candidate), so compare as a subsequence.
        let mut it = got.iter();
        for (cmd, _) in &items {
            prop_assert!(it.any(|g| g == cmd), "lost {:?}", cmd);
        }
    }

    #[test]
    fn command_decoder_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..2000)) {
        let mut decoder = CommandDecoder::new();
        let n = decoder.feed(&bytes).count();
        prop_assert!(decoder.pending() < 10);
        let s = decoder.stats();
        prop_assert!(n as u32 == s.frames + s.unknown_type + s.out_of_range);
    }

    #[test]
    fn display_round_trip(frame in display_frame()) {
        prop_assert_eq!(DisplayFrame::decode(&frame.encode()), Ok(frame));
    }

    #[test]
    fn display_frames_survive_chunking_and_garbage(
        items in prop::collection::vec(
            (display_frame(), prop::collection::vec(any::<u8>(), 0..100)), 0..6),
        cuts in prop::collection::vec(any::<usize>(), 0..20),
    ) {
        let mut stream = Vec::new();
        for (frame, garbage) in &items {
            stream.extend_from_slice(garbage);
            stream.extend_from_slice(&frame.encode());
        }
        let mut decoder = DisplayDecoder::new();
        let mut got = Vec::new();
        for chunk in chunks(&stream, &cuts) {
            got.extend(decoder.feed(&chunk).filter_map(Result::ok));
        }
        let mut it = got.iter();
        for (frame, _) in &items {
            prop_assert!(it.any(|g| g == frame), "lost {:?}", frame);
        }
    }

    #[test]
    fn display_decoder_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..3000)) {
        let mut decoder = DisplayDecoder::new();
        let _ = decoder.feed(&bytes).count();
    }
}

#[test]
fn a_lost_byte_costs_only_the_frame_it_hit() {
    let frames = [
        Command::Revive,
        Command::Throttle(Percent::new(60).unwrap()),
        Command::Kill,
    ];
    let mut stream: Vec<u8> = frames.iter().flat_map(|c| c.encode()).collect();
    stream.remove(13); // a byte inside the second frame
    let mut decoder = CommandDecoder::new();
    let got: Vec<_> = decoder.feed(&stream).collect();
    assert_eq!(got, vec![Ok(Command::Revive), Ok(Command::Kill)]);
    assert!(decoder.stats().crc_errors >= 1);
}
