//! Transparent pipe and AT command-mode dialogues against a mock serial port, driven by the
//! caller's clock (`poll(now_ms)`) and blocking with a `DelayNs`.

use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::serial::{Mock as SerialMock, Transaction};
use embedded_hal_nb::serial::{ErrorKind, Read, Write};
use xbee_driver::DeviceError;
use xbee_driver::{
    settings, ApiMode, BaudRate, CommandOutcome, CommandTiming, Error, Mode, PowerLevel, Role,
    Transparent,
};
use xbee_driver::{AtCommand, AtRequest, Parameter, XBee};

type Radio = XBee<SerialMock<u8>, Transparent>;

fn would_block() -> Transaction<u8> {
    Transaction::read_error(nb::Error::WouldBlock)
}

/// Factory timing without the extra guard margin, so that the times in these tests are round
/// numbers (`default_timing_keeps_a_guard_margin` covers the margin).
fn radio(expected: &[Transaction<u8>]) -> Radio {
    let timing = CommandTiming::default().with_guard_margin_ms(0);
    XBee::with_timing(SerialMock::new(expected), timing)
}

/// The transactions of a successful entry: flush, `+++`, `OK\r`.
fn enter_ok() -> Vec<Transaction<u8>> {
    vec![
        Transaction::flush(),
        Transaction::write_many(b"+++"),
        Transaction::read_many(b"OK\r"),
    ]
}

/// Drives a caller-clocked entry: guard time, `+++`, reply at the second guard time.
fn enter_with_clock(r: &mut Radio) {
    r.start_command_mode().unwrap();
    assert_eq!(r.poll(0), Err(nb::Error::WouldBlock)); // flushed, guard starts
    assert_eq!(r.mode(), Mode::Entering);
    assert_eq!(r.poll(999), Err(nb::Error::WouldBlock)); // still inside the guard time
    assert_eq!(r.poll(1000), Ok(CommandOutcome::Entered)); // +++ then OK\r (mock answers at once)
    assert_eq!(r.mode(), Mode::Command);
}

#[test]
fn bytes_pass_through_in_transparent_mode() {
    let mut r = radio(&[
        Transaction::write_many(b"$\x00"),
        Transaction::flush(),
        Transaction::read(0x24),
        would_block(),
        Transaction::read_error(nb::Error::Other(ErrorKind::Overrun)),
    ]);
    assert!(r.is_transparent());
    r.write(b'$').unwrap();
    r.write(0).unwrap();
    r.flush().unwrap();
    assert_eq!(r.read(), Ok(0x24));
    assert_eq!(r.read(), Err(nb::Error::WouldBlock));
    assert_eq!(
        r.read(),
        Err(nb::Error::Other(Error::Comm(ErrorKind::Overrun)))
    );
    r.release().done();
}

#[test]
fn default_timing_keeps_a_guard_margin() {
    // Factory GT is 1 s; the driver keeps 50 ms more silence before +++.
    let timing = CommandTiming::default();
    assert_eq!(
        (
            timing.guard_time_ms,
            timing.guard_margin_ms,
            timing.command_character
        ),
        (1000, 50, b'+')
    );
    let mut r = XBee::new(SerialMock::new(&enter_ok()));
    r.start_command_mode().unwrap();
    assert_eq!(r.poll(7), Err(nb::Error::WouldBlock));
    assert_eq!(r.poll(1056), Err(nb::Error::WouldBlock));
    assert_eq!(r.poll(1057), Ok(CommandOutcome::Entered));
    r.release().done();
}

