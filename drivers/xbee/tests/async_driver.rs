//! The async driver on a scripted `embedded-io-async` port: the digi-xbee vectors of
//! `vectors.rs` in both directions, the frame decoder's resynchronisation and cancel-safety, and
//! AT command-mode dialogues with the guard times awaited on a delay that only counts.
#![cfg(feature = "async")]

mod digi_vectors;

use std::cell::Cell;
use std::collections::VecDeque;
use std::future::{poll_fn, Future};
use std::pin::pin;
use std::rc::Rc;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use digi_vectors::{frames, AT_NI_QUERY, AT_NI_RESPONSE, RX_API1, RX_API2, TX_API1, TX_API2};
use embedded_io_async::{ErrorKind, Write as _};
use xbee_driver::{
    encode, settings, Address16, Address64, Api, ApiEscaping, AtCommand, AtRequest, CommandTiming,
    DeviceError, Error, Frame, FrameError, Mode, Parameter, PowerLevel, Transparent, XBeeAsync,
};

struct NoopWake;
impl Wake for NoopWake {
    fn wake(self: Arc<Self>) {}
}

/// Polls `fut` up to `polls` times; `None` if it is still pending then.
fn poll_up_to<F: Future>(fut: F, polls: usize) -> Option<F::Output> {
    let waker = Waker::from(Arc::new(NoopWake));
    let mut cx = Context::from_waker(&waker);
    let mut fut = pin!(fut);
    (0..polls).find_map(|_| match fut.as_mut().poll(&mut cx) {
        Poll::Ready(out) => Some(out),
        Poll::Pending => None,
    })
}

/// Runs a future that waits on nothing outside the script and the counting delay.
fn block_on<F: Future>(fut: F) -> F::Output {
    poll_up_to(fut, 10_000).expect("future did not complete")
}

/// One step of what the module side of the link does.
#[derive(Debug)]
enum Step {
    /// The driver must write exactly these bytes (in one or more `write` calls).
    Write(Vec<u8>),
    /// These bytes are waiting to be read; a read with no `Read` step first waits forever.
    Read(Vec<u8>),
    /// The next read waits once (the bytes after it arrive later).
    Gap,
    /// Reads wait until the delay clock reaches this many ns.
    SilentUntil(u64),
    /// The next `write` takes nothing: `Ok(0)`.
    WriteZero,
    /// The next `flush` is expected.
    Flush,
}

use Step::{Flush as F, Gap, Read as R, Write as W};

/// An in-memory `embedded-io-async` serial port following a script of [`Step`]s; it notes the
/// delay clock at each write, to check the guard times.
#[derive(Debug)]
struct ScriptPort {
    script: VecDeque<Step>,
    clock_ns: Rc<Cell<u64>>,
    writes: Vec<(Vec<u8>, u64)>,
}

impl ScriptPort {
    fn new(script: Vec<Step>, clock_ns: Rc<Cell<u64>>) -> Self {
        Self {
            script: script.into(),
            clock_ns,
            writes: Vec::new(),
        }
    }

    fn push(&mut self, steps: Vec<Step>) {
        self.script.extend(steps);
    }

    fn done(&self) {
        assert!(self.script.is_empty(), "unused steps: {:?}", self.script);
    }
}

impl embedded_io_async::ErrorType for ScriptPort {
    type Error = ErrorKind;
}

impl embedded_io_async::Write for ScriptPort {
    async fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        if let Some(Step::WriteZero) = self.script.front() {
            self.script.pop_front();
            return Ok(0);
        }
        let Some(Step::Write(expected)) = self.script.front_mut() else {
            panic!("unexpected write {buf:02X?}, script: {:?}", self.script);
        };
        let n = buf.len().min(expected.len());
        assert_eq!(&buf[..n], &expected[..n], "written bytes");
        expected.drain(..n);
        if expected.is_empty() {
            self.script.pop_front();
        }
        self.writes.push((buf[..n].to_vec(), self.clock_ns.get()));
        Ok(n)
    }

    async fn flush(&mut self) -> Result<(), ErrorKind> {
        if let Some(Step::Flush) = self.script.front() {
            self.script.pop_front();
        }
        Ok(())
    }
}

