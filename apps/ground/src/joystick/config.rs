//! The joystick configuration file: TOML, read at start (`dima-ground --config FILE`, else
//! [`default_path`] when it exists, else the defaults) and written by the calibration window.
//!
//! Every key is optional and has a documented default, so an empty or missing file works. An
//! unknown key, a wrong type, a name that is not a gamepad axis or button, or a value out of
//! range is an error that names the key, and the station does not start on it.
//!
//! ```toml
//! kill_button = "South"      # the gamepad button that kills
//!
//! [throttle]                 # likewise [steering] and [tail]
//! axis = "LeftStickY"        # a gamepad axis, or "none"
//! centre = 0.0               # raw value with the stick released
//! min = -1.0                 # raw value at the lower end
//! max = 1.0                  # raw value at the upper end
//! dead_zone = 0.12           # normalised deflection counted as released, 0..=0.5
//! invert = false
//! expo = 0.0                 # out = (1 - e)·x + e·x³, e in 0..=1
//! ```

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

use dima_groundlink::station::ManualChannel;
use serde::Deserialize;

use super::names::{PadButton, StickAxis};
use super::shaping::AxisCalibration;

/// The file name under the configuration directory's `dima/`.
pub const FILE_NAME: &str = "ground.toml";

/// The largest dead zone accepted: more than half the travel is a mistake.
pub const MAX_DEAD_ZONE: f32 = 0.5;

/// How the station reads the gamepad.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JoystickConfig {
    /// Throttle: by default the left stick's vertical axis.
    pub throttle: AxisCalibration,
    /// Steering: by default the right stick's horizontal axis.
    pub steering: AxisCalibration,
    /// Tail: by default not on the gamepad.
    pub tail: AxisCalibration,
    /// The button that kills: by default South (A on Xbox pads, × on PlayStation pads).
    pub kill_button: PadButton,
}

impl Default for JoystickConfig {
    fn default() -> Self {
        JoystickConfig {
            throttle: AxisCalibration::on(Some(StickAxis::LeftStickY)),
            steering: AxisCalibration::on(Some(StickAxis::RightStickX)),
            tail: AxisCalibration::on(None),
            kill_button: PadButton::South,
        }
    }
}

/// Why the joystick configuration cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum JoystickConfigError {
    /// The file cannot be read.
    #[error("{}: cannot read the joystick configuration: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why (part of the message).
        error: io::Error,
    },
    /// Not TOML, an unknown key, or a value of the wrong type (the message names the key and
    /// shows the line).
    #[error("{origin}: {message}")]
    Parse {
        /// The file.
        origin: String,
        /// What the TOML reader says.
        message: String,
    },
    /// A value the station cannot use.
    #[error("{origin}: `{key}` {reason}")]
    Invalid {
        /// The file.
        origin: String,
        /// The key, with its section: `throttle.expo`.
        key: String,
        /// What is wrong and what is accepted.
        reason: String,
    },
    /// The file cannot be written.
    #[error("{}: cannot write the joystick configuration: {error}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// Why (part of the message).
        error: io::Error,
    },
}

/// The file as written: every key optional, nothing unknown.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileText {
    kill_button: Option<String>,
    throttle: Option<AxisSection>,
    steering: Option<AxisSection>,
    tail: Option<AxisSection>,
}

/// One `[throttle]`, `[steering]` or `[tail]` section as written.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisSection {
    axis: Option<String>,
    centre: Option<f32>,
    min: Option<f32>,
    max: Option<f32>,
    dead_zone: Option<f32>,
    invert: Option<bool>,
    expo: Option<f32>,
}

/// The configuration as the station starts with it.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedConfig {
    /// What was read (or the defaults).
    pub config: JoystickConfig,
    /// Where the calibration window saves (`None`: no configuration directory is known).
    pub path: Option<PathBuf>,
    /// Where the configuration came from, for the window.
    pub note: String,
}

/// The default file: `$XDG_CONFIG_HOME/dima/ground.toml`, else `$HOME/.config/dima/ground.toml`.
pub fn default_path() -> Option<PathBuf> {
    default_path_from(
        std::env::var_os("XDG_CONFIG_HOME").map(PathBuf::from),
        std::env::var_os("HOME").map(PathBuf::from),
    )
}

