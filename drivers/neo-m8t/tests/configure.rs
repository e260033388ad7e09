//! Configuration state machine against an embedded-hal-mock serial port: golden frames, ACK,
//! NAK, timeout, retries and the baud-rate switch.

use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::serial::{Mock, Transaction};
use embedded_hal_nb::serial::ErrorKind;
use neo_m8t::commands;
use neo_m8t::Error;
mod common;
use common::*;
use neo_m8t::ProtocolVersion;
use neo_m8t::{Config, Configurator, Progress};

type T = Transaction<u8>;

fn write(bytes: &[u8]) -> T {
    T::write_many(bytes)
}

fn reply(bytes: &[u8]) -> T {
    T::read_many(bytes)
}

fn idle() -> T {
    T::read_error(nb::Error::WouldBlock)
}

/// Polls with a 1 ms clock until done or error; returns the baud-rate requests seen.
fn drive(cfg: &mut Configurator<512>, serial: &mut Mock<u8>) -> Result<Vec<u32>, Error<ErrorKind>> {
    let mut switches = Vec::new();
    for now_ms in 0..100_000u32 {
        match cfg.poll(serial, now_ms)? {
            Progress::Done => return Ok(switches),
            Progress::SetBaudRate(baud) => switches.push(baud),
            Progress::Pending => {}
        }
    }
    panic!("configuration did not finish");
}

#[test]
fn command_builders_reproduce_golden_frames() {
    assert_eq!(commands::poll_mon_ver().as_bytes(), &MON_VER_POLL);
    assert_eq!(
        commands::cfg_prt_uart1(115_200).as_bytes(),
        &CFG_PRT_UART1_115200
    );
    assert_eq!(
        commands::cfg_msg_uart1(0x01, 0x07, 1).as_bytes(),
        &CFG_MSG_NAV_PVT_UART1
    );
    assert_eq!(
        commands::cfg_rate(200, 1, neo_m8t::AlignmentToReferenceTime::Gps).as_bytes(),
        &CFG_RATE_200MS
    );
}

/// CFG-NAV5 with only the dynamic model selected (automotive), as pyubx2 1.4.0 serialises
/// `UBXMessage("CFG", "CFG-NAV5", SET, dyn=1, dynModel=4)`: every unselected field is zero.
const CFG_NAV5_AUTOMOTIVE_PYUBX2: [u8; 44] = [
    0xB5, 0x62, 0x06, 0x24, 0x24, 0x00, 0x01, 0x00, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x53, 0x70,
];

#[test]
fn cfg_nav5_sends_only_what_its_mask_selects() {
    let nav5 = commands::cfg_nav5(neo_m8t::NavDynamicModel::Automotive);
    assert_eq!(nav5.as_bytes(), &CFG_NAV5_AUTOMOTIVE_PYUBX2);
}

