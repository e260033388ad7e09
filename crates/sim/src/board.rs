//! The simulated sensor board: the answer to each request, built from the vehicle model with
//! the project's own codecs.
//!
//! - accelerometer, gyroscope and magnetometer words from physical values with bias and noise
//!   ([`dima_sensorboard::imu::packet_words_from_physical`], magnetometer through the inverse
//!   of Bosch's trim compensation);
//! - BMP280 raw values through the inverse of the datasheet compensation for a real
//!   calibration set (the datasheet's own example device);
//! - a NAV-PVT frame at 10 Hz from the model's position and velocity ([`neo_m8t::NavPvt`]);
//! - the v1 packet assembled by [`PacketBuilder`] with the STM32 CRC, and behind it one info
//!   piece (`$H`) as the firmware sends them ([`InfoPieceCycle`]): a version 2 info frame with
//!   calibration and health, snapshot every 250 ms, each snapshot cut into 9 pieces and sent
//!   once, from piece 0 again after a request 500 ms or more after the previous one.

use bosch_bmp280::compensation::inverse::raw_for_celsius_pascal_f32;
use bosch_bmp280::Calibration;
use bosch_bmx055::accel::AccelRange;
use bosch_bmx055::gyro::GyroRange;
use bosch_bmx055::mag::MagTrim;
use bosch_bmx055::Xyz;
use dima_sensorboard::imu::{packet_words_from_physical, ImuPhysical};
use dima_sensorboard::{
    BoardFaults, BoardHealth, InfoFrame, InfoPieceCycle, PacketBuilder, SensorStatus, Stm32Crc,
    GNSS_FRAME_LEN, INFO_GAP_MS, INFO_PIECE_LEN, INFO_SNAPSHOT_MS, PACKET_LEN,
};

use crate::model::VehicleState;
use crate::rng::SimRng;

/// The simulated BMP280's calibration registers 0x88..=0x9F: the datasheet's worked example.
pub const DATASHEET_BMP280_CALIBRATION: [u8; 24] = Calibration::DATASHEET_EXAMPLE_BYTES;

/// The simulated BMM150's trim bursts (0x5D..=0x5E, 0x62..=0x65, 0x68..=0x71, in the info
/// frame's order): Bosch's example device.
pub const BMM150_TRIM: [u8; 16] = bosch_bmx055::mag::MagTrim::EXAMPLE_BURST_BYTES;

/// Hall resistance the simulated magnetometer reports.
pub const RHALL: u16 = 7_000;

/// Standard gravity, m/s².
const G: f64 = 9.806_65;
/// Mean Earth radius, m (local flat-Earth conversion to degrees).
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;
/// GPS time of week at the simulated start (Sunday 08:00:00 UTC plus 18 leap seconds), ms.
const START_ITOW_MS: u32 = 8 * 3_600_000 + 18_000;
/// Bytes of an answer: a packet and, most of the time, an info piece.
pub const MAX_ANSWER_LEN: usize = PACKET_LEN + INFO_PIECE_LEN;

/// Where and how the simulated board starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardConfig {
    /// Start latitude, degrees.
    pub start_lat_deg: f64,
    /// Start longitude, degrees.
    pub start_lon_deg: f64,
    /// Height above mean sea level, m.
    pub height_msl_m: f64,
    /// Ambient temperature, °C.
    pub temperature_c: f64,
    /// Sea-level pressure, Pa.
    pub sea_level_pa: f64,
    /// GNSS navigation rate, Hz.
    pub gnss_rate_hz: f64,
    /// Add sensor noise and bias (off: exact values, for tests).
    pub noise: bool,
}

impl Default for BoardConfig {
    fn default() -> Self {
        BoardConfig {
            start_lat_deg: -34.0885,
            start_lon_deg: 18.4750,
            height_msl_m: 12.0,
            temperature_c: 22.0,
            sea_level_pa: 101_325.0,
            gnss_rate_hz: 10.0,
            noise: true,
        }
    }
}

/// The Earth's field at the start (Cape Town: about 25.5 µT, inclination -65°, declination
/// -26°), north, east and down components in µT.
const FIELD_NED_UT: [f64; 3] = [9.7, -4.7, -23.1];

/// Sensor errors drawn once per run from the seed.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Errors {
    accel_bias_mg: [f64; 3],
    gyro_bias_dps: [f64; 3],
}