impl embedded_io_async::Read for ScriptPort {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        poll_fn(|_| {
            if let Some(&Step::SilentUntil(ns)) = self.script.front() {
                if self.clock_ns.get() >= ns {
                    self.script.pop_front();
                }
            }
            self.poll_read(buf)
        })
        .await
    }
}

impl ScriptPort {
    fn poll_read(&mut self, buf: &mut [u8]) -> Poll<Result<usize, ErrorKind>> {
        match self.script.front_mut() {
            Some(Step::Read(bytes)) => {
                let n = buf.len().min(bytes.len());
                buf[..n].copy_from_slice(&bytes[..n]);
                bytes.drain(..n);
                if bytes.is_empty() {
                    self.script.pop_front();
                }
                Poll::Ready(Ok(n))
            }
            Some(Step::Gap) => {
                self.script.pop_front();
                Poll::Pending
            }
            _ => Poll::Pending,
        }
    }
}

/// A delay that returns at once and adds what it was asked to wait to a shared clock.
#[derive(Debug, Clone)]
struct CountingDelay {
    clock_ns: Rc<Cell<u64>>,
}

impl embedded_hal_async::delay::DelayNs for CountingDelay {
    async fn delay_ns(&mut self, ns: u32) {
        self.clock_ns.set(self.clock_ns.get() + u64::from(ns));
    }
}

const MS: u64 = 1_000_000;

/// A port and a delay sharing one clock.
fn port_and_delay(script: Vec<Step>) -> (ScriptPort, CountingDelay) {
    let clock_ns = Rc::new(Cell::new(0));
    let delay = CountingDelay {
        clock_ns: clock_ns.clone(),
    };
    (ScriptPort::new(script, clock_ns), delay)
}

fn api(script: Vec<Step>, escaping: ApiEscaping) -> XBeeAsync<ScriptPort, Api> {
    XBeeAsync::new_api(port_and_delay(script).0, escaping)
}

#[test]
fn send_writes_the_digi_bytes_in_both_api_modes() {
    for (frame, api1, api2) in frames() {
        for (escaping, bytes) in [(ApiEscaping::Unescaped, api1), (ApiEscaping::Escaped, api2)] {
            let mut radio = api(vec![W(bytes.to_vec()), F], escaping);
            block_on(radio.send(&frame)).unwrap();
            radio.release().done();
        }
    }
}

#[test]
fn a_long_frame_goes_out_as_the_encoder_writes_it() {
    // Longer than the driver's write chunk, with bytes API 2 escapes at every position.
    let data: Vec<u8> = (0..300u32)
        .map(|i| [0x7E, 0x7D, 0x11, 0x13, 0x42][(i % 5) as usize])
        .collect();
    let frame = Frame::Unknown {
        frame_type: 0x10,
        data: &data,
    };
    for escaping in [ApiEscaping::Unescaped, ApiEscaping::Escaped] {
        let mut expected = vec![0u8; 700];
        let n = encode(&frame, escaping, &mut expected).unwrap();
        expected.truncate(n);
        let mut radio = api(vec![W(expected), F], escaping);
        block_on(radio.send(&frame)).unwrap();
        radio.release().done();
    }
    // Too long for the length field: refused before anything is written.
    let data = vec![0u8; 65_535];
    let mut radio = api(vec![], ApiEscaping::Escaped);
    assert_eq!(
        block_on(radio.send(&Frame::Unknown {
            frame_type: 0xA1,
            data: &data
        })),
        Err(Error::Device(DeviceError::Frame(FrameError::TooLong)))
    );
    radio.release().done();
}

#[test]
fn transmit_and_at_command_take_fresh_frame_ids() {
    for (escaping, expected) in [
        (ApiEscaping::Unescaped, TX_API1),
        (ApiEscaping::Escaped, TX_API2),
    ] {
        let mut radio = api(vec![W(expected.to_vec()), F], escaping);
        let id = block_on(radio.transmit(Address64(0x0013_A200_40A1_B2C3), b"Hi")).unwrap();
        assert_eq!(id, 1);
        radio.release().done();
    }
    let mut radio = api(vec![W(AT_NI_QUERY.to_vec()), F], ApiEscaping::Escaped);
    let long = [0u8; 33];
    assert_eq!(
        block_on(radio.send_at_command(AtCommand::NI, Parameter::Text(&long))),
        Err(Error::Device(DeviceError::InvalidInput))
    );
    // The refused parameter cost no frame id: the query goes out as digi-xbee's id 1.
    assert_eq!(
        block_on(radio.send_at_command(AtCommand::NI, Parameter::None)),
        Ok(1)
    );
    radio.release().done();
}

