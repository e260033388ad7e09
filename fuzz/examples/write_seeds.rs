//! Writes the seed corpora in `fuzz/seeds/<target>/`: golden vectors from datasheets and the
//! original hardware, and frames made with the project's own encoders (the ground link v2
//! frames under the targets' fixed key, which no hand could write).
//!
//! ```text
//! cargo run --manifest-path fuzz/Cargo.toml --example write_seeds -- [SIM_LOG.mcap]
//! ```
//!
//! With a log of a short `dima sim` run, the `mcap_log` seed is that log rewritten without its
//! latency histogram attachment (to keep it small); without one, the committed seed is kept.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use dima_fuzz::{LINK_KEY, SESSION};
use dima_groundlink::v2::{self, CommandFrame, FailsafeCause, Health, LinkKey, RobotMode};
use dima_groundlink::{Command, DisplayFrame, Percent};
use dima_sensorboard::imu::ImuPacketWords;
use dima_sensorboard::{
    nav_pvt, AnswerCycleV2, GnssFrame, InfoFrame, LinkFlags, NavPvt, PacketV2, SensorPacket,
    SensorStatus, Stm32Crc, Trailer,
};

/// The original ground station's heartbeat, byte for byte (docs/wire-formats.md, command frame v1).
const HEARTBEAT: [u8; 10] = [0x24, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC6, 0x22, 0xF7, 0x1D];

/// BMP280 calibration registers 0x88..=0x9F, datasheet example.
const BMP280_CALIB: [u8; 24] = [
    0x70, 0x6B, 0x43, 0x67, 0x18, 0xFC, 0x7D, 0x8E, 0x43, 0xD6, 0xD0, 0x0B, 0x27, 0x0B, 0x8C, 0x00,
    0xF9, 0xFF, 0x8C, 0x3C, 0xF8, 0xC6, 0x70, 0x17,
];

/// BMM150 trim registers, Bosch SensorAPI example.
const BMM150_TRIM: [u8; 16] = [
    0x00, 0x00, 0x00, 0x00, 0x1A, 0x1A, 0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D,
];

/// Digi's `digi-xbee` test vectors: AT NI query, AT ID set, AT NI response "ROBOT".
const XBEE_BOTH_MODES: [&[u8]; 3] = [
    &[0x7E, 0x00, 0x04, 0x08, 0x01, 0x4E, 0x49, 0x5F],
    &[0x7E, 0x00, 0x06, 0x08, 0x52, 0x49, 0x44, 0x7F, 0xFF, 0x9A],
    &[
        0x7E, 0x00, 0x0A, 0x88, 0x01, 0x4E, 0x49, 0x00, 0x52, 0x4F, 0x42, 0x4F, 0x54, 0x59,
    ],
];
/// Digi's transmit request and receive packet, API 1.
const XBEE_API1: [&[u8]; 2] = [
    &[
        0x7E, 0x00, 0x10, 0x10, 0x01, 0x00, 0x13, 0xA2, 0x00, 0x40, 0xA1, 0xB2, 0xC3, 0xFF, 0xFE,
        0x00, 0x00, 0x48, 0x69, 0x35,
    ],
    &[
        0x7E, 0x00, 0x12, 0x90, 0x00, 0x13, 0xA2, 0x00, 0x40, 0x52, 0x2B, 0xAA, 0x7D, 0x84, 0x01,
        0x52, 0x78, 0x44, 0x61, 0x74, 0x61, 0x0D,
    ],
];
/// The same two frames, API 2 (escaped).
const XBEE_API2: [&[u8]; 2] = [
    &[
        0x7E, 0x00, 0x10, 0x10, 0x01, 0x00, 0x7D, 0x33, 0xA2, 0x00, 0x40, 0xA1, 0xB2, 0xC3, 0xFF,
        0xFE, 0x00, 0x00, 0x48, 0x69, 0x35,
    ],
    &[
        0x7E, 0x00, 0x12, 0x90, 0x00, 0x7D, 0x33, 0xA2, 0x00, 0x40, 0x52, 0x2B, 0xAA, 0x7D, 0x5D,
        0x84, 0x01, 0x52, 0x78, 0x44, 0x61, 0x74, 0x61, 0x0D,
    ],
];