/// Faults of the board's sensors for one answer.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SensorFaultState {
    /// Repeat the last NAV-PVT unchanged (no new epochs).
    pub gnss_frozen: bool,
    /// New epochs carry no fix (fix type 0, gnssFixOK clear).
    pub gnss_lost: bool,
    /// Keep the last accelerometer and gyroscope words.
    pub imu_stuck: bool,
    /// The car lies on its left side: the accelerometer reads 1 g along its Y axis.
    pub rolled_over: bool,
}

/// The board's answer to one request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Answer {
    /// The v1 packet.
    pub packet: [u8; PACKET_LEN],
    /// The info piece sent after it, while a snapshot's pieces are going out.
    pub info: Option<[u8; INFO_PIECE_LEN]>,
}

/// The simulated board's logic, without I/O.
#[derive(Debug, Clone)]
pub struct BoardSim {
    config: BoardConfig,
    calibration: Calibration,
    trim: MagTrim,
    rng: SimRng,
    errors: Errors,
    builder: PacketBuilder,
    gnss_frame: [u8; GNSS_FRAME_LEN],
    gnss_epochs: u64,
    last_head_mot_deg: f64,
    last_request_s: Option<f64>,
    requests_skipped: u32,
    /// The info pieces going out behind the packets.
    pieces: InfoPieceCycle,
    /// When the last info snapshot was taken, s, and its counter.
    last_snapshot_s: Option<f64>,
    snapshot: u8,
}

impl BoardSim {
    /// A board just out of reset.
    pub fn new(config: BoardConfig, rng: SimRng) -> BoardSim {
        let mut rng = rng;
        let noise = if config.noise { 1.0 } else { 0.0 };
        let errors = Errors {
            accel_bias_mg: [0; 3].map(|_| rng.normal(8.0 * noise)),
            gyro_bias_dps: [0; 3].map(|_| rng.normal(0.3 * noise)),
        };
        let t = &BMM150_TRIM;
        BoardSim {
            config,
            calibration: Calibration::from_bytes(&DATASHEET_BMP280_CALIBRATION),
            trim: MagTrim::from_bursts(
                &[t[0], t[1]],
                &[t[2], t[3], t[4], t[5]],
                &[
                    t[6], t[7], t[8], t[9], t[10], t[11], t[12], t[13], t[14], t[15],
                ],
            ),
            rng,
            errors,
            builder: PacketBuilder::new(),
            gnss_frame: [0; GNSS_FRAME_LEN],
            gnss_epochs: 0,
            last_head_mot_deg: 0.0,
            last_request_s: None,
            requests_skipped: 0,
            pieces: InfoPieceCycle::new(),
            last_snapshot_s: None,
            snapshot: 0,
        }
    }

    /// Counts a request that arrived while an answer was still going out (reported in the
    /// next info frame).
    pub fn skip_request(&mut self) {
        self.requests_skipped = self.requests_skipped.saturating_add(1);
    }

    /// GNSS epochs produced so far.
    pub fn gnss_epochs(&self) -> u64 {
        self.gnss_epochs
    }

    fn noise(&mut self, sigma: f64) -> f64 {
        if self.config.noise {
            self.rng.normal(sigma)
        } else {
            0.0
        }
    }

    /// The answer to a request at `now_s` (seconds since boot) with the car in `state`.
    pub fn answer(&mut self, now_s: f64, state: &VehicleState) -> Answer {
        self.answer_with(now_s, state, SensorFaultState::default())
    }