/// [`default_path`] from the two variables' values (an empty or relative `XDG_CONFIG_HOME`
/// is ignored, as the XDG base directory specification says).
pub fn default_path_from(
    xdg_config_home: Option<PathBuf>,
    home: Option<PathBuf>,
) -> Option<PathBuf> {
    let dir = xdg_config_home
        .filter(|p| p.is_absolute())
        .or_else(|| home.filter(|p| p.is_absolute()).map(|h| h.join(".config")))?;
    Some(dir.join("dima").join(FILE_NAME))
}

/// Reads the configuration: `explicit` (`--config FILE`: it must exist), else `default`
/// when it exists, else the defaults (saved to `default` by the calibration window).
pub fn load(
    explicit: Option<&Path>,
    default: Option<PathBuf>,
) -> Result<LoadedConfig, JoystickConfigError> {
    if let Some(path) = explicit {
        let config = read(path)?;
        return Ok(LoadedConfig {
            config,
            path: Some(path.to_owned()),
            note: path.display().to_string(),
        });
    }
    let Some(path) = default else {
        return Ok(LoadedConfig {
            config: JoystickConfig::default(),
            path: None,
            note: "defaults (no configuration directory: neither XDG_CONFIG_HOME nor HOME)"
                .to_owned(),
        });
    };
    match std::fs::read_to_string(&path) {
        Ok(text) => Ok(LoadedConfig {
            config: JoystickConfig::from_toml(&text, &path.display().to_string())?,
            note: path.display().to_string(),
            path: Some(path),
        }),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(LoadedConfig {
            config: JoystickConfig::default(),
            note: format!("defaults (no {})", path.display()),
            path: Some(path),
        }),
        Err(error) => Err(JoystickConfigError::Read { path, error }),
    }
}

/// Reads and checks one file.
pub fn read(path: &Path) -> Result<JoystickConfig, JoystickConfigError> {
    let text = std::fs::read_to_string(path).map_err(|error| JoystickConfigError::Read {
        path: path.to_owned(),
        error,
    })?;
    JoystickConfig::from_toml(&text, &path.display().to_string())
}

impl JoystickConfig {
    /// Parses and checks a file's text; `origin` (the file's name) starts every error.
    pub fn from_toml(text: &str, origin: &str) -> Result<JoystickConfig, JoystickConfigError> {
        let file: FileText = toml::from_str(text).map_err(|e| JoystickConfigError::Parse {
            origin: origin.to_owned(),
            message: e.to_string().trim_end().to_owned(),
        })?;
        let invalid = |key: &str, reason: String| JoystickConfigError::Invalid {
            origin: origin.to_owned(),
            key: key.to_owned(),
            reason,
        };
        let defaults = JoystickConfig::default();
        let kill_button = match file.kill_button {
            None => defaults.kill_button,
            Some(name) => PadButton::from_name(&name).ok_or_else(|| {
                invalid(
                    "kill_button",
                    format!(
                        "= \"{name}\": not a gamepad button; one of {}",
                        button_names()
                    ),
                )
            })?,
        };
        let mut config = JoystickConfig {
            kill_button,
            ..defaults
        };
        for (channel, section) in
            ManualChannel::ALL
                .into_iter()
                .zip([file.throttle, file.steering, file.tail])
        {
            let axis = section
                .unwrap_or_default()
                .resolve(*defaults.channel(channel), channel.name())
                .map_err(|(key, reason)| invalid(&key, reason))?;
            *config.channel_mut(channel) = axis;
        }
        config
            .check_distinct_axes()
            .map_err(|(key, reason)| invalid(&key, reason))?;
        Ok(config)
    }

    /// The channel's calibration.
    pub fn channel(&self, channel: ManualChannel) -> &AxisCalibration {
        match channel {
            ManualChannel::Throttle => &self.throttle,
            ManualChannel::Steering => &self.steering,
            ManualChannel::Tail => &self.tail,
        }
    }

    /// The channel's calibration, to change.
    pub fn channel_mut(&mut self, channel: ManualChannel) -> &mut AxisCalibration {
        match channel {
            ManualChannel::Throttle => &mut self.throttle,
            ManualChannel::Steering => &mut self.steering,
            ManualChannel::Tail => &mut self.tail,
        }
    }

