//! A serial port on raw termios: non-blocking file descriptor, `ppoll` waits with deadlines,
//! embedded-hal-nb byte `Read`/`Write` for the driver crates. Works the same on a UART, a USB
//! CDC port and a pseudo-terminal.

use std::os::fd::{AsFd, AsRawFd, BorrowedFd, OwnedFd};
use std::path::Path;

use nix::errno::Errno;
use nix::fcntl::{open, OFlag};
use nix::poll::{ppoll, PollFd, PollFlags};
use nix::sys::stat::Mode;
use nix::sys::termios::{self, BaudRate, ControlFlags, SetArg, SpecialCharacterIndices};
use nix::sys::time::TimeSpec;

use crate::rt::monotonic_ns;
use dima_core::Nanos;

/// Line settings. Always 8 data bits, no parity, no flow control.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineSettings {
    /// Baud rate (a standard termios rate).
    pub baud: u32,
    /// 1 or 2 stop bits.
    pub stop_bits: u8,
}

/// An error of the serial port, as an errno (no allocation on the realtime path).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SerialError {
    /// A system call failed.
    #[error("serial I/O: {0}")]
    Io(Errno),
    /// The other end hung up (USB unplugged, pty closed).
    #[error("serial port hung up")]
    HangUp,
    /// The deadline passed before the operation completed.
    #[error("serial deadline passed")]
    Timeout,
}

impl embedded_hal_nb::serial::Error for SerialError {
    fn kind(&self) -> embedded_hal_nb::serial::ErrorKind {
        embedded_hal_nb::serial::ErrorKind::Other
    }
}

fn baud_rate(baud: u32) -> Option<BaudRate> {
    use BaudRate::*;
    Some(match baud {
        1200 => B1200,
        2400 => B2400,
        4800 => B4800,
        9600 => B9600,
        19200 => B19200,
        38400 => B38400,
        57600 => B57600,
        115200 => B115200,
        230400 => B230400,
        460800 => B460800,
        500000 => B500000,
        576000 => B576000,
        921600 => B921600,
        1000000 => B1000000,
        1152000 => B1152000,
        1500000 => B1500000,
        2000000 => B2000000,
        3000000 => B3000000,
        4000000 => B4000000,
        _ => return None,
    })
}

const RX_BUFFER: usize = 512;

/// A raw, non-blocking serial port.
#[derive(Debug)]
pub struct SerialPort {
    fd: OwnedFd,
    rx: [u8; RX_BUFFER],
    rx_pos: usize,
    rx_len: usize,
}

fn timeout_until(deadline_ns: Nanos) -> TimeSpec {
    let left = deadline_ns.saturating_sub(monotonic_ns());
    TimeSpec::new((left / 1_000_000_000) as _, (left % 1_000_000_000) as _)
}

