//! `dima sim --firmware ELF`: the sensor board's own firmware, its `qemu` build running under
//! `qemu-system-arm -M netduinoplus2`, in place of the board written in Rust ([`crate::board`]).
//!
//! - **Sensors**: the vehicle model's readings go to the firmware's four sensor dies as register
//!   images over USART2 (the frames of `dima_firmware_logic::sensor_image`, `firmware/README.md`):
//!   the same raw words the Rust board puts in its packets ([`BoardSim`]: BMX055 words through the
//!   inverse of Bosch's compensation, BMP280 raw values through the inverse of the datasheet
//!   compensation), once per loop period (at most every [`FEED_PERIOD`]); at boot first the chip ids, the BMP280 calibration
//!   and the BMM150 trim, which the firmware's real bring-up reads.
//! - **GNSS**: each new NAV-PVT epoch (10 Hz) as UBX bytes on USART1.
//! - **Requests**: each rising edge of the application's request line ([`RequestLine`]) becomes
//!   one byte on USART3, the `qemu` build's stand-in for the request pin.
//! - **Answers**: what the firmware sends on USART3 is split into its frames (packet, info
//!   piece), passed through the link's [`FaultInjector`] like the Rust board's answers, and
//!   written to the application's pty at the configured baud rate from the request edge.
//!
//! Every packet the firmware sent unchanged is fingerprinted in [`BoardStats::intact`] (so the
//! runner's check that every logged packet was sent intact applies as it does to the Rust
//! board), and every register set fed is kept in [`FirmwareStats`] for [`firmware_checks`].

use std::collections::{HashMap, HashSet};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{mpsc, Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::Context;
use dima_sensorboard::{GNSS_FRAME_LEN, INFO_PIECE_LEN, PACKET_LEN};

use crate::board::{
    BoardConfig, BoardSim, SensorFaultState, BMM150_TRIM, DATASHEET_BMP280_CALIBRATION,
};
use crate::devices::{fingerprint, lock, set_fifo, BoardSetup, BoardStats, LinkPort, LATE_ANSWER};
use crate::faults::{FaultInjector, FaultSpec, SensorFaults};
use crate::pty::LinePace;
use crate::request::RequestLine;
use crate::rng::SimRng;
use crate::world::World;

/// The shortest time between two writes of the model's readings into the dies' images
/// (250 Hz); they are written once per loop period, at most this often. Each write is 46
/// bytes on USART2, an interrupt per byte in the emulator.
pub const FEED_PERIOD: Duration = Duration::from_millis(4);
/// How long the relay waits for the firmware's packet after forwarding a request.
const ANSWER_TIMEOUT: Duration = Duration::from_millis(100);
/// How long the emulator may take to boot the firmware (QEMU start, bring-up).
const BOOT_TIMEOUT: Duration = Duration::from_secs(30);
/// How long the firmware is asked for packets before the application starts, their answers
/// dropped: QEMU translates the guest's code the first time it runs, which makes the first
/// answers of a fresh emulator several milliseconds late.
pub const WARM_UP: Duration = Duration::from_millis(1500);
/// Bytes the relay collects before a paced write (the Rust board's writes go in 16-byte
/// chunks too).
const RELAY_CHUNK: usize = 16;
/// The byte that stands in for a request edge (any byte but the smoke test's `!` and `~`).
const REQUEST_BYTE: u8 = b'R';

/// Frame ids of the four dies (`dima_firmware_logic::sensor_image::Die`).
const ACCEL: u8 = 0;
const GYRO: u8 = 1;
const MAG: u8 = 2;
const BMP280: u8 = 3;
/// The frame that ends the boot-time images.
const END_OF_BOOT_IMAGES: u8 = 0xFF;
/// First byte of an image frame.
const IMAGE_SYNC: u8 = 0xA5;

/// One image frame: sync, die, first register, length, bytes, and a check that makes the
/// 8-bit sum of everything after the sync zero.
pub fn image_frame(die: u8, start: u8, data: &[u8]) -> Vec<u8> {
    let len = u8::try_from(data.len()).expect("an image frame holds at most 255 bytes");
    let mut out = Vec::with_capacity(data.len() + 5);
    out.extend_from_slice(&[IMAGE_SYNC, die, start, len]);
    out.extend_from_slice(data);
    let sum = out[1..].iter().fold(0u8, |s, &b| s.wrapping_add(b));
    out.push(sum.wrapping_neg());
    out
}

/// The dies' data registers for one reading, as the packet carries them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DieRegisters {
    /// Accelerometer 0x02..=0x07.
    pub accel: [u8; 6],
    /// Gyroscope 0x02..=0x07.
    pub gyro: [u8; 6],
    /// Magnetometer 0x42..=0x49 (X, Y, Z, RHALL).
    pub mag: [u8; 8],
    /// BMP280 0xF7..=0xFC (pressure, temperature).
    pub bmp280: [u8; 6],
}

