//! Golden vectors from the Pololu Maestro Servo Controller User's Guide (serial interface
//! section), copied from the project's vector list, and the DIMA frames of the original robot.

use pololu_maestro::{
    crc7, encode, encode_set_target, encode_set_targets, reply, Acceleration, Channel, Command,
    DeviceNumber, ErrorFlags, Framing, Mini24, MiniSscServo, MiniSscValue, MultiTargets,
    QuarterMicros, Speed,
};

fn ch(n: u8) -> Channel {
    Channel::new::<Mini24>(n).unwrap()
}

fn qus(v: u16) -> QuarterMicros {
    QuarterMicros::new(v).unwrap()
}

// Pololu guide: compact Set Target ch 2 = 1500 µs (6000) -> 84 02 70 2E
#[test]
fn compact_set_target() {
    let p = encode(
        &Command::SetTarget {
            channel: ch(2),
            target: qus(6000),
        },
        Framing::COMPACT,
    );
    assert_eq!(&*p, &[0x84, 0x02, 0x70, 0x2E]);
    assert_eq!(
        &*encode_set_target(Framing::COMPACT, ch(2), qus(6000)),
        &[0x84, 0x02, 0x70, 0x2E]
    );
}

// Pololu guide: Pololu protocol Set Target ch 0 = 6000, device 12 -> AA 0C 04 00 70 2E
#[test]
fn pololu_set_target() {
    let framing = Framing::pololu(DeviceNumber::new(12).unwrap());
    let p = encode(
        &Command::SetTarget {
            channel: ch(0),
            target: qus(6000),
        },
        framing,
    );
    assert_eq!(&*p, &[0xAA, 0x0C, 0x04, 0x00, 0x70, 0x2E]);
    assert_eq!(DeviceNumber::DEFAULT, DeviceNumber::new(12).unwrap());
}

// Pololu guide: Set Speed ch 5 = 140 -> 87 05 0C 01
#[test]
fn set_speed() {
    let p = encode(
        &Command::SetSpeed {
            channel: ch(5),
            speed: Speed::new(140).unwrap(),
        },
        Framing::COMPACT,
    );
    assert_eq!(&*p, &[0x87, 0x05, 0x0C, 0x01]);
}

// Pololu guide: Set Multiple Targets ch 3 = 0, ch 4 = 6000 -> 9F 02 03 00 00 70 2E
#[test]
fn set_multiple_targets() {
    let multi = MultiTargets::new(ch(3), &[qus(0), qus(6000)]).unwrap();
    let p = encode(&Command::SetMultipleTargets(multi), Framing::COMPACT);
    assert_eq!(&*p, &[0x9F, 0x02, 0x03, 0x00, 0x00, 0x70, 0x2E]);
}

// Pololu guide: Mini SSC ch 0 neutral -> FF 00 7F
#[test]
fn mini_ssc_neutral() {
    let cmd = Command::MiniSsc {
        servo: MiniSscServo::new(0).unwrap(),
        value: MiniSscValue::NEUTRAL,
    };
    assert_eq!(&*encode(&cmd, Framing::COMPACT), &[0xFF, 0x00, 0x7F]);
    // Mini SSC is never framed nor CRC'd.
    let framing = Framing::pololu(DeviceNumber::DEFAULT).with_crc(true);
    assert_eq!(&*encode(&cmd, framing), &[0xFF, 0x00, 0x7F]);
}

// Pololu guide: CRC-7 of 83 01 -> 17; CRC-7 of 84 02 70 2E -> 18
#[test]
fn crc7_vectors() {
    assert_eq!(crc7(&[0x83, 0x01]), 0x17);
    assert_eq!(crc7(&[0x84, 0x02, 0x70, 0x2E]), 0x18);
}

#[test]
fn compact_set_target_with_crc() {
    let p = encode_set_target(Framing::COMPACT.with_crc(true), ch(2), qus(6000));
    assert_eq!(&*p, &[0x84, 0x02, 0x70, 0x2E, 0x18]);
}

