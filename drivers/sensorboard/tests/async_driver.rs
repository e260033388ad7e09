//! The async host driver against an in-memory `embedded-io-async` port: the vectors of
//! `driver.rs` and the generated capture of `capture.rs`, with the answer deadline raced
//! against a delay.
#![cfg(feature = "async")]

#[path = "common/capture.rs"]
mod capture;

use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::future::{poll_fn, Future};
use std::pin::pin;
use std::rc::Rc;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use capture::{Capture, Noise};
use dima_sensorboard::{DeviceError, Error, Frame, InfoFrame, SensorBoardAsync, SensorPacket};
use embedded_hal_mock::eh1::digital::{Mock as PinMock, State, Transaction as PinTx};
use embedded_hal_mock::eh1::MockError;
use embedded_io_async::ErrorKind;

struct NoopWake;
impl Wake for NoopWake {
    fn wake(self: Arc<Self>) {}
}

/// Runs a future that never waits on anything outside the mocks (they complete at once or
/// stay pending, and the delay completes at once).
fn block_on<F: Future>(fut: F) -> F::Output {
    let waker = Waker::from(Arc::new(NoopWake));
    let mut cx = Context::from_waker(&waker);
    let mut fut = pin!(fut);
    for _ in 0..1000 {
        if let Poll::Ready(out) = fut.as_mut().poll(&mut cx) {
            return out;
        }
    }
    panic!("future did not complete");
}

/// One step of what the board side of the link does.
#[derive(Debug)]
enum Step {
    /// These bytes are waiting to be read; a read with no step left waits forever.
    Read(Vec<u8>),
    /// The next read fails.
    ReadError(ErrorKind),
    /// The next read returns `Ok(0)`: the stream has ended.
    End,
}

/// An in-memory `embedded-io-async` serial port following a script of [`Step`]s; clones share
/// the script, so a test can add what arrives later while the driver owns the port.
#[derive(Debug, Default, Clone)]
struct ScriptPort {
    script: Rc<RefCell<VecDeque<Step>>>,
    bytes_read: Rc<Cell<usize>>,
}

impl ScriptPort {
    fn new(script: Vec<Step>) -> Self {
        Self {
            script: Rc::new(RefCell::new(script.into())),
            bytes_read: Rc::default(),
        }
    }

    fn arrive(&self, bytes: &[u8]) {
        self.script
            .borrow_mut()
            .push_back(Step::Read(bytes.to_vec()));
    }
}

impl embedded_io_async::ErrorType for ScriptPort {
    type Error = ErrorKind;
}

impl embedded_io_async::Read for ScriptPort {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        poll_fn(|_| {
            let mut script = self.script.borrow_mut();
            match script.front_mut() {
                Some(Step::Read(bytes)) => {
                    let n = buf.len().min(bytes.len());
                    buf[..n].copy_from_slice(&bytes[..n]);
                    bytes.drain(..n);
                    if bytes.is_empty() {
                        script.pop_front();
                    }
                    self.bytes_read.set(self.bytes_read.get() + n);
                    Poll::Ready(Ok(n))
                }
                Some(Step::ReadError(kind)) => {
                    let kind = *kind;
                    script.pop_front();
                    Poll::Ready(Err(kind))
                }
                Some(Step::End) => Poll::Ready(Ok(0)),
                None => Poll::Pending,
            }
        })
        .await
    }
}

/// A delay that returns at once and adds up what it was asked to wait.
#[derive(Debug, Default)]
struct InstantDelay {
    waited_ns: u64,
}

impl embedded_hal_async::delay::DelayNs for InstantDelay {
    async fn delay_ns(&mut self, ns: u32) {
        self.waited_ns += u64::from(ns);
    }
}

type Board = SensorBoardAsync<PinMock, ScriptPort>;

/// The answer deadline of the tests, µs: one 4 ms period.
const TIMEOUT_US: u32 = 4_000;

fn board(pin: &[PinTx], script: Vec<Step>) -> Board {
    SensorBoardAsync::new(PinMock::new(pin), ScriptPort::new(script))
}

fn done(board: Board) {
    let (mut pin, serial) = board.release();
    pin.done();
    let script = serial.script.borrow();
    assert!(script.is_empty(), "unused steps: {script:?}");
}

fn read(board: &mut Board) -> Result<Frame, Error<MockError, ErrorKind>> {
    block_on(board.read_frame(&mut InstantDelay::default(), TIMEOUT_US))
}

// The vectors of `driver.rs`.

fn packet() -> [u8; 132] {
    SensorPacket {
        accel: [1, 2, 3],
        temp_raw: 519_888,
        ..SensorPacket::default()
    }
    .encode()
}

#[test]
fn request_pulse_raises_then_lowers_and_a_request_while_high_makes_a_new_edge() {
    let mut b = board(
        &[
            PinTx::set(State::High),
            PinTx::set(State::Low),
            PinTx::set(State::High),
            PinTx::set(State::Low),
            PinTx::set(State::High),
        ],
        vec![],
    );
    b.request().unwrap();
    b.end_request().unwrap();
    b.request().unwrap();
    b.request().unwrap();
    done(b);
}