#[test]
fn caller_clocked_dialogue() {
    let mut expected = vec![Transaction::flush()];
    expected.push(Transaction::write_many(b"+++"));
    expected.push(would_block()); // poll at 1000: OK not there yet
    expected.push(Transaction::read_many(b"OK\r")); // poll at 2000
    expected.push(Transaction::write_many(b"ATID\r"));
    expected.push(Transaction::read_many(b"7FFF\r"));
    expected.push(Transaction::write_many(b"ATID2A\r"));
    expected.push(would_block());
    expected.push(Transaction::read_many(b"OK\r"));
    expected.push(Transaction::write_many(b"ATCN\r"));
    expected.push(Transaction::read_many(b"OK\r"));
    expected.push(Transaction::write(b'x'));
    let mut r = radio(&expected);

    r.start_command_mode().unwrap();
    assert_eq!(r.poll(0), Err(nb::Error::WouldBlock));
    // Data written during the guard time is refused, not sent.
    assert_eq!(
        r.write(b'x'),
        Err(nb::Error::Other(Error::Device(
            DeviceError::CommandModeActive
        )))
    );
    assert_eq!(r.poll(500), Err(nb::Error::WouldBlock));
    assert_eq!(r.poll(1000), Err(nb::Error::WouldBlock)); // +++ sent, waiting for OK
    assert_eq!(r.read(), Err(nb::Error::WouldBlock)); // replies are not data
    assert_eq!(r.poll(2000), Ok(CommandOutcome::Entered));

    r.start_command(&AtRequest::query(AtCommand::ID)).unwrap();
    assert_eq!(r.mode(), Mode::Busy);
    assert_eq!(
        r.start_command(&AtRequest::query(AtCommand::CH)),
        Err(Error::Device(DeviceError::Busy))
    );
    assert_eq!(r.poll(2010), Ok(CommandOutcome::Reply));
    assert_eq!(r.reply(), b"7FFF");
    assert_eq!(settings::parse_number(r.reply()), Some(0x7FFF));

    r.start_command(&settings::set_pan_id(0x2A)).unwrap();
    assert_eq!(r.poll(2020), Err(nb::Error::WouldBlock));
    assert_eq!(r.poll(2030), Ok(CommandOutcome::Reply));
    assert_eq!(r.reply(), b"OK");

    assert_eq!(
        r.write(b'x'),
        Err(nb::Error::Other(Error::Device(
            DeviceError::CommandModeActive
        )))
    );
    r.start_exit().unwrap();
    assert_eq!(r.poll(2040), Ok(CommandOutcome::Exited));
    assert!(r.is_transparent());
    r.write(b'x').unwrap();
    r.release().done();
}

#[test]
fn module_that_never_answers_times_out_and_data_waits_for_ct() {
    let mut expected = vec![Transaction::flush(), Transaction::write_many(b"+++")];
    expected.extend([would_block(), would_block(), would_block()]);
    expected.push(Transaction::write(b'x'));
    let mut r = radio(&expected);

    r.start_command_mode().unwrap();
    assert_eq!(r.poll(0), Err(nb::Error::WouldBlock));
    assert_eq!(r.poll(1000), Err(nb::Error::WouldBlock)); // +++ out at t = 1000
    assert_eq!(r.poll(2999), Err(nb::Error::WouldBlock)); // deadline is GT + reply timeout
    assert_eq!(
        r.poll(3000),
        Err(nb::Error::Other(Error::Device(DeviceError::Timeout)))
    );

    // The module may have switched without us hearing OK: no data until CT has surely passed
    // (CT 10 s + 1 s margin after the +++), and no commands either.
    assert_eq!(r.mode(), Mode::Command);
    assert_eq!(
        r.write(b'x'),
        Err(nb::Error::Other(Error::Device(
            DeviceError::CommandModeActive
        )))
    );
    r.start_command(&AtRequest::query(AtCommand::ID)).unwrap();
    assert_eq!(
        r.poll(3001),
        Err(nb::Error::Other(Error::Device(
            DeviceError::NotInCommandMode
        )))
    );
    assert_eq!(r.poll(11_999), Ok(CommandOutcome::Idle));
    assert_eq!(r.poll(12_000), Ok(CommandOutcome::AutoExited));
    assert!(r.is_transparent());
    r.write(b'x').unwrap();
    r.release().done();
}

#[test]
fn command_that_is_never_answered_times_out() {
    let mut expected = enter_ok();
    expected.push(Transaction::write_many(b"ATVR\r"));
    expected.extend([would_block(), would_block()]);
    // The late answer arrives before the next command: it is drained, not taken as its reply.
    expected.extend([Transaction::read_many(b"100D\r"), would_block()]);
    expected.push(Transaction::write_many(b"ATHV\r"));
    expected.push(Transaction::read_many(b"4247\r"));
    let mut r = radio(&expected);
    enter_with_clock(&mut r);

    r.start_command(&AtRequest::query(AtCommand::VR)).unwrap();
    assert_eq!(r.poll(1010), Err(nb::Error::WouldBlock));
    assert_eq!(
        r.poll(2010),
        Err(nb::Error::Other(Error::Device(DeviceError::Timeout)))
    );
    assert_eq!(r.mode(), Mode::Command);

    r.start_command(&AtRequest::query(AtCommand::HV)).unwrap();
    assert_eq!(r.poll(2020), Ok(CommandOutcome::Reply));
    assert_eq!(r.reply(), b"4247");
    assert_eq!(r.discarded_bytes(), 5);
    r.release().done();
}

