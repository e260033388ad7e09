//! QEMU smoke test of the sensor-board firmware.
//!
//! Runs the firmware's `qemu` build on QEMU's `netduinoplus2` machine (STM32F405) with USART1
//! (GNSS) and USART3 (host link) on local TCP sockets, then checks what a host sees, in this
//! order (one method of `Smoke` each):
//!
//! 1. SysTick's exception priority is below the request interrupt's, and SPI1_CR1 as the
//!    firmware left it clocks the sensor bus at 10 MHz at most from the APB2 clock the HAL
//!    computed for (the fastest divider that does);
//!    the watchdog starts before the clock set-up (which can wait for ever for the crystal)
//!    and the sensors;
//! 2. nothing at all arrives before the first request (no packet at boot, none unrequested);
//! 3. the first eleven requests are each answered with one packet and one info piece, and the
//!    eleventh completes the first info record (version 3, with health and faults: no GNSS
//!    UART error, no fault before this boot);
//! 4. requests a few milliseconds apart get exactly one packet each;
//! 5. a NAV-PVT frame written to the GNSS UART shows up, byte for byte, in later packets;
//! 6. after a pause (500 ms or more on the board's clock) a record arrives again within eleven
//!    answers, with a larger uptime and the GNSS bit set;
//! 7. a receiver silent for 1 s is reported in the info frame;
//! 8. a sampling tick that runs into the next period (asked for with the byte `~`, a hook of
//!    the `qemu` build) is counted in the info frame's `sample_overruns`;
//! 9. the decoder counted one packet per request and every record the checks saw;
//! 10. a panic (asked for with the byte `!`, a hook of the `qemu` build) resets the board at
//!     once (QEMU models no watchdog: only the panic handler's own reset can reboot it), the
//!     next boot reports `reset: fault Panic`, and the answers after it come from the new boot.
//!
//! Every byte from USART3 goes through `dima_sensorboard::StreamDecoder`, which checks start
//! tokens and CRCs: a packet counts only if the decoder accepts it, and any skipped byte or CRC
//! error fails the test.
//!
//! Usage: `qemu-smoke PATH/TO/ELF` (QEMU's `qemu-system-arm` must be on the PATH). The last
//! line of output is `N passed, N failed`; the exit status is non-zero on any failure.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use dima_sensorboard::{nav_pvt, NavPvt, GNSS_FRAME_LEN};
use dima_sensorboard::{BoardFaults, Frame, InfoFrame, RawPacket, SensorStatus, StreamDecoder};

/// Pieces of the board's info record (version 3): requests until a whole record.
const PIECES: usize = dima_sensorboard::INFO_V3_PIECES;

/// Host-side pause that must look like a host restart to the board (its threshold: 500 ms).
const PAUSE: Duration = Duration::from_secs(2);

/// How long to wait for an answer to one request.
const ANSWER_TIMEOUT: Duration = Duration::from_millis(1500);

/// Kills QEMU when the test ends, whatever the outcome.
struct Qemu(Child);

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// The host side of USART3: sends request bytes, decodes what comes back.
struct HostLink {
    stream: TcpStream,
    decoder: StreamDecoder,
    /// Requests sent so far.
    requests: u32,
}