#[test]
fn read_frame_decodes_the_digi_bytes_in_both_api_modes() {
    for (frame, api1, api2) in frames() {
        for (escaping, bytes) in [(ApiEscaping::Unescaped, api1), (ApiEscaping::Escaped, api2)] {
            let mut radio = api(vec![R(bytes.to_vec())], escaping);
            assert_eq!(block_on(radio.read_frame()), Ok(frame), "{escaping:?}");
            assert_eq!(radio.stats().frames, 1);
            // Nothing more has arrived: the next read waits.
            assert!(poll_up_to(radio.read_frame(), 10).is_none());
            radio.release().done();
        }
    }
}

#[test]
fn a_frame_split_across_reads_after_garbage_is_resynchronised_and_counted() {
    let mut script = vec![R(vec![0x00, 0x55, 0x13]), Gap];
    script.push(R(RX_API2[..5].to_vec()));
    script.push(Gap);
    script.push(R(RX_API2[5..14].to_vec()));
    script.push(Gap);
    script.push(R(RX_API2[14..].to_vec()));
    script.push(R(AT_NI_RESPONSE.to_vec()));
    let mut radio = api(script, ApiEscaping::Escaped);
    match block_on(radio.read_frame()) {
        Ok(Frame::ReceivePacket(rx)) => {
            assert_eq!(rx.source, Address64(0x0013_A200_4052_2BAA));
            assert_eq!(rx.source_16, Address16(0x7D84));
            assert_eq!(rx.data, b"RxData");
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(matches!(
        block_on(radio.read_frame()),
        Ok(Frame::AtResponse(_))
    ));
    let stats = radio.stats();
    assert_eq!(stats.frames, 2);
    assert_eq!(stats.discarded_bytes, 3);
    radio.release().done();
}

#[test]
fn a_dropped_read_frame_keeps_the_bytes_it_read() {
    let (port, _) = port_and_delay(vec![R(RX_API1[..9].to_vec())]);
    let mut radio: XBeeAsync<_, Api> = XBeeAsync::new_api(port, ApiEscaping::Unescaped);
    // The first half arrives, then nothing: the read is dropped while it waits.
    assert!(poll_up_to(radio.read_frame(), 50).is_none());
    radio.serial_mut().done();
    radio.serial_mut().push(vec![R(RX_API1[9..].to_vec())]);
    match block_on(radio.read_frame()) {
        Ok(Frame::ReceivePacket(rx)) => assert_eq!(rx.data, b"RxData"),
        other => panic!("unexpected {other:?}"),
    }
    assert_eq!(radio.stats().discarded_bytes, 0);
    radio.release().done();
}

#[test]
fn write_returning_zero_is_a_timeout_not_a_panic() {
    let mut radio = api(vec![Step::WriteZero], ApiEscaping::Unescaped);
    assert_eq!(
        block_on(radio.transmit(Address64(0x0013_A200_40A1_B2C3), b"Hi")),
        Err(Error::Device(DeviceError::Timeout))
    );
    radio.release().done();

    // The transparent pipe's `write_all` reports it as well.
    let (port, _) = port_and_delay(vec![W(b"$".to_vec()), Step::WriteZero]);
    let mut pipe = XBeeAsync::new(port);
    assert_eq!(
        block_on(pipe.write_all(b"$D")),
        Err(Error::Device(DeviceError::Timeout))
    );
    pipe.release().done();
}

/// Factory timing without the extra guard margin, so that the times are round numbers.
fn radio(script: Vec<Step>) -> (XBeeAsync<ScriptPort, Transparent>, CountingDelay) {
    let (port, delay) = port_and_delay(script);
    let timing = CommandTiming::default().with_guard_margin_ms(0);
    (XBeeAsync::with_timing(port, timing), delay)
}

#[test]
fn command_mode_dialogue_waits_the_guard_times() {
    let (mut r, mut delay) = radio(vec![
        W(b"$".to_vec()),
        F,
        W(b"+++".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"ATPL2\r".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"ATID\r".to_vec()),
        R(b"7FFF\r".to_vec()),
        W(b"ATPL\r".to_vec()),
        R(b"2\r".to_vec()),
        W(b"ATCH\r".to_vec()),
        R(b"ZZ\r".to_vec()),
        W(b"ATCN\r".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"$".to_vec()),
    ]);
    block_on(r.write_all(b"$")).unwrap();
    let mut session = block_on(r.command_mode(&mut delay)).unwrap();
    block_on(session.set(&settings::set_power_level(PowerLevel::Medium))).unwrap();
    assert_eq!(block_on(session.query_number(AtCommand::ID)), Ok(0x7FFF));
    assert_eq!(
        block_on(session.query(AtCommand::PL, settings::parse_power_level)),
        Ok(PowerLevel::Medium)
    );
    assert_eq!(
        block_on(session.query(AtCommand::CH, settings::parse_channel)),
        Err(Error::Device(DeviceError::InvalidReply))
    );
    block_on(session.exit()).unwrap();
    assert_eq!(r.mode(), Mode::Transparent);
    block_on(r.write_all(b"$")).unwrap();

    let port = r.release();
    port.done();
    // `+++` after a guard time of silence; the module's own guard time is its reply's business.
    let times: Vec<(&[u8], u64)> = port.writes.iter().map(|(b, t)| (&b[..], *t)).collect();
    assert_eq!(
        times,
        vec![
            (&b"$"[..], 0),
            (b"+++", 1000 * MS),
            (b"ATPL2\r", 1000 * MS),
            (b"ATID\r", 1000 * MS),
            (b"ATPL\r", 1000 * MS),
            (b"ATCH\r", 1000 * MS),
            (b"ATCN\r", 1000 * MS),
            (b"$", 1000 * MS),
        ]
    );
}

#[test]
fn guard_margin_is_added_before_the_command_sequence() {
    let (port, mut delay) = port_and_delay(vec![F, W(b"+++".to_vec()), R(b"OK\r".to_vec())]);
    let mut r = XBeeAsync::new(port);
    // The session is dropped at once, without `exit`.
    let _ = block_on(r.command_mode(&mut delay)).unwrap();
    let port = r.release();
    port.done();
    assert_eq!(port.writes, vec![(b"+++".to_vec(), 1050 * MS)]);
}

#[test]
fn a_module_that_never_answers_is_a_timeout_and_data_waits_out_ct() {
    let (mut r, mut delay) = radio(vec![F, W(b"+++".to_vec()), W(b"!".to_vec())]);
    assert_eq!(
        block_on(r.command_mode(&mut delay)).err(),
        Some(Error::Device(DeviceError::Timeout))
    );
    // GT before `+++`, then GT plus the reply timeout for the `OK`.
    assert_eq!(delay.clock_ns.get(), 3000 * MS);
    // The module may have switched without being heard: data is refused, not sent as AT text.
    assert_eq!(r.mode(), Mode::Command);
    assert_eq!(
        block_on(r.write_all(b"!")),
        Err(Error::Device(DeviceError::CommandModeActive))
    );
    let mut buf = [0u8; 4];
    assert_eq!(
        block_on(embedded_io_async::Read::read(&mut r, &mut buf)),
        Err(Error::Device(DeviceError::CommandModeActive))
    );
    // Until CT plus the reply timeout (11 s) after `+++` have surely passed.
    block_on(r.wait_until_transparent(&mut delay));
    assert_eq!(delay.clock_ns.get(), (1000 + 11_000) * MS);
    assert!(r.is_transparent());
    block_on(r.write_all(b"!")).unwrap();
    r.release().done();
}

#[test]
fn an_error_reply_is_an_at_error_and_the_session_stays_open() {
    let (mut r, mut delay) = radio(vec![
        F,
        W(b"+++".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"ATCH1A\r".to_vec()),
        R(b"ERROR\r".to_vec()),
        W(b"ATCN\r".to_vec()),
        R(b"OK\r".to_vec()),
    ]);
    let mut session = block_on(r.command_mode(&mut delay)).unwrap();
    let request = settings::set_channel(0x1A).unwrap();
    assert_eq!(
        block_on(session.set(&request)),
        Err(Error::Device(DeviceError::AtError))
    );
    block_on(session.exit()).unwrap();
    assert!(r.is_transparent());
    r.release().done();
}

#[test]
fn a_late_reply_is_discarded_before_the_next_command() {
    let (mut r, mut delay) = radio(vec![
        F,
        W(b"+++".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"ATID\r".to_vec()),
        // Sent after the 1 s guard time: the reply comes after the reply timeout of 1 s.
        Step::SilentUntil(2000 * MS),
        R(b"3332\r".to_vec()),
        W(b"ATPL\r".to_vec()),
        R(b"2\r".to_vec()),
        W(b"ATCN\r".to_vec()),
        R(b"OK\r".to_vec()),
    ]);
    let mut session = block_on(r.command_mode(&mut delay)).unwrap();
    assert_eq!(
        block_on(session.query_number(AtCommand::ID)),
        Err(Error::Device(DeviceError::Timeout))
    );
    assert_eq!(
        block_on(session.send(&AtRequest::query(AtCommand::PL))),
        Ok(&b"2"[..])
    );
    block_on(session.exit()).unwrap();
    assert_eq!(r.discarded_bytes(), 5);
    r.release().done();
}

#[test]
fn a_session_dropped_without_exit_keeps_data_refused() {
    let (mut r, mut delay) = radio(vec![
        F,
        W(b"+++".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"ATCN\r".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"$".to_vec()),
    ]);
    // The session is dropped at once, without `exit`.
    let _ = block_on(r.command_mode(&mut delay)).unwrap();
    assert_eq!(r.mode(), Mode::Command);
    assert_eq!(
        block_on(r.write_all(b"$")),
        Err(Error::Device(DeviceError::CommandModeActive))
    );
    // Still well within CT: a new session opens at once (no second `+++`) and leaves.
    let clock = delay.clock_ns.clone();
    let before = clock.get();
    let session = block_on(r.command_mode(&mut delay)).unwrap();
    assert_eq!(clock.get(), before);
    block_on(session.exit()).unwrap();
    block_on(r.write_all(b"$")).unwrap();
    r.release().done();
}

#[test]
fn a_command_too_close_to_ct_is_refused_and_exit_waits_ct_out() {
    // CT of 3 s and a reply timeout of 1 s: a command may start at most (3 - 1) / 2 = 1 s after
    // the last accepted one.
    let (port, mut delay) = port_and_delay(vec![
        F,
        W(b"+++".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"ATID\r".to_vec()),
        Gap, // no reply: the reply timeout of 1 s runs out
    ]);
    let timing = CommandTiming::default()
        .with_guard_margin_ms(0)
        .with_command_timeout_ms(3000);
    let mut r = XBeeAsync::with_timing(port, timing);
    let clock = delay.clock_ns.clone();
    let mut session = block_on(r.command_mode(&mut delay)).unwrap();
    assert_eq!(
        block_on(session.query_number(AtCommand::ID)),
        Err(Error::Device(DeviceError::Timeout))
    );
    // Over 1 s since `+++`, the last input the module accepted: no more commands.
    assert_eq!(
        block_on(session.send(&AtRequest::query(AtCommand::PL))),
        Err(Error::Device(DeviceError::NotInCommandMode))
    );
    assert_eq!(clock.get(), 2000 * MS);
    // Leaving sends no `ATCN` that might arrive as data: it waits until CT plus the reply
    // timeout have surely passed since `ATID` went out (at 1 s).
    block_on(session.exit()).unwrap();
    assert_eq!(clock.get(), (1000 + 4000) * MS);
    assert!(r.is_transparent());
    r.release().done();
}

#[test]
fn a_reply_already_there_is_taken_even_with_a_zero_reply_timeout() {
    let (port, mut delay) = port_and_delay(vec![
        F,
        W(b"+++".to_vec()),
        R(b"OK\r".to_vec()),
        W(b"ATPL\r".to_vec()),
        R(b"4\r".to_vec()),
        W(b"ATPL\r".to_vec()),
    ]);
    let timing = CommandTiming::default()
        .with_guard_margin_ms(0)
        .with_reply_timeout_ms(0);
    let mut r = XBeeAsync::with_timing(port, timing);
    let mut session = block_on(r.command_mode(&mut delay)).unwrap();
    assert_eq!(
        block_on(session.send(&AtRequest::query(AtCommand::PL))),
        Ok(&b"4"[..])
    );
    // No reply waiting: the zero timeout ends the wait at once.
    assert_eq!(
        block_on(session.send(&AtRequest::query(AtCommand::PL))),
        Err(Error::Device(DeviceError::Timeout))
    );
    r.release().done();
}
