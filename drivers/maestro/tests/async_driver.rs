//! The async driver writes the same bytes as the blocking one (the vectors of `driver.rs`) and
//! reads replies against a deadline raced with the read.
#![cfg(feature = "async")]

use std::collections::VecDeque;
use std::future::{poll_fn, Future};
use std::pin::pin;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use embedded_io_async::ErrorKind;
use pololu_maestro::{
    AsyncDeadline, AsyncDelayDeadline, AsyncIoSerial, Channel, ChannelLimits, DeviceError,
    DeviceNumber, Error, ErrorFlags, Framing, Limits, MaestroAsync, Micro6, Mini12, PwmTiming,
    QuarterMicros, ScriptParameter, ScriptStatus, Speed, Subroutine, TargetError,
};

struct NoopWake;
impl Wake for NoopWake {
    fn wake(self: Arc<Self>) {}
}

/// Runs a future that never waits on anything outside the mocks (they complete at once or
/// stay pending, and the deadline completes at once).
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

/// One step of what the Maestro side of the link does.
#[derive(Debug)]
enum Step {
    /// The driver must write exactly these bytes (in one or more `write` calls).
    Write(Vec<u8>),
    /// These bytes are waiting to be read; a read with no `Read` step first waits forever.
    Read(Vec<u8>),
    /// The next read fails.
    ReadError(ErrorKind),
}

/// An in-memory `embedded-io-async` serial port following a script of [`Step`]s.
#[derive(Debug)]
struct ScriptPort {
    script: VecDeque<Step>,
    flushes: u32,
}

impl ScriptPort {
    fn new(script: Vec<Step>) -> Self {
        Self {
            script: script.into(),
            flushes: 0,
        }
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
        let Some(Step::Write(expected)) = self.script.front_mut() else {
            panic!("unexpected write {buf:02X?}, script: {:?}", self.script);
        };
        let n = buf.len().min(expected.len());
        assert_eq!(&buf[..n], &expected[..n], "written bytes");
        expected.drain(..n);
        if expected.is_empty() {
            self.script.pop_front();
        }
        Ok(n)
    }

    async fn flush(&mut self) -> Result<(), ErrorKind> {
        self.flushes += 1;
        Ok(())
    }
}