impl DieRegisters {
    /// The registers in bytes 2..=27 of a v1 packet.
    pub fn of_packet(packet: &[u8; PACKET_LEN]) -> DieRegisters {
        let take = |from: usize| -> [u8; 8] { std::array::from_fn(|i| packet[from + i]) };
        let six = |from: usize| -> [u8; 6] { std::array::from_fn(|i| packet[from + i]) };
        DieRegisters {
            accel: six(2),
            gyro: six(8),
            mag: take(14),
            bmp280: six(22),
        }
    }

    /// The update frames that put these values into the images. The magnetometer's data-ready
    /// bit (bit 0 of 0x48) is set: the firmware reads its data only when it is.
    pub fn frames(&self) -> Vec<u8> {
        let mut mag = self.mag;
        mag[6] |= 0x01;
        let mut out = image_frame(ACCEL, 0x02, &self.accel);
        out.extend(image_frame(GYRO, 0x02, &self.gyro));
        out.extend(image_frame(MAG, 0x42, &mag));
        out.extend(image_frame(BMP280, 0xF7, &self.bmp280));
        out
    }
}

/// The boot-time images: chip ids, BMM150 trim, BMP280 calibration, a first reading, then the
/// end-of-boot-images frame.
pub fn boot_images(first: &DieRegisters) -> Vec<u8> {
    let t = &BMM150_TRIM;
    let mut out = image_frame(ACCEL, 0x00, &[0xFA]);
    out.extend(image_frame(GYRO, 0x00, &[0x0F]));
    out.extend(image_frame(MAG, 0x40, &[0x32]));
    out.extend(image_frame(MAG, 0x5D, &t[0..2]));
    out.extend(image_frame(MAG, 0x62, &t[2..6]));
    out.extend(image_frame(MAG, 0x68, &t[6..16]));
    out.extend(image_frame(BMP280, 0xD0, &[0x58]));
    out.extend(image_frame(BMP280, 0x88, &DATASHEET_BMP280_CALIBRATION));
    out.extend(first.frames());
    out.extend(image_frame(END_OF_BOOT_IMAGES, 0, &[]));
    out
}

/// What the firmware board was fed and sent, beyond [`BoardStats`].
#[derive(Debug, Default)]
pub struct FirmwareStats {
    /// Register sets written into the images.
    pub feeds: AtomicU64,
    /// NAV-PVT frames written to the GNSS UART.
    pub gnss_frames: AtomicU64,
    /// Packets the firmware sent.
    pub packets_sent: AtomicU64,
    /// Info pieces the firmware sent.
    pub pieces_sent: AtomicU64,
    /// Bytes the firmware sent outside a packet or an info piece (relayed as they are).
    pub stray_bytes: AtomicU64,
    /// Requests forwarded that the firmware did not answer within the timeout.
    pub unanswered: AtomicU64,
    /// Time from a request forwarded to its packet's last byte from QEMU, µs: sum and
    /// largest.
    pub packet_latency_us_sum: AtomicU64,
    /// See `packet_latency_us_sum`.
    pub packet_latency_us_max: AtomicU64,
    /// Time from a request edge to the end of the relayed answer, µs: sum and largest.
    pub answer_us_sum: AtomicU64,
    /// See `answer_us_sum`.
    pub answer_us_max: AtomicU64,
    /// When each accelerometer register set was fed, s of simulation time (a car at rest
    /// gives the same set again now and then).
    pub fed_accel: Mutex<HashMap<[u8; 6], Vec<f64>>>,
    /// Gyroscope register sets fed.
    pub fed_gyro: Mutex<HashSet<[u8; 6]>>,
    /// Magnetometer register sets fed.
    pub fed_mag: Mutex<HashSet<[u8; 8]>>,
    /// BMP280 register sets fed.
    pub fed_bmp280: Mutex<HashSet<[u8; 6]>>,
    /// What the firmware printed (semihosting) up to `ready`.
    pub boot_lines: Mutex<Vec<String>>,
}

impl FirmwareStats {
    /// One line for the run's summary; `logged` packets of the log matched ones it sent.
    pub fn summary(&self, logged: u64) -> String {
        let n = |a: &AtomicU64| a.load(Ordering::Relaxed);
        let packets = n(&self.packets_sent).max(1);
        format!(
            "firmware under QEMU: sent {} packets (request to last byte avg/max {}/{} µs, \
             edge to answer relayed avg/max {}/{} µs) and {} info pieces ({} bytes outside a \
             frame, {} requests unanswered); fed {} register sets and {} NAV-PVT frames; {} \
             logged packets byte-identical to ones it sent",
            n(&self.packets_sent),
            n(&self.packet_latency_us_sum) / packets,
            n(&self.packet_latency_us_max),
            n(&self.answer_us_sum) / packets,
            n(&self.answer_us_max),
            n(&self.pieces_sent),
            n(&self.stray_bytes),
            n(&self.unanswered),
            n(&self.feeds),
            n(&self.gnss_frames),
            logged
        )
    }

