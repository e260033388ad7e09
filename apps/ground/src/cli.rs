//! The command line of `dima-ground`.

use std::path::PathBuf;

use clap::Parser;
use dima_groundlink::v2::LinkKey;

use crate::joystick::config::{default_path, LoadedConfig};
use crate::joystick::JoystickConfigError;

/// The DIMA ground station: drive the robot, kill and revive it, watch its sensors and GNSS,
/// and record the session.
///
/// Keys: Up/Down or W/S throttle, Left/Right or A/D steering, Q/E tail (held: a step from
/// neutral; released: neutral), Space kill (always), R held for one second revive. After a
/// kill, a revive, or the robot reporting KILLED or FAILSAFE, a key, stick or slider still held
/// must be let go and moved again before it drives.
///
/// Replay (--replay FILE.mcap): P play/pause, Left/Right 5 s back/forward, Minus/Plus speed,
/// Home/End start/end of the log; the timeline seeks with a click or a drag.
#[derive(Debug, Clone, Parser)]
#[command(name = "dima-ground", version, about, long_about)]
pub struct Cli {
    /// Connect to this serial port (or pty) at start.
    #[arg(long, value_name = "PATH", conflicts_with = "sim")]
    pub port: Option<PathBuf>,
    /// The link key (one line of 32 hexadecimal characters, readable by its owner only, as
    /// `dima keygen` writes it): the station speaks ground link v2, authenticated. Without
    /// it the station speaks version 1, unauthenticated (robots with `[xbee] require_auth =
    /// false` only). With --sim a fresh key is made for the simulated robot unless this is given.
    #[arg(long, value_name = "PATH")]
    pub key_file: Option<PathBuf>,
    /// Baud rate of the XBee link.
    #[arg(long, default_value_t = 9600, value_name = "N")]
    pub baud: u32,
    /// Run the simulated robot (as `dima sim --ground-pty` does) and connect to it; it stops
    /// when the station exits.
    #[arg(long)]
    pub sim: bool,
    /// Directory of the simulated robot's MCAP log (with --sim).
    #[arg(long, default_value = "dima-logs", value_name = "DIR")]
    pub sim_log_dir: PathBuf,
    /// Stop the simulated robot after this many seconds (with --sim; default: at exit).
    #[arg(long, value_name = "SECONDS", requires = "sim")]
    pub sim_duration: Option<f64>,
    /// With --sim: the sensor board is the board's own firmware under QEMU (its emulator
    /// build, `cargo build --profile qemu --features qemu` in firmware/, or that directory),
    /// as `dima sim --firmware` runs it; needs `qemu-system-arm`. QEMU keeps up with a 50 Hz
    /// loop on a busy machine: set `loop_rate_hz` in --robot-config.
    #[arg(long, value_name = "ELF", requires = "sim")]
    pub firmware: Option<PathBuf>,
    /// The robot's configuration (`dima`'s TOML): its channel table gives the pulse widths
    /// shown, and with --sim the simulated robot runs with it. Default: `dima`'s defaults.
    #[arg(long, value_name = "FILE")]
    pub robot_config: Option<PathBuf>,
    /// A robot MCAP log with a sensor-board info frame: its calibration turns magnetometer and
    /// barometer values into µT, Pa and °C (with --sim the simulated board's is used).
    #[arg(long, value_name = "FILE")]
    pub sensor_info: Option<PathBuf>,
    /// Directory for the session recording (MCAP).
    #[arg(long, default_value = "./dima-ground-logs", value_name = "DIR")]
    pub log_dir: PathBuf,
    /// Do not record the session.
    #[arg(long)]
    pub no_record: bool,
    /// How far a held key moves an axis from neutral, percent.
    #[arg(long, default_value_t = 20, value_name = "PERCENT",
          value_parser = clap::value_parser!(u8).range(1..=50))]
    pub key_step: u8,
    /// The station's joystick configuration (TOML: which gamepad axis drives throttle,
    /// steering and tail, their calibration, dead zone, inversion and expo, the kill button).
    /// It must exist and be valid. Default: `$XDG_CONFIG_HOME/dima/ground.toml` (or
    /// `~/.config/dima/ground.toml`) if it exists, else the documented defaults; the
    /// calibration window saves there.
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Open the "Calibrate joystick" window at start.
    #[arg(long)]
    pub calibrate_joystick: bool,
    /// Render the running window to this PNG after --after seconds, then exit 0.
    #[arg(long, value_name = "FILE")]
    pub screenshot: Option<PathBuf>,
    /// Seconds before the screenshot.
    #[arg(
        long,
        default_value_t = 5.0,
        value_name = "SECONDS",
        requires = "screenshot"
    )]
    pub after: f64,
    /// No alert sounds (the banners still show).
    #[arg(long)]
    pub mute: bool,
    /// Save a screenshot of the window to this directory each time the alert banner, the
    /// drive controls' state or the robot's reported throttle target changes
    /// (`NN-<alert>-<controls>-throttle-<µs>.png`, once the change is drawn).
    #[arg(long, value_name = "DIR")]
    pub state_screenshots: Option<PathBuf>,
    /// Offline map tiles for the Map panel: a directory in the slippy-map layout
    /// `ZOOM/X/Y.png` (Web Mercator, 256 pixels, as tile servers and map downloaders write
    /// them). Read from the disk only; the station never fetches tiles. Missing tiles are
    /// not drawn.
    #[arg(long, value_name = "DIR")]
    pub map_tiles: Option<PathBuf>,
    /// Show this QGroundControl plan on the Map panel: the mission's legs and waypoints and
    /// the inclusion areas of its `geoFence`, read and checked as the robot reads its
    /// `[navigation] mission_file`. For reference: the robot follows its own mission file (the
    /// station does not upload a plan). In a replay of a robot log the map shows the mission
    /// and fence the log records unless --plan is given.
    #[arg(long, value_name = "FILE.plan")]
    pub plan: Option<PathBuf>,
    /// The panel shown in the middle of the window at start (switch with its tabs).
    #[arg(long, value_enum, default_value_t = Panel::Plots, value_name = "PANEL")]
    pub panel: Panel,
    /// Replay this MCAP log instead of driving: a station session log (decoded again, with
    /// --key-file for ground link v2) or a robot log (the reports it would have sent), through
    /// the same panels and plots, with a timeline. Nothing is sent and nothing is recorded.
    #[arg(long, value_name = "FILE.mcap", conflicts_with_all = ["port", "sim"])]
    pub replay: Option<PathBuf>,
    /// Replay speed: 0.25, 0.5, 1, 2, 4 or 8 (the nearest is taken).
    #[arg(
        long,
        default_value_t = 1.0,
        value_name = "FACTOR",
        requires = "replay"
    )]
    pub replay_speed: f64,
    /// Start the replay playing, and pause it when the log time reaches this many seconds
    /// (without it the replay starts paused at the start).
    #[arg(long, value_name = "SECONDS", requires = "replay")]
    pub replay_pause_at: Option<f64>,
    /// Window size in logical pixels, WIDTHxHEIGHT.
    #[arg(long, default_value = "1400x900", value_name = "WxH", value_parser = parse_size)]
    pub window_size: (f32, f32),
}