#[test]
fn other_commands_follow_the_receiver_description_layout() {
    // CFG-NAV5: mask 0x0001 (dyn only), dynModel 4 = automotive.
    let nav5 = commands::cfg_nav5(neo_m8t::NavDynamicModel::Automotive);
    let b = nav5.as_bytes();
    assert_eq!(&b[..6], &[0xB5, 0x62, 0x06, 0x24, 36, 0]);
    assert_eq!(&b[6..9], &[0x01, 0x00, 4]);
    // CFG-TP5 default: tpIdx 0, version 1, cable delay 50 ns, 1 s periods, 0 / 100 ms pulses.
    let tp5 = commands::cfg_tp5(&neo_m8t::TimePulse::default());
    let b = tp5.as_bytes();
    assert_eq!(&b[..6], &[0xB5, 0x62, 0x06, 0x31, 32, 0]);
    let p = &b[6..38];
    assert_eq!((p[0], p[1]), (0, 1));
    assert_eq!(i16::from_le_bytes([p[4], p[5]]), 50);
    assert_eq!(u32::from_le_bytes(p[8..12].try_into().unwrap()), 1_000_000);
    assert_eq!(u32::from_le_bytes(p[12..16].try_into().unwrap()), 1_000_000);
    assert_eq!(u32::from_le_bytes(p[16..20].try_into().unwrap()), 0);
    assert_eq!(u32::from_le_bytes(p[20..24].try_into().unwrap()), 100_000);
    assert_eq!(u32::from_le_bytes(p[28..32].try_into().unwrap()), 0xF7);
    // CFG-TMODE2 survey-in: mode 1, min duration 300 s, limit 2000 mm.
    let tm = commands::cfg_tmode2(&neo_m8t::TimeMode::SurveyIn {
        min_duration_s: 300,
        accuracy_limit_mm: 2_000,
    });
    let b = tm.as_bytes();
    assert_eq!(&b[..6], &[0xB5, 0x62, 0x06, 0x3D, 28, 0]);
    let p = &b[6..34];
    assert_eq!(p[0], 1);
    assert_eq!(u32::from_le_bytes(p[20..24].try_into().unwrap()), 300);
    assert_eq!(u32::from_le_bytes(p[24..28].try_into().unwrap()), 2_000);
    // Fixed ECEF: cm values survive the builder's metre scaling.
    let tm = commands::cfg_tmode2(&neo_m8t::TimeMode::FixedEcef {
        x_cm: 428_123_456,
        y_cm: -64_012_345,
        z_cm: 467_654_321,
        accuracy_mm: 1_500,
    });
    let p = &tm.as_bytes()[6..34];
    assert_eq!(p[0], 2);
    assert_eq!(i32::from_le_bytes(p[4..8].try_into().unwrap()), 428_123_456);
    assert_eq!(
        i32::from_le_bytes(p[8..12].try_into().unwrap()),
        -64_012_345
    );
    assert_eq!(
        i32::from_le_bytes(p[12..16].try_into().unwrap()),
        467_654_321
    );
    assert_eq!(u32::from_le_bytes(p[16..20].try_into().unwrap()), 1_500);
    // CFG-PRT poll for UART1.
    assert_eq!(
        commands::poll_cfg_prt_uart1().as_bytes(),
        &[0xB5, 0x62, 0x06, 0x00, 0x01, 0x00, 0x01, 0x08, 0x22]
    );
}

#[test]
fn full_sequence_without_baud_change_uses_golden_frames_and_reports_version() {
    let config = Config::default().with_measurement_period_ms(200);
    let mut script = vec![write(&MON_VER_POLL), idle(), reply(&mon_ver_reply())];
    script.push(write(&CFG_PRT_UART1_115200));
    script.push(reply(&ack(&CFG_PRT_UART1_115200)));
    let cmds = cfg_commands(&config);
    assert_eq!(cmds[0].as_bytes(), &CFG_MSG_NAV_PVT_UART1);
    assert_eq!(cmds[9].as_bytes(), &CFG_RATE_200MS);
    for cmd in &cmds {
        script.push(write(cmd.as_bytes()));
        script.push(idle());
        script.push(reply(&ack(cmd.as_bytes())));
    }
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 115_200);
    assert_eq!(drive(&mut cfg, &mut serial), Ok(vec![]));
    serial.done();

    assert!(cfg.is_done());
    assert_eq!(cfg.retries(), 0);
    let v = cfg.version().expect("MON-VER recorded");
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

/// Script up to and including the ACK of CFG-PRT, no baud change.
fn prefix(config: &Config) -> Vec<T> {
    let prt = commands::cfg_prt_uart1(config.baud_rate);
    vec![
        write(&MON_VER_POLL),
        reply(&mon_ver_reply()),
        write(prt.as_bytes()),
        reply(&ack(prt.as_bytes())),
    ]
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
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 115_200);
    assert_eq!(
        drive(&mut cfg, &mut serial),
        Err(Error::Device(neo_m8t::DeviceError::Nak {
            class: 0x06,
            id: 0x24
        }))
    );
    serial.done();
}

