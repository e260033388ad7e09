//! The blocking driver against a mocked embedded-hal-nb serial port.

use embedded_hal_mock::eh1::serial::{Mock, Transaction};
use embedded_hal_nb::serial::ErrorKind;
use pololu_maestro::{
    Channel, ChannelLimits, DeviceNumber, Error, ErrorFlags, Framing, Limits, Maestro, Micro6,
    Mini12, PollBudget, PwmTiming, QuarterMicros, ScriptParameter, ScriptStatus, Speed, Subroutine,
};

type Tx = Transaction<u8>;

fn micro(
    expect: &[Tx],
) -> (
    Maestro<pololu_maestro::NbSerial<Mock<u8>>, Micro6>,
    Mock<u8>,
) {
    let serial = Mock::new(expect);
    (
        Maestro::new_serial(serial.clone(), Micro6, Framing::COMPACT),
        serial,
    )
}

fn mini(
    expect: &[Tx],
    framing: Framing,
) -> (
    Maestro<pololu_maestro::NbSerial<Mock<u8>>, Mini12>,
    Mock<u8>,
) {
    let serial = Mock::new(expect);
    (Maestro::new_serial(serial.clone(), Mini12, framing), serial)
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

#[test]
fn set_target_writes_one_packet() {
    let (mut m, mut s) = micro(&[Tx::write_many([0x84, 0x02, 0x70, 0x2E])]);
    m.set_target(ch6(2), us(1500)).unwrap();
    s.done();
}

#[test]
fn set_targets_is_one_frame() {
    let (m, mut s) = micro(&[Tx::write_many([
        0x84, 0x00, 0x70, 0x2E, 0x84, 0x01, 0x40, 0x39, 0x84, 0x02, 0x40, 0x3E,
    ])]);
    let mut m = m.with_limits(dima_limits());
    m.set_targets(&[(ch6(0), us(1500)), (ch6(1), us(1840)), (ch6(2), us(2000))])
        .unwrap();
    s.done();
}

#[test]
fn out_of_range_sends_nothing() {
    let (m, mut s) = micro(&[]);
    let mut m = m.with_limits(dima_limits());
    assert_eq!(
        m.set_target(ch6(1), us(1900)),
        Err(Error::Target(pololu_maestro::TargetError::OutOfRange {
            channel: 1,
            target: 7600,
            min: 5000,
            max: 7360
        }))
    );
    // One bad target in a batch rejects the whole batch.
    assert!(matches!(
        m.set_targets(&[(ch6(0), us(1500)), (ch6(1), us(1000))]),
        Err(Error::Target(pololu_maestro::TargetError::OutOfRange {
            channel: 1,
            ..
        }))
    ));
    // Target 0 on a limited channel is refused too; stopping pulses is explicit.
    assert!(m.set_target(ch6(0), QuarterMicros::OFF).is_err());
    assert!(m.encode_targets(&[(ch6(2), us(999))]).is_err());
    s.done();
}

#[test]
fn stop_pulses_and_neutral() {
    let (m, mut s) = micro(&[
        Tx::write_many([0x84, 0x01, 0x24, 0x30]),
        Tx::write_many([0x84, 0x01, 0x00, 0x00]),
    ]);
    let mut m = m.with_limits(dima_limits());
    m.set_neutral(ch6(1)).unwrap(); // 1545 µs = 6180 = 0x24 + (0x30 << 7)
    m.stop_pulses(ch6(1)).unwrap();
    assert_eq!(
        m.set_neutral(ch6(4)),
        Err(Error::Target(pololu_maestro::TargetError::InvalidInput))
    );
    s.done();
}

#[test]
fn channel_of_a_bigger_model_is_rejected() {
    let (mut m, mut s) = micro(&[]);
    let ch = Channel::new::<Mini12>(8).unwrap();
    assert_eq!(
        m.set_target(ch, us(1500)),
        Err(Error::Target(pololu_maestro::TargetError::InvalidChannel {
            channel: 8,
            channels: 6
        }))
    );
    assert!(Channel::new::<Micro6>(6).is_err());
    s.done();
}

#[test]
fn encode_targets_matches_set_targets() {
    let (m, mut s) = micro(&[]);
    let m = m.with_limits(dima_limits());
    let frame = m
        .encode_targets(&[(ch6(0), us(1500)), (ch6(1), us(1840)), (ch6(2), us(2000))])
        .unwrap();
    assert_eq!(
        frame.as_bytes(),
        &[0x84, 0x00, 0x70, 0x2E, 0x84, 0x01, 0x40, 0x39, 0x84, 0x02, 0x40, 0x3E]
    );
    s.done();
}

#[test]
fn get_position_round_trip() {
    // Pololu guide: Get Position reply 70 17 -> 6000.
    let (mut m, mut s) = micro(&[
        Tx::read_error(nb::Error::WouldBlock),
        Tx::write_many([0x90, 0x02]),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::read(0x70),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::read(0x17),
    ]);
    assert_eq!(
        m.get_position(ch6(2), &mut PollBudget(5)).unwrap().get(),
        6000
    );
    s.done();
}

#[test]
fn short_reply_is_a_timeout() {
    let (mut m, mut s) = micro(&[
        Tx::read_error(nb::Error::WouldBlock),
        Tx::write_many([0x90, 0x00]),
        Tx::read(0x70),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::read_error(nb::Error::WouldBlock),
    ]);
    assert_eq!(
        m.get_position(ch6(0), &mut PollBudget(2)),
        Err(Error::Device(pololu_maestro::DeviceError::Timeout))
    );
    s.done();
}

#[test]
fn missing_reply_is_a_timeout_with_a_closure_deadline() {
    let (mut m, mut s) = micro(&[
        Tx::read_error(nb::Error::WouldBlock),
        Tx::write_many([0xA1]),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::read_error(nb::Error::WouldBlock),
    ]);
    let mut polls = 0;
    let mut deadline = || {
        polls += 1;
        polls >= 2
    };
    assert_eq!(
        m.get_errors(&mut deadline),
        Err(Error::Device(pololu_maestro::DeviceError::Timeout))
    );
    s.done();
}

#[test]
fn stale_bytes_are_discarded_before_a_query() {
    let (mut m, mut s) = micro(&[
        Tx::read_many([0x12, 0x34]),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::write_many([0xA1]),
        Tx::read_many([0x08, 0x00]),
    ]);
    assert_eq!(
        m.get_errors(&mut PollBudget(10)).unwrap(),
        ErrorFlags::SERIAL_CRC
    );
    assert_eq!(m.stale_bytes(), 2);
    s.done();
}

#[test]
fn transport_error_is_comm() {
    let (mut m, mut s) = micro(&[
        Tx::read_error(nb::Error::WouldBlock),
        Tx::write_many([0xAE]),
        Tx::read_error(nb::Error::Other(ErrorKind::Parity)),
    ]);
    assert_eq!(
        m.get_script_status(&mut PollBudget(10)),
        Err(Error::Comm(ErrorKind::Parity))
    );
    s.done();
}

#[test]
fn write_budget_bounds_a_busy_transmitter() {
    let serial = Mock::new(&[
        Tx::write_error(0x84, nb::Error::WouldBlock),
        Tx::write_error(0x84, nb::Error::WouldBlock),
    ]);
    let mut m = Maestro::new(
        pololu_maestro::NbSerial::new(serial.clone()).with_write_polls_per_byte(2),
        Micro6,
        Framing::COMPACT,
    );
    assert_eq!(
        m.set_target(ch6(0), us(1500)),
        Err(Error::Device(pololu_maestro::DeviceError::Timeout))
    );
    let mut serial = serial;
    serial.done();
}

#[test]
fn script_commands_and_status() {
    let (mut m, mut s) = micro(&[
        Tx::write_many([0xA4]),
        Tx::write_many([0xA7, 0x03]),
        Tx::write_many([0xA8, 0x03, 0x70, 0x2E]),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::write_many([0xAE]),
        Tx::read(0x01),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::write_many([0xAE]),
        Tx::read(0x07),
        Tx::write_many([0xA2]),
    ]);
    m.stop_script().unwrap();
    m.restart_script(Subroutine::new(3).unwrap()).unwrap();
    m.restart_script_with_parameter(
        Subroutine::new(3).unwrap(),
        ScriptParameter::new(6000).unwrap(),
    )
    .unwrap();
    assert_eq!(
        m.get_script_status(&mut PollBudget(1)).unwrap(),
        ScriptStatus::Stopped
    );
    assert_eq!(
        m.get_script_status(&mut PollBudget(1)),
        Err(Error::Device(pololu_maestro::DeviceError::InvalidReply(
            0x07
        )))
    );
    m.go_home().unwrap();
    s.done();
}

#[test]
fn mini_only_commands_pololu_protocol_with_crc() {
    let framing = Framing::pololu(DeviceNumber::DEFAULT).with_crc(true);
    let pwm = [0xAA, 0x0C, 0x0A, 0x60, 0x00, 0x40, 0x01];
    let multi = [0xAA, 0x0C, 0x1F, 0x02, 0x03, 0x00, 0x00, 0x70, 0x2E];
    let moving = [0xAA, 0x0C, 0x13];
    let with_crc = |bytes: &[u8]| {
        let mut v = bytes.to_vec();
        v.push(pololu_maestro::crc7(bytes));
        v
    };
    let (mut m, mut s) = mini(
        &[
            Tx::write_many(with_crc(&pwm)),
            Tx::write_many(with_crc(&multi)),
            Tx::read_error(nb::Error::WouldBlock),
            Tx::write_many(with_crc(&moving)),
            Tx::read(0x01),
        ],
        framing,
    );
    m.set_pwm(PwmTiming::new(96, 192).unwrap()).unwrap();
    let ch = |n| Channel::new::<Mini12>(n).unwrap();
    m.set_multiple_targets(ch(3), &[QuarterMicros::OFF, QuarterMicros::NEUTRAL])
        .unwrap();
    assert!(m.get_moving_state(&mut PollBudget(1)).unwrap());
    // Past channel 11 of a Mini Maestro 12: refused before anything is sent.
    assert!(m
        .set_multiple_targets(ch(11), &[QuarterMicros::NEUTRAL, QuarterMicros::NEUTRAL])
        .is_err());
    s.done();
}

#[test]
fn speed_and_acceleration() {
    let (mut m, mut s) = micro(&[
        Tx::write_many([0x87, 0x05, 0x0C, 0x01]),
        Tx::write_many([0x89, 0x05, 0x04, 0x00]),
    ]);
    m.set_speed(ch6(5), Speed::new(140).unwrap()).unwrap();
    m.set_acceleration(ch6(5), pololu_maestro::Acceleration::new(4))
        .unwrap();
    s.done();
}

#[test]
fn encode_multiple_targets_is_checked_and_sans_io() {
    let ch = |n| Channel::new::<Mini12>(n).unwrap();
    let (m, mut s) = mini(&[], Framing::COMPACT);
    let m = m.with_limits(
        Limits::new().with(ch(1), ChannelLimits::from_micros(1250, 1840, 1545).unwrap()),
    );
    // DIMA throttle, steering, tail in one Set Multiple Targets packet.
    let packet = m
        .encode_multiple_targets(ch(0), &[us(1500), us(1840), us(2000)])
        .unwrap();
    assert_eq!(
        &*packet,
        &[0x9F, 0x03, 0x00, 0x70, 0x2E, 0x40, 0x39, 0x40, 0x3E]
    );
    assert!(matches!(
        m.encode_multiple_targets(ch(0), &[us(1500), us(1900)]),
        Err(Error::Target(pololu_maestro::TargetError::OutOfRange {
            channel: 1,
            ..
        }))
    ));
    s.done();
}

#[test]
fn sixty_four_stale_bytes_are_discarded_and_the_query_goes_out() {
    let (mut m, mut s) = micro(&[
        Tx::read_many([0x55; 64]),
        Tx::read_error(nb::Error::WouldBlock),
        Tx::write_many([0xA1]),
        Tx::read_many([0x00, 0x00]),
    ]);
    assert_eq!(m.get_errors(&mut PollBudget(10)), Ok(ErrorFlags::empty()));
    assert_eq!(m.stale_bytes(), 64);
    s.done();
}

#[test]
fn endless_unasked_data_fails_the_query() {
    // One byte more than the driver discards: the query is not sent.
    let (mut m, mut s) = micro(&[Tx::read_many([0x55; 65])]);
    assert_eq!(
        m.get_errors(&mut PollBudget(10)),
        Err(Error::Device(pololu_maestro::DeviceError::UnexpectedData))
    );
    assert_eq!(m.stale_bytes(), 65);
    s.done();
}

#[test]
fn flush_is_passed_through() {
    let (mut m, mut s) = micro(&[
        Tx::write_many([0xA2]),
        Tx::flush_error(nb::Error::WouldBlock),
        Tx::flush(),
    ]);
    m.go_home().unwrap();
    m.flush().unwrap();
    s.done();
}

#[test]
fn release_gives_the_serial_port_back() {
    let maestro = Maestro::new_serial(
        Mock::new(&[Tx::write_many([0x84, 0x00, 0x70, 0x2E])]),
        Micro6,
        Framing::COMPACT,
    );
    let mut maestro = maestro;
    maestro
        .set_target(Channel::new::<Micro6>(0).unwrap(), QuarterMicros::NEUTRAL)
        .unwrap();
    // The port given to `new_serial`, not the interface wrapper.
    let mut serial: Mock<u8> = maestro.release();
    serial.done();
}

#[test]
fn into_interface_gives_back_what_new_was_given() {
    let iface = pololu_maestro::NbSerial::new(Mock::new(&[]));
    let maestro = Maestro::new(iface, Micro6, Framing::COMPACT);
    let mut serial = maestro.into_interface().release();
    serial.done();
}
