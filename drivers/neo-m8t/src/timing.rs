//! TIM-TP and TIM-TM2 as owned integer records (NEO-M8T timing messages).

/// TIM-TP (class 0x0D, id 0x01): time of the next time pulse.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimTp {
    /// Time pulse time of week, ms (`towMS`), in the time base given by `flags`.
    pub tow_ms: u32,
    /// Sub-millisecond part of the time of week, 2^-32 ms (`towSubMS`).
    pub tow_sub_ms: u32,
    /// Quantisation error of the time pulse, ps (`qErr`).
    pub q_err_ps: i32,
    /// Week number, weeks (`week`).
    pub week: u16,
    /// Time base, UTC availability, RAIM and qErr validity bits (`flags`).
    pub flags: u8,
    /// Time reference and UTC standard (`refInfo`).
    pub ref_info: u8,
}

impl TimTp {
    /// Reads the fields from the `ublox` crate's view.
    pub fn from_ublox(p: &ublox::tim_tp::TimTpRef<'_>) -> Self {
        Self {
            tow_ms: p.tow_ms(),
            tow_sub_ms: p.tow_sub_ms(),
            q_err_ps: p.q_err(),
            week: p.week(),
            flags: p.flags_raw(),
            ref_info: p.ref_info_raw(),
        }
    }
}

/// TIM-TM2 (class 0x0D, id 0x03): time mark on the EXTINT input.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TimTm2 {
    /// Channel (EXTINT pin) of the mark (`ch`).
    pub channel: u8,
    /// Mode, run, edge, time base and validity bits (`flags`).
    pub flags: u8,
    /// Rising edge counter (`count`).
    pub count: u16,
    /// Week number of the last rising edge (`wnR`).
    pub wn_r: u16,
    /// Week number of the last falling edge (`wnF`).
    pub wn_f: u16,
    /// Time of week of the last rising edge, ms (`towMsR`).
    pub tow_ms_r: u32,
    /// Sub-millisecond part of the rising edge, ns (`towSubMsR`).
    pub tow_sub_ms_r_ns: u32,
    /// Time of week of the last falling edge, ms (`towMsF`).
    pub tow_ms_f: u32,
    /// Sub-millisecond part of the falling edge, ns (`towSubMsF`).
    pub tow_sub_ms_f_ns: u32,
    /// Accuracy estimate, ns (`accEst`).
    pub acc_est_ns: u32,
}

impl TimTm2 {
    /// Reads the fields from the `ublox` crate's view.
    pub fn from_ublox(p: &ublox::tim_tm2::TimTm2Ref<'_>) -> Self {
        Self {
            channel: p.ch(),
            flags: p.flags_raw(),
            count: p.count(),
            wn_r: p.wn_r(),
            wn_f: p.wn_f(),
            tow_ms_r: p.tow_ms_r(),
            tow_sub_ms_r_ns: p.tow_sub_ms_r(),
            tow_ms_f: p.tow_ms_f(),
            tow_sub_ms_f_ns: p.tow_sub_ms_f(),
            acc_est_ns: p.acc_est(),
        }
    }
}