/// u-blox ACK-ACK for CFG-RATE (receiver description, UBX-ACK-ACK).
const UBX_ACK_ACK: [u8; 10] = [0xB5, 0x62, 0x05, 0x01, 0x02, 0x00, 0x06, 0x08, 0x16, 0x3F];

/// Set Target, channel 2, 1500 µs (Pololu Maestro user's guide).
const MAESTRO_SET_TARGET: [u8; 4] = [0x84, 0x02, 0x70, 0x2E];

fn fix(itow_ms: u32) -> NavPvt {
    NavPvt {
        itow_ms,
        year: 2026,
        month: 11,
        day: 22,
        hour: 8,
        valid: nav_pvt::VALID_DATE | nav_pvt::VALID_TIME,
        t_acc_ns: 30,
        fix_type: 3,
        flags: 1,
        num_sv: 9,
        lon_deg_e7: 85_465_123,
        lat_deg_e7: 473_976_543,
        height_mm: 500_000,
        h_msl_mm: 452_000,
        h_acc_mm: 1500,
        v_acc_mm: 2500,
        vel_n_mm_s: 1000,
        vel_e_mm_s: -1000,
        g_speed_mm_s: 1414,
        head_mot_deg_e5: 13_500_000,
        s_acc_mm_s: 200,
        head_acc_deg_e5: 1_000_000,
        p_dop_e2: 150,
        ..NavPvt::default()
    }
}

fn info() -> InfoFrame {
    InfoFrame {
        version: 1,
        firmware: [1, 2, 3],
        status: SensorStatus::ACCEL_OK
            | SensorStatus::GYRO_OK
            | SensorStatus::MAG_OK
            | SensorStatus::BMP280_OK
            | SensorStatus::GNSS_SEEN,
        bmp280_calibration: BMP280_CALIB,
        bmm150_trim: BMM150_TRIM,
        uptime_ms: 0x0102_0304,
        requests_skipped: 7,
        ..InfoFrame::default()
    }
}

fn packet(i: i16, gnss: Option<NavPvt>) -> [u8; 132] {
    let mut builder = dima_sensorboard::PacketBuilder::new();
    builder
        .accel([i, -i, 1000])
        .gyro([i * 100, 0, -i])
        .mag([-300, 120, -1200], 6000)
        .pressure_raw(415_148)
        .temperature_raw(519_888);
    if let Some(fix) = gnss {
        builder.gnss_frame(fix.to_frame().as_bytes());
    }
    *builder.build(&mut Stm32Crc)
}

fn sensor_seeds() -> Vec<(&'static str, Vec<u8>)> {
    let mut capture = b"boot noise $ $I".to_vec();
    capture.extend(packet(1, None));
    capture.extend(info().encode());
    capture.extend(&packet(2, Some(fix(1000)))[..70]); // torn answer
    capture.extend(packet(3, Some(fix(1200))));
    capture.extend(info().encode_v2_with(&mut Stm32Crc));
    capture.extend(b"$$");
    capture.extend(packet(4, Some(fix(1400))));
    vec![
        ("packet", SensorPacket::default().encode().to_vec()),
        ("packet-gnss", packet(7, Some(fix(500))).to_vec()),
        ("info-v1", info().encode().to_vec()),
        ("info-v2", info().encode_v2_with(&mut Stm32Crc).to_vec()),
        ("capture", capture),
    ]
}

fn packet_v2(request_count: u32, flags: LinkFlags) -> [u8; 42] {
    let mut imu = [0u8; 20];
    for (i, b) in imu.iter_mut().enumerate() {
        *b = (request_count as u8).wrapping_add(i as u8 * 13);
    }
    PacketV2 {
        request_count,
        sample_time_us: 0xFFFF_FF00u32.wrapping_add(request_count * 500),
        imu: ImuPacketWords::from_le_bytes(&imu),
        press_raw: 415_148,
        temp_raw: 519_888,
        status: info().status,
        flags,
    }
    .encode(&mut Stm32Crc)
}