impl HostLink {
    /// Reads for `window` and returns the frames decoded in that time.
    fn collect_for(&mut self, window: Duration) -> Vec<Frame> {
        let deadline = Instant::now() + window;
        let mut frames = Vec::new();
        let mut buffer = [0u8; 512];
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return frames;
            }
            self.stream
                .set_read_timeout(Some(left.max(Duration::from_millis(1))))
                .expect("set read timeout");
            match self.stream.read(&mut buffer) {
                Ok(0) => return frames,
                Ok(n) => frames.extend(self.decoder.frames(&buffer[..n])),
                Err(e)
                    if e.kind() == std::io::ErrorKind::WouldBlock
                        || e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => panic!("reading USART3: {e}"),
            }
        }
    }

    /// Sends requests until an info record arrives, at most `max`: the frames, and how many
    /// requests it took.
    fn request_record(&mut self, max: usize) -> (Vec<Frame>, usize) {
        let mut frames = Vec::new();
        for sent in 1..=max {
            frames.extend(self.request(1));
            if frames.iter().any(|frame| matches!(frame, Frame::Info(_))) {
                return (frames, sent);
            }
        }
        (frames, max)
    }

    /// Sends one request and reads until `expected` frames arrived (or the timeout).
    fn request(&mut self, expected: usize) -> Vec<Frame> {
        self.stream.write_all(b"R").expect("write request");
        self.requests += 1;
        let deadline = Instant::now() + ANSWER_TIMEOUT;
        let mut frames = Vec::new();
        while frames.len() < expected && Instant::now() < deadline {
            frames.extend(self.collect_for(Duration::from_millis(20)));
        }
        // Anything beyond the expected answer would be an unrequested frame.
        frames.extend(self.collect_for(Duration::from_millis(30)));
        frames
    }
}

/// Tallies checks and prints each one.
#[derive(Default)]
struct Checks {
    passed: u32,
    failed: u32,
}

impl Checks {
    fn check(&mut self, ok: bool, what: &str) {
        if ok {
            self.passed += 1;
            println!("ok      {what}");
        } else {
            self.failed += 1;
            println!("FAILED  {what}");
        }
    }
}

fn split(frames: &[Frame]) -> (Vec<RawPacket>, Vec<InfoFrame>) {
    let mut packets = Vec::new();
    let mut infos = Vec::new();
    for frame in frames {
        match frame {
            Frame::Packet(packet) => packets.push(*packet),
            Frame::Info(info) => infos.push(*info),
        }
    }
    (packets, infos)
}

/// The frame kinds in order, for messages: e.g. "packet, info".
fn kinds(frames: &[Frame]) -> String {
    let names: Vec<&str> = frames
        .iter()
        .map(|frame| match frame {
            Frame::Packet(_) => "packet",
            Frame::Info(_) => "info",
        })
        .collect();
    format!("[{}]", names.join(", "))
}

/// A checksum-valid UBX NAV-PVT frame (100 bytes) with recognisable contents.
fn nav_pvt_frame() -> [u8; GNSS_FRAME_LEN] {
    let fix = NavPvt {
        itow_ms: 345_600_000,
        year: 2026,
        month: 11,
        day: 22,
        hour: 8,
        valid: nav_pvt::VALID_DATE | nav_pvt::VALID_TIME | nav_pvt::VALID_FULLY_RESOLVED,
        fix_type: 3,
        flags: nav_pvt::FLAG_GNSS_FIX_OK,
        num_sv: 9,
        lon_deg_e7: 112_345_678,
        lat_deg_e7: 481_234_567,
        height_mm: 520_000,
        h_msl_mm: 470_000,
        ..NavPvt::default()
    };
    *fix.to_frame().as_bytes()
}

fn main() {
    let elf = std::env::args()
        .nth(1)
        .expect("usage: qemu-smoke PATH/TO/FIRMWARE.elf");
    let qemu_bin = std::env::var("QEMU").unwrap_or_else(|_| "qemu-system-arm".into());
    let Board {
        qemu,
        mut gnss,
        link,
        said,
        boots,
    } = Board::start(&qemu_bin, &elf);

    let mut smoke = Smoke {
        link,
        checks: Checks::default(),
        records: 0,
    };
    smoke.watchdog_runs_before_anything_can_hang(&said.steps);
    smoke.systick_below_the_request_interrupt(&said.priorities);
    smoke.sensor_bus_within_ten_megahertz(&said.spi1);
    smoke.silence_until_requested();
    let first_info = smoke.first_record();
    smoke.quick_requests_get_one_packet_each();
    smoke.nav_pvt_is_carried_verbatim(&mut gnss);
    smoke.record_again_after_a_pause(first_info);
    smoke.silent_receiver_is_reported();
    smoke.slow_tick_is_counted();
    smoke.decoder_saw_every_answer();
    smoke.panic_resets_at_once_and_is_reported(&said, &boots);

    drop(qemu);
    let checks = smoke.checks;
    println!("{} passed, {} failed", checks.passed, checks.failed);
    if checks.failed != 0 {
        std::process::exit(1);
    }
}

