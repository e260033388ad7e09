//! Sketch of the sensor-board sampling task (±2 g / 1000 Hz, ±2000 °/s / 0x81, magnetometer low-power preset in forced mode), written against the
//! embedded-hal traits so it builds anywhere; `main` runs it on mocked buses.
//!
//! On the STM32F4 board the three SPI devices come from one SPI1 bus (PA5 SCK, PA6 MISO,
//! PA7 MOSI, mode 3) shared through `embedded-hal-bus` (`AtomicDevice` or
//! `CriticalSectionDevice`, since RTIC resources must be `Send`), with chip selects PE7
//! (accelerometer), PE8 (gyroscope) and PE9 (magnetometer). At boot the firmware calls
//! `Bmx055::init(&mut delay, &IMU_CONFIG)` and sends the returned trim to the host;
//! a timer task then calls [`sample_words`] and hands the words to its packet format (the DIMA
//! board: `dima_sensorboard::imu::ImuPacketWords::from_sample`).

use bosch_bmx055::{Bmx055, Bmx055Config, Error, ImuSample};
use embedded_hal::spi::SpiDevice;
use embedded_hal_mock::eh1::delay::NoopDelay;
use embedded_hal_mock::eh1::spi::{Mock, Transaction as T};

type Imu<A, G, M> = Bmx055<
    bosch_bmx055::SpiInterface<A>,
    bosch_bmx055::SpiInterface<G>,
    bosch_bmx055::SpiInterface<M>,
>;

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

/// Timer task body: sample the three dies (no waiting); the words are left-justified with the
/// status bits masked, as a packet carries them.
fn sample_words<A, G, M, E>(imu: &mut Imu<A, G, M>) -> Result<ImuSample, Error<E>>
where
    A: SpiDevice<Error = E>,
    G: SpiDevice<Error = E>,
    M: SpiDevice<Error = E>,
{
    imu.sample()
}

fn w(reg: u8, v: u8) -> [T<u8>; 3] {
    [
        T::transaction_start(),
        T::write_vec(vec![reg, v]),
        T::transaction_end(),
    ]
}

fn r(reg: u8, resp: &[u8]) -> [T<u8>; 4] {
    [
        T::transaction_start(),
        T::write_vec(vec![reg | 0x80]),
        T::read_vec(resp.to_vec()),
        T::transaction_end(),
    ]
}

fn main() {
    let acc: Vec<T<u8>> = [
        w(0x14, 0xB6).to_vec(),
        r(0x00, &[0xFA]).to_vec(),
        w(0x0F, 0x03).to_vec(),
        w(0x10, 0x0F).to_vec(),
        w(0x11, 0x00).to_vec(),
        r(0x02, &[0x01, 0, 0, 0, 0x01, 0x40]).to_vec(),
    ]
    .concat();
    let gyro: Vec<T<u8>> = [
        w(0x14, 0xB6).to_vec(),
        r(0x00, &[0x0F]).to_vec(),
        w(0x0F, 0x00).to_vec(),
        w(0x10, 0x81).to_vec(),
        w(0x11, 0x00).to_vec(),
        r(0x02, &[0; 6]).to_vec(),
    ]
    .concat();
    let trim3 = [0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D];
    let mag: Vec<T<u8>> = [
        w(0x4B, 0x01).to_vec(),
        w(0x4B, 0x83).to_vec(),
        r(0x40, &[0x32]).to_vec(),
        r(0x5D, &[0, 0]).to_vec(),
        r(0x62, &[0, 0, 0x1A, 0x1A]).to_vec(),
        r(0x68, &trim3).to_vec(),
        w(0x51, 0x01).to_vec(),
        w(0x52, 0x02).to_vec(),
        w(0x4C, 0x02).to_vec(),
        r(0x42, &[0x80, 0x02, 0x20, 0xFE, 0xF4, 0xFE, 0x61, 0x6D]).to_vec(),
        w(0x4C, 0x02).to_vec(),
    ]
    .concat();
    let (mut a, mut g, mut m) = (Mock::new(&acc), Mock::new(&gyro), Mock::new(&mag));
    let mut imu = Bmx055::new_spi(a.clone(), g.clone(), m.clone());
    let trim = imu.init(&mut NoopDelay, &IMU_CONFIG).expect("init");
    let sample = sample_words(&mut imu).expect("sample");
    println!(
        "trim {trim:?}\nfresh mag: {}\naccel {:?} gyro {:?} mag {:?}",
        sample.mag_fresh, sample.accel.words, sample.gyro.words, sample.mag
    );
    a.done();
    g.done();
    m.done();
}
