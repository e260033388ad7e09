//! The host driver against embedded-hal-mock: request pulses, polling, errors, bounds.

use dima_sensorboard::{Error, Frame, InfoFrame, SensorBoard, SensorPacket, MAX_BYTES_PER_POLL};
use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as PinTx};
use embedded_hal_mock::eh1::serial::{Mock as SerialMock, Transaction as SerialTx};
use embedded_hal_mock::eh1::MockError;
use embedded_hal_nb::serial::ErrorKind;

fn board(pin: &[PinTx], serial: &[SerialTx<u8>]) -> SensorBoard<PinMock, SerialMock<u8>> {
    SensorBoard::new(PinMock::new(pin), SerialMock::new(serial))
}

fn done(board: SensorBoard<PinMock, SerialMock<u8>>) {
    let (mut pin, mut serial) = board.release();
    pin.done();
    serial.done();
}

fn would_block() -> SerialTx<u8> {
    SerialTx::read_error(nb::Error::WouldBlock)
}

fn packet() -> [u8; 132] {
    SensorPacket {
        accel: [1, 2, 3],
        temp_raw: 519_888,
        ..SensorPacket::default()
    }
    .encode()
}

#[test]
fn request_pulse_raises_then_lowers() {
    let mut b = board(
        &[
            PinTx::set(State::High),
            PinTx::set(State::Low),
            PinTx::set(State::High),
        ],
        &[],
    );
    b.request().unwrap();
    b.end_request().unwrap();
    b.request().unwrap();
    done(b);
}

#[test]
fn request_while_high_makes_a_new_edge() {
    let mut b = board(
        &[
            PinTx::set(State::High),
            PinTx::set(State::Low),
            PinTx::set(State::High),
        ],
        &[],
    );
    b.request().unwrap();
    b.request().unwrap();
    done(b);
}

#[test]
fn pin_error_is_reported() {
    let mut b = board(
        &[PinTx::set(State::High).with_error(MockError::Io(std::io::ErrorKind::NotConnected))],
        &[],
    );
    assert_eq!(
        b.request(),
        Err(Error::Pin(MockError::Io(std::io::ErrorKind::NotConnected)))
    );
    done(b);
}

#[test]
fn poll_returns_would_block_until_the_packet_is_complete() {
    let bytes = packet();
    let mut b = board(
        &[],
        &[
            would_block(),
            SerialTx::read_many(&bytes[..70]),
            would_block(),
            SerialTx::read_many(&bytes[70..]),
        ],
    );
    assert_eq!(b.poll(), Err(nb::Error::WouldBlock));
    assert_eq!(b.poll(), Err(nb::Error::WouldBlock));
    match b.poll() {
        Ok(Frame::Packet(raw)) => assert_eq!(raw.into_bytes(), bytes),
        other => panic!("unexpected {other:?}"),
    }
    assert_eq!(b.stats().packets, 1);
    done(b);
}

#[test]
fn packet_then_info_frame_in_one_answer() {
    let info = InfoFrame {
        version: 1,
        firmware: [0, 1, 0],
        uptime_ms: 12,
        ..InfoFrame::default()
    };
    let mut answer = packet().to_vec();
    answer.extend_from_slice(&info.encode());
    let mut b = board(&[], &[SerialTx::read_many(&answer), would_block()]);
    assert!(matches!(b.poll(), Ok(Frame::Packet(_))));
    assert_eq!(b.poll(), Ok(Frame::Info(info)));
    assert_eq!(b.poll(), Err(nb::Error::WouldBlock));
    done(b);
}

#[test]
fn serial_error_is_reported_and_decoding_goes_on() {
    let bytes = packet();
    let mut b = board(
        &[],
        &[
            SerialTx::read_many(&bytes[..40]),
            SerialTx::read_error(nb::Error::Other(ErrorKind::Overrun)),
            // The rest of the torn answer, then a whole new one.
            SerialTx::read_many(&bytes[60..]),
            SerialTx::read_many(bytes),
        ],
    );
    assert_eq!(
        b.poll(),
        Err(nb::Error::Other(Error::Comm(ErrorKind::Overrun)))
    );
    match b.poll() {
        Ok(Frame::Packet(raw)) => assert_eq!(raw.into_bytes(), bytes),
        other => panic!("unexpected {other:?}"),
    }
    assert!(b.stats().bytes_skipped >= 112);
    done(b);
}

#[test]
fn one_poll_reads_a_bounded_number_of_bytes() {
    let garbage = vec![0xA5u8; MAX_BYTES_PER_POLL];
    let mut b = board(&[], &[SerialTx::read_many(&garbage)]);
    // The port would deliver forever; poll stops after MAX_BYTES_PER_POLL bytes. The mock
    // fails on `done` if fewer were read, and panics on a read it does not expect.
    assert_eq!(b.poll(), Err(nb::Error::WouldBlock));
    assert_eq!(b.stats().bytes_skipped, MAX_BYTES_PER_POLL as u64);
    done(b);
}

#[test]
fn discard_buffered_drops_a_late_half_packet() {
    let bytes = packet();
    let mut b = board(&[], &[SerialTx::read_many(&bytes[..50]), would_block()]);
    assert_eq!(b.poll(), Err(nb::Error::WouldBlock));
    b.discard_buffered();
    assert_eq!(b.stats().bytes_skipped, 50);
    done(b);
}

#[test]
fn error_display() {
    let e: Error<MockError, ErrorKind> = Error::Comm(ErrorKind::Overrun);
    assert_eq!(e.to_string(), "sensor board serial error: Overrun");
}
