//! Pins the waits the drivers actually request and the self-test limits against Bosch's
//! published values. Waits may be longer than documented, never shorter; limits must be
//! exactly the documented ones.

mod common;

use bosch_bmx055::accel::Accelerometer;
use bosch_bmx055::accel::{SELF_TEST_MIN_MG, SELF_TEST_SETTLE_MS};
use bosch_bmx055::gyro::Gyroscope;
use bosch_bmx055::mag::Magnetometer;
use common::{read, write};
use embedded_hal::delay::DelayNs;
use embedded_hal_mock::eh1::spi::Mock as SpiMock;

/// Records every requested wait, in ns.
#[derive(Default)]
struct Recorder(Vec<u64>);

impl DelayNs for Recorder {
    fn delay_ns(&mut self, ns: u32) {
        self.0.push(ns.into());
    }
    fn delay_us(&mut self, us: u32) {
        self.0.push(u64::from(us) * 1_000);
    }
    fn delay_ms(&mut self, ms: u32) {
        self.0.push(u64::from(ms) * 1_000_000);
    }
}

impl Recorder {
    fn total_ns(&self) -> u64 {
        self.0.iter().sum()
    }
}

#[test]
fn accelerometer_soft_reset_waits_at_least_1_8_ms() {
    // Bosch BMA2 SensorAPI (bma2_defs.h / bma2_soft_reset): BMA2_DELAY_SOFT_RESET 1800 µs.
    let mut spi = SpiMock::new(&write(0x14, 0xB6));
    let mut acc = Accelerometer::new_spi(spi.clone());
    let mut delay = Recorder::default();
    acc.soft_reset(&mut delay).unwrap();
    assert!(delay.total_ns() >= 1_800_000, "{:?}", delay.0);
    spi.done();
}

#[test]
fn accelerometer_self_test_settles_50_ms_and_uses_the_documented_limits() {
    // Bosch BMA2 SensorAPI (bma2.c, self_test_excitation_data): wait 50 ms after each
    // excitation before reading.
    assert_eq!(SELF_TEST_SETTLE_MS, 50);
    // Bosch BMA2 SensorAPI (bma2_defs.h): BMA2_ST_ACC_X/Y/Z_AXIS_SIGNAL_DIFF 800, 800, 400 mg.
    assert_eq!(
        (SELF_TEST_MIN_MG.x, SELF_TEST_MIN_MG.y, SELF_TEST_MIN_MG.z),
        (800.0, 800.0, 400.0)
    );
    let mut parts = vec![write(0x0F, 0x05)];
    for (pos, neg) in [(0x15, 0x11), (0x16, 0x12), (0x17, 0x13)] {
        parts.push(write(0x32, pos));
        parts.push(read(0x02, &[0; 6]));
        parts.push(write(0x32, neg));
        parts.push(read(0x02, &[0; 6]));
    }
    parts.push(write(0x32, 0x00));
    parts.push(write(0x14, 0xB6));
    let mut spi = SpiMock::new(&parts.concat());
    let mut acc = Accelerometer::new_spi(spi.clone());
    let mut delay = Recorder::default();
    let r = acc.self_test(&mut delay).unwrap();
    assert!(!r.passed(), "no deflection must fail");
    let settles = delay.0.iter().filter(|&&ns| ns >= 50_000_000).count();
    assert_eq!(settles, 6, "{:?}", delay.0);
    spi.done();
}

#[test]
fn gyroscope_soft_reset_waits_the_30_ms_start_up() {
    // BMX055 datasheet (BST-BMX055-DS000), key features, gyroscope: "30ms start-up time".
    let mut spi = SpiMock::new(&write(0x14, 0xB6));
    let mut gyro = Gyroscope::new_spi(spi.clone());
    let mut delay = Recorder::default();
    gyro.soft_reset(&mut delay).unwrap();
    assert!(delay.total_ns() >= 30_000_000, "{:?}", delay.0);
    spi.done();
}

#[test]
fn magnetometer_power_on_and_soft_reset_waits() {
    // Bosch BMM150 SensorAPI (bmm150_defs.h): BMM150_START_UP_TIME 3 ms after setting the
    // power bit (bmm150_init), BMM150_SOFT_RESET_DELAY 1 ms after the soft reset.
    let mut spi = SpiMock::new(&[write(0x4B, 0x01), write(0x4B, 0x83)].concat());
    let mut mag = Magnetometer::new_spi(spi.clone());
    let mut delay = Recorder::default();
    mag.power_on(&mut delay).unwrap();
    assert!(delay.total_ns() >= 3_000_000, "{:?}", delay.0);
    let mut delay = Recorder::default();
    mag.soft_reset(&mut delay).unwrap();
    assert!(delay.total_ns() >= 1_000_000, "{:?}", delay.0);
    spi.done();
}

#[test]
fn magnetometer_overflow_codes() {
    use bosch_bmx055::mag;
    // Bosch BMM150 SensorAPI (bmm150_defs.h): BMM150_XYAXES_FLIP_OVERFLOW_ADCVAL -4096,
    // BMM150_ZAXIS_HALL_OVERFLOW_ADCVAL -16384, BMM150_OVERFLOW_OUTPUT -32768,
    // BMM150_OVERFLOW_OUTPUT_FLOAT 0.0.
    assert_eq!(mag::OVERFLOW_XY, -4096);
    assert_eq!(mag::OVERFLOW_Z, -16384);
    assert_eq!(mag::OVERFLOW_OUTPUT, -32768);
    assert_eq!(mag::OVERFLOW_OUTPUT_F32, 0.0);
}
