//! `XBee<S, Api>` on a mock serial port: frame ids, error reporting, resynchronisation.

use embedded_hal_mock::eh1::serial::{Mock as SerialMock, Transaction};
use xbee_driver::encode_raw;
use xbee_driver::DeviceError;
use xbee_driver::{frame_type, Api, ExplicitAddressing, RemoteAtCommand};
use xbee_driver::{
    Address16, Address64, ApiEscaping, AtCommand, Error, Frame, FrameError, ModemStatus, Parameter,
    XBee,
};

fn would_block() -> Transaction<u8> {
    Transaction::read_error(nb::Error::WouldBlock)
}

fn raw(frame_data: &[u8], escaping: ApiEscaping) -> Vec<u8> {
    let mut buf = vec![0u8; 2 * frame_data.len() + 8];
    let n = encode_raw(frame_data, escaping, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

#[test]
fn frame_ids_advance_and_skip_zero() {
    let mut expected = Vec::new();
    for id in 1..=3u8 {
        let data = [frame_type::AT_COMMAND, id, b'N', b'I'];
        expected.push(Transaction::write_many(raw(&data, ApiEscaping::Escaped)));
        expected.push(Transaction::flush());
    }
    let mut api: XBee<_, Api> = XBee::new_api(SerialMock::new(&expected), ApiEscaping::Escaped);
    for id in 1..=3u8 {
        assert_eq!(api.send_at_command(AtCommand::NI, Parameter::None), Ok(id));
    }
    api.release().done();
}

#[test]
fn at_parameter_longer_than_the_limit_is_refused_before_io() {
    let mut api: XBee<_, Api> = XBee::new_api(SerialMock::new(&[]), ApiEscaping::Unescaped);
    let long = [0u8; 33];
    assert_eq!(
        api.send_at_command(AtCommand::NI, Parameter::Text(&long)),
        Err(Error::Device(DeviceError::InvalidInput))
    );
    api.release().done();
}

#[test]
fn modem_status_and_garbage() {
    // Modem status "coordinator started" (0x06), after line noise.
    let mut bytes = vec![0x00, 0xFF, 0x13];
    bytes.extend(raw(&[frame_type::MODEM_STATUS, 0x06], ApiEscaping::Escaped));
    let serial = SerialMock::new(&[Transaction::read_many(&bytes), would_block()]);
    let mut api: XBee<_, Api> = XBee::new_api(serial, ApiEscaping::Escaped);
    assert_eq!(
        api.poll_frame(),
        Ok(Frame::ModemStatus(ModemStatus::CoordinatorStarted))
    );
    assert_eq!(api.poll_frame(), Err(nb::Error::WouldBlock));
    assert_eq!(api.stats().frames, 1);
    assert_eq!(api.stats().discarded_bytes, 3);
    api.release().done();
}

#[test]
fn known_frame_with_invalid_length_is_reported() {
    // A transmit status must have 7 bytes of frame data; this one has 2.
    let bytes = raw(&[frame_type::TRANSMIT_STATUS, 0x01], ApiEscaping::Unescaped);
    let serial = SerialMock::new(&[Transaction::read_many(&bytes)]);
    let mut api: XBee<_, Api> = XBee::new_api(serial, ApiEscaping::Unescaped);
    assert_eq!(
        api.poll_frame(),
        Err(nb::Error::Other(Error::Device(DeviceError::Frame(
            FrameError::InvalidLength {
                frame_type: 0x8B,
                len: 2
            }
        ))))
    );
    api.release().done();
}

#[test]
fn backlog_after_api1_rescan_is_drained_without_new_bytes() {
    // A truncated frame claiming 12 bytes of data swallows two short frames; when its checksum
    // fails, the rescan finds both, and the second comes out of the buffer without a read.
    let a = raw(&[frame_type::MODEM_STATUS, 0x02], ApiEscaping::Unescaped);
    let b = raw(&[frame_type::MODEM_STATUS, 0x03], ApiEscaping::Unescaped);
    let mut bytes = vec![0x7E, 0x00, 0x0C, 0x90];
    bytes.extend(&a);
    bytes.extend(&b);
    bytes.extend([0x00; 2]);
    let serial = SerialMock::new(&[Transaction::read_many(&bytes), would_block()]);
    let mut api: XBee<_, Api<64>> = XBee::api_with_capacity(serial, ApiEscaping::Unescaped);
    assert_eq!(
        api.poll_frame(),
        Ok(Frame::ModemStatus(ModemStatus::Joined))
    );
    assert_eq!(
        api.poll_frame(),
        Ok(Frame::ModemStatus(ModemStatus::Disassociated))
    );
    assert_eq!(api.poll_frame(), Err(nb::Error::WouldBlock));
    assert_eq!(api.stats().checksum_errors, 1);
    api.release().done();
}

#[test]
fn explicit_and_remote_frames_go_out_as_their_fields() {
    // Field order from the XBee 3 Zigbee user guide (frames 0x11 and 0x17).
    let explicit = Frame::ExplicitAddressing(ExplicitAddressing {
        frame_id: 1,
        destination: Address64(0x0013_A200_0102_0304),
        destination_16: Address16::UNKNOWN,
        source_endpoint: 0xE8,
        destination_endpoint: 0xE8,
        cluster_id: 0x0011,
        profile_id: 0xC105,
        broadcast_radius: 0,
        options: 0,
        data: b"A",
    });
    let remote = Frame::RemoteAtCommand(RemoteAtCommand {
        frame_id: 2,
        destination: Address64(0x0013_A200_0102_0304),
        destination_16: Address16::UNKNOWN,
        options: 0x02,
        command: AtCommand::PL,
        parameter: &[0x04],
    });
    let explicit_data = [
        0x11, 0x01, 0x00, 0x13, 0xA2, 0x00, 0x01, 0x02, 0x03, 0x04, 0xFF, 0xFE, 0xE8, 0xE8, 0x00,
        0x11, 0xC1, 0x05, 0x00, 0x00, 0x41,
    ];
    let remote_data = [
        0x17, 0x02, 0x00, 0x13, 0xA2, 0x00, 0x01, 0x02, 0x03, 0x04, 0xFF, 0xFE, 0x02, 0x50, 0x4C,
        0x04,
    ];
    let serial = SerialMock::new(&[
        Transaction::write_many(raw(&explicit_data, ApiEscaping::Unescaped)),
        Transaction::flush(),
        Transaction::write_many(raw(&remote_data, ApiEscaping::Unescaped)),
        Transaction::flush(),
    ]);
    let mut api: XBee<_, Api> = XBee::new_api(serial, ApiEscaping::Unescaped);
    api.send(&explicit).unwrap();
    api.send(&remote).unwrap();
    api.release().done();
    assert_eq!(Frame::parse(&explicit_data), Ok(explicit));
    assert_eq!(Frame::parse(&remote_data), Ok(remote));
}

#[test]
fn unknown_frame_types_are_kept() {
    let data = [0xA1, 1, 2, 3];
    assert_eq!(
        Frame::parse(&data),
        Ok(Frame::Unknown {
            frame_type: 0xA1,
            data: &[1, 2, 3]
        })
    );
}

/// Frame data longer than the driver's write chunk, with bytes that API 2 escapes at every
/// position (so escapes fall on the chunk boundaries).
fn long_frame_data() -> Vec<u8> {
    let mut data = vec![frame_type::TRANSMIT_REQUEST];
    data.extend((0..300u32).map(|i| [0x7E, 0x7D, 0x11, 0x13, 0x42][(i % 5) as usize]));
    data
}

#[test]
fn a_long_frame_goes_out_as_the_encoder_writes_it() {
    let data = long_frame_data();
    for escaping in [ApiEscaping::Unescaped, ApiEscaping::Escaped] {
        let expected = raw(&data, escaping);
        let serial = SerialMock::new(&[Transaction::write_many(&expected), Transaction::flush()]);
        let mut api: XBee<_, Api> = XBee::new_api(serial, escaping);
        let frame = Frame::Unknown {
            frame_type: data[0],
            data: &data[1..],
        };
        api.send(&frame).unwrap();
        api.release().done();
    }
}

#[test]
fn a_frame_too_long_to_send_writes_nothing() {
    let data = vec![0u8; 65_535];
    let frame = Frame::Unknown {
        frame_type: 0xA1,
        data: &data,
    };
    let mut api: XBee<_, Api> = XBee::new_api(SerialMock::new(&[]), ApiEscaping::Escaped);
    assert_eq!(
        api.send(&frame),
        Err(Error::Device(DeviceError::Frame(FrameError::TooLong)))
    );
    api.release().done();
}

#[test]
fn frame_longer_than_the_length_field_is_refused() {
    let data = vec![0u8; 65_535];
    let frame = Frame::Unknown {
        frame_type: 0xA1,
        data: &data,
    };
    let mut out = vec![0u8; 70_000];
    assert_eq!(
        xbee_driver::encode(&frame, ApiEscaping::Unescaped, &mut out),
        Err(FrameError::TooLong)
    );
    let fits = Frame::Unknown {
        frame_type: 0xA1,
        data: &data[1..],
    };
    assert_eq!(
        xbee_driver::encode(&fits, ApiEscaping::Unescaped, &mut out),
        Ok(65_535 + 4)
    );
    assert_eq!(
        xbee_driver::encode(&fits, ApiEscaping::Unescaped, &mut out[..100]),
        Err(FrameError::BufferTooSmall)
    );
}

#[test]
fn a_port_that_never_takes_a_byte_times_out_instead_of_hanging() {
    // The first byte (the delimiter) is refused three times: with a budget of three polls the
    // send ends there. Without the budget this test would spin forever.
    let refused: Vec<_> = (0..3)
        .map(|_| Transaction::write_error(0x7E, nb::Error::WouldBlock))
        .collect();
    let serial = SerialMock::new(&refused);
    let mut api: XBee<_, Api> =
        XBee::new_api(serial, ApiEscaping::Escaped).with_write_polls_per_byte(3);
    assert_eq!(
        api.send_at_command(AtCommand::NI, Parameter::None),
        Err(Error::Device(DeviceError::Timeout))
    );
    api.release().done();
}

#[test]
fn a_flush_that_never_completes_times_out() {
    let data = [frame_type::AT_COMMAND, 1, b'N', b'I'];
    let mut expected = vec![Transaction::write_many(raw(&data, ApiEscaping::Unescaped))];
    expected.extend((0..2).map(|_| Transaction::flush_error(nb::Error::WouldBlock)));
    let mut api: XBee<_, Api> = XBee::new_api(SerialMock::new(&expected), ApiEscaping::Unescaped)
        .with_write_polls_per_byte(2);
    assert_eq!(
        api.send_at_command(AtCommand::NI, Parameter::None),
        Err(Error::Device(DeviceError::Timeout))
    );
    api.release().done();
}

#[test]
fn a_busy_port_within_the_budget_still_sends_the_frame() {
    let data = [frame_type::AT_COMMAND, 1, b'N', b'I'];
    let bytes = raw(&data, ApiEscaping::Unescaped);
    let mut expected = vec![Transaction::write_error(bytes[0], nb::Error::WouldBlock)];
    expected.push(Transaction::write_many(bytes));
    expected.push(Transaction::flush_error(nb::Error::WouldBlock));
    expected.push(Transaction::flush());
    let mut api: XBee<_, Api> = XBee::new_api(SerialMock::new(&expected), ApiEscaping::Unescaped)
        .with_write_polls_per_byte(2);
    assert_eq!(api.send_at_command(AtCommand::NI, Parameter::None), Ok(1));
    api.release().done();
}

/// The README's API-mode quick start compiles and runs without type annotations: `new_api`
/// picks the default buffer, `transmit` and `poll_frame` infer the rest.
#[test]
fn readme_api_quick_start_needs_no_annotations() {
    // Transmit Request 0x10, frame id 1, to the coordinator (0/0), 16-bit address unknown,
    // radius 0, options 0, then the data (XBee API reference, frame 0x10).
    let mut request = vec![0x10, 0x01, 0, 0, 0, 0, 0, 0, 0, 0, 0xFF, 0xFE, 0x00, 0x00];
    request.extend_from_slice(b"hello");
    // Transmit Status 0x8B for frame id 1: success (delivery 0), no discovery overhead.
    let status = [0x8B, 0x01, 0xFF, 0xFE, 0x00, 0x00, 0x00];
    let serial = SerialMock::new(&[
        Transaction::write_many(raw(&request, ApiEscaping::Escaped)),
        Transaction::flush(),
        Transaction::read_many(raw(&status, ApiEscaping::Escaped)),
        would_block(),
    ]);
    let mut xbee = XBee::new_api(serial, ApiEscaping::Escaped);
    let id = xbee.transmit(Address64::COORDINATOR, b"hello").unwrap();
    match xbee.poll_frame() {
        Ok(Frame::TransmitStatus(s)) => assert_eq!((s.frame_id, s.delivery_status), (id, 0)),
        other => panic!("expected a transmit status, got {other:?}"),
    }
    assert_eq!(xbee.poll_frame(), Err(nb::Error::WouldBlock));
    xbee.release().done();
}
