//! Manual driving: keys, gamepad and sliders merged into what the link holds and sends.
//!
//! Per channel, the first source that holds a value wins: a key, then the gamepad's stick,
//! then a slider being dragged. While a source holds, its value is held on the link (sent in
//! every slot). When a key or stick lets go, neutral is sent once; when a slider is let go,
//! its final value is sent once and stays on the slider.
//!
//! Nothing asked for before a revive drives after it: after a kill, a revive, or the station
//! dropping the manual values (it does when the robot reports KILLED or FAILSAFE), every
//! slider shows neutral again, and a key, stick or slider still held must be let go (a stick
//! back inside its dead zone) before it drives again. The link never re-asserts a held value
//! on its own: a value is held only from a new press or a new movement.

use dima_groundlink::station::ManualChannel;
use dima_groundlink::Percent;

use crate::channels::ChannelTable;
use crate::keys::AxisChange;
use crate::link::LinkControl;

/// What holds a channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Source {
    /// A key.
    Key,
    /// A gamepad stick.
    Gamepad,
    /// A slider being dragged.
    Slider,
}

/// The inputs of one frame, per channel (throttle, steering, tail).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManualInputs {
    /// The keyboard's axes.
    pub keys: [AxisChange; 3],
    /// Sticks outside their dead zone.
    pub gamepad: [Option<Percent>; 3],
    /// Sliders being dragged, with their value.
    pub slider_dragged: [Option<Percent>; 3],
}

impl Default for ManualInputs {
    fn default() -> Self {
        ManualInputs {
            keys: [AxisChange::Idle; 3],
            gamepad: [None; 3],
            slider_dragged: [None; 3],
        }
    }
}

/// The merge of the manual inputs, with what the sliders show.
#[derive(Debug, Clone)]
pub struct ManualControl {
    neutral: [Percent; 3],
    holder: [Option<(Source, Percent)>; 3],
    blocked: [bool; 3],
    /// The value each channel's slider shows (the last value sent or held).
    pub shown: [Percent; 3],
}

impl ManualControl {
    /// Everything at the channel table's neutral.
    pub fn new(table: &ChannelTable) -> ManualControl {
        let neutral = ManualChannel::ALL.map(|c| table.neutral_percent(c));
        ManualControl {
            neutral,
            holder: [None; 3],
            blocked: [false; 3],
            shown: neutral,
        }
    }

    /// The channel's neutral.
    pub fn neutral(&self, channel: ManualChannel) -> Percent {
        self.neutral[channel as usize]
    }

    /// Who holds `channel` now.
    pub fn holder(&self, channel: ManualChannel) -> Option<Source> {
        self.holder[channel as usize].map(|(s, _)| s)
    }

    /// A kill: nothing is held any more (the link dropped it too), every slider shows
    /// neutral, and whatever is still pressed must be let go first.
    pub fn killed(&mut self) {
        self.cancelled();
    }

    /// The station dropped the manual values (a revive, or the robot reported KILLED or
    /// FAILSAFE): every slider shows neutral and whatever is still pressed must be let go
    /// first. Returns the requests that stop holding on the link what this side held (the
    /// link dropped it already; this covers a hold that crossed the drop on its way).
    pub fn cancelled(&mut self) -> Vec<LinkControl> {
        let mut out = Vec::new();
        for (i, channel) in ManualChannel::ALL.into_iter().enumerate() {
            if self.holder[i].take().is_some() {
                self.blocked[i] = true;
                out.push(LinkControl::Hold(channel, None));
            }
            self.shown[i] = self.neutral[i];
        }
        out
    }

    /// The link requests for this frame's inputs.
    pub fn update(&mut self, inputs: &ManualInputs) -> Vec<LinkControl> {
        let mut out = Vec::new();
        for (i, channel) in ManualChannel::ALL.into_iter().enumerate() {
            let key = match inputs.keys[i] {
                AxisChange::Held(v) => Some(v),
                AxisChange::Released(_) | AxisChange::Idle => None,
            };
            let wanted = key
                .map(|v| (Source::Key, v))
                .or(inputs.gamepad[i].map(|v| (Source::Gamepad, v)))
                .or(inputs.slider_dragged[i].map(|v| (Source::Slider, v)));
            if self.blocked[i] {
                if wanted.is_some() {
                    continue;
                }
                self.blocked[i] = false;
            }
            let before = self.holder[i];
            if before == wanted {
                continue;
            }
            match wanted {
                Some((_, v)) => {
                    if before.map(|(_, b)| b) != Some(v) {
                        out.push(LinkControl::Hold(channel, Some(channel.command(v))));
                    }
                    self.shown[i] = v;
                }
                None => {
                    out.push(LinkControl::Hold(channel, None));
                    let last = match before {
                        Some((Source::Slider, v)) => v,
                        _ => self.neutral[i],
                    };
                    out.push(LinkControl::Request(channel.command(last)));
                    self.shown[i] = last;
                }
            }
            self.holder[i] = wanted;
        }
        out
    }

