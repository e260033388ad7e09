//! The replay clock: the log time shown, in virtual time. Play, pause, seek and speed act on
//! it; the window hands it the wall time at each frame and reads the log time back. Pure: no
//! clock of its own, so it is tested with made-up wall times.

use std::time::Duration;

/// The playback speeds offered, slowest first.
pub const SPEEDS: [f64; 6] = [0.25, 0.5, 1.0, 2.0, 4.0, 8.0];

/// Where the replay is in the log and how it moves.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayClock {
    /// The log's duration: the clock never passes it.
    duration: Duration,
    /// The log time now, from the log's start.
    position: Duration,
    /// Playing (the position follows the wall time) or paused.
    playing: bool,
    /// Index into [`SPEEDS`].
    speed: usize,
    /// The wall time of the last tick (`None`: none yet, or playback just started).
    last_wall: Option<Duration>,
}

impl ReplayClock {
    /// At the start of a log of `duration`, paused, at 1×.
    pub fn new(duration: Duration) -> ReplayClock {
        ReplayClock {
            duration,
            position: Duration::ZERO,
            playing: false,
            speed: 2,
            last_wall: None,
        }
    }

    /// Advances to wall time `wall` (any monotonic origin): while playing the log time moves
    /// by the wall time since the last tick times the speed, and stops at the end of the log
    /// (playback pauses there). Returns the log time.
    pub fn tick(&mut self, wall: Duration) -> Duration {
        if self.playing {
            if let Some(last) = self.last_wall {
                let step = wall.saturating_sub(last).mul_f64(self.speed());
                self.position = (self.position + step).min(self.duration);
            }
            if self.position >= self.duration {
                self.playing = false;
            }
        }
        self.last_wall = Some(wall);
        self.position
    }

    /// The log time now, from the log's start.
    pub fn position(&self) -> Duration {
        self.position
    }

    /// The log's duration.
    pub fn duration(&self) -> Duration {
        self.duration
    }

    /// Whether the clock moves.
    pub fn is_playing(&self) -> bool {
        self.playing
    }

    /// Whether the clock is at the end of the log.
    pub fn at_end(&self) -> bool {
        self.position >= self.duration
    }

    /// Starts moving (from the start again when at the end).
    pub fn play(&mut self) {
        if self.at_end() {
            self.position = Duration::ZERO;
        }
        self.playing = true;
    }

    /// Holds the log time.
    pub fn pause(&mut self) {
        self.playing = false;
    }

    /// Play when paused, pause when playing.
    pub fn toggle(&mut self) {
        if self.playing {
            self.pause();
        } else {
            self.play();
        }
    }

    /// Jumps to log time `to` (clamped to the log).
    pub fn seek(&mut self, to: Duration) {
        self.position = to.min(self.duration);
    }

    /// Jumps by `seconds` (negative: back), clamped to the log.
    pub fn skip(&mut self, seconds: f64) {
        let now = self.position.as_secs_f64();
        self.seek(Duration::from_secs_f64((now + seconds).max(0.0)));
    }

    /// The speed, a factor of the wall time.
    pub fn speed(&self) -> f64 {
        SPEEDS[self.speed]
    }

    /// Sets the speed to the offered one nearest `factor`.
    pub fn set_speed(&mut self, factor: f64) {
        let distance = |s: f64| (s.ln() - factor.max(1e-3).ln()).abs();
        self.speed = (0..SPEEDS.len())
            .min_by(|&a, &b| distance(SPEEDS[a]).total_cmp(&distance(SPEEDS[b])))
            .unwrap_or(2);
    }

    /// The next faster speed (the fastest stays).
    pub fn faster(&mut self) {
        self.speed = (self.speed + 1).min(SPEEDS.len() - 1);
    }

    /// The next slower speed (the slowest stays).
    pub fn slower(&mut self) {
        self.speed = self.speed.saturating_sub(1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(seconds: f64) -> Duration {
        Duration::from_secs_f64(seconds)
    }

    fn close(a: Duration, b: f64) -> bool {
        (a.as_secs_f64() - b).abs() < 1e-6
    }

    #[test]
    fn pause_holds_the_log_time_and_play_resumes_from_it() {
        let mut clock = ReplayClock::new(s(60.0));
        assert!(close(clock.tick(s(100.0)), 0.0), "starts paused");
        clock.play();
        assert!(close(clock.tick(s(100.0)), 0.0), "no jump at play");
        assert!(close(clock.tick(s(103.0)), 3.0));
        clock.pause();
        assert!(close(clock.tick(s(110.0)), 3.0), "paused: held");
        assert!(close(clock.tick(s(200.0)), 3.0));
        clock.play();
        assert!(
            close(clock.tick(s(201.0)), 4.0),
            "the pause is not caught up"
        );
    }

    #[test]
    fn two_times_advances_twice_as_fast_and_speeds_step_through_the_offered_ones() {
        let mut clock = ReplayClock::new(s(60.0));
        clock.set_speed(2.0);
        clock.play();
        clock.tick(s(0.0));
        assert!(close(clock.tick(s(1.5)), 3.0));
        clock.set_speed(0.25);
        assert!(close(clock.tick(s(5.5)), 4.0));
        clock.slower();
        assert_eq!(clock.speed(), 0.25, "the slowest stays");
        for _ in 0..10 {
            clock.faster();
        }
        assert_eq!(clock.speed(), 8.0, "the fastest stays");
        assert!(close(clock.tick(s(6.5)), 12.0));
        clock.set_speed(3.0);
        assert!([2.0, 4.0].contains(&clock.speed()));
    }

    #[test]
    fn the_end_of_the_log_stops_playback_and_play_starts_over() {
        let mut clock = ReplayClock::new(s(10.0));
        clock.set_speed(8.0);
        clock.play();
        clock.tick(s(0.0));
        assert!(close(clock.tick(s(1.0)), 8.0));
        assert!(close(clock.tick(s(2.0)), 10.0), "clamped to the end");
        assert!(!clock.is_playing() && clock.at_end());
        assert!(close(clock.tick(s(3.0)), 10.0));
        clock.play();
        assert!(close(clock.position(), 0.0), "play at the end starts over");
        assert!(close(clock.tick(s(3.5)), 4.0));
    }

    #[test]
    fn seek_and_skip_stay_inside_the_log() {
        let mut clock = ReplayClock::new(s(10.0));
        clock.seek(s(7.5));
        assert!(close(clock.tick(s(0.0)), 7.5), "paused seek lands");
        clock.seek(s(99.0));
        assert!(close(clock.position(), 10.0));
        clock.skip(-4.0);
        assert!(close(clock.position(), 6.0));
        clock.skip(-40.0);
        assert!(close(clock.position(), 0.0));
        clock.toggle();
        assert!(clock.is_playing());
        clock.toggle();
        assert!(!clock.is_playing());
    }
}
