//! Sans-IO GNSS stream: feed bytes from any source, keep the latest typed messages.
//!
//! [`GnssStream`] needs no serial port: a firmware can push each DMA chunk from its receive
//! interrupt and copy out the latest 100-byte NAV-PVT frame for its sensor packet, a host
//! can push whatever `read()` returned.

use crate::commands::{CLASS_ACK, ID_ACK_ACK, ID_ACK_NAK};
use crate::frame::{Frame, FramerStats, UbxFramer};
use crate::nav_pvt::NavPvtFrame;
use crate::timing::{TimTm2, TimTp};
use ublox::proto23::PacketRef;

/// One message found in the stream, copied out of the framer's buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Message {
    /// NAV-PVT, as the exact 100-byte frame.
    NavPvt(NavPvtFrame),
    /// TIM-TP (time pulse time data).
    TimTp(TimTp),
    /// TIM-TM2 (time mark data).
    TimTm2(TimTm2),
    /// ACK-ACK: the receiver accepted the message `class`/`id`.
    Ack {
        /// Class of the acknowledged message.
        class: u8,
        /// Id of the acknowledged message.
        id: u8,
    },
    /// ACK-NAK: the receiver rejected the message `class`/`id`.
    Nak {
        /// Class of the rejected message.
        class: u8,
        /// Id of the rejected message.
        id: u8,
    },
    /// Any other valid frame (or a known message with an unexpected length).
    Other {
        /// Message class.
        class: u8,
        /// Message id.
        id: u8,
    },
}

impl Message {
    /// Classifies a checksum-verified frame.
    pub fn from_frame(frame: &Frame<'_>) -> Self {
        match frame.decode() {
            Ok(PacketRef::NavPvt(_)) => match NavPvtFrame::from_frame(frame) {
                Some(f) => Self::NavPvt(f),
                None => Self::other(frame),
            },
            Ok(PacketRef::TimTp(p)) => Self::TimTp(TimTp::from_ublox(&p)),
            Ok(PacketRef::TimTm2(p)) => Self::TimTm2(TimTm2::from_ublox(&p)),
            _ => match (frame.class(), frame.id(), frame.payload()) {
                (CLASS_ACK, ID_ACK_ACK, &[class, id]) => Self::Ack { class, id },
                (CLASS_ACK, ID_ACK_NAK, &[class, id]) => Self::Nak { class, id },
                _ => Self::other(frame),
            },
        }
    }

    fn other(frame: &Frame<'_>) -> Self {
        Self::Other {
            class: frame.class(),
            id: frame.id(),
        }
    }
}

/// Resynchronising UBX stream that keeps the latest NAV-PVT, TIM-TP and TIM-TM2.
///
/// `N` is the framer buffer (see [`UbxFramer`]); 100 bytes suffice for NAV-PVT and the
/// timing messages.
///
/// ```
/// use neo_m8t::{GnssStream, NavPvt};
///
/// let frame = NavPvt { itow_ms: 1000, ..NavPvt::default() }.to_frame();
/// let mut stream = GnssStream::<100>::with_capacity();
/// // A DMA chunk: noise, then the frame split over two pushes.
/// stream.push_slice(&[0x24, 0x24, 0xB5]);
/// let (head, tail) = frame.as_bytes().split_at(40);
/// stream.push_slice(head);
/// assert_eq!(stream.push_slice(tail), 1);
/// let latest = stream.take_nav_pvt().unwrap();
/// assert_eq!(latest.as_bytes(), frame.as_bytes());
/// assert_eq!(stream.stats().bytes_skipped, 3);
/// ```
#[derive(Debug, Clone)]
pub struct GnssStream<const N: usize = 512> {
    framer: UbxFramer<N>,
    nav_pvt: Option<NavPvtFrame>,
    nav_pvt_fresh: bool,
    nav_pvt_count: u32,
    tim_tp: Option<TimTp>,
    tim_tm2: Option<TimTm2>,
}

