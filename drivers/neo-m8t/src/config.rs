//! What to configure: port, messages, rate, navigation model, time pulse, timing mode.

pub use ublox::cfg_nav5::NavDynamicModel;
pub use ublox::cfg_rate::AlignmentToReferenceTime;

/// Receiver configuration applied by [`Configurator`](crate::Configurator).
///
/// `Default` is what DIMA uses: UART1 at 115200 baud, UBX only in and out, NAV-PVT at every
/// solution and nothing else, 100 ms (10 Hz) measurements aligned to GPS time, automotive
/// dynamic model, 1 Hz time pulse, no TIM messages, timing mode left alone.
///
/// ```
/// use neo_m8t::{Config, NavDynamicModel};
///
/// let config = Config::default()
///     .with_baud_rate(230_400)
///     .with_measurement_period_ms(200)
///     .with_dynamic_model(NavDynamicModel::Pedestrian)
///     .with_tim_tp(true);
/// assert_eq!(config.measurement_period_ms, 200);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// UART1 baud rate to switch to, baud.
    pub baud_rate: u32,
    /// Time between measurements, ms (`measRate`; 100 ms = 10 Hz).
    pub measurement_period_ms: u16,
    /// Measurements per navigation solution (`navRate`), cycles.
    pub nav_rate: u16,
    /// Time system the measurements are aligned to (`timeRef`).
    pub time_ref: AlignmentToReferenceTime,
    /// Dynamic platform model of the navigation engine (CFG-NAV5).
    pub dynamic_model: NavDynamicModel,
    /// TIMEPULSE settings (CFG-TP5); `None` leaves them as they are.
    pub time_pulse: Option<TimePulse>,
    /// Timing mode (CFG-TMODE2); `None` leaves it as it is.
    pub time_mode: Option<TimeMode>,
    /// Output TIM-TP on UART1 at every solution.
    pub tim_tp: bool,
    /// Output TIM-TM2 on UART1 at every solution.
    pub tim_tm2: bool,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            baud_rate: 115_200,
            measurement_period_ms: 100,
            nav_rate: 1,
            time_ref: AlignmentToReferenceTime::Gps,
            dynamic_model: NavDynamicModel::Automotive,
            time_pulse: Some(TimePulse::default()),
            time_mode: None,
            tim_tp: false,
            tim_tm2: false,
        }
    }
}

impl Config {
    /// Sets [`baud_rate`](Self::baud_rate).
    pub fn with_baud_rate(mut self, baud_rate: u32) -> Self {
        self.baud_rate = baud_rate;
        self
    }

    /// Sets [`measurement_period_ms`](Self::measurement_period_ms).
    pub fn with_measurement_period_ms(mut self, period_ms: u16) -> Self {
        self.measurement_period_ms = period_ms;
        self
    }

    /// Sets [`dynamic_model`](Self::dynamic_model).
    pub fn with_dynamic_model(mut self, model: NavDynamicModel) -> Self {
        self.dynamic_model = model;
        self
    }

    /// Sets [`time_pulse`](Self::time_pulse).
    pub fn with_time_pulse(mut self, time_pulse: Option<TimePulse>) -> Self {
        self.time_pulse = time_pulse;
        self
    }

    /// Sets [`time_mode`](Self::time_mode).
    pub fn with_time_mode(mut self, time_mode: Option<TimeMode>) -> Self {
        self.time_mode = time_mode;
        self
    }

    /// Sets [`tim_tp`](Self::tim_tp).
    pub fn with_tim_tp(mut self, on: bool) -> Self {
        self.tim_tp = on;
        self
    }

    /// Sets [`tim_tm2`](Self::tim_tm2).
    pub fn with_tim_tm2(mut self, on: bool) -> Self {
        self.tim_tm2 = on;
        self
    }
}

/// CFG-TP5 `flags` bits (u-blox M8 receiver description).
pub mod tp5_flags {
    /// Time pulse active.
    pub const ACTIVE: u32 = 0x01;
    /// Synchronise to GNSS time when it is valid.
    pub const LOCK_GNSS_FREQ: u32 = 0x02;
    /// Use the `*_locked` values once locked to GNSS time.
    pub const LOCKED_OTHER_SET: u32 = 0x04;
    /// `period` fields are frequencies in Hz instead of periods in µs.
    pub const IS_FREQ: u32 = 0x08;
    /// `pulse_len` fields are lengths in µs instead of duty cycles in 2^-32.
    pub const IS_LENGTH: u32 = 0x10;
    /// Align the pulse to the top of a second.
    pub const ALIGN_TO_TOW: u32 = 0x20;
    /// Rising edge at the top of the second.
    pub const POLARITY_RISING: u32 = 0x40;
    /// `gridUtcGnss` (bits 7-10) = 1: GPS time grid (0 is UTC).
    pub const GRID_GPS: u32 = 1 << 7;
}

/// TIMEPULSE configuration (CFG-TP5), integer units as on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TimePulse {
    /// Which pulse output: 0 TIMEPULSE, 1 TIMEPULSE2.
    pub index: u8,
    /// Antenna cable delay, ns.
    pub antenna_cable_delay_ns: i16,
    /// RF group delay, ns (read-only on the receiver; sent as given).
    pub rf_group_delay_ns: i16,
    /// Period before lock, µs (or frequency in Hz with [`tp5_flags::IS_FREQ`]).
    pub period_us: u32,
    /// Period once locked, µs (or Hz).
    pub period_locked_us: u32,
    /// Pulse length before lock, µs (or duty cycle in 2^-32 without
    /// [`tp5_flags::IS_LENGTH`]); 0 = no pulse before lock.
    pub pulse_len_us: u32,
    /// Pulse length once locked, µs (or duty cycle).
    pub pulse_len_locked_us: u32,
    /// User delay, ns.
    pub user_delay_ns: i32,
    /// [`tp5_flags`] bits.
    pub flags: u32,
}

impl Default for TimePulse {
    /// 1 Hz on TIMEPULSE, no pulse before lock, 100 ms pulse once locked, rising edge at the
    /// top of the GPS second.
    fn default() -> Self {
        use tp5_flags::*;
        Self {
            index: 0,
            antenna_cable_delay_ns: 50,
            rf_group_delay_ns: 0,
            period_us: 1_000_000,
            period_locked_us: 1_000_000,
            pulse_len_us: 0,
            pulse_len_locked_us: 100_000,
            user_delay_ns: 0,
            flags: ACTIVE
                | LOCK_GNSS_FREQ
                | LOCKED_OTHER_SET
                | IS_LENGTH
                | ALIGN_TO_TOW
                | POLARITY_RISING
                | GRID_GPS,
        }
    }
}

/// Timing mode of a timing receiver (CFG-TMODE2).
///
/// A moving vehicle needs [`Disabled`](Self::Disabled); the others are for a fixed antenna.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeMode {
    /// Normal navigation.
    Disabled,
    /// Survey the antenna position, then switch to fixed mode.
    SurveyIn {
        /// Minimum survey duration, s.
        min_duration_s: u32,
        /// Position accuracy to reach, mm.
        accuracy_limit_mm: u32,
    },
    /// Antenna at a known ECEF position.
    FixedEcef {
        /// ECEF X, cm.
        x_cm: i32,
        /// ECEF Y, cm.
        y_cm: i32,
        /// ECEF Z, cm.
        z_cm: i32,
        /// Position accuracy, mm.
        accuracy_mm: u32,
    },
}
