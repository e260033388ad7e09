//! Property tests: escaping and frame round trips, and "never panics" on arbitrary input.

use proptest::prelude::*;
use xbee_driver::{checksum, encode, FrameDecoder};
use xbee_driver::{escape, needs_escape, unescape};
use xbee_driver::{format_line, parse_hex, AtCommand, AtRequest, Parameter, MAX_LINE_LEN};
use xbee_driver::{ApiEscaping, Frame};

fn escaping() -> impl Strategy<Value = ApiEscaping> {
    prop_oneof![Just(ApiEscaping::Unescaped), Just(ApiEscaping::Escaped)]
}

/// Frame data that parses: a known or unknown type byte and arbitrary bytes after it.
fn frame_data() -> impl Strategy<Value = Vec<u8>> {
    let types = prop_oneof![
        Just(0x08u8),
        Just(0x09),
        Just(0x10),
        Just(0x11),
        Just(0x17),
        Just(0x88),
        Just(0x8A),
        Just(0x8B),
        Just(0x90),
        Just(0x91),
        Just(0x97),
        any::<u8>(),
    ];
    (types, prop::collection::vec(any::<u8>(), 0..120)).prop_map(|(t, mut rest)| {
        // Fixed-size frames: keep their exact length so that they parse.
        match t {
            0x8A => rest.truncate(1),
            0x8B => rest.truncate(6),
            _ => {}
        }
        let mut data = vec![t];
        data.extend(rest);
        data
    })
}

fn decode_all(escaping: ApiEscaping, bytes: &[u8]) -> Vec<Vec<u8>> {
    let mut decoder = FrameDecoder::<256>::new(escaping);
    let mut out = Vec::new();
    for &b in bytes {
        if let Some(f) = decoder.push(b) {
            out.push(f.data().to_vec());
        }
        while let Some(f) = decoder.next_buffered() {
            out.push(f.data().to_vec());
        }
    }
    out
}

