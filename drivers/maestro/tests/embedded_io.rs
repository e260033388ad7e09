//! The embedded-io 0.7 transport (run with `--features embedded-io`).

use std::collections::VecDeque;

use pololu_maestro::{Channel, Error, Framing, Maestro, Mini12, PollBudget, QuarterMicros};

/// A port that accepts at most `chunk` bytes per write (0 = refuses everything) and replies
/// from a queue.
struct FakePort {
    written: Vec<u8>,
    writes: usize,
    chunk: usize,
    rx: VecDeque<u8>,
    /// Bytes that "arrive" once something has been written (the simulated reply).
    reply: Vec<u8>,
}

#[derive(Debug, PartialEq)]
struct Broken;

impl std::fmt::Display for Broken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("broken port")
    }
}

impl std::error::Error for Broken {}

impl embedded_io::Error for Broken {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

impl embedded_io::ErrorType for FakePort {
    type Error = Broken;
}

impl embedded_io::Write for FakePort {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Broken> {
        self.writes += 1;
        let n = buf.len().min(self.chunk);
        self.written.extend_from_slice(&buf[..n]);
        self.rx.extend(self.reply.drain(..));
        Ok(n)
    }
    fn flush(&mut self) -> Result<(), Broken> {
        Ok(())
    }
}

impl embedded_io::Read for FakePort {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Broken> {
        match (self.rx.pop_front(), buf.first_mut()) {
            (Some(b), Some(slot)) => {
                *slot = b;
                Ok(1)
            }
            _ => Ok(0),
        }
    }
}

impl embedded_io::ReadReady for FakePort {
    fn read_ready(&mut self) -> Result<bool, Broken> {
        Ok(!self.rx.is_empty())
    }
}

fn port(chunk: usize, rx: &[u8]) -> FakePort {
    FakePort {
        written: Vec::new(),
        writes: 0,
        chunk,
        rx: rx.iter().copied().collect(),
        reply: Vec::new(),
    }
}

fn ch(n: u8) -> Channel {
    Channel::new::<Mini12>(n).unwrap()
}

#[test]
fn set_targets_is_a_single_write() {
    let mut m = Maestro::new_io(port(usize::MAX, &[]), Mini12, Framing::COMPACT);
    let t = QuarterMicros::from_micros;
    m.set_targets(&[(ch(0), t(1500).unwrap()), (ch(1), t(1840).unwrap())])
        .unwrap();
    let p = m.release();
    assert_eq!(p.writes, 1);
    assert_eq!(p.written, [0x84, 0x00, 0x70, 0x2E, 0x84, 0x01, 0x40, 0x39]);
}

#[test]
fn partial_writes_are_continued() {
    let mut m = Maestro::new_io(port(3, &[]), Mini12, Framing::COMPACT);
    m.set_target(ch(2), QuarterMicros::NEUTRAL).unwrap();
    let p = m.release();
    assert_eq!(p.written, [0x84, 0x02, 0x70, 0x2E]);
    assert_eq!(p.writes, 2);
}

#[test]
fn a_port_that_accepts_nothing_times_out() {
    let mut m = Maestro::new_io(port(0, &[]), Mini12, Framing::COMPACT);
    assert_eq!(
        m.go_home(),
        Err(Error::Device(pololu_maestro::DeviceError::Timeout))
    );
}

#[test]
fn query_reads_reply_and_times_out_when_short() {
    // Pololu guide: Get Position reply 70 17 -> 6000.
    let mut m = Maestro::new_io(port(usize::MAX, &[]), Mini12, Framing::COMPACT);
    m.interface().inner().rx.extend([0x70]);
    // The lone 0x70 is stale (it arrived before the query) and is discarded; no reply follows.
    assert_eq!(
        m.get_position(ch(0), &mut PollBudget(3)),
        Err(Error::Device(pololu_maestro::DeviceError::Timeout))
    );
    assert_eq!(m.stale_bytes(), 1);
}

#[test]
fn query_round_trip() {
    // Pololu guide: Get Position reply 70 17 -> 6000.
    let mut p = port(usize::MAX, &[]);
    p.reply = vec![0x70, 0x17];
    let mut m = Maestro::new_io(p, Mini12, Framing::COMPACT);
    assert_eq!(
        m.get_position(ch(5), &mut PollBudget(3)).unwrap().get(),
        6000
    );
    assert_eq!(m.release().written, [0x90, 0x05]);
}
