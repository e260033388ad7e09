//! Wiring: rings, device supervisors, the realtime, telemetry and logger threads, shutdown.
//!
//! [`run`] is device-agnostic: it takes one opener per device. `dima run` passes the hardware
//! openers ([`hardware_devices`]); a simulation passes openers for pseudo-terminals and its own
//! request line, and everything else (threads, loop, drivers, decoders, logger) is the same.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::Context;
use embedded_hal::digital::OutputPin;
use linux_embedded_hal::CdevPin;

use super::record::CycleRecord;
use super::rt_loop::{BusyFault, LoopEnds, LoopParams, RealtimeLoop};
use crate::config::{Config, RealtimeConfig, ServoKind};
use crate::devices::sensor::{open_hardware_sensor, SensorDevice};
use crate::devices::serial::{LineSettings, SerialPort};
use crate::devices::servo::{ServoBoard, ServoOutput};
use crate::devices::{device_link, spawn_supervisors, DeviceLink, Opener};
use crate::live::LiveView;
use crate::logging::{spawn_logger, LogFaults, LoggerOutcome, LoggerSettings, McapLog};
use crate::metrics::LoopMetrics;
use crate::rt::{monotonic_ns, PeriodicClock, RtSettings, RtSetup, RtSetupReport};
use crate::telemetry::{
    spawn_telemetry, LinkCounters, LinkSecurity, TelemetrySettings, TelemetryStats,
};
use dima_core::mission::Navigation;
use dima_log::schema::{self, SummaryRecord};

/// One opener per device.
pub struct Devices<P, S> {
    /// Sensor board: serial port and request line.
    pub sensor: Opener<SensorDevice<P>>,
    /// Servo controller.
    pub servo: Opener<S>,
    /// Ground link (XBee in transparent mode).
    pub ground: Opener<SerialPort>,
}

/// The real hardware, as configured.
pub fn hardware_devices(config: &Config) -> Devices<CdevPin, ServoBoard> {
    let sensor = config.sensor.clone();
    let servo = config.clone();
    let xbee = config.xbee.clone();
    Devices {
        sensor: Box::new(move || open_hardware_sensor(&sensor)),
        servo: Box::new(move || ServoBoard::open(&servo)),
        ground: Box::new(move || {
            SerialPort::open(
                &xbee.port,
                LineSettings {
                    baud: xbee.baud,
                    stop_bits: 1,
                },
            )
            .with_context(|| {
                format!(
                    "XBee: cannot open {} at {} baud (plugged in, and in the dialout group?)",
                    xbee.port.display(),
                    xbee.baud
                )
            })
        }),
    }
}

/// Called on the logger thread with every cycle record, in order (never on the realtime
/// thread): for a live status display.
pub type Observer = Box<dyn FnMut(&CycleRecord) + Send>;

/// How a run ends, and who watches it.
#[derive(Default)]
pub struct RunOptions {
    /// Stop after this long (None: at SIGINT/SIGTERM or when `stop` is set).
    pub duration: Option<Duration>,
    /// Sees every cycle record (e.g. a simulation's status line).
    pub observer: Option<Observer>,
    /// Extra work inside the realtime cycle (a simulation's `loop:busy` fault).
    pub busy: Option<BusyFault>,
    /// A stalled or full log disk (a simulation's `log:stall` and `log:full` faults).
    pub log_faults: LogFaults,
}

/// What a run did.
pub struct RunSummary {
    /// The safe targets were written at the end (false: the Maestro was missing or the write
    /// failed, and the outputs are whatever the Maestro last had).
    pub outputs_safe: bool,
    /// Why the required realtime setup failed, if it did (the run stayed KILLED).
    pub realtime_fault: Option<String>,
    /// Loop metrics.
    pub metrics: LoopMetrics,
    /// Telemetry counters.
    pub telemetry: TelemetryStats,
    /// The RT setup report.
    pub rt_report: Option<RtSetupReport>,
    /// The MCAP file written, if any.
    pub log_path: Option<PathBuf>,
    /// Records the logger wrote.
    pub records_logged: u64,
}

