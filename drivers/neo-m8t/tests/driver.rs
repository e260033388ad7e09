//! The serial-port reader against an embedded-hal-mock serial port.

use embedded_hal_mock::eh1::serial::{Mock, Transaction};
use embedded_hal_nb::serial::ErrorKind;
use neo_m8t::{Error, Message, NavPvt, NeoM8t};

type T = Transaction<u8>;

fn pvt(itow_ms: u32) -> [u8; 100] {
    *NavPvt {
        itow_ms,
        fix_type: 3,
        ..NavPvt::default()
    }
    .to_frame()
    .as_bytes()
}

fn idle() -> T {
    T::read_error(nb::Error::WouldBlock)
}

#[test]
fn read_message_returns_frames_and_would_block_when_idle() {
    let mut bad = pvt(100);
    bad[30] ^= 0xFF;
    let mut serial = Mock::new(&[
        T::read_many([0x47, 0x50]), // "GP": left-over NMEA
        T::read_many(bad),
        T::read_many(pvt(200)),
        idle(),
    ]);
    let mut gnss: NeoM8t<_, 100> = NeoM8t::with_capacity(serial.clone());
    match gnss.read_message() {
        Ok(Message::NavPvt(f)) => assert_eq!(f.to_nav_pvt().itow_ms, 200),
        other => panic!("expected NAV-PVT, got {other:?}"),
    }
    assert_eq!(gnss.read_message(), Err(nb::Error::WouldBlock));
    let stats = gnss.stream().stats();
    assert_eq!(stats.frames_ok, 1);
    assert_eq!(stats.checksum_errors, 1);
    assert_eq!(stats.bytes_skipped, 102);
    serial.done();
}

#[test]
fn poll_nav_pvt_returns_the_newest_frame_once() {
    let mut serial = Mock::new(&[
        T::read_many(pvt(100)),
        T::read_many(pvt(200)),
        idle(),
        idle(),
    ]);
    let mut gnss: NeoM8t<_, 100> = NeoM8t::with_capacity(serial.clone());
    let frame = gnss.poll_nav_pvt().unwrap().expect("a frame");
    assert_eq!(frame.as_bytes(), &pvt(200));
    assert_eq!(gnss.poll_nav_pvt(), Ok(None));
    assert_eq!(gnss.stream().nav_pvt_count(), 2);
    serial.done();
}

#[test]
fn poll_nav_pvt_ends_on_a_port_that_never_runs_dry() {
    // More frames than one call may read: the call returns the newest it has read, the
    // next call goes on from there.
    let total = neo_m8t::MAX_MESSAGES_PER_POLL as u32 + 4;
    let mut script: Vec<T> = (1..=total).map(|i| T::read_many(pvt(i * 100))).collect();
    script.push(idle());
    let mut serial = Mock::new(&script);
    let mut gnss: NeoM8t<_, 100> = NeoM8t::with_capacity(serial.clone());
    let first = gnss.poll_nav_pvt().unwrap().expect("a frame");
    let limit = neo_m8t::MAX_MESSAGES_PER_POLL as u32;
    assert_eq!(first.to_nav_pvt().itow_ms, limit * 100);
    let second = gnss.poll_nav_pvt().unwrap().expect("the rest");
    assert_eq!(second.to_nav_pvt().itow_ms, total * 100);
    assert_eq!(gnss.stream().nav_pvt_count(), total);
    serial.done();
}

#[test]
fn line_error_drops_the_partial_frame_and_reading_goes_on() {
    let a = pvt(100);
    let mut serial = Mock::new(&[
        T::read_many(&a[..50]),
        T::read_error(nb::Error::Other(ErrorKind::Overrun)),
        T::read_many(&a[60..]),
        T::read_many(pvt(200)),
        idle(),
    ]);
    let mut gnss: NeoM8t<_, 100> = NeoM8t::with_capacity(serial.clone());
    let frame = gnss.poll_nav_pvt().unwrap().expect("the second frame");
    assert_eq!(frame.to_nav_pvt().itow_ms, 200);
    assert_eq!(gnss.line_errors(), 1);
    assert_eq!(gnss.stream().stats().bytes_skipped, 90);
    serial.done();
}

#[test]
fn port_failure_is_a_comm_error() {
    let mut serial = Mock::new(&[T::read_error(nb::Error::Other(ErrorKind::Other))]);
    let mut gnss: NeoM8t<_, 100> = NeoM8t::with_capacity(serial.clone());
    assert_eq!(
        gnss.read_message(),
        Err(nb::Error::Other(Error::Comm(ErrorKind::Other)))
    );
    serial.done();
}

/// The README's most common use compiles without type annotations: `new` picks the default
/// buffer, and the reading calls infer everything else.
#[test]
fn new_infers_the_default_buffer() {
    let mut serial = Mock::new(&[T::read_many(pvt(300)), idle(), idle()]);
    let mut gnss = NeoM8t::new(serial.clone());
    let frame = gnss.poll_nav_pvt().unwrap().expect("a NAV-PVT frame");
    assert_eq!(frame.to_nav_pvt().itow_ms, 300);
    assert_eq!(gnss.read_message(), Err(nb::Error::WouldBlock));
    serial.done();
}
