//! The error shape shared by the driver crates: `Comm` for the serial port, `Device` for
//! everything else, with the timeout as `Device(DeviceError::Timeout)`.

use core::error::Error as _;

use xbee_driver::{DeviceError, Error, FrameError};

#[test]
fn bus_device_and_timeout_errors_have_the_common_variants() {
    let bus: Error<&str> = Error::Comm("overrun");
    assert_eq!(bus.to_string(), "XBee serial port error: \"overrun\"");
    assert!(bus.source().is_none());

    let timeout: Error<&str> = DeviceError::Timeout.into();
    assert_eq!(timeout, Error::Device(DeviceError::Timeout));
    assert_eq!(
        timeout.source().map(|s| s.to_string()),
        Some(DeviceError::Timeout.to_string())
    );

    let frame: Error<&str> = FrameError::Empty.into();
    assert_eq!(frame, Error::Device(DeviceError::Frame(FrameError::Empty)));
    assert!(frame.to_string().starts_with("XBee API frame"));
}
