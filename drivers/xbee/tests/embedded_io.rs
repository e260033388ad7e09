//! embedded-io adapters of the transparent pipe (run with `--features embedded-io`).
#![cfg(feature = "embedded-io")]

use embedded_hal_mock::eh1::serial::{Mock as SerialMock, Transaction};
use xbee_driver::DeviceError;
use xbee_driver::{Error, XBee};

#[test]
fn write_all_and_read_pass_through() {
    // The DIMA ground link's heartbeat command frame (10 bytes, ground link v1).
    let heartbeat = [0x24, 0x00, 0x00, 0x00, 0x00, 0x00, 0xC6, 0x22, 0xF7, 0x1D];
    let serial = SerialMock::new(&[
        Transaction::write_many(heartbeat),
        Transaction::flush(),
        Transaction::read_error(nb::Error::WouldBlock),
        Transaction::read_many(&heartbeat[..4]),
        Transaction::read_error(nb::Error::WouldBlock),
    ]);
    let mut radio = XBee::new(serial);
    embedded_io::Write::write_all(&mut radio, &heartbeat).unwrap();
    embedded_io::Write::flush(&mut radio).unwrap();
    let mut buf = [0u8; 16];
    // Blocks through one WouldBlock, then returns what is waiting.
    let n = embedded_io::Read::read(&mut radio, &mut buf).unwrap();
    assert_eq!(&buf[..n], &heartbeat[..4]);
    radio.release().done();
}

#[test]
fn command_mode_refuses_instead_of_blocking() {
    let serial = SerialMock::new(&[
        Transaction::flush(),
        Transaction::write_many(b"+++"),
        Transaction::read_error(nb::Error::WouldBlock),
    ]);
    let mut radio = XBee::new(serial);
    radio.start_command_mode().unwrap();
    assert!(radio.poll(0).is_err());
    assert!(radio.poll(1050).is_err()); // GT + margin: +++ out, waiting for OK
    let mut buf = [0u8; 4];
    assert_eq!(
        embedded_io::Read::read(&mut radio, &mut buf),
        Err(Error::Device(DeviceError::CommandModeActive))
    );
    assert_eq!(
        embedded_io::Write::write(&mut radio, b"data"),
        Err(Error::Device(DeviceError::CommandModeActive))
    );
    radio.release().done();
}
