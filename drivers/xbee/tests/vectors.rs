//! Golden API frames from Digi's `digi-xbee` library (copied verbatim from the project's
//! test-vector list), in API 1 and API 2 form, in both directions: typed frame -> bytes, and
//! bytes -> typed frame (through the decoder and through `XBee<S, Api>` on a mock serial port).

mod digi_vectors;

use digi_vectors::{
    frames, AT_ID_SET, AT_NI_QUERY, AT_NI_RESPONSE, RX_API1, RX_API2, TX_API1, TX_API2,
};
use embedded_hal_mock::eh1::serial::{Mock as SerialMock, Transaction};
use xbee_driver::{encode, encoded_len, Api, FrameDecoder, XBee};
use xbee_driver::{Address16, Address64, ApiEscaping, AtCommand, Frame, Parameter};

fn decode_all<const N: usize>(decoder: &mut FrameDecoder<N>, bytes: &[u8]) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for &b in bytes {
        if let Some(frame) = decoder.push(b) {
            out.push(frame.data().to_vec());
        }
        while let Some(frame) = decoder.next_buffered() {
            out.push(frame.data().to_vec());
        }
    }
    out
}

#[test]
fn encode_matches_digi_in_both_api_modes() {
    for (frame, api1, api2) in frames() {
        let mut buf = [0u8; 64];
        let n = encode(&frame, ApiEscaping::Unescaped, &mut buf).unwrap();
        assert_eq!(&buf[..n], api1, "API 1 {frame:?}");
        assert_eq!(encoded_len(&frame, ApiEscaping::Unescaped), api1.len());
        let n = encode(&frame, ApiEscaping::Escaped, &mut buf).unwrap();
        assert_eq!(&buf[..n], api2, "API 2 {frame:?}");
        assert_eq!(encoded_len(&frame, ApiEscaping::Escaped), api2.len());
    }
}

#[test]
fn decode_matches_digi_in_both_api_modes() {
    for (frame, api1, api2) in frames() {
        for (escaping, bytes) in [(ApiEscaping::Unescaped, api1), (ApiEscaping::Escaped, api2)] {
            let mut decoder = FrameDecoder::<64>::new(escaping);
            let (last, head) = bytes.split_last().unwrap();
            for &b in head {
                assert!(decoder.push(b).is_none());
            }
            let raw = decoder.push(*last).expect("complete frame");
            assert_eq!(raw.parse().unwrap(), frame, "{escaping:?}");
            assert_eq!(decoder.stats().frames, 1);
            assert_eq!(decoder.stats().checksum_errors, 0);
        }
    }
}

#[test]
fn at_parameter_from_number_matches_digi() {
    // The `ID` = 0x7FFF vector carries the parameter as two bytes.
    let mut buf = [0u8; 8];
    let n = Parameter::Number(0x7FFF).to_api_bytes(&mut buf).unwrap();
    assert_eq!(&buf[..n], &AT_ID_SET[7..9]);
}

#[test]
fn xbee_api_sends_digi_bytes() {
    for (escaping, expected) in [
        (ApiEscaping::Unescaped, TX_API1),
        (ApiEscaping::Escaped, TX_API2),
    ] {
        let serial = SerialMock::new(&[Transaction::write_many(expected), Transaction::flush()]);
        let mut api: XBee<_, Api> = XBee::new_api(serial, escaping);
        let id = api
            .transmit(Address64(0x0013_A200_40A1_B2C3), b"Hi")
            .unwrap();
        assert_eq!(id, 1);
        api.release().done();
    }
    let serial = SerialMock::new(&[Transaction::write_many(AT_NI_QUERY), Transaction::flush()]);
    let mut api: XBee<_, Api> = XBee::new_api(serial, ApiEscaping::Escaped);
    assert_eq!(
        api.send_at_command(AtCommand::NI, Parameter::None).unwrap(),
        1
    );
    api.release().done();
}