#[test]
fn pin_error_is_reported() {
    let mut b = board(
        &[PinTx::set(State::High).with_error(MockError::Io(std::io::ErrorKind::NotConnected))],
        vec![],
    );
    assert_eq!(
        b.request(),
        Err(Error::Pin(MockError::Io(std::io::ErrorKind::NotConnected)))
    );
    done(b);
}

#[test]
fn a_half_answer_times_out_and_the_next_read_completes_it() {
    let bytes = packet();
    let port = ScriptPort::new(vec![Step::Read(bytes[..70].to_vec())]);
    let mut b = SensorBoardAsync::new(PinMock::new(&[]), port.clone());
    let mut delay = InstantDelay::default();
    assert_eq!(
        block_on(b.read_frame(&mut delay, TIMEOUT_US)),
        Err(Error::Device(DeviceError::Timeout))
    );
    // The deadline was measured with the delay.
    assert_eq!(delay.waited_ns, u64::from(TIMEOUT_US) * 1_000);
    // The read that lost the race had taken the 70 bytes; they wait in the decoder.
    assert_eq!(port.bytes_read.get(), 70);
    port.arrive(&bytes[70..]);
    match read(&mut b) {
        Ok(Frame::Packet(raw)) => assert_eq!(raw.into_bytes(), bytes),
        other => panic!("unexpected {other:?}"),
    }
    assert_eq!(b.stats().packets, 1);
    assert_eq!(b.stats().bytes_skipped, 0);
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
    let mut b = board(&[], vec![Step::Read(answer)]);
    assert!(matches!(read(&mut b), Ok(Frame::Packet(_))));
    assert_eq!(read(&mut b), Ok(Frame::Info(info)));
    assert_eq!(read(&mut b), Err(Error::Device(DeviceError::Timeout)));
    done(b);
}

#[test]
fn serial_error_is_reported_and_decoding_goes_on() {
    let bytes = packet();
    let mut b = board(
        &[],
        vec![
            Step::Read(bytes[..40].to_vec()),
            Step::ReadError(ErrorKind::InvalidData),
            // The rest of the torn answer, then a whole new one.
            Step::Read(bytes[60..].to_vec()),
            Step::Read(bytes.to_vec()),
        ],
    );
    assert_eq!(read(&mut b), Err(Error::Comm(ErrorKind::InvalidData)));
    match read(&mut b) {
        Ok(Frame::Packet(raw)) => assert_eq!(raw.into_bytes(), bytes),
        other => panic!("unexpected {other:?}"),
    }
    assert!(b.stats().bytes_skipped >= 112);
    done(b);
}

#[test]
fn an_ended_stream_is_a_timeout_not_a_hang() {
    let bytes = packet();
    let mut b = board(&[], vec![Step::Read(bytes[..50].to_vec()), Step::End]);
    let mut delay = InstantDelay::default();
    // A deadline that never comes first: the end of the stream itself answers.
    assert_eq!(
        block_on(b.read_frame(&mut delay, u32::MAX)),
        Err(Error::Device(DeviceError::Timeout))
    );
    b.discard_buffered();
    assert_eq!(b.stats().bytes_skipped, 50);
    let (mut pin, serial) = b.release();
    pin.done();
    assert_eq!(serial.bytes_read.get(), 50);
}

#[test]
fn generated_capture_decodes_to_exactly_the_sent_packets() {
    let mut noise = Noise(0x1234_5678);
    let Capture {
        bytes,
        sent,
        info,
        garbage,
    } = capture::generated(&mut noise);
    // The capture arrives in reads of arbitrary size.
    let mut script = Vec::new();
    let mut rest = &bytes[..];
    while !rest.is_empty() {
        let n = (noise.next() as usize % 300 + 1).min(rest.len());
        let (chunk, tail) = rest.split_at(n);
        script.push(Step::Read(chunk.to_vec()));
        rest = tail;
    }
    let mut b = board(&[], script);
    let mut packets = Vec::new();
    let mut infos = 0;
    loop {
        let frame = match read(&mut b) {
            Ok(frame) => frame,
            // The capture is over: the port has nothing more.
            Err(Error::Device(DeviceError::Timeout)) => break,
            Err(e) => panic!("port error {e:?}"),
        };
        match frame {
            Frame::Packet(raw) => packets.push(raw.decode()),
            Frame::Info(got) => {
                assert_eq!(got, info);
                infos += 1;
            }
        }
    }
    assert_eq!(packets, sent);
    assert_eq!(infos, 2);
    let pvt = packets[150].nav_pvt().expect("GNSS present");
    assert_eq!(pvt.itow_ms, 150_000);
    let stats = b.stats();
    assert_eq!(stats.packets, 200);
    assert_eq!(stats.info_frames, 2);
    assert_eq!(stats.bytes_skipped, garbage);
    done(b);
}