/// Sensor link v2: the board's answers to 24 requests (NAV-PVT frames at requests 2 and 12,
/// an info snapshot at request 0), a single packet, one NAV-PVT frame's pieces, and pieces of
/// two epochs interleaved with a torn packet and a v1 packet in between.
fn sensor_v2_seeds() -> Vec<(&'static str, Vec<u8>)> {
    let mut cycle = AnswerCycleV2::new();
    let mut answers = b"boot $P".to_vec();
    for request in 0..24u32 {
        if request == 0 {
            cycle.publish_info(&info().encode_v3_pieces_with(1, &mut Stm32Crc));
        }
        if request == 2 || request == 12 {
            cycle.publish_gnss(
                &GnssFrame::from_nav_pvt(&fix(1000 + request * 100)),
                &mut Stm32Crc,
            );
        }
        let trailer = cycle.next(request == 0);
        let flags = trailer.map_or(LinkFlags::empty(), |t| t.flag());
        answers.extend(packet_v2(request, flags));
        answers.extend(trailer.as_ref().map_or(&[][..], Trailer::as_bytes));
    }
    let a = GnssFrame::from_nav_pvt(&fix(2000)).encode_pieces_with(7, &mut Stm32Crc);
    let b = GnssFrame::from_nav_pvt(&fix(2100)).encode_pieces_with(8, &mut Stm32Crc);
    let mut mixed = Vec::new();
    mixed.extend(a[0]);
    mixed.extend(a[1]);
    mixed.extend(&packet_v2(30, LinkFlags::empty())[..17]);
    mixed.extend(b[2]);
    mixed.extend(SensorPacket::default().encode());
    mixed.extend(b[0]);
    mixed.extend(a[2]);
    for piece in b {
        mixed.extend(packet_v2(31, LinkFlags::GNSS_PIECE_FOLLOWS));
        mixed.extend(piece);
    }
    vec![
        ("packet", packet_v2(1, LinkFlags::empty()).to_vec()),
        ("gnss-pieces", a.concat()),
        ("answers", answers),
        ("mixed-epochs", mixed),
    ]
}

fn v1_commands() -> Vec<u8> {
    let mut stream = HEARTBEAT.to_vec();
    for command in [
        Command::Revive,
        Command::Throttle(Percent::new(75).unwrap()),
        Command::Steering(Percent::MAX),
        Command::Tail(Percent::HALF),
        Command::SpeedSetpoint { mm_s: -1500 },
        Command::HeadingSetpoint { deg_e5: 9_000_000 },
        Command::Kill,
    ] {
        stream.extend(command.encode());
    }
    stream
}

fn v2_command(
    command: Command,
    session: u32,
    seq: u32,
    key: &LinkKey,
) -> [u8; v2::COMMAND_FRAME_LEN] {
    CommandFrame::new(command, session, seq).encode(key)
}

/// A repetition, under `seq`, of the request whose first frame was `request`.
fn v2_repeat(command: Command, seq: u32, request: u32) -> [u8; v2::COMMAND_FRAME_LEN] {
    CommandFrame::repeat(command, SESSION, seq, request).encode(&LinkKey::from_bytes(LINK_KEY))
}

/// A v2 session: revive, drive, a replay, a forgery, a kill from a station without the session,
/// a stale session, a kill; then a throttle given while KILLED, a revive, and repetitions of
/// both after it (heartbeats to the gate), and a throttle given after the revive.
fn v2_commands() -> Vec<u8> {
    let key = LinkKey::from_bytes(LINK_KEY);
    let other = LinkKey::from_bytes([0x42; 16]);
    let throttle = Command::Throttle(Percent::new(60).unwrap());
    let mut stream = Vec::new();
    stream.extend(v2_command(Command::Revive, SESSION, 1, &key));
    stream.extend(v2_command(throttle, SESSION, 2, &key));
    stream.extend(v2_command(throttle, SESSION, 2, &key));
    stream.extend(v2_command(Command::Revive, SESSION, 3, &other));
    stream.extend(v2_command(Command::Kill, 0, 1, &key));
    stream.extend(v2_command(Command::Revive, SESSION ^ 1, 9, &key));
    stream.extend(v2_command(
        Command::HeadingSetpoint { deg_e5: 18_000_000 },
        SESSION,
        4,
        &key,
    ));
    stream.extend(v2_command(Command::Kill, SESSION, 5, &key));
    let drive = Command::Throttle(Percent::new(80).unwrap());
    stream.extend(v2_repeat(drive, 6, 6));
    stream.extend(v2_repeat(Command::Revive, 7, 7));
    stream.extend(v2_repeat(drive, 8, 6));
    stream.extend(v2_repeat(Command::Revive, 9, 7));
    stream.extend(v2_repeat(Command::SpeedSetpoint { mm_s: 3_000 }, 10, 4));
    stream.extend(v2_repeat(drive, 11, 11));
    stream
}