#[test]
fn xbee_api_receives_digi_bytes() {
    for (escaping, bytes) in [
        (ApiEscaping::Unescaped, RX_API1),
        (ApiEscaping::Escaped, RX_API2),
    ] {
        let serial = SerialMock::new(&[
            Transaction::read_many(bytes),
            Transaction::read_error(nb::Error::WouldBlock),
        ]);
        let mut api: XBee<_, Api> = XBee::new_api(serial, escaping);
        match api.poll_frame() {
            Ok(Frame::ReceivePacket(rx)) => {
                assert_eq!(rx.source, Address64(0x0013_A200_4052_2BAA));
                assert_eq!(rx.source_16, Address16(0x7D84));
                assert_eq!(rx.options, 0x01);
                assert_eq!(rx.data, b"RxData");
            }
            other => panic!("unexpected {other:?}"),
        }
        assert!(matches!(api.poll_frame(), Err(nb::Error::WouldBlock)));
        api.release().done();
    }
}

#[test]
fn all_vectors_back_to_back_in_one_stream() {
    for escaping in [ApiEscaping::Unescaped, ApiEscaping::Escaped] {
        let mut stream = Vec::new();
        let mut expected = Vec::new();
        for (frame, api1, api2) in frames() {
            stream.extend_from_slice(if escaping == ApiEscaping::Escaped {
                api2
            } else {
                api1
            });
            let mut data = [0u8; 64];
            let n = encode(&frame, ApiEscaping::Unescaped, &mut data).unwrap();
            expected.push(data[3..n - 1].to_vec());
        }
        let mut decoder = FrameDecoder::<64>::new(escaping);
        assert_eq!(decode_all(&mut decoder, &stream), expected);
    }
}

#[test]
fn garbage_and_truncated_frames_are_skipped_api2() {
    let mut stream = vec![0x00, 0x55, 0xFF, 0x7D, 0x13];
    stream.extend_from_slice(&TX_API2[..9]); // truncated by the next delimiter
    stream.extend_from_slice(RX_API2);
    let mut bad = AT_NI_QUERY.to_vec();
    *bad.last_mut().unwrap() ^= 0x01; // checksum error
    stream.extend_from_slice(&bad);
    stream.extend_from_slice(AT_NI_RESPONSE);
    let mut decoder = FrameDecoder::<64>::new(ApiEscaping::Escaped);
    let found = decode_all(&mut decoder, &stream);
    assert_eq!(
        found,
        vec![RX_API1[3..21].to_vec(), AT_NI_RESPONSE[3..13].to_vec()]
    );
    let stats = decoder.stats();
    assert_eq!(stats.frames, 2);
    assert_eq!(stats.truncated, 1);
    assert_eq!(stats.checksum_errors, 1);
    assert!(stats.discarded_bytes >= 5);
}

#[test]
fn every_truncation_before_a_good_frame_is_recovered_api1() {
    // A frame cut at any point, then two good frames: both good frames come out. In API 1 the
    // decoder may have to wait for the cut frame's claimed length before it rescans, so the
    // stream ends with enough idle filler.
    for (_, cut_source, _) in frames() {
        for cut in 1..cut_source.len() {
            let mut stream = cut_source[..cut].to_vec();
            stream.extend_from_slice(RX_API1);
            stream.extend_from_slice(AT_NI_RESPONSE);
            stream.extend_from_slice(&[0u8; 64]);
            let mut decoder = FrameDecoder::<64>::new(ApiEscaping::Unescaped);
            let found = decode_all(&mut decoder, &stream);
            assert_eq!(
                found,
                vec![RX_API1[3..21].to_vec(), AT_NI_RESPONSE[3..13].to_vec()],
                "cut {cut} of {cut_source:02X?}"
            );
        }
    }
}

#[test]
fn oversized_frame_is_dropped_and_next_found() {
    // Length 0x0100 does not fit a 64-byte decoder.
    let mut stream = vec![0x7E, 0x01, 0x00, 0x90];
    stream.extend_from_slice(AT_NI_QUERY);
    for escaping in [ApiEscaping::Unescaped, ApiEscaping::Escaped] {
        let mut decoder = FrameDecoder::<64>::new(escaping);
        let found = decode_all(&mut decoder, &stream);
        assert_eq!(found, vec![AT_NI_QUERY[3..7].to_vec()], "{escaping:?}");
        assert_eq!(decoder.stats().length_errors, 1);
    }
}