proptest! {
    #[test]
    fn escape_round_trip(input in prop::collection::vec(any::<u8>(), 0..300)) {
        let mut escaped = vec![0u8; input.len() * 2];
        let n = escape(&input, &mut escaped).unwrap();
        let escaped = &escaped[..n];
        prop_assert!(escaped.iter().all(|&b| b != 0x7E && b != 0x11 && b != 0x13));
        prop_assert_eq!(n, input.len() + input.iter().filter(|&&b| needs_escape(b)).count());
        let mut back = vec![0u8; n];
        let m = unescape(escaped, &mut back).unwrap();
        prop_assert_eq!(&back[..m], &input[..]);
    }

    #[test]
    fn unescape_never_panics(input in prop::collection::vec(any::<u8>(), 0..300), cap in 0usize..300) {
        let mut out = vec![0u8; cap];
        let _ = unescape(&input, &mut out);
    }

    #[test]
    fn parse_emit_is_identity(data in frame_data()) {
        if let Ok(frame) = Frame::parse(&data) {
            let mut buf = vec![0u8; 2 * data.len() + 8];
            let n = encode(&frame, ApiEscaping::Unescaped, &mut buf).unwrap();
            prop_assert_eq!(n, data.len() + 4);
            prop_assert_eq!(&buf[3..n - 1], &data[..]);
            prop_assert_eq!(buf[n - 1], checksum(&data));
            prop_assert_eq!(frame.data_len(), data.len());
        }
    }

    #[test]
    fn encode_decode_round_trip(data in frame_data(), esc in escaping()) {
        let frame = Frame::parse(&data);
        prop_assume!(frame.is_ok());
        let frame = frame.unwrap();
        let mut buf = vec![0u8; 2 * data.len() + 8];
        let n = encode(&frame, esc, &mut buf).unwrap();
        let mut decoder = FrameDecoder::<256>::new(esc);
        let mut decoded = None;
        for (i, &b) in buf[..n].iter().enumerate() {
            let out = decoder.push(b).map(|f| f.data().to_vec());
            if i + 1 < n {
                prop_assert!(out.is_none());
            } else {
                decoded = out;
            }
        }
        let decoded = decoded.expect("frame complete on its last byte");
        prop_assert_eq!(Frame::parse(&decoded), Ok(frame));
    }

    #[test]
    fn good_frames_survive_garbage_api2(
        garbage in prop::collection::vec(any::<u8>(), 0..64),
        frames in prop::collection::vec(frame_data(), 1..4),
    ) {
        // API 2: a raw 0x7E always restarts, so every good frame after garbage comes out, in
        // order (garbage may by chance form extra frames of its own, which is allowed).
        let mut stream = garbage.clone();
        let mut expected = Vec::new();
        for data in &frames {
            let frame = Frame::parse(data);
            prop_assume!(frame.is_ok());
            let mut buf = vec![0u8; 2 * data.len() + 8];
            let n = encode(&frame.unwrap(), ApiEscaping::Escaped, &mut buf).unwrap();
            stream.extend_from_slice(&buf[..n]);
            expected.push(data.clone());
        }
        let found = decode_all(ApiEscaping::Escaped, &stream);
        let tail = &found[found.len().saturating_sub(expected.len())..];
        prop_assert_eq!(tail, &expected[..]);
    }

    #[test]
    fn good_frames_survive_garbage_without_delimiter_api1(
        garbage in prop::collection::vec(any::<u8>().prop_filter("no 0x7E", |b| *b != 0x7E), 0..64),
        frames in prop::collection::vec(frame_data(), 1..4),
    ) {
        let mut stream = garbage.clone();
        let mut expected = Vec::new();
        for data in &frames {
            let frame = Frame::parse(data);
            prop_assume!(frame.is_ok());
            let mut buf = vec![0u8; data.len() + 8];
            let n = encode(&frame.unwrap(), ApiEscaping::Unescaped, &mut buf).unwrap();
            stream.extend_from_slice(&buf[..n]);
            expected.push(data.clone());
        }
        prop_assert_eq!(decode_all(ApiEscaping::Unescaped, &stream), expected);
    }

    #[test]
    fn decoder_never_panics_and_counts(bytes in prop::collection::vec(any::<u8>(), 0..1024), esc in escaping()) {
        let mut decoder = FrameDecoder::<32>::new(esc);
        let max = decoder.max_frame_data_len();
        let mut frames = 0u32;
        for &b in &bytes {
            if let Some(f) = decoder.push(b) {
                prop_assert!(!f.data().is_empty());
                prop_assert!(f.data().len() <= max);
                let _ = f.parse();
                frames += 1;
            }
            while decoder.next_buffered().is_some() {
                frames += 1;
            }
        }
        prop_assert_eq!(decoder.stats().frames, frames);
    }

    #[test]
    fn frame_parse_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..64)) {
        let _ = Frame::parse(&bytes);
    }

    #[test]
    fn command_numbers_round_trip(value in any::<u64>(), name in any::<[u8; 2]>()) {
        let mut line = [0u8; MAX_LINE_LEN];
        let n = format_line(&AtRequest::set(AtCommand(name), Parameter::Number(value)), &mut line).unwrap();
        prop_assert_eq!(&line[..2], b"AT");
        prop_assert_eq!(line[n - 1], b'\r');
        prop_assert_eq!(parse_hex(&line[4..n - 1]), Some(value));
        let mut api = [0u8; 8];
        let m = Parameter::Number(value).to_api_bytes(&mut api).unwrap();
        let mut be = [0u8; 8];
        be[8 - m..].copy_from_slice(&api[..m]);
        prop_assert_eq!(u64::from_be_bytes(be), value);
    }

    #[test]
    fn parse_hex_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..40)) {
        let _ = parse_hex(&bytes);
    }
}
