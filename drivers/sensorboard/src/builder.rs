//! Board side: assembling a packet from sensor readings and the latest NAV-PVT frame.

use crate::crc::SensorCrc;
use crate::gnss::GNSS_FRAME_LEN;
use crate::imu::{ImuPacketWords, IMU_LEN, IMU_OFFSET};
use crate::packet::{
    encode_adc20, ACCEL_OFFSET, ACCEL_RANGE, CRC_OFFSET, GNSS_OFFSET, GYRO_OFFSET, MAG_OFFSET,
    MAG_XY_RANGE, MAG_Z_RANGE, PACKET_CRC_COVERED, PACKET_LEN, PACKET_START, PRESSURE_OFFSET,
    RHALL_MAX, RHALL_OFFSET, TEMPERATURE_OFFSET,
};

/// Assembles a v1 sensor packet in place.
///
/// The firmware keeps one builder per buffer of its double buffer, writes each reading as it
/// arrives (register bytes as read, or counts), and calls [`PacketBuilder::build`] to fill in
/// the CRC with whatever [`SensorCrc`] it has (the STM32 CRC unit). Fields not written stay
/// zero; the GNSS area stays zero until a NAV-PVT frame is given, which is what the original
/// board sends before its first fix message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PacketBuilder {
    bytes: [u8; PACKET_LEN],
}

impl Default for PacketBuilder {
    fn default() -> Self {
        Self::new()
    }
}

/// Clamps `value` into `range` (inclusive).
const fn clamp_i16(value: i16, range: (i16, i16)) -> i16 {
    if value < range.0 {
        range.0
    } else if value > range.1 {
        range.1
    } else {
        value
    }
}

impl PacketBuilder {
    /// A packet with the start token and every other byte zero.
    #[must_use]
    pub const fn new() -> Self {
        let mut bytes = [0u8; PACKET_LEN];
        bytes[0] = PACKET_START[0];
        bytes[1] = PACKET_START[1];
        Self { bytes }
    }

    fn put_words(&mut self, offset: usize, words: [i16; 3]) {
        for (i, word) in words.iter().enumerate() {
            let at = offset + 2 * i;
            self.bytes[at..at + 2].copy_from_slice(&word.to_le_bytes());
        }
    }

    /// Accelerometer counts (12-bit signed, saturated to [`ACCEL_RANGE`]), stored
    /// left-justified as the BMX055 delivers them.
    pub fn accel(&mut self, counts: [i16; 3]) -> &mut Self {
        self.put_words(ACCEL_OFFSET, counts.map(|c| clamp_i16(c, ACCEL_RANGE) << 4));
        self
    }

    /// Accelerometer data registers 0x02..=0x07 as read (X LSB, X MSB, ... Z MSB). The
    /// new-data bits in each LSB are masked off (`& 0xF0`) as on the original board.
    pub fn accel_registers(&mut self, registers: [u8; 6]) -> &mut Self {
        let mut masked = registers;
        for lsb in masked.iter_mut().step_by(2) {
            *lsb &= 0xF0;
        }
        self.bytes[ACCEL_OFFSET..ACCEL_OFFSET + 6].copy_from_slice(&masked);
        self
    }

    /// The accelerometer, gyroscope and magnetometer words at once (packet bytes 2..=21), as
    /// [`ImuPacketWords::to_le_bytes`] lays them out.
    pub fn imu_words(&mut self, words: &ImuPacketWords) -> &mut Self {
        self.bytes[IMU_OFFSET..IMU_OFFSET + IMU_LEN].copy_from_slice(&words.to_le_bytes());
        self
    }

    /// Gyroscope counts (full 16-bit signed).
    pub fn gyro(&mut self, counts: [i16; 3]) -> &mut Self {
        self.put_words(GYRO_OFFSET, counts);
        self
    }

