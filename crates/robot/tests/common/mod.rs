//! Test stand-ins for the devices at the far end of real pseudo-terminals: a sensor board that
//! answers request edges with v1 packets, a Maestro that decodes what it receives, and a ground
//! station. The application side opens the pty slaves with its production serial code.
#![allow(dead_code)]

pub mod counting_alloc;

use std::os::fd::{AsFd, OwnedFd};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU16, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{JoinHandle, Thread};
use std::time::{Duration, Instant};

use dima_core::monitor::{OverrunRule, OverrunWindow};
use dima_core::Mode;
use dima_groundlink::{Command, DisplayDecoder, DisplayFrame};
use dima_robot::app::Observer;
use dima_robot::config::Config;
use dima_robot::devices::sensor::SensorDevice;
use dima_robot::devices::serial::{LineSettings, SerialPort};
use dima_robot::devices::servo::MaestroPort;
use dima_sensorboard::{GnssFrame, NavPvt, SensorPacket};
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::termios::{self, SetArg};

/// A pseudo-terminal: the master for the test, the slave path for the application.
pub struct Pty {
    pub master: OwnedFd,
    pub path: PathBuf,
    _slave: OwnedFd,
}

pub fn pty() -> Pty {
    let p = nix::pty::openpty(None, None).unwrap();
    let mut t = termios::tcgetattr(&p.master).unwrap();
    termios::cfmakeraw(&mut t);
    termios::tcsetattr(&p.master, SetArg::TCSANOW, &t).unwrap();
    let path = nix::unistd::ttyname(&p.slave).unwrap();
    Pty {
        master: p.master,
        path,
        _slave: p.slave,
    }
}

pub fn write_all(fd: &OwnedFd, mut bytes: &[u8]) {
    while !bytes.is_empty() {
        match nix::unistd::write(fd, bytes) {
            Ok(n) => bytes = &bytes[n..],
            Err(nix::errno::Errno::EAGAIN) => std::thread::sleep(Duration::from_micros(100)),
            Err(_) => return,
        }
    }
}

/// Reads what is there within `timeout` (empty on timeout or error).
pub fn read_some(fd: &OwnedFd, buf: &mut [u8], timeout_ms: u16) -> usize {
    let mut fds = [PollFd::new(fd.as_fd(), PollFlags::POLLIN)];
    match poll(&mut fds, PollTimeout::from(timeout_ms)) {
        Ok(n) if n > 0 => match nix::unistd::read(fd, buf) {
            Ok(n) if n > 0 => n,
            // Hung up (nothing holds the slave side open) or an error: poll reports it at once,
            // every time. Wait as long as a quiet line would, so that a caller's loop (at
            // SCHED_FIFO in the fake devices) does not spin and starve the threads under test.
            _ => {
                std::thread::sleep(Duration::from_millis(timeout_ms.into()));
                0
            }
        },
        _ => 0,
    }
}

/// The request line: counts rising edges and wakes the board thread. Allocation-free.
pub struct RequestPin {
    edges: Arc<AtomicU64>,
    board: Thread,
    high: bool,
}

impl embedded_hal::digital::ErrorType for RequestPin {
    type Error = core::convert::Infallible;
}

impl embedded_hal::digital::OutputPin for RequestPin {
    fn set_high(&mut self) -> Result<(), Self::Error> {
        if !self.high {
            self.edges.fetch_add(1, Ordering::Release);
            self.board.unpark();
        }
        self.high = true;
        Ok(())
    }
    fn set_low(&mut self) -> Result<(), Self::Error> {
        self.high = false;
        Ok(())
    }
}

/// Sensor values the fake board reports: accel X counts up with each answer.
pub fn nav_pvt(itow_ms: u32) -> NavPvt {
    NavPvt {
        itow_ms,
        year: 2026,
        month: 11,
        day: 22,
        hour: 8,
        min: 0,
        sec: 0,
        valid: 0,
        t_acc_ns: 50,
        nano_ns: 0,
        fix_type: 3,
        flags: 0x01,
        flags2: 0,
        num_sv: 9,
        lon_deg_e7: 184_750_000,
        lat_deg_e7: -340_885_000,
        height_mm: 40_000,
        h_msl_mm: 10_000,
        h_acc_mm: 1_500,
        v_acc_mm: 2_500,
        vel_n_mm_s: 1_000,
        vel_e_mm_s: -200,
        vel_d_mm_s: 5,
        g_speed_mm_s: 1_020,
        head_mot_deg_e5: 34_870_000,
        s_acc_mm_s: 100,
        head_acc_deg_e5: 100_000,
        p_dop_e2: 150,
        reserved1: [0; 6],
        head_veh_deg_e5: 0,
        mag_dec_deg_e2: 0,
        mag_acc_deg_e2: 0,
    }
}