    /// Checks what the file reader checks (for a configuration built in the window): the same
    /// error, with `origin` naming where it was going.
    pub fn validate(&self, origin: &str) -> Result<(), JoystickConfigError> {
        JoystickConfig::from_toml(&self.to_toml(), origin).map(|_| ())
    }

    /// No axis drives two channels.
    fn check_distinct_axes(&self) -> Result<(), (String, String)> {
        let mut taken: Vec<(StickAxis, ManualChannel)> = Vec::new();
        for channel in ManualChannel::ALL {
            let Some(axis) = self.channel(channel).axis else {
                continue;
            };
            if let Some((_, other)) = taken.iter().find(|(a, _)| *a == axis) {
                return Err((
                    format!("{}.axis", channel.name()),
                    format!("= \"{axis}\": already the axis of {}", other.name()),
                ));
            }
            taken.push((axis, channel));
        }
        Ok(())
    }

    /// The whole file, every key written, with comments: what the calibration window saves.
    pub fn to_toml(&self) -> String {
        let mut out = String::new();
        out.push_str(
            "# dima-ground joystick configuration (see the station's README).\n\
             # Saved by the \"Calibrate joystick\" window; every key is optional.\n\n",
        );
        out.push_str("# The gamepad button that kills, one of:\n");
        for names in PadButton::ALL.chunks(10) {
            let names: Vec<&str> = names.iter().map(|b| b.name()).collect();
            let _ = writeln!(out, "#   {}", names.join(", "));
        }
        let _ = writeln!(out, "kill_button = \"{}\"", self.kill_button);
        for channel in ManualChannel::ALL {
            let a = self.channel(channel);
            let axis = a.axis.map_or("none", StickAxis::name);
            let _ = write!(
                out,
                "\n[{}]\naxis = \"{axis}\"\ncentre = {:?}\nmin = {:?}\nmax = {:?}\n\
                 dead_zone = {:?}\ninvert = {}\nexpo = {:?}\n",
                channel.name(),
                a.centre,
                a.min,
                a.max,
                a.dead_zone,
                a.invert,
                a.expo
            );
        }
        out
    }

    /// Writes [`JoystickConfig::to_toml`] to `path` (creating its directory), through a
    /// temporary file renamed over it, so a crash never leaves half a file.
    pub fn save(&self, path: &Path) -> Result<(), JoystickConfigError> {
        let write_error = |error| JoystickConfigError::Write {
            path: path.to_owned(),
            error,
        };
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(write_error)?;
        }
        let mut temporary = path.as_os_str().to_owned();
        temporary.push(".tmp");
        let temporary = PathBuf::from(temporary);
        std::fs::write(&temporary, self.to_toml()).map_err(write_error)?;
        std::fs::rename(&temporary, path).map_err(write_error)
    }
}

impl AxisSection {
    /// The section over `defaults`, checked; an error is the key (`throttle.expo`) and why.
    fn resolve(
        self,
        defaults: AxisCalibration,
        section: &str,
    ) -> Result<AxisCalibration, (String, String)> {
        let key = |name: &str| format!("{section}.{name}");
        let axis = match self.axis.as_deref() {
            None => defaults.axis,
            Some("none") => None,
            Some(name) => Some(StickAxis::from_name(name).ok_or_else(|| {
                (
                    key("axis"),
                    format!(
                        "= \"{name}\": not a gamepad axis; one of {}, or \"none\"",
                        StickAxis::ALL.map(StickAxis::name).join(", ")
                    ),
                )
            })?),
        };
        let a = AxisCalibration {
            axis,
            centre: self.centre.unwrap_or(defaults.centre),
            min: self.min.unwrap_or(defaults.min),
            max: self.max.unwrap_or(defaults.max),
            dead_zone: self.dead_zone.unwrap_or(defaults.dead_zone),
            invert: self.invert.unwrap_or(defaults.invert),
            expo: self.expo.unwrap_or(defaults.expo),
        };
        let within = |name: &str, v: f32, lo: f32, hi: f32| {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err((key(name), format!("= {v}: must be between {lo} and {hi}")))
            }
        };
        within("centre", a.centre, -1.0, 1.0)?;
        within("min", a.min, -1.0, 1.0)?;
        within("max", a.max, -1.0, 1.0)?;
        within("dead_zone", a.dead_zone, 0.0, MAX_DEAD_ZONE)?;
        within("expo", a.expo, 0.0, 1.0)?;
        if a.min >= a.centre {
            return Err((
                key("min"),
                format!(
                    "= {}: must be below {} = {}",
                    a.min,
                    key("centre"),
                    a.centre
                ),
            ));
        }
        if a.max <= a.centre {
            return Err((
                key("max"),
                format!(
                    "= {}: must be above {} = {}",
                    a.max,
                    key("centre"),
                    a.centre
                ),
            ));
        }
        Ok(a)
    }
}