/// The panels of the middle of the window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Panel {
    /// Sensor and GNSS plots.
    Plots,
    /// The track and the car on a metre grid, over offline map tiles when given.
    Map,
}

fn parse_size(text: &str) -> Result<(f32, f32), String> {
    let (w, h) = text
        .split_once('x')
        .ok_or_else(|| format!("`{text}`: expected WIDTHxHEIGHT, e.g. 1400x900"))?;
    let n = |s: &str| {
        s.trim()
            .parse::<f32>()
            .ok()
            .filter(|v| (200.0..=10_000.0).contains(v))
            .ok_or_else(|| format!("`{s}`: expected a size between 200 and 10000"))
    };
    Ok((n(w)?, n(h)?))
}

impl Cli {
    /// The link key of `--key-file` (ground link v2) and a note for the window; `None` and
    /// "not authenticated (v1)" without it. A key file its group or others can read is refused
    /// with the loader's error, which names the file and the `chmod` that fixes it.
    pub fn link_key(&self) -> anyhow::Result<(Option<LinkKey>, String)> {
        Ok(match &self.key_file {
            Some(path) => (
                Some(dima_groundlink::key_file::load(path)?),
                format!("ground link v2, authenticated (key {})", path.display()),
            ),
            None => (None, "not authenticated (v1)".to_owned()),
        })
    }