impl SerialPort {
    /// Opens `path` raw (`cfmakeraw`), 8 data bits, no parity, `settings.stop_bits`, no flow
    /// control, non-blocking, and drops whatever was queued before.
    pub fn open(path: &Path, settings: LineSettings) -> std::io::Result<SerialPort> {
        let rate = baud_rate(settings.baud).ok_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("unsupported baud rate {}", settings.baud),
            )
        })?;
        let fd = open(
            path,
            OFlag::O_RDWR | OFlag::O_NOCTTY | OFlag::O_NONBLOCK | OFlag::O_CLOEXEC,
            Mode::empty(),
        )?;
        let mut t = termios::tcgetattr(&fd)?;
        termios::cfmakeraw(&mut t);
        termios::cfsetspeed(&mut t, rate)?;
        t.control_flags &= !(ControlFlags::CSIZE
            | ControlFlags::PARENB
            | ControlFlags::CSTOPB
            | ControlFlags::CRTSCTS);
        t.control_flags |= ControlFlags::CS8 | ControlFlags::CLOCAL | ControlFlags::CREAD;
        if settings.stop_bits == 2 {
            t.control_flags |= ControlFlags::CSTOPB;
        }
        // VMIN 1 with O_NONBLOCK: "no data" is EAGAIN, so a read of 0 bytes means hang-up.
        t.control_chars[SpecialCharacterIndices::VMIN as usize] = 1;
        t.control_chars[SpecialCharacterIndices::VTIME as usize] = 0;
        termios::tcsetattr(&fd, SetArg::TCSANOW, &t)?;
        termios::tcflush(&fd, termios::FlushArg::TCIOFLUSH)?;
        Ok(SerialPort {
            fd,
            rx: [0; RX_BUFFER],
            rx_pos: 0,
            rx_len: 0,
        })
    }

    /// A second descriptor for the same port, for waiting while a driver owns this one.
    pub fn try_clone_fd(&self) -> std::io::Result<OwnedFd> {
        self.fd.try_clone()
    }

    /// Waits until `fd` is readable or `deadline_ns` (CLOCK_MONOTONIC) passes: `Ok(true)` when
    /// readable, `Ok(false)` at the deadline.
    pub fn wait_readable(fd: BorrowedFd<'_>, deadline_ns: Nanos) -> Result<bool, SerialError> {
        wait(fd, PollFlags::POLLIN, deadline_ns)
    }

    /// Waits until this port is readable or `deadline_ns` passes (`Ok(false)`).
    pub fn wait_input(&self, deadline_ns: Nanos) -> Result<bool, SerialError> {
        wait(self.fd.as_fd(), PollFlags::POLLIN, deadline_ns)
    }

    /// Waits until this port can take more bytes or `deadline_ns` passes (`Ok(false)`).
    pub fn wait_output(&self, deadline_ns: Nanos) -> Result<bool, SerialError> {
        wait(self.fd.as_fd(), PollFlags::POLLOUT, deadline_ns)
    }

    /// Reads whatever is available into `buf` without waiting (`Ok(0)`: nothing there).
    pub fn read_available(&mut self, buf: &mut [u8]) -> Result<usize, SerialError> {
        let buffered = self.rx_len - self.rx_pos;
        if buffered > 0 {
            let n = buffered.min(buf.len());
            buf[..n].copy_from_slice(&self.rx[self.rx_pos..self.rx_pos + n]);
            self.rx_pos += n;
            return Ok(n);
        }
        raw_read(self.fd.as_fd(), buf)
    }

    /// Writes all of `bytes`, waiting for room until `deadline_ns`.
    pub fn write_all(&mut self, mut bytes: &[u8], deadline_ns: Nanos) -> Result<(), SerialError> {
        while !bytes.is_empty() {
            match nix::unistd::write(&self.fd, bytes) {
                Ok(n) => bytes = &bytes[n..],
                Err(Errno::EAGAIN) => {
                    if !wait(self.fd.as_fd(), PollFlags::POLLOUT, deadline_ns)? {
                        return Err(SerialError::Timeout);
                    }
                }
                Err(Errno::EINTR) => {}
                Err(Errno::EIO | Errno::ENXIO | Errno::ENODEV) => return Err(SerialError::HangUp),
                Err(e) => return Err(SerialError::Io(e)),
            }
        }
        Ok(())
    }
}

fn raw_read(fd: BorrowedFd<'_>, buf: &mut [u8]) -> Result<usize, SerialError> {
    loop {
        return match nix::unistd::read(fd, buf) {
            Ok(0) if !buf.is_empty() => Err(SerialError::HangUp),
            Ok(n) => Ok(n),
            Err(Errno::EAGAIN) => Ok(0),
            Err(Errno::EINTR) => continue,
            Err(Errno::EIO | Errno::ENXIO | Errno::ENODEV) => Err(SerialError::HangUp),
            Err(e) => Err(SerialError::Io(e)),
        };
    }
}

fn wait(fd: BorrowedFd<'_>, events: PollFlags, deadline_ns: Nanos) -> Result<bool, SerialError> {
    loop {
        let mut fds = [PollFd::new(fd, events)];
        match ppoll(&mut fds, Some(timeout_until(deadline_ns)), None) {
            Ok(0) => return Ok(false),
            Ok(_) => {
                let revents = fds[0].revents().unwrap_or(PollFlags::empty());
                if revents.intersects(events) {
                    return Ok(true);
                }
                if revents.intersects(PollFlags::POLLHUP | PollFlags::POLLERR) {
                    return Err(SerialError::HangUp);
                }
                if revents.contains(PollFlags::POLLNVAL) {
                    return Err(SerialError::Io(Errno::EBADF));
                }
            }
            Err(Errno::EINTR) => {}
            Err(e) => return Err(SerialError::Io(e)),
        }
        if monotonic_ns() >= deadline_ns {
            return Ok(false);
        }
    }
}

impl AsRawFd for SerialPort {
    fn as_raw_fd(&self) -> std::os::fd::RawFd {
        self.fd.as_raw_fd()
    }
}

impl AsFd for SerialPort {
    fn as_fd(&self) -> BorrowedFd<'_> {
        self.fd.as_fd()
    }
}

impl embedded_hal_nb::serial::ErrorType for SerialPort {
    type Error = SerialError;
}

