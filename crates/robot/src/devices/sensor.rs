//! The sensor board as the loop sees it: the sensor-board crate's host driver over a raw serial
//! port and a request line, plus a second descriptor of the port to wait on with a deadline.

use std::os::fd::{AsFd, OwnedFd};
use std::path::Path;

use anyhow::Context;
use dima_sensorboard::SensorBoard;
use embedded_hal::digital::OutputPin;
use linux_embedded_hal::gpio_cdev::{Chip, LineRequestFlags};
use linux_embedded_hal::CdevPin;

use super::serial::{LineSettings, SerialError, SerialPort};
use crate::config::SensorConfig;
use dima_core::Nanos;

/// The sensor board: driver plus a descriptor to wait on.
pub struct SensorDevice<P> {
    /// The sensor-board host driver.
    pub board: SensorBoard<P, SerialPort>,
    wait_fd: OwnedFd,
}

impl<P: OutputPin> SensorDevice<P> {
    /// From an open port and request line.
    pub fn new(port: SerialPort, request: P) -> std::io::Result<SensorDevice<P>> {
        let wait_fd = port.try_clone_fd()?;
        Ok(SensorDevice {
            board: SensorBoard::new(request, port),
            wait_fd,
        })
    }

    /// Waits until bytes arrive or `deadline_ns` passes (`Ok(false)`).
    pub fn wait_readable(&self, deadline_ns: Nanos) -> Result<bool, SerialError> {
        SerialPort::wait_readable(self.wait_fd.as_fd(), deadline_ns)
    }
}

/// Requests `line` of the GPIO character device `chip` as an output, low (uAPI v1, which the
/// Jetson Nano's 4.9 kernel has).
pub fn open_request_line(chip: &Path, line: u32) -> anyhow::Result<CdevPin> {
    let mut chip_dev = Chip::new(chip).with_context(|| {
        format!(
            "request line: cannot open {} (does the user have access to the gpio group?)",
            chip.display()
        )
    })?;
    let handle = chip_dev
        .get_line(line)
        .and_then(|l| l.request(LineRequestFlags::OUTPUT, 0, "dima-request"))
        .with_context(|| {
            format!(
                "request line: cannot claim line {line} of {} as an output (busy or absent?)",
                chip.display()
            )
        })?;
    CdevPin::new(handle).context("request line: reading line info")
}

/// Opens the sensor UART as configured.
pub fn open_sensor_port(config: &SensorConfig) -> anyhow::Result<SerialPort> {
    SerialPort::open(
        &config.port,
        LineSettings {
            baud: config.baud,
            stop_bits: config.stop_bits,
        },
    )
    .with_context(|| {
        format!(
            "sensor board: cannot open {} at {} baud (wired, and in the dialout group?)",
            config.port.display(),
            config.baud
        )
    })
}

/// The hardware opener: the configured UART and the GPIO request line.
pub fn open_hardware_sensor(config: &SensorConfig) -> anyhow::Result<SensorDevice<CdevPin>> {
    let port = open_sensor_port(config)?;
    let pin = open_request_line(&config.request_chip, config.request_line)?;
    SensorDevice::new(port, pin).context("sensor board: duplicating the port descriptor")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_gpio_chip_names_the_device() {
        let err = open_request_line(Path::new("/dev/gpiochip-absent"), 216)
            .err()
            .unwrap();
        let text = format!("{err:#}");
        assert!(text.contains("/dev/gpiochip-absent"), "{text}");
        assert!(text.contains("request line"), "{text}");
    }

    #[test]
    fn missing_sensor_port_names_the_device() {
        let config = SensorConfig {
            port: "/dev/ttyTHS-absent".into(),
            ..SensorConfig::default()
        };
        let text = format!("{:#}", open_hardware_sensor(&config).err().unwrap());
        assert!(text.contains("/dev/ttyTHS-absent"), "{text}");
        assert!(text.contains("460800"), "{text}");
    }
}
