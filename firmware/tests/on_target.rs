//! On-target checks of the pure logic, run under QEMU through semihosting.
//!
//! The same `dima-firmware-logic` and `dima-sensorboard` code the host tests cover, built for
//! thumbv7em and run on QEMU's Cortex-M4: the CRC vectors, the request state machine, the
//! sampling schedule, and a packet and an info frame through encoder and decoder. Prints one
//! line per check and `N passed, N failed`; the exit status is the verdict.
//!
//! ```sh
//! CARGO_TARGET_THUMBV7EM_NONE_EABIHF_RUNNER="qemu-system-arm -M netduinoplus2 -nographic \
//!   -monitor none -semihosting-config enable=on,target=native -kernel" \
//!   cargo test --release --test on_target
//! ```
#![no_std]
#![no_main]

use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use dima_firmware_logic::Schedule;
use dima_firmware_logic::{
    AfterTransfer, Answer, CheckedCrc, MagAction, NibbleCrc, RequestHandler,
};
use dima_firmware_logic::{ScheduleConfig, INFO_GAP_MS};
use dima_sensorboard::{InfoFrame, PacketBuilder, SensorCrc, SensorPacket, SensorStatus, Stm32Crc};
// Links the device's interrupt vectors.
use stm32f4xx_hal as _;

struct Checks {
    passed: u32,
    failed: u32,
}

impl Checks {
    fn check(&mut self, ok: bool, name: &str) {
        if ok {
            self.passed += 1;
            hprintln!("ok      {}", name);
        } else {
            self.failed += 1;
            hprintln!("FAILED  {}", name);
        }
    }
}

#[entry]
fn main() -> ! {
    let mut checks = Checks {
        passed: 0,
        failed: 0,
    };
    crc_vectors(&mut checks);
    crc_fallback_and_self_check(&mut checks);
    request_state_machine(&mut checks);
    sampling_schedule(&mut checks);
    packet_round_trip(&mut checks);
    info_frame_round_trips(&mut checks);

    hprintln!("{} passed, {} failed", checks.passed, checks.failed);
    if checks.failed == 0 {
        debug::exit(debug::EXIT_SUCCESS);
    } else {
        debug::exit(debug::EXIT_FAILURE);
    }
    loop {
        cortex_m::asm::wfi();
    }
}

/// Sensor CRC vectors (the shared vectors: STM32 CRC unit, one byte per word).
fn crc_vectors(checks: &mut Checks) {
    let ascending: [u8; 128] = core::array::from_fn(|i| i as u8);
    checks.check(
        Stm32Crc::compute(&ascending) == 0x6557_DE1A,
        "CRC of bytes 0x00..=0x7F is 0x6557DE1A",
    );
    checks.check(
        Stm32Crc::compute(&[0u8; 128]) == 0xE151_AAB2,
        "CRC of 128 zero bytes is 0xE151AAB2",
    );
}

/// The software fallback of the CRC unit, and the boot self-check that selects it: QEMU has
/// no CRC unit, so the check runs here against the table CRC standing in for a working unit
/// and against a unit that reads zero, like QEMU's.
fn crc_fallback_and_self_check(checks: &mut Checks) {
    let ascending: [u8; 128] = core::array::from_fn(|i| i as u8);
    // The software fallback of the CRC unit, and the boot self-check that selects it: QEMU
    // has no CRC unit, so the check runs here against the table CRC standing in for a working
    // unit and against a unit that reads zero, like QEMU's.
    checks.check(
        NibbleCrc.checksum(&ascending) == 0x6557_DE1A
            && NibbleCrc.checksum(&[0u8; 128]) == 0xE151_AAB2,
        "fallback CRC matches both vectors",
    );
    checks.check(
        CheckedCrc::check(Stm32Crc).unit_ok(),
        "self-check keeps a unit that computes the vector",
    );
    struct ReadsZero;
    impl SensorCrc for ReadsZero {
        fn checksum(&mut self, _bytes: &[u8]) -> u32 {
            0
        }
    }
    let mut dead = CheckedCrc::check(ReadsZero);
    checks.check(
        !dead.unit_ok() && dead.checksum(&ascending) == 0x6557_DE1A,
        "self-check replaces a unit that reads zero by the fallback",
    );
}