#[test]
fn silence_is_retried_then_a_timeout_error() {
    let config = Config::default();
    let mut script = vec![];
    // MON-VER unanswered: sent 1 + 2 retries, each waited for 10 ms (11 polls of silence).
    for _ in 0..3 {
        script.push(write(&MON_VER_POLL));
        for _ in 0..11 {
            script.push(idle());
        }
    }
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 115_200)
        .with_timeout_ms(10)
        .with_retries(2);
    assert_eq!(
        drive(&mut cfg, &mut serial),
        Err(Error::Device(neo_m8t::DeviceError::Timeout {
            class: 0x0A,
            id: 0x04
        }))
    );
    assert_eq!(cfg.retries(), 2);
    serial.done();
}

#[test]
fn a_retry_can_succeed_and_unrelated_frames_and_noise_are_ignored() {
    let config = Config::default().with_time_pulse(None);
    let mut script = prefix(&config);
    let cmds = cfg_commands(&config);
    let other_ack = ack(&CFG_RATE_200MS);
    let pvt = neo_m8t::NavPvt::default().to_frame();
    for (i, cmd) in cmds.iter().enumerate() {
        script.push(write(cmd.as_bytes()));
        if i == 0 {
            // First attempt: noise, a NAV-PVT, an ACK for something else; then silence
            // until the 10 ms timeout.
            script.push(reply(&[0x00, 0xB5, 0x62, 0x24]));
            script.push(reply(pvt.as_bytes()));
            script.push(reply(&other_ack));
            for _ in 0..11 {
                script.push(idle());
            }
            script.push(write(cmd.as_bytes()));
        }
        script.push(reply(&ack(cmd.as_bytes())));
    }
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 115_200).with_timeout_ms(10);
    assert_eq!(drive(&mut cfg, &mut serial), Ok(vec![]));
    assert_eq!(cfg.retries(), 1);
    // The noise `B5 62 24 B5 62 01` announces a 354-byte payload and swallows the NAV-PVT
    // and the ACK behind it; the resend drops that stale candidate: 4 + 100 + 10 bytes.
    assert_eq!(cfg.framer_stats().bytes_skipped, 114);
    serial.done();
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
        T::flush(),
        // Now at 460800, while settling: the ACK for CFG-PRT arrives at the new rate, so no
        // poll is needed.
        idle(),
        reply(&ack(prt.as_bytes())),
    ];
    let cmds = cfg_commands(&config);
    for (i, cmd) in cmds.iter().enumerate() {
        script.push(write(cmd.as_bytes()));
        if i == 0 {
            // A CFG-PRT frame and a repeated ACK for CFG-PRT must not confuse CFG-MSG.
            script.push(reply(&frame(0x06, 0x00, &CFG_PRT_UART1_115200[6..26])));
            script.push(reply(&ack(prt.as_bytes())));
        }
        script.push(reply(&ack(cmd.as_bytes())));
    }
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 9_600);
    assert_eq!(drive(&mut cfg, &mut serial), Ok(vec![460_800]));
    assert_eq!(cfg.baud_rate(), 460_800);
    serial.done();
}

