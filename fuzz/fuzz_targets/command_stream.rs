//! Ground-link command stream on any bytes: `dima_groundlink::CommandDecoder` (v1), and the
//! v2 `CommandDecoder` and `CommandGate` with a fixed key.
//!
//! Beyond "no panic", for v1:
//! - the same bytes fed whole, one byte at a time and in reads of random sizes give the same
//!   results and the same counters;
//! - every byte is accounted for: 10 bytes per frame delivered or rejected for its type or
//!   data, plus skipped bytes, plus the partial frame held;
//! - a delivered command re-encodes to a frame that decodes to the same command, and its type
//!   and data pass the range checks again;
//! - a frame is rejected for its type only when the type is unknown.
//!
//! For v2 (key [`LINK_KEY`], robot session [`SESSION`]):
//! - the decoder delivers exactly the authentic frames a reference scan finds (every offset
//!   tried, an authentic frame taken whole, anything else costing one byte), so no forged
//!   frame ever gets through and none hides an authentic one; 28 bytes per frame, plus skipped
//!   and pending bytes, add up to the input; every delivered frame's request is 1 to its
//!   sequence number, unless it is a kill;
//! - the gate accepts exactly what the rules say: an authentic frame of the current session
//!   with a newer sequence number (as a heartbeat: a revive of a request it already acted on,
//!   and a manual command or setpoint requested before the last revive it acted on), or an
//!   authentic kill; fed the same bytes again, it accepts nothing but kills (a frame accepted
//!   once is never accepted again unless it is a kill);
//! - an authentic frame with any one byte changed is refused.
#![no_main]

use dima_fuzz::{chunks, Rng, LINK_KEY, SESSION};
use dima_groundlink::v2::{self, CommandFrame, CommandGate, FrameError, LinkKey};
use dima_groundlink::{
    Command, CommandDecoder, CommandError, CommandStats, CommandType, COMMAND_FRAME_LEN,
};
use libfuzzer_sys::fuzz_target;

type Results = Vec<Result<Command, CommandError>>;

fn by_reads(reads: &[&[u8]]) -> (Results, CommandStats, usize) {
    let mut decoder = CommandDecoder::new();
    let mut results = Vec::new();
    for read in reads {
        results.extend(decoder.feed(read));
    }
    (results, decoder.stats(), decoder.pending())
}

fn by_bytes(data: &[u8]) -> (Results, CommandStats, usize) {
    let mut decoder = CommandDecoder::new();
    let results = data.iter().filter_map(|&b| decoder.push(b)).collect();
    (results, decoder.stats(), decoder.pending())
}

fn check_v1(data: &[u8]) {
    let whole = by_reads(&[data]);
    let (results, stats, pending) = &whole;
    assert!(*pending < COMMAND_FRAME_LEN);
    let framed = stats.frames + stats.unknown_type + stats.out_of_range;
    assert_eq!(
        framed as usize * COMMAND_FRAME_LEN + stats.skipped_bytes as usize + pending,
        data.len(),
        "{stats:?}, {pending} pending"
    );
    assert_eq!(results.len(), framed as usize);
    for result in results {
        match *result {
            Ok(command) => {
                assert_eq!(Command::decode(&command.encode()), Ok(command));
                assert_eq!(
                    Command::from_parts(command.command_type(), command.data()),
                    Ok(command)
                );
            }
            Err(CommandError::UnknownType { found }) => {
                assert!(CommandType::from_byte(found).is_none());
            }
            Err(CommandError::OutOfRange { kind, data }) => {
                assert!(Command::from_parts(kind, data).is_err());
                assert_ne!(kind, CommandType::Kill, "a kill is never refused");
            }
            Err(error) => panic!("the decoder handed out {error:?}"),
        }
    }
    assert_eq!(by_bytes(data), whole, "one byte at a time");
    assert_eq!(by_reads(&chunks(data, 32, 1)), whole, "random reads");
}