    /// Keeps `regs`, fed at `t_s`.
    fn record(&self, regs: &DieRegisters, t_s: f64) {
        lock(&self.fed_accel)
            .entry(regs.accel)
            .or_default()
            .push(t_s);
        lock(&self.fed_gyro).insert(regs.gyro);
        lock(&self.fed_mag).insert(regs.mag);
        lock(&self.fed_bmp280).insert(regs.bmp280);
    }
}

/// The emulator running the firmware: its process and the host ends of its three UARTs.
struct Emulator {
    child: Child,
    /// USART1: NAV-PVT bytes to the firmware.
    gnss: TcpStream,
    /// USART2: image frames to the firmware.
    images: TcpStream,
    /// USART3: request bytes to the firmware, its answers back.
    link: TcpStream,
    /// The firmware's semihosting lines.
    said: mpsc::Receiver<String>,
}

impl Drop for Emulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Emulator {
    /// Starts `elf` on `qemu` with USART1, USART2 and USART3 on local TCP sockets.
    fn start(qemu: &str, elf: &Path) -> anyhow::Result<Emulator> {
        let listen = || TcpListener::bind("127.0.0.1:0").context("binding a local socket");
        let (gnss, images, link) = (listen()?, listen()?, listen()?);
        let port = |l: &TcpListener| l.local_addr().map(|a| a.port());
        let serial = |p: u16| format!("tcp:127.0.0.1:{p},nodelay=on");
        let mut child = Command::new(qemu)
            .args(["-M", "netduinoplus2", "-nographic", "-monitor", "none"])
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(["-serial", &serial(port(&gnss)?)])
            .args(["-serial", &serial(port(&images)?)])
            .args(["-serial", &serial(port(&link)?)])
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .with_context(|| format!("starting {qemu} (install qemu-system-arm, or set QEMU)"))?;
        let stdout = child.stdout.take().context("QEMU's output")?;
        let (tx, said) = mpsc::channel();
        std::thread::Builder::new()
            .name("sim-fw-output".into())
            .spawn(move || {
                for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                    if tx.send(line).is_err() {
                        break;
                    }
                }
            })?;
        let accept = |l: &TcpListener, what: &str| -> anyhow::Result<TcpStream> {
            let (s, _) = l
                .accept()
                .with_context(|| format!("QEMU connecting {what}"))?;
            s.set_nodelay(true)?;
            Ok(s)
        };
        // QEMU connects its serial ports in order before the firmware runs.
        let gnss = accept(&gnss, "USART1")?;
        let images = accept(&images, "USART2")?;
        let link = accept(&link, "USART3")?;
        Ok(Emulator {
            child,
            gnss,
            images,
            link,
            said,
        })
    }

    /// Waits for a semihosting line for which `done` holds, keeping every line in `lines`.
    fn wait_for(
        &self,
        lines: &Mutex<Vec<String>>,
        deadline: Instant,
        done: impl Fn(&str) -> bool,
    ) -> anyhow::Result<String> {
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let line = self.said.recv_timeout(left).map_err(|_| {
                anyhow::anyhow!(
                    "the firmware under QEMU did not get there (it said: {:?})",
                    lock(lines)
                )
            })?;
            lock(lines).push(line.clone());
            if done(&line) {
                return Ok(line);
            }
        }
    }
}

/// The firmware booted under QEMU, its dies loaded and its code warmed up, before the
/// simulation's clock starts (booting takes a second or two of wall time, which the
/// scenario's script must not lose).
pub struct BootedFirmware {
    emulator: Emulator,
    /// The encoders that made the boot images; the feeder goes on with them.
    board: BoardSim,
    /// What the firmware was fed and sent.
    pub stats: Arc<FirmwareStats>,
}

/// Boots `elf` under QEMU (`$QEMU`, else `qemu-system-arm`): answers its `sensor images:
/// waiting` with the dies' chip ids, calibration, trim and the model's reading of the car at
/// rest in `world` (board `config`, noise from `rng`), waits for `ready`, then asks for
/// packets for [`WARM_UP`].
pub fn boot_firmware(
    elf: &Path,
    config: BoardConfig,
    rng: &SimRng,
    world: &World,
) -> anyhow::Result<BootedFirmware> {
    let qemu = std::env::var("QEMU").unwrap_or_else(|_| "qemu-system-arm".into());
    let stats = Arc::new(FirmwareStats::default());
    let mut board = BoardSim::new(config, rng.fork(1));
    let emulator = Emulator::start(&qemu, elf)?;
    let deadline = Instant::now() + BOOT_TIMEOUT;
    emulator.wait_for(&stats.boot_lines, deadline, |l| {
        l.starts_with("sensor images:")
    })?;
    let packet = board
        .answer_with(0.0, &world.state(), SensorFaultState::default())
        .packet;
    let first = DieRegisters::of_packet(&packet);
    stats.record(&first, 0.0);
    (&emulator.images)
        .write_all(&boot_images(&first))
        .context("writing the boot images")?;
    let loaded = emulator.wait_for(&stats.boot_lines, deadline, |l| {
        l.starts_with("sensor images: ") && !l.ends_with("waiting")
    })?;
    if loaded != "sensor images: loaded" {
        anyhow::bail!("the firmware did not take the sensor images ({loaded})");
    }
    emulator.wait_for(&stats.boot_lines, deadline, |l| l == "ready")?;
    let mut link = FirmwareLink {
        stream: emulator.link.try_clone()?,
        buffer: Vec::new(),
        current: None,
    };
    link.warm_up(WARM_UP);
    Ok(BootedFirmware {
        emulator,
        board,
        stats,
    })
}