    /// Gyroscope data registers 0x02..=0x07 as read.
    pub fn gyro_registers(&mut self, registers: [u8; 6]) -> &mut Self {
        self.bytes[GYRO_OFFSET..GYRO_OFFSET + 6].copy_from_slice(&registers);
        self
    }

    /// Magnetometer counts: X and Y saturated to [`MAG_XY_RANGE`], Z to [`MAG_Z_RANGE`],
    /// `rhall` to [`RHALL_MAX`]; stored left-justified as the BMM150 delivers them.
    pub fn mag(&mut self, xyz: [i16; 3], rhall: u16) -> &mut Self {
        self.put_words(
            MAG_OFFSET,
            [
                clamp_i16(xyz[0], MAG_XY_RANGE) << 3,
                clamp_i16(xyz[1], MAG_XY_RANGE) << 3,
                clamp_i16(xyz[2], MAG_Z_RANGE) << 1,
            ],
        );
        let rhall = if rhall > RHALL_MAX { RHALL_MAX } else { rhall };
        self.bytes[RHALL_OFFSET..RHALL_OFFSET + 2].copy_from_slice(&(rhall << 2).to_le_bytes());
        self
    }

    /// Magnetometer data registers 0x42..=0x49 as read (X, Y, Z, RHALL; LSB first). The status
    /// bits below each value are masked off (X/Y `& 0xF8`, Z `& 0xFE`, RHALL `& 0xFC`).
    pub fn mag_registers(&mut self, registers: [u8; 8]) -> &mut Self {
        let mut masked = registers;
        masked[0] &= 0xF8;
        masked[2] &= 0xF8;
        masked[4] &= 0xFE;
        masked[6] &= 0xFC;
        self.bytes[MAG_OFFSET..MAG_OFFSET + 8].copy_from_slice(&masked);
        self
    }

    /// BMP280 raw pressure `adc_P` (20 bits; larger values saturate).
    pub fn pressure_raw(&mut self, adc_p: u32) -> &mut Self {
        self.bytes[PRESSURE_OFFSET..PRESSURE_OFFSET + 3].copy_from_slice(&encode_adc20(adc_p));
        self
    }

    /// BMP280 raw temperature `adc_T` (20 bits; larger values saturate).
    pub fn temperature_raw(&mut self, adc_t: u32) -> &mut Self {
        self.bytes[TEMPERATURE_OFFSET..TEMPERATURE_OFFSET + 3]
            .copy_from_slice(&encode_adc20(adc_t));
        self
    }

    /// BMP280 data registers 0xF7..=0xFC as read (pressure MSB, LSB, XLSB, temperature MSB,
    /// LSB, XLSB), copied unchanged.
    pub fn bmp280_registers(&mut self, registers: [u8; 6]) -> &mut Self {
        self.bytes[PRESSURE_OFFSET..PRESSURE_OFFSET + 6].copy_from_slice(&registers);
        self
    }

    /// The latest NAV-PVT frame from the receiver, copied verbatim (or zeros: no frame yet).
    pub fn gnss_frame(&mut self, frame: &[u8; GNSS_FRAME_LEN]) -> &mut Self {
        self.bytes[GNSS_OFFSET..GNSS_OFFSET + GNSS_FRAME_LEN].copy_from_slice(frame);
        self
    }

    /// Fills in the CRC of bytes 0..=127 computed by `crc` and returns the finished packet.
    ///
    /// The builder keeps its contents, so the next packet only needs the fields that changed.
    pub fn build(&mut self, crc: &mut impl SensorCrc) -> &[u8; PACKET_LEN] {
        let value = crc.checksum(&self.bytes[..PACKET_CRC_COVERED]);
        self.bytes[CRC_OFFSET..].copy_from_slice(&value.to_le_bytes());
        &self.bytes
    }

    /// The bytes as they are now (the CRC is whatever the last [`PacketBuilder::build`] wrote).
    #[must_use]
    pub const fn as_bytes(&self) -> &[u8; PACKET_LEN] {
        &self.bytes
    }
}
