//! Info pieces: the info frame cut into 21-byte frames, one sent after each packet.
//!
//! A whole version 2 info frame (108 bytes, 2.58 ms at 460 800 baud 8N2) behind a packet
//! (3.15 ms) does not fit in a 4 ms request period: the next request would be skipped. A piece
//! (0.50 ms) does: packet + piece = 3.65 ms. Layout (21 bytes):
//!
//! | offset | size | content |
//! |---|---|---|
//! | 0-1 | 2 | start token `$H` (0x24 0x48) |
//! | 2 | 1 | snapshot counter: which info record the piece belongs to (u8, wraps) |
//! | 3 | 1 | piece index, 0 ..= count - 1 |
//! | 4 | 1 | piece count (1 ..= [`INFO_PIECE_MAX_COUNT`]; 9 for a version 2 frame, 11 for version 3) |
//! | 5-16 | 12 | the next 12 bytes of the info frame (the last piece is zero-padded) |
//! | 17-20 | 4 | sensor CRC ([`crate::crc`]: each byte a zero-extended word) over bytes 0-16, u32 LE |
//!
//! The payloads of pieces 0 ..= count - 1 of one snapshot, in order, are the whole info frame
//! (its `$I` header and its own CRC included), so a reassembled record is checked twice: every
//! piece by its CRC, the record by the info frame's CRC.
//!
//! **Board side** ([`InfoPieceCycle`]): the board takes a snapshot of its info frame every
//! 250 ms and sends each snapshot once, one piece after each packet, piece 0 first. A new
//! snapshot waits until the pieces of the current one are all out, so the pieces of one
//! record are never mixed with another's. A request [`crate::INFO_GAP_MS`] or more after the
//! previous one (the host has just started) starts the current snapshot again from piece 0.
//!
//! **Host side** ([`crate::StreamDecoder`]): a record is handed out only when pieces
//! 0 ..= count - 1 of one snapshot arrived one after another with valid CRCs and the
//! reassembled bytes are a valid info frame; anything else drops the record and counts it.

use crate::crc::SensorCrc;
use crate::info::{InfoFrame, INFO_MAX_LEN, INFO_V2_LEN, INFO_V3_LEN};

/// The start token of an info piece.
pub const INFO_PIECE_START: [u8; 2] = *b"$H";

/// Info frame bytes carried by one piece.
pub const INFO_PIECE_PAYLOAD_LEN: usize = 12;

/// Total length of an info piece on the wire.
pub const INFO_PIECE_LEN: usize = 5 + INFO_PIECE_PAYLOAD_LEN + 4;

/// Pieces of a version 2 info frame (108 bytes).
pub const INFO_V2_PIECES: usize = INFO_V2_LEN.div_ceil(INFO_PIECE_PAYLOAD_LEN);

/// Pieces of a version 3 info frame (128 bytes).
pub const INFO_V3_PIECES: usize = INFO_V3_LEN.div_ceil(INFO_PIECE_PAYLOAD_LEN);

/// Most pieces a record may have: enough for the largest info frame a decoder accepts.
pub const INFO_PIECE_MAX_COUNT: u8 = INFO_MAX_LEN.div_ceil(INFO_PIECE_PAYLOAD_LEN) as u8;

/// Bytes covered by a piece's CRC.
const PIECE_CRC_COVERED: usize = INFO_PIECE_LEN - 4;

/// A request this long after the previous one (milliseconds) means the host has just
/// (re)started: the board starts the current info snapshot again from piece 0.
pub const INFO_GAP_MS: u32 = 500;

/// How often the board takes a new info snapshot, milliseconds.
pub const INFO_SNAPSHOT_MS: u32 = 250;

/// One piece of an info frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InfoPiece {
    /// Which snapshot (info record) this piece belongs to.
    pub snapshot: u8,
    /// Position of the piece in its record, from 0.
    pub index: u8,
    /// Pieces in the record.
    pub count: u8,
    /// Info frame bytes `12 * index .. 12 * index + 12`.
    pub payload: [u8; INFO_PIECE_PAYLOAD_LEN],
}

