//! Sensor dies as register images in RAM, fed by a host: the `qemu` build's stand-in for the
//! four dies on SPI1, so the firmware's real bring-up and sampling code runs under the
//! emulator against values a host chooses (`dima sim --firmware`).
//!
//! Each die is a 256-byte register file ([`RegisterImage`]) behind an embedded-hal SPI
//! transaction, as the datasheets describe the bus: the first byte written is the register
//! address (bit 7 set: read), further written bytes go to consecutive registers, reads
//! auto-increment. The BMX055 dies use addresses below 0x80, so their register is the address
//! without bit 7; the BMP280's registers sit at 0x80 and above, so its register is the
//! address with bit 7 set. The firmware's own writes (soft resets, configuration) land in the
//! image like on a die.
//!
//! The host updates the images over a UART with [`ImageFrameParser`] frames:
//!
//! ```text
//! 0xA5  die  start  len  data[len]  check
//! ```
//!
//! `die` 0 accelerometer, 1 gyroscope, 2 magnetometer, 3 BMP280 ([`Die`]); `start` the first
//! register (its datasheet address, e.g. 0xF7 for the BMP280's pressure MSB); `len` 0 to 255
//! data bytes; `check` makes the 8-bit sum of every byte from `die` to `check` zero. A frame
//! with `die` 0xFF ([`END_OF_BOOT_IMAGES`]) and no data tells the firmware that the images for
//! its bring-up are complete. A bad check or an unknown die drops the frame; the parser looks
//! for the next 0xA5.

use embedded_hal::spi::{ErrorKind, Operation};

/// First byte of every image frame.
pub const IMAGE_SYNC: u8 = 0xA5;
/// The `die` byte of the frame that ends the boot-time images.
pub const END_OF_BOOT_IMAGES: u8 = 0xFF;
/// Largest frame: sync, die, start, length, 255 data bytes, check.
pub const MAX_FRAME_LEN: usize = 4 + 255 + 1;

/// One of the four sensor dies, by its frame id.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Die {
    /// BMX055 accelerometer (id 0).
    Accel = 0,
    /// BMX055 gyroscope (id 1).
    Gyro = 1,
    /// BMX055 magnetometer, BMM150 (id 2).
    Mag = 2,
    /// BMP280 (id 3).
    Bmp280 = 3,
}

impl Die {
    /// The die with frame id `id`.
    #[must_use]
    pub fn from_id(id: u8) -> Option<Die> {
        match id {
            0 => Some(Die::Accel),
            1 => Some(Die::Gyro),
            2 => Some(Die::Mag),
            3 => Some(Die::Bmp280),
            _ => None,
        }
    }

    /// Whether the die's registers sit at 0x80 and above (the BMP280).
    #[must_use]
    pub fn high_registers(self) -> bool {
        self == Die::Bmp280
    }
}

/// A die's 256 registers.
#[derive(Clone)]
pub struct RegisterImage {
    regs: [u8; 256],
}

impl RegisterImage {
    /// All registers zero (a die that does not answer its chip id).
    pub const ZERO: Self = Self { regs: [0; 256] };

    /// Writes `bytes` from register `start` on (wrapping at 0xFF).
    pub fn write(&mut self, start: u8, bytes: &[u8]) {
        for (i, &byte) in bytes.iter().enumerate() {
            self.regs[(usize::from(start) + i) & 0xFF] = byte;
        }
    }

    /// Register `address`.
    #[must_use]
    pub fn get(&self, address: u8) -> u8 {
        self.regs[usize::from(address)]
    }

    /// One SPI transaction on the die (see the module docs); `high_registers` for the BMP280.
    /// A read before any address, or a transfer other than write and read, is an error.
    pub fn transaction(
        &mut self,
        high_registers: bool,
        operations: &mut [Operation<'_, u8>],
    ) -> Result<(), ErrorKind> {
        let mut cursor: Option<u8> = None;
        for operation in operations {
            match operation {
                Operation::Write(bytes) => {
                    let (&address, data) = bytes.split_first().ok_or(ErrorKind::Other)?;
                    let start = if high_registers {
                        address | 0x80
                    } else {
                        address & 0x7F
                    };
                    self.write(start, data);
                    cursor = Some(start.wrapping_add(data.len() as u8));
                    // A read after an address byte alone starts at that register.
                    if data.is_empty() {
                        cursor = Some(start);
                    }
                }
                Operation::Read(buffer) => {
                    let start = cursor.ok_or(ErrorKind::Other)?;
                    for (i, byte) in buffer.iter_mut().enumerate() {
                        *byte = self.regs[(usize::from(start) + i) & 0xFF];
                    }
                    cursor = Some(start.wrapping_add(buffer.len() as u8));
                }
                Operation::DelayNs(_) => {}
                _ => return Err(ErrorKind::Other),
            }
        }
        Ok(())
    }
}

/// The four dies' images.
#[derive(Clone)]
pub struct SensorImages {
    dies: [RegisterImage; 4],
}

impl SensorImages {
    /// Every die all zeros: no chip id answers until the host sends one.
    pub const ZERO: Self = Self {
        dies: [RegisterImage::ZERO; 4],
    };

