//! `--sim`: the simulated robot, exactly as `dima sim --ground-pty` runs it (the same runner
//! from `dima-sim` and the same application from `dima-robot`), in a child process of this
//! binary ([`crate::sim_robot`], behind the default feature `sim`).
//!
//! A child process keeps the robot's threads, signals and pseudo-terminals apart from the
//! user interface, and lets the station stop it like any robot: SIGTERM, after which the
//! application writes its safe outputs and closes its MCAP log. The child re-runs this binary
//! with the hidden first argument `sim-robot`, so nothing else needs to be built. It
//! also asks the kernel for a SIGTERM should the station die first.
//!
//! The two speak ground link v2: the station writes a fresh key into the simulation's run
//! directory ([`LINK_KEY_FILE`], created with mode 0600; or uses the one it was given), the robot
//! runs with that key and `require_auth = true`, and the run directory goes away with the
//! robot.

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use nix::sys::signal::{kill, Signal};
use nix::unistd::Pid;

/// Name of the ground-station pty link in the simulation's run directory.
pub const GROUND_PTY_LINK: &str = "ground-station";
/// Name of the link key the station makes in the simulation's run directory.
pub const LINK_KEY_FILE: &str = "link.key";

/// What the station asks of the simulated robot.
#[derive(Debug, Clone)]
pub struct SimLaunch {
    /// Directory for the robot's MCAP log.
    pub log_dir: PathBuf,
    /// The robot's configuration file (its ports are replaced by the simulation's).
    pub robot_config: Option<PathBuf>,
    /// Stop after this many seconds (None: until the station exits).
    pub duration_s: Option<f64>,
    /// The link key file to use (None: a fresh key in the run directory).
    pub key_file: Option<PathBuf>,
    /// The firmware's emulator build to run as the sensor board (None: the Rust board).
    pub firmware: Option<PathBuf>,
}

/// The running simulated robot.
pub struct SimRobot {
    child: Child,
    run_dir: PathBuf,
    key_file: PathBuf,
}

impl SimRobot {
    /// Starts the robot; its ground pty appears at [`ground_pty`](Self::ground_pty) within a
    /// second or so (the link thread keeps trying until it does).
    pub fn start(launch: &SimLaunch) -> anyhow::Result<SimRobot> {
        let exe = std::env::current_exe()
            .map_err(|e| anyhow::anyhow!("--sim: cannot find this program's path: {e}"))?;
        let run_dir = std::env::temp_dir().join(format!("dima-ground-sim-{}", std::process::id()));
        let key_file = match &launch.key_file {
            Some(path) => path.clone(),
            None => fresh_key(&run_dir)?,
        };
        let mut command = Command::new(exe);
        command
            .arg(crate::sim_robot::SIM_ROBOT_ARG)
            .arg("--run-dir")
            .arg(&run_dir)
            .arg("--key-file")
            .arg(&key_file)
            .arg("--ground-pty")
            .arg("--quiet")
            .arg("--log-dir")
            .arg(&launch.log_dir);
        if let Some(c) = &launch.robot_config {
            command.arg("--config").arg(c);
        }
        if let Some(d) = launch.duration_s {
            command.arg("--duration").arg(d.to_string());
        }
        if let Some(elf) = &launch.firmware {
            command.arg("--firmware").arg(elf);
        }
        let child = command
            .spawn()
            .map_err(|e| anyhow::anyhow!("--sim: cannot start the simulated robot: {e}"))?;
        Ok(SimRobot {
            child,
            run_dir,
            key_file,
        })
    }

    /// The link key file the robot uses (the station must use the same key).
    pub fn key_file(&self) -> &Path {
        &self.key_file
    }

    /// The path of the robot's ground-station pty (a stable link to `/dev/pts/N`).
    pub fn ground_pty(&self) -> PathBuf {
        self.run_dir.join(GROUND_PTY_LINK)
    }

    /// The child's process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Whether the robot has exited (and with what status).
    pub fn exited(&mut self) -> Option<std::process::ExitStatus> {
        self.child.try_wait().ok().flatten()
    }

    /// Stops the robot: SIGTERM, up to `grace` for its safe outputs and log, then SIGKILL.
    pub fn stop(&mut self, grace: Duration) {
        if self.exited().is_some() {
            return;
        }
        if let Ok(pid) = i32::try_from(self.child.id()) {
            let _ = kill(Pid::from_raw(pid), Signal::SIGTERM);
        }
        let t0 = Instant::now();
        while t0.elapsed() < grace {
            if self.exited().is_some() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        eprintln!("dima-ground: the simulated robot did not stop within {grace:?}; killing it");
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for SimRobot {
    fn drop(&mut self) {
        self.stop(Duration::from_secs(5));
    }
}

/// A fresh link key in `<run_dir>/link.key` (the directory created owner-only if missing; a
/// key left there by an earlier run with this process id is replaced).
fn fresh_key(run_dir: &Path) -> anyhow::Result<PathBuf> {
    use std::os::unix::fs::DirBuilderExt;
    std::fs::DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(run_dir)
        .map_err(|e| anyhow::anyhow!("--sim: cannot create {}: {e}", run_dir.display()))?;
    let path = run_dir.join(LINK_KEY_FILE);
    let _ = std::fs::remove_file(&path);
    dima_groundlink::key_file::create(&path).map_err(|e| anyhow::anyhow!("--sim: {e}"))?;
    Ok(path)
}

/// The robot's newest MCAP log in `dir` (for tools and tests).
pub fn newest_log(dir: &Path) -> Option<PathBuf> {
    std::fs::read_dir(dir)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .max_by_key(|p| p.metadata().and_then(|m| m.modified()).ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fresh_key_is_owner_only_and_replaces_a_stale_one() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("dima-ground-simkey-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let first = fresh_key(&dir).unwrap();
        let key = dima_groundlink::key_file::load(&first).unwrap();
        let mode = std::fs::metadata(&first).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
        let dir_mode = std::fs::metadata(&dir).unwrap().permissions().mode();
        assert_eq!(dir_mode & 0o077, 0);
        let second = fresh_key(&dir).unwrap();
        assert_eq!(first, second);
        assert_ne!(dima_groundlink::key_file::load(&second).unwrap(), key);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
