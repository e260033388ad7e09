//! Display-frame values in physical units, and the setpoint conversions of control mode.
//!
//! The IMU scales are those of the ranges the sensor board configures (accelerometer ±2 g,
//! gyroscope ±2000 °/s, from `dima-sensorboard`). The magnetometer and the barometer need the
//! sensor board's calibration (BMM150 trim, BMP280 calibration registers), which the board
//! sends to the robot in its info frame: with it, µT, Pa and °C; without it, raw counts,
//! labelled as such.

use std::path::Path;

use bosch_bmp280::compensation::{pressure_pa_f32, temperature_celsius_f32};
use bosch_bmp280::Calibration;
use bosch_bmx055::mag::{compensate_f32, MagRaw, MagTrim};
use dima_groundlink::{DisplayFrame, HEADING_FULL_TURN_DEG_E5, MAX_SPEED_MM_S};
use dima_sensorboard::units::{accel_m_s2_2g, gyro_dps_2000};

/// The sensor board's calibration, as its info frame carries it.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorCalibration {
    /// BMP280 compensation parameters.
    pub bmp280: Calibration,
    /// BMM150 trim.
    pub mag_trim: MagTrim,
    /// Where it came from (shown to the operator).
    pub source: String,
}

impl SensorCalibration {
    /// From the info frame's bytes: BMP280 registers 0x88..=0x9F and the BMM150 trim bursts
    /// 0x5D..=0x5E, 0x62..=0x65, 0x68..=0x71 in that order.
    pub fn from_info_bytes(
        bmp280: &[u8; 24],
        trim: &[u8; 16],
        source: impl Into<String>,
    ) -> SensorCalibration {
        let mut b1 = [0u8; 2];
        let mut b2 = [0u8; 4];
        let mut b3 = [0u8; 10];
        b1.copy_from_slice(&trim[..2]);
        b2.copy_from_slice(&trim[2..6]);
        b3.copy_from_slice(&trim[6..]);
        SensorCalibration {
            bmp280: Calibration::from_bytes(bmp280),
            mag_trim: MagTrim::from_bursts(&b1, &b2, &b3),
            source: source.into(),
        }
    }

    /// The calibration of the simulated sensor board of `dima sim` (its info frame's content):
    /// the drivers' datasheet examples.
    pub fn simulated_board() -> SensorCalibration {
        SensorCalibration::from_info_bytes(
            &bosch_bmp280::Calibration::DATASHEET_EXAMPLE_BYTES,
            &MagTrim::EXAMPLE_BURST_BYTES,
            "the simulated board's info frame",
        )
    }

    /// The last info frame in a robot's MCAP log (`/sensor/info`, written by `dima`), over
    /// every file of the run `path` belongs to.
    pub fn from_robot_log(path: &Path) -> anyhow::Result<SensorCalibration> {
        use dima_log::schema::SENSOR_INFO;
        let run = dima_log::run::read_run(path)?;
        if let Some(w) = run.warnings.first() {
            anyhow::bail!("{w}");
        }
        let info = run.infos.into_iter().last().map(|i| i.msg).ok_or_else(|| {
            anyhow::anyhow!(
                "{} has no {} message (a log of `dima run` or `dima sim` once the sensor board answered)",
                path.display(),
                SENSOR_INFO.topic
            )
        })?;
        let bmp: [u8; 24] = info.bmp280_calibration.as_slice().try_into().map_err(|_| {
            anyhow::anyhow!("{}: BMP280 calibration is not 24 bytes", path.display())
        })?;
        let trim: [u8; 16] = info
            .bmm150_trim
            .as_slice()
            .try_into()
            .map_err(|_| anyhow::anyhow!("{}: BMM150 trim is not 16 bytes", path.display()))?;
        Ok(SensorCalibration::from_info_bytes(
            &bmp,
            &trim,
            format!("the info frame in {}", path.display()),
        ))
    }
}

/// The magnetic field: compensated, or raw counts when the trim is unknown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MagField {
    /// X, Y, Z in µT (0.0 marks an overflowed axis, as the BMM150 compensation does).
    MicroTesla([f32; 3]),
    /// X, Y, Z raw counts and the hall resistance.
    Raw([i16; 3], u16),
}

/// The barometer: compensated, or the raw ADC values when the calibration is unknown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Baro {
    /// Pressure, Pa, and temperature, °C.
    Compensated {
        /// Pressure, Pa (`None` where the datasheet formula guards a division by zero).
        pressure_pa: Option<f32>,
        /// Temperature, °C.
        temperature_c: f32,
    },
    /// Raw 20-bit ADC values.
    Raw {
        /// Pressure ADC.
        adc_p: u32,
        /// Temperature ADC.
        adc_t: u32,
    },
}