/// The request state machine: no packet yet, skips, a piece behind each packet, restarts.
fn request_state_machine(checks: &mut Checks) {
    let mut handler = RequestHandler::new();
    checks.check(
        handler.on_request(0, false) == Answer::NotReady,
        "no packet before the first one exists",
    );
    checks.check(
        handler.on_request(1, true) == Answer::Send,
        "first answer: the packet",
    );
    checks.check(
        handler.on_request(2, true) == Answer::Skip && handler.skipped() == 1,
        "request during a transfer is skipped and counted",
    );
    checks.check(
        handler.on_transfer_complete() == AfterTransfer::SendPiece { restart: true },
        "after the first packet: an info piece from piece 0",
    );
    handler.piece_started();
    checks.check(
        handler.on_transfer_complete() == AfterTransfer::Idle && !handler.is_busy(),
        "packet, then piece, then idle",
    );
    handler.on_request(6, true);
    checks.check(
        handler.on_transfer_complete() == AfterTransfer::SendPiece { restart: false },
        "next answer: the next piece",
    );
    handler.end_answer();
    handler.on_request(6 + INFO_GAP_MS, true);
    checks.check(
        handler.on_transfer_complete() == AfterTransfer::SendPiece { restart: true },
        "a pause of 500 ms starts the snapshot again",
    );
}

/// The sampling schedule's first two ticks.
fn sampling_schedule(checks: &mut Checks) {
    let mut schedule = Schedule::new(ScheduleConfig::DEFAULT);
    let first = schedule.next_tick();
    let second = schedule.next_tick();
    checks.check(
        first.read_inertial && first.read_baro && first.mag == MagAction::Trigger,
        "tick 0: inertial, baro, magnetometer trigger",
    );
    checks.check(
        second.mag == MagAction::Poll && !second.read_baro,
        "tick 1: magnetometer poll, no baro",
    );
}

/// A packet through the builder and the decoder.
fn packet_round_trip(checks: &mut Checks) {
    let mut builder = PacketBuilder::new();
    builder
        .gyro_registers([0x11, 0x22, 0x33, 0x44, 0x55, 0x66])
        .bmp280_registers([0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00]);
    let packet = *builder.build(&mut Stm32Crc);
    let decoded = SensorPacket::decode(&packet);
    checks.check(
        decoded.is_ok_and(|p| p.gyro == [0x2211, 0x4433, 0x6655]),
        "packet round trip through PacketBuilder and SensorPacket::decode",
    );
}

/// An info frame through encoder and decoder: version 1, version 2 with health (CRC from the
/// fallback), version 3 with faults, and version 3 cut into eleven pieces through the stream
/// decoder.
fn info_frame_round_trips(checks: &mut Checks) {
    let info = InfoFrame {
        version: 1,
        firmware: [0, 1, 0],
        status: SensorStatus::ACCEL_OK | SensorStatus::GNSS_SEEN,
        bmp280_calibration: [7; 24],
        bmm150_trim: [9; 16],
        uptime_ms: 123_456,
        requests_skipped: 3,
        ..InfoFrame::default()
    };
    let bytes = info.encode();
    checks.check(
        InfoFrame::decode(&bytes).is_ok_and(|(back, len)| back == info && len == 60),
        "info frame round trip (60 bytes)",
    );
    // Version 2 as the board sends it: health included, CRC from the fallback CRC.
    let info = InfoFrame {
        version: 2,
        health: dima_sensorboard::BoardHealth {
            gyro_errors: 5,
            mag_timeout_errors: 2,
            watchdog_resets: 1,
            accel_age_ms: 4,
            ..Default::default()
        },
        ..info
    };
    let bytes = info.encode_v2_with(&mut NibbleCrc);
    checks.check(
        InfoFrame::decode(&bytes).is_ok_and(|(back, len)| back == info && len == 108),
        "info frame v2 round trip with health (108 bytes)",
    );
    // Version 3 as the board sends it: faults too, eleven pieces through the stream decoder.
    let info = InfoFrame {
        version: 3,
        faults: dima_sensorboard::BoardFaults {
            gnss_framing_errors: 2,
            sample_overruns: 9,
            reset_fault: 4,
            ..Default::default()
        },
        ..info
    };
    let bytes = info.encode_v3_with(&mut NibbleCrc);
    checks.check(
        InfoFrame::decode(&bytes).is_ok_and(|(back, len)| back == info && len == 128),
        "info frame v3 round trip with health and faults (128 bytes)",
    );
    let pieces = info.encode_v3_pieces_with(7, &mut NibbleCrc);
    let mut decoder = dima_sensorboard::StreamDecoder::new();
    let mut records = 0;
    for piece in &pieces {
        for frame in decoder.frames(piece) {
            records += usize::from(frame == dima_sensorboard::Frame::Info(info));
        }
    }
    checks.check(
        records == 1 && decoder.stats().info_pieces == 11,
        "info pieces reassemble into the v3 frame (11 x 21 bytes)",
    );
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    hprintln!("panic: {}", info);
    hprintln!("0 passed, 1 failed");
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
