//! The DIMA ground station: the operator's side of the ground link.
//!
//! The user interface ([`ui`]) is a thin layer over plain modules, each with one job and its
//! own tests:
//! - [`serial`]: opening a serial port (or a pseudo-terminal) raw at a baud rate, and listing
//!   the ports a robot's XBee could be on;
//! - [`link`]: the link thread that owns the port: sends what the station logic of
//!   [`dima_groundlink::station`] says (which command frames go out when; with v2, numbered and
//!   repeated until the robot acknowledges them), decodes display frames, counts everything,
//!   reconnects, and never blocks the user interface;
//! - [`keys`]: the keyboard contract (arrows/WASD, Q/E, Space kills, R held 1 s revives) as a
//!   pure function of the keys held and the time;
//! - [`control`]: keys, gamepad and sliders merged into what the link holds and sends;
//! - [`gamepad`]: sticks and a kill button through `gilrs`;
//! - [`joystick`]: the gamepad's axes, calibration, dead zone, inversion, expo and kill
//!   button, their file, and the calibration flow;
//! - [`channels`]: percent to pulse width from the robot's channel table;
//! - [`units`]: display-frame values in physical units, compensated with the sensor board's
//!   calibration when it is known;
//! - [`telemetry`]: the latest display frame in physical units and its history;
//! - [`plots`]: time-series buffers and the GNSS track in local metres;
//! - [`map`]: the map panel's geometry: Web Mercator tiles, the metre grid on the screen,
//!   the scale bar, offline tiles and their cache, the heading setpoint drawn;
//! - [`downlink`]: what the station can say about the robot's reports (authentic, or why
//!   not: a wrong key, a v1 station and a v2 robot, silence), as a pure function;
//! - [`robot_view`]: what the station shows as the robot's state: its reported outputs and
//!   setpoints (never the station's intent), whether the drive controls can act, the
//!   downlink's loss from its sequence numbers;
//! - [`alerts`]: which alert the operator must see (FAILSAFE with its cause, a kill, the link
//!   lost and regained, a refused revive) and when it clears, as a pure function;
//! - [`sound`]: the alerts' sounds through the system's command-line player, or skipped;
//! - [`recording`]: the session log (everything sent and received, timestamped) as MCAP;
//! - [`replay`]: `--replay`, a station session log or a robot log played back through the
//!   same panels, with a replay clock (play, pause, seek, speed) in virtual time;
//! - [`sim`]: `--sim`, the simulated robot exactly as `dima sim --ground-pty` runs it, in a
//!   child process;
//! - [`cli`]: the command line.
#![deny(missing_docs)]

pub mod alerts;
pub mod channels;
pub mod cli;
pub mod control;
pub mod downlink;
pub mod gamepad;
pub mod joystick;
pub mod keys;
pub mod link;
pub mod map;
pub mod plots;
pub mod recording;
pub mod replay;
pub mod robot_view;
pub mod serial;
pub mod sim;
pub mod sim_robot;
pub mod sound;
pub mod telemetry;
pub mod ui;
pub mod units;
