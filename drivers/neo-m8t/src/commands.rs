//! The UBX messages the driver sends, built with the `ublox` crate's builders (pure, no I/O).

use crate::config::{AlignmentToReferenceTime, NavDynamicModel, TimeMode, TimePulse};
use crate::frame::{encode_frame, Frame, HEADER_LEN};
use ublox::cfg_msg::CfgMsgAllPortsBuilder;
use ublox::cfg_nav5::{CfgNav5Builder, CfgNav5Params};
use ublox::cfg_prt::{
    CfgPrtUartBuilder, DataBits, InProtoMask, OutProtoMask, Parity, StopBits, UartMode, UartPortId,
};
use ublox::cfg_rate::CfgRateBuilder;
use ublox::cfg_tmode2::{CfgTModeModes, CfgTmode2Builder, CfgTmode2Flags};
use ublox::cfg_tp5::{CfgTp5Builder, CfgTp5Flags, CfgTp5TimePulseMode};

/// Longest command frame: CFG-NAV5, 36-byte payload + 8.
pub const MAX_COMMAND_LEN: usize = 44;

/// CFG class.
pub const CLASS_CFG: u8 = 0x06;
/// CFG-PRT id.
pub const ID_CFG_PRT: u8 = 0x00;
/// CFG-MSG id.
pub const ID_CFG_MSG: u8 = 0x01;
/// CFG-RATE id.
pub const ID_CFG_RATE: u8 = 0x08;
/// CFG-NAV5 id.
pub const ID_CFG_NAV5: u8 = 0x24;
/// CFG-TP5 id.
pub const ID_CFG_TP5: u8 = 0x31;
/// CFG-TMODE2 id.
pub const ID_CFG_TMODE2: u8 = 0x3D;
/// ACK class (ACK-ACK and ACK-NAK, the receiver's answer to every CFG message).
pub(crate) const CLASS_ACK: u8 = 0x05;
/// ACK-NAK id: the message was rejected.
pub(crate) const ID_ACK_NAK: u8 = 0x00;
/// ACK-ACK id: the message was accepted.
pub(crate) const ID_ACK_ACK: u8 = 0x01;
/// MON class.
pub const CLASS_MON: u8 = 0x0A;
/// MON-VER id.
pub const ID_MON_VER: u8 = 0x04;

/// NMEA standard messages (class 0xF0) an M8 outputs by default: GGA, GLL, GSA, GSV, RMC,
/// VTG. They are switched off on UART1.
pub const DEFAULT_NMEA: [(u8, u8); 6] = [
    (0xF0, 0x00),
    (0xF0, 0x01),
    (0xF0, 0x02),
    (0xF0, 0x03),
    (0xF0, 0x04),
    (0xF0, 0x05),
];

/// One encoded UBX frame to send, held by value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Command {
    bytes: [u8; MAX_COMMAND_LEN],
    len: usize,
}

impl Command {
    /// Wraps encoded frame bytes (at most [`MAX_COMMAND_LEN`]).
    fn from_frame_bytes(frame: &[u8]) -> Self {
        let mut bytes = [0u8; MAX_COMMAND_LEN];
        let len = frame.len().min(MAX_COMMAND_LEN);
        bytes[..len].copy_from_slice(&frame[..len]);
        Self { bytes, len }
    }

    /// Builds a frame from class, id and payload (payload at most 36 bytes).
    pub fn new(class: u8, id: u8, payload: &[u8]) -> Option<Self> {
        let mut bytes = [0u8; MAX_COMMAND_LEN];
        let len = encode_frame(class, id, payload, &mut bytes)?;
        Some(Self { bytes, len })
    }

    /// The frame bytes, sync to checksum.
    pub fn as_bytes(&self) -> &[u8] {
        &self.bytes[..self.len]
    }

    /// Message class.
    pub fn class(&self) -> u8 {
        self.bytes[2]
    }

    /// Message id.
    pub fn id(&self) -> u8 {
        self.bytes[3]
    }

    /// The frame as a [`Frame`] view.
    pub fn frame(&self) -> Option<Frame<'_>> {
        Frame::new(self.as_bytes())
    }
}

/// CFG-PRT for UART1: 8N1 at `baud_rate`, UBX only in and out.
pub fn cfg_prt_uart1(baud_rate: u32) -> Command {
    Command::from_frame_bytes(
        &CfgPrtUartBuilder {
            portid: UartPortId::Uart1,
            reserved0: 0,
            tx_ready: 0,
            mode: UartMode::new(DataBits::Eight, Parity::None, StopBits::One),
            baud_rate,
            in_proto_mask: InProtoMask::UBLOX,
            out_proto_mask: OutProtoMask::UBLOX,
            flags: 0,
            reserved5: 0,
        }
        .into_packet_bytes(),
    )
}