/// The authentic v2 frames in `data`, by trying every offset: an authentic frame (valid, or
/// with invalid content) is taken whole, anything else costs one byte.
fn reference_v2(data: &[u8], key: &LinkKey) -> Vec<Result<CommandFrame, FrameError>> {
    let mut found = Vec::new();
    let mut at = 0;
    while let Some(window) = data.get(at..at + v2::COMMAND_FRAME_LEN) {
        let window: &[u8; v2::COMMAND_FRAME_LEN] = window.try_into().unwrap();
        match CommandFrame::decode(window, key) {
            Ok(frame) => found.push(Ok(frame)),
            Err(error @ (FrameError::Command(_) | FrameError::BadRequest { .. })) => {
                found.push(Err(error))
            }
            Err(_) => {
                at += 1;
                continue;
            }
        }
        at += v2::COMMAND_FRAME_LEN;
    }
    found
}

fn check_v2(data: &[u8]) {
    let key = LinkKey::from_bytes(LINK_KEY);
    let reference = reference_v2(data, &key);

    let mut decoder = v2::CommandDecoder::new(key.clone());
    let results: Vec<_> = decoder.feed(data).collect();
    let stats = decoder.stats();
    let bad_tags = results
        .iter()
        .filter(|r| **r == Err(FrameError::BadTag))
        .count();
    assert_eq!(bad_tags, stats.bad_tag as usize);
    let authentic: Vec<_> = results
        .into_iter()
        .filter(|r| *r != Err(FrameError::BadTag))
        .collect();
    assert_eq!(authentic, reference);
    for frame in reference.iter().flatten() {
        assert!(
            frame.command == Command::Kill || (1..=frame.seq).contains(&frame.request),
            "{frame:?}"
        );
    }
    assert_eq!(
        stats.frames as usize * v2::COMMAND_FRAME_LEN
            + stats.skipped_bytes as usize
            + decoder.pending(),
        data.len(),
        "{stats:?}"
    );

    // The gate against its rules.
    let mut gate = CommandGate::new(key.clone(), SESSION);
    let accepted: Vec<Command> = gate.feed(data).filter_map(Result::ok).collect();
    let mut last_seq = 0;
    let mut last_revive_request = 0;
    let (mut revive_repeats, mut pre_revive_requests) = (0, 0);
    let mut expected = Vec::new();
    for frame in reference.iter().flatten() {
        if frame.session == SESSION && frame.seq > last_seq {
            last_seq = frame.seq;
            let value = matches!(
                frame.command,
                Command::Throttle(_)
                    | Command::Steering(_)
                    | Command::Tail(_)
                    | Command::SpeedSetpoint { .. }
                    | Command::HeadingSetpoint { .. }
            );
            // A revive request is acted on once; its repetitions are heartbeats. So are the
            // values requested before the last revive acted on.
            if frame.command == Command::Revive && frame.request <= last_revive_request {
                revive_repeats += 1;
                expected.push(Command::Heartbeat);
            } else if value && frame.request < last_revive_request {
                pre_revive_requests += 1;
                expected.push(Command::Heartbeat);
            } else {
                if frame.command == Command::Revive {
                    last_revive_request = frame.request;
                }
                expected.push(frame.command);
            }
        } else if frame.command == Command::Kill {
            expected.push(Command::Kill);
        }
    }
    assert_eq!(accepted, expected);
    assert_eq!(gate.last_accepted(), last_seq);
    assert_eq!(gate.stats().accepted as usize, accepted.len());
    assert_eq!(gate.stats().revive_repeats, revive_repeats);
    assert_eq!(gate.stats().pre_revive_requests, pre_revive_requests);
    // The same bytes again, from a clean stream: without the reset, a frame whose start ends
    // `data` and whose rest begins it would be whole for the first time, and rightly accepted.
    gate.reset_stream();
    let again: Vec<Command> = gate.feed(data).filter_map(Result::ok).collect();
    assert!(
        again.iter().all(|c| *c == Command::Kill),
        "accepted again: {again:?}"
    );

    // Forgeries of the authentic frames: one byte changed.
    let mut rng = Rng::from_bytes(data, 4);
    for frame in reference.iter().flatten() {
        let mut forged = frame.encode(&key);
        let at = (rng.next_u64() % forged.len() as u64) as usize;
        forged[at] ^= rng.size(255) as u8;
        let mut fresh = CommandGate::new(key.clone(), SESSION);
        assert!(
            fresh.check(&forged).is_err(),
            "forgery accepted: {forged:02x?}"
        );
    }
}

fuzz_target!(|data: &[u8]| {
    check_v1(data);
    check_v2(data);
});
