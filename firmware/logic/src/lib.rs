//! Pure logic of the DIMA sensor-board firmware.
//!
//! Everything here is plain state machines and code generic over embedded-hal traits, so it
//! builds for the STM32 (where the firmware in `../src` drives it from interrupts) and for the
//! host, where `cargo test-logic` runs its unit tests:
//!
//! - [`request`]: what to do with a request edge (send the latest packet, restart the info
//!   snapshot, or skip and count because a transfer is still running);
//! - [`link`]: the transmit side over a DMA stream ([`TxDma`]): buffer rotation, a piece
//!   behind each packet, skips, DMA errors;
//! - [`schedule`]: which sensor to read on which sampling tick (accelerometer and gyroscope
//!   every tick, magnetometer in forced mode with data-ready polling, BMP280 in normal mode);
//! - [`latest`]: the front half of the packet double buffer, the latest complete packet;
//! - [`crc_check`]: the CRC unit's boot-time self-check and the software fallback;
//! - [`reset_record`]: what the board remembers across resets (watchdog resets, the fault
//!   that made `init` reset the board);
//! - [`gnss_rx`]: the GNSS receive double buffer; either interrupt that ends a buffer
//!   acknowledges both sources itself;
//! - [`blink`]: the status LED pattern that reports sensors that did not answer at boot;
//! - [`supervisor`]: whether the sampling tick may feed the watchdog (the link is not stuck
//!   sending) and whether the GNSS receiver has gone silent;
//! - [`spi_clock`]: the SPI1 prescaler the HAL picks, and the sensor bus rate the firmware
//!   asks for (never above the sensors' 10 MHz);
//! - [`uart_errors`]: overrun, framing and noise errors of the GNSS UART, from its status
//!   register;
//! - [`sensor_image`]: the `qemu` build's sensor dies, register images a host feeds over a
//!   UART;
//! - [`sensors`]: the four sensor dies behind embedded-hal `SpiDevice`s, brought up and read
//!   through the workspace's BMX055 and BMP280 drivers (tested here against a simulated
//!   register file).
#![no_std]
#![deny(unsafe_code)]
#![deny(missing_docs)]

pub mod blink;
pub mod crc_check;
pub mod dima;
pub mod gnss_rx;
pub mod gnss_setup;
pub mod latest;
pub mod link;
pub mod request;
pub mod reset_record;
pub mod schedule;
pub mod sensor_image;
pub mod sensors;
pub mod spi_clock;
pub mod supervisor;
pub mod uart_errors;

pub use crc_check::{CheckedCrc, NibbleCrc};
pub use gnss_setup::{Outcome as GnssSetupOutcome, ReplyPort, ReplyTap, SetupStatus};
pub use latest::LatestPacket;
pub use link::{TxDma, TxLink};
pub use request::{AfterTransfer, Answer, RequestHandler, INFO_GAP_MS};
pub use schedule::{MagAction, Schedule, ScheduleConfig, TickPlan};
pub use sensors::{BootReport, Sensors};
pub use supervisor::{LinkProgress, Supervisor, SupervisorConfig, Verdict};
