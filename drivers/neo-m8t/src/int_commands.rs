//! The configuration messages of [`crate::commands`], built with integer arithmetic only.
//!
//! The `ublox` crate's CFG builders take floating-point fields (CFG-TP5's periods as `f64`,
//! CFG-TMODE2's positions in metres) and scale them back to the integers on the wire. On a
//! microcontroller that pulls in software `f64` arithmetic for values that were integers all
//! along. These builders write the same payloads field by field from the integer
//! configuration, so the bytes are identical (a test compares both on every message the
//! [`Configurator`](crate::Configurator) sends) at a fraction of the flash. The `ublox`
//! parser is still what reads the receiver's answers.
//!
//! Each builder returns `Option` only to fit [`Configurator`](crate::Configurator)'s step
//! table: the payload sizes are checked at compile time, so the result is always `Some`.
//!
//! Field layouts follow the u-blox M8 receiver description (UBX-13003221), all little-endian.

use crate::commands::{
    Command, CLASS_CFG, CLASS_MON, ID_CFG_MSG, ID_CFG_NAV5, ID_CFG_PRT, ID_CFG_RATE, ID_CFG_TMODE2,
    ID_CFG_TP5, ID_MON_VER, MAX_COMMAND_LEN,
};
use crate::config::{AlignmentToReferenceTime, NavDynamicModel, TimeMode, TimePulse};

/// CFG-PRT `mode` for 8 data bits, no parity, 1 stop bit (`charLen` = 3, `parity` = 4).
const MODE_8N1: u32 = (0b11 << 6) | (0b100 << 9);
/// CFG-PRT protocol mask bit for UBX (both `inProtoMask` and `outProtoMask`).
const PROTO_UBX: u16 = 0x0001;
/// UART1's port id.
const PORT_UART1: u8 = 1;
/// CFG-NAV5 `mask` bit: apply the dynamic model.
const NAV5_MASK_DYN: u16 = 0x0001;
/// CFG-TP5 message version.
const TP5_VERSION: u8 = 0x01;

/// A payload written field by field, little-endian.
struct Payload<const N: usize> {
    bytes: [u8; N],
    at: usize,
}

impl<const N: usize> Payload<N> {
    const fn new() -> Self {
        Self {
            bytes: [0; N],
            at: 0,
        }
    }

    fn put(mut self, field: &[u8]) -> Self {
        let end = self.at + field.len();
        if let Some(slot) = self.bytes.get_mut(self.at..end) {
            slot.copy_from_slice(field);
        }
        self.at = end;
        self
    }

    fn u8(self, value: u8) -> Self {
        self.put(&[value])
    }

    fn u16(self, value: u16) -> Self {
        self.put(&value.to_le_bytes())
    }

    fn u32(self, value: u32) -> Self {
        self.put(&value.to_le_bytes())
    }

    fn i16(self, value: i16) -> Self {
        self.put(&value.to_le_bytes())
    }

    fn i32(self, value: i32) -> Self {
        self.put(&value.to_le_bytes())
    }

    /// Skips `count` reserved (zero) bytes.
    fn zeros(mut self, count: usize) -> Self {
        self.at += count;
        self
    }

    /// The payload fits a [`Command`]: checked when the builder is compiled.
    const FITS: () = assert!(N + 8 <= MAX_COMMAND_LEN);

    /// The frame. Always `Some`: [`Self::FITS`] rules out the only failure, an oversized payload.
    fn frame(self, class: u8, id: u8) -> Option<Command> {
        let () = Self::FITS;
        Command::new(class, id, self.bytes.get(..self.at)?)
    }
}

/// CFG-PRT for UART1: 8N1 at `baud_rate`, UBX only in and out.
pub fn cfg_prt_uart1(baud_rate: u32) -> Option<Command> {
    Payload::<20>::new()
        .u8(PORT_UART1)
        .u8(0) // reserved0
        .u16(0) // txReady
        .u32(MODE_8N1)
        .u32(baud_rate)
        .u16(PROTO_UBX)
        .u16(PROTO_UBX)
        .u16(0) // flags
        .u16(0) // reserved5
        .frame(CLASS_CFG, ID_CFG_PRT)
}

/// CFG-MSG: message `class`/`id` every `rate` solutions on UART1, off on every other port.
pub fn cfg_msg_uart1(class: u8, id: u8, rate: u8) -> Option<Command> {
    Payload::<8>::new()
        .put(&[class, id, 0, rate, 0, 0, 0, 0])
        .frame(CLASS_CFG, ID_CFG_MSG)
}

/// CFG-RATE: measurement period, solutions per measurement, time alignment.
pub fn cfg_rate(
    period_ms: u16,
    nav_rate: u16,
    time_ref: AlignmentToReferenceTime,
) -> Option<Command> {
    Payload::<6>::new()
        .u16(period_ms)
        .u16(nav_rate)
        .u16(time_ref as u16)
        .frame(CLASS_CFG, ID_CFG_RATE)
}

