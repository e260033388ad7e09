//! The joystick as the operator set it up: which gamepad axis drives throttle, steering and
//! tail, each axis's calibration (centre and range), dead zone, inversion and expo, and the
//! kill button; the file that keeps them and the calibration that measures them.
//!
//! - [`names`]: the gamepad axes and buttons by name, as the file spells them;
//! - [`shaping`]: a raw axis value to a stick deflection in -1..=1, as pure functions;
//! - [`config`]: the TOML file (`dima-ground --config FILE`, default
//!   `$XDG_CONFIG_HOME/dima/ground.toml`);
//! - [`calibration`]: the calibration flow (ends, then centre) as a pure state machine.

pub mod calibration;
pub mod config;
pub mod names;
pub mod shaping;

pub use calibration::{CalibrationFlow, CalibrationStep};
pub use config::{JoystickConfig, JoystickConfigError};
pub use names::{AxesSample, PadButton, StickAxis};
pub use shaping::AxisCalibration;
