//! Alert sounds without a native audio library: each alert has its own tone pattern, written
//! as a WAV in memory and played by the system's command-line player (`aplay`, `paplay` or
//! `pw-play`, the first found) in the background. With `--mute`, or without a player or an
//! audio device, nothing is played: the banner still shows, and the skipped sounds are counted
//! and said once on standard error.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

use crate::alerts::Alert;

/// Sample rate of the tones, Hz.
pub const SAMPLE_RATE: u32 = 16_000;

/// The players tried, in order.
const PLAYERS: [&str; 3] = ["aplay", "paplay", "pw-play"];

/// The tone pattern of an alert: (frequency Hz, duration ms) pieces, 0 Hz for a pause.
pub fn pattern(alert: &Alert) -> &'static [(u32, u32)] {
    match alert {
        // Urgent: alternating high-low, three times.
        Alert::Failsafe(_) => &[
            (880, 180),
            (660, 180),
            (880, 180),
            (660, 180),
            (880, 180),
            (660, 180),
        ],
        // One long low tone.
        Alert::Killed => &[(440, 600)],
        // Falling.
        Alert::LinkLost => &[(988, 200), (784, 200), (587, 200), (392, 400)],
        // Rising, short.
        Alert::LinkRegained => &[(523, 120), (784, 160)],
        // Two short beeps.
        Alert::ReviveRefused(_) => &[(1200, 100), (0, 80), (1200, 100)],
    }
}

/// A mono 16-bit PCM WAV of `pattern` at [`SAMPLE_RATE`].
pub fn wav(pattern: &[(u32, u32)]) -> Vec<u8> {
    let mut samples: Vec<i16> = Vec::new();
    for &(hz, ms) in pattern {
        let n = (SAMPLE_RATE * ms / 1000) as usize;
        if n == 0 {
            continue;
        }
        for i in 0..n {
            // A short fade in and out keeps the pieces from clicking.
            let edge = (i.min(n - 1 - i) as f32 / 80.0).min(1.0);
            let t = i as f32 / SAMPLE_RATE as f32;
            let v = (2.0 * std::f32::consts::PI * hz as f32 * t).sin() * edge * 0.4;
            samples.push((v * f32::from(i16::MAX)) as i16);
        }
    }
    let data_len = (samples.len() * 2) as u32;
    let mut out = Vec::with_capacity(44 + data_len as usize);
    out.extend_from_slice(b"RIFF");
    out.extend_from_slice(&(36 + data_len).to_le_bytes());
    out.extend_from_slice(b"WAVEfmt ");
    out.extend_from_slice(&16u32.to_le_bytes());
    out.extend_from_slice(&1u16.to_le_bytes()); // PCM
    out.extend_from_slice(&1u16.to_le_bytes()); // mono
    out.extend_from_slice(&SAMPLE_RATE.to_le_bytes());
    out.extend_from_slice(&(SAMPLE_RATE * 2).to_le_bytes());
    out.extend_from_slice(&2u16.to_le_bytes());
    out.extend_from_slice(&16u16.to_le_bytes());
    out.extend_from_slice(b"data");
    out.extend_from_slice(&data_len.to_le_bytes());
    for s in samples {
        out.extend_from_slice(&s.to_le_bytes());
    }
    out
}

/// What became of a sound.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Handed to the player (it may still fail; that is counted as skipped).
    Started,
    /// `--mute`.
    Muted,
    /// No player found.
    Skipped,
}

/// Plays the alerts' sounds.
#[derive(Debug)]
pub struct Sounder {
    muted: bool,
    player: Option<PathBuf>,
    /// Sounds not played (no player, or the player failed: no audio device).
    skipped: Arc<AtomicU64>,
    /// The reason was said on standard error.
    said: Arc<AtomicBool>,
}

impl Sounder {
    /// A sounder; `muted` plays nothing. Looks for a player on `PATH` once.
    pub fn new(muted: bool) -> Sounder {
        let player = if muted { None } else { find_player() };
        Sounder {
            muted,
            player,
            skipped: Arc::new(AtomicU64::new(0)),
            said: Arc::new(AtomicBool::new(false)),
        }
    }

    /// Sounds not played so far (no player or no audio device).
    pub fn skipped(&self) -> u64 {
        self.skipped.load(Ordering::Relaxed)
    }