/// CFG-NAV5 that changes only the dynamic model (mask = dyn); every field the mask does not
/// select is zero, as u-blox's tools send it.
pub fn cfg_nav5(model: NavDynamicModel) -> Option<Command> {
    Payload::<36>::new()
        .u16(NAV5_MASK_DYN)
        .u8(dynamic_model_code(model))
        .zeros(36 - 3) // fixMode .. reserved2: not selected by the mask
        .frame(CLASS_CFG, ID_CFG_NAV5)
}

/// CFG-TP5 for one time pulse output.
pub fn cfg_tp5(tp: &TimePulse) -> Option<Command> {
    Payload::<32>::new()
        .u8(u8::from(tp.index != 0))
        .u8(TP5_VERSION)
        .zeros(2)
        .i16(tp.antenna_cable_delay_ns)
        .i16(tp.rf_group_delay_ns)
        .u32(tp.period_us)
        .u32(tp.period_locked_us)
        .u32(tp.pulse_len_us)
        .u32(tp.pulse_len_locked_us)
        .i32(tp.user_delay_ns)
        .u32(tp.flags)
        .frame(CLASS_CFG, ID_CFG_TP5)
}

/// CFG-TMODE2 (positions in cm and accuracies in mm, as on the wire).
pub fn cfg_tmode2(mode: &TimeMode) -> Option<Command> {
    let (code, xyz_cm, fixed_acc_mm, min_s, limit_mm) = match *mode {
        TimeMode::Disabled => (0u8, [0; 3], 0, 0, 0),
        TimeMode::SurveyIn {
            min_duration_s,
            accuracy_limit_mm,
        } => (1, [0; 3], 0, min_duration_s, accuracy_limit_mm),
        TimeMode::FixedEcef {
            x_cm,
            y_cm,
            z_cm,
            accuracy_mm,
        } => (2, [x_cm, y_cm, z_cm], accuracy_mm, 0, 0),
    };
    Payload::<28>::new()
        .u8(code)
        .u8(0) // reserved1
        .u16(0) // flags: ECEF
        .i32(xyz_cm[0])
        .i32(xyz_cm[1])
        .i32(xyz_cm[2])
        .u32(fixed_acc_mm)
        .u32(min_s)
        .u32(limit_mm)
        .frame(CLASS_CFG, ID_CFG_TMODE2)
}

/// MON-VER poll (empty payload).
pub fn poll_mon_ver() -> Option<Command> {
    Payload::<0>::new().frame(CLASS_MON, ID_MON_VER)
}