    /// The answer with the sensors' faults at this time.
    pub fn answer_with(
        &mut self,
        now_s: f64,
        state: &VehicleState,
        faults: SensorFaultState,
    ) -> Answer {
        let gap_s = f64::from(INFO_GAP_MS) * 1e-3;
        let restart = self.last_request_s.is_none_or(|t| now_s - t >= gap_s);
        self.last_request_s = Some(now_s);
        if !faults.gnss_frozen {
            self.update_gnss(now_s, state, faults.gnss_lost);
        }

        let e = self.errors;
        let accel_mg = if faults.rolled_over {
            // On its left side: gravity's reaction along +Y, nothing along Z.
            Xyz {
                x: e.accel_bias_mg[0] + self.noise(4.0),
                y: 1e3 + e.accel_bias_mg[1] + self.noise(4.0),
                z: e.accel_bias_mg[2] + self.noise(4.0),
            }
        } else {
            Xyz {
                x: state.accel_m_s2 / G * 1e3 + e.accel_bias_mg[0] + self.noise(4.0),
                y: state.lateral_accel_left_m_s2() / G * 1e3 + e.accel_bias_mg[1] + self.noise(4.0),
                z: 1e3 + e.accel_bias_mg[2] + self.noise(4.0),
            }
        };
        let gyro_dps = Xyz {
            x: e.gyro_bias_dps[0] + self.noise(0.1),
            y: e.gyro_bias_dps[1] + self.noise(0.1),
            // Board Z up: a clockwise (seen from above) turn is a negative rate about Z.
            z: -state.yaw_rate_dps + e.gyro_bias_dps[2] + self.noise(0.1),
        };
        let (sin_h, cos_h) = state.heading_deg.to_radians().sin_cos();
        let [n, east, d] = FIELD_NED_UT;
        let mag_ut = Xyz {
            x: n * cos_h + east * sin_h + self.noise(0.3),
            y: n * sin_h - east * cos_h + self.noise(0.3),
            z: -d + self.noise(0.3),
        };
        let physical = ImuPhysical {
            accel_mg: Xyz::new(accel_mg.x as f32, accel_mg.y as f32, accel_mg.z as f32),
            gyro_dps: Xyz::new(gyro_dps.x as f32, gyro_dps.y as f32, gyro_dps.z as f32),
            mag_ut: Xyz::new(mag_ut.x as f32, mag_ut.y as f32, mag_ut.z as f32),
        };
        if let Some(words) = packet_words_from_physical(
            &physical,
            AccelRange::G2,
            GyroRange::Dps2000,
            &self.trim,
            RHALL,
        ) {
            let b = words.to_le_bytes();
            let mut accel = [0u8; 6];
            let mut gyro = [0u8; 6];
            let mut mag = [0u8; 8];
            accel.copy_from_slice(&b[0..6]);
            gyro.copy_from_slice(&b[6..12]);
            mag.copy_from_slice(&b[12..20]);
            if !faults.imu_stuck {
                self.builder.accel_registers(accel).gyro_registers(gyro);
            }
            self.builder.mag_registers(mag);
        }

        let celsius = self.config.temperature_c + self.noise(0.02);
        let pascal = self.config.sea_level_pa
            * (1.0 - 2.255_77e-5 * self.config.height_msl_m).powf(5.255_88)
            + self.noise(1.5);
        let raw = raw_for_celsius_pascal_f32(&self.calibration, celsius as f32, pascal as f32);
        self.builder
            .pressure_raw(raw.adc_p)
            .temperature_raw(raw.adc_t)
            .gnss_frame(&self.gnss_frame);
        let packet = *self.builder.build(&mut Stm32Crc);

        self.take_info_snapshot(now_s);
        let info = self.pieces.next(restart).copied();
        Answer { packet, info }
    }

    /// Takes a new info snapshot (a version 2 frame cut into pieces) when the last one is
    /// [`INFO_SNAPSHOT_MS`] old, as the firmware's sampling task does.
    fn take_info_snapshot(&mut self, now_s: f64) {
        let every_s = f64::from(INFO_SNAPSHOT_MS) * 1e-3;
        if self.last_snapshot_s.is_some_and(|t| now_s - t < every_s) {
            return;
        }
        self.last_snapshot_s = Some(now_s);
        self.snapshot = self.snapshot.wrapping_add(1);
        let set = InfoFrame {
            version: 2,
            firmware: [0, 1, 0],
            status: SensorStatus::ACCEL_OK
                | SensorStatus::GYRO_OK
                | SensorStatus::MAG_OK
                | SensorStatus::BMP280_OK
                | SensorStatus::GNSS_SEEN,
            bmp280_calibration: DATASHEET_BMP280_CALIBRATION,
            bmm150_trim: BMM150_TRIM,
            uptime_ms: (now_s * 1e3) as u32,
            requests_skipped: self.requests_skipped,
            // The simulated sensors never fail; each is read for every packet.
            health: BoardHealth::default(),
            // Not in a version 2 frame (the board's version 3 adds them).
            faults: BoardFaults::default(),
        }
        .encode_v2_pieces_with(self.snapshot, &mut Stm32Crc);
        self.pieces.publish(&set);
    }