    /// One SPI transaction on `die`.
    pub fn transaction(
        &mut self,
        die: Die,
        operations: &mut [Operation<'_, u8>],
    ) -> Result<(), ErrorKind> {
        self.dies[die as usize].transaction(die.high_registers(), operations)
    }

    /// Applies a host update.
    pub fn apply(&mut self, update: &ImageUpdate<'_>) {
        self.dies[update.die as usize].write(update.start, update.data);
    }

    /// `die`'s image.
    #[must_use]
    pub fn die(&self, die: Die) -> &RegisterImage {
        &self.dies[die as usize]
    }
}

/// A complete, checked frame from the host.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ImageFrame<'a> {
    /// New register values for one die.
    Update(ImageUpdate<'a>),
    /// The images for the bring-up are complete.
    EndOfBootImages,
}

/// New values for registers `start..start + data.len()` of `die`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ImageUpdate<'a> {
    /// The die.
    pub die: Die,
    /// First register.
    pub start: u8,
    /// The values.
    pub data: &'a [u8],
}

/// Reassembles image frames from the host's bytes, one byte at a time.
pub struct ImageFrameParser {
    frame: [u8; MAX_FRAME_LEN],
    len: usize,
    dropped: u32,
}

impl Default for ImageFrameParser {
    fn default() -> Self {
        Self::new()
    }
}

impl ImageFrameParser {
    /// Waiting for a sync byte.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            frame: [0; MAX_FRAME_LEN],
            len: 0,
            dropped: 0,
        }
    }

    /// Frames dropped for a bad check or an unknown die.
    #[must_use]
    pub fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Takes one byte; returns the frame it completes, if any.
    pub fn push(&mut self, byte: u8) -> Option<ImageFrame<'_>> {
        if self.len == 0 && byte != IMAGE_SYNC {
            return None;
        }
        self.frame[self.len] = byte;
        self.len += 1;
        if self.len < 4 {
            return None;
        }
        let total = 4 + usize::from(self.frame[3]) + 1;
        if self.len < total {
            return None;
        }
        self.len = 0;
        let body = &self.frame[1..total];
        let sum = body.iter().fold(0u8, |sum, &b| sum.wrapping_add(b));
        let die = self.frame[1];
        if sum != 0 {
            self.dropped = self.dropped.wrapping_add(1);
            return None;
        }
        if die == END_OF_BOOT_IMAGES {
            return Some(ImageFrame::EndOfBootImages);
        }
        let Some(die) = Die::from_id(die) else {
            self.dropped = self.dropped.wrapping_add(1);
            return None;
        };
        Some(ImageFrame::Update(ImageUpdate {
            die,
            start: self.frame[2],
            data: &self.frame[4..total - 1],
        }))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    /// A frame as the host writes it.
    fn frame(die: u8, start: u8, data: &[u8]) -> Vec<u8> {
        let mut out = std::vec![IMAGE_SYNC, die, start, data.len() as u8];
        out.extend_from_slice(data);
        let sum = out[1..].iter().fold(0u8, |s, &b| s.wrapping_add(b));
        out.push(sum.wrapping_neg());
        out
    }

    fn parse_all(parser: &mut ImageFrameParser, bytes: &[u8], images: &mut SensorImages) -> u32 {
        let mut ends = 0;
        for &b in bytes {
            match parser.push(b) {
                Some(ImageFrame::Update(update)) => images.apply(&update),
                Some(ImageFrame::EndOfBootImages) => ends += 1,
                None => {}
            }
        }
        ends
    }

    #[test]
    fn the_frame_layout_is_the_documented_one() {
        // The BMP280's six data registers from 0xF7; the host's encoder has the same vector.
        let bytes = frame(3, 0xF7, &[0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00]);
        assert_eq!(
            bytes,
            [0xA5, 0x03, 0xF7, 0x06, 0x65, 0x5A, 0xC0, 0x7E, 0xED, 0x00, 0x16]
        );
        assert_eq!(frame(0xFF, 0, &[]), [0xA5, 0xFF, 0x00, 0x00, 0x01]);
    }

    #[test]
    fn frames_update_the_die_they_name_and_resynchronise_after_junk() {
        let mut parser = ImageFrameParser::new();
        let mut images = SensorImages::ZERO;
        let mut bytes = std::vec![0x00, 0x13, IMAGE_SYNC - 1];
        bytes.extend(frame(0, 0x00, &[0xFA]));
        bytes.extend(frame(2, 0x42, &[1, 2, 3, 4, 5, 6, 7, 8]));
        let mut bad = frame(1, 0x00, &[0x0F]);
        *bad.last_mut().unwrap() ^= 0x40;
        bytes.extend(bad);
        bytes.extend(frame(7, 0x00, &[0x01]));
        bytes.extend(frame(0xFF, 0, &[]));
        assert_eq!(parse_all(&mut parser, &bytes, &mut images), 1);
        assert_eq!(images.die(Die::Accel).get(0x00), 0xFA);
        assert_eq!(images.die(Die::Mag).get(0x42), 1);
        assert_eq!(images.die(Die::Mag).get(0x49), 8);
        assert_eq!(images.die(Die::Gyro).get(0x00), 0, "bad check: not applied");
        assert_eq!(parser.dropped(), 2, "bad check and unknown die");
    }

    #[test]
    fn spi_reads_auto_increment_and_writes_land_in_the_image() {
        let mut images = SensorImages::ZERO;
        images.apply(&ImageUpdate {
            die: Die::Bmp280,
            start: 0xF7,
            data: &[1, 2, 3, 4, 5, 6],
        });
        // BMP280: read 0xF7 (address byte with bit 7), write 0xF4 as 0x74.
        let mut data = [0u8; 6];
        images
            .transaction(
                Die::Bmp280,
                &mut [Operation::Write(&[0xF7]), Operation::Read(&mut data)],
            )
            .unwrap();
        assert_eq!(data, [1, 2, 3, 4, 5, 6]);
        images
            .transaction(Die::Bmp280, &mut [Operation::Write(&[0x74, 0x57])])
            .unwrap();
        assert_eq!(images.die(Die::Bmp280).get(0xF4), 0x57);
        // BMX055: read 0x82 means register 0x02.
        images.apply(&ImageUpdate {
            die: Die::Gyro,
            start: 0x02,
            data: &[9, 8],
        });
        let mut two = [0u8; 2];
        images
            .transaction(
                Die::Gyro,
                &mut [Operation::Write(&[0x82]), Operation::Read(&mut two)],
            )
            .unwrap();
        assert_eq!(two, [9, 8]);
        let mut orphan = [0u8; 1];
        assert!(images
            .transaction(Die::Gyro, &mut [Operation::Read(&mut orphan)])
            .is_err());
    }

    #[test]
    fn the_real_bring_up_passes_on_fed_images() {
        use crate::sensors::Sensors;
        use embedded_hal::delay::DelayNs;
        use embedded_hal::spi::{ErrorType, SpiDevice};

        struct Shared<'a>(&'a core::cell::RefCell<SensorImages>, Die);
        impl ErrorType for Shared<'_> {
            type Error = ErrorKind;
        }
        impl SpiDevice for Shared<'_> {
            fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
                self.0.borrow_mut().transaction(self.1, ops)
            }
        }
        struct NoDelay;
        impl DelayNs for NoDelay {
            fn delay_ns(&mut self, _: u32) {}
        }

        let images = core::cell::RefCell::new(SensorImages::ZERO);
        let mut parser = ImageFrameParser::new();
        let mut bytes = Vec::new();
        bytes.extend(frame(0, 0x00, &[0xFA]));
        bytes.extend(frame(1, 0x00, &[0x0F]));
        bytes.extend(frame(2, 0x40, &[0x32]));
        bytes.extend(frame(2, 0x5D, &[1, 2]));
        bytes.extend(frame(3, 0xD0, &[0x58]));
        let calibration = bosch_bmp280::Calibration::DATASHEET_EXAMPLE_BYTES;
        bytes.extend(frame(3, 0x88, &calibration));
        parse_all(&mut parser, &bytes, &mut images.borrow_mut());
        let (_, report) = Sensors::init(
            Shared(&images, Die::Accel),
            Shared(&images, Die::Gyro),
            Shared(&images, Die::Mag),
            Shared(&images, Die::Bmp280),
            &mut NoDelay,
        );
        assert_eq!(report.status.bits() & 0x0F, 0x0F);
        assert_eq!(report.bmp280_calibration, calibration);
        assert_eq!(report.bmm150_trim[..2], [1, 2]);
    }
}