/// The firmware running under QEMU, ready: its two UARTs on local sockets and what it said
/// about its exception priorities.
struct Board {
    /// Kills QEMU when dropped.
    qemu: Qemu,
    /// The host side of USART1 (GNSS).
    gnss: TcpStream,
    /// The host side of USART3 (the link).
    link: HostLink,
    /// What the firmware said before `ready`.
    said: BootLines,
    /// What it says before each later `ready` (after a reset).
    boots: mpsc::Receiver<BootLines>,
}

/// The firmware's semihosting lines before `ready`, each without its prefix (empty if it
/// printed none).
#[derive(Default)]
struct BootLines {
    /// "priorities: systick 0x.., request 0x..".
    priorities: String,
    /// "spi1: cr1 0x...., pclk2 N Hz".
    spi1: String,
    /// The steps of `init` in the order they started ("boot: clocks" gives "clocks").
    steps: Vec<String>,
    /// "reset: fault X": the fault that reset the previous boot ("none", "Panic", ...).
    reset: String,
}

impl Board {
    /// Starts `elf` on QEMU (`qemu_bin`) with USART1 and USART3 on local TCP sockets and
    /// waits (20 s at most) for the firmware's "ready"; echoes the firmware's output.
    fn start(qemu_bin: &str, elf: &str) -> Self {
        // QEMU connects to these as a client: USART1 (GNSS) and USART3 (host link).
        let gnss_listener = TcpListener::bind("127.0.0.1:0").expect("bind GNSS socket");
        let link_listener = TcpListener::bind("127.0.0.1:0").expect("bind link socket");
        let gnss_port = gnss_listener.local_addr().expect("GNSS port").port();
        let link_port = link_listener.local_addr().expect("link port").port();

        let mut child = Command::new(qemu_bin)
            .args(["-M", "netduinoplus2", "-nographic", "-monitor", "none"])
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(["-serial", &format!("tcp:127.0.0.1:{gnss_port},nodelay=on")])
            .args(["-serial", "null"])
            .args(["-serial", &format!("tcp:127.0.0.1:{link_port},nodelay=on")])
            .args(["-kernel", elf])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("starting {qemu_bin}: {e}"));
        let stdout = child.stdout.take().expect("QEMU stdout");
        let qemu = Qemu(child);

        let (gnss, _) = gnss_listener.accept().expect("QEMU connects USART1");
        let (link_stream, _) = link_listener.accept().expect("QEMU connects USART3");
        link_stream.set_nodelay(true).expect("nodelay");

        let (said, boots) = wait_until_ready(stdout);
        Board {
            qemu,
            gnss,
            link: HostLink {
                stream: link_stream,
                decoder: StreamDecoder::new(),
                requests: 0,
            },
            said,
            boots,
        }
    }
}

/// Echoes the firmware's semihosting output (on a thread, for the whole run) and waits for
/// its "ready" line, printed once its receivers are enabled; returns the lines it printed
/// before it (see [`BootLines`]) and the channel that brings the lines of later boots.
fn wait_until_ready(stdout: ChildStdout) -> (BootLines, mpsc::Receiver<BootLines>) {
    let (ready_tx, ready_rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut said = BootLines::default();
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            println!("firmware: {line}");
            let line = line.trim();
            if let Some(rest) = line.strip_prefix("priorities: ") {
                said.priorities = rest.to_owned();
            }
            if let Some(rest) = line.strip_prefix("boot: ") {
                said.steps.push(rest.to_owned());
            }
            if let Some(rest) = line.strip_prefix("reset: ") {
                said.reset = rest.to_owned();
            }
            if let Some(rest) = line.strip_prefix("spi1: ") {
                said.spi1 = rest.to_owned();
            }
            if line == "ready" {
                let _ = ready_tx.send(std::mem::take(&mut said));
            }
        }
    });
    let started = Instant::now();
    let said = ready_rx
        .recv_timeout(Duration::from_secs(20))
        .expect("firmware did not print `ready` within 20 s");
    println!("firmware ready after {:?}", started.elapsed());
    (said, ready_rx)
}