/// One display frame in physical units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Physical {
    /// Acceleration X, Y, Z, m/s².
    pub acc_m_s2: [f32; 3],
    /// Angular rate X, Y, Z, °/s.
    pub gyro_dps: [f32; 3],
    /// Magnetic field.
    pub mag: MagField,
    /// Pressure and temperature.
    pub baro: Baro,
    /// Latitude, degrees (north positive).
    pub lat_deg: f64,
    /// Longitude, degrees (east positive).
    pub lon_deg: f64,
    /// Velocity north, east, down, m/s.
    pub vel_ned_m_s: [f64; 3],
    /// Height above the ellipsoid, m.
    pub height_m: f64,
    /// Height above mean sea level, m.
    pub h_msl_m: f64,
    /// Ground speed, m/s.
    pub ground_speed_m_s: f64,
    /// Heading of motion, degrees.
    pub heading_deg: f64,
}

impl Physical {
    /// Converts `frame`, compensating with `calibration` when given.
    pub fn from_frame(frame: &DisplayFrame, calibration: Option<&SensorCalibration>) -> Physical {
        let mag = match calibration {
            Some(c) => {
                let raw = MagRaw {
                    x: frame.mag[0],
                    y: frame.mag[1],
                    z: frame.mag[2],
                    rhall: frame.mag_hall,
                    data_ready: true,
                };
                let f = compensate_f32(&raw, &c.mag_trim);
                MagField::MicroTesla([f.x, f.y, f.z])
            }
            None => MagField::Raw(frame.mag, frame.mag_hall),
        };
        let baro = match calibration {
            Some(c) => {
                let (temperature_c, t_fine) = temperature_celsius_f32(&c.bmp280, frame.baro_temp);
                Baro::Compensated {
                    pressure_pa: pressure_pa_f32(&c.bmp280, t_fine, frame.baro_press),
                    temperature_c,
                }
            }
            None => Baro::Raw {
                adc_p: frame.baro_press,
                adc_t: frame.baro_temp,
            },
        };
        let mm = |v: i32| f64::from(v) * 1e-3;
        Physical {
            acc_m_s2: frame.acc.map(accel_m_s2_2g),
            gyro_dps: frame.gyro.map(gyro_dps_2000),
            mag,
            baro,
            lat_deg: f64::from(frame.lat_e7) * 1e-7,
            lon_deg: f64::from(frame.lon_e7) * 1e-7,
            vel_ned_m_s: [
                mm(frame.vel_n_mm_s),
                mm(frame.vel_e_mm_s),
                mm(frame.vel_d_mm_s),
            ],
            height_m: mm(frame.height_mm),
            h_msl_m: mm(frame.h_msl_mm),
            ground_speed_m_s: mm(frame.g_speed_mm_s),
            heading_deg: f64::from(frame.head_mot_deg_e5) * 1e-5,
        }
    }

    /// Whether the frame carries a position (a robot without a fix sends 0, 0).
    pub fn has_position(&self) -> bool {
        self.lat_deg != 0.0 || self.lon_deg != 0.0
    }
}

/// Why a setpoint cannot be sent.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum SetpointError {
    /// Not a finite number.
    #[error("not a number")]
    NotFinite,
    /// Beyond what the protocol accepts.
    #[error("{value} m/s is beyond ±{limit} m/s")]
    SpeedOutOfRange {
        /// The value asked for, m/s.
        value: f64,
        /// The limit, m/s.
        limit: f64,
    },
}

/// A speed setpoint in m/s as the protocol's mm/s (type 6), rounded to the nearest mm/s.
pub fn speed_setpoint_mm_s(m_s: f64) -> Result<i32, SetpointError> {
    if !m_s.is_finite() {
        return Err(SetpointError::NotFinite);
    }
    let mm = (m_s * 1000.0).round();
    let limit = f64::from(MAX_SPEED_MM_S);
    if mm.abs() > limit {
        return Err(SetpointError::SpeedOutOfRange {
            value: m_s,
            limit: limit / 1000.0,
        });
    }
    Ok(mm as i32)
}