#[test]
fn baud_switch_when_the_ack_was_lost_is_confirmed_by_the_poll_answer() {
    let config = Config::default()
        .with_baud_rate(460_800)
        .with_time_pulse(None);
    let prt = commands::cfg_prt_uart1(460_800);
    let poll = commands::poll_cfg_prt_uart1();
    let mut script = vec![
        write(&MON_VER_POLL),
        reply(&mon_ver_reply()),
        write(prt.as_bytes()),
        T::flush(),
        // Settling (3 ms): garbage (the old-rate ACK seen at the new rate), a line error.
        reply(&[0xFE, 0x00, 0xB5, 0x80]),
        T::read_error(nb::Error::Other(ErrorKind::FrameFormat)),
        idle(),
        idle(),
        idle(),
        // Then the poll, and its answer confirms the new rate.
        write(poll.as_bytes()),
        reply(&frame(0x06, 0x00, &prt.as_bytes()[6..26])),
    ];
    for cmd in cfg_commands(&config) {
        script.push(write(cmd.as_bytes()));
        script.push(reply(&ack(cmd.as_bytes())));
    }
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 9_600).with_switch_settle_ms(3);
    assert_eq!(drive(&mut cfg, &mut serial), Ok(vec![460_800]));
    assert_eq!(cfg.line_errors(), 1);
    serial.done();
}

#[test]
fn nak_of_the_port_change_is_an_error_not_a_confirmed_switch() {
    // The receiver rejects CFG-PRT: it stays at the old rate. A NAK read after the host
    // switched (it was queued before the switch) must not count as proof of the new rate.
    let config = Config::default().with_baud_rate(460_800);
    let prt = commands::cfg_prt_uart1(460_800);
    let script = vec![
        write(&MON_VER_POLL),
        reply(&mon_ver_reply()),
        write(prt.as_bytes()),
        T::flush(),
        reply(&nak(prt.as_bytes())),
    ];
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 9_600);
    let mut switches = Vec::new();
    let mut result = Ok(());
    for now_ms in 0..100 {
        match cfg.poll(&mut serial, now_ms) {
            Ok(Progress::SetBaudRate(b)) => switches.push(b),
            Ok(Progress::Pending) => {}
            Ok(Progress::Done) => panic!("must not finish"),
            Err(e) => {
                result = Err(e);
                break;
            }
        }
    }
    assert_eq!(
        result,
        Err(Error::Device(neo_m8t::DeviceError::Nak {
            class: 0x06,
            id: 0x00
        }))
    );
    assert_eq!(switches, vec![460_800]);
    // The receiver is still at the old rate; the host UART must go back to it.
    assert_eq!(cfg.baud_rate(), 9_600);
    serial.done();
}

#[test]
fn baud_switch_without_answer_goes_back_and_finally_fails() {
    let config = Config::default().with_baud_rate(460_800);
    let prt = commands::cfg_prt_uart1(460_800);
    let poll = commands::poll_cfg_prt_uart1();
    let mut script = vec![write(&MON_VER_POLL), reply(&mon_ver_reply())];
    for _ in 0..2 {
        script.push(write(prt.as_bytes()));
        script.push(T::flush());
        // 2 ms settling, the poll, 5 ms of silence.
        script.extend([idle(), idle()]);
        script.push(write(poll.as_bytes()));
        for _ in 0..6 {
            script.push(idle());
        }
    }
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 9_600)
        .with_timeout_ms(5)
        .with_switch_settle_ms(2)
        .with_retries(1);
    let mut switches = Vec::new();
    let mut result = Ok(());
    for now_ms in 0..1_000 {
        match cfg.poll(&mut serial, now_ms) {
            Ok(Progress::SetBaudRate(b)) => switches.push(b),
            Ok(Progress::Pending) => {}
            Ok(Progress::Done) => panic!("must not finish"),
            Err(e) => {
                result = Err(e);
                break;
            }
        }
    }
    assert_eq!(
        result,
        Err(Error::Device(neo_m8t::DeviceError::BaudSwitchFailed {
            baud_rate: 460_800
        }))
    );
    assert_eq!(switches, vec![460_800, 9_600, 460_800]);
    serial.done();
}

#[test]
fn port_error_is_reported() {
    let mut serial = Mock::new(&[
        write(&MON_VER_POLL),
        T::read_error(nb::Error::Other(ErrorKind::Other)),
    ]);
    let mut cfg = Configurator::<512>::with_capacity(Config::default(), 115_200);
    assert_eq!(cfg.poll(&mut serial, 0), Err(Error::Comm(ErrorKind::Other)));
    serial.done();
}