/// SPI1_CR1 and the APB2 clock from the firmware's "spi1: cr1 0x...., pclk2 N Hz" line.
fn parse_spi1(line: &str) -> Option<(u32, u32)> {
    let rest = line.strip_prefix("cr1 0x")?;
    let (cr1, rest) = rest.split_once(", pclk2 ")?;
    let pclk2 = rest.strip_suffix(" Hz")?;
    Some((u32::from_str_radix(cr1, 16).ok()?, pclk2.parse().ok()?))
}

/// The checks, in the order they run, over one host link.
struct Smoke {
    link: HostLink,
    checks: Checks,
    /// Info records the checks have seen, for the decoder's count at the end.
    records: usize,
}

impl Smoke {
    /// The independent watchdog (clocked by the LSI, independent of the crystal) starts before
    /// the clock set-up, which waits for the crystal and the PLL without a time-out, and
    /// before the sensors: a crystal that never starts resets the board instead of hanging
    /// it for ever.
    fn watchdog_runs_before_anything_can_hang(&mut self, steps: &[String]) {
        let at = |step: &str| steps.iter().position(|s| s == step);
        let ok = match (at("watchdog"), at("clocks"), at("sensors")) {
            (Some(watchdog), Some(clocks), Some(sensors)) => {
                watchdog < clocks && watchdog < sensors
            }
            _ => false,
        };
        self.checks.check(
            ok,
            &format!("watchdog started before the clocks and the sensors (init steps {steps:?})"),
        );
    }

    /// SysTick below the request interrupt. RTIC maps its priority p to the hardware value
    /// (16 - p) << 4 on the STM32F4's 4 priority bits: request (3) 0xd0, SysTick (2) 0xe0;
    /// a larger value is a lower priority.
    fn systick_below_the_request_interrupt(&mut self, priorities: &str) {
        self.checks.check(
            priorities == "systick 0xe0, request 0xd0",
            &format!("SysTick below the request interrupt (got \"{priorities}\")"),
        );
    }

    /// The sensor bus clock as programmed: SPI1_CR1's baud-rate bits (RM0090 28.5.1: divider
    /// 2 << BR) from the APB2 clock the HAL computed them for give at most the BMX055's and
    /// BMP280's 10 MHz, and the fastest divider that does (half of it would be too fast).
    fn sensor_bus_within_ten_megahertz(&mut self, spi1: &str) {
        const SENSOR_SPI_MAX_HZ: u32 = 10_000_000;
        let verdict = parse_spi1(spi1).map(|(cr1, pclk2)| {
            let divider = 2u32 << ((cr1 >> 3) & 0b111);
            let spi_hz = pclk2 / divider;
            let fastest = divider == 2 || pclk2 / (divider / 2) > SENSOR_SPI_MAX_HZ;
            (spi_hz, spi_hz <= SENSOR_SPI_MAX_HZ && fastest)
        });
        self.checks.check(
            verdict.is_some_and(|(_, ok)| ok),
            &format!(
                "SPI1 clock at most 10 MHz, the fastest divider that is (got \"{spi1}\": {} Hz)",
                verdict.map_or(0, |(hz, _)| hz)
            ),
        );
    }

    /// Silence until requested.
    fn silence_until_requested(&mut self) {
        let unrequested = self.link.collect_for(Duration::from_millis(300));
        self.checks.check(
            unrequested.is_empty() && self.link.decoder.stats().bytes_skipped == 0,
            "nothing is sent before the first request",
        );
    }

    /// The first eleven requests: a packet and a piece each; the eleventh completes a record,
    /// which
    /// this returns.
    fn first_record(&mut self) -> Option<InfoFrame> {
        let (first, sent) = self.link.request_record(PIECES);
        let (packets, infos) = split(&first);
        self.checks.check(
            sent == PIECES && packets.len() == PIECES && infos.len() == 1,
            &format!(
                "first record after {PIECES} answers of packet + piece (got {} in {sent} requests, {} pieces)",
                kinds(&first),
                self.link.decoder.stats().info_pieces
            ),
        );
        self.records += infos.len();
        let first_info = infos.first().copied();
        if let Some(info) = first_info {
            self.first_record_contents(&info);
        }
        self.checks.check(
            packets.first().is_some_and(|p| p.as_bytes()[..2] == *b"$$"),
            "packet starts with $$ and passes the CRC",
        );
        first_info
    }

