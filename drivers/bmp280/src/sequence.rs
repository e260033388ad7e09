//! The bring-up and measurement sequences as plain data and functions, shared by the blocking
//! and async drivers so both issue the same register accesses with the same timing. Firmware
//! that drives the bus itself (DMA, interrupts) can follow the same steps with these values.

use crate::config::{Config, PowerMode};
use crate::register::{self, Status};

/// Start-up time after power-on or soft reset before the device answers (datasheet table 2,
/// `t_startup` 2 ms).
pub const STARTUP_US: u32 = 2000;
/// Wait between two `im_update` polls after the start-up time.
pub const NVM_POLL_INTERVAL_US: u32 = 1000;
/// `status` reads allowed for the NVM copy to finish before giving up (5 ms in all after the
/// start-up time, well above the copy's duration).
pub const NVM_POLLS: u32 = 5;
/// Wait between two `measuring` polls of a forced measurement.
pub const FORCED_POLL_INTERVAL_US: u32 = 500;
/// Slack beyond the datasheet's maximum measurement time before a forced measurement counts as
/// timed out (covers the tolerance of the caller's delay).
pub const FORCED_TIMEOUT_MARGIN_US: u32 = 2000;

/// The register writes that apply `config`, in order: `ctrl_meas` with sleep mode (the datasheet
/// says `config` writes may be ignored in normal mode), then `config`, then `ctrl_meas` with the
/// requested mode, which starts measuring in normal or forced mode.
pub const fn config_writes(config: &Config) -> [(u8, u8); 3] {
    [
        (
            register::CTRL_MEAS,
            config.with_mode(PowerMode::Sleep).ctrl_meas(),
        ),
        (register::CONFIG, config.config_register()),
        (register::CTRL_MEAS, config.ctrl_meas()),
    ]
}

/// The `ctrl_meas` value that starts one forced measurement with `config`'s oversampling.
pub const fn forced_start(config: &Config) -> u8 {
    config.with_mode(PowerMode::Forced).ctrl_meas()
}

/// The configuration the device holds after power-on or soft reset (all registers 0: sleep,
/// both measurements skipped).
pub const fn reset_config() -> Config {
    Config::from_registers(0, 0)
}

/// True while the NVM copy runs.
pub const fn nvm_busy(status: u8) -> bool {
    Status::from_bits_truncate(status).contains(Status::IM_UPDATE)
}

/// True while a conversion runs.
pub const fn measuring(status: u8) -> bool {
    Status::from_bits_truncate(status).contains(Status::MEASURING)
}

/// True while a forced measurement may still be running, from `status` (0xF3) and `ctrl_meas`
/// (0xF4) read in one burst.
///
/// The `measuring` bit alone is not enough: right after the `ctrl_meas` write that starts a
/// forced measurement it can still read 0 for a moment, and a poll then would hand out the
/// previous sample. The mode bits stay at forced until the device has finished and returned to
/// sleep (datasheet 3.6.2), so either sign means "not ready yet".
pub const fn forced_busy(status: u8, ctrl_meas: u8) -> bool {
    measuring(status) || matches!(PowerMode::from_bits(ctrl_meas), PowerMode::Forced)
}

/// Number of data-register reads, one every [`FORCED_POLL_INTERVAL_US`], that cover the first
/// conversion after `config` was applied: its maximum measurement time plus
/// [`FORCED_TIMEOUT_MARGIN_US`].
pub const fn first_conversion_polls(config: &Config) -> u32 {
    (config.measurement_time_max_us() + FORCED_TIMEOUT_MARGIN_US) / FORCED_POLL_INTERVAL_US + 1
}

/// Number of `measuring` polls after waiting the typical time, so that the total wait covers the
/// maximum time plus [`FORCED_TIMEOUT_MARGIN_US`].
pub const fn forced_polls(config: &Config) -> u32 {
    let extra = config.measurement_time_max_us() - config.measurement_time_typ_us()
        + FORCED_TIMEOUT_MARGIN_US;
    extra / FORCED_POLL_INTERVAL_US + 1
}
