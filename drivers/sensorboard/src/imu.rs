//! The BMX055 part of the sensor packet (bytes 2..=21): the accelerometer, gyroscope and
//! magnetometer words as the packet carries them, in both directions, with no I/O. The firmware
//! fills the packet from register reads without re-encoding; the host decodes and compensates
//! with the `bosch-bmx055` crate; a simulator builds words from physical values (feature `sim`).

use bosch_bmx055::accel::AccelRaw;
use bosch_bmx055::gyro::GyroRaw;
use bosch_bmx055::mag::{MagPacketWords, MagRaw};
use bosch_bmx055::{ImuSample, Xyz};

use crate::packet::{ACCEL_OFFSET, PRESSURE_OFFSET};

/// Offset of the first BMX055 byte (accelerometer X LSB) in the sensor packet.
pub const IMU_OFFSET: usize = ACCEL_OFFSET;
/// Number of BMX055 bytes in the sensor packet (accelerometer 6, gyroscope 6, magnetometer 6,
/// RHALL 2).
pub const IMU_LEN: usize = PRESSURE_OFFSET - ACCEL_OFFSET;

/// The accelerometer, gyroscope and magnetometer words of one sensor packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImuPacketWords {
    /// Accelerometer, 12-bit left-justified, status nibble masked.
    pub accel: Xyz<i16>,
    /// Gyroscope, 16-bit.
    pub gyro: Xyz<i16>,
    /// Magnetometer X/Y/Z and RHALL, left-justified, status bits masked.
    pub mag: MagPacketWords,
}

impl ImuPacketWords {
    /// Assembles the words from the three drivers' reads.
    pub const fn from_raw(accel: &AccelRaw, gyro: &GyroRaw, mag: MagPacketWords) -> Self {
        Self {
            accel: accel.words,
            gyro: gyro.words,
            mag,
        }
    }

    /// The words of one sample of all three dies ([`bosch_bmx055::Bmx055::sample`]).
    pub const fn from_sample(sample: &ImuSample) -> Self {
        Self::from_raw(&sample.accel, &sample.gyro, sample.mag)
    }

    /// The 20 packet bytes (packet offsets 2..=21), each word little-endian.
    pub fn to_le_bytes(&self) -> [u8; IMU_LEN] {
        let mut out = [0u8; IMU_LEN];
        let words = [
            self.accel.x,
            self.accel.y,
            self.accel.z,
            self.gyro.x,
            self.gyro.y,
            self.gyro.z,
            self.mag.xyz.x,
            self.mag.xyz.y,
            self.mag.xyz.z,
            self.mag.rhall as i16,
        ];
        for (chunk, w) in out.chunks_exact_mut(2).zip(words) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
        out
    }

    /// Parses the 20 packet bytes. Status bits are masked again, so any bytes decode.
    pub fn from_le_bytes(b: &[u8; IMU_LEN]) -> Self {
        let w = |i: usize| i16::from_le_bytes([b[2 * i], b[2 * i + 1]]);
        let mut mag_regs = [0u8; 8];
        mag_regs.copy_from_slice(&b[12..20]);
        Self {
            accel: Xyz::new(w(0) & !0x0F, w(1) & !0x0F, w(2) & !0x0F),
            gyro: Xyz::new(w(3), w(4), w(5)),
            mag: MagPacketWords::from_registers(&mag_regs),
        }
    }

    /// Accelerometer counts and flags (new-data flags are not carried and read `false`).
    pub fn accel_raw(&self) -> AccelRaw {
        AccelRaw {
            words: self.accel,
            new_data: Xyz::default(),
        }
    }

    /// Gyroscope sample.
    pub fn gyro_raw(&self) -> GyroRaw {
        GyroRaw { words: self.gyro }
    }

    /// Magnetometer sample, right-justified for compensation.
    pub fn mag_raw(&self) -> MagRaw {
        self.mag.to_raw()
    }
}

#[cfg(feature = "sim")]
mod physical {
    use bosch_bmx055::accel::{accel_mg_to_word, AccelRange};
    use bosch_bmx055::gyro::{gyro_dps_to_word, GyroRange};
    use bosch_bmx055::mag::{raw_x_for_ut, raw_y_for_ut, raw_z_for_ut, MagRaw, MagTrim};
    use bosch_bmx055::Xyz;

    use super::ImuPacketWords;

    /// Physical values a simulator wants the packet to report.
    #[derive(Debug, Clone, Copy, PartialEq)]
    #[cfg_attr(feature = "defmt", derive(defmt::Format))]
    pub struct ImuPhysical {
        /// Acceleration in mg.
        pub accel_mg: Xyz<f32>,
        /// Rate in °/s.
        pub gyro_dps: Xyz<f32>,
        /// Field in µT.
        pub mag_ut: Xyz<f32>,
    }

    /// Builds packet words from physical values (the simulator direction): accelerometer and
    /// gyroscope are rounded and saturated, the magnetometer axes come from the best-effort
    /// inverse compensation for `trim` at Hall resistance `rhall` (`bosch_bmx055::mag::inverse`).
    /// `None` if the magnetometer compensation cannot be inverted with this trim and `rhall`.
    pub fn packet_words_from_physical(
        value: &ImuPhysical,
        accel_range: AccelRange,
        gyro_range: GyroRange,
        trim: &MagTrim,
        rhall: u16,
    ) -> Option<ImuPacketWords> {
        let rhall = rhall & 0x3FFF;
        let mag = MagRaw {
            x: raw_x_for_ut(value.mag_ut.x, rhall, trim)?,
            y: raw_y_for_ut(value.mag_ut.y, rhall, trim)?,
            z: raw_z_for_ut(value.mag_ut.z, rhall, trim)?,
            rhall,
            data_ready: true,
        };
        Some(ImuPacketWords {
            accel: value.accel_mg.map(|mg| accel_mg_to_word(mg, accel_range)),
            gyro: value.gyro_dps.map(|d| gyro_dps_to_word(d, gyro_range)),
            mag: mag.packet_words(),
        })
    }
}

#[cfg(feature = "sim")]
#[cfg_attr(docsrs, doc(cfg(feature = "sim")))]
pub use physical::{packet_words_from_physical, ImuPhysical};