    /// What the first record says about a board under QEMU.
    fn first_record_contents(&mut self, info: &InfoFrame) {
        self.checks.check(
            info.version == 3,
            "info frame version 3 (with health and faults)",
        );
        // Not the sampling overruns: QEMU's timers follow the host's clock, and a busy host
        // can stall a tick past the next period (the slow-tick check below covers the count).
        self.checks.check(
            info.faults
                == BoardFaults {
                    sample_overruns: info.faults.sample_overruns,
                    ..BoardFaults::default()
                },
            &format!(
                "no GNSS UART error, no fault before this boot ({:?})",
                info.faults
            ),
        );
        // No sensor answers under QEMU: no read ever succeeded, none was attempted after boot.
        self.checks.check(
            info.health.accel_age_ms == u16::MAX
                && info.health.bmp280_age_ms == u16::MAX
                && info.health.accel_errors == 0,
            &format!(
                "absent sensors: never read, not retried ({:?})",
                info.health
            ),
        );
        self.checks.check(
            info.firmware == [0, 1, 0],
            &format!("firmware version 0.1.0 (got {:?})", info.firmware),
        );
        // QEMU models no CRC unit (it reads zero): the boot self-check must fail, report it,
        // and the software fallback must keep every packet valid (checked below).
        self.checks.check(
            info.status.contains(SensorStatus::CRC_UNIT_FAILED),
            &format!(
                "CRC unit self-check fails under QEMU and is reported (status {:#04x})",
                info.status.bits()
            ),
        );
        // No GNSS byte yet, but the receiver counts as silent only after 1 s of the board's
        // clock.
        if info.uptime_ms < 1_000 {
            self.checks.check(
                !info.status.contains(SensorStatus::GNSS_SILENT),
                &format!(
                    "GNSS not silent before 1 s of uptime (status {:#04x}, {} ms)",
                    info.status.bits(),
                    info.uptime_ms
                ),
            );
        }
        println!(
            "info: status {:#04x}, uptime {} ms, skipped {}",
            info.status.bits(),
            info.uptime_ms,
            info.requests_skipped
        );
    }

    /// Requests 10 ms apart: one packet each (and a record when a snapshot completes).
    fn quick_requests_get_one_packet_each(&mut self) {
        let mut plain = 0;
        let mut extra = 0;
        for _ in 0..20 {
            std::thread::sleep(Duration::from_millis(10));
            let frames = self.link.request(1);
            let (p, i) = split(&frames);
            self.records += i.len();
            if p.len() == 1 && i.len() <= 1 {
                plain += 1;
            } else {
                extra += 1;
            }
        }
        self.checks.check(
            plain == 20 && extra == 0,
            &format!("20 quick requests -> 20 single packets (got {plain}, {extra} odd answers)"),
        );
    }

    /// GNSS: a NAV-PVT frame on USART1 (after three bytes of noise) must appear in the packets
    /// that follow.
    fn nav_pvt_is_carried_verbatim(&mut self, gnss: &mut TcpStream) {
        let nav = nav_pvt_frame();
        gnss.write_all(&[0x00, 0xFF, 0xB5])
            .expect("write GNSS noise");
        gnss.write_all(&nav).expect("write NAV-PVT");
        // The next sampling tick takes it over; allow a slow board clock (up to 10 tries).
        let mut carried = false;
        for _ in 0..10 {
            std::thread::sleep(Duration::from_millis(50));
            let frames = self.link.request(1);
            let (p, i) = split(&frames);
            self.records += i.len();
            carried = p
                .first()
                .is_some_and(|packet| packet.as_bytes()[28..128] == nav);
            if carried {
                break;
            }
        }
        self.checks.check(
            carried,
            "NAV-PVT written to USART1 is carried verbatim in bytes 28..128",
        );
    }