fn display_v1() -> DisplayFrame {
    DisplayFrame {
        acc: [-1, 2, -3],
        gyro: [4, -5, 6],
        mag: [-7, 8, -9],
        mag_hall: 0x1234,
        baro_press: 0x000A_BCDE,
        baro_temp: 0x0001_2345,
        lat_e7: -340_885_000,
        lon_e7: 184_750_000,
        vel_n_mm_s: -10,
        vel_e_mm_s: 11,
        vel_d_mm_s: -12,
        height_mm: 13,
        h_msl_mm: 14,
        g_speed_mm_s: 15,
        head_mot_deg_e5: 16,
    }
}

fn display_v2(seq: u32, mode: RobotMode) -> [u8; v2::DISPLAY_FRAME_LEN] {
    v2::DisplayFrame {
        mode,
        failsafe_cause: Some(FailsafeCause::CommsLoss),
        revive_refusal: None,
        session: SESSION,
        seq,
        ack_seq: seq.saturating_sub(1),
        health: Health {
            commands: seq,
            bad_tag: 1,
            ..Health::default()
        },
        sensors: display_v1(),
    }
    .encode(&LinkKey::from_bytes(LINK_KEY))
}

fn display_v3(seq: u32, mode: RobotMode) -> [u8; v2::DISPLAY_V3_FRAME_LEN] {
    let key = LinkKey::from_bytes(LINK_KEY);
    let status = v2::DisplayFrame::decode(&display_v2(seq, mode), &key).expect("authentic");
    v2::DisplayFrameV3 {
        status,
        actuation: v2::Actuation {
            servo_quarter_us: [6400, 6000, 5600],
            speed_setpoint_mm_s: Some(1500),
            heading_setpoint_deg_e5: None,
            speed_estimate_mm_s: Some(1200),
            heading_estimate_deg_e5: Some(9_000_000),
            speed_error_mm_s: Some(300),
            controllers: [
                v2::ControllerCode::SpeedPid,
                v2::ControllerCode::HeadingPid,
                v2::ControllerCode::Neutral,
            ],
        },
    }
    .encode(&key)
}

fn display_seeds() -> Vec<(&'static str, Vec<u8>)> {
    let mut stream = b"noise".to_vec();
    stream.extend(display_v1().encode());
    stream.extend(display_v2(1, RobotMode::Manual));
    stream.extend(&display_v1().encode()[..30]);
    stream.extend(display_v2(2, RobotMode::Failsafe));
    stream.extend(DisplayFrame::default().encode());
    stream.extend(display_v3(3, RobotMode::Auto));
    vec![
        ("v1", display_v1().encode().to_vec()),
        ("v2", display_v2(7, RobotMode::Auto).to_vec()),
        ("v3", display_v3(8, RobotMode::Auto).to_vec()),
        ("mixed", stream),
    ]
}

fn ubx(class: u8, id: u8, payload: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; payload.len() + 8];
    let n = neo_m8t::encode_frame(class, id, payload, &mut out).expect("frame fits");
    out.truncate(n);
    out
}

/// MON-VER as an M8T answers it: software and hardware version, then extensions.
fn mon_ver() -> Vec<u8> {
    let mut payload = Vec::new();
    let field = |text: &str, len: usize| {
        let mut f = text.as_bytes().to_vec();
        f.resize(len, 0);
        f
    };
    payload.extend(field("ROM CORE 3.01 (107888)", 30));
    payload.extend(field("00080000", 10));
    for ext in ["FWVER=TIM 1.10", "PROTVER=22.00", "GPS;GLO;GAL;BDS"] {
        payload.extend(field(ext, 30));
    }
    ubx(0x0A, 0x04, &payload)
}