/// Why bytes are not a valid info piece.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InfoPieceError {
    /// Fewer than [`INFO_PIECE_LEN`] bytes.
    Truncated,
    /// The first two bytes are not `$H`.
    StartToken,
    /// The count is 0 or above [`INFO_PIECE_MAX_COUNT`], or the index is not below it.
    Header {
        /// Piece index byte.
        index: u8,
        /// Piece count byte.
        count: u8,
    },
    /// The CRC does not match.
    Checksum {
        /// CRC computed over bytes 0-16.
        computed: u32,
        /// CRC carried in the piece.
        received: u32,
    },
}

impl core::fmt::Display for InfoPieceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Truncated => write!(f, "info piece truncated: needs {INFO_PIECE_LEN} bytes"),
            Self::StartToken => f.write_str("info piece does not start with `$H`"),
            Self::Header { index, count } => {
                write!(
                    f,
                    "info piece header not accepted: piece {index} of {count}"
                )
            }
            Self::Checksum { computed, received } => write!(
                f,
                "info piece CRC mismatch: computed {computed:#010x}, received {received:#010x}"
            ),
        }
    }
}

impl core::error::Error for InfoPieceError {}

impl InfoPiece {
    /// The wire bytes, CRC from `crc`.
    #[must_use]
    pub fn encode_with(&self, crc: &mut impl SensorCrc) -> [u8; INFO_PIECE_LEN] {
        let mut bytes = [0u8; INFO_PIECE_LEN];
        bytes[..2].copy_from_slice(&INFO_PIECE_START);
        bytes[2] = self.snapshot;
        bytes[3] = self.index;
        bytes[4] = self.count;
        bytes[5..PIECE_CRC_COVERED].copy_from_slice(&self.payload);
        let value = crc.checksum(&bytes[..PIECE_CRC_COVERED]);
        bytes[PIECE_CRC_COVERED..].copy_from_slice(&value.to_le_bytes());
        bytes
    }

    /// Decodes the piece at the start of `bytes` (bytes after it are ignored).
    ///
    /// # Errors
    /// Any [`InfoPieceError`].
    pub fn decode_with(bytes: &[u8], crc: &mut impl SensorCrc) -> Result<Self, InfoPieceError> {
        let bytes = bytes
            .get(..INFO_PIECE_LEN)
            .ok_or(InfoPieceError::Truncated)?;
        if bytes[..2] != INFO_PIECE_START {
            return Err(InfoPieceError::StartToken);
        }
        let (index, count) = (bytes[3], bytes[4]);
        if !header_ok(index, count) {
            return Err(InfoPieceError::Header { index, count });
        }
        let (covered, tail) = bytes.split_at(PIECE_CRC_COVERED);
        let received = u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]);
        let computed = crc.checksum(covered);
        if computed != received {
            return Err(InfoPieceError::Checksum { computed, received });
        }
        let mut payload = [0u8; INFO_PIECE_PAYLOAD_LEN];
        payload.copy_from_slice(&covered[5..]);
        Ok(Self {
            snapshot: bytes[2],
            index,
            count,
            payload,
        })
    }
}

/// True when piece `index` of `count` can exist.
pub(crate) fn header_ok(index: u8, count: u8) -> bool {
    (1..=INFO_PIECE_MAX_COUNT).contains(&count) && index < count
}

/// The pieces of one version 2 info frame, on the wire, in order.
pub type InfoPieceSet = [[u8; INFO_PIECE_LEN]; INFO_V2_PIECES];

/// The pieces of one version 3 info frame, on the wire, in order.
pub type InfoPieceSetV3 = [[u8; INFO_PIECE_LEN]; INFO_V3_PIECES];

