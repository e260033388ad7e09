//! Read the BMX055 over Linux spidev (e.g. a Raspberry Pi or Jetson header), one chip select
//! per die, and print scaled and compensated values.
//!
//! Usage: `cargo run --example linux_spidev -- /dev/spidev0.0 /dev/spidev0.1 /dev/spidev1.0`
//! (accelerometer, gyroscope, magnetometer). Needs SPI mode 3 (or 0), at most 10 MHz.

use bosch_bmx055::mag::compensate_f32;
use bosch_bmx055::{Bmx055, Bmx055Config};
use linux_embedded_hal::spidev::{SpiModeFlags, SpidevOptions};
use linux_embedded_hal::{Delay, SpidevDevice};
use std::error::Error;

/// ±2 g / 1000 Hz, ±2000 °/s / 2000 Hz with the 230 Hz filter, magnetometer low-power preset
/// in forced mode.
const IMU_CONFIG: Bmx055Config = Bmx055Config {
    accel: bosch_bmx055::accel::AccelConfig {
        range: bosch_bmx055::accel::AccelRange::G2,
        bandwidth: bosch_bmx055::accel::AccelBandwidth::Hz1000,
        power: bosch_bmx055::accel::AccelPowerMode::Normal,
    },
    gyro: bosch_bmx055::gyro::GyroConfig {
        range: bosch_bmx055::gyro::GyroRange::Dps2000,
        bandwidth: bosch_bmx055::gyro::GyroBandwidth::Odr2000Bw230,
        power: bosch_bmx055::gyro::GyroPowerMode::Normal,
    },
    mag: bosch_bmx055::mag::MagConfig::forced(bosch_bmx055::mag::MagPreset::LowPower),
};

fn open(path: &str) -> Result<SpidevDevice, Box<dyn Error>> {
    let mut dev = SpidevDevice::open(path).map_err(|e| format!("{path}: {e}"))?;
    let options = SpidevOptions::new()
        .bits_per_word(8)
        .max_speed_hz(1_000_000)
        .mode(SpiModeFlags::SPI_MODE_3)
        .build();
    dev.0
        .configure(&options)
        .map_err(|e| format!("{path}: cannot configure SPI: {e}"))?;
    Ok(dev)
}

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [accel, gyro, mag] = args.as_slice() else {
        return Err("usage: linux_spidev ACCEL_SPIDEV GYRO_SPIDEV MAG_SPIDEV".into());
    };
    let mut imu = Bmx055::new_spi(open(accel)?, open(gyro)?, open(mag)?);
    let mut delay = Delay;
    let trim = imu
        .init(&mut delay, &IMU_CONFIG)
        .map_err(|e| format!("BMX055 init failed: {e}"))?;
    println!("magnetometer trim: {trim:?}");
    for _ in 0..50 {
        let s = imu
            .sample()
            .map_err(|e| format!("BMX055 read failed: {e}"))?;
        let mg = s.accel.mg(imu.accel.range());
        let dps = s.gyro.dps(imu.gyro.range());
        let ut = compensate_f32(&s.mag.to_raw(), &trim);
        println!(
            "acc {:8.1} {:8.1} {:8.1} mg | gyro {:8.2} {:8.2} {:8.2} °/s | mag {:7.1} {:7.1} {:7.1} µT{}",
            mg.x, mg.y, mg.z, dps.x, dps.y, dps.z, ut.x, ut.y, ut.z,
            if s.mag_fresh { "" } else { " (previous)" }
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    Ok(())
}