fn ubx_seeds() -> Vec<(&'static str, Vec<u8>)> {
    let nav = fix(1000).to_frame().as_bytes().to_vec();
    let tim_tp = ubx(0x0D, 0x01, &[0x10; 16]);
    let tim_tm2 = ubx(0x0D, 0x03, &[0x01; 28]);
    let mut stream = vec![0x24, 0x24, 0xB5];
    stream.extend(&nav[..40]);
    stream.extend(&nav);
    stream.extend(UBX_ACK_ACK);
    stream.extend(&tim_tp);
    stream.extend(&tim_tm2);
    stream.extend(mon_ver());
    vec![
        ("nav-pvt", nav),
        ("ack-ack", UBX_ACK_ACK.to_vec()),
        ("mon-ver", mon_ver()),
        ("stream", stream),
    ]
}

/// Bursts as the `maestro_replies` target reads them: a length byte, then the bytes.
fn bursts(parts: &[&[u8]]) -> Vec<u8> {
    let mut out = Vec::new();
    for part in parts {
        out.push(part.len() as u8);
        out.extend(*part);
    }
    out
}

fn maestro_seeds() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        // Replies after an empty port: position 6000 (1500 µs), errors 0x0008, one-byte answers.
        (
            "replies",
            bursts(&[
                &[],
                &[0x70, 0x2E],
                &[0x08, 0x00],
                &[0x01],
                &[0x00],
                &[0xC0, 0x1C],
            ]),
        ),
        // 64 stale bytes, then a reply: the query must go out.
        ("stale-64", bursts(&[&[0x55; 64], &[0x70, 0x2E]])),
        // 65: more than the driver discards.
        ("stale-65", bursts(&[&[0x55; 65], &[0x70, 0x2E]])),
        // Host -> Maestro bytes for the device-side decoder.
        ("set-target", MAESTRO_SET_TARGET.to_vec()),
    ]
}

fn config_seeds() -> Vec<(&'static str, Vec<u8>)> {
    let pca = "[servo]\nkind = \"pca9685\"\n\n[pca9685]\npwm_frequency_hz = 50\n\n\
               [realtime]\nloop_rate_hz = 50\n\n[safety]\noverrun_limit = 5\n";
    vec![
        (
            "default",
            dima_core::config::DEFAULT_TOML.as_bytes().to_vec(),
        ),
        ("pca9685", pca.as_bytes().to_vec()),
    ]
}

/// QGroundControl plans: the 40 m square of `dima-core`'s tests, without and with a fence
/// polygon (fence version 2), and the older format (`coordinate`, `param1`..`param4`) with a
/// version 1 fence.
fn plan_seeds() -> Vec<(&'static str, Vec<u8>)> {
    let old = r#"{"fileType": "Plan", "version": 1,
        "geoFence": {"version": 1, "breachReturn": [48.1, 11.5],
                     "polygon": [[48.0995, 11.4995], [48.0995, 11.5015], [48.1015, 11.5015],
                                 [48.1015, 11.4995]]},
        "mission": {"items": [
            {"command": 178, "param1": 1, "param2": 2.5, "param3": -1, "param4": 0,
             "coordinate": [0, 0, 0]},
            {"command": 16, "param1": 0, "param2": 2, "param3": 0, "param4": 0,
             "coordinate": [48.1, 11.5, 0]},
            {"command": 16, "param1": 0, "param2": 0, "param3": 0, "param4": 0,
             "coordinate": [48.101, 11.501, 0]}]}}"#;
    vec![
        (
            "square-40m.plan",
            include_bytes!("../../crates/core/tests/fixtures/square-40m.plan").to_vec(),
        ),
        (
            "square-40m-fenced.plan",
            include_bytes!("../../crates/core/tests/fixtures/square-40m-fenced.plan").to_vec(),
        ),
        ("old-format-v1-fence.plan", old.as_bytes().to_vec()),
    ]
}