/// The sensor-board threads of `dima sim --firmware`, on the `booted` firmware: the feeder
/// writing the model into the dies' images every `feed_period` (at most every
/// [`FEED_PERIOD`]) and NAV-PVT into the GNSS UART, and the relay answering request edges
/// with what the firmware sends.
#[allow(clippy::too_many_arguments)]
pub fn spawn_firmware_board(
    booted: BootedFirmware,
    world: Arc<World>,
    line: Arc<RequestLine>,
    port: LinkPort,
    setup: BoardSetup,
    rng: SimRng,
    stats: Arc<BoardStats>,
    feed_period: Duration,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<Vec<JoinHandle<()>>> {
    let BoardSetup {
        link_faults,
        sensor_faults,
        pace,
        ..
    } = setup;
    let BootedFirmware {
        emulator,
        board,
        stats: firmware,
    } = booted;
    let feeder = Feeder {
        world: world.clone(),
        board,
        sensor_faults,
        firmware: firmware.clone(),
        counts_only: stats.counts_only,
        stop: stop.clone(),
        period: feed_period.max(FEED_PERIOD),
        gnss_epochs: 0,
        gnss: Some(emulator.gnss.try_clone()?),
        images: Some(emulator.images.try_clone()?),
    };
    let link = FirmwareLink {
        stream: emulator.link.try_clone()?,
        buffer: Vec::with_capacity(1024),
        current: None,
    };
    let relay = Relay {
        _emulator: emulator,
        world,
        line,
        port,
        link,
        injector: FaultInjector::new(link_faults.clone(), rng.fork(2)),
        spec: link_faults,
        pace,
        stats,
        firmware,
        stop,
        seen: 0,
    };
    let feeder = std::thread::Builder::new()
        .name("sim-fw-sensors".into())
        .spawn(move || feeder.run())?;
    let relay = std::thread::Builder::new()
        .name("sim-fw-board".into())
        .spawn(move || relay.run())?;
    Ok(vec![relay, feeder])
}

/// Writes the model's readings into the dies' images and NAV-PVT into the GNSS UART.
struct Feeder {
    world: Arc<World>,
    /// The Rust board's encoders (and noise); only its packets' register bytes are used.
    board: BoardSim,
    sensor_faults: SensorFaults,
    firmware: Arc<FirmwareStats>,
    counts_only: bool,
    stop: Arc<AtomicBool>,
    /// Time between two writes of the images.
    period: Duration,
    /// NAV-PVT epochs sent so far.
    gnss_epochs: u64,
    gnss: Option<TcpStream>,
    images: Option<TcpStream>,
}

impl Feeder {
    /// The model's reading now (with the sensors' faults); also sends a new NAV-PVT epoch.
    fn sample(&mut self) -> DieRegisters {
        let t = self.world.now_s();
        let faults = SensorFaultState {
            gnss_frozen: self.sensor_faults.gnss_frozen_at(t),
            gnss_lost: self.sensor_faults.gnss_lost_at(t),
            imu_stuck: self.sensor_faults.imu_stuck_at(t),
            rolled_over: self.sensor_faults.rolled_over_at(t),
        };
        let packet = self
            .board
            .answer_with(t, &self.world.state(), faults)
            .packet;
        if self.board.gnss_epochs() > self.gnss_epochs {
            self.gnss_epochs = self.board.gnss_epochs();
            if let Some(gnss) = &mut self.gnss {
                if gnss.write_all(&packet[28..28 + GNSS_FRAME_LEN]).is_ok() {
                    self.firmware.gnss_frames.fetch_add(1, Ordering::Relaxed);
                }
            }
        }
        let regs = DieRegisters::of_packet(&packet);
        if !self.counts_only {
            self.firmware.record(&regs, t);
        }
        self.firmware.feeds.fetch_add(1, Ordering::Relaxed);
        regs
    }

    /// Feeds every `period` until `stop`.
    fn run(mut self) {
        let mut next = Instant::now();
        while !self.stop.load(Ordering::Relaxed) {
            let regs = self.sample();
            let written = self
                .images
                .as_mut()
                .map(|images| images.write_all(&regs.frames()));
            if matches!(written, Some(Err(_))) {
                return;
            }
            next += self.period;
            let now = Instant::now();
            if next > now {
                std::thread::sleep(next - now);
            } else {
                next = now;
            }
        }
    }
}

/// The kinds of frame in the firmware's output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A v1 packet (`$$`, 132 bytes).
    Packet,
    /// An info piece (`$H`, 21 bytes).
    Piece,
    /// A byte outside any frame.
    Stray,
}