/// CFG-PRT poll for UART1 (payload: port id 1); the receiver answers with its CFG-PRT.
pub fn poll_cfg_prt_uart1() -> Command {
    // One-byte payload: cannot fail.
    Command::new(CLASS_CFG, ID_CFG_PRT, &[1]).unwrap_or(Command {
        bytes: [0; MAX_COMMAND_LEN],
        len: 0,
    })
}

/// CFG-MSG: message `class`/`id` every `rate` solutions on UART1, off on every other port.
pub fn cfg_msg_uart1(class: u8, id: u8, rate: u8) -> Command {
    Command::from_frame_bytes(
        &CfgMsgAllPortsBuilder {
            msg_class: class,
            msg_id: id,
            rates: [0, rate, 0, 0, 0, 0],
        }
        .into_packet_bytes(),
    )
}

/// CFG-RATE: measurement period, solutions per measurement, time alignment.
pub fn cfg_rate(period_ms: u16, nav_rate: u16, time_ref: AlignmentToReferenceTime) -> Command {
    Command::from_frame_bytes(
        &CfgRateBuilder {
            measure_rate_ms: period_ms,
            nav_rate,
            time_ref,
        }
        .into_packet_bytes(),
    )
}

/// CFG-NAV5 that changes only the dynamic model: the mask selects `dyn` alone and every field it
/// does not select is sent as zero (the receiver ignores them; a builder default such as
/// fixMode = 3 would suggest a setting that is not applied).
pub fn cfg_nav5(model: NavDynamicModel) -> Command {
    let builder_frame = CfgNav5Builder {
        mask: CfgNav5Params::DYN,
        dyn_model: model,
        ..CfgNav5Builder::default()
    }
    .into_packet_bytes();
    // Payload bytes 0-1: mask, 2: dynModel (as the ublox crate encodes it), 3..36: unselected.
    let mut payload = [0u8; 36];
    payload[..3].copy_from_slice(&builder_frame[HEADER_LEN..HEADER_LEN + 3]);
    Command::new(CLASS_CFG, ID_CFG_NAV5, &payload)
        .unwrap_or_else(|| Command::from_frame_bytes(&builder_frame))
}

/// CFG-TP5 for one time pulse output.
pub fn cfg_tp5(tp: &TimePulse) -> Command {
    Command::from_frame_bytes(
        &CfgTp5Builder {
            tp_idx: if tp.index == 0 {
                CfgTp5TimePulseMode::TimePulse
            } else {
                CfgTp5TimePulseMode::TimePulse2
            },
            version: 0x01,
            reserved1: [0; 2],
            ant_cable_delay: f32::from(tp.antenna_cable_delay_ns),
            rf_group_delay: f32::from(tp.rf_group_delay_ns),
            freq_period: f64::from(tp.period_us),
            freq_period_lock: f64::from(tp.period_locked_us),
            pulse_len_ratio: f64::from(tp.pulse_len_us),
            pulse_len_ratio_lock: f64::from(tp.pulse_len_locked_us),
            user_delay: f64::from(tp.user_delay_ns),
            flags: CfgTp5Flags::from_bits_retain(tp.flags),
        }
        .into_packet_bytes(),
    )
}

/// CFG-TMODE2.
pub fn cfg_tmode2(mode: &TimeMode) -> Command {
    let (time_transfer_mode, xyz_cm, fixed_acc_mm, min_s, limit_mm) = match *mode {
        TimeMode::Disabled => (CfgTModeModes::Disabled, [0; 3], 0, 0, 0),
        TimeMode::SurveyIn {
            min_duration_s,
            accuracy_limit_mm,
        } => (
            CfgTModeModes::SurveyIn,
            [0; 3],
            0,
            min_duration_s,
            accuracy_limit_mm,
        ),
        TimeMode::FixedEcef {
            x_cm,
            y_cm,
            z_cm,
            accuracy_mm,
        } => (CfgTModeModes::Fixed, [x_cm, y_cm, z_cm], accuracy_mm, 0, 0),
    };
    // The builder takes metres and scales back to cm / mm with rounding.
    let m_from_cm = |cm: i32| f64::from(cm) / 100.0;
    let m_from_mm = |mm: u32| f64::from(mm) / 1000.0;
    Command::from_frame_bytes(
        &CfgTmode2Builder {
            time_transfer_mode,
            reserved1: 0,
            flags: CfgTmode2Flags::empty(),
            ecef_x_or_lat: m_from_cm(xyz_cm[0]),
            ecef_y_or_lon: m_from_cm(xyz_cm[1]),
            ecef_z_or_alt: m_from_cm(xyz_cm[2]),
            fixed_pos_acc: m_from_mm(fixed_acc_mm),
            survey_in_min_duration: min_s,
            survey_in_accur_limit: m_from_mm(limit_mm),
        }
        .into_packet_bytes(),
    )
}

/// MON-VER poll (empty payload).
pub fn poll_mon_ver() -> Command {
    Command::from_frame_bytes(
        &ublox::UbxPacketRequest::request_for_unknown(CLASS_MON, ID_MON_VER).into_packet_bytes(),
    )
}
