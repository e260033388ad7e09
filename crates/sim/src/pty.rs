//! Pseudo-terminals for the simulated devices.
//!
//! Each device gets a pty pair in raw mode on both sides and a stable symlink to the slave
//! (like a udev name), so the application opens the same path before and after a simulated
//! disconnect: [`SimPty::open`] makes a new pair and points the link at it, dropping the
//! [`SimPty`] closes both ends (the application sees a hang-up) and removes the link.

use std::io;
use std::os::fd::{AsFd, BorrowedFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use nix::errno::Errno;
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::termios::{self, SetArg};

/// The device side of a pseudo-terminal, with the application's path.
#[derive(Debug)]
pub struct SimPty {
    master: OwnedFd,
    /// Held open so the master never reads EIO while the application has the port closed.
    _slave: OwnedFd,
    device: PathBuf,
    link: PathBuf,
}

fn make_raw(fd: BorrowedFd<'_>) -> io::Result<()> {
    let mut t = termios::tcgetattr(fd)?;
    termios::cfmakeraw(&mut t);
    termios::tcsetattr(fd, SetArg::TCSANOW, &t)?;
    Ok(())
}

impl SimPty {
    /// Opens a raw pty pair and points `link` at its slave (replacing an older link).
    pub fn open(link: &Path) -> io::Result<SimPty> {
        let pair = nix::pty::openpty(None, None)?;
        make_raw(pair.master.as_fd())?;
        make_raw(pair.slave.as_fd())?;
        let flags = OFlag::from_bits_truncate(fcntl(&pair.master, FcntlArg::F_GETFL)?);
        fcntl(&pair.master, FcntlArg::F_SETFL(flags | OFlag::O_NONBLOCK))?;
        let device = nix::unistd::ttyname(&pair.slave)?;
        let tmp = link.with_extension("new");
        let _ = std::fs::remove_file(&tmp);
        std::os::unix::fs::symlink(&device, &tmp)?;
        std::fs::rename(&tmp, link)?;
        Ok(SimPty {
            master: pair.master,
            _slave: pair.slave,
            device,
            link: link.to_owned(),
        })
    }

    /// The path the application opens (the symlink).
    pub fn path(&self) -> &Path {
        &self.link
    }

    /// The pty slave the link points at (`/dev/pts/N`).
    pub fn device_path(&self) -> &Path {
        &self.device
    }

    /// The simulated device's end.
    pub fn master(&self) -> BorrowedFd<'_> {
        self.master.as_fd()
    }

    /// Writes all of `bytes` unless `timeout` passes first (the application is not reading);
    /// returns the number of bytes written.
    pub fn write(&self, mut bytes: &[u8], timeout: Duration) -> io::Result<usize> {
        let deadline = Instant::now() + timeout;
        let total = bytes.len();
        while !bytes.is_empty() {
            match nix::unistd::write(&self.master, bytes) {
                Ok(n) => bytes = &bytes[n..],
                Err(Errno::EAGAIN) => {
                    let left = deadline.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        break;
                    }
                    let mut fds = [PollFd::new(self.master.as_fd(), PollFlags::POLLOUT)];
                    let ms = left.as_millis().clamp(1, 100) as u16;
                    let _ = poll(&mut fds, PollTimeout::from(ms));
                }
                Err(Errno::EINTR) => {}
                Err(e) => return Err(e.into()),
            }
        }
        Ok(total - bytes.len())
    }

    /// Writes `bytes` at the pace of a UART: each chunk goes out when its last byte would
    /// have finished on the wire, so the reader sees the last byte no sooner than the whole
    /// frame's wire time after the call. Returns the number of bytes written (fewer when the
    /// reader stops taking bytes for `timeout`).
    pub fn write_paced(
        &self,
        bytes: &[u8],
        pace: LinePace,
        timeout: Duration,
    ) -> io::Result<usize> {
        self.write_paced_from(Instant::now(), bytes, pace, timeout)
    }

    /// [`write_paced`](Self::write_paced) for a transmission that started at `start` (e.g. a
    /// request edge a UART with DMA answers within microseconds).
    pub fn write_paced_from(
        &self,
        start: Instant,
        bytes: &[u8],
        pace: LinePace,
        timeout: Duration,
    ) -> io::Result<usize> {
        const CHUNK: usize = 16;
        let mut sent = 0;
        for chunk in bytes.chunks(CHUNK) {
            let due = start + pace.wire_time(sent + chunk.len());
            let wait = due.saturating_duration_since(Instant::now());
            if !wait.is_zero() {
                std::thread::sleep(wait);
            }
            let n = self.write(chunk, timeout)?;
            sent += n;
            if n < chunk.len() {
                break;
            }
        }
        Ok(sent)
    }

    /// Reads what arrives within `timeout` (0 bytes when nothing did).
    pub fn read(&self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        let mut fds = [PollFd::new(self.master.as_fd(), PollFlags::POLLIN)];
        let ms = timeout.as_millis().min(u128::from(u16::MAX)) as u16;
        match poll(&mut fds, PollTimeout::from(ms)) {
            Ok(0) | Err(Errno::EINTR) => return Ok(0),
            Ok(_) => {}
            Err(e) => return Err(e.into()),
        }
        match nix::unistd::read(&self.master, buf) {
            Ok(n) => Ok(n),
            Err(Errno::EAGAIN | Errno::EINTR) => Ok(0),
            Err(e) => Err(e.into()),
        }
    }
}