    /// Whether sounds are off (`--mute`).
    pub fn muted(&self) -> bool {
        self.muted
    }

    /// Plays `alert`'s sound in the background; never blocks.
    pub fn play(&self, alert: &Alert) -> Outcome {
        if self.muted {
            return Outcome::Muted;
        }
        let Some(player) = self.player.clone() else {
            skip(
                &self.skipped,
                &self.said,
                "no audio player (aplay, paplay, pw-play) found",
            );
            return Outcome::Skipped;
        };
        let bytes = wav(pattern(alert));
        let (skipped, said) = (self.skipped.clone(), self.said.clone());
        let spawned = std::thread::Builder::new()
            .name("ground-sound".into())
            .spawn(move || {
                if let Err(why) = run_player(&player, &bytes) {
                    skip(&skipped, &said, &why);
                }
            });
        if spawned.is_err() {
            skip(&self.skipped, &self.said, "cannot start a thread");
            return Outcome::Skipped;
        }
        Outcome::Started
    }
}

/// Counts a sound not played; says why the first time.
fn skip(skipped: &AtomicU64, said: &AtomicBool, why: &str) {
    skipped.fetch_add(1, Ordering::Relaxed);
    if !said.swap(true, Ordering::Relaxed) {
        eprintln!("dima-ground: alert sounds off: {why} (the banners still show)");
    }
}

fn find_player() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    PLAYERS.iter().find_map(|name| {
        std::env::split_paths(&path)
            .map(|dir| dir.join(name))
            .find(|p| p.is_file())
    })
}

/// Plays a WAV through `player` reading standard input; the error says why it did not.
fn run_player(player: &Path, wav: &[u8]) -> Result<(), String> {
    let mut child = Command::new(player)
        .args(player_args(player))
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("{}: {e}", player.display()))?;
    if let Some(mut stdin) = child.stdin.take() {
        // A player that exits early (no device) closes its input: the wait says why.
        let _ = stdin.write_all(wav);
    }
    let status = child
        .wait()
        .map_err(|e| format!("{}: {e}", player.display()))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!(
            "{} failed ({status}): no audio device?",
            player.display()
        ))
    }
}

fn player_args(player: &Path) -> &'static [&'static str] {
    match player.file_name().and_then(|n| n.to_str()) {
        Some("aplay") => &["-q", "-"],
        Some("pw-play") => &["-"],
        _ => &[],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::v2::{FailsafeCause, ReviveRefusal};

    #[test]
    fn each_alert_has_its_own_pattern_and_a_valid_wav() {
        let alerts = [
            Alert::Failsafe(Some(FailsafeCause::CommsLoss)),
            Alert::Killed,
            Alert::LinkLost,
            Alert::LinkRegained,
            Alert::ReviveRefused(ReviveRefusal::TooSoon),
        ];
        for (i, a) in alerts.iter().enumerate() {
            for b in &alerts[..i] {
                assert_ne!(pattern(a), pattern(b), "{a:?} and {b:?}");
            }
            let w = wav(pattern(a));
            let ms: u32 = pattern(a).iter().map(|p| p.1).sum();
            assert_eq!(&w[..4], b"RIFF");
            assert_eq!(&w[8..16], b"WAVEfmt ");
            assert_eq!(w.len(), 44 + 2 * (SAMPLE_RATE * ms / 1000) as usize);
            assert_eq!(
                u32::from_le_bytes(w[4..8].try_into().unwrap()) as usize,
                w.len() - 8
            );
        }
    }

    #[test]
    fn muted_plays_nothing_and_counts_nothing() {
        let s = Sounder::new(true);
        assert_eq!(s.play(&Alert::Killed), Outcome::Muted);
        assert_eq!(s.skipped(), 0);
    }

    #[test]
    fn without_a_player_the_sound_is_skipped_and_counted() {
        let s = Sounder {
            muted: false,
            player: None,
            skipped: Arc::default(),
            said: Arc::default(),
        };
        assert_eq!(s.play(&Alert::LinkLost), Outcome::Skipped);
        assert_eq!(s.play(&Alert::LinkLost), Outcome::Skipped);
        assert_eq!(s.skipped(), 2);
    }
}
