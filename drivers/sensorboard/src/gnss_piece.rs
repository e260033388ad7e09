//! GNSS pieces: the 100-byte NAV-PVT frame cut into four 34-byte frames that travel behind
//! version 2 packets, and the board-side cycle that decides what follows each packet.
//!
//! Layout (34 bytes, little-endian):
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0-1 | 2 | start token `$G` (0x24 0x47) |
//! | 2 | 1 | epoch: which NAV-PVT frame the piece belongs to (u8, one more per new frame, wraps) |
//! | 3 | 1 | piece index, 0 ..= 3 |
//! | 4 | 1 | piece count, always [`GNSS_PIECE_COUNT`] = 4 |
//! | 5-29 | 25 | NAV-PVT frame bytes 25 x index ..= 25 x index + 24 |
//! | 30-33 | 4 | sensor CRC ([`crate::crc`]) over bytes 0-29, u32 |
//!
//! **Board side** ([`AnswerCycleV2`]): when the receiver delivers a new NAV-PVT frame (10 Hz)
//! the board cuts it into pieces of a new epoch; one piece follows each packet, piece 0
//! first, so a frame is out 4 packets (2 ms at 2 kHz) later. A newer frame waits until the
//! current one's pieces are out (only the newest waiting frame is kept), so the pieces of two
//! epochs never interleave on the wire. When no GNSS piece is pending, an info piece
//! ([`crate::InfoPiece`], 21 bytes, shorter than a GNSS piece) follows instead, if there is one.
//!
//! **Host side** ([`crate::StreamDecoderV2`]): a [`GnssFrame`] is handed out only when pieces
//! 0 ..= 3 of one epoch arrived one after another (other frames between them do not matter)
//! with valid CRCs; a piece of another epoch, or a piece out of order, drops the partial frame
//! and counts it, and a piece 0 starts a new one.

use crate::crc::SensorCrc;
use crate::gnss::{GnssFrame, GNSS_FRAME_LEN};
use crate::packet_v2::LinkFlags;
use crate::piece::{InfoPieceCycle, INFO_PIECE_LEN};

/// The start token of a GNSS piece.
pub const GNSS_PIECE_START: [u8; 2] = *b"$G";

/// Pieces of one NAV-PVT frame.
pub const GNSS_PIECE_COUNT: u8 = 4;

/// NAV-PVT frame bytes carried by one piece.
pub const GNSS_PIECE_PAYLOAD_LEN: usize = GNSS_FRAME_LEN / GNSS_PIECE_COUNT as usize;

/// Total length of a GNSS piece on the wire.
pub const GNSS_PIECE_LEN: usize = 5 + GNSS_PIECE_PAYLOAD_LEN + 4;

/// Bytes covered by a piece's CRC.
const GNSS_PIECE_CRC_COVERED: usize = GNSS_PIECE_LEN - 4;

/// The pieces of one NAV-PVT frame, on the wire, in order.
pub type GnssPieceSet = [[u8; GNSS_PIECE_LEN]; GNSS_PIECE_COUNT as usize];

/// One piece of a NAV-PVT frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GnssPiece {
    /// Which NAV-PVT frame this piece belongs to.
    pub epoch: u8,
    /// Position of the piece in its frame, 0 ..= 3.
    pub index: u8,
    /// NAV-PVT frame bytes `25 * index .. 25 * index + 25`.
    pub payload: [u8; GNSS_PIECE_PAYLOAD_LEN],
}

/// Why bytes are not a valid GNSS piece.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GnssPieceError {
    /// Fewer than [`GNSS_PIECE_LEN`] bytes.
    Truncated,
    /// The first two bytes are not `$G`.
    StartToken,
    /// The count is not [`GNSS_PIECE_COUNT`], or the index is not below it.
    Header {
        /// Piece index byte.
        index: u8,
        /// Piece count byte.
        count: u8,
    },
    /// The CRC does not match.
    Checksum {
        /// CRC computed over bytes 0-29.
        computed: u32,
        /// CRC carried in the piece.
        received: u32,
    },
}

impl core::fmt::Display for GnssPieceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Truncated => write!(f, "GNSS piece truncated: needs {GNSS_PIECE_LEN} bytes"),
            Self::StartToken => f.write_str("GNSS piece does not start with `$G`"),
            Self::Header { index, count } => {
                write!(
                    f,
                    "GNSS piece header not accepted: piece {index} of {count}"
                )
            }
            Self::Checksum { computed, received } => write!(
                f,
                "GNSS piece CRC mismatch: computed {computed:#010x}, received {received:#010x}"
            ),
        }
    }
}

impl core::error::Error for GnssPieceError {}