impl Drop for SimPty {
    fn drop(&mut self) {
        // Only remove the link if it still points at this pair (a newer one may have replaced it).
        if std::fs::read_link(&self.link).ok().as_deref() == Some(self.device.as_path()) {
            let _ = std::fs::remove_file(&self.link);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Read, Write};

    #[test]
    fn bytes_both_ways_through_the_link_and_reopen() {
        let dir = std::env::temp_dir().join(format!("dima-sim-pty-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let link = dir.join("dev");
        let pty = SimPty::open(&link).unwrap();
        let mut app = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&link)
            .unwrap();
        // Raw on the slave: bytes pass unchanged, including CR, LF and 0x03.
        app.write_all(&[0x0D, 0x0A, 0x03, 0xFF]).unwrap();
        let mut buf = [0u8; 8];
        let n = pty.read(&mut buf, Duration::from_secs(1)).unwrap();
        assert_eq!(&buf[..n], &[0x0D, 0x0A, 0x03, 0xFF]);
        assert_eq!(pty.write(&[0x24, 0x0D], Duration::from_secs(1)).unwrap(), 2);
        let mut got = [0u8; 2];
        app.read_exact(&mut got).unwrap();
        assert_eq!(got, [0x24, 0x0D]);

        // Disconnect: the application's read sees the hang-up, the link is gone.
        let first = pty.device_path().to_owned();
        drop(pty);
        assert!(!link.exists());
        assert!(app.read(&mut buf).map_or(true, |n| n == 0));
        // Reconnect: same link, working again.
        let pty = SimPty::open(&link).unwrap();
        assert_eq!(std::fs::read_link(&link).unwrap(), pty.device_path());
        let _ = first;
        drop(pty);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_pace_names_the_8n1_baud_rate_of_its_byte_rate() {
        assert_eq!(LinePace::new(9_600, 10).baud_8n1(), 9_600);
        assert_eq!(LinePace::new(115_200, 10).baud_8n1(), 115_200);
        // 8N2 at 9600 baud: 872.7 bytes a second, as many as 8N1 at 8730 baud.
        assert_eq!(LinePace::new(9_600, 11).baud_8n1(), 8_730);
    }
}

/// The pace of a UART line: the time one byte takes on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinePace {
    /// Nanoseconds per byte (start, data and stop bits).
    pub byte_ns: u64,
}

impl LinePace {
    /// `baud` with `bits_per_byte` bits per byte (11 for 8N2, 10 for 8N1).
    pub fn new(baud: u32, bits_per_byte: u64) -> LinePace {
        LinePace {
            byte_ns: bits_per_byte * 1_000_000_000 / u64::from(baud.max(1)),
        }
    }

    /// The baud rate of an 8N1 line that carries bytes at this pace (rounded): what a ground
    /// station's frame budget is reckoned in.
    pub fn baud_8n1(&self) -> u32 {
        let bytes_per_s = (1_000_000_000 + self.byte_ns / 2) / self.byte_ns.max(1);
        u32::try_from(bytes_per_s * 10).unwrap_or(u32::MAX)
    }

    /// Time `n` bytes take on the wire.
    pub fn wire_time(&self, n: usize) -> Duration {
        Duration::from_nanos(self.byte_ns * n as u64)
    }
}
