//! The STM32 CRC unit as the sensor packet CRC.

use dima_sensorboard::SensorCrc;
use stm32f4xx_hal::crc32::Crc32;

/// The hardware CRC unit, fed one zero-extended byte per 32-bit word as the original board did
/// (the HAL's `update_bytes` packs four bytes per word, which is a different CRC).
pub struct HwCrc(pub Crc32);

impl SensorCrc for HwCrc {
    fn checksum(&mut self, bytes: &[u8]) -> u32 {
        self.0.init();
        let mut value = 0xFFFF_FFFF;
        for &byte in bytes {
            value = self.0.update(&[u32::from(byte)]);
        }
        value
    }
}