#[test]
fn run_blocking_applies_the_configuration() {
    let config = Config::default().with_baud_rate(230_400);
    let prt = commands::cfg_prt_uart1(230_400);
    let mut script = vec![
        write(&MON_VER_POLL),
        idle(),
        reply(&mon_ver_reply()),
        write(prt.as_bytes()),
        T::flush(),
        reply(&ack(prt.as_bytes())),
    ];
    for cmd in cfg_commands(&config) {
        script.push(write(cmd.as_bytes()));
        script.push(reply(&ack(cmd.as_bytes())));
    }
    let mut serial = Mock::new(&script);
    let mut cfg = Configurator::<512>::with_capacity(config, 115_200);
    let mut bauds = Vec::new();
    cfg.run_blocking(&mut serial, &mut NoopDelay::new(), |_, b| bauds.push(b))
        .unwrap();
    assert_eq!(bauds, vec![230_400]);
    serial.done();
}

mod chunked {
    use super::*;
    use proptest::prelude::*;

    /// Splits `bytes` at the given cut lengths (cycled), with an idle read between pieces.
    /// (The last piece completes a frame that settles the step, so no read follows it.)
    fn chopped(bytes: &[u8], cuts: &[usize], script: &mut Vec<T>) {
        let mut rest = bytes;
        let mut cut = cuts.iter().cycle();
        while !rest.is_empty() {
            let n = (*cut.next().unwrap()).clamp(1, rest.len());
            let (piece, tail) = rest.split_at(n);
            script.push(reply(piece));
            if !tail.is_empty() {
                script.push(idle());
            }
            rest = tail;
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Answers split into random pieces, with NAV-PVT frames streaming in between,
        /// configure the receiver all the same.
        #[test]
        fn answers_in_random_pieces_with_nav_pvt_in_between(
            cuts in prop::collection::vec(1usize..40, 1..10),
            pvt_before in prop::collection::vec(any::<bool>(), 13),
        ) {
            let config = Config::default();
            let pvt = neo_m8t::NavPvt { itow_ms: 7, ..neo_m8t::NavPvt::default() }.to_frame();
            let mut script = vec![write(&MON_VER_POLL)];
            chopped(&mon_ver_reply(), &cuts, &mut script);
            let prt = commands::cfg_prt_uart1(config.baud_rate);
            let mut cmds = vec![prt];
            cmds.extend(cfg_commands(&config));
            for (cmd, pvt_first) in cmds.iter().zip(&pvt_before) {
                script.push(write(cmd.as_bytes()));
                let mut answer = Vec::new();
                if *pvt_first {
                    answer.extend_from_slice(pvt.as_bytes());
                }
                answer.extend_from_slice(&ack(cmd.as_bytes()));
                chopped(&answer, &cuts, &mut script);
            }
            let mut serial = Mock::new(&script);
            let mut cfg = Configurator::<512>::with_capacity(config, 115_200);
            prop_assert_eq!(drive(&mut cfg, &mut serial), Ok(vec![]));
            prop_assert_eq!(cfg.retries(), 0);
            serial.done();
        }
    }
}

#[test]
fn a_transmitter_that_never_drains_times_out() {
    // The first byte of MON-VER never leaves: 0 ms .. 10 ms of WouldBlock.
    let script: Vec<T> = (0..11)
        .map(|_| T::write_error(0xB5, nb::Error::WouldBlock))
        .collect();
    let mut serial = Mock::new(&script);
    let mut cfg =
        Configurator::<512>::with_capacity(Config::default(), 115_200).with_timeout_ms(10);
    assert_eq!(
        drive(&mut cfg, &mut serial),
        Err(Error::Device(neo_m8t::DeviceError::Timeout {
            class: 0x0A,
            id: 0x04
        }))
    );
    serial.done();
}