impl embedded_io_async::Read for ScriptPort {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        poll_fn(|_| match self.script.front_mut() {
            Some(Step::Read(bytes)) => {
                let n = buf.len().min(bytes.len());
                buf[..n].copy_from_slice(&bytes[..n]);
                bytes.drain(..n);
                if bytes.is_empty() {
                    self.script.pop_front();
                }
                Poll::Ready(Ok(n))
            }
            Some(Step::ReadError(kind)) => {
                let kind = *kind;
                self.script.pop_front();
                Poll::Ready(Err(kind))
            }
            _ => Poll::Pending,
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

/// A deadline that never expires: the reply decides.
struct Never;
impl AsyncDeadline for Never {
    async fn expire(&mut self) {
        std::future::pending::<()>().await
    }
}

type Port = AsyncIoSerial<ScriptPort>;

fn micro(script: Vec<Step>) -> MaestroAsync<Port, Micro6> {
    MaestroAsync::new_io(ScriptPort::new(script), Micro6, Framing::COMPACT)
}

fn ch6(n: u8) -> Channel {
    Channel::new::<Micro6>(n).unwrap()
}

fn us(v: u16) -> QuarterMicros {
    QuarterMicros::from_micros(v).unwrap()
}

fn dima_limits() -> Limits {
    Limits::new()
        .with(
            ch6(0),
            ChannelLimits::from_micros(1000, 2000, 1500).unwrap(),
        )
        .with(
            ch6(1),
            ChannelLimits::from_micros(1250, 1840, 1545).unwrap(),
        )
        .with(
            ch6(2),
            ChannelLimits::from_micros(1000, 2000, 1500).unwrap(),
        )
}

use Step::{Read as R, ReadError as RE, Write as W};

#[test]
fn set_target_writes_one_packet() {
    let mut m = micro(vec![W(vec![0x84, 0x02, 0x70, 0x2E])]);
    block_on(m.set_target(ch6(2), us(1500))).unwrap();
    m.release().done();
}

#[test]
fn set_targets_is_one_frame() {
    let mut m = micro(vec![W(vec![
        0x84, 0x00, 0x70, 0x2E, 0x84, 0x01, 0x40, 0x39, 0x84, 0x02, 0x40, 0x3E,
    ])])
    .with_limits(dima_limits());
    block_on(m.set_targets(&[(ch6(0), us(1500)), (ch6(1), us(1840)), (ch6(2), us(2000))])).unwrap();
    m.release().done();
}

#[test]
fn out_of_range_sends_nothing() {
    let mut m = micro(vec![]).with_limits(dima_limits());
    assert_eq!(
        block_on(m.set_target(ch6(1), us(1900))),
        Err(Error::Target(TargetError::OutOfRange {
            channel: 1,
            target: 7600,
            min: 5000,
            max: 7360
        }))
    );
    assert!(matches!(
        block_on(m.set_targets(&[(ch6(0), us(1500)), (ch6(1), us(1000))])),
        Err(Error::Target(TargetError::OutOfRange { channel: 1, .. }))
    ));
    assert!(block_on(m.set_target(ch6(0), QuarterMicros::OFF)).is_err());
    let ch8 = Channel::new::<Mini12>(8).unwrap();
    assert_eq!(
        block_on(m.set_target(ch8, us(1500))),
        Err(Error::Target(TargetError::InvalidChannel {
            channel: 8,
            channels: 6
        }))
    );
    m.release().done();
}

#[test]
fn stop_pulses_and_neutral() {
    let mut m = micro(vec![
        W(vec![0x84, 0x01, 0x24, 0x30]),
        W(vec![0x84, 0x01, 0x00, 0x00]),
    ])
    .with_limits(dima_limits());
    block_on(m.set_neutral(ch6(1))).unwrap();
    block_on(m.stop_pulses(ch6(1))).unwrap();
    assert_eq!(
        block_on(m.set_neutral(ch6(4))),
        Err(Error::Target(TargetError::InvalidInput))
    );
    m.release().done();
}

#[test]
fn get_position_round_trip() {
    let mut m = micro(vec![W(vec![0x90, 0x02]), R(vec![0x70]), R(vec![0x17])]);
    let mut delay = InstantDelay::default();
    let position = block_on(m.get_position(ch6(2), &mut Never)).unwrap();
    assert_eq!(position.get(), 6000);
    assert_eq!(delay.waited_ns, 0);
    // The same query with a delay deadline: the reply is there before the delay is asked.
    let mut m = micro(vec![W(vec![0x90, 0x02]), R(vec![0x70, 0x17])]);
    let mut deadline = AsyncDelayDeadline::new(&mut delay, 2_000);
    assert_eq!(
        block_on(m.get_position(ch6(2), &mut deadline))
            .unwrap()
            .get(),
        6000
    );
    assert_eq!(delay.waited_ns, 0);
    m.release().done();
}

#[test]
fn short_reply_is_a_timeout_after_the_delay() {
    let mut m = micro(vec![W(vec![0x90, 0x00]), R(vec![0x70])]);
    let mut delay = InstantDelay::default();
    assert_eq!(
        block_on(m.get_position(ch6(0), &mut AsyncDelayDeadline::new(&mut delay, 2_000))),
        Err(Error::Device(DeviceError::Timeout))
    );
    assert_eq!(delay.waited_ns, 2_000_000);
    m.release().done();
}

#[test]
fn missing_reply_is_a_timeout() {
    let mut m = micro(vec![W(vec![0xA1])]);
    let mut delay = InstantDelay::default();
    assert_eq!(
        block_on(m.get_errors(&mut AsyncDelayDeadline::new(&mut delay, 500))),
        Err(Error::Device(DeviceError::Timeout))
    );
    assert_eq!(delay.waited_ns, 500_000);
    m.release().done();
}

#[test]
fn stale_bytes_are_discarded_before_a_query() {
    let mut m = micro(vec![
        R(vec![0x12, 0x34]),
        W(vec![0xA1]),
        R(vec![0x08, 0x00]),
    ]);
    assert_eq!(
        block_on(m.get_errors(&mut Never)).unwrap(),
        ErrorFlags::SERIAL_CRC
    );
    assert_eq!(m.stale_bytes(), 2);
    m.release().done();
}

#[test]
fn sixty_four_stale_bytes_are_discarded_and_the_query_goes_out() {
    let mut m = micro(vec![R(vec![0x55; 64]), W(vec![0xA1]), R(vec![0x00, 0x00])]);
    assert_eq!(block_on(m.get_errors(&mut Never)), Ok(ErrorFlags::empty()));
    assert_eq!(m.stale_bytes(), 64);
    m.release().done();
}

#[test]
fn endless_unasked_data_fails_the_query() {
    let mut m = micro(vec![R(vec![0x55; 65])]);
    assert_eq!(
        block_on(m.get_errors(&mut Never)),
        Err(Error::Device(DeviceError::UnexpectedData))
    );
    assert_eq!(m.stale_bytes(), 65);
    m.release().done();
}

#[test]
fn transport_error_is_comm() {
    let mut m = micro(vec![W(vec![0xAE]), RE(ErrorKind::InvalidData)]);
    assert_eq!(
        block_on(m.get_script_status(&mut Never)),
        Err(Error::Comm(ErrorKind::InvalidData))
    );
    m.release().done();
}

#[test]
fn script_commands_and_status() {
    let mut m = micro(vec![
        W(vec![0xA4]),
        W(vec![0xA7, 0x03]),
        W(vec![0xA8, 0x03, 0x70, 0x2E]),
        W(vec![0xAE]),
        R(vec![0x01]),
        W(vec![0xAE]),
        R(vec![0x07]),
        W(vec![0xA2]),
    ]);
    block_on(m.stop_script()).unwrap();
    block_on(m.restart_script(Subroutine::new(3).unwrap())).unwrap();
    block_on(m.restart_script_with_parameter(
        Subroutine::new(3).unwrap(),
        ScriptParameter::new(6000).unwrap(),
    ))
    .unwrap();
    assert_eq!(
        block_on(m.get_script_status(&mut Never)).unwrap(),
        ScriptStatus::Stopped
    );
    assert_eq!(
        block_on(m.get_script_status(&mut Never)),
        Err(Error::Device(DeviceError::InvalidReply(0x07)))
    );
    block_on(m.go_home()).unwrap();
    m.release().done();
}

#[test]
fn mini_only_commands_pololu_protocol_with_crc() {
    let framing = Framing::pololu(DeviceNumber::DEFAULT).with_crc(true);
    let with_crc = |bytes: &[u8]| {
        let mut v = bytes.to_vec();
        v.push(pololu_maestro::crc7(bytes));
        v
    };
    let mut m = MaestroAsync::new_io(
        ScriptPort::new(vec![
            W(with_crc(&[0xAA, 0x0C, 0x0A, 0x60, 0x00, 0x40, 0x01])),
            W(with_crc(&[
                0xAA, 0x0C, 0x1F, 0x02, 0x03, 0x00, 0x00, 0x70, 0x2E,
            ])),
            W(with_crc(&[0xAA, 0x0C, 0x13])),
            R(vec![0x01]),
        ]),
        Mini12,
        framing,
    );
    block_on(m.set_pwm(PwmTiming::new(96, 192).unwrap())).unwrap();
    let ch = |n| Channel::new::<Mini12>(n).unwrap();
    block_on(m.set_multiple_targets(ch(3), &[QuarterMicros::OFF, QuarterMicros::NEUTRAL])).unwrap();
    assert!(block_on(m.get_moving_state(&mut Never)).unwrap());
    assert!(block_on(
        m.set_multiple_targets(ch(11), &[QuarterMicros::NEUTRAL, QuarterMicros::NEUTRAL])
    )
    .is_err());
    m.release().done();
}

#[test]
fn speed_and_acceleration() {
    let mut m = micro(vec![
        W(vec![0x87, 0x05, 0x0C, 0x01]),
        W(vec![0x89, 0x05, 0x04, 0x00]),
    ]);
    block_on(m.set_speed(ch6(5), Speed::new(140).unwrap())).unwrap();
    block_on(m.set_acceleration(ch6(5), pololu_maestro::Acceleration::new(4))).unwrap();
    m.release().done();
}

#[test]
fn flush_is_passed_through_and_encoding_needs_no_io() {
    let mut m = micro(vec![W(vec![0xA2])]).with_limits(dima_limits());
    block_on(m.go_home()).unwrap();
    block_on(m.flush()).unwrap();
    assert_eq!(m.interface().inner().flushes, 1);
    let frame = m
        .encode_targets(&[(ch6(0), us(1500)), (ch6(1), us(1840)), (ch6(2), us(2000))])
        .unwrap();
    assert_eq!(
        frame.as_bytes(),
        &[0x84, 0x00, 0x70, 0x2E, 0x84, 0x01, 0x40, 0x39, 0x84, 0x02, 0x40, 0x3E]
    );
    m.release().done();
}