    /// A pause (500 ms or more on the board's clock): a record again within eleven answers, the
    /// snapshot started from piece 0, with a larger uptime, the GNSS bit and the GNSS noise
    /// counted.
    fn record_again_after_a_pause(&mut self, first_info: Option<InfoFrame>) {
        let (after_pause, pause) = self.record_after_a_pause(first_info);
        let (_, infos) = split(&after_pause);
        self.checks.check(
            infos.len() == 1,
            &format!(
                "after a {pause:?} pause a record within {PIECES} answers (got {})",
                kinds(&after_pause)
            ),
        );
        if let (Some(first), Some(second)) = (first_info, infos.first()) {
            self.checks.check(
                second.uptime_ms > first.uptime_ms + 500,
                &format!(
                    "uptime grows ({} ms -> {} ms)",
                    first.uptime_ms, second.uptime_ms
                ),
            );
            self.checks.check(
                second
                    .status
                    .contains(dima_sensorboard::SensorStatus::GNSS_SEEN),
                &format!(
                    "info frame reports GNSS frames seen (status {:#04x})",
                    second.status.bits()
                ),
            );
            // The noise written before the NAV-PVT frame is dropped by the UBX reader and
            // counted.
            self.checks.check(
                second.health.gnss_bytes_dropped > 0,
                &format!(
                    "GNSS noise counted in the health ({} bytes dropped)",
                    second.health.gnss_bytes_dropped
                ),
            );
        }
    }

    /// The pause itself. QEMU's SysTick drops periods when the host is busy, so the
    /// board's clock can run far slower than the host's: the pause doubles until the record
    /// shows an uptime 500 ms past the first one (at most three tries). Every request must be
    /// answered. Returns the last answers and the last pause.
    fn record_after_a_pause(&mut self, first_info: Option<InfoFrame>) -> (Vec<Frame>, Duration) {
        let mut pause = PAUSE;
        let mut after_pause = Vec::new();
        for _ in 0..3 {
            std::thread::sleep(pause);
            let (frames, _) = self.link.request_record(PIECES);
            after_pause = frames;
            let (_, infos) = split(&after_pause);
            self.records += infos.len();
            if infos
                .first()
                .zip(first_info)
                .is_some_and(|(second, first)| second.uptime_ms > first.uptime_ms + 500)
            {
                break;
            }
            println!("no later record after a {pause:?} pause: the board's clock runs slow");
            pause *= 2;
        }
        (after_pause, pause)
    }

    /// No GNSS byte since the NAV-PVT frame: once the board's clock has seen 1 s more, the
    /// info frame has status bit 7 (GNSS silent). The board's clock may run slow under a busy
    /// host: the wait doubles, at most three tries, each one answered with an info frame.
    fn silent_receiver_is_reported(&mut self) {
        let mut wait = Duration::from_millis(1_500);
        let mut silent = None;
        for _ in 0..3 {
            std::thread::sleep(wait);
            let (frames, _) = self.link.request_record(PIECES);
            let (_, infos) = split(&frames);
            self.records += infos.len();
            if let Some(info) = infos.first() {
                if info.status.contains(SensorStatus::GNSS_SILENT) {
                    silent = Some(*info);
                    break;
                }
                println!(
                    "no GNSS-silent bit after {wait:?} (status {:#04x}, uptime {} ms): the board's \
                     clock runs slow",
                    info.status.bits(),
                    info.uptime_ms
                );
            }
            wait *= 2;
        }
        self.checks.check(
            silent.is_some_and(|info| info.status.contains(SensorStatus::GNSS_SEEN)),
            &format!(
                "a receiver silent for 1 s is reported in status bit 7, GNSS_SEEN kept (status {:#04x})",
                silent.map_or(0, |info| info.status.bits())
            ),
        );
    }