#[test]
fn error_reply_is_an_error_and_command_mode_stays_open() {
    let mut expected = enter_ok();
    expected.push(Transaction::write_many(b"ATCH1A\r"));
    expected.push(Transaction::read_many(b"ERROR\r"));
    expected.push(Transaction::write_many(b"ATCN\r"));
    expected.push(Transaction::read_many(b"OK\r"));
    let mut r = radio(&expected);
    enter_with_clock(&mut r);

    r.start_command(&settings::set_channel(0x1A).unwrap())
        .unwrap();
    assert_eq!(
        r.poll(1100),
        Err(nb::Error::Other(Error::Device(DeviceError::AtError)))
    );
    assert_eq!(r.reply(), b"ERROR");
    assert_eq!(r.mode(), Mode::Command);
    // A hand-made CN is an exit too.
    r.start_command(&AtRequest::query(AtCommand::CN)).unwrap();
    assert_eq!(r.poll(1200), Ok(CommandOutcome::Exited));
    assert!(r.is_transparent());
    r.release().done();
}

#[test]
fn ct_expiry_is_tracked_on_both_sides() {
    let timing = CommandTiming::default();
    assert_eq!(timing.guard_time_ms, 1000);
    assert_eq!(timing.command_timeout_ms, 10_000);
    let mut expected = enter_ok();
    expected.push(Transaction::write_many(b"ATAP\r"));
    expected.push(Transaction::read_many(b"0\r"));
    let mut r = radio(&expected);
    enter_with_clock(&mut r); // OK for the +++ sent at t = 1000

    r.start_command(&AtRequest::query(AtCommand::AP)).unwrap();
    assert_eq!(r.poll(9_999), Ok(CommandOutcome::Reply)); // CT restarted at t = 9999
    assert_eq!(
        settings::parse_api_mode(r.reply()),
        Some(ApiMode::Transparent)
    );

    // Too close to CT for another command: it would arrive as radio data.
    r.start_command(&AtRequest::query(AtCommand::AP)).unwrap();
    assert_eq!(
        r.poll(9_999 + 9_000),
        Err(nb::Error::Other(Error::Device(
            DeviceError::NotInCommandMode
        )))
    );
    // Data only once CT has surely run out: 9999 + 10 000 + 1000.
    assert_eq!(r.poll(20_998), Ok(CommandOutcome::Idle));
    assert_eq!(r.poll(20_999), Ok(CommandOutcome::AutoExited));
    r.release().done();
}

#[test]
fn exit_too_close_to_ct_waits_instead_of_sending_atcn() {
    let mut r = radio(&enter_ok());
    enter_with_clock(&mut r);
    r.start_exit().unwrap();
    assert_eq!(r.poll(10_000), Err(nb::Error::WouldBlock)); // ATCN would be too late
    assert_eq!(r.mode(), Mode::Leaving);
    assert_eq!(r.poll(11_999), Err(nb::Error::WouldBlock));
    assert_eq!(r.poll(12_000), Ok(CommandOutcome::Exited));
    r.release().done();
}

#[test]
fn reentering_while_fresh_is_immediate_and_after_ct_waits() {
    let mut expected = enter_ok();
    expected.extend(enter_ok());
    let mut r = radio(&expected);
    enter_with_clock(&mut r);
    r.start_command_mode().unwrap();
    assert_eq!(r.poll(2000), Ok(CommandOutcome::Entered));
    // Stale: wait until surely out (1000 + 11 000), then a full entry.
    r.start_command_mode().unwrap();
    assert_eq!(r.poll(10_500), Err(nb::Error::WouldBlock));
    assert_eq!(r.poll(12_000), Err(nb::Error::WouldBlock)); // flushed, guard starts
    assert_eq!(r.poll(13_000), Ok(CommandOutcome::Entered));
    r.release().done();
}