impl GnssPiece {
    /// The wire bytes, CRC from `crc`.
    #[must_use]
    pub fn encode_with(&self, crc: &mut impl SensorCrc) -> [u8; GNSS_PIECE_LEN] {
        let mut bytes = [0u8; GNSS_PIECE_LEN];
        bytes[..2].copy_from_slice(&GNSS_PIECE_START);
        bytes[2] = self.epoch;
        bytes[3] = self.index;
        bytes[4] = GNSS_PIECE_COUNT;
        bytes[5..GNSS_PIECE_CRC_COVERED].copy_from_slice(&self.payload);
        let value = crc.checksum(&bytes[..GNSS_PIECE_CRC_COVERED]);
        bytes[GNSS_PIECE_CRC_COVERED..].copy_from_slice(&value.to_le_bytes());
        bytes
    }

    /// Decodes the piece at the start of `bytes` (bytes after it are ignored).
    ///
    /// # Errors
    /// Any [`GnssPieceError`].
    pub fn decode_with(bytes: &[u8], crc: &mut impl SensorCrc) -> Result<Self, GnssPieceError> {
        let bytes = bytes
            .get(..GNSS_PIECE_LEN)
            .ok_or(GnssPieceError::Truncated)?;
        if bytes[..2] != GNSS_PIECE_START {
            return Err(GnssPieceError::StartToken);
        }
        let (index, count) = (bytes[3], bytes[4]);
        if count != GNSS_PIECE_COUNT || index >= count {
            return Err(GnssPieceError::Header { index, count });
        }
        let (covered, tail) = bytes.split_at(GNSS_PIECE_CRC_COVERED);
        let received = u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]);
        let computed = crc.checksum(covered);
        if computed != received {
            return Err(GnssPieceError::Checksum { computed, received });
        }
        let mut payload = [0u8; GNSS_PIECE_PAYLOAD_LEN];
        payload.copy_from_slice(&covered[5..]);
        Ok(Self {
            epoch: bytes[2],
            index,
            payload,
        })
    }
}

impl GnssFrame {
    /// Cuts the 100 bytes into the [`GNSS_PIECE_COUNT`] pieces of epoch `epoch`; every CRC
    /// comes from `crc`.
    #[must_use]
    pub fn encode_pieces_with(&self, epoch: u8, crc: &mut impl SensorCrc) -> GnssPieceSet {
        let mut set = [[0u8; GNSS_PIECE_LEN]; GNSS_PIECE_COUNT as usize];
        for (index, (slot, chunk)) in set
            .iter_mut()
            .zip(self.as_bytes().chunks_exact(GNSS_PIECE_PAYLOAD_LEN))
            .enumerate()
        {
            let mut piece = GnssPiece {
                epoch,
                index: index as u8,
                payload: [0; GNSS_PIECE_PAYLOAD_LEN],
            };
            piece.payload.copy_from_slice(chunk);
            *slot = piece.encode_with(crc);
        }
        set
    }
}

/// What follows a version 2 packet on the wire (see [`AnswerCycleV2::next`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Trailer<'a> {
    /// A GNSS piece.
    Gnss(&'a [u8; GNSS_PIECE_LEN]),
    /// An info piece.
    Info(&'a [u8; INFO_PIECE_LEN]),
}

impl Trailer<'_> {
    /// The bytes to send right after the packet.
    #[must_use]
    pub fn as_bytes(&self) -> &[u8] {
        match self {
            Self::Gnss(bytes) => &bytes[..],
            Self::Info(bytes) => &bytes[..],
        }
    }

    /// The packet's link flag that announces this trailer.
    #[must_use]
    pub const fn flag(&self) -> LinkFlags {
        match self {
            Self::Gnss(_) => LinkFlags::GNSS_PIECE_FOLLOWS,
            Self::Info(_) => LinkFlags::INFO_PIECE_FOLLOWS,
        }
    }
}

/// Board side of packet v2: what follows the next packet.
///
/// A GNSS piece when one is pending (the newest NAV-PVT frame goes out in four consecutive
/// answers, piece 0 first), else an info piece if the [`InfoPieceCycle`] has one. Only one
/// trailer follows a packet, so an answer is at most 42 + 34 = 76 bytes.
///
/// The sampling side calls [`publish_gnss`](Self::publish_gnss) for each new NAV-PVT frame
/// and [`publish_info`](Self::publish_info) for each info snapshot; the answering side calls
/// [`next`](Self::next) once per request, sets [`Trailer::flag`] in the packet, and sends the
/// packet then the trailer.
#[derive(Debug, Clone)]
pub struct AnswerCycleV2 {
    sending: GnssPieceSet,
    waiting: GnssPieceSet,
    waiting_fresh: bool,
    /// Next piece of `sending` to go out; [`GNSS_PIECE_COUNT`] when all are out.
    index: usize,
    /// Epoch of the next published frame.
    epoch: u8,
    info: InfoPieceCycle,
    /// A restart seen while GNSS pieces had the slot: the next info piece starts over.
    info_restart: bool,
}

impl Default for AnswerCycleV2 {
    fn default() -> Self {
        Self::new()
    }
}