    /// A one-off value for `channel` (a slider clicked or typed in, "centre"): sent once.
    pub fn set(&mut self, channel: ManualChannel, value: Percent) -> Option<LinkControl> {
        let i = channel as usize;
        if self.holder[i].is_some() {
            return None;
        }
        self.shown[i] = value;
        Some(LinkControl::Request(channel.command(value)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dima_groundlink::Command;

    fn pct(v: u8) -> Percent {
        Percent::new(v).unwrap()
    }

    fn keys(throttle: AxisChange) -> ManualInputs {
        ManualInputs {
            keys: [throttle, AxisChange::Idle, AxisChange::Idle],
            ..ManualInputs::default()
        }
    }

    #[test]
    fn a_key_holds_then_releases_to_neutral() {
        let mut m = ManualControl::new(&ChannelTable::default());
        let held = m.update(&keys(AxisChange::Held(pct(70))));
        assert_eq!(
            held,
            vec![LinkControl::Hold(
                ManualChannel::Throttle,
                Some(Command::Throttle(pct(70)))
            )]
        );
        assert!(m.update(&keys(AxisChange::Held(pct(70)))).is_empty());
        assert_eq!(m.shown[0], pct(70));
        let released = m.update(&keys(AxisChange::Released(pct(50))));
        assert_eq!(
            released,
            vec![
                LinkControl::Hold(ManualChannel::Throttle, None),
                LinkControl::Request(Command::Throttle(pct(50)))
            ]
        );
        assert_eq!(m.shown[0], pct(50));
        assert!(m.update(&ManualInputs::default()).is_empty());
    }

    #[test]
    fn keys_win_over_the_gamepad_and_sliders_keep_their_value() {
        let mut m = ManualControl::new(&ChannelTable::default());
        let mut i = ManualInputs {
            gamepad: [Some(pct(90)), None, None],
            slider_dragged: [None, Some(pct(20)), None],
            ..ManualInputs::default()
        };
        let out = m.update(&i);
        assert_eq!(out.len(), 2);
        assert_eq!(m.holder(ManualChannel::Throttle), Some(Source::Gamepad));
        assert_eq!(m.holder(ManualChannel::Steering), Some(Source::Slider));
        i.keys[0] = AxisChange::Held(pct(30));
        assert_eq!(
            m.update(&i),
            vec![LinkControl::Hold(
                ManualChannel::Throttle,
                Some(Command::Throttle(pct(30)))
            )]
        );
        // The slider is let go at 25 %: sent once, and it stays there.
        i.slider_dragged[1] = None;
        let out = m.update(&i);
        assert_eq!(
            out,
            vec![
                LinkControl::Hold(ManualChannel::Steering, None),
                LinkControl::Request(Command::Steering(pct(20)))
            ]
        );
        assert_eq!(m.shown[1], pct(20));
        // A one-off value is refused while a source holds the channel.
        assert_eq!(m.set(ManualChannel::Throttle, pct(10)), None);
        assert_eq!(
            m.set(ManualChannel::Tail, pct(10)),
            Some(LinkControl::Request(Command::Tail(pct(10))))
        );
    }

    #[test]
    fn after_a_cancellation_every_source_must_be_let_go_and_sliders_show_neutral() {
        let mut m = ManualControl::new(&ChannelTable::default());
        // A slider put at 80 % (sent once), the stick held at 90 %, a key on steering.
        assert!(m.set(ManualChannel::Tail, pct(80)).is_some());
        let mut held = ManualInputs {
            keys: [
                AxisChange::Idle,
                AxisChange::Held(pct(30)),
                AxisChange::Idle,
            ],
            gamepad: [Some(pct(90)), None, None],
            ..ManualInputs::default()
        };
        assert_eq!(m.update(&held).len(), 2);
        assert_eq!(m.shown, [pct(90), pct(30), pct(80)]);
        // The robot reported FAILSAFE (or the operator revived): the station dropped them.
        let out = m.cancelled();
        assert_eq!(
            out,
            vec![
                LinkControl::Hold(ManualChannel::Throttle, None),
                LinkControl::Hold(ManualChannel::Steering, None)
            ]
        );
        assert_eq!(m.shown, [pct(50); 3], "every slider at neutral on screen");
        // Still held, frame after frame: nothing is sent.
        for _ in 0..5 {
            assert!(m.update(&held).is_empty());
        }
        // The stick moves but stays out of centre: still nothing.
        held.gamepad[0] = Some(pct(70));
        assert!(m.update(&held).is_empty());
        // Back to centre and the key let go: then a new movement drives.
        held.gamepad[0] = None;
        held.keys[1] = AxisChange::Released(pct(50));
        assert!(m.update(&held).is_empty());
        held.gamepad[0] = Some(pct(60));
        held.keys[1] = AxisChange::Idle;
        assert_eq!(
            m.update(&held),
            vec![LinkControl::Hold(
                ManualChannel::Throttle,
                Some(Command::Throttle(pct(60)))
            )]
        );
        assert_eq!(m.shown[0], pct(60));
    }

    #[test]
    fn after_a_kill_a_held_key_must_be_released_first() {
        let mut m = ManualControl::new(&ChannelTable::default());
        m.update(&keys(AxisChange::Held(pct(70))));
        m.killed();
        assert_eq!(m.shown[0], pct(50));
        for _ in 0..3 {
            assert!(m.update(&keys(AxisChange::Held(pct(70)))).is_empty());
        }
        assert!(m.update(&keys(AxisChange::Released(pct(50)))).is_empty());
        assert_eq!(m.update(&keys(AxisChange::Held(pct(70)))).len(), 1);
    }
}