    /// A panic in the sampling task: the board reboots within a few seconds of host time (QEMU
    /// has no watchdog, so a board that halts on a panic never comes back), its boot message
    /// names the panic, and what answers afterwards is the new boot: its info record no longer
    /// has the GNSS-seen bit the old boot had set. (A core halted with its interrupts on keeps
    /// answering with the last packet and the old snapshot's pieces.)
    fn panic_resets_at_once_and_is_reported(
        &mut self,
        first: &BootLines,
        boots: &mpsc::Receiver<BootLines>,
    ) {
        self.checks.check(
            first.reset == "fault none",
            &format!("first boot reports no fault (got \"{}\")", first.reset),
        );
        let gnss_seen = |frames: &[Frame]| {
            split(frames)
                .1
                .first()
                .map(|info| info.status.contains(SensorStatus::GNSS_SEEN))
        };
        let before = gnss_seen(&self.link.request_record(PIECES + 1).0);
        self.link.stream.write_all(b"!").expect("write panic byte");
        let rebooted = boots.recv_timeout(Duration::from_secs(10)).ok();
        self.checks.check(
            rebooted
                .as_ref()
                .is_some_and(|said| said.reset == "fault Panic"),
            &format!(
                "a panic resets the board at once and the next boot reports it (got {:?})",
                rebooted.as_ref().map(|said| said.reset.as_str())
            ),
        );
        // QEMU's TIM2 can take a while to tick again after a reset: requests until a record.
        let (frames, _) = self.link.request_record(3 * PIECES);
        let after = gnss_seen(&frames);
        self.checks.check(
            before == Some(true) && after == Some(false),
            &format!(
                "after the panic the answers come from the new boot (GNSS seen before {before:?}, after {after:?})"
            ),
        );
        let reset_fault = split(&frames).1.first().map(|info| info.faults.reset_fault);
        self.checks.check(
            reset_fault == Some(4),
            &format!(
                "the new boot's info frame reports the panic (reset fault {reset_fault:?}, want 4)"
            ),
        );
    }

    /// A sampling tick that overruns its period (it runs until the next one has begun, asked
    /// for with `~`) is counted: `sample_overruns` in a later record is above the one before.
    fn slow_tick_is_counted(&mut self) {
        let overruns = |link: &mut HostLink, records: &mut usize| {
            let (frames, _) = link.request_record(PIECES);
            let (_, infos) = split(&frames);
            *records += infos.len();
            infos.first().map(|info| info.faults.sample_overruns)
        };
        let before = overruns(&mut self.link, &mut self.records);
        // Not a request: nothing comes back.
        self.link
            .stream
            .write_all(b"~")
            .expect("write slow-tick byte");
        // The next snapshot, 250 ms of the board's clock later, has the count.
        let mut after = None;
        for _ in 0..5 {
            std::thread::sleep(Duration::from_millis(400));
            after = overruns(&mut self.link, &mut self.records);
            if after > before {
                break;
            }
        }
        self.checks.check(
            matches!((before, after), (Some(b), Some(a)) if a > b),
            &format!(
                "a sampling tick that runs into the next period is counted in sample_overruns ({before:?} -> {after:?})"
            ),
        );
    }

    /// The decoder's totals: no CRC error, no byte outside a frame, one packet per request
    /// and every record the checks saw.
    fn decoder_saw_every_answer(&mut self) {
        let stats = self.link.decoder.stats();
        println!(
            "decoder: {} packets, {} info records from {} pieces ({} records dropped), {} CRC \
             errors, {} bytes skipped",
            stats.packets,
            stats.info_frames,
            stats.info_pieces,
            stats.info_records_dropped,
            stats.crc_errors,
            stats.bytes_skipped
        );
        self.checks.check(
            stats.crc_errors == 0 && stats.bytes_skipped == 0,
            "no CRC error, no byte outside a frame",
        );
        let (requests, records) = (self.link.requests, self.records);
        self.checks.check(
            stats.packets == u64::from(requests)
                && stats.info_frames == records as u64
                && stats.info_pieces <= u64::from(requests),
            &format!(
                "{} packets, {} records (seen {records}) and {} pieces for {} requests",
                stats.packets, stats.info_frames, stats.info_pieces, requests
            ),
        );
    }
}