/// A `dima sim` log without its latency histogram attachment, chunks compressed, schemas and
/// channels only in the chunks.
fn small_log(sim_log: &Path) -> Vec<u8> {
    let bytes = std::fs::read(sim_log).expect("read the sim log");
    let mut out = std::io::Cursor::new(Vec::new());
    let mut writer = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .compression_level(19)
        .repeat_schemas(false)
        .repeat_channels(false)
        .create(&mut out)
        .expect("MCAP writer");
    let mut channels = BTreeMap::new();
    for message in dima_log::reader::messages(&bytes).expect("a complete sim log") {
        let id = *channels
            .entry(message.channel.id)
            .or_insert_with(|| writer.add_channel_from(&message.channel));
        writer
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: id,
                    sequence: message.sequence,
                    log_time: message.log_time,
                    publish_time: message.log_time,
                },
                &message.data,
            )
            .expect("write a message");
    }
    for m in dima_log::reader::metadata(&bytes).0 {
        let metadata = mcap::records::Metadata {
            name: m.name,
            metadata: m.pairs,
        };
        writer.write_metadata(&metadata).expect("write metadata");
    }
    writer.finish().expect("finish the MCAP file");
    drop(writer);
    out.into_inner()
}

/// `add_channel` with the channel's own schema.
trait AddChannelFrom {
    fn add_channel_from(&mut self, channel: &dima_log::reader::ChannelInfo) -> u16;
}

impl<W: std::io::Write + std::io::Seek> AddChannelFrom for mcap::Writer<W> {
    fn add_channel_from(&mut self, channel: &dima_log::reader::ChannelInfo) -> u16 {
        let schema = if channel.schema_name.is_empty() {
            0
        } else {
            self.add_schema(
                &channel.schema_name,
                &channel.schema_encoding,
                &channel.schema,
            )
            .expect("write a schema")
        };
        self.add_channel(
            schema,
            &channel.topic,
            &channel.message_encoding,
            &BTreeMap::new(),
        )
        .expect("write a channel")
    }
}

fn write(dir: &Path, target: &str, seeds: &[(&str, Vec<u8>)]) {
    let dir = dir.join(target);
    std::fs::create_dir_all(&dir).expect("create the seed directory");
    for (name, bytes) in seeds {
        std::fs::write(dir.join(name), bytes).expect("write a seed");
    }
}

fn main() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("seeds");
    let sensor = sensor_seeds();
    let mut commands = vec![
        ("heartbeat", HEARTBEAT.to_vec()),
        ("v1", v1_commands()),
        ("v2", v2_commands()),
    ];
    let mut mixed = v1_commands();
    mixed.extend(v2_commands());
    commands.push(("mixed", mixed));
    let display = display_seeds();
    write(&dir, "sensor_stream", &sensor);
    write(&dir, "sensor_stream_v2", &sensor_v2_seeds());
    write(&dir, "command_stream", &commands);
    write(&dir, "display_stream", &display);
    let mut xbee: Vec<(&str, Vec<u8>)> = Vec::new();
    let mut api1 = Vec::new();
    let mut api2 = Vec::new();
    for frame in XBEE_BOTH_MODES {
        api1.extend(frame);
        api2.extend(frame);
    }
    for (a, b) in XBEE_API1.iter().zip(XBEE_API2) {
        api1.extend(*a);
        api2.extend(b);
    }
    xbee.push(("at-ni-query", XBEE_BOTH_MODES[0].to_vec()));
    xbee.push(("api1", api1));
    xbee.push(("api2", api2));
    write(&dir, "xbee_frames", &xbee);
    write(&dir, "ubx_reader", &ubx_seeds());
    write(&dir, "maestro_replies", &maestro_seeds());
    write(&dir, "config_toml", &config_seeds());
    write(&dir, "plan_file", &plan_seeds());
    write(
        &dir,
        "inspect",
        &[
            ("sensor", sensor[4].1.clone()),
            ("command", v1_commands()),
            (
                "display",
                display
                    .iter()
                    .find(|(name, _)| *name == "mixed")
                    .expect("a mixed display seed")
                    .1
                    .clone(),
            ),
        ],
    );
    if let Some(sim_log) = std::env::args_os().nth(1) {
        write(&dir, "mcap_log", &[("sim", small_log(Path::new(&sim_log)))]);
    }
    println!("seeds written to {}", dir.display());
}