impl<const N: usize> Default for GnssStream<N> {
    fn default() -> Self {
        Self::with_capacity()
    }
}

impl GnssStream {
    /// An empty stream with the default 512-byte frame buffer.
    pub const fn new() -> Self {
        Self::with_capacity()
    }
}

impl<const N: usize> GnssStream<N> {
    /// An empty stream with an `N`-byte frame buffer (`GnssStream::<100>::with_capacity()`).
    pub const fn with_capacity() -> Self {
        Self {
            framer: UbxFramer::with_capacity(),
            nav_pvt: None,
            nav_pvt_fresh: false,
            nav_pvt_count: 0,
            tim_tp: None,
            tim_tm2: None,
        }
    }

    /// Feeds one byte; returns the message it completed, if any (the latest values are
    /// updated as well).
    pub fn push(&mut self, byte: u8) -> Option<Message> {
        let message = self.framer.push(byte).map(|f| Message::from_frame(&f))?;
        self.record(&message);
        Some(message)
    }

    /// Returns a message held back from an earlier push (see [`UbxFramer::poll_pending`]).
    pub fn poll_pending(&mut self) -> Option<Message> {
        let message = self
            .framer
            .poll_pending()
            .map(|f| Message::from_frame(&f))?;
        self.record(&message);
        Some(message)
    }

    /// Feeds a chunk; returns how many NAV-PVT frames it completed. Other messages only
    /// update the latest values.
    pub fn push_slice(&mut self, bytes: &[u8]) -> usize {
        let before = self.nav_pvt_count;
        for &byte in bytes {
            let mut next = self.push(byte);
            while next.is_some() {
                next = self.poll_pending();
            }
        }
        self.nav_pvt_count.wrapping_sub(before) as usize
    }

    fn record(&mut self, message: &Message) {
        match *message {
            Message::NavPvt(frame) => {
                self.nav_pvt = Some(frame);
                self.nav_pvt_fresh = true;
                self.nav_pvt_count = self.nav_pvt_count.wrapping_add(1);
            }
            Message::TimTp(tp) => self.tim_tp = Some(tp),
            Message::TimTm2(tm) => self.tim_tm2 = Some(tm),
            _ => {}
        }
    }

    /// The latest NAV-PVT frame, whether or not it was already taken.
    pub fn latest_nav_pvt(&self) -> Option<&NavPvtFrame> {
        self.nav_pvt.as_ref()
    }

    /// The latest NAV-PVT frame if it arrived since the previous call.
    pub fn take_nav_pvt(&mut self) -> Option<NavPvtFrame> {
        if core::mem::take(&mut self.nav_pvt_fresh) {
            self.nav_pvt
        } else {
            None
        }
    }

    /// Copies the latest NAV-PVT frame into `out` (e.g. bytes 28-127 of the sensor packet);
    /// returns `false` and leaves `out` untouched if none was received yet.
    pub fn copy_latest_nav_pvt(&self, out: &mut [u8; crate::nav_pvt::FRAME_LEN]) -> bool {
        match &self.nav_pvt {
            Some(frame) => {
                out.copy_from_slice(frame.as_bytes());
                true
            }
            None => false,
        }
    }

    /// NAV-PVT frames received so far (wraps).
    pub fn nav_pvt_count(&self) -> u32 {
        self.nav_pvt_count
    }

    /// The latest TIM-TP message.
    pub fn latest_tim_tp(&self) -> Option<TimTp> {
        self.tim_tp
    }

    /// The latest TIM-TM2 message.
    pub fn latest_tim_tm2(&self) -> Option<TimTm2> {
        self.tim_tm2
    }

    /// Framing counters: frames ok, checksum failures, oversized frames, bytes skipped.
    pub fn stats(&self) -> FramerStats {
        self.framer.stats()
    }

    /// Drops a partial frame (e.g. after a baud-rate change or a UART overrun).
    pub fn clear_partial(&mut self) {
        self.framer.clear();
    }
}