/// Sets `stop` on SIGINT and SIGTERM.
pub fn install_signal_handlers(stop: &Arc<AtomicBool>) -> anyhow::Result<()> {
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(stop))
            .context("installing the SIGINT/SIGTERM handlers")?;
    }
    Ok(())
}

/// Sets `stop` and waits for the realtime thread when dropped, also while unwinding from a
/// panic on the calling thread: the loop then writes the safe targets before the process
/// goes on to exit.
struct StopRealtimeOnDrop {
    stop: Arc<AtomicBool>,
    realtime: Option<std::thread::JoinHandle<(LoopMetrics, bool)>>,
}

impl Drop for StopRealtimeOnDrop {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(handle) = self.realtime.take() {
            let _ = handle.join();
        }
    }
}

/// Runs the whole application until `stop` is set or the duration passes; outputs go safe,
/// the log is flushed and closed, and the summary is returned. A panic of any thread stops
/// the loop, which writes the safe targets first (the realtime thread's own panic too, as it
/// unwinds), and the run returns an error.
pub fn run<P, S>(
    config: &Config,
    devices: Devices<P, S>,
    options: RunOptions,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<RunSummary>
where
    P: OutputPin + Send + 'static,
    S: ServoOutput + Send + 'static,
{
    config.validate()?;
    let security = LinkSecurity::from_config(&config.xbee)?;
    let mut params = LoopParams::from_config(config)?;
    let navigation = super::mission::load_navigation(config)?;
    params.core.set_navigation(&navigation);
    params.busy = options.busy;
    prepare_allocator(&config.realtime);
    let rt = &config.realtime;
    let (commands_tx, commands_rx) = rtrb::RingBuffer::new(rt.command_ring);
    let (log_tx, log_rx) = rtrb::RingBuffer::new(rt.log_ring_records);
    let (snapshot_in, snapshot_out) = triple_buffer::triple_buffer(&Default::default());
    let aux_stop = Arc::new(AtomicBool::new(false));
    let (sensor_link, servo_link, supervisors) =
        start_supervisors(config, devices.sensor, devices.servo, &aux_stop)?;
    let (report_tx, report_rx) = mpsc::channel();
    let logger_stop = Arc::new(AtomicBool::new(false));
    let logger = start_logger(
        config,
        &navigation,
        log_rx,
        report_rx,
        &logger_stop,
        options.log_faults,
        options.observer,
    )?;
    let link_counters = Arc::new(LinkCounters::default());
    let telemetry = spawn_telemetry(
        devices.ground,
        commands_tx,
        snapshot_out,
        telemetry_settings(config, security),
        Arc::clone(&link_counters),
        Arc::clone(&aux_stop),
    )?;
    let ends = LoopEnds {
        commands: commands_rx,
        log: log_tx,
        snapshot: snapshot_in,
        link: link_counters,
        stop: Arc::clone(&stop),
    };
    let (realtime, rt_report_rx) = start_realtime(config, params, ends, sensor_link, servo_link)?;
    let threads = RunThreads {
        realtime: StopRealtimeOnDrop {
            stop: Arc::clone(&stop),
            realtime: Some(realtime),
        },
        telemetry,
        supervisors,
        logger,
        aux_stop,
        logger_stop,
    };
    let (rt_report, realtime_fault) = report_realtime_setup(config, &rt_report_rx, &report_tx);
    let failed_thread = threads.watch(options.duration, &stop);
    let ended = threads.shut_down(failed_thread)?;
    let log_path = finish_log(ended.log.log, &ended.metrics, &ended.telemetry)?;
    Ok(RunSummary {
        outputs_safe: ended.outputs_safe,
        realtime_fault,
        metrics: ended.metrics,
        telemetry: ended.telemetry,
        rt_report,
        log_path,
        records_logged: ended.log.records,
    })
}

/// Prepares the allocator for the realtime thread: for locking all memory, or (without the
/// lock) to map large blocks so the loop's allocations before it starts stay put.
fn prepare_allocator(rt: &RealtimeConfig) {
    if rt.lock_memory {
        crate::rt::setup::prepare_allocator_for_locking();
    } else {
        crate::rt::setup::map_large_blocks();
    }
}

/// Starts the thread that opens and reopens the sensor board and the servo controller;
/// returns the loop's ends of their links and the thread.
#[allow(clippy::type_complexity)]
fn start_supervisors<P, S>(
    config: &Config,
    sensor: Opener<SensorDevice<P>>,
    servo: Opener<S>,
    stop: &Arc<AtomicBool>,
) -> anyhow::Result<(DeviceLink<SensorDevice<P>>, DeviceLink<S>, JoinHandle<()>)>
where
    P: OutputPin + Send + 'static,
    S: ServoOutput + Send + 'static,
{
    let (mut sensor_sup, sensor_link) = device_link(
        "sensor board",
        sensor,
        Duration::from_millis(u64::from(config.sensor.reopen_interval_ms)),
    );
    let (servo_name, servo_reopen_ms) = match config.servo.kind {
        ServoKind::Maestro => ("Maestro", config.maestro.reopen_interval_ms),
        ServoKind::Pca9685 => ("PCA9685", config.pca9685.reopen_interval_ms),
    };
    let (mut servo_sup, servo_link) = device_link(
        servo_name,
        servo,
        Duration::from_millis(u64::from(servo_reopen_ms)),
    );
    let supervisors = spawn_supervisors(
        vec![
            Box::new(move |now| sensor_sup.service(now)),
            Box::new(move |now| servo_sup.service(now)),
        ],
        Arc::clone(stop),
    )?;
    Ok((sensor_link, servo_link, supervisors))
}

/// Starts the live view (`[foxglove] listen`) when it is configured.
fn start_live_view(config: &Config) -> anyhow::Result<Option<Arc<LiveView>>> {
    let Some(addr) = config.foxglove.listen_addr()? else {
        return Ok(None);
    };
    let live = LiveView::start(addr)?;
    tracing::info!("live view: ws://{} (Foxglove WebSocket)", live.local_addr());
    Ok(Some(Arc::new(live)))
}

/// Opens the log (when enabled), writes its header and starts the logger thread, which ends
/// once `stop` is set.
fn start_logger(
    config: &Config,
    navigation: &Navigation,
    records: rtrb::Consumer<CycleRecord>,
    rt_reports: mpsc::Receiver<RtSetupReport>,
    stop: &Arc<AtomicBool>,
    faults: LogFaults,
    observer: Option<Observer>,
) -> anyhow::Result<JoinHandle<LoggerOutcome>> {
    let live = start_live_view(config)?;
    let mut log = if config.log.enabled {
        let log = McapLog::create(&config.log.directory)?;
        tracing::info!("logging to {}", log.path().display());
        Some(log)
    } else {
        None
    };
    let header = vec![
        (
            schema::METADATA_DIMA.to_owned(),
            vec![
                ("version", env!("CARGO_PKG_VERSION").to_owned()),
                ("config", toml::to_string(config)?),
            ],
        ),
        (
            schema::METADATA_NAVIGATION.to_owned(),
            vec![("json", serde_json::to_string(navigation)?)],
        ),
    ];
    if let Some(l) = log.as_mut() {
        for (name, pairs) in &header {
            l.metadata(name, pairs)?;
        }
    }
    Ok(spawn_logger(
        log,
        records,
        rt_reports,
        LoggerSettings {
            flush_interval: Duration::from_millis(u64::from(config.log.flush_interval_ms)),
            decoded_every: u64::from(config.log.decoded_every),
            header,
            max_file_duration: match config.log.max_file_duration_s {
                0 => None,
                s => Some(Duration::from_secs(u64::from(s))),
            },
            faults,
            live,
        },
        Arc::clone(stop),
        observer,
    )?)
}

/// The telemetry thread's settings from the configuration.
fn telemetry_settings(config: &Config, security: LinkSecurity) -> TelemetrySettings {
    TelemetrySettings {
        display_period: Duration::from_secs_f64(1.0 / config.xbee.display_rate_hz),
        reopen_interval: Duration::from_millis(u64::from(config.xbee.reopen_interval_ms)),
        priority: config.realtime.telemetry_priority,
        security,
        controllers: controller_codes(&config.control),
    }
}

/// The configured controller kinds, throttle, steering, tail, as display frames v3 carry them.
pub fn controller_codes(
    control: &dima_core::config::ControlConfig,
) -> [dima_groundlink::v2::ControllerCode; 3] {
    dima_core::control::Channel::ALL
        .map(|ch| dima_groundlink::v2::ControllerCode::from_name(&control.channel(ch).kind))
}

/// Starts the realtime thread; it reports its setup on the returned channel before the
/// loop's first cycle.
#[allow(clippy::type_complexity)]
fn start_realtime<P, S>(
    config: &Config,
    params: LoopParams,
    ends: LoopEnds,
    sensor: DeviceLink<SensorDevice<P>>,
    servo: DeviceLink<S>,
) -> anyhow::Result<(
    JoinHandle<(LoopMetrics, bool)>,
    mpsc::Receiver<RtSetupReport>,
)>
where
    P: OutputPin + Send + 'static,
    S: ServoOutput + Send + 'static,
{
    let settings = RtSettings::from(&config.realtime);
    let (report, report_rx) = mpsc::channel();
    let stack_size = settings.prefault_stack_kib.max(256) * 1024 + 256 * 1024;
    let worker = RealtimeWorker {
        settings,
        params,
        ends,
        sensor,
        servo,
        report,
    };
    let handle = std::thread::Builder::new()
        .name("dima-rt".into())
        .stack_size(stack_size)
        .spawn(move || worker.run())?;
    Ok((handle, report_rx))
}

/// The realtime thread: its setup, then the loop.
struct RealtimeWorker<P: OutputPin, S: ServoOutput> {
    settings: RtSettings,
    params: LoopParams,
    ends: LoopEnds,
    sensor: DeviceLink<SensorDevice<P>>,
    servo: DeviceLink<S>,
    /// Where the setup report goes.
    report: mpsc::Sender<RtSetupReport>,
}

impl<P: OutputPin, S: ServoOutput> RealtimeWorker<P, S> {
    /// Applies the realtime setup (a required one that failed keeps the loop KILLED), runs
    /// the loop until it stops, and returns its metrics and whether the outputs were left
    /// safe.
    fn run(self) -> (LoopMetrics, bool) {
        let setup = RtSetup::apply(&self.settings);
        let fault = self.settings.required && setup.report.failures().is_some();
        let _ = self.report.send(setup.report.clone());
        let period_ns = self.params.period_ns;
        let mut rt_loop = RealtimeLoop::new(self.params, self.ends, self.sensor, self.servo, fault);
        let mut clock = PeriodicClock::new(period_ns, monotonic_ns());
        rt_loop.run(&mut clock, None);
        drop(setup);
        (rt_loop.metrics().clone(), rt_loop.outputs_safe())
    }
}

/// Waits for the realtime thread's setup report, logs it (a required setup that failed as an
/// error, with what to do) and hands it to the logger; returns it and the failure, if any.
fn report_realtime_setup(
    config: &Config,
    reports: &mpsc::Receiver<RtSetupReport>,
    to_logger: &mpsc::Sender<RtSetupReport>,
) -> (Option<RtSetupReport>, Option<String>) {
    let rt_report = reports.recv().ok();
    let mut realtime_fault = None;
    if let Some(report) = &rt_report {
        tracing::info!("{report}");
        if let Some(failed) = report.failures().filter(|_| config.realtime.required) {
            tracing::error!(
                "realtime setup failed ({failed}): staying KILLED and refusing every revive \
                 (check realtime.cpus and realtime.priority against this machine, run as root \
                 or with CAP_SYS_NICE and CAP_IPC_LOCK, see docs/jetson.md; \
                 realtime.required = false drives without these guarantees)"
            );
            realtime_fault = Some(failed);
        }
        let _ = to_logger.send(report.clone());
    }
    (rt_report, realtime_fault)
}

/// The threads of a run, for watching and stopping them.
struct RunThreads {
    /// The realtime thread (stopped and joined if the run ends early).
    realtime: StopRealtimeOnDrop,
    telemetry: JoinHandle<TelemetryStats>,
    supervisors: JoinHandle<()>,
    logger: JoinHandle<LoggerOutcome>,
    /// Stops the telemetry and supervisor threads.
    aux_stop: Arc<AtomicBool>,
    /// Stops the logger.
    logger_stop: Arc<AtomicBool>,
}

/// What the threads returned at the end of a run.
struct ThreadResults {
    metrics: LoopMetrics,
    outputs_safe: bool,
    telemetry: TelemetryStats,
    log: LoggerOutcome,
}

impl RunThreads {
    /// Waits until the realtime loop ends, setting `stop` once `duration` has passed or
    /// another thread ended early (it panicked); returns that thread's name.
    fn watch(&self, duration: Option<Duration>, stop: &AtomicBool) -> Option<&'static str> {
        let started = Instant::now();
        let mut failed_thread = None;
        while self
            .realtime
            .realtime
            .as_ref()
            .is_some_and(|h| !h.is_finished())
        {
            if duration.is_some_and(|d| started.elapsed() >= d) {
                stop.store(true, Ordering::Relaxed);
            }
            // A thread that ends before the stop has panicked: stop the loop (safe outputs).
            if failed_thread.is_none() {
                if self.telemetry.is_finished() {
                    failed_thread = Some("telemetry");
                } else if self.logger.is_finished() {
                    failed_thread = Some("logger");
                }
                if failed_thread.is_some() {
                    stop.store(true, Ordering::Relaxed);
                }
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        failed_thread
    }

    /// Joins the realtime thread, then stops and joins the others (the logger last, so it
    /// writes every record); an error names a thread that panicked.
    fn shut_down(mut self, failed_thread: Option<&'static str>) -> anyhow::Result<ThreadResults> {
        let realtime = self.realtime.realtime.take().expect("joined only here");
        let rt_result = realtime.join();
        self.aux_stop.store(true, Ordering::Relaxed);
        let telemetry = self.telemetry.join();
        let _ = self.supervisors.join();
        self.logger_stop.store(true, Ordering::Release);
        let outcome = self.logger.join();
        let Ok((metrics, outputs_safe)) = rt_result else {
            anyhow::bail!(
                "the realtime thread panicked (the safe targets were written as it unwound)"
            );
        };
        let (Ok(telemetry), Ok(log)) = (telemetry, outcome) else {
            anyhow::bail!(
                "the {} thread panicked; the loop stopped with safe outputs{}",
                failed_thread.unwrap_or("telemetry or logger"),
                if outputs_safe {
                    ""
                } else {
                    " (not confirmed: the servo write failed)"
                }
            );
        };
        Ok(ThreadResults {
            metrics,
            outputs_safe,
            telemetry,
            log,
        })
    }
}

/// Writes the run's summary and latency histogram into the log and closes it (the histogram
/// also beside it as `<log>.latency.txt`); the log's path.
fn finish_log(
    log: Option<McapLog>,
    metrics: &LoopMetrics,
    telemetry: &TelemetryStats,
) -> anyhow::Result<Option<PathBuf>> {
    let Some(mut log) = log else {
        return Ok(None);
    };
    let histogram = metrics.wake_latency.cyclictest_format();
    log.metadata(
        schema::METADATA_SUMMARY,
        &[
            ("summary", metrics.summary()),
            ("ground_link", telemetry.summary()),
            (
                "json",
                serde_json::to_string(&SummaryRecord {
                    link: telemetry.link,
                    ..metrics.summary_record()
                })?,
            ),
        ],
    )?;
    log.attach(
        schema::ATTACHMENT_HISTOGRAM,
        "text/plain",
        histogram.as_bytes(),
    )?;
    let path = log.finish()?;
    let hist_path = path.with_extension("latency.txt");
    std::fs::write(&hist_path, &histogram)
        .with_context(|| format!("writing {}", hist_path.display()))?;
    Ok(Some(path))
}
