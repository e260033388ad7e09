//! The BMX055 words of the sensor packet: the layout of bytes 2..=21, the same bytes as the
//! builder's register writers and the decoder's counts, and (feature `sim`) physical values
//! through the packet.

use bosch_bmx055::accel::AccelRaw;
use bosch_bmx055::gyro::GyroRaw;
use bosch_bmx055::mag::{compensate_f32, MagPacketWords, MagTrim};
use bosch_bmx055::{ImuSample, Xyz};
use dima_sensorboard::imu::{ImuPacketWords, IMU_LEN, IMU_OFFSET};
use dima_sensorboard::{PacketBuilder, SensorPacket};
use proptest::prelude::*;

const ACC_REGS: [u8; 6] = [0x11, 0x00, 0xF1, 0xFF, 0x01, 0x40];
const GYRO_REGS: [u8; 6] = [0x90, 0x02, 0x70, 0xFD, 0x00, 0x00];
// Shared BMM150 vector row 1 (Bosch SensorAPI), data-ready bit set.
const MAG_REGS: [u8; 8] = [0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D];

fn vector_trim() -> MagTrim {
    MagTrim::from_bursts(
        &[0x00, 0x00],
        &[0x00, 0x00, 0x1A, 0x1A],
        &[0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D],
    )
}

fn sample() -> ImuSample {
    ImuSample {
        accel: AccelRaw::from_registers(&ACC_REGS),
        gyro: GyroRaw::from_registers(&GYRO_REGS),
        mag: MagPacketWords::from_registers(&MAG_REGS),
        mag_fresh: true,
    }
}

#[test]
fn the_words_are_packet_bytes_2_to_21() {
    assert_eq!((IMU_OFFSET, IMU_LEN), (2, 20));
    let bytes = ImuPacketWords::from_sample(&sample()).to_le_bytes();
    assert_eq!(
        bytes,
        [
            0x10, 0x00, 0xF0, 0xFF, 0x00, 0x40, // accel, status nibble masked
            0x90, 0x02, 0x70, 0xFD, 0x00, 0x00, // gyro
            0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x60, 0x6D, // mag, DRDY masked
        ]
    );
    let raw = ImuPacketWords::from_le_bytes(&bytes).mag_raw();
    assert_eq!(compensate_f32(&raw, &vector_trim()).x.round(), 29.0);
}

#[test]
fn the_builder_writes_the_same_bytes_from_words_or_registers() {
    let mut from_words = PacketBuilder::new();
    from_words.imu_words(&ImuPacketWords::from_sample(&sample()));
    let mut from_registers = PacketBuilder::new();
    from_registers
        .accel_registers(ACC_REGS)
        .gyro_registers(GYRO_REGS)
        .mag_registers(MAG_REGS);
    assert_eq!(from_words, from_registers);
    let mut crc = dima_sensorboard::Stm32Crc;
    let packet = SensorPacket::decode(from_words.build(&mut crc)).unwrap();
    assert_eq!(packet.accel, [1, -1, 1024]);
    assert_eq!(
        ImuPacketWords::from_sample(&sample()).accel_raw().counts(),
        Xyz::new(1, -1, 1024)
    );
}

proptest! {
    #[test]
    fn packet_bytes_round_trip(b: [u8; 20]) {
        let words = ImuPacketWords::from_le_bytes(&b);
        prop_assert_eq!(ImuPacketWords::from_le_bytes(&words.to_le_bytes()), words);
    }
}

#[cfg(feature = "sim")]
proptest! {
    #[test]
    fn physical_values_survive_the_packet(
        ax in -1900f32..1900f32, gz in -1900f32..1900f32,
        mx in -500f32..500f32, mz in -1000f32..1000f32,
    ) {
        use bosch_bmx055::accel::{accel_word_to_mg, AccelRange};
        use bosch_bmx055::gyro::{gyro_word_to_dps, GyroRange};
        use dima_sensorboard::imu::{packet_words_from_physical, ImuPhysical};
        let trim = vector_trim();
        let phys = ImuPhysical {
            accel_mg: Xyz::new(ax, 0.0, 1000.0),
            gyro_dps: Xyz::new(0.0, 0.0, gz),
            mag_ut: Xyz::new(mx, 0.0, mz),
        };
        let words = packet_words_from_physical(
            &phys, AccelRange::G2, GyroRange::Dps2000, &trim, 7053,
        ).unwrap();
        let decoded = ImuPacketWords::from_le_bytes(&words.to_le_bytes());
        prop_assert!((accel_word_to_mg(decoded.accel.x, AccelRange::G2) - ax).abs() <= 0.5);
        prop_assert!((gyro_word_to_dps(decoded.gyro.z, GyroRange::Dps2000) - gz).abs() <= 0.031);
        let ut = compensate_f32(&decoded.mag_raw(), &trim);
        prop_assert!((ut.x - mx).abs() <= 0.2, "x {} vs {}", ut.x, mx);
        prop_assert!((ut.z - mz).abs() <= 0.2, "z {} vs {}", ut.z, mz);
    }
}