impl Kind {
    /// The kind of frame that starts with `head` (two bytes).
    fn of(head: &[u8]) -> Kind {
        match head {
            b"$$" => Kind::Packet,
            b"$H" => Kind::Piece,
            _ => Kind::Stray,
        }
    }

    /// Its length in bytes.
    fn len(self) -> usize {
        match self {
            Kind::Packet => PACKET_LEN,
            Kind::Piece => INFO_PIECE_LEN,
            Kind::Stray => 1,
        }
    }
}

/// A frame on its way through the relay: what the firmware sent of it so far, and what the
/// fault injector made of that.
#[derive(Debug)]
struct Outgoing {
    kind: Kind,
    sent: Vec<u8>,
    mangled: Vec<u8>,
    intact: bool,
}

/// The host end of USART3: request bytes out, the firmware's bytes in.
struct FirmwareLink {
    stream: TcpStream,
    /// Bytes received and not yet relayed.
    buffer: Vec<u8>,
    /// The frame being relayed, if one is half through.
    current: Option<Outgoing>,
}

impl FirmwareLink {
    /// Reads what arrives within `timeout` (rounded up to whole milliseconds; zero: only what
    /// is there) into the buffer; false when the link is gone. Polls rather than a socket
    /// read timeout, which the kernel rounds up to its tick (4 ms and more).
    fn fill(&mut self, timeout: Duration) -> bool {
        use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
        use std::os::fd::AsFd;
        let ms = timeout.as_micros().div_ceil(1000).min(u128::from(u16::MAX)) as u16;
        let mut fds = [PollFd::new(self.stream.as_fd(), PollFlags::POLLIN)];
        match poll(&mut fds, PollTimeout::from(ms)) {
            Ok(0) | Err(nix::errno::Errno::EINTR) => return true,
            Ok(_) => {}
            Err(_) => return false,
        }
        let mut chunk = [0u8; 512];
        match self.stream.read(&mut chunk) {
            Ok(0) => false,
            Ok(n) => {
                self.buffer.extend_from_slice(&chunk[..n]);
                true
            }
            Err(e) => matches!(
                e.kind(),
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::Interrupted
            ),
        }
    }

    /// Asks for a packet every 10 ms for `time`, and drops the answers (see [`WARM_UP`]).
    fn warm_up(&mut self, time: Duration) {
        let end = Instant::now() + time;
        while Instant::now() < end {
            if self.stream.write_all(&[REQUEST_BYTE]).is_err() {
                return;
            }
            let next = Instant::now() + Duration::from_millis(10);
            while Instant::now() < next {
                self.fill(next.saturating_duration_since(Instant::now()));
            }
            self.buffer.clear();
        }
        // The last answer's stragglers.
        self.fill(Duration::from_millis(20));
        self.buffer.clear();
    }

    /// Moves the buffered bytes through `injector` into `wire`, frame by frame (a frame's
    /// bytes go on as they arrive); returns the frames completed.
    fn relay_buffered(
        &mut self,
        injector: &mut FaultInjector,
        wire: &mut Vec<u8>,
    ) -> Vec<Outgoing> {
        let mut done = Vec::new();
        loop {
            if self.current.is_none() {
                let kind = match self.buffer.as_slice() {
                    [] | [b'$'] => return done,
                    [_] => Kind::Stray,
                    more => Kind::of(&more[..2]),
                };
                self.current = Some(Outgoing {
                    kind,
                    sent: Vec::with_capacity(kind.len()),
                    mangled: Vec::with_capacity(kind.len() + 8),
                    intact: true,
                });
            }
            let Some(frame) = self.current.as_mut() else {
                return done;
            };
            let take = (frame.kind.len() - frame.sent.len()).min(self.buffer.len());
            if take == 0 {
                return done;
            }
            let part: Vec<u8> = self.buffer.drain(..take).collect();
            let before = frame.mangled.len();
            frame.intact &= injector.mangle_part(&part, &mut frame.mangled);
            frame.sent.extend_from_slice(&part);
            wire.extend_from_slice(&frame.mangled[before..]);
            if frame.sent.len() == frame.kind.len() {
                injector.end_frame(frame.intact);
                done.extend(self.current.take());
            }
        }
    }
}

/// Answers request edges with the firmware's frames.
struct Relay {
    /// Kills QEMU when the relay ends.
    _emulator: Emulator,
    world: Arc<World>,
    line: Arc<RequestLine>,
    port: LinkPort,
    link: FirmwareLink,
    injector: FaultInjector,
    spec: FaultSpec,
    pace: LinePace,
    stats: Arc<BoardStats>,
    firmware: Arc<FirmwareStats>,
    stop: Arc<AtomicBool>,
    /// Request edges taken so far.
    seen: u64,
}

