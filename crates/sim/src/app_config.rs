//! The configuration the application runs with in a simulation: the given file (or the
//! defaults, with the steering's safe position at 1560 µs so that safe outputs differ from
//! MANUAL at neutral; steering moves nothing at a standstill), with the simulation's pty links as ports, the chosen loop rate, a
//! sensor link fast enough for it, short reopen intervals, and (unless `--realtime`) no
//! realtime privileges required.

use std::path::Path;

use anyhow::Context;
use dima_core::config::{Config, SafeOutput, ServoKind, STANDARD_BAUD_RATES};

/// The steering's safe position in the simulation's default configuration, µs (neutral is
/// 1545).
pub const SIM_STEERING_SAFE_US: u16 = 1_560;

/// Where the simulated devices are.
#[derive(Debug, Clone, Copy)]
pub struct SimPorts<'a> {
    /// Sensor board.
    pub sensor: &'a Path,
    /// Maestro.
    pub maestro: &'a Path,
    /// XBee.
    pub xbee: &'a Path,
}

/// Builds and validates the application's configuration for a simulation run.
pub fn app_config(
    file: Option<&Path>,
    ports: SimPorts<'_>,
    loop_rate_hz: u32,
    realtime: bool,
    log_dir: &Path,
) -> anyhow::Result<Config> {
    let mut config = match file {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read config file {}", path.display()))?;
            Config::from_toml(&text, &path.display().to_string())?
        }
        None => {
            let mut c = Config::default();
            c.channels.steering.safe = SafeOutput::PulseUs(SIM_STEERING_SAFE_US);
            c
        }
    };
    config.sensor.port = ports.sensor.to_owned();
    config.maestro.port = ports.maestro.to_owned();
    // The simulated servo board is a Maestro, whatever board the file names.
    config.servo.kind = ServoKind::Maestro;
    config.xbee.port = ports.xbee.to_owned();
    config.realtime.loop_rate_hz = loop_rate_hz;
    fit_sensor_link(&mut config, file.is_none());
    if file.is_none() {
        fit_counted_protections(&mut config);
    }
    config.maestro.servo_refresh_hz = config.maestro.servo_refresh_hz.min(loop_rate_hz);
    for interval in [
        &mut config.sensor.reopen_interval_ms,
        &mut config.maestro.reopen_interval_ms,
        &mut config.xbee.reopen_interval_ms,
    ] {
        *interval = (*interval).min(200);
    }
    if !realtime {
        // SCHED_FIFO where the system allows it (it falls back by itself), nothing that needs
        // a dedicated machine or privileges.
        config.realtime.cpus = Vec::new();
        config.realtime.lock_memory = false;
        config.realtime.cpu_dma_latency = false;
        config.realtime.required = false;
    }
    config.log.enabled = true;
    config.log.directory = log_dir.to_owned();
    config.validate()?;
    Ok(config)
}

/// Serves the run's live view on `listen` (`--foxglove ADDR`, as `[foxglove] listen`);
/// `None` keeps the configuration's setting. An error names the flag when the address is not
/// `IP:PORT`.
pub fn set_live_view(config: &mut Config, listen: Option<&str>) -> anyhow::Result<()> {
    if let Some(addr) = listen {
        config.foxglove.listen = addr.to_owned();
        config
            .validate()
            .with_context(|| format!("--foxglove {addr}"))?;
    }
    Ok(())
}

/// With the default configuration, keeps the protections counted in packets or late wake-ups
/// within the second the configuration allows at slow loop rates (a given file is validated as
/// it is, and says what does not fit).
fn fit_counted_protections(config: &mut Config) {
    let rate = config.realtime.loop_rate_hz;
    let second = dima_core::config::most_packets_within(rate, 1_000_000_000);
    let s = &mut config.safety;
    s.sensor_loss_packets = s.sensor_loss_packets.min(second);
    s.imu_stuck_packets = s.imu_stuck_packets.min(second).max(2);
    s.overrun_limit = s
        .overrun_limit
        .min(dima_core::config::max_overrun_limit(rate));
}

/// Fits the packet deadline in the period (less the servo write budget) and, with the default
/// configuration (`raise_baud`), at loop rates where a packet would not fit at the configured
/// baud rate, raises the sensor link to the first standard rate that leaves 15 % margin (the
/// board's USART reaches several Mbaud). A given file's baud rate is kept: validation then
/// says when a packet does not fit.
fn fit_sensor_link(config: &mut Config, raise_baud: bool) {
    let period_us = (config.period_ns() / 1_000) as u32;
    let s = &mut config.sensor;
    s.packet_deadline_us = s
        .packet_deadline_us
        .min(period_us.saturating_sub(config.maestro.write_budget_us));
    if !raise_baud {
        return;
    }
    let deadline_ns = u64::from(config.sensor.packet_deadline_us) * 1_000;
    let configured = config.sensor.baud;
    for &baud in STANDARD_BAUD_RATES.iter().filter(|&&b| b >= configured) {
        config.sensor.baud = baud;
        if config.packet_wire_ns() * 115 / 100 < deadline_ns {
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn build(rate: u32) -> Config {
        let p = Path::new("/tmp/x");
        let ports = SimPorts {
            sensor: p,
            maestro: p,
            xbee: p,
        };
        app_config(None, ports, rate, false, p).unwrap()
    }

    #[test]
    fn slow_loops_keep_the_default_protections_within_a_second() {
        for rate in [10, 25, 50, 100] {
            let c = build(rate);
            assert!(c.validate().is_ok(), "{rate} Hz");
            let second = dima_core::config::most_packets_within(rate, 1_000_000_000);
            assert!(c.safety.sensor_loss_packets <= second, "{rate} Hz");
            assert!(c.safety.imu_stuck_packets <= second, "{rate} Hz");
        }
    }

    #[test]
    fn the_default_rate_keeps_the_v1_link() {
        let c = build(250);
        assert_eq!(
            (c.sensor.baud, c.sensor.packet_deadline_us),
            (460_800, 3_700)
        );
        assert!(!c.realtime.required);
        assert_eq!(c.channels.steering.safe, SafeOutput::PulseUs(1_560));
        assert_ne!(
            c.channels.steering.safe.pulse_us(),
            c.channels.steering.neutral_us
        );
    }

    #[test]
    fn foxglove_sets_the_live_view_and_checks_the_address() {
        let mut c = build(250);
        set_live_view(&mut c, None).unwrap();
        assert_eq!(c.foxglove.listen_addr().unwrap(), None);
        set_live_view(&mut c, Some("127.0.0.1:8765")).unwrap();
        assert_eq!(
            c.foxglove.listen_addr().unwrap(),
            Some("127.0.0.1:8765".parse().unwrap())
        );
        let message = format!("{:#}", set_live_view(&mut c, Some("8765")).unwrap_err());
        assert!(message.contains("--foxglove 8765"), "{message}");
        assert!(message.contains("expected IP:PORT"), "{message}");
    }

    #[test]
    fn a_fast_loop_gets_a_fast_sensor_link() {
        let c = build(1_000);
        assert_eq!(c.sensor.packet_deadline_us, 700);
        assert_eq!(c.sensor.baud, 3_000_000);
        assert!(c.packet_wire_ns() < 700_000);
    }
}
