//! Serial ports: open one raw (8N1, no flow control) at a baud rate, and list the candidates.
//!
//! A pseudo-terminal (`dima sim --ground-pty` prints one) opens the same way: its baud rate is
//! accepted and has no effect.

use std::fs::{File, OpenOptions};
use std::os::fd::AsFd;
use std::os::unix::fs::OpenOptionsExt;
use std::path::{Path, PathBuf};

use nix::sys::termios::{self, BaudRate, ControlFlags, SetArg, SpecialCharacterIndices};

/// Baud rates offered in the picker (the XBee's default is 9600).
pub const COMMON_BAUDS: [u32; 8] = [
    9600, 19_200, 38_400, 57_600, 115_200, 230_400, 460_800, 921_600,
];

/// Why a port could not be opened.
#[derive(Debug, thiserror::Error)]
pub enum SerialError {
    /// The baud rate is not one termios offers.
    #[error("{baud} baud is not a standard rate (try {COMMON_BAUDS:?})")]
    UnsupportedBaud {
        /// The rate asked for.
        baud: u32,
    },
    /// Opening failed.
    #[error("cannot open {path}: {source} (does it exist, and may this user open it? On Linux: group dialout)")]
    Open {
        /// The port.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The port is not a terminal or refused the settings.
    #[error("cannot configure {path} as a serial port: {source}")]
    Configure {
        /// The port.
        path: PathBuf,
        /// The cause.
        source: nix::Error,
    },
}

/// The termios constant for `baud`.
pub fn baud_rate(baud: u32) -> Option<BaudRate> {
    Some(match baud {
        1200 => BaudRate::B1200,
        2400 => BaudRate::B2400,
        4800 => BaudRate::B4800,
        9600 => BaudRate::B9600,
        19_200 => BaudRate::B19200,
        38_400 => BaudRate::B38400,
        57_600 => BaudRate::B57600,
        115_200 => BaudRate::B115200,
        230_400 => BaudRate::B230400,
        460_800 => BaudRate::B460800,
        921_600 => BaudRate::B921600,
        1_000_000 => BaudRate::B1000000,
        2_000_000 => BaudRate::B2000000,
        _ => return None,
    })
}

/// Opens `path` non-blocking, raw 8N1 at `baud`, without becoming its controlling terminal.
pub fn open_port(path: &Path, baud: u32) -> Result<File, SerialError> {
    let rate = baud_rate(baud).ok_or(SerialError::UnsupportedBaud { baud })?;
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .custom_flags(libc_flags())
        .open(path)
        .map_err(|source| SerialError::Open {
            path: path.to_owned(),
            source,
        })?;
    let configure = |file: &File| -> nix::Result<()> {
        let mut t = termios::tcgetattr(file.as_fd())?;
        termios::cfmakeraw(&mut t);
        termios::cfsetspeed(&mut t, rate)?;
        t.control_flags |= ControlFlags::CLOCAL | ControlFlags::CREAD;
        t.control_flags &= !(ControlFlags::CSTOPB | ControlFlags::PARENB | ControlFlags::CRTSCTS);
        t.control_chars[SpecialCharacterIndices::VMIN as usize] = 0;
        t.control_chars[SpecialCharacterIndices::VTIME as usize] = 0;
        termios::tcsetattr(file.as_fd(), SetArg::TCSANOW, &t)?;
        termios::tcflush(file.as_fd(), termios::FlushArg::TCIOFLUSH)
    };
    configure(&file).map_err(|source| SerialError::Configure {
        path: path.to_owned(),
        source,
    })?;
    Ok(file)
}

fn libc_flags() -> i32 {
    (nix::fcntl::OFlag::O_NOCTTY | nix::fcntl::OFlag::O_NONBLOCK).bits()
}

/// Serial ports present now: USB serial adapters and ACM devices, their stable names under
/// `/dev/serial/by-id`, and the first on-board UARTs (as on a Jetson), sorted.
pub fn list_ports() -> Vec<PathBuf> {
    list_ports_in(Path::new("/dev"))
}

/// [`list_ports`] under another root (for tests).
pub fn list_ports_in(dev: &Path) -> Vec<PathBuf> {
    let mut ports = Vec::new();
    if let Ok(entries) = std::fs::read_dir(dev) {
        for entry in entries.flatten() {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            let uart = ["ttyS0", "ttyS1", "ttyTHS0", "ttyTHS1", "ttyTHS2", "ttyAMA0"];
            if name.starts_with("ttyUSB") || name.starts_with("ttyACM") || uart.contains(&&*name) {
                ports.push(entry.path());
            }
        }
    }
    if let Ok(entries) = std::fs::read_dir(dev.join("serial/by-id")) {
        ports.extend(entries.flatten().map(|e| e.path()));
    }
    ports.sort();
    ports
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};
    use std::os::fd::OwnedFd;

    #[test]
    fn standard_rates_only() {
        for baud in COMMON_BAUDS {
            assert!(baud_rate(baud).is_some(), "{baud}");
        }
        assert!(baud_rate(9601).is_none());
        let err = open_port(Path::new("/dev/null"), 12_345).unwrap_err();
        assert!(err.to_string().contains("12345"), "{err}");
    }

    #[test]
    fn missing_and_non_terminal_files_are_clear_errors() {
        let err = open_port(Path::new("/nonexistent/ttyUSB9"), 9600).unwrap_err();
        assert!(err.to_string().contains("/nonexistent/ttyUSB9"), "{err}");
        let err = open_port(Path::new("/dev/null"), 9600).unwrap_err();
        assert!(matches!(err, SerialError::Configure { .. }), "{err}");
    }

    #[test]
    fn a_pseudo_terminal_opens_raw_both_ways() {
        let pair = nix::pty::openpty(None, None).unwrap();
        let slave_path = nix::unistd::ttyname(&pair.slave).unwrap();
        let mut port = open_port(&slave_path, 9600).unwrap();
        let master: OwnedFd = pair.master;
        let mut master = File::from(master);
        // Raw: bytes that a cooked terminal would translate (CR, ^C, ^D) pass unchanged.
        port.write_all(&[b'$', 0x0D, 0x03, 0x04, 0x0A]).unwrap();
        let mut buf = [0u8; 5];
        master.read_exact(&mut buf).unwrap();
        assert_eq!(buf, [b'$', 0x0D, 0x03, 0x04, 0x0A]);
        master.write_all(&[0x0D, 0x11, 0x13]).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(50));
        let mut back = [0u8; 3];
        port.read_exact(&mut back).unwrap();
        assert_eq!(back, [0x0D, 0x11, 0x13]);
    }

    #[test]
    fn lists_serial_device_names() {
        let dir = std::env::temp_dir().join(format!("dima-ground-dev-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("serial/by-id")).unwrap();
        for name in ["ttyUSB0", "ttyACM1", "tty5", "null", "ttyS0", "ttyS9"] {
            std::fs::write(dir.join(name), b"").unwrap();
        }
        std::fs::write(dir.join("serial/by-id/usb-FTDI_XBee-if00-port0"), b"").unwrap();
        let names: Vec<String> = list_ports_in(&dir)
            .iter()
            .map(|p| p.strip_prefix(&dir).unwrap().display().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "serial/by-id/usb-FTDI_XBee-if00-port0",
                "ttyACM1",
                "ttyS0",
                "ttyUSB0"
            ]
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