// Pololu support (forum thread "CRC-7 usage on Maestro and Python 2.x"): in the Pololu
// protocol the CRC covers the whole packet, 0xAA and the device number included:
// Get Position ch 0, device 1 -> AA 01 10 00, CRC 6B.
#[test]
fn pololu_protocol_crc_covers_the_whole_packet() {
    let framing = Framing::pololu(DeviceNumber::new(1).unwrap()).with_crc(true);
    let p = encode(&Command::GetPosition { channel: ch(0) }, framing);
    assert_eq!(&*p, &[0xAA, 0x01, 0x10, 0x00, 0x6B]);
}

// Pololu guide: Get Position reply 70 17 -> 6000
#[test]
fn get_position_reply() {
    assert_eq!(reply::decode_position([0x70, 0x17]), 6000);
    assert_eq!(reply::encode_position(6000), [0x70, 0x17]);
}

// Pololu guide, "Errors": bit numbers of the error register.
#[test]
fn error_bits() {
    assert_eq!(ErrorFlags::SERIAL_SIGNAL.bits(), 1 << 0);
    assert_eq!(ErrorFlags::SERIAL_OVERRUN.bits(), 1 << 1);
    assert_eq!(ErrorFlags::SERIAL_BUFFER_FULL.bits(), 1 << 2);
    assert_eq!(ErrorFlags::SERIAL_CRC.bits(), 1 << 3);
    assert_eq!(ErrorFlags::SERIAL_PROTOCOL.bits(), 1 << 4);
    assert_eq!(ErrorFlags::SERIAL_TIMEOUT.bits(), 1 << 5);
    assert_eq!(ErrorFlags::SCRIPT_STACK.bits(), 1 << 6);
    assert_eq!(ErrorFlags::SCRIPT_CALL_STACK.bits(), 1 << 7);
    assert_eq!(ErrorFlags::SCRIPT_PROGRAM_COUNTER.bits(), 1 << 8);
    // Reply: bits 0-7 first, then bits 8-15.
    assert_eq!(
        reply::decode_errors([0x10, 0x01]),
        ErrorFlags::SERIAL_PROTOCOL | ErrorFlags::SCRIPT_PROGRAM_COUNTER
    );
}

// Pololu guide: command bytes of the servo and script commands (compact protocol).
#[test]
fn command_bytes() {
    use pololu_maestro::opcode::*;
    assert_eq!(
        [
            SET_TARGET,
            SET_SPEED,
            SET_ACCELERATION,
            SET_PWM,
            GET_POSITION,
            GET_MOVING_STATE,
            SET_MULTIPLE_TARGETS,
            GET_ERRORS,
            GO_HOME,
            STOP_SCRIPT,
            RESTART_SCRIPT,
            RESTART_SCRIPT_WITH_PARAMETER,
            GET_SCRIPT_STATUS,
            POLOLU,
            MINI_SSC
        ],
        [
            0x84, 0x87, 0x89, 0x8A, 0x90, 0x93, 0x9F, 0xA1, 0xA2, 0xA4, 0xA7, 0xA8, 0xAE, 0xAA,
            0xFF
        ]
    );
    let acc = encode(
        &Command::SetAcceleration {
            channel: ch(0),
            acceleration: Acceleration::new(255),
        },
        Framing::COMPACT,
    );
    assert_eq!(&*acc, &[0x89, 0x00, 0x7F, 0x01]);
}

// Targets of the DIMA car's three channels: throttle 1500 µs, steering 1840 µs, tail 2000 µs.
#[test]
fn dima_frames() {
    let t = |n, us| {
        encode_set_target(
            Framing::COMPACT,
            ch(n),
            QuarterMicros::from_micros(us).unwrap(),
        )
    };
    assert_eq!(&*t(0, 1500), &[0x84, 0x00, 0x70, 0x2E]);
    assert_eq!(&*t(1, 1840), &[0x84, 0x01, 0x40, 0x39]);
    assert_eq!(&*t(2, 2000), &[0x84, 0x02, 0x40, 0x3E]);

    let frame = encode_set_targets(
        Framing::COMPACT,
        &[
            (ch(0), QuarterMicros::from_micros(1500).unwrap()),
            (ch(1), QuarterMicros::from_micros(1840).unwrap()),
            (ch(2), QuarterMicros::from_micros(2000).unwrap()),
        ],
    )
    .unwrap();
    assert_eq!(
        &*frame,
        &[0x84, 0x00, 0x70, 0x2E, 0x84, 0x01, 0x40, 0x39, 0x84, 0x02, 0x40, 0x3E]
    );
}