/// The `dynModel` code of a dynamic platform model (CFG-NAV5).
fn dynamic_model_code(model: NavDynamicModel) -> u8 {
    match model {
        NavDynamicModel::Portable => 0,
        NavDynamicModel::Stationary => 2,
        NavDynamicModel::Pedestrian => 3,
        NavDynamicModel::Automotive => 4,
        NavDynamicModel::Sea => 5,
        NavDynamicModel::AirborneWithLess1gAcceleration => 6,
        NavDynamicModel::AirborneWithLess2gAcceleration => 7,
        NavDynamicModel::AirborneWithLess4gAcceleration => 8,
        // Models of newer protocol versions, when another crate enables them.
        #[allow(unreachable_patterns)]
        _ => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands;
    use crate::config::tp5_flags;
    use crate::Config;

    // `Command` equality is byte equality: both builders zero the unused tail.

    /// Every message a configurator sends for `config`, from both builders.
    fn both(config: &Config) -> [(Command, Command); 5] {
        [
            (
                commands::cfg_prt_uart1(config.baud_rate),
                cfg_prt_uart1(config.baud_rate).expect("fits"),
            ),
            (
                commands::cfg_rate(
                    config.measurement_period_ms,
                    config.nav_rate,
                    config.time_ref,
                ),
                cfg_rate(
                    config.measurement_period_ms,
                    config.nav_rate,
                    config.time_ref,
                )
                .expect("fits"),
            ),
            (
                commands::cfg_nav5(config.dynamic_model),
                cfg_nav5(config.dynamic_model).expect("fits"),
            ),
            (commands::poll_mon_ver(), poll_mon_ver().expect("fits")),
            (
                commands::cfg_msg_uart1(0x01, 0x07, 1),
                cfg_msg_uart1(0x01, 0x07, 1).expect("fits"),
            ),
        ]
    }

    #[test]
    fn default_config_messages_are_byte_identical() {
        for (reference, integer) in both(&Config::default()) {
            assert_eq!(integer.as_bytes(), reference.as_bytes());
            assert!(integer.as_bytes().len() >= 8);
        }
    }

    #[test]
    fn every_nmea_switch_off_and_tim_message_is_byte_identical() {
        for (class, id) in commands::DEFAULT_NMEA {
            assert_eq!(
                cfg_msg_uart1(class, id, 0).expect("fits"),
                commands::cfg_msg_uart1(class, id, 0)
            );
        }
        for (class, id) in [(0x0D, 0x01), (0x0D, 0x03)] {
            assert_eq!(
                cfg_msg_uart1(class, id, 1).expect("fits"),
                commands::cfg_msg_uart1(class, id, 1)
            );
        }
    }

    #[test]
    fn every_dynamic_model_and_time_reference_is_byte_identical() {
        use AlignmentToReferenceTime as T;
        use NavDynamicModel as M;
        for model in [
            M::Portable,
            M::Stationary,
            M::Pedestrian,
            M::Automotive,
            M::Sea,
            M::AirborneWithLess1gAcceleration,
            M::AirborneWithLess2gAcceleration,
            M::AirborneWithLess4gAcceleration,
        ] {
            assert_eq!(cfg_nav5(model).expect("fits"), commands::cfg_nav5(model));
        }
        for time_ref in [T::Utc, T::Gps, T::Glo, T::Bds, T::Gal] {
            assert_eq!(
                cfg_rate(100, 1, time_ref).expect("fits"),
                commands::cfg_rate(100, 1, time_ref)
            );
        }
    }

    #[test]
    fn time_pulse_and_timing_modes_are_byte_identical() {
        let pulses = [
            TimePulse::default(),
            TimePulse {
                index: 1,
                antenna_cable_delay_ns: -7,
                rf_group_delay_ns: i16::MIN,
                period_us: u32::MAX,
                period_locked_us: 1,
                pulse_len_us: 123_456_789,
                pulse_len_locked_us: 0,
                user_delay_ns: i32::MIN,
                flags: tp5_flags::ACTIVE | tp5_flags::IS_FREQ,
            },
        ];
        for tp in &pulses {
            assert_eq!(cfg_tp5(tp).expect("fits"), commands::cfg_tp5(tp));
        }
        let modes = [
            TimeMode::Disabled,
            TimeMode::SurveyIn {
                min_duration_s: 300,
                accuracy_limit_mm: 2_501,
            },
            TimeMode::FixedEcef {
                x_cm: 418_356_789,
                y_cm: -86_512_301,
                z_cm: i32::MAX,
                accuracy_mm: 1_999,
            },
        ];
        for mode in &modes {
            assert_eq!(cfg_tmode2(mode).expect("fits"), commands::cfg_tmode2(mode));
        }
    }

    proptest::proptest! {
        #[test]
        fn any_port_rate_and_message_is_byte_identical(
            baud in proptest::prelude::any::<u32>(),
            period in proptest::prelude::any::<u16>(),
            nav_rate in proptest::prelude::any::<u16>(),
            class in proptest::prelude::any::<u8>(),
            id in proptest::prelude::any::<u8>(),
            rate in proptest::prelude::any::<u8>(),
        ) {
            proptest::prop_assert_eq!(
                cfg_prt_uart1(baud).expect("fits"),
                commands::cfg_prt_uart1(baud)
            );
            proptest::prop_assert_eq!(
                cfg_rate(period, nav_rate, AlignmentToReferenceTime::Gps).expect("fits"),
                commands::cfg_rate(period, nav_rate, AlignmentToReferenceTime::Gps)
            );
            proptest::prop_assert_eq!(
                cfg_msg_uart1(class, id, rate).expect("fits"),
                commands::cfg_msg_uart1(class, id, rate)
            );
        }

        #[test]
        fn any_time_pulse_and_fixed_position_is_byte_identical(
            delays in proptest::prelude::any::<(i16, i16, i32)>(),
            periods in proptest::prelude::any::<(u32, u32, u32, u32)>(),
            flags in proptest::prelude::any::<u32>(),
            xyz in proptest::prelude::any::<(i32, i32, i32)>(),
            accuracy in proptest::prelude::any::<(u32, u32, u32)>(),
        ) {
            let tp = TimePulse {
                index: (flags & 1) as u8,
                antenna_cable_delay_ns: delays.0,
                rf_group_delay_ns: delays.1,
                period_us: periods.0,
                period_locked_us: periods.1,
                pulse_len_us: periods.2,
                pulse_len_locked_us: periods.3,
                user_delay_ns: delays.2,
                flags,
            };
            proptest::prop_assert_eq!(cfg_tp5(&tp).expect("fits"), commands::cfg_tp5(&tp));
            for mode in [
                TimeMode::FixedEcef { x_cm: xyz.0, y_cm: xyz.1, z_cm: xyz.2, accuracy_mm: accuracy.0 },
                TimeMode::SurveyIn { min_duration_s: accuracy.1, accuracy_limit_mm: accuracy.2 },
            ] {
                proptest::prop_assert_eq!(
                    cfg_tmode2(&mode).expect("fits"),
                    commands::cfg_tmode2(&mode)
                );
            }
        }
    }
}
