//! Helpers shared by the fuzz targets.
//!
//! The targets take plain byte streams (so the seeds are real captures and frames), and derive
//! everything else they need, such as where reads end, from the bytes themselves: the same
//! input always runs the same way, and a crash file reproduces.

/// A small deterministic generator (xorshift64*), seeded from the input.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// Seeds from the bytes (FNV-1a) and a salt, so two uses on one input differ.
    pub fn from_bytes(data: &[u8], salt: u64) -> Rng {
        let mut h = 0xCBF2_9CE4_8422_2325u64 ^ salt;
        for &b in data {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01B3);
        }
        Rng(h | 1)
    }

    /// The next value.
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// A value in `1..=max` (`max` at least 1).
    pub fn size(&mut self, max: usize) -> usize {
        1 + (self.next_u64() % max.max(1) as u64) as usize
    }
}

/// Cuts `data` into reads of 1 to `max` bytes, the sizes drawn from the input itself.
pub fn chunks(data: &[u8], max: usize, salt: u64) -> Vec<&[u8]> {
    let mut rng = Rng::from_bytes(data, salt);
    let mut out = Vec::new();
    let mut rest = data;
    while !rest.is_empty() {
        let (head, tail) = rest.split_at(rng.size(max).min(rest.len()));
        out.push(head);
        rest = tail;
    }
    out
}

/// The link key of the ground-link v2 targets and of their seeds: fixed, so that the seeds
/// hold authentic frames and mutations of them are forgeries.
pub const LINK_KEY: [u8; 16] = *b"dima fuzz key v2";

/// The robot's session id in the v2 targets and seeds.
pub const SESSION: u32 = 0x5EED_0002;
