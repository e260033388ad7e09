//! Devices: how the realtime loop gets them, loses them and gets them back.
//!
//! The loop never opens or closes a device (opening allocates and may block). A
//! [`Supervisor`] thread opens each device with a caller-given opener and hands it to the loop
//! through a lock-free ring; when the loop meets an I/O error it hands the device back through a
//! second ring and carries on with safe behaviour; the supervisor drops it (closing the port)
//! and reopens after the configured interval. The openers are the only device-specific part:
//! `dima run` opens the real ports, and a simulation can open pseudo-terminals with the very
//! same [`serial::SerialPort`] and pass its own request line.

pub mod pca9685;
pub mod sensor;
pub mod serial;
pub mod servo;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Opens a device; the error names the device and what to do.
pub type Opener<T> = Box<dyn FnMut() -> anyhow::Result<T> + Send>;

/// The realtime side of a device hand-over.
pub struct DeviceLink<T> {
    incoming: rtrb::Consumer<T>,
    broken: rtrb::Producer<T>,
    current: Option<T>,
}

/// What [`DeviceLink::refresh`] saw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkEvent {
    /// Nothing changed.
    None,
    /// A (re)opened device was adopted.
    Connected,
}

impl<T> DeviceLink<T> {
    /// Adopts a device the supervisor has opened, if any. Never blocks or allocates.
    pub fn refresh(&mut self) -> LinkEvent {
        match self.incoming.pop() {
            Ok(device) => {
                if let Some(old) = self.current.replace(device) {
                    // Cannot happen with one supervisor, but never drop on this thread.
                    let _ = self.broken.push(old);
                }
                LinkEvent::Connected
            }
            Err(_) => LinkEvent::None,
        }
    }

    /// The device, if one is connected.
    pub fn get(&mut self) -> Option<&mut T> {
        self.current.as_mut()
    }

    /// Whether a device is connected.
    pub fn is_connected(&self) -> bool {
        self.current.is_some()
    }

    /// Gives the current device back to the supervisor to be closed and reopened.
    pub fn fail(&mut self) {
        if let Some(device) = self.current.take() {
            // The ring holds two: the supervisor empties it long before it fills. If it ever
            // were full, the device would be dropped here, which is still correct, just not
            // allocation-free.
            let _ = self.broken.push(device);
        }
    }
}

/// The non-realtime side: opens, reopens and closes one device.
pub struct Supervisor<T> {
    name: &'static str,
    open: Opener<T>,
    to_loop: rtrb::Producer<T>,
    from_loop: rtrb::Consumer<T>,
    interval: Duration,
    connected: bool,
    failures: u64,
    last_attempt: Option<Instant>,
}

/// A linked supervisor and realtime end.
pub fn device_link<T>(
    name: &'static str,
    open: Opener<T>,
    reopen_interval: Duration,
) -> (Supervisor<T>, DeviceLink<T>) {
    let (to_loop, incoming) = rtrb::RingBuffer::new(1);
    let (broken, from_loop) = rtrb::RingBuffer::new(2);
    (
        Supervisor {
            name,
            open,
            to_loop,
            from_loop,
            interval: reopen_interval,
            connected: false,
            failures: 0,
            last_attempt: None,
        },
        DeviceLink {
            incoming,
            broken,
            current: None,
        },
    )
}

impl<T> Supervisor<T> {
    /// One round: close devices the loop gave back, and (re)open when due. Returns true while
    /// a device is with the loop.
    pub fn service(&mut self, now: Instant) -> bool {
        while let Ok(device) = self.from_loop.pop() {
            drop(device);
            self.connected = false;
            self.last_attempt = Some(now);
            tracing::warn!(
                "{}: lost (I/O error); outputs stay safe, reopening every {:?}",
                self.name,
                self.interval
            );
        }
        let due = self
            .last_attempt
            .is_none_or(|t| now.duration_since(t) >= self.interval);
        if !self.connected && due && self.to_loop.slots() > 0 {
            self.last_attempt = Some(now);
            match (self.open)() {
                Ok(device) => {
                    if self.to_loop.push(device).is_ok() {
                        self.connected = true;
                        if self.failures > 0 {
                            tracing::info!(
                                "{}: connected after {} failed attempts",
                                self.name,
                                self.failures
                            );
                        } else {
                            tracing::info!("{}: connected", self.name);
                        }
                        self.failures = 0;
                    }
                }
                Err(error) => {
                    self.failures += 1;
                    // Report the first failure and then about once a minute.
                    let every = (60 / self.interval.as_secs().max(1)).max(1);
                    if self.failures == 1 || self.failures.is_multiple_of(every) {
                        tracing::warn!(
                            "{error:#} (attempt {}; retrying every {:?})",
                            self.failures,
                            self.interval
                        );
                    }
                }
            }
        }
        self.connected
    }
}

/// Runs supervisors on one thread until `stop` is set, servicing each every 20 ms.
pub fn spawn_supervisors(
    mut services: Vec<Box<dyn FnMut(Instant) -> bool + Send>>,
    stop: Arc<AtomicBool>,
) -> std::io::Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("dima-devices".into())
        .spawn(move || {
            while !stop.load(Ordering::Relaxed) {
                let now = Instant::now();
                for service in services.iter_mut() {
                    service(now);
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn open_fail_reopen_cycle() {
        let attempts = Arc::new(std::sync::atomic::AtomicU32::new(0));
        let a = attempts.clone();
        let opener: Opener<u32> = Box::new(move || {
            let n = a.fetch_add(1, Ordering::SeqCst);
            if n == 0 {
                anyhow::bail!("/dev/ttyX: not there")
            }
            Ok(n)
        });
        let (mut sup, mut link) = device_link("test device", opener, Duration::from_millis(100));
        let t0 = Instant::now();
        assert!(!sup.service(t0)); // first attempt fails
        assert_eq!(link.refresh(), LinkEvent::None);
        assert!(!sup.service(t0 + Duration::from_millis(50))); // not due yet
        assert_eq!(attempts.load(Ordering::SeqCst), 1);
        assert!(sup.service(t0 + Duration::from_millis(100)));
        assert_eq!(link.refresh(), LinkEvent::Connected);
        assert_eq!(link.get().copied(), Some(1));
        link.fail();
        assert!(!link.is_connected());
        let t1 = t0 + Duration::from_millis(200);
        assert!(!sup.service(t1)); // takes it back, waits the interval
        assert!(sup.service(t1 + Duration::from_millis(100)));
        assert_eq!(link.refresh(), LinkEvent::Connected);
        assert_eq!(link.get().copied(), Some(2));
    }
}