    /// The joystick configuration: `--config FILE`, else the default file if it exists, else
    /// the defaults. A file that is missing (with `--config`), unreadable or invalid is an
    /// error naming the file and the key: the station does not start on it.
    pub fn joystick_config(&self) -> Result<LoadedConfig, JoystickConfigError> {
        crate::joystick::config::load(self.config.as_deref(), default_path())
    }

    /// Checks what clap cannot.
    pub fn validate(&self) -> anyhow::Result<()> {
        if !(self.after.is_finite() && self.after >= 0.0) {
            anyhow::bail!("--after must be a number of seconds >= 0");
        }
        if crate::serial::baud_rate(self.baud).is_none() {
            anyhow::bail!("--baud {}: not a standard rate", self.baud);
        }
        if self.sim && !cfg!(feature = "sim") {
            anyhow::bail!(
                "--sim: this dima-ground was built without the simulator (cargo feature `sim`)"
            );
        }
        if let Some(dir) = &self.map_tiles {
            if !dir.is_dir() {
                anyhow::bail!("--map-tiles {}: not a directory", dir.display());
            }
        }
        if !(self.replay_speed.is_finite() && self.replay_speed > 0.0) {
            anyhow::bail!("--replay-speed must be a positive factor");
        }
        if let Some(t) = self.replay_pause_at {
            if !(t.is_finite() && t >= 0.0) {
                anyhow::bail!("--replay-pause-at must be a number of seconds >= 0");
            }
        }
        if let Some(d) = self.sim_duration {
            if !(d.is_finite() && d > 0.0) {
                anyhow::bail!("--sim-duration must be a positive number of seconds");
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags() {
        let c = Cli::try_parse_from(["dima-ground", "--port", "/dev/pts/4", "--baud", "115200"])
            .unwrap();
        assert_eq!(c.port, Some(PathBuf::from("/dev/pts/4")));
        assert_eq!(c.baud, 115_200);
        assert_eq!(c.key_file, None);
        assert_eq!(c.log_dir, PathBuf::from("./dima-ground-logs"));
        assert_eq!(c.key_step, 20);
        assert_eq!(c.window_size, (1400.0, 900.0));
        assert_eq!((c.map_tiles.clone(), c.panel), (None, Panel::Plots));
        assert_eq!(c.config, None);
        assert!(!c.calibrate_joystick);
        c.validate().unwrap();

        let c = Cli::try_parse_from([
            "dima-ground",
            "--sim",
            "--screenshot",
            "a.png",
            "--after",
            "7",
            "--window-size",
            "800x600",
        ])
        .unwrap();
        assert!(c.sim);
        assert_eq!(c.after, 7.0);
        assert_eq!(c.window_size, (800.0, 600.0));

        let tiles = std::env::temp_dir();
        let c = Cli::try_parse_from([
            "dima-ground",
            "--map-tiles",
            tiles.to_str().unwrap(),
            "--panel",
            "map",
        ])
        .unwrap();
        assert_eq!(
            (c.map_tiles.clone(), c.panel),
            (Some(tiles.clone()), Panel::Map)
        );
        c.validate().unwrap();
        let missing = Cli::try_parse_from(["dima-ground", "--map-tiles", "/no/such/tiles"]);
        assert!(missing.unwrap().validate().is_err());
        assert!(Cli::try_parse_from(["dima-ground", "--panel", "radar"]).is_err());

        let c = Cli::try_parse_from(["dima-ground", "--key-file", "/etc/dima/link.key"]).unwrap();
        assert_eq!(c.key_file, Some(PathBuf::from("/etc/dima/link.key")));
        assert!(Cli::try_parse_from(["dima-ground", "--sim", "--port", "/dev/x"]).is_err());
        assert!(Cli::try_parse_from(["dima-ground", "--key-step", "0"]).is_err());
        assert!(Cli::try_parse_from(["dima-ground", "--window-size", "big"]).is_err());
        let bad = Cli::try_parse_from(["dima-ground", "--baud", "1234"]).unwrap();
        assert!(bad.validate().is_err());
    }

    #[test]
    fn replay_flags() {
        let c = Cli::try_parse_from([
            "dima-ground",
            "--replay",
            "run.mcap",
            "--replay-speed",
            "4",
            "--replay-pause-at",
            "12.5",
        ])
        .unwrap();
        assert_eq!(c.replay, Some(PathBuf::from("run.mcap")));
        assert_eq!((c.replay_speed, c.replay_pause_at), (4.0, Some(12.5)));
        c.validate().unwrap();
        assert!(Cli::try_parse_from(["dima-ground", "--replay", "a", "--sim"]).is_err());
        assert!(Cli::try_parse_from(["dima-ground", "--replay", "a", "--port", "/dev/x"]).is_err());
        assert!(Cli::try_parse_from(["dima-ground", "--replay-speed", "2"]).is_err());
        let slow =
            Cli::try_parse_from(["dima-ground", "--replay", "a", "--replay-speed", "0"]).unwrap();
        assert!(slow.validate().is_err());
    }

    #[test]
    fn a_key_file_others_can_read_is_refused() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("dima-ground-key-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("link.key");
        let key = dima_groundlink::key_file::create(&path).unwrap();
        let cli =
            Cli::try_parse_from(["dima-ground", "--key-file", path.to_str().unwrap()]).unwrap();
        let (loaded, note) = cli.link_key().unwrap();
        assert_eq!(loaded, Some(key));
        assert!(note.contains("v2"), "{note}");
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o644)).unwrap();
        let error = format!("{:#}", cli.link_key().unwrap_err());
        assert!(error.contains("chmod 600"), "{error}");
        assert!(error.contains(path.to_str().unwrap()), "{error}");
        let v1 = Cli::try_parse_from(["dima-ground"])
            .unwrap()
            .link_key()
            .unwrap();
        assert_eq!(v1, (None, "not authenticated (v1)".to_owned()));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn config_names_the_joystick_file_and_a_bad_one_is_refused() {
        let dir = std::env::temp_dir().join(format!("dima-ground-config-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("ground.toml");
        std::fs::write(
            &path,
            "kill_button = \"Start\"\n[tail]\naxis = \"RightStickY\"\n",
        )
        .unwrap();
        let cli = Cli::try_parse_from(["dima-ground", "--config", path.to_str().unwrap()]).unwrap();
        let loaded = cli.joystick_config().unwrap();
        assert_eq!(loaded.config.kill_button, crate::joystick::PadButton::Start);
        assert_eq!(loaded.path, Some(path.clone()));
        std::fs::write(&path, "[steering]\nexpo = 2.0\n").unwrap();
        let error = cli.joystick_config().unwrap_err().to_string();
        assert!(error.contains("steering.expo"), "{error}");
        assert!(error.contains(path.to_str().unwrap()), "{error}");
        std::fs::remove_file(&path).unwrap();
        assert!(
            cli.joystick_config().is_err(),
            "a missing --config file is an error"
        );
        let c = Cli::try_parse_from(["dima-ground", "--calibrate-joystick"]).unwrap();
        assert!(c.calibrate_joystick);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