/// A heading in degrees (any value, wrapped into 0..360) as the protocol's 1e-5 degrees
/// (type 7).
pub fn heading_setpoint_deg_e5(deg: f64) -> Result<i32, SetpointError> {
    if !deg.is_finite() {
        return Err(SetpointError::NotFinite);
    }
    let e5 = (deg.rem_euclid(360.0) * 1e5).round() as i64;
    // 359.999996° rounds up to a full turn, which is north again.
    Ok((e5 % i64::from(HEADING_FULL_TURN_DEG_E5)) as i32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn barometer_datasheet_example() {
        // BMP280 datasheet 8.1/8.2: with the example calibration, adc_T 519888 is 25.08 °C and
        // adc_P 415148 is 100653.27 Pa (floating-point formula).
        let cal = SensorCalibration::simulated_board();
        let frame = DisplayFrame {
            baro_temp: 519_888,
            baro_press: 415_148,
            ..DisplayFrame::default()
        };
        let p = Physical::from_frame(&frame, Some(&cal));
        let Baro::Compensated {
            pressure_pa: Some(pa),
            temperature_c,
        } = p.baro
        else {
            panic!("{:?}", p.baro)
        };
        assert!(
            close(f64::from(temperature_c), 25.08, 0.01),
            "{temperature_c}"
        );
        assert!(close(f64::from(pa), 100_653.27, 0.5), "{pa}");
        let raw = Physical::from_frame(&frame, None);
        assert_eq!(
            raw.baro,
            Baro::Raw {
                adc_p: 415_148,
                adc_t: 519_888
            }
        );
    }

    #[test]
    fn imu_scales_and_signs() {
        // BMX055: ±2 g over 2048 counts (1000/1024 mg per count; the datasheet rounds it to
        // 0.98); ±2000 °/s at 16.4 counts per °/s.
        let frame = DisplayFrame {
            acc: [-1000, 0, 1020],
            gyro: [164, -328, 0],
            ..DisplayFrame::default()
        };
        let p = Physical::from_frame(&frame, None);
        assert!(close(
            f64::from(p.acc_m_s2[0]),
            -1000.0 / 1024.0 * 9.80665,
            1e-4
        ));
        assert!(close(
            f64::from(p.acc_m_s2[2]),
            1020.0 / 1024.0 * 9.80665,
            1e-4
        ));
        assert!(close(f64::from(p.gyro_dps[0]), 10.0, 1e-4));
        assert!(close(f64::from(p.gyro_dps[1]), -20.0, 1e-4));
    }

    #[test]
    fn gnss_fields_in_the_right_order_and_units() {
        // Zurich: 47.3769° N, 8.5417° E; the original GUI swapped these and lost signs.
        let frame = DisplayFrame {
            lat_e7: 473_769_000,
            lon_e7: -85_417_000,
            vel_n_mm_s: 1_250,
            vel_e_mm_s: -300,
            vel_d_mm_s: 15,
            height_mm: 408_123,
            h_msl_mm: 360_000,
            g_speed_mm_s: 1_285,
            head_mot_deg_e5: 34_650_000,
            ..DisplayFrame::default()
        };
        let p = Physical::from_frame(&frame, None);
        assert!(close(p.lat_deg, 47.3769, 1e-9));
        assert!(close(p.lon_deg, -8.5417, 1e-9));
        assert_eq!(p.vel_ned_m_s, [1.25, -0.3, 0.015]);
        assert!(close(p.height_m, 408.123, 1e-9));
        assert!(close(p.h_msl_m, 360.0, 1e-9));
        assert!(close(p.ground_speed_m_s, 1.285, 1e-9));
        assert!(close(p.heading_deg, 346.5, 1e-9));
        assert!(p.has_position());
        assert!(!Physical::from_frame(&DisplayFrame::default(), None).has_position());
    }

    #[test]
    fn magnetometer_uses_the_trim_bursts_in_info_frame_order() {
        let cal = SensorCalibration::simulated_board();
        let t = &MagTrim::EXAMPLE_BURST_BYTES;
        let expected_trim = MagTrim::from_bursts(
            &[t[0], t[1]],
            &[t[2], t[3], t[4], t[5]],
            &[
                t[6], t[7], t[8], t[9], t[10], t[11], t[12], t[13], t[14], t[15],
            ],
        );
        assert_eq!(cal.mag_trim, expected_trim);
        let frame = DisplayFrame {
            mag: [-120, 340, -800],
            mag_hall: 7_000,
            ..DisplayFrame::default()
        };
        let MagField::MicroTesla(ut) = Physical::from_frame(&frame, Some(&cal)).mag else {
            panic!("compensated expected")
        };
        // Signs survive (the original lost them), within the BMM150's ranges (±1300 µT for X
        // and Y, ±2500 µT for Z).
        assert!(ut[0] < 0.0 && ut[1] > 0.0 && ut[2] < 0.0, "{ut:?}");
        assert!(ut[0].abs() < 1300.0 && ut[1].abs() < 1300.0 && ut[2].abs() < 2500.0);
        assert_eq!(
            Physical::from_frame(&frame, None).mag,
            MagField::Raw([-120, 340, -800], 7_000)
        );
    }

    #[test]
    fn setpoints_in_protocol_units() {
        assert_eq!(speed_setpoint_mm_s(1.5), Ok(1_500));
        assert_eq!(speed_setpoint_mm_s(-0.0004), Ok(0));
        assert_eq!(speed_setpoint_mm_s(100.0), Ok(100_000));
        assert!(speed_setpoint_mm_s(100.001).is_err());
        assert!(speed_setpoint_mm_s(f64::NAN).is_err());
        assert_eq!(heading_setpoint_deg_e5(90.0), Ok(9_000_000));
        assert_eq!(heading_setpoint_deg_e5(-90.0), Ok(27_000_000));
        assert_eq!(heading_setpoint_deg_e5(360.0), Ok(0));
        assert_eq!(heading_setpoint_deg_e5(359.999_996), Ok(0));
        assert_eq!(heading_setpoint_deg_e5(12.345_67), Ok(1_234_567));
        assert!(heading_setpoint_deg_e5(f64::INFINITY).is_err());
    }
}
