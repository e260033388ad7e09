//! The four sensor dies on SPI1, driven by the workspace's driver crates.
//!
//! At boot each die is brought up on its own (soft reset, chip id with bounded retries, DIMA
//! configuration), so one that never answers only clears its status bit: it is reported in the
//! info frame and on the status LED, its packet fields stay zero, and the board keeps running.
//! Afterwards [`Sensors::tick`] does what the sampling schedule says and writes the register
//! words into the packet being assembled.

use crate::dima;
use crate::schedule::{MagAction, Schedule, TickPlan};
use bosch_bmp280::{Bmp280, SpiInterface as BaroSpi};
use bosch_bmx055::accel::{AccelRaw, Accelerometer};
use bosch_bmx055::gyro::{GyroRaw, Gyroscope};
use bosch_bmx055::mag::{MagPacketWords, Magnetometer};
use bosch_bmx055::SpiInterface;
use dima_sensorboard::imu::ImuPacketWords;
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
    /// Failed transfers after boot per die: accelerometer, gyroscope, magnetometer, BMP280.
    errors: [u32; 4],
    /// Tick of the last good read per die (same order); `None` until the first one.
    last_good: [Option<u32>; 4],
    /// Ticks since boot.
    ticks: u32,
}

/// Index of each die in [`Sensors::errors`] and [`Sensors::ages_ms`].
const ACCEL: usize = 0;
const GYRO: usize = 1;
const MAG: usize = 2;
const BARO: usize = 3;

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
        if accel.init(delay, &dima::ACCEL).is_ok() {
            report.status |= SensorStatus::ACCEL_OK;
        }
        let mut gyro = Gyroscope::new_spi(gyro);
        if gyro.init(delay, &dima::GYRO).is_ok() {
            report.status |= SensorStatus::GYRO_OK;
        }
        let mut mag = Magnetometer::new_spi(mag);
        if let Ok(trim) = mag.init(delay, &dima::MAG) {
            report.status |= SensorStatus::MAG_OK;
            let (low, mid, high) = trim.to_bursts();
            report.bmm150_trim[..2].copy_from_slice(&low);
            report.bmm150_trim[2..6].copy_from_slice(&mid);
            report.bmm150_trim[6..].copy_from_slice(&high);
        }
        let mut baro = Bmp280::new_spi(baro);
        for _ in 0..BARO_ATTEMPTS {
            if baro.init(delay).is_ok() && baro.configure(dima::BAROMETER).is_ok() {
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
            errors: [0; 4],
            last_good: [None; 4],
            ticks: 0,
        };
        (sensors, report)
    }

    /// The status found at boot.
    #[must_use]
    pub fn status(&self) -> SensorStatus {
        self.status
    }

    fn ok(&self, flag: SensorStatus) -> bool {
        self.status.contains(flag)
    }

    /// Counts a failed transfer of `die`, or records a good read.
    fn count<T, E>(&mut self, die: usize, result: Result<T, E>) -> Option<T> {
        match result {
            Ok(value) => {
                self.last_good[die] = Some(self.ticks);
                Some(value)
            }
            Err(_) => {
                self.errors[die] = self.errors[die].wrapping_add(1);
                None
            }
        }
    }

    /// Does the reads of one tick and writes bytes 2..=27 of the packet. Readings that fail
    /// keep their previous value (and are counted); dies that never answered stay zero.
    pub fn tick(&mut self, plan: TickPlan, schedule: &mut Schedule, packet: &mut PacketBuilder) {
        self.ticks = self.ticks.wrapping_add(1);
        if plan.read_inertial {
            if self.ok(SensorStatus::ACCEL_OK) {
                let read = self.accel.read_raw();
                if let Some(raw) = self.count(ACCEL, read) {
                    self.accel_raw = raw;
                }
            }
            if self.ok(SensorStatus::GYRO_OK) {
                let read = self.gyro.read_raw();
                if let Some(raw) = self.count(GYRO, read) {
                    self.gyro_raw = raw;
                }
            }
        }

        if self.ok(SensorStatus::MAG_OK) {
            match plan.mag {
                MagAction::None => {}
                MagAction::Trigger => {
                    let started = self.mag.start_forced();
                    if started.is_err() {
                        self.errors[MAG] = self.errors[MAG].wrapping_add(1);
                    }
                }
                MagAction::Poll => match self.mag.poll_data() {
                    Ok(raw) => {
                        self.mag_words = raw.packet_words();
                        self.last_good[MAG] = Some(self.ticks);
                        schedule.mag_polled(true);
                    }
                    Err(nb::Error::WouldBlock) => schedule.mag_polled(false),
                    Err(nb::Error::Other(_)) => {
                        self.errors[MAG] = self.errors[MAG].wrapping_add(1);
                        schedule.mag_polled(false);
                    }
                },
            }
        }

        if plan.read_baro && self.ok(SensorStatus::BMP280_OK) {
            let read = self.baro.read_raw_bytes();
            if let Some(bytes) = self.count(BARO, read) {
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

    /// Gives the four SPI devices back (accelerometer, gyroscope, magnetometer, BMP280).
    pub fn release(self) -> (A, G, M, B) {
        (
            self.accel.release(),
            self.gyro.release(),
            self.mag.release(),
            self.baro.release(),
        )
    }

    /// SPI transfers that failed after boot, all dies together.
    #[must_use]
    pub fn bus_errors(&self) -> u32 {
        self.errors.iter().fold(0, |sum, &e| sum.wrapping_add(e))
    }

    /// SPI transfers that failed after boot: accelerometer, gyroscope, magnetometer, BMP280.
    #[must_use]
    pub fn errors(&self) -> [u32; 4] {
        self.errors
    }

    /// Time since each die's last good read (same order), ms, for ticks of `period_us`;
    /// `u16::MAX` if never (a die absent at boot) or longer ago.
    #[must_use]
    pub fn ages_ms(&self, period_us: u32) -> [u16; 4] {
        self.last_good.map(|last| match last {
            Some(tick) => {
                // 32-bit only (no 64-bit division on the board); saturates after 71 minutes,
                // long past u16::MAX ms.
                let ms = self.ticks.wrapping_sub(tick).saturating_mul(period_us) / 1000;
                u16::try_from(ms).unwrap_or(u16::MAX)
            }
            None => u16::MAX,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schedule::ScheduleConfig;
    use dima_sensorboard::PACKET_LEN;
    use embedded_hal::spi::{ErrorKind, ErrorType, Operation};

    /// A sensor die as a register file behind SPI: the first byte of a transaction is the
    /// address (bit 7 set: read), further bytes are written, reads auto-increment.
    ///
    /// The BMX055 dies use addresses below 0x80, so the register index is the address byte
    /// without bit 7; the BMP280's registers sit at 0x80 and above, so its index is the address
    /// byte with bit 7.
    struct FakeDie {
        regs: [u8; 256],
        high_registers: bool,
        dead: bool,
        transactions: u32,
        /// Transactions from this one on fail (a die that breaks after boot).
        fail_from: u32,
    }

    impl FakeDie {
        fn bmx(regs: &[(u8, &[u8])]) -> Self {
            Self::with(false, regs)
        }

        fn bmp(regs: &[(u8, &[u8])]) -> Self {
            Self::with(true, regs)
        }

        fn with(high_registers: bool, regs: &[(u8, &[u8])]) -> Self {
            let mut die = Self {
                regs: [0; 256],
                high_registers,
                dead: false,
                transactions: 0,
                fail_from: u32::MAX,
            };
            for (start, bytes) in regs {
                let start = usize::from(*start);
                die.regs[start..start + bytes.len()].copy_from_slice(bytes);
            }
            die
        }

        /// A die that never answers: every transfer fails.
        fn dead() -> Self {
            let mut die = Self::bmx(&[]);
            die.dead = true;
            die
        }

        fn index(&self, address: u8) -> usize {
            usize::from(if self.high_registers {
                address | 0x80
            } else {
                address & 0x7F
            })
        }
    }

    impl ErrorType for FakeDie {
        type Error = ErrorKind;
    }

    impl SpiDevice for FakeDie {
        fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
            self.transactions += 1;
            if self.dead || self.transactions > self.fail_from {
                return Err(ErrorKind::Other);
            }
            let mut cursor: Option<usize> = None;
            for operation in operations {
                match operation {
                    Operation::Write(bytes) => {
                        let (&address, data) = bytes.split_first().ok_or(ErrorKind::Other)?;
                        let start = self.index(address);
                        for (i, &byte) in data.iter().enumerate() {
                            self.regs[(start + i) & 0xFF] = byte;
                        }
                        cursor = Some(start);
                    }
                    Operation::Read(buffer) => {
                        let start = cursor.ok_or(ErrorKind::Other)?;
                        for (i, byte) in buffer.iter_mut().enumerate() {
                            *byte = self.regs[(start + i) & 0xFF];
                        }
                    }
                    _ => return Err(ErrorKind::Other),
                }
            }
            Ok(())
        }
    }

    struct NoDelay;

    impl DelayNs for NoDelay {
        fn delay_ns(&mut self, _ns: u32) {}
    }

    const ACCEL_DATA: [u8; 6] = [0x31, 0x12, 0x4F, 0xFE, 0x01, 0x40];
    const GYRO_DATA: [u8; 6] = [0x11, 0x22, 0x33, 0x44, 0x55, 0x66];
    /// X, Y, Z, RHALL (LSB first); bit 0 of 0x48 is data-ready.
    const MAG_DATA: [u8; 8] = [0x0F, 0x20, 0xF7, 0xE0, 0x03, 0x10, 0x0D, 0x50];
    const MAG_TRIM_5D: [u8; 2] = [0x01, 0x02];
    const MAG_TRIM_62: [u8; 4] = [0x03, 0x04, 0x05, 0x06];
    const MAG_TRIM_68: [u8; 10] = [0xFB, 0x02, 0xAB, 0x60, 0x8D, 0x1B, 0x00, 0x00, 0xFD, 0x1D];
    const BARO_DATA: [u8; 6] = [0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00];

    /// BMP280 calibration 0x88..=0x9F, the datasheet's example values (dig_T1 = 27504,
    /// dig_T2 = 26435, dig_T3 = -1000, dig_P1 = 36477, ...), little-endian.
    const BARO_CALIBRATION: [u8; 24] = [
        0x70, 0x6B, 0x43, 0x67, 0x18, 0xFC, 0x7D, 0x8E, 0x43, 0xD6, 0xD0, 0x0B, 0x27, 0x0B, 0x8C,
        0x00, 0xF9, 0xFF, 0x8C, 0x3C, 0xF8, 0xC6, 0x70, 0x17,
    ];

    fn accel() -> FakeDie {
        FakeDie::bmx(&[(0x00, &[0xFA]), (0x02, &ACCEL_DATA)])
    }

    fn gyro() -> FakeDie {
        FakeDie::bmx(&[(0x00, &[0x0F]), (0x02, &GYRO_DATA)])
    }

    fn mag() -> FakeDie {
        FakeDie::bmx(&[
            (0x40, &[0x32]),
            (0x42, &MAG_DATA),
            (0x5D, &MAG_TRIM_5D),
            (0x62, &MAG_TRIM_62),
            (0x68, &MAG_TRIM_68),
        ])
    }

    fn baro() -> FakeDie {
        FakeDie::bmp(&[
            (0x88, &BARO_CALIBRATION),
            (0xD0, &[0x58]),
            (0xF7, &BARO_DATA),
        ])
    }

    /// Runs `ticks` sampling ticks and returns the packet bytes.
    fn sample(
        sensors: &mut Sensors<FakeDie, FakeDie, FakeDie, FakeDie>,
        ticks: usize,
    ) -> [u8; PACKET_LEN] {
        let mut schedule = Schedule::new(ScheduleConfig::DEFAULT);
        let mut packet = PacketBuilder::new();
        for _ in 0..ticks {
            let plan = schedule.next_tick();
            sensors.tick(plan, &mut schedule, &mut packet);
        }
        *packet.as_bytes()
    }

    #[test]
    fn every_die_present_reports_all_ok_with_calibration_and_trim() {
        let (sensors, report) = Sensors::init(accel(), gyro(), mag(), baro(), &mut NoDelay);
        assert_eq!(report.status.bits(), 0x0F);
        assert_eq!(sensors.status(), report.status);
        assert_eq!(report.bmp280_calibration, BARO_CALIBRATION);
        let mut trim = [0u8; 16];
        trim[..2].copy_from_slice(&MAG_TRIM_5D);
        trim[2..6].copy_from_slice(&MAG_TRIM_62);
        trim[6..].copy_from_slice(&MAG_TRIM_68);
        assert_eq!(report.bmm150_trim, trim);
    }

    #[test]
    fn packet_carries_the_registers_with_status_bits_masked() {
        let (mut sensors, _) = Sensors::init(accel(), gyro(), mag(), baro(), &mut NoDelay);
        // Tick 0 triggers the magnetometer, tick 1 finds its data ready.
        let packet = sample(&mut sensors, 2);
        // The packet's masks (docs/wire-formats.md): accel LSBs & 0xF0; gyro as read; mag X/Y
        // LSB & 0xF8, Z LSB & 0xFE, RHALL LSB & 0xFC; BMP280 0xF7..=0xFC as read.
        assert_eq!(packet[..2], *b"$$");
        assert_eq!(packet[2..8], [0x30, 0x12, 0x40, 0xFE, 0x00, 0x40]);
        assert_eq!(packet[8..14], GYRO_DATA);
        assert_eq!(
            packet[14..22],
            [0x08, 0x20, 0xF0, 0xE0, 0x02, 0x10, 0x0C, 0x50]
        );
        assert_eq!(packet[22..28], BARO_DATA);
        assert_eq!(sensors.bus_errors(), 0);
    }

    #[test]
    fn magnetometer_data_wait_for_data_ready() {
        let mut not_ready = mag();
        not_ready.regs[0x48] &= !0x01;
        let (mut sensors, report) = Sensors::init(accel(), gyro(), not_ready, baro(), &mut NoDelay);
        assert!(report.status.contains(SensorStatus::MAG_OK));
        let packet = sample(&mut sensors, 5);
        assert_eq!(packet[14..22], [0; 8], "no data before data-ready");
    }

    #[test]
    fn a_dead_die_is_reported_and_left_out_without_hanging() {
        let (mut sensors, report) =
            Sensors::init(accel(), FakeDie::dead(), mag(), baro(), &mut NoDelay);
        assert_eq!(
            report.status,
            SensorStatus::ACCEL_OK | SensorStatus::MAG_OK | SensorStatus::BMP280_OK
        );
        let packet = sample(&mut sensors, 2);
        assert_eq!(packet[8..14], [0; 6], "gyro fields stay zero");
        assert_eq!(packet[2..4], [0x30, 0x12]);
        // The dead die is not touched after boot.
        assert_eq!(sensors.bus_errors(), 0);
    }

    #[test]
    fn a_die_that_breaks_after_boot_is_counted_per_die_and_ages() {
        let mut gyro = gyro();
        // Bring-up takes a handful of transactions; let two reads through, then fail.
        let (sensors, _) = Sensors::init(accel(), self::gyro(), mag(), baro(), &mut NoDelay);
        let boot_transactions = sensors.release().1.transactions;
        gyro.fail_from = boot_transactions + 2;
        let (mut sensors, report) = Sensors::init(accel(), gyro, mag(), baro(), &mut NoDelay);
        assert!(report.status.contains(SensorStatus::GYRO_OK));
        let mut schedule = Schedule::new(ScheduleConfig::DEFAULT);
        let mut packet = PacketBuilder::new();
        for _ in 0..12 {
            let plan = schedule.next_tick();
            sensors.tick(plan, &mut schedule, &mut packet);
        }
        // Ten of twelve gyro reads failed; nothing else did.
        assert_eq!(sensors.errors(), [0, 10, 0, 0]);
        assert_eq!(sensors.bus_errors(), 10);
        // Last good gyro read on tick 2 of 12: 10 ticks of 1 ms ago. The accelerometer was
        // read this tick; the BMP280 on tick 11 (every fifth tick from tick 1).
        let ages = sensors.ages_ms(1000);
        assert_eq!(ages[0], 0);
        assert_eq!(ages[1], 10);
        assert_eq!(ages[3], 1);
        // The failed read kept the last good value in the packet.
        assert_eq!(packet.as_bytes()[8..14], GYRO_DATA);
    }

    #[test]
    fn spi_errors_are_counted_for_the_die_that_fails() {
        // Each die in turn fails every transfer after boot; only its own counter grows.
        let boot = {
            let (sensors, _) = Sensors::init(accel(), gyro(), mag(), baro(), &mut NoDelay);
            let (a, g, m, b) = sensors.release();
            [
                a.transactions,
                g.transactions,
                m.transactions,
                b.transactions,
            ]
        };
        for die in 0..4 {
            let mut dies = [accel(), gyro(), mag(), baro()];
            dies[die].fail_from = boot[die];
            let [a, g, m, b] = dies;
            let (mut sensors, report) = Sensors::init(a, g, m, b, &mut NoDelay);
            assert_eq!(
                report.status.bits() & 0x0F,
                0x0F,
                "die {die}: all up at boot"
            );
            let mut schedule = Schedule::new(ScheduleConfig::DEFAULT);
            let mut packet = PacketBuilder::new();
            for _ in 0..20 {
                let plan = schedule.next_tick();
                sensors.tick(plan, &mut schedule, &mut packet);
            }
            let errors = sensors.errors();
            for (other, &count) in errors.iter().enumerate() {
                if other == die {
                    assert!(count > 0, "die {die}: its failures counted ({errors:?})");
                } else {
                    assert_eq!(count, 0, "die {die}: die {other} untouched ({errors:?})");
                }
            }
            assert_eq!(
                sensors.ages_ms(1000)[die],
                u16::MAX,
                "die {die}: never read"
            );
        }
    }

    #[test]
    fn dies_never_read_report_the_largest_age() {
        let (sensors, _) = Sensors::init(
            FakeDie::dead(),
            FakeDie::dead(),
            FakeDie::dead(),
            FakeDie::dead(),
            &mut NoDelay,
        );
        assert_eq!(sensors.ages_ms(1000), [u16::MAX; 4]);
    }

    #[test]
    fn wrong_chip_ids_clear_the_status_bits() {
        let wrong = |die: FakeDie, at: usize| {
            let mut die = die;
            die.regs[at] = 0x00;
            die
        };
        let (_, report) = Sensors::init(
            wrong(accel(), 0x00),
            wrong(gyro(), 0x00),
            wrong(mag(), 0x40),
            wrong(baro(), 0xD0),
            &mut NoDelay,
        );
        assert_eq!(report.status, SensorStatus::empty());
        assert_eq!(report.bmp280_calibration, [0; 24]);
        assert_eq!(report.bmm150_trim, [0; 16]);
    }

    #[test]
    fn a_board_without_sensors_boots_with_bounded_work() {
        let (sensors, report) = Sensors::init(
            FakeDie::dead(),
            FakeDie::dead(),
            FakeDie::dead(),
            FakeDie::dead(),
            &mut NoDelay,
        );
        assert_eq!(report.status, SensorStatus::empty());
        let (a, g, m, b) = sensors.release();
        for die in [a, g, m, b] {
            assert!(
                (1..=8).contains(&die.transactions),
                "{} transactions",
                die.transactions
            );
        }
    }
}