/// Packet `n` of a live board: the accelerometer's and the gyroscope's words both change from
/// packet to packet (a die whose words stay the same is a stuck IMU).
pub fn packet(n: u64) -> SensorPacket {
    SensorPacket {
        accel: [(n % 1000) as i16, -512, 1000],
        gyro: [(n % 5) as i16 - 2, -2, -164],
        mag: [-300, 200, -1000],
        rhall: 7000,
        press_raw: 415_148,
        temp_raw: 519_888,
        gnss: GnssFrame::from_nav_pvt(&nav_pvt((n / 25 * 100) as u32)),
    }
}

/// A sensor board on the master side of a pty: one packet per rising edge.
pub struct FakeBoard {
    pub edges: Arc<AtomicU64>,
    pub answered: Arc<AtomicU64>,
    pub silent: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl FakeBoard {
    /// A board on a 460 800 baud 8N2 link.
    pub fn spawn(master: OwnedFd) -> FakeBoard {
        FakeBoard::spawn_with_wire_time(master, PACKET_WIRE_TIME)
    }

    /// A board whose packets take `wire_time` on the link.
    pub fn spawn_with_wire_time(master: OwnedFd, wire_time: Duration) -> FakeBoard {
        let edges = Arc::new(AtomicU64::new(0));
        let answered = Arc::new(AtomicU64::new(0));
        let silent = Arc::new(AtomicBool::new(false));
        let stop = Arc::new(AtomicBool::new(false));
        let (e, a, s, st) = (
            edges.clone(),
            answered.clone(),
            silent.clone(),
            stop.clone(),
        );
        let handle = std::thread::spawn(move || {
            try_fifo(40);
            let mut seen = 0;
            let mut junk = [0u8; 64];
            while !st.load(Ordering::Relaxed) {
                std::thread::park_timeout(Duration::from_millis(2));
                // Drop anything the host sends (nothing, on this link).
                let _ = read_some(&master, &mut junk, 0);
                let now = e.load(Ordering::Acquire);
                if now != seen {
                    seen = now;
                    if !s.load(Ordering::Relaxed) {
                        // The packet's last byte cannot arrive sooner than its wire time after
                        // the request.
                        std::thread::sleep(wire_time);
                        write_all(&master, &packet(now).encode());
                        a.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }
        });
        FakeBoard {
            edges,
            answered,
            silent,
            stop,
            handle: Some(handle),
        }
    }

    pub fn pin(&self) -> RequestPin {
        RequestPin {
            edges: self.edges.clone(),
            board: self.handle.as_ref().unwrap().thread().clone(),
            high: false,
        }
    }

    /// Stops the board and closes its end of the pty (the cable is pulled).
    pub fn unplug(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            h.thread().unpark();
            h.join().unwrap();
        }
    }
}

impl Drop for FakeBoard {
    fn drop(&mut self) {
        self.unplug();
    }
}

/// A Maestro on the master side of a pty: decodes Set Target commands with the Maestro crate.
pub struct FakeMaestro {
    pub targets: Arc<[AtomicU16; 24]>,
    pub commands: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl FakeMaestro {
    pub fn spawn(master: OwnedFd) -> FakeMaestro {
        let targets: Arc<[AtomicU16; 24]> =
            Arc::new(std::array::from_fn(|_| AtomicU16::new(0xFFFF)));
        let commands = Arc::new(AtomicU64::new(0));
        let stop = Arc::new(AtomicBool::new(false));
        let (t, c, s) = (targets.clone(), commands.clone(), stop.clone());
        let handle = std::thread::spawn(move || {
            try_fifo(40);
            let mut decoder =
                pololu_maestro::CommandDecoder::new(pololu_maestro::DecoderConfig::default());
            let mut buf = [0u8; 256];
            while !s.load(Ordering::Relaxed) {
                let n = read_some(&master, &mut buf, 5);
                for b in &buf[..n] {
                    if let Some(pololu_maestro::Command::SetTarget { channel, target }) =
                        decoder.push(*b)
                    {
                        t[usize::from(channel.index())].store(target.get(), Ordering::Relaxed);
                        c.fetch_add(1, Ordering::Relaxed);
                    }
                }
            }
        });
        FakeMaestro {
            targets,
            commands,
            stop,
            handle: Some(handle),
        }
    }

    /// Quarter-microsecond targets of channels 0, 1, 2.
    pub fn first3(&self) -> [u16; 3] {
        [0, 1, 2].map(|i| self.targets[i].load(Ordering::Relaxed))
    }

    /// Waits until channels 0..3 show `want` (quarter-µs); returns the time it took.
    pub fn wait_for(&self, want: [u16; 3], timeout: Duration) -> Option<Duration> {
        let t0 = Instant::now();
        while t0.elapsed() < timeout {
            if self.first3() == want {
                return Some(t0.elapsed());
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        None
    }
}

impl Drop for FakeMaestro {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            h.join().unwrap();
        }
    }
}

/// A ground station on the master side of the XBee pty: heartbeats while enabled, commands on
/// demand, display frames decoded and kept.
pub struct FakeGround {
    pub heartbeats: Arc<AtomicBool>,
    pub displays: Arc<Mutex<Vec<DisplayFrame>>>,
    master: Arc<OwnedFd>,
    last_sent: Arc<Mutex<Instant>>,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<()>>,
}

impl FakeGround {
    pub fn spawn(master: OwnedFd) -> FakeGround {
        let master = Arc::new(master);
        let heartbeats = Arc::new(AtomicBool::new(true));
        let displays = Arc::new(Mutex::new(Vec::new()));
        let last_sent = Arc::new(Mutex::new(Instant::now()));
        let stop = Arc::new(AtomicBool::new(false));
        let (m, hb, d, ls, s) = (
            master.clone(),
            heartbeats.clone(),
            displays.clone(),
            last_sent.clone(),
            stop.clone(),
        );
        let handle = std::thread::spawn(move || {
            try_fifo(40);
            let mut decoder = DisplayDecoder::new();
            let mut buf = [0u8; 256];
            let mut next_hb = Instant::now();
            while !s.load(Ordering::Relaxed) {
                if hb.load(Ordering::Relaxed) && Instant::now() >= next_hb {
                    write_all(&m, &Command::Heartbeat.encode());
                    *ls.lock().unwrap() = Instant::now();
                    next_hb += Duration::from_millis(100);
                }
                let n = read_some(&m, &mut buf, 10);
                for f in decoder.feed(&buf[..n]).flatten() {
                    d.lock().unwrap().push(f);
                }
            }
        });
        FakeGround {
            heartbeats,
            displays,
            master,
            last_sent,
            stop,
            handle: Some(handle),
        }
    }

    pub fn send(&self, command: Command) {
        write_all(&self.master, &command.encode());
        *self.last_sent.lock().unwrap() = Instant::now();
    }

    pub fn last_sent(&self) -> Instant {
        *self.last_sent.lock().unwrap()
    }
}

impl Drop for FakeGround {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(h) = self.handle.take() {
            h.join().unwrap();
        }
    }
}

/// Gives the calling test thread SCHED_FIFO `priority` when allowed (as root), so a busy
/// machine does not starve the simulated devices; otherwise it stays SCHED_OTHER.
/// 132 bytes at 460 800 baud 8N2.
pub const PACKET_WIRE_TIME: Duration = Duration::from_micros(3_152);

pub fn try_fifo(priority: u8) {
    let _ = dima_robot::rt::setup::set_fifo(priority);
}

/// A configuration for a test run with a log in `log_dir`: SCHED_FIFO when permitted (it is
/// refused and reported otherwise), no pinning, no memory locking, and the default safety
/// thresholds.
pub fn test_config(log_dir: &std::path::Path) -> Config {
    let mut c = Config::default();
    c.realtime.priority = 60;
    c.realtime.telemetry_priority = 30;
    c.realtime.cpus = vec![];
    c.realtime.lock_memory = false;
    c.realtime.cpu_dma_latency = false;
    c.realtime.required = false;
    c.realtime.prefault_stack_kib = 64;
    c.sensor.reopen_interval_ms = 100;
    c.maestro.reopen_interval_ms = 100;
    c.xbee.reopen_interval_ms = 100;
    c.xbee.display_rate_hz = 10.0;
    // The test ground station speaks ground link v1.
    c.xbee.require_auth = false;
    c.log.directory = log_dir.to_owned();
    c.log.flush_interval_ms = 200;
    c
}

pub fn open_port(path: &std::path::Path, baud: u32, stop_bits: u8) -> anyhow::Result<SerialPort> {
    Ok(SerialPort::open(path, LineSettings { baud, stop_bits })?)
}

pub fn sensor_device(
    path: &std::path::Path,
    pin: RequestPin,
) -> anyhow::Result<SensorDevice<RequestPin>> {
    Ok(SensorDevice::new(open_port(path, 460_800, 2)?, pin)?)
}

pub fn maestro_port(path: &std::path::Path) -> anyhow::Result<MaestroPort> {
    Ok(MaestroPort::new(open_port(path, 115_200, 1)?))
}

pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("dima-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// What the loop reported, cycle by cycle, through `RunOptions::observer`: the mode after the
/// latest cycle, and whether the host held the loop up past the configuration's overrun rule
/// (the late wake-ups and missed periods the cycle records give, fed through that rule).
#[derive(Clone)]
pub struct LoopWatch {
    mode: Arc<Mutex<Option<Mode>>>,
    overload_ns: Arc<Mutex<Option<u64>>>,
}

impl LoopWatch {
    /// A watch for a run of `config`, and the observer that feeds it.
    pub fn new(config: &Config) -> (LoopWatch, Observer) {
        let watch = LoopWatch {
            mode: Arc::new(Mutex::new(None)),
            overload_ns: Arc::new(Mutex::new(None)),
        };
        let rule = OverrunRule {
            limit: config.safety.overrun_limit,
            max_stall_ns: u64::from(config.safety.max_stall_ms) * 1_000_000,
            period_ns: config.period_ns(),
        };
        let mut window = OverrunWindow::default();
        let (mode, overload) = (watch.mode.clone(), watch.overload_ns.clone());
        let observer: Observer = Box::new(move |record| {
            *mode.lock().unwrap() = Some(record.outputs.mode);
            let t = record.tick.wake_ns;
            if window.record(record.tick.missed, t, &rule) {
                overload.lock().unwrap().get_or_insert(t);
            }
        });
        (watch, observer)
    }

    /// The mode after the latest cycle reported.
    pub fn mode(&self) -> Option<Mode> {
        *self.mode.lock().unwrap()
    }

    /// The wake time (ns) of the first cycle at which the recorded late wake-ups exceeded the
    /// overrun rule; `None` while they never have.
    pub fn overload_at(&self) -> Option<u64> {
        *self.overload_ns.lock().unwrap()
    }

    /// Waits up to `timeout` until the loop reports a mode that drives (MANUAL or AUTO).
    pub fn wait_for_driving(&self, timeout: Duration) -> bool {
        let t0 = Instant::now();
        while t0.elapsed() < timeout {
            if self.mode().is_some_and(|m| !m.is_safe()) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        false
    }
}

/// How long to wait for a driving mode after a revive before sending it again.
pub const REVIVE_AGAIN_AFTER: Duration = Duration::from_millis(500);

/// Revives the robot and sends `then`, again every [`REVIVE_AGAIN_AFTER`] until the loop
/// reports MANUAL (or AUTO, which setpoints in `then` switch to), for at most `timeout`: a
/// revive right after start-up may be refused on a busy host (too few good packets yet, or an
/// overrun after a start-up stall). A revive in MANUAL or AUTO changes nothing. Returns
/// whether the robot reached a driving mode.
pub fn revive_until_driving(
    ground: &FakeGround,
    watch: &LoopWatch,
    then: &[Command],
    timeout: Duration,
) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < timeout {
        ground.send(Command::Revive);
        for c in then {
            ground.send(*c);
        }
        if watch.wait_for_driving(REVIVE_AGAIN_AFTER) {
            return true;
        }
    }
    false
}