impl embedded_hal_nb::serial::Read<u8> for SerialPort {
    fn read(&mut self) -> nb::Result<u8, SerialError> {
        if self.rx_pos == self.rx_len {
            let n = raw_read(self.fd.as_fd(), &mut self.rx)?;
            if n == 0 {
                return Err(nb::Error::WouldBlock);
            }
            self.rx_pos = 0;
            self.rx_len = n;
        }
        let byte = self.rx[self.rx_pos];
        self.rx_pos += 1;
        Ok(byte)
    }
}

impl embedded_hal_nb::serial::Write<u8> for SerialPort {
    fn write(&mut self, word: u8) -> nb::Result<(), SerialError> {
        match nix::unistd::write(&self.fd, &[word]) {
            Ok(1) => Ok(()),
            Ok(_) | Err(Errno::EAGAIN) | Err(Errno::EINTR) => Err(nb::Error::WouldBlock),
            Err(Errno::EIO | Errno::ENXIO | Errno::ENODEV) => {
                Err(nb::Error::Other(SerialError::HangUp))
            }
            Err(e) => Err(nb::Error::Other(SerialError::Io(e))),
        }
    }

    fn flush(&mut self) -> nb::Result<(), SerialError> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_nb::serial::{Read, Write};
    use nix::pty::openpty;

    /// A pty pair: the slave opened by path as a real port, the master as the far end.
    fn pty() -> (OwnedFd, SerialPort) {
        let pty = openpty(None, None).unwrap();
        let path = nix::unistd::ttyname(&pty.slave).unwrap();
        let port = SerialPort::open(
            &path,
            LineSettings {
                baud: 460_800,
                stop_bits: 2,
            },
        )
        .unwrap();
        drop(pty.slave);
        (pty.master, port)
    }

    fn make_raw(fd: &OwnedFd) {
        let mut t = termios::tcgetattr(fd).unwrap();
        termios::cfmakeraw(&mut t);
        termios::tcsetattr(fd, SetArg::TCSANOW, &t).unwrap();
    }

    #[test]
    fn bytes_both_ways_and_deadlines() {
        let (master, mut port) = pty();
        make_raw(&master);
        // Nothing there: WouldBlock, and a wait times out at its deadline.
        assert!(matches!(port.read(), Err(nb::Error::WouldBlock)));
        let t0 = monotonic_ns();
        let fd = port.try_clone_fd().unwrap();
        assert!(!SerialPort::wait_readable(fd.as_fd(), t0 + 5_000_000).unwrap());
        assert!(monotonic_ns() - t0 >= 5_000_000);

        nix::unistd::write(&master, &[0x24, 0x00, 0xFF]).unwrap();
        assert!(SerialPort::wait_readable(fd.as_fd(), monotonic_ns() + 1_000_000_000).unwrap());
        assert_eq!(nb::block!(port.read()).unwrap(), 0x24);
        assert_eq!(nb::block!(port.read()).unwrap(), 0x00);
        assert_eq!(nb::block!(port.read()).unwrap(), 0xFF);

        port.write_all(&[1, 2, 3], monotonic_ns() + 1_000_000_000)
            .unwrap();
        nb::block!(port.write(4)).unwrap();
        let mut buf = [0u8; 8];
        std::thread::sleep(std::time::Duration::from_millis(10));
        let n = nix::unistd::read(&master, &mut buf).unwrap();
        assert_eq!(&buf[..n], &[1, 2, 3, 4]);
    }

    #[test]
    fn hang_up_is_reported() {
        let (master, mut port) = pty();
        drop(master);
        let fd = port.try_clone_fd().unwrap();
        // The wait returns at once (readable or hung up), and the read names the hang-up.
        let t0 = monotonic_ns();
        let waited = SerialPort::wait_readable(fd.as_fd(), t0 + 1_000_000_000);
        assert!(matches!(waited, Ok(true) | Err(SerialError::HangUp)));
        assert!(monotonic_ns() - t0 < 500_000_000);
        assert!(matches!(
            port.read(),
            Err(nb::Error::Other(SerialError::HangUp))
        ));
    }

    #[test]
    fn unknown_baud_and_missing_device_name_the_problem() {
        let e = SerialPort::open(
            Path::new("/dev/null"),
            LineSettings {
                baud: 12_345,
                stop_bits: 1,
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("12345"));
        assert!(SerialPort::open(
            Path::new("/dev/does-not-exist"),
            LineSettings {
                baud: 9600,
                stop_bits: 1
            }
        )
        .is_err());
    }
}