impl InfoFrame {
    /// Encodes the frame as version 2 ([`InfoFrame::encode_v2_with`]) and cuts it into the
    /// [`INFO_V2_PIECES`] pieces of snapshot `snapshot`; every CRC comes from `crc`.
    #[must_use]
    pub fn encode_v2_pieces_with(&self, snapshot: u8, crc: &mut impl SensorCrc) -> InfoPieceSet {
        let mut set = [[0u8; INFO_PIECE_LEN]; INFO_V2_PIECES];
        cut_into_pieces(&self.encode_v2_with(crc), snapshot, crc, &mut set);
        set
    }

    /// Encodes the frame as version 3 ([`InfoFrame::encode_v3_with`]) and cuts it into the
    /// [`INFO_V3_PIECES`] pieces of snapshot `snapshot`; every CRC comes from `crc`.
    #[must_use]
    pub fn encode_v3_pieces_with(&self, snapshot: u8, crc: &mut impl SensorCrc) -> InfoPieceSetV3 {
        let mut set = [[0u8; INFO_PIECE_LEN]; INFO_V3_PIECES];
        cut_into_pieces(&self.encode_v3_with(crc), snapshot, crc, &mut set);
        set
    }
}

/// Cuts an encoded info frame into `set.len()` pieces of snapshot `snapshot` (the last one
/// zero-padded); every CRC comes from `crc`.
fn cut_into_pieces(
    frame: &[u8],
    snapshot: u8,
    crc: &mut impl SensorCrc,
    set: &mut [[u8; INFO_PIECE_LEN]],
) {
    let count = set.len() as u8;
    for (index, (slot, chunk)) in set
        .iter_mut()
        .zip(frame.chunks(INFO_PIECE_PAYLOAD_LEN))
        .enumerate()
    {
        let mut piece = InfoPiece {
            snapshot,
            index: index as u8,
            count,
            payload: [0; INFO_PIECE_PAYLOAD_LEN],
        };
        piece.payload[..chunk.len()].copy_from_slice(chunk);
        *slot = piece.encode_with(crc);
    }
}

/// Board side: which info piece goes out after the next packet.
///
/// Holds the snapshot being sent and, behind it, the newest snapshot not yet started. The
/// sampling side [`publish`](InfoPieceCycle::publish)es a new set every
/// [`INFO_SNAPSHOT_MS`]; the answering side asks [`next`](InfoPieceCycle::next) once per
/// packet. Both are constant time apart from copying the set.
#[derive(Debug, Clone)]
pub struct InfoPieceCycle {
    sending: InfoPieceSetV3,
    waiting: InfoPieceSetV3,
    /// Pieces in `sending` and `waiting` (a version 2 or a version 3 set).
    sending_count: usize,
    waiting_count: usize,
    /// A snapshot has been started (else `sending` is empty).
    started: bool,
    waiting_fresh: bool,
    /// Next piece of `sending` to go out; `sending_count` when all are out.
    index: usize,
}

impl Default for InfoPieceCycle {
    fn default() -> Self {
        Self::new()
    }
}

impl InfoPieceCycle {
    /// No snapshot yet: [`InfoPieceCycle::next`] gives nothing until the first publish.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            sending: [[0; INFO_PIECE_LEN]; INFO_V3_PIECES],
            waiting: [[0; INFO_PIECE_LEN]; INFO_V3_PIECES],
            sending_count: 0,
            waiting_count: 0,
            started: false,
            waiting_fresh: false,
            index: 0,
        }
    }

    /// A new snapshot (the pieces of a version 2 or 3 frame, [`INFO_V3_PIECES`] at most;
    /// more are dropped): sent once the current one is out (a newer publish replaces it).
    pub fn publish(&mut self, set: &[[u8; INFO_PIECE_LEN]]) {
        let count = set.len().min(INFO_V3_PIECES);
        self.waiting[..count].copy_from_slice(&set[..count]);
        self.waiting_count = count;
        self.waiting_fresh = true;
    }

    /// The piece to send after this packet, if any. `restart`: the host has just (re)started
    /// (a request [`INFO_GAP_MS`] after the previous one): begin a snapshot from piece 0, the
    /// newest one if a new one waits.
    pub fn next(&mut self, restart: bool) -> Option<&[u8; INFO_PIECE_LEN]> {
        if restart || self.index >= self.sending_count {
            if self.waiting_fresh {
                self.sending = self.waiting;
                self.sending_count = self.waiting_count;
                self.waiting_fresh = false;
                self.started = true;
                self.index = 0;
            } else if restart && self.started {
                self.index = 0;
            }
        }
        let piece = self.sending[..self.sending_count].get(self.index)?;
        self.index += 1;
        Some(piece)
    }
}