impl Relay {
    /// Answers request edges until `stop`.
    fn run(mut self) {
        self.line.listen();
        // Answer requests promptly on a busy machine when the system allows it (as the Rust
        // board does).
        let _ = set_fifo(70);
        self.seen = self.line.edges();
        while !self.stop.load(Ordering::Relaxed) {
            let now = self.line.wait_edge(self.seen, Duration::from_millis(5));
            let t = self.world.now_s();
            let connected = self.maintain_port(t);
            if now == self.seen {
                continue;
            }
            let edge_at = self.take_edges(now);
            if !connected || self.spec.silent_at(t) {
                self.stats.unanswered.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            if self.answer(edge_at) {
                self.stats.answers.fetch_add(1, Ordering::Relaxed);
                self.count_late_answer();
            } else {
                self.stats.unanswered.fetch_add(1, Ordering::Relaxed);
                self.firmware.unanswered.fetch_add(1, Ordering::Relaxed);
            }
            self.skip_requests_during_answer();
            *lock(&self.stats.faults) = self.injector.stats();
        }
    }

    /// Opens or closes the pty by the link's disconnect windows at `t`, drops what the
    /// application sent; true when connected.
    fn maintain_port(&mut self, t: f64) -> bool {
        let connected = self.port.update(&self.spec, t).is_some();
        self.stats.opens.store(self.port.opens, Ordering::Relaxed);
        if let Some(pty) = self.port.pty() {
            let mut junk = [0u8; 256];
            let _ = pty.read(&mut junk, Duration::ZERO);
        }
        connected
    }

    /// Takes the edges up to `now` (all but the last came while the previous answer was going
    /// out: not forwarded) and returns when the last one came.
    fn take_edges(&mut self, now: u64) -> Instant {
        let edges = now - self.seen;
        self.seen = now;
        let edge_at = Instant::now()
            .checked_sub(self.line.since_last_edge())
            .unwrap_or_else(Instant::now);
        self.stats.requests.fetch_add(edges, Ordering::Relaxed);
        self.stats
            .unanswered
            .fetch_add(edges.saturating_sub(1), Ordering::Relaxed);
        edge_at
    }

    /// Forwards the request and relays the firmware's answer as it arrives (through the fault
    /// injector, at the line's pace from `edge_at`, in chunks of at least [`RELAY_CHUNK`]
    /// bytes: QEMU sends a byte at a time, and a paced write per byte would oversleep): the
    /// packet, then the info piece behind it if one comes; false when no packet came within
    /// [`ANSWER_TIMEOUT`].
    fn answer(&mut self, edge_at: Instant) -> bool {
        if self.link.stream.write_all(&[REQUEST_BYTE]).is_err() {
            return false;
        }
        let asked = Instant::now();
        let deadline = asked + ANSWER_TIMEOUT;
        let start = edge_at + self.injector.delay();
        let mut pending = Vec::with_capacity(256);
        let mut written = 0;
        let mut answered = false;
        loop {
            let done = self.link.relay_buffered(&mut self.injector, &mut pending);
            let packet_now = done.iter().any(|f| f.kind == Kind::Packet);
            for frame in &done {
                if frame.kind == Kind::Packet {
                    let f = &self.firmware;
                    note(&f.packet_latency_us_sum, &f.packet_latency_us_max, asked);
                }
                self.count(frame);
            }
            answered |= packet_now;
            let between_frames = answered && self.link.current.is_none();
            // After the packet and what followed it at once (its info piece): done.
            let finished = between_frames && !packet_now;
            if pending.len() >= RELAY_CHUNK || between_frames {
                self.write_paced(&pending, start, written);
                written += pending.len();
                pending.clear();
            }
            if finished {
                let f = &self.firmware;
                note(&f.answer_us_sum, &f.answer_us_max, edge_at);
                return true;
            }
            let left = deadline.saturating_duration_since(Instant::now());
            // Between frames, only what is there: the firmware sends the piece right behind
            // the packet, long before the packet's paced write has ended.
            let wait = if between_frames { Duration::ZERO } else { left };
            if left.is_zero() || !self.link.fill(wait) {
                self.write_paced(&pending, start, written);
                return answered;
            }
        }
    }

    /// Writes `bytes` to the application's pty at the line's pace, the answer having started
    /// at `start` and `already` bytes of it written.
    fn write_paced(&self, bytes: &[u8], start: Instant, already: usize) {
        if let (false, Some(pty)) = (bytes.is_empty(), self.port.pty()) {
            let from = start + self.pace.wire_time(already);
            let _ = pty.write_paced_from(from, bytes, self.pace, Duration::from_millis(50));
        }
    }

    /// Counts a frame the firmware sent, as it went out.
    fn count(&self, frame: &Outgoing) {
        let f = &self.firmware;
        match frame.kind {
            Kind::Packet => {
                f.packets_sent.fetch_add(1, Ordering::Relaxed);
                self.count_packet(&frame.sent, &frame.mangled);
            }
            Kind::Piece => {
                f.pieces_sent.fetch_add(1, Ordering::Relaxed);
                self.stats.info_frames.fetch_add(1, Ordering::Relaxed);
            }
            Kind::Stray => {
                f.stray_bytes.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// Counts `packet` as intact or damaged by what the fault injector made of it (`out`).
    fn count_packet(&self, packet: &[u8], out: &[u8]) {
        let stats = &self.stats;
        let intact = out.windows(packet.len()).any(|w| w == packet);
        if intact {
            stats.packets_intact.fetch_add(1, Ordering::Relaxed);
            if !stats.counts_only {
                lock(&stats.intact).insert(fingerprint(packet));
            }
        } else {
            stats.packets_damaged.fetch_add(1, Ordering::Relaxed);
            if !stats.counts_only {
                lock(&stats.damaged).insert(fingerprint(out));
            }
        }
    }

    /// Counts the answer late when it was complete after the deadline, or after the next
    /// request already came.
    fn count_late_answer(&self) {
        if self.line.edges() != self.seen || self.line.since_last_edge() > LATE_ANSWER {
            self.stats.late_answers.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// The requests that came while the answer was going out are not forwarded.
    fn skip_requests_during_answer(&mut self) {
        let during = self.line.edges() - self.seen;
        if during > 0 {
            self.seen += during;
            self.stats.requests.fetch_add(during, Ordering::Relaxed);
            self.stats.unanswered.fetch_add(during, Ordering::Relaxed);
        }
    }
}

/// Adds the time since `since` to `sum` and `max`, µs.
fn note(sum: &AtomicU64, max: &AtomicU64, since: Instant) {
    let us = since.elapsed().as_micros() as u64;
    sum.fetch_add(us, Ordering::Relaxed);
    max.fetch_max(us, Ordering::Relaxed);
}

/// The checks of a run with the firmware in the loop, judged on the application's log
/// (`log_path`, the last file of the run): every logged packet's sensor registers are ones
/// the model fed (each die's, byte for byte), the accelerometer's following the model in time
/// (fed within 0.5 s of the packet's log time);
/// the board's health record shows all four dies present with no SPI error, no magnetometer
/// time-out and no GNSS byte outside a valid frame; no CRC error
/// (unless `link_faults` damage the sensor link on purpose). With `bounded` evidence (a soak:
/// no register sets kept) the register check is skipped.
pub fn firmware_checks(
    log_path: &Path,
    fed: &FirmwareStats,
    start_wall_ns: u64,
    crc_errors: u64,
    link_faults: bool,
    bounded: bool,
) -> Vec<(String, Option<Result<(), String>>)> {
    let mut checks = Vec::new();
    let runs: anyhow::Result<Vec<dima_log::LoggedRun>> = dima_log::naming::run_files(log_path)
        .and_then(|files| files.iter().map(|f| dima_log::LoggedRun::read(f)).collect());
    let runs = match runs {
        Ok(r) => r,
        Err(e) => {
            checks.push((
                "firmware: the log reads back".to_owned(),
                Some(Err(format!("{e:#}"))),
            ));
            return checks;
        }
    };
    checks.push((
        "firmware: 0 CRC errors".to_owned(),
        (!link_faults).then(|| {
            if crc_errors == 0 {
                Ok(())
            } else {
                Err(format!("{crc_errors} CRC errors"))
            }
        }),
    ));
    checks.push((
        "firmware: the health record shows all four sensors present and no SPI, magnetometer or GNSS error".to_owned(),
        Some(health_all_present(&runs)),
    ));
    checks.push((
        "firmware: every logged sensor register is one the model fed".to_owned(),
        (!bounded).then(|| registers_fed(&runs, fed, start_wall_ns)),
    ));
    checks
}

/// The last info record: status bits 0..=3 set (accelerometer, gyroscope, magnetometer,
/// BMP280 found at boot), no SPI error on any die, no magnetometer time-out, every GNSS byte
/// in a valid NAV-PVT frame.
fn health_all_present(runs: &[dima_log::LoggedRun]) -> Result<(), String> {
    let info = runs
        .iter()
        .flat_map(|r| r.infos.iter())
        .last()
        .ok_or("no info record in the log")?;
    let h = &info.msg.health;
    let errors = [h.accel_errors, h.gyro_errors, h.mag_errors, h.bmp280_errors];
    if info.msg.status & 0x0F != 0x0F {
        return Err(format!("status {:#04x}: a die missing", info.msg.status));
    }
    if errors.iter().any(|&e| e != 0) {
        return Err(format!("SPI errors per die {errors:?}"));
    }
    if h.mag_timeout_errors != 0 {
        return Err(format!("{} magnetometer time-outs", h.mag_timeout_errors));
    }
    if h.gnss_bytes_dropped != 0 || h.gnss_frame_errors != 0 {
        return Err(format!(
            "GNSS: {} bytes dropped, {} bad frames",
            h.gnss_bytes_dropped, h.gnss_frame_errors
        ));
    }
    Ok(())
}

/// Each logged packet's accelerometer, gyroscope, magnetometer and BMP280 registers are a set
/// the model fed; the accelerometer's within 0.5 s of the packet's log time (which is the
/// cycle's wake-up: a loop held up on a busy machine logs data newer than its time).
fn registers_fed(
    runs: &[dima_log::LoggedRun],
    fed: &FirmwareStats,
    start_wall_ns: u64,
) -> Result<(), String> {
    let accel = lock(&fed.fed_accel);
    let gyro = lock(&fed.fed_gyro);
    let mag = lock(&fed.fed_mag);
    let bmp280 = lock(&fed.fed_bmp280);
    let mut checked = 0u64;
    for (&t_ns, packet) in runs.iter().flat_map(|r| r.raw.iter()) {
        let regs = DieRegisters::of_packet(packet);
        let t_s = t_ns.saturating_sub(start_wall_ns) as f64 * 1e-9;
        let Some(fed_s) = accel.get(&regs.accel) else {
            return Err(format!(
                "accelerometer {:02x?} at {t_s:.3} s never fed",
                regs.accel
            ));
        };
        if !fed_s.iter().any(|f| (t_s - 0.5..=t_s + 0.5).contains(f)) {
            return Err(format!(
                "accelerometer logged at {t_s:.3} s was fed at {fed_s:.3?} s, not within 0.5 s"
            ));
        }
        if !gyro.contains(&regs.gyro) {
            return Err(format!(
                "gyroscope {:02x?} at {t_s:.3} s never fed",
                regs.gyro
            ));
        }
        if !mag.contains(&regs.mag) {
            return Err(format!(
                "magnetometer {:02x?} at {t_s:.3} s never fed",
                regs.mag
            ));
        }
        if !bmp280.contains(&regs.bmp280) {
            return Err(format!(
                "BMP280 {:02x?} at {t_s:.3} s never fed",
                regs.bmp280
            ));
        }
        checked += 1;
    }
    if checked == 0 {
        return Err("no packet in the log".to_owned());
    }
    Ok(())
}

/// Where `dima sim --firmware` looks for the ELF when given a directory: the `qemu` build.
pub fn qemu_elf(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join("target/thumbv7em-none-eabihf/qemu/dima-firmware")
    } else {
        path.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_frames_match_the_firmware_parsers_vector() {
        // The same vector as the firmware's `sensor_image` tests.
        assert_eq!(
            image_frame(3, 0xF7, &[0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00]),
            [0xA5, 0x03, 0xF7, 0x06, 0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00, 0x16]
        );
        assert_eq!(image_frame(0xFF, 0, &[]), [0xA5, 0xFF, 0x00, 0x00, 0x01]);
    }

    #[test]
    fn registers_come_from_the_packet_and_the_magnetometer_is_ready() {
        let mut packet = [0u8; PACKET_LEN];
        for (i, b) in packet.iter_mut().enumerate() {
            *b = i as u8;
        }
        let regs = DieRegisters::of_packet(&packet);
        assert_eq!(regs.accel, [2, 3, 4, 5, 6, 7]);
        assert_eq!(regs.gyro, [8, 9, 10, 11, 12, 13]);
        assert_eq!(regs.mag, [14, 15, 16, 17, 18, 19, 20, 21]);
        assert_eq!(regs.bmp280, [22, 23, 24, 25, 26, 27]);
        let frames = regs.frames();
        // accel frame 11 bytes, gyro 11, then the magnetometer's: RHALL LSB (0x48) has bit 0.
        let mag = &frames[22..22 + 13];
        assert_eq!(mag[..4], [0xA5, MAG, 0x42, 8]);
        assert_eq!(mag[4 + 6], 20 | 0x01);
    }

    #[test]
    fn the_relay_passes_frames_on_as_they_arrive() {
        let (a, _b) = {
            let l = TcpListener::bind("127.0.0.1:0").unwrap();
            let c = TcpStream::connect(l.local_addr().unwrap()).unwrap();
            (l.accept().unwrap().0, c)
        };
        let mut link = FirmwareLink {
            stream: a,
            buffer: Vec::new(),
            current: None,
        };
        let mut injector = FaultInjector::new(FaultSpec::default(), SimRng::new(1));
        let mut packet = [9u8; PACKET_LEN];
        packet[..2].copy_from_slice(b"$$");
        let mut piece = [7u8; INFO_PIECE_LEN];
        piece[..2].copy_from_slice(b"$H");
        let mut wire = Vec::new();
        link.buffer.push(0x55);
        link.buffer.extend_from_slice(&packet[..100]);
        let done = link.relay_buffered(&mut injector, &mut wire);
        assert_eq!(done.len(), 1, "the stray byte");
        assert_eq!(done[0].kind, Kind::Stray);
        assert_eq!(wire.len(), 101, "the packet's first bytes went on");
        link.buffer.extend_from_slice(&packet[100..]);
        link.buffer.extend_from_slice(&piece[..1]);
        let done = link.relay_buffered(&mut injector, &mut wire);
        assert_eq!(done.len(), 1);
        assert_eq!((done[0].kind, done[0].intact), (Kind::Packet, true));
        assert_eq!(done[0].sent, packet);
        assert_eq!(
            wire.len(),
            1 + PACKET_LEN,
            "a lone `$` waits for the next byte"
        );
        link.buffer.extend_from_slice(&piece[1..]);
        let done = link.relay_buffered(&mut injector, &mut wire);
        assert_eq!(done[0].kind, Kind::Piece);
        assert_eq!(wire[1 + PACKET_LEN..], piece);
    }
}