#[test]
fn radio_data_before_ok_is_discarded_and_counted() {
    let mut r = radio(&[
        Transaction::flush(),
        Transaction::write_many(b"+++"),
        Transaction::read_many(b"$abc\rOK\r"),
    ]);
    enter_with_clock(&mut r);
    assert_eq!(r.discarded_bytes(), 5);
    r.release().done();
}

#[test]
fn invalid_requests_are_refused_before_any_io() {
    let mut r = radio(&enter_ok());
    assert_eq!(
        r.start_command(&AtRequest::query(AtCommand::ID)),
        Err(Error::Device(DeviceError::NotInCommandMode))
    );
    assert_eq!(
        r.start_exit(),
        Err(Error::Device(DeviceError::NotInCommandMode))
    );
    enter_with_clock(&mut r);
    let bad = AtRequest::set(AtCommand::NI, xbee_driver::Parameter::Text(b"A,B"));
    assert_eq!(
        r.start_command(&bad),
        Err(Error::Device(DeviceError::InvalidInput))
    );
    r.release().done();
}

// ---- Blocking with a DelayNs ----

#[test]
fn blocking_session_configures_a_dima_pair_module() {
    let key = [
        0x00, 0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88, 0x99, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE,
        0xFF,
    ];
    let mut expected = enter_ok();
    for (line, reply) in [
        (&b"ATVR\r"[..], &b"100D\r"[..]),
        (b"ATID7FFF\r", b"OK\r"),
        (b"ATCE1\r", b"OK\r"),
        (b"ATEE1\r", b"OK\r"),
        (b"ATKY00112233445566778899AABBCCDDEEFF\r", b"OK\r"),
        (b"ATNIGROUND\r", b"OK\r"),
        (b"ATPL4\r", b"OK\r"),
        (b"ATBD3\r", b"OK\r"),
        (b"ATAP0\r", b"OK\r"),
        // The ground station sends to the robot's module (README pairing table).
        (b"ATDH13A200\r", b"OK\r"),
        (b"ATDL40A1B2C3\r", b"OK\r"),
        (b"ATNI\r", b"GROUND\r"),
        (b"ATCE\r", b"1\r"),
        (b"ATEE\r", b"1\r"),
        (b"ATSH\r", b"13A200\r"),
        (b"ATSL\r", b"40A1B2C3\r"),
        (b"ATWR\r", b"OK\r"),
        (b"ATAC\r", b"OK\r"),
        (b"ATCN\r", b"OK\r"),
    ] {
        expected.push(Transaction::write_many(line));
        expected.push(Transaction::read_many(reply));
    }
    let mut r = radio(&expected);
    let mut delay = NoopDelay::new();
    let mut s = r.command_mode(&mut delay).unwrap();
    assert_eq!(s.firmware_version().unwrap(), 0x100D);
    s.set_pan_id(0x7FFF).unwrap();
    s.set_role(Role::Coordinator).unwrap();
    s.set_encryption(true).unwrap();
    s.set_encryption_key(&key).unwrap();
    s.set_node_identifier("GROUND").unwrap();
    s.set_power_level(PowerLevel::Highest).unwrap();
    s.set_baud_rate(BaudRate::Bps9600).unwrap();
    s.set_api_mode(ApiMode::Transparent).unwrap();
    let robot = xbee_driver::Address64(0x0013_A200_40A1_B2C3);
    s.set_raw(AtCommand::DH, Parameter::Number(robot.0 >> 32))
        .unwrap();
    s.set_raw(AtCommand::DL, Parameter::Number(robot.0 & 0xFFFF_FFFF))
        .unwrap();
    let mut name = [0u8; 20];
    let n = s.node_identifier(&mut name).unwrap();
    assert_eq!(&name[..n], b"GROUND");
    assert_eq!(s.role().unwrap(), Role::Coordinator);
    assert!(s.encryption().unwrap());
    assert_eq!(
        s.serial_number().unwrap(),
        xbee_driver::Address64(0x0013_A200_40A1_B2C3)
    );
    s.write_settings().unwrap();
    s.apply_changes().unwrap();
    s.exit().unwrap();
    assert!(r.is_transparent());
    r.release().done();
}

