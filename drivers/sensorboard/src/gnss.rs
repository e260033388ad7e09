//! The GNSS area of the packet: a complete UBX NAV-PVT frame, copied verbatim by the board.
//!
//! The board forwards the last NAV-PVT frame its u-blox receiver sent, byte for byte, in
//! packet bytes 28..=127. Until the first frame arrives the area is all zeros. This module
//! keeps those 100 bytes as they are ([`GnssFrame`]); the typed view is the NEO-M8T driver's
//! [`NavPvt`] (every payload field as the integer the receiver sends, parsed with the `ublox`
//! crate), so the board, the host and the simulator share one definition of the message.

pub use neo_m8t::nav_pvt;
pub use neo_m8t::nav_pvt::{FixType, NavPvt, NavPvtFrame};

/// Length of the GNSS area: a UBX frame with a 92-byte NAV-PVT payload (6 header bytes,
/// payload, 2 checksum bytes).
pub const GNSS_FRAME_LEN: usize = neo_m8t::nav_pvt::FRAME_LEN;

/// The 100-byte GNSS area exactly as it travels in the packet.
///
/// The board copies its receiver's NAV-PVT frame here without touching it, so keeping the raw
/// bytes lets a log be replayed bit for bit. [`GnssFrame::nav_pvt`] gives the typed view.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct GnssFrame([u8; GNSS_FRAME_LEN]);

impl GnssFrame {
    /// The area the board sends before its receiver produced a NAV-PVT frame: all zeros.
    pub const ABSENT: Self = Self([0; GNSS_FRAME_LEN]);

    /// Wraps 100 bytes as received or as they should be sent, whatever they contain.
    #[must_use]
    pub const fn from_bytes(bytes: [u8; GNSS_FRAME_LEN]) -> Self {
        Self(bytes)
    }

    /// The 100 bytes exactly as they are on the wire.
    #[must_use]
    pub const fn as_bytes(&self) -> &[u8; GNSS_FRAME_LEN] {
        &self.0
    }

    /// The 100 bytes, by value.
    #[must_use]
    pub const fn into_bytes(self) -> [u8; GNSS_FRAME_LEN] {
        self.0
    }

    /// Builds a well-formed NAV-PVT frame (header, payload, checksum) from `pvt`.
    #[must_use]
    pub fn from_nav_pvt(pvt: &NavPvt) -> Self {
        Self::from(pvt.to_frame())
    }

    /// Whether the area is all zeros (the board has not seen a NAV-PVT frame yet).
    #[must_use]
    pub fn is_zero(&self) -> bool {
        self.0.iter().all(|&b| b == 0)
    }

    /// The area as a checksum-verified NAV-PVT frame.
    ///
    /// `None` when the area is all zeros, is not a NAV-PVT frame with the 92-byte payload, or
    /// fails its UBX checksum: the GNSS part of the packet is then absent, the rest of the
    /// packet is not affected.
    #[must_use]
    pub fn nav_pvt_frame(&self) -> Option<NavPvtFrame> {
        NavPvtFrame::from_bytes(&self.0)
    }

    /// Parses the area as a NAV-PVT message; `None` as for
    /// [`nav_pvt_frame`](Self::nav_pvt_frame).
    #[must_use]
    pub fn nav_pvt(&self) -> Option<NavPvt> {
        self.nav_pvt_frame().map(|frame| frame.to_nav_pvt())
    }
}

impl From<NavPvtFrame> for GnssFrame {
    fn from(frame: NavPvtFrame) -> Self {
        Self(*frame.as_bytes())
    }
}

impl Default for GnssFrame {
    fn default() -> Self {
        Self::ABSENT
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for GnssFrame {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "GnssFrame({=[u8]:02x})", &self.0[..]);
    }
}
