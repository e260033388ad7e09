//! The async driver against an in-memory `embedded-io-async` port: the vectors of `driver.rs`
//! and `configure.rs` (golden frames, the `ublox` crate's MON-VER payload), with answer
//! deadlines raced against a delay.
#![cfg(feature = "async")]

use std::collections::VecDeque;
use std::future::{poll_fn, Future};
use std::pin::pin;
use std::sync::Arc;
use std::task::{Context, Poll, Wake, Waker};

use embedded_io_async::ErrorKind;

mod common;
use common::*;
use neo_m8t::commands;
use neo_m8t::{Config, DeviceError, Error, Message, NavPvt, NeoM8tAsync, ProtocolVersion};

struct NoopWake;
impl Wake for NoopWake {
    fn wake(self: Arc<Self>) {}
}

/// Polls `fut` once: what the driver does with the bytes already waiting.
fn poll_once<F: Future>(fut: F) -> Poll<F::Output> {
    let waker = Waker::from(Arc::new(NoopWake));
    let mut cx = Context::from_waker(&waker);
    pin!(fut).as_mut().poll(&mut cx)
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

/// One step of what the receiver side of the link does.
#[derive(Debug)]
enum Step {
    /// The driver must write exactly these bytes (in one or more `write` calls).
    Write(Vec<u8>),
    /// The next `write` returns `Ok(0)`: the port takes nothing.
    WriteZero,
    /// The driver must flush.
    Flush,
    /// These bytes are waiting to be read; a read with no `Read` step first waits forever.
    Read(Vec<u8>),
    /// The next read fails.
    ReadError(ErrorKind),
    /// Every read returns `Ok(0)`: the stream has ended.
    End,
}

/// An in-memory `embedded-io-async` serial port following a script of [`Step`]s; `reads`
/// counts the bytes the driver took.
#[derive(Debug)]
struct ScriptPort {
    script: VecDeque<Step>,
    bytes_read: usize,
}

impl ScriptPort {
    fn new(script: Vec<Step>) -> Self {
        Self {
            script: script.into(),
            bytes_read: 0,
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
        match self.script.front_mut() {
            Some(Step::WriteZero) => {
                self.script.pop_front();
                Ok(0)
            }
            Some(Step::Write(expected)) => {
                let n = buf.len().min(expected.len());
                assert_eq!(&buf[..n], &expected[..n], "written bytes");
                expected.drain(..n);
                if expected.is_empty() {
                    self.script.pop_front();
                }
                Ok(n)
            }
            _ => panic!("unexpected write {buf:02X?}, script: {:?}", self.script),
        }
    }

    async fn flush(&mut self) -> Result<(), ErrorKind> {
        match self.script.pop_front() {
            Some(Step::Flush) => Ok(()),
            other => panic!("unexpected flush, next step: {other:?}"),
        }
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
                self.bytes_read += n;
                Poll::Ready(Ok(n))
            }
            Some(Step::ReadError(kind)) => {
                let kind = *kind;
                self.script.pop_front();
                Poll::Ready(Err(kind))
            }
            Some(Step::End) => Poll::Ready(Ok(0)),
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

// The vectors of `driver.rs`.

fn pvt(itow_ms: u32) -> [u8; 100] {
    *NavPvt {
        itow_ms,
        fix_type: 3,
        ..NavPvt::default()
    }
    .to_frame()
    .as_bytes()
}

fn write(bytes: &[u8]) -> Step {
    Step::Write(bytes.to_vec())
}

fn reply(bytes: &[u8]) -> Step {
    Step::Read(bytes.to_vec())
}

/// Script up to and including the ACK of CFG-PRT, no baud change.
fn prefix(config: &Config) -> Vec<Step> {
    let prt = commands::cfg_prt_uart1(config.baud_rate);
    vec![
        write(&MON_VER_POLL),
        reply(&mon_ver_reply()),
        write(prt.as_bytes()),
        reply(&ack(prt.as_bytes())),
    ]
}

type Gnss<const N: usize> = NeoM8tAsync<ScriptPort, N>;

/// Configures at 115200 baud with an instant delay; returns the result and the host baud-rate
/// changes asked for.
fn configure(
    gnss: &mut Gnss<512>,
    config: Config,
    baud: u32,
) -> (Result<neo_m8t::ReceiverVersion, Error<ErrorKind>>, Vec<u32>) {
    let mut delay = InstantDelay::default();
    let mut switches = Vec::new();
    let result = block_on(gnss.configure(config, baud, &mut delay, |_, b| switches.push(b)));
    (result, switches)
}

#[test]
fn nav_pvt_is_found_in_a_split_stream_with_garbage() {
    let mut bad = pvt(100);
    bad[30] ^= 0xFF;
    let good = pvt(200);
    let mut gnss: Gnss<100> = NeoM8tAsync::with_capacity(ScriptPort::new(vec![
        reply(&[0x47, 0x50]), // "GP": left-over NMEA
        reply(&bad),
        reply(&good[..37]),
        reply(&good[37..]),
    ]));
    match block_on(gnss.read_message()) {
        Ok(Message::NavPvt(f)) => assert_eq!(f.to_nav_pvt().itow_ms, 200),
        other => panic!("expected NAV-PVT, got {other:?}"),
    }
    // Nothing more has arrived: the next read waits.
    assert!(poll_once(gnss.read_message()).is_pending());
    let stats = gnss.stream().stats();
    assert_eq!(stats.frames_ok, 1);
    assert_eq!(stats.checksum_errors, 1);
    assert_eq!(stats.bytes_skipped, 102);
    gnss.serial_mut().done();
}

#[test]
fn a_dropped_read_loses_no_byte_it_took() {
    let frame = pvt(300);
    let mut gnss: Gnss<100> =
        NeoM8tAsync::with_capacity(ScriptPort::new(vec![reply(&frame[..60])]));
    // The read takes the 60 waiting bytes, then waits; it is dropped there (a select, a
    // timeout).
    assert!(poll_once(gnss.read_nav_pvt()).is_pending());
    assert_eq!(gnss.serial_mut().bytes_read, 60);
    gnss.serial_mut().script.push_back(reply(&frame[60..]));
    let got = block_on(gnss.read_nav_pvt()).expect("the frame completed by the rest");
    assert_eq!(got.as_bytes(), &frame);
    assert_eq!(gnss.stream().stats().bytes_skipped, 0);
    // Handed out once: the stream does not offer it again as fresh.
    assert_eq!(gnss.stream_mut().take_nav_pvt(), None);
    gnss.serial_mut().done();
}

#[test]
fn read_error_is_a_comm_error_and_drops_the_partial_frame() {
    let a = pvt(100);
    let mut gnss: Gnss<100> = NeoM8tAsync::with_capacity(ScriptPort::new(vec![
        reply(&a[..50]),
        Step::ReadError(ErrorKind::Other),
        reply(&a[60..]),
        reply(&pvt(200)),
    ]));
    assert_eq!(
        block_on(gnss.read_message()),
        Err(Error::Comm(ErrorKind::Other))
    );
    assert_eq!(gnss.line_errors(), 1);
    let frame = block_on(gnss.read_nav_pvt()).expect("the second frame");
    assert_eq!(frame.to_nav_pvt().itow_ms, 200);
    assert_eq!(gnss.stream().stats().bytes_skipped, 90);
    gnss.serial_mut().done();
}

#[test]
fn an_ended_stream_is_a_timeout_naming_what_was_awaited() {
    let mut gnss: Gnss<100> = NeoM8tAsync::with_capacity(ScriptPort::new(vec![Step::End]));
    assert_eq!(
        block_on(gnss.read_message()),
        Err(Error::Device(DeviceError::Timeout {
            class: 0x01,
            id: 0x07
        }))
    );
    // While an ACK is awaited, the command is named; the delay never wins here.
    let rate = commands::cfg_rate(200, 1, neo_m8t::AlignmentToReferenceTime::Gps);
    gnss.serial_mut().script.push_front(write(&CFG_RATE_200MS));
    let mut delay = InstantDelay::default();
    assert_eq!(
        block_on(gnss.send_and_await_ack(&rate, &mut delay, u32::MAX)),
        Err(Error::Device(DeviceError::Timeout {
            class: 0x06,
            id: 0x08
        }))
    );
    gnss.serial_mut().script.pop_front(); // the end of the stream stays
    gnss.serial_mut().done();
}

#[test]
fn full_sequence_without_baud_change_uses_golden_frames_and_reports_version() {
    let config = Config::default().with_measurement_period_ms(200);
    let mut script = vec![write(&MON_VER_POLL), reply(&mon_ver_reply())];
    script.push(write(&CFG_PRT_UART1_115200));
    script.push(reply(&ack(&CFG_PRT_UART1_115200)));
    let cmds = cfg_commands(&config);
    assert_eq!(cmds[0].as_bytes(), &CFG_MSG_NAV_PVT_UART1);
    assert_eq!(cmds[9].as_bytes(), &CFG_RATE_200MS);
    for cmd in &cmds {
        script.push(write(cmd.as_bytes()));
        script.push(reply(&ack(cmd.as_bytes())));
    }
    let mut gnss = NeoM8tAsync::new(ScriptPort::new(script));
    let (result, switches) = configure(&mut gnss, config, 115_200);
    let v = result.expect("configured");
    assert_eq!(switches, Vec::<u32>::new());
    gnss.serial_mut().done();
    assert_eq!(v.software.as_str(), "EXT CORE 3.01 (d189ff)");
    assert_eq!(v.hardware.as_str(), "00080000");
    assert_eq!(v.firmware.as_str(), "ADR 4.11");
    assert_eq!(
        v.protocol,
        Some(ProtocolVersion {
            major: 19,
            minor: 10
        })
    );
}

#[test]
fn nak_is_an_error_naming_the_message() {
    let config = Config::default().with_time_pulse(None);
    let mut script = prefix(&config);
    let cmds = cfg_commands(&config);
    let (nav5, before) = cmds.split_last().unwrap();
    for cmd in before {
        script.push(write(cmd.as_bytes()));
        script.push(reply(&ack(cmd.as_bytes())));
    }
    script.push(write(nav5.as_bytes()));
    script.push(reply(&nak(nav5.as_bytes())));
    let mut gnss = NeoM8tAsync::new(ScriptPort::new(script));
    let (result, _) = configure(&mut gnss, config, 115_200);
    assert_eq!(
        result,
        Err(Error::Device(DeviceError::Nak {
            class: 0x06,
            id: 0x24
        }))
    );
    gnss.serial_mut().done();
}

#[test]
fn a_receiver_that_never_answers_is_a_timeout_after_every_retry() {
    // MON-VER unanswered: sent once and resent DEFAULT_RETRIES times, each wait the default
    // timeout long.
    let attempts = u64::from(neo_m8t::DEFAULT_RETRIES) + 1;
    let script = (0..attempts).map(|_| write(&MON_VER_POLL)).collect();
    let mut gnss = NeoM8tAsync::new(ScriptPort::new(script));
    let mut delay = InstantDelay::default();
    let result = block_on(gnss.configure(Config::default(), 115_200, &mut delay, |_, _| {}));
    assert_eq!(
        result,
        Err(Error::Device(DeviceError::Timeout {
            class: 0x0A,
            id: 0x04
        }))
    );
    let timeout_ns = u64::from(neo_m8t::DEFAULT_TIMEOUT_MS) * 1_000_000;
    assert_eq!(delay.waited_ns, attempts * timeout_ns);
    gnss.serial_mut().done();
}

#[test]
fn an_ack_is_awaited_while_nav_pvt_keeps_arriving() {
    let rate = commands::cfg_rate(200, 1, neo_m8t::AlignmentToReferenceTime::Gps);
    assert_eq!(rate.as_bytes(), &CFG_RATE_200MS);
    let mut gnss: Gnss<100> = NeoM8tAsync::with_capacity(ScriptPort::new(vec![
        write(&CFG_RATE_200MS),
        reply(&pvt(500)),
        reply(&ack(&CFG_PRT_UART1_115200)), // an ACK for something else
        reply(&ack(&CFG_RATE_200MS)),
    ]));
    let mut delay = InstantDelay::default();
    assert_eq!(
        block_on(gnss.send_and_await_ack(&rate, &mut delay, 100)),
        Ok(())
    );
    let latest = gnss.stream_mut().take_nav_pvt().expect("NAV-PVT kept");
    assert_eq!(latest.to_nav_pvt().itow_ms, 500);
    gnss.serial_mut().done();
}

#[test]
fn an_ack_nak_answers_the_command() {
    let rate = commands::cfg_rate(200, 1, neo_m8t::AlignmentToReferenceTime::Gps);
    let mut gnss = NeoM8tAsync::new(ScriptPort::new(vec![
        write(&CFG_RATE_200MS),
        reply(&nak(&CFG_RATE_200MS)),
    ]));
    let mut delay = InstantDelay::default();
    assert_eq!(
        block_on(gnss.send_and_await_ack(&rate, &mut delay, 100)),
        Err(Error::Device(DeviceError::Nak {
            class: 0x06,
            id: 0x08
        }))
    );
    gnss.serial_mut().done();
}

#[test]
fn a_port_that_takes_nothing_is_a_timeout_not_a_panic() {
    let rate = commands::cfg_rate(200, 1, neo_m8t::AlignmentToReferenceTime::Gps);
    let mut gnss = NeoM8tAsync::new(ScriptPort::new(vec![Step::WriteZero]));
    let mut delay = InstantDelay::default();
    assert_eq!(
        block_on(gnss.send_and_await_ack(&rate, &mut delay, 100)),
        Err(Error::Device(DeviceError::Timeout {
            class: 0x06,
            id: 0x08
        }))
    );
    gnss.serial_mut().done();
}

#[test]
fn baud_switch_with_ack_at_the_new_rate() {
    let config = Config::default()
        .with_baud_rate(460_800)
        .with_time_pulse(None);
    let prt = commands::cfg_prt_uart1(460_800);
    let mut script = vec![
        write(&MON_VER_POLL),
        reply(&mon_ver_reply()),
        write(prt.as_bytes()),
        Step::Flush,
        // Now at 460800, while settling: the ACK for CFG-PRT arrives at the new rate.
        reply(&ack(prt.as_bytes())),
    ];
    for cmd in cfg_commands(&config) {
        script.push(write(cmd.as_bytes()));
        script.push(reply(&ack(cmd.as_bytes())));
    }
    let mut gnss = NeoM8tAsync::new(ScriptPort::new(script));
    let (result, switches) = configure(&mut gnss, config, 9_600);
    assert!(result.is_ok(), "{result:?}");
    assert_eq!(switches, vec![460_800]);
    gnss.serial_mut().done();
}

#[test]
fn nak_of_the_port_change_switches_the_host_back() {
    let config = Config::default().with_baud_rate(460_800);
    let prt = commands::cfg_prt_uart1(460_800);
    let script = vec![
        write(&MON_VER_POLL),
        reply(&mon_ver_reply()),
        write(prt.as_bytes()),
        Step::Flush,
        reply(&nak(prt.as_bytes())),
    ];
    let mut gnss = NeoM8tAsync::new(ScriptPort::new(script));
    let (result, switches) = configure(&mut gnss, config, 9_600);
    assert_eq!(
        result,
        Err(Error::Device(DeviceError::Nak {
            class: 0x06,
            id: 0x00
        }))
    );
    // The receiver kept the old rate; the host follows it back.
    assert_eq!(switches, vec![460_800, 9_600]);
    gnss.serial_mut().done();
}
