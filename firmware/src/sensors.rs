//! The four sensor dies on SPI1, driven by the workspace's driver crates.
//!
//! At boot each die is brought up on its own (soft reset, chip id with bounded retries, DIMA
//! configuration), so one that never answers only clears its status bit: it is reported in the
//! info frame and on the status LED, its packet fields stay zero, and the board keeps running.
//! Afterwards [`Sensors::tick`] does what the sampling schedule says and writes the register
//! words into the packet being assembled.

use bosch_bmp280::{Bmp280, Config as BaroConfig, SpiInterface as BaroSpi};
use bosch_bmx055::accel::{AccelConfig, AccelRaw};
use bosch_bmx055::gyro::{GyroConfig, GyroRaw};
use bosch_bmx055::interface::SpiInterface;
use bosch_bmx055::mag::{MagConfig, MagPacketWords};
use bosch_bmx055::{Accelerometer, Gyroscope, ImuPacketWords, Magnetometer};
use dima_firmware_logic::{MagAction, Schedule, TickPlan};
use dima_sensorboard::{PacketBuilder, SensorStatus};
use embedded_hal::delay::DelayNs;
use embedded_hal::spi::SpiDevice;

/// Attempts at bringing up the BMP280 (its driver checks the chip id once per attempt).
const BARO_ATTEMPTS: u8 = 3;

/// What boot found out, for the info frame.
pub struct BootReport {
    /// Which dies answered and were configured.
    pub status: SensorStatus,
    /// BMP280 calibration registers 0x88..=0x9F (zeros if the BMP280 did not answer).
    pub bmp280_calibration: [u8; 24],
    /// BMM150 trim registers 0x5D..=0x5E, 0x62..=0x65, 0x68..=0x71 (zeros if absent).
    pub bmm150_trim: [u8; 16],
}

/// The sensor dies and their latest readings.
pub struct Sensors<A, G, M, B> {
    accel: Accelerometer<SpiInterface<A>>,
    gyro: Gyroscope<SpiInterface<G>>,
    mag: Magnetometer<SpiInterface<M>>,
    baro: Bmp280<BaroSpi<B>>,
    status: SensorStatus,
    accel_raw: AccelRaw,
    gyro_raw: GyroRaw,
    mag_words: MagPacketWords,
    bus_errors: u32,
}

impl<A, G, M, B> Sensors<A, G, M, B>
where
    A: SpiDevice,
    G: SpiDevice,
    M: SpiDevice,
    B: SpiDevice,
{
    /// Brings every die up with the DIMA settings and reports what answered.
    pub fn init(
        accel: A,
        gyro: G,
        mag: M,
        baro: B,
        delay: &mut impl DelayNs,
    ) -> (Self, BootReport) {
        let mut report = BootReport {
            status: SensorStatus::empty(),
            bmp280_calibration: [0; 24],
            bmm150_trim: [0; 16],
        };

        let mut accel = Accelerometer::new_spi(accel);
        if accel.init(delay, &AccelConfig::DIMA).is_ok() {
            report.status |= SensorStatus::ACCEL_OK;
        }
        let mut gyro = Gyroscope::new_spi(gyro);
        if gyro.init(delay, &GyroConfig::DIMA).is_ok() {
            report.status |= SensorStatus::GYRO_OK;
        }
        let mut mag = Magnetometer::new_spi(mag);
        if let Ok(trim) = mag.init(delay, &MagConfig::DIMA) {
            report.status |= SensorStatus::MAG_OK;
            let (low, mid, high) = trim.to_bursts();
            report.bmm150_trim[..2].copy_from_slice(&low);
            report.bmm150_trim[2..6].copy_from_slice(&mid);
            report.bmm150_trim[6..].copy_from_slice(&high);
        }
        let mut baro = Bmp280::new_spi(baro);
        for _ in 0..BARO_ATTEMPTS {
            if baro.init(delay).is_ok() && baro.configure(BaroConfig::dima()).is_ok() {
                if let Some(calibration) = baro.calibration() {
                    report.bmp280_calibration = calibration.to_bytes();
                    report.status |= SensorStatus::BMP280_OK;
                }
                break;
            }
        }

        let sensors = Self {
            accel,
            gyro,
            mag,
            baro,
            status: report.status,
            accel_raw: AccelRaw::default(),
            gyro_raw: GyroRaw::default(),
            mag_words: MagPacketWords::default(),
            bus_errors: 0,
        };
        (sensors, report)
    }

    fn ok(&self, flag: SensorStatus) -> bool {
        self.status.contains(flag)
    }

    fn count<T, E>(&mut self, result: Result<T, E>) -> Option<T> {
        if result.is_err() {
            self.bus_errors = self.bus_errors.wrapping_add(1);
        }
        result.ok()
    }

    /// Does the reads of one tick and writes bytes 2..=27 of the packet. Readings that fail
    /// keep their previous value (and are counted); dies that never answered stay zero.
    pub fn tick(&mut self, plan: TickPlan, schedule: &mut Schedule, packet: &mut PacketBuilder) {
        if plan.read_inertial {
            if self.ok(SensorStatus::ACCEL_OK) {
                let read = self.accel.read_raw();
                if let Some(raw) = self.count(read) {
                    self.accel_raw = raw;
                }
            }
            if self.ok(SensorStatus::GYRO_OK) {
                let read = self.gyro.read_raw();
                if let Some(raw) = self.count(read) {
                    self.gyro_raw = raw;
                }
            }
        }

        if self.ok(SensorStatus::MAG_OK) {
            match plan.mag {
                MagAction::None => {}
                MagAction::Trigger => {
                    let started = self.mag.start_forced();
                    self.count(started);
                }
                MagAction::Poll => match self.mag.poll_data() {
                    Ok(raw) => {
                        self.mag_words = raw.packet_words();
                        schedule.mag_polled(true);
                    }
                    Err(nb::Error::WouldBlock) => schedule.mag_polled(false),
                    Err(nb::Error::Other(_)) => {
                        self.bus_errors = self.bus_errors.wrapping_add(1);
                        schedule.mag_polled(false);
                    }
                },
            }
        }

        if plan.read_baro && self.ok(SensorStatus::BMP280_OK) {
            let read = self.baro.read_raw_bytes();
            if let Some(bytes) = self.count(read) {
                packet.bmp280_registers(bytes);
            }
        }

        let words =
            ImuPacketWords::from_raw(&self.accel_raw, &self.gyro_raw, self.mag_words).to_le_bytes();
        packet
            .accel_registers(core::array::from_fn(|i| words[i]))
            .gyro_registers(core::array::from_fn(|i| words[6 + i]))
            .mag_registers(core::array::from_fn(|i| words[12 + i]));
    }

    /// SPI transfers that failed after boot.
    pub fn bus_errors(&self) -> u32 {
        self.bus_errors
    }
}