#[test]
fn blocking_entry_against_a_silent_module_times_out() {
    // Clock steps of 250 us (4 polls per ms), starting at 0. The guard time ends at the poll
    // at 1000 ms, which sends +++ and reads once; every later poll reads once until the poll
    // at GT + GT + reply timeout = 3000 ms. Reads: (3000 - 1000) * 4 + 1.
    let reads = (3000 - 1000) * 4 + 1;
    let mut expected = vec![Transaction::flush(), Transaction::write_many(b"+++")];
    expected.extend(std::iter::repeat_with(would_block).take(reads));
    expected.push(Transaction::write(b'x'));
    let mut r = radio(&expected);
    let mut delay = NoopDelay::new();
    assert!(matches!(
        r.command_mode(&mut delay),
        Err(Error::Device(DeviceError::Timeout))
    ));
    assert_eq!(
        r.write(b'x'),
        Err(nb::Error::Other(Error::Device(
            DeviceError::CommandModeActive
        )))
    );
    // Waits out CT without touching the port, then data flows.
    r.wait_until_transparent(&mut delay).unwrap();
    r.write(b'x').unwrap();
    r.release().done();
}

#[test]
fn blocking_command_answered_error_then_session_dropped_leaves() {
    let mut expected = enter_ok();
    expected.push(Transaction::write_many(b"ATCH1A\r"));
    expected.push(Transaction::read_many(b"ERROR\r"));
    expected.push(Transaction::write_many(b"ATCN\r"));
    expected.push(Transaction::read_many(b"OK\r"));
    let mut r = radio(&expected);
    let mut delay = NoopDelay::new();
    {
        let mut s = r.command_mode(&mut delay).unwrap();
        assert_eq!(
            s.set_channel(0x1A),
            Err(Error::Device(DeviceError::AtError))
        );
        assert_eq!(
            s.set_channel(0x1B),
            Err(Error::Device(DeviceError::InvalidInput))
        ); // refused, nothing sent
    } // dropped: ATCN
    assert!(r.is_transparent());
    r.release().done();
}

#[test]
fn blocking_command_never_answered_times_out() {
    // The command goes out at some poll; that poll and the following ones read once each
    // until the reply timeout (1000 ms = 4000 steps of 250 us) has elapsed: 4001 reads.
    let mut expected = enter_ok();
    expected.push(Transaction::write_many(b"ATPL\r"));
    expected.extend(std::iter::repeat_with(would_block).take(4001));
    let mut r = radio(&expected);
    let mut delay = NoopDelay::new();
    let mut s = r.command_mode(&mut delay).unwrap();
    assert_eq!(s.power_level(), Err(Error::Device(DeviceError::Timeout)));
    // Forget the session so that dropping it does not send ATCN to the silent mock.
    core::mem::forget(s);
    r.release().done();
}

#[test]
fn blocking_session_refuses_commands_after_half_the_ct_window() {
    // Short timing to keep the transaction list small: GT 10 ms, CT 100 ms, replies 10 ms.
    // On the delay-counted clock a command is only sent within (100 - 10) / 2 = 45 ms of the
    // last accepted one (the OK of +++ at 10 ms). Each unanswered command costs 10 ms:
    // 40 steps of 250 us, 41 reads.
    let timing = CommandTiming::default()
        .with_guard_time_ms(10)
        .with_command_timeout_ms(100)
        .with_reply_timeout_ms(10)
        .with_guard_margin_ms(0);
    let mut expected = enter_ok();
    for i in 0..5 {
        if i > 0 {
            expected.push(would_block()); // drain a late reply to the previous command
        }
        expected.push(Transaction::write_many(b"ATVR\r"));
        expected.extend(std::iter::repeat_with(would_block).take(41));
    }
    let mut r = XBee::with_timing(SerialMock::new(&expected), timing);
    let mut delay = NoopDelay::new();
    {
        let mut s = r.command_mode(&mut delay).unwrap();
        for _ in 0..5 {
            assert_eq!(
                s.firmware_version(),
                Err(Error::Device(DeviceError::Timeout))
            ); // sent at 10, 20, ..., 50 ms
        }
        // At 60 ms, 50 ms after the last accepted command: refused, nothing sent.
        assert_eq!(
            s.firmware_version(),
            Err(Error::Device(DeviceError::NotInCommandMode))
        );
    } // dropped: too late for ATCN, waits until CT has surely passed instead
    assert!(r.is_transparent());
    r.release().done();
}