/// Every button name, for messages.
fn button_names() -> String {
    PadButton::ALL.map(PadButton::name).join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn error(text: &str) -> String {
        JoystickConfig::from_toml(text, "ground.toml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn an_empty_file_is_the_documented_defaults() {
        let c = JoystickConfig::from_toml("", "ground.toml").unwrap();
        assert_eq!(c, JoystickConfig::default());
        assert_eq!(c.throttle.axis, Some(StickAxis::LeftStickY));
        assert_eq!(c.steering.axis, Some(StickAxis::RightStickX));
        assert_eq!(c.tail.axis, None);
        assert_eq!(c.kill_button, PadButton::South);
        for a in [c.throttle, c.steering, c.tail] {
            assert_eq!((a.centre, a.min, a.max), (0.0, -1.0, 1.0));
            assert_eq!((a.dead_zone, a.invert, a.expo), (0.12, false, 0.0));
        }
    }

    #[test]
    fn a_section_overrides_only_its_keys() {
        let c = JoystickConfig::from_toml(
            "kill_button = \"East\"\n[steering]\nexpo = 0.4\ninvert = true\n[tail]\naxis = \"LeftStickX\"\ncentre = 0\n",
            "ground.toml",
        )
        .unwrap();
        assert_eq!(c.kill_button, PadButton::East);
        assert_eq!(
            c.steering.axis,
            Some(StickAxis::RightStickX),
            "default axis kept"
        );
        assert_eq!((c.steering.expo, c.steering.invert), (0.4, true));
        assert_eq!(c.tail.axis, Some(StickAxis::LeftStickX));
        assert_eq!(c.throttle, JoystickConfig::default().throttle);
        let c = JoystickConfig::from_toml("[throttle]\naxis = \"none\"\n", "g").unwrap();
        assert_eq!(c.throttle.axis, None);
    }

    #[test]
    fn a_bad_file_is_refused_naming_the_key() {
        let e = error("[throttle]\nexpos = 0.3\n");
        assert!(e.contains("ground.toml") && e.contains("expos"), "{e}");
        let e = error("kill = \"South\"\n");
        assert!(e.contains("kill"), "{e}");
        let e = error("[rudder]\naxis = \"LeftStickX\"\n");
        assert!(e.contains("rudder"), "{e}");
        let e = error("[steering]\nexpo = \"much\"\n");
        assert!(e.contains("expo"), "{e}");
        let e = error("[steering]\nexpo = 1.5\n");
        assert!(e.contains("`steering.expo` = 1.5"), "{e}");
        let e = error("[tail]\ndead_zone = -0.1\n");
        assert!(e.contains("`tail.dead_zone`"), "{e}");
        let e = error("[throttle]\naxis = \"LeftStick\"\n");
        assert!(
            e.contains("`throttle.axis`") && e.contains("LeftStickY"),
            "{e}"
        );
        let e = error("kill_button = \"A\"\n");
        assert!(e.contains("`kill_button`") && e.contains("South"), "{e}");
        let e = error("[throttle]\ncentre = 0.5\nmax = 0.4\n");
        assert!(
            e.contains("`throttle.max` = 0.4: must be above throttle.centre"),
            "{e}"
        );
        let e = error("[throttle]\nmin = 0.1\n");
        assert!(e.contains("`throttle.min`"), "{e}");
        let e = error("[tail]\naxis = \"LeftStickY\"\n");
        assert!(e.contains("`tail.axis`") && e.contains("throttle"), "{e}");
        let e = error("[throttle\n");
        assert!(e.contains("ground.toml"), "{e}");
    }

    #[test]
    fn what_is_saved_reads_back_the_same() {
        let mut c = JoystickConfig {
            throttle: AxisCalibration {
                axis: Some(StickAxis::RightStickY),
                centre: 0.0312,
                min: -0.9371,
                max: 0.955,
                dead_zone: 0.05,
                invert: true,
                expo: 0.35,
            },
            ..JoystickConfig::default()
        };
        c.steering.axis = Some(StickAxis::LeftStickX);
        c.tail.axis = Some(StickAxis::RightStickX);
        c.kill_button = PadButton::RightTrigger;
        let text = c.to_toml();
        assert_eq!(
            JoystickConfig::from_toml(&text, "saved").unwrap(),
            c,
            "{text}"
        );
        c.validate("saved").unwrap();
        c.tail.axis = Some(StickAxis::LeftStickX);
        assert!(c.validate("saved").is_err(), "two channels on one axis");

        let dir = std::env::temp_dir().join(format!("dima-ground-joystick-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let path = dir.join("dima").join(FILE_NAME);
        c.tail.axis = None;
        c.save(&path).unwrap();
        assert_eq!(read(&path).unwrap(), c);
        let loaded = load(None, Some(path.clone())).unwrap();
        assert_eq!((loaded.config, loaded.path), (c, Some(path.clone())));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_missing_default_file_is_the_defaults_but_a_missing_explicit_one_is_an_error() {
        let dir = std::env::temp_dir().join(format!(
            "dima-ground-joystick-missing-{}",
            std::process::id()
        ));
        let path = dir.join(FILE_NAME);
        let loaded = load(None, Some(path.clone())).unwrap();
        assert_eq!(loaded.config, JoystickConfig::default());
        assert_eq!(loaded.path, Some(path.clone()));
        assert!(loaded.note.contains("defaults"), "{}", loaded.note);
        let e = load(Some(&path), None).unwrap_err().to_string();
        assert!(e.contains(path.to_str().unwrap()), "{e}");
        let none = load(None, None).unwrap();
        assert_eq!((none.config, none.path), (JoystickConfig::default(), None));
    }

    /// The complete example of the station's README.
    fn readme_example() -> &'static str {
        let readme = include_str!("../../README.md");
        let start = readme
            .find("```toml\n# dima-ground joystick configuration")
            .expect("the README has the joystick example")
            + "```toml\n".len();
        let len = readme[start..].find("```").expect("the example ends");
        &readme[start..start + len]
    }

    #[test]
    fn the_readme_example_parses_and_names_every_key() {
        let text = readme_example();
        let c = JoystickConfig::from_toml(text, "README.md").unwrap();
        let defaults = JoystickConfig::default();
        assert_eq!(c.kill_button, defaults.kill_button);
        assert_eq!(c.throttle, defaults.throttle);
        assert_eq!(c.steering.expo, 0.3);
        assert_eq!(c.steering.axis, defaults.steering.axis);
        assert_eq!(c.tail.axis, Some(StickAxis::RightStickY));
        assert_eq!(
            AxisCalibration {
                axis: None,
                ..c.tail
            },
            defaults.tail
        );
        // Complete: every key of every section is in it.
        for key in ["kill_button", "[throttle]", "[steering]", "[tail]"] {
            assert!(text.contains(key), "{key}");
        }
        for key in [
            "axis",
            "centre",
            "min",
            "max",
            "dead_zone",
            "invert",
            "expo",
        ] {
            assert_eq!(text.matches(&format!("\n{key} = ")).count(), 3, "{key}");
        }
        // Every axis and button name the example lists is one the file accepts.
        for axis in StickAxis::ALL {
            assert!(text.contains(axis.name()), "{axis}");
        }
        for button in PadButton::ALL {
            assert!(text.contains(button.name()), "{button}");
        }
    }

    #[test]
    fn the_default_path_follows_xdg() {
        let p = |x: Option<&str>, h: Option<&str>| {
            default_path_from(x.map(PathBuf::from), h.map(PathBuf::from))
        };
        assert_eq!(
            p(Some("/cfg"), Some("/home/op")),
            Some(PathBuf::from("/cfg/dima/ground.toml"))
        );
        assert_eq!(
            p(None, Some("/home/op")),
            Some(PathBuf::from("/home/op/.config/dima/ground.toml"))
        );
        assert_eq!(
            p(Some("relative"), Some("/home/op")),
            Some(PathBuf::from("/home/op/.config/dima/ground.toml"))
        );
        assert_eq!(p(Some(""), None), None);
    }
}