/// Host side: puts the pieces of one snapshot back together (used by
/// [`crate::StreamDecoder`]).
#[derive(Debug, Clone)]
pub(crate) struct Reassembler {
    bytes: [u8; INFO_PIECE_MAX_COUNT as usize * INFO_PIECE_PAYLOAD_LEN],
    state: Assembly,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Assembly {
    /// No record in progress (a record was completed or none was seen yet).
    Idle,
    /// Collecting: the snapshot, its count and the index expected next.
    Collecting { snapshot: u8, count: u8, next: u8 },
    /// The current record was already dropped: ignore its pieces until a piece 0.
    Dropped,
}

/// What a piece did: records dropped (0, 1 or 2) and a completed record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct PieceOutcome {
    /// Records lost: the unfinished one a piece 0 replaced, the one a stray piece belongs
    /// to, or a complete one that is not a valid info frame.
    pub(crate) dropped: u8,
    /// The record the last piece completed.
    pub(crate) record: Option<InfoFrame>,
}

impl Reassembler {
    pub(crate) const fn new() -> Self {
        Self {
            bytes: [0; INFO_PIECE_MAX_COUNT as usize * INFO_PIECE_PAYLOAD_LEN],
            state: Assembly::Idle,
        }
    }

    pub(crate) fn push(&mut self, piece: &InfoPiece, crc: &mut impl SensorCrc) -> PieceOutcome {
        let mut outcome = PieceOutcome::default();
        if piece.index == 0 {
            if matches!(self.state, Assembly::Collecting { .. }) {
                outcome.dropped += 1;
            }
            self.state = Assembly::Collecting {
                snapshot: piece.snapshot,
                count: piece.count,
                next: 0,
            };
        }
        let expected = match self.state {
            Assembly::Collecting {
                snapshot,
                count,
                next,
            } => snapshot == piece.snapshot && count == piece.count && next == piece.index,
            Assembly::Idle | Assembly::Dropped => false,
        };
        if !expected {
            // A piece that cannot continue a record: the record it belongs to (and the one in
            // progress) is lost, counted once.
            if self.state != Assembly::Dropped {
                outcome.dropped += 1;
            }
            self.state = Assembly::Dropped;
            return outcome;
        }
        let start = usize::from(piece.index) * INFO_PIECE_PAYLOAD_LEN;
        if let Some(slot) = self.bytes.get_mut(start..start + INFO_PIECE_PAYLOAD_LEN) {
            slot.copy_from_slice(&piece.payload);
        }
        if piece.index + 1 < piece.count {
            self.state = Assembly::Collecting {
                snapshot: piece.snapshot,
                count: piece.count,
                next: piece.index + 1,
            };
            return outcome;
        }
        self.state = Assembly::Idle;
        let len = usize::from(piece.count) * INFO_PIECE_PAYLOAD_LEN;
        match self
            .bytes
            .get(..len)
            .and_then(|bytes| InfoFrame::decode_with(bytes, crc).ok())
        {
            Some((info, _)) => outcome.record = Some(info),
            None => outcome.dropped += 1,
        }
        outcome
    }
}