impl AnswerCycleV2 {
    /// Nothing to send yet.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            sending: [[0; GNSS_PIECE_LEN]; GNSS_PIECE_COUNT as usize],
            waiting: [[0; GNSS_PIECE_LEN]; GNSS_PIECE_COUNT as usize],
            waiting_fresh: false,
            index: GNSS_PIECE_COUNT as usize,
            epoch: 0,
            info: InfoPieceCycle::new(),
            info_restart: false,
        }
    }

    /// A new NAV-PVT frame: cut into pieces of the next epoch (CRCs from `crc`) and sent once
    /// the current frame's pieces are out (a newer publish replaces one still waiting).
    /// Returns the epoch given to it.
    pub fn publish_gnss(&mut self, frame: &GnssFrame, crc: &mut impl SensorCrc) -> u8 {
        let epoch = self.epoch;
        self.waiting = frame.encode_pieces_with(epoch, crc);
        self.waiting_fresh = true;
        self.epoch = self.epoch.wrapping_add(1);
        epoch
    }

    /// A new info snapshot's pieces, as [`InfoPieceCycle::publish`].
    pub fn publish_info(&mut self, set: &[[u8; INFO_PIECE_LEN]]) {
        self.info.publish(set);
    }

    /// Whether GNSS pieces are still to be sent (the current frame's or a waiting one).
    #[must_use]
    pub const fn gnss_pending(&self) -> bool {
        self.waiting_fresh || self.index < GNSS_PIECE_COUNT as usize
    }

    /// What to send after this packet, if anything. `restart` as for [`InfoPieceCycle::next`]
    /// (kept for the next info piece when a GNSS piece takes this answer).
    pub fn next(&mut self, restart: bool) -> Option<Trailer<'_>> {
        if self.index >= GNSS_PIECE_COUNT as usize && self.waiting_fresh {
            self.sending = self.waiting;
            self.waiting_fresh = false;
            self.index = 0;
        }
        if let Some(piece) = self.sending.get(self.index) {
            self.index += 1;
            self.info_restart |= restart;
            return Some(Trailer::Gnss(piece));
        }
        let restart = core::mem::take(&mut self.info_restart) || restart;
        self.info.next(restart).map(Trailer::Info)
    }
}

/// Host side: puts the pieces of one NAV-PVT frame back together (used by
/// [`crate::StreamDecoderV2`]).
#[derive(Debug, Clone)]
pub(crate) struct GnssReassembler {
    bytes: [u8; GNSS_FRAME_LEN],
    state: Assembly,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Assembly {
    /// No frame in progress.
    Idle,
    /// Collecting: the epoch and the index expected next.
    Collecting { epoch: u8, next: u8 },
    /// The current frame was dropped: ignore its pieces until a piece 0.
    Dropped,
}

/// What a piece did: frames dropped (0, 1 or 2) and a completed frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct GnssOutcome {
    /// Frames lost: the unfinished one a piece 0 replaced, or the one a stray piece belongs to
    /// (with the one in progress, counted once).
    pub(crate) dropped: u8,
    /// The frame the last piece completed.
    pub(crate) frame: Option<GnssFrame>,
}

impl GnssReassembler {
    pub(crate) const fn new() -> Self {
        Self {
            bytes: [0; GNSS_FRAME_LEN],
            state: Assembly::Idle,
        }
    }

    pub(crate) fn push(&mut self, piece: &GnssPiece) -> GnssOutcome {
        let mut outcome = GnssOutcome::default();
        if piece.index == 0 {
            if matches!(self.state, Assembly::Collecting { .. }) {
                outcome.dropped += 1;
            }
            self.state = Assembly::Collecting {
                epoch: piece.epoch,
                next: 0,
            };
        }
        let expected = match self.state {
            Assembly::Collecting { epoch, next } => epoch == piece.epoch && next == piece.index,
            Assembly::Idle | Assembly::Dropped => false,
        };
        if !expected {
            if self.state != Assembly::Dropped {
                outcome.dropped += 1;
            }
            self.state = Assembly::Dropped;
            return outcome;
        }
        let start = usize::from(piece.index) * GNSS_PIECE_PAYLOAD_LEN;
        if let Some(slot) = self.bytes.get_mut(start..start + GNSS_PIECE_PAYLOAD_LEN) {
            slot.copy_from_slice(&piece.payload);
        }
        if piece.index + 1 < GNSS_PIECE_COUNT {
            self.state = Assembly::Collecting {
                epoch: piece.epoch,
                next: piece.index + 1,
            };
        } else {
            self.state = Assembly::Idle;
            outcome.frame = Some(GnssFrame::from_bytes(self.bytes));
        }
        outcome
    }
}

// The pieces carry the whole frame, with no padding.
const _: () = assert!(GNSS_PIECE_PAYLOAD_LEN * GNSS_PIECE_COUNT as usize == GNSS_FRAME_LEN);