    /// A new NAV-PVT epoch every `1 / gnss_rate_hz` s of simulated time (without a fix when
    /// `lost`).
    fn update_gnss(&mut self, now_s: f64, state: &VehicleState, lost: bool) {
        let period = 1.0 / self.config.gnss_rate_hz.max(0.1);
        let epoch = (now_s / period).floor().max(0.0) as u64 + 1;
        if epoch <= self.gnss_epochs {
            return;
        }
        self.gnss_epochs = epoch;
        let epoch_s = (epoch - 1) as f64 * period;
        let c = self.config;
        let lat0 = c.start_lat_deg.to_radians();
        let north = state.north_m + self.noise(0.3);
        let east = state.east_m + self.noise(0.3);
        let lat = c.start_lat_deg + (north / EARTH_RADIUS_M).to_degrees();
        let lon = c.start_lon_deg + (east / (EARTH_RADIUS_M * lat0.cos())).to_degrees();
        let vn = state.vel_north_m_s() + self.noise(0.03);
        let ve = state.vel_east_m_s() + self.noise(0.03);
        let g_speed = vn.hypot(ve);
        // The receiver keeps the last heading of motion when nearly stopped.
        if g_speed > 0.1 {
            self.last_head_mot_deg = ve.atan2(vn).to_degrees().rem_euclid(360.0);
        }
        let itow_ms = START_ITOW_MS.wrapping_add((epoch_s * 1e3).round() as u32);
        let utc_s = 8 * 3600 + (epoch_s as u64);
        let pvt = neo_m8t::NavPvt {
            itow_ms,
            year: 2026,
            month: 11,
            day: 22,
            hour: ((utc_s / 3600) % 24) as u8,
            min: ((utc_s / 60) % 60) as u8,
            sec: (utc_s % 60) as u8,
            valid: neo_m8t::nav_pvt::VALID_DATE
                | neo_m8t::nav_pvt::VALID_TIME
                | neo_m8t::nav_pvt::VALID_FULLY_RESOLVED,
            t_acc_ns: 25,
            nano_ns: ((epoch_s.fract()) * 1e9) as i32,
            fix_type: if lost { 0 } else { 3 },
            flags: if lost {
                0
            } else {
                neo_m8t::nav_pvt::FLAG_GNSS_FIX_OK
            },
            flags2: 0xE0,
            num_sv: 12,
            lon_deg_e7: (lon * 1e7).round() as i32,
            lat_deg_e7: (lat * 1e7).round() as i32,
            height_mm: ((c.height_msl_m + 32.0) * 1e3) as i32,
            h_msl_mm: (c.height_msl_m * 1e3) as i32,
            h_acc_mm: 1_200,
            v_acc_mm: 1_900,
            vel_n_mm_s: (vn * 1e3).round() as i32,
            vel_e_mm_s: (ve * 1e3).round() as i32,
            vel_d_mm_s: 0,
            g_speed_mm_s: (g_speed * 1e3).round() as i32,
            head_mot_deg_e5: (self.last_head_mot_deg * 1e5).round() as i32 % 36_000_000,
            s_acc_mm_s: 150,
            head_acc_deg_e5: if g_speed > 0.5 { 80_000 } else { 18_000_000 },
            p_dop_e2: 130,
            reserved1: [0; 6],
            head_veh_deg_e5: 0,
            mag_dec_deg_e2: -2_600,
            mag_acc_deg_e2: 100,
        };
        self.gnss_frame = *pvt.to_frame().as_bytes();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bosch_bmp280::compensation::{pressure_pa_f32, temperature_celsius_f32};
    use dima_sensorboard::{units, Frame, StreamDecoder};

    fn exact() -> BoardSim {
        BoardSim::new(
            BoardConfig {
                noise: false,
                ..BoardConfig::default()
            },
            SimRng::new(1),
        )
    }

    fn decode(bytes: &[u8]) -> Vec<Frame> {
        let mut d = StreamDecoder::new();
        let mut input = bytes;
        let mut out = Vec::new();
        while let Some(f) = d.feed(&mut input) {
            out.push(f);
        }
        out
    }

    #[test]
    fn datasheet_calibration_constant_is_the_vector() {
        // Bosch BMP280 datasheet calculation example, as in the project's vectors.
        let c = Calibration::from_bytes(&DATASHEET_BMP280_CALIBRATION);
        assert_eq!((c.dig_t1, c.dig_t2, c.dig_t3), (27504, 26435, -1000));
        assert_eq!((c.dig_p1, c.dig_p2, c.dig_p9), (36477, -10685, 6000));
    }

    #[test]
    fn info_pieces_behind_the_packets_like_the_firmware() {
        let mut b = exact();
        let s = VehicleState::default();
        let mut stream = Vec::new();
        let mut pieces = 0;
        // 2 s of requests at 250 Hz: a snapshot every 250 ms, each sent once in 9 pieces.
        for i in 0..500 {
            if i == 300 {
                b.skip_request();
            }
            let a = b.answer(0.010 + f64::from(i) * 0.004, &s);
            stream.extend_from_slice(&a.packet);
            if let Some(piece) = a.info {
                pieces += 1;
                stream.extend_from_slice(&piece);
            }
        }
        assert_eq!(pieces, 8 * 9);
        let frames = decode(&stream);
        let infos: Vec<_> = frames
            .iter()
            .filter_map(|f| match f {
                Frame::Info(i) => Some(*i),
                Frame::Packet(_) => None,
            })
            .collect();
        assert_eq!(frames.len() - infos.len(), 500);
        let uptimes: Vec<u32> = infos.iter().map(|i| i.uptime_ms).collect();
        // The first request at least 250 ms after the last snapshot: every 63rd, 252 ms apart.
        assert_eq!(uptimes, [10, 262, 514, 766, 1018, 1270, 1522, 1774]);
        let info = infos[7];
        assert_eq!(info.version, 2);
        assert_eq!(info.bmp280_calibration, DATASHEET_BMP280_CALIBRATION);
        assert_eq!(info.bmm150_trim, BMM150_TRIM);
        assert_eq!(info.requests_skipped, 1);
        assert_eq!(infos[4].requests_skipped, 0);
    }

    #[test]
    fn a_host_restart_gets_a_record_within_nine_answers() {
        let mut b = exact();
        let s = VehicleState::default();
        for i in 0..5 {
            b.answer(0.010 + f64::from(i) * 0.004, &s);
        }
        // The host stops mid-record and comes back 600 ms later: piece 0 again.
        let mut stream = Vec::new();
        for i in 0..9 {
            let a = b.answer(0.630 + f64::from(i) * 0.004, &s);
            stream.extend_from_slice(&a.packet);
            stream.extend_from_slice(&a.info.expect("a piece behind each packet"));
        }
        let infos = decode(&stream)
            .into_iter()
            .filter(|f| matches!(f, Frame::Info(_)))
            .count();
        assert_eq!(infos, 1);
    }

    #[test]
    fn packet_decodes_to_the_model_values() {
        let mut b = exact();
        let state = VehicleState {
            t_s: 1.0,
            north_m: 100.0,
            east_m: -50.0,
            heading_deg: 90.0,
            speed_m_s: 3.0,
            accel_m_s2: 0.9806_65,
            yaw_rate_dps: 30.0,
            tail_yaw_dps: 0.0,
        };
        let a = b.answer(1.0, &state);
        let frames = decode(&a.packet);
        let Frame::Packet(raw) = frames[0] else {
            panic!("packet")
        };
        let p = raw.decode();
        // 0.1 g forward; 1 g up; lateral -v*r = -3 * 0.5236 = -1.571 m/s² = -160 mg. The
        // board and the host use the same scale (2 g over 2048 counts): within a count.
        let mg = p.accel.map(units::accel_mg_2g);
        assert!((mg[0] - 100.0).abs() < 1.5, "{mg:?}");
        assert!((mg[1] + 160.2).abs() < 1.5, "{mg:?}");
        assert!((mg[2] - 1000.0).abs() < 1.5, "{mg:?}");
        assert!(
            (units::gyro_dps_2000(p.gyro[2]) + 30.0).abs() < 0.1,
            "{:?}",
            p.gyro
        );
        // BMP280 through the real compensation: 22 °C, 12 m above sea level.
        let (celsius, t_fine) = temperature_celsius_f32(&b.calibration, p.temp_raw);
        let pa = pressure_pa_f32(&b.calibration, t_fine, p.press_raw).unwrap();
        assert!((celsius - 22.0).abs() < 0.01, "{celsius}");
        assert!((pa - 101_181.0).abs() < 5.0, "{pa}");
        // Magnetometer through the real trim compensation: heading east, field north 9.7 µT
        // shows on the left axis (y), east component -4.7 µT on x, 23.1 µT up on z.
        let m = dima_sensorboard::imu::ImuPacketWords::from_le_bytes(
            a.packet[2..22].try_into().unwrap(),
        );
        let ut = bosch_bmx055::mag::compensate_f32(&m.mag_raw(), &b.trim);
        assert!((ut.x + 4.7).abs() < 1.5, "{ut:?}");
        assert!((ut.y - 9.7).abs() < 1.5, "{ut:?}");
        assert!((ut.z - 23.1).abs() < 1.5, "{ut:?}");
        // GNSS: the position, velocity and heading of the model.
        let pvt = p.nav_pvt().expect("NAV-PVT");
        assert_eq!(pvt.g_speed_mm_s, 3_000);
        assert_eq!(pvt.vel_e_mm_s, 3_000);
        assert_eq!(pvt.head_mot_deg_e5, 9_000_000);
        assert!((pvt.lat_deg() - (-34.0885 + 100.0 / 111_194.9)).abs() < 1e-6);
        assert!(pvt.gnss_fix_ok());
    }

    #[test]
    fn a_rolled_over_car_reads_gravity_along_its_side_and_nothing_else_changes() {
        let mut b = exact();
        let state = VehicleState {
            accel_m_s2: 2.0,
            ..VehicleState::default()
        };
        let decoded = |a: &Answer| match decode(&a.packet).first() {
            Some(Frame::Packet(raw)) => raw.decode(),
            other => panic!("not a packet: {other:?}"),
        };
        let upright = decoded(&b.answer(0.05, &state));
        let rolled = SensorFaultState {
            rolled_over: true,
            ..SensorFaultState::default()
        };
        let side = decoded(&b.answer_with(0.06, &state, rolled));
        let mg = side.accel.map(units::accel_mg_2g);
        assert!((mg[1] - 1_000.0).abs() < 20.0, "{mg:?}");
        assert!(mg[0].abs() < 20.0 && mg[2].abs() < 20.0, "{mg:?}");
        assert!(upright.accel.map(units::accel_mg_2g)[2] > 980.0);
        assert_eq!(side.gyro, upright.gyro);
    }

    #[test]
    fn sensor_faults_freeze_gnss_and_imu_words() {
        let mut b = exact();
        let state = VehicleState::default();
        let decoded = |a: &Answer| match decode(&a.packet).first() {
            Some(Frame::Packet(raw)) => raw.decode(),
            other => panic!("not a packet: {other:?}"),
        };
        let first = decoded(&b.answer(0.05, &state));
        let moving = VehicleState {
            yaw_rate_dps: 30.0,
            accel_m_s2: 2.0,
            ..state
        };
        let frozen = SensorFaultState {
            gnss_frozen: true,
            imu_stuck: true,
            ..SensorFaultState::default()
        };
        let later = decoded(&b.answer_with(0.55, &moving, frozen));
        assert_eq!(later.gnss, first.gnss, "the same NAV-PVT, byte for byte");
        assert_eq!((later.accel, later.gyro), (first.accel, first.gyro));
        let lost = SensorFaultState {
            gnss_lost: true,
            ..SensorFaultState::default()
        };
        let p = decoded(&b.answer_with(0.65, &moving, lost));
        let pvt = p.nav_pvt().unwrap();
        assert_eq!((pvt.fix_type, pvt.gnss_fix_ok()), (0, false));
        assert!(
            pvt.itow_ms > first.nav_pvt().unwrap().itow_ms,
            "time goes on"
        );
        assert_ne!(p.gyro, first.gyro, "the IMU moves again");
    }

    #[test]
    fn gnss_epochs_at_ten_hertz() {
        let mut b = exact();
        let s = VehicleState::default();
        let mut itows = Vec::new();
        for i in 0..250 {
            let a = b.answer(f64::from(i) * 0.004, &s);
            let p = decode(&a.packet);
            let Frame::Packet(raw) = p[0] else { panic!() };
            let itow = raw.decode().nav_pvt().unwrap().itow_ms;
            if itows.last() != Some(&itow) {
                itows.push(itow);
            }
        }
        assert_eq!(itows.len(), 10);
        assert!(itows.windows(2).all(|w| w[1] - w[0] == 100));
        assert_eq!(b.gnss_epochs(), 10);
    }

    #[test]
    fn noise_is_seeded() {
        let s = VehicleState::default();
        let mut a = BoardSim::new(BoardConfig::default(), SimRng::new(9));
        let mut b = BoardSim::new(BoardConfig::default(), SimRng::new(9));
        let mut c = BoardSim::new(BoardConfig::default(), SimRng::new(10));
        let (pa, pb, pc) = (a.answer(0.1, &s), b.answer(0.1, &s), c.answer(0.1, &s));
        assert_eq!(pa, pb);
        assert_ne!(pa.packet, pc.packet);
    }
}
