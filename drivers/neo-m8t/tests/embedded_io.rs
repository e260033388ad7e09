//! The embedded-io adapter (feature `embedded-io`).
#![cfg(feature = "embedded-io")]

use embedded_hal_nb::serial::{Read, Write};
use neo_m8t::{IoSerial, NavPvt, NeoM8t};
use std::collections::VecDeque;

/// An in-memory port: `rx` is what the receiver sent, `tx` what we wrote; `tx_room` limits
/// how many bytes can be written before the port reports "not ready".
struct Port {
    rx: VecDeque<u8>,
    tx: Vec<u8>,
    tx_room: usize,
}

impl embedded_io::ErrorType for Port {
    type Error = core::convert::Infallible;
}

impl embedded_io::Read for Port {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let n = buf.len().min(self.rx.len());
        for slot in &mut buf[..n] {
            *slot = self.rx.pop_front().unwrap();
        }
        Ok(n)
    }
}

impl embedded_io::ReadReady for Port {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(!self.rx.is_empty())
    }
}

impl embedded_io::Write for Port {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        let n = buf.len().min(self.tx_room);
        self.tx.extend_from_slice(&buf[..n]);
        self.tx_room -= n;
        Ok(n)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

impl embedded_io::WriteReady for Port {
    fn write_ready(&mut self) -> Result<bool, Self::Error> {
        Ok(self.tx_room > 0)
    }
}

#[test]
fn adapter_reads_without_blocking_and_writes_until_full() {
    let mut port = IoSerial(Port {
        rx: VecDeque::from(vec![0x42]),
        tx: Vec::new(),
        tx_room: 1,
    });
    assert_eq!(port.read(), Ok(0x42));
    assert_eq!(port.read(), Err(nb::Error::WouldBlock));
    assert_eq!(port.write(0x01), Ok(()));
    assert_eq!(port.write(0x02), Err(nb::Error::WouldBlock));
    assert_eq!(port.flush(), Ok(()));
    assert_eq!(port.into_inner().tx, vec![0x01]);
}

#[test]
fn driver_reads_nav_pvt_through_the_adapter() {
    let frame = NavPvt {
        itow_ms: 4242,
        ..NavPvt::default()
    }
    .to_frame();
    let port = IoSerial(Port {
        rx: frame.as_bytes().iter().copied().collect(),
        tx: Vec::new(),
        tx_room: 0,
    });
    let mut gnss: NeoM8t<_, 100> = NeoM8t::with_capacity(port);
    assert_eq!(gnss.poll_nav_pvt(), Ok(Some(frame)));
}
