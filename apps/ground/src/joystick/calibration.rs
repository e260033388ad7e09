//! The calibration flow, as a pure state machine: raw gamepad samples and the time in, the
//! calibration out. The window only draws it and feeds it.
//!
//! 1. [`CalibrationStep::MoveToEnds`]: the operator moves every stick to all its ends; the
//!    flow keeps each axis's lowest and highest value. [`CalibrationFlow::next`] goes on once
//!    every axis a channel uses has travelled at least [`MIN_TRAVEL`].
//! 2. [`CalibrationStep::ReleaseToCentre`]: the operator lets go; once every axis has stayed
//!    within [`STILL_SPREAD`] for [`STILL_TIME`], the mean of that time is each axis's centre.
//! 3. [`CalibrationStep::Done`]: [`CalibrationFlow::apply`] writes the measured centre and
//!    ends into the channels' calibration (dead zone, inversion and expo are kept).
//!
//! The flow waits for a gamepad before its first sample; the gamepad disconnecting after that
//! fails the flow ([`CalibrationStep::Failed`]); it
//! starts again with [`CalibrationFlow::restart`].

use std::time::Duration;

use dima_groundlink::station::ManualChannel;

use super::config::JoystickConfig;
use super::names::{AxesSample, StickAxis};

/// The raw travel (highest minus lowest value) an axis a channel uses must cover.
pub const MIN_TRAVEL: f32 = 1.0;

/// The least raw distance from the centre to each end of an axis a channel uses (a trigger
/// resting at one end is no stick).
pub const MIN_SIDE: f32 = 0.25;

/// How much an axis may wander while it counts as resting.
pub const STILL_SPREAD: f32 = 0.05;

/// How long every axis must rest for its centre to be taken.
pub const STILL_TIME: Duration = Duration::from_secs(1);

/// Where the calibration is.
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrationStep {
    /// Move every stick to all its ends.
    MoveToEnds,
    /// Let every stick go to its centre and wait.
    ReleaseToCentre,
    /// Measured: ready to apply.
    Done,
    /// Stopped, and why.
    Failed(String),
}

/// The lowest and highest raw value of one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Travel {
    /// Lowest raw value seen.
    pub min: f32,
    /// Highest raw value seen.
    pub max: f32,
}

impl Travel {
    /// Highest minus lowest.
    pub fn span(&self) -> f32 {
        self.max - self.min
    }
}

/// Samples while waiting for the sticks to rest.
#[derive(Debug, Clone, PartialEq)]
struct RestWindow {
    since: Duration,
    low: AxesSample,
    high: AxesSample,
    sum: [f64; StickAxis::COUNT],
    count: u32,
}

impl RestWindow {
    fn start(sample: &AxesSample, now: Duration) -> RestWindow {
        RestWindow {
            since: now,
            low: *sample,
            high: *sample,
            sum: sample.map(|v| v.map_or(0.0, f64::from)),
            count: 1,
        }
    }

    /// Adds a sample; `false` when an axis moved more than [`STILL_SPREAD`] (or appeared or
    /// vanished), so the window must start again.
    fn add(&mut self, sample: &AxesSample) -> bool {
        for (i, value) in sample.iter().enumerate() {
            match (*value, self.low[i], self.high[i]) {
                (None, None, None) => {}
                (Some(v), Some(lo), Some(hi)) => {
                    let (lo, hi) = (lo.min(v), hi.max(v));
                    if hi - lo > STILL_SPREAD {
                        return false;
                    }
                    self.low[i] = Some(lo);
                    self.high[i] = Some(hi);
                    self.sum[i] += f64::from(v);
                }
                _ => return false,
            }
        }
        self.count += 1;
        true
    }

    fn means(&self) -> AxesSample {
        let mut out: AxesSample = [None; StickAxis::COUNT];
        for (i, slot) in out.iter_mut().enumerate() {
            if self.low[i].is_some() {
                *slot = Some((self.sum[i] / f64::from(self.count)) as f32);
            }
        }
        out
    }
}

/// The calibration flow.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationFlow {
    step: CalibrationStep,
    travel: [Option<Travel>; StickAxis::COUNT],
    rest: Option<RestWindow>,
    centre: AxesSample,
}

impl Default for CalibrationFlow {
    fn default() -> Self {
        CalibrationFlow::new()
    }
}

impl CalibrationFlow {
    /// At the first step, nothing measured.
    pub fn new() -> CalibrationFlow {
        CalibrationFlow {
            step: CalibrationStep::MoveToEnds,
            travel: [None; StickAxis::COUNT],
            rest: None,
            centre: [None; StickAxis::COUNT],
        }
    }

    /// Where the flow is.
    pub fn step(&self) -> &CalibrationStep {
        &self.step
    }

    /// Back to the first step, forgetting everything measured.
    pub fn restart(&mut self) {
        *self = CalibrationFlow::new();
    }

    /// One frame's raw axis values of the gamepad in use (`None`: no gamepad) at `now`.
    pub fn sample(&mut self, axes: Option<&AxesSample>, now: Duration) {
        if matches!(
            self.step,
            CalibrationStep::Done | CalibrationStep::Failed(_)
        ) {
            return;
        }
        let Some(axes) = axes else {
            if self.step == CalibrationStep::MoveToEnds && self.travel.iter().all(Option::is_none) {
                // Nothing measured yet: still waiting for a gamepad.
                return;
            }
            self.step = CalibrationStep::Failed(
                "the gamepad was disconnected: connect it and start again".to_owned(),
            );
            return;
        };
        let axes = axes.map(|v| v.filter(|v| v.is_finite()));
        match self.step {
            CalibrationStep::MoveToEnds => {
                for (travel, value) in self.travel.iter_mut().zip(axes) {
                    if let Some(v) = value {
                        *travel = Some(match *travel {
                            None => Travel { min: v, max: v },
                            Some(t) => Travel {
                                min: t.min.min(v),
                                max: t.max.max(v),
                            },
                        });
                    }
                }
            }
            CalibrationStep::ReleaseToCentre => {
                let still = match self.rest.as_mut() {
                    Some(w) => w.add(&axes),
                    None => false,
                };
                if !still {
                    self.rest = Some(RestWindow::start(&axes, now));
                }
                if let Some(w) = &self.rest {
                    if now.saturating_sub(w.since) >= STILL_TIME {
                        self.centre = w.means();
                        self.step = CalibrationStep::Done;
                    }
                }
            }
            CalibrationStep::Done | CalibrationStep::Failed(_) => {}
        }
    }

    /// An axis's travel so far.
    pub fn travel(&self, axis: StickAxis) -> Option<Travel> {
        self.travel[axis as usize]
    }

    /// An axis's measured centre (at [`CalibrationStep::Done`]).
    pub fn centre(&self, axis: StickAxis) -> Option<f32> {
        self.centre[axis as usize]
    }

    /// The axes of `config`'s channels that have not travelled [`MIN_TRAVEL`] yet.
    pub fn still_to_move(&self, config: &JoystickConfig) -> Vec<StickAxis> {
        used_axes(config)
            .filter(|a| self.travel(*a).is_none_or(|t| t.span() < MIN_TRAVEL))
            .collect()
    }

    /// From the ends to the centre, once every axis `config`'s channels use has travelled
    /// far enough; otherwise which axis still has to move.
    pub fn next(&mut self, config: &JoystickConfig) -> Result<(), String> {
        if self.step != CalibrationStep::MoveToEnds {
            return Err("not measuring the ends".to_owned());
        }
        let missing = self.still_to_move(config);
        if !missing.is_empty() {
            let names: Vec<&str> = missing.iter().map(|a| a.name()).collect();
            return Err(format!("move {} to both ends first", names.join(", ")));
        }
        self.step = CalibrationStep::ReleaseToCentre;
        self.rest = None;
        Ok(())
    }

    /// `config` with the measured centre and ends of each channel's axis (dead zone,
    /// inversion, expo and the kill button as they are in `config`).
    pub fn apply(&self, config: &JoystickConfig) -> Result<JoystickConfig, String> {
        if self.step != CalibrationStep::Done {
            return Err("the calibration is not finished".to_owned());
        }
        let mut out = *config;
        for channel in ManualChannel::ALL {
            let Some(axis) = config.channel(channel).axis else {
                continue;
            };
            let (Some(travel), Some(centre)) = (self.travel(axis), self.centre(axis)) else {
                return Err(format!(
                    "{}: {axis} was not measured: calibrate again",
                    channel.name()
                ));
            };
            let (min, max) = (travel.min.max(-1.0), travel.max.min(1.0));
            let centre = centre.clamp(-1.0, 1.0);
            if travel.span() < MIN_TRAVEL {
                return Err(format!(
                    "{}: {axis} travelled only {:.2}: calibrate again",
                    channel.name(),
                    travel.span()
                ));
            }
            if centre - min < MIN_SIDE || max - centre < MIN_SIDE {
                return Err(format!(
                    "{}: {axis} rests at {centre:.2}, too near an end of {min:.2}..{max:.2} \
                     (a trigger?): choose a stick",
                    channel.name()
                ));
            }
            let a = out.channel_mut(channel);
            a.centre = centre;
            a.min = min;
            a.max = max;
        }
        Ok(out)
    }
}

/// What the window's Save writes: the measured calibration applied to `draft` once the flow
/// is done, else `draft` as it is (settings only: axes, inversion, dead zone, expo, kill
/// button); checked as the file reader checks it (`origin` names the file in the error).
pub fn to_save(
    flow: &CalibrationFlow,
    draft: &JoystickConfig,
    origin: &str,
) -> Result<JoystickConfig, String> {
    let config = match flow.step() {
        CalibrationStep::Done => flow.apply(draft)?,
        _ => *draft,
    };
    config.validate(origin).map_err(|e| e.to_string())?;
    Ok(config)
}

/// The axes `config`'s channels use.
fn used_axes(config: &JoystickConfig) -> impl Iterator<Item = StickAxis> + '_ {
    ManualChannel::ALL
        .into_iter()
        .filter_map(|c| config.channel(c).axis)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    /// A sample with the left stick's vertical and the right stick's horizontal axes (the
    /// default throttle and steering), and a trigger resting at -1.
    fn sticks(throttle: f32, steering: f32) -> AxesSample {
        let mut s: AxesSample = [None; StickAxis::COUNT];
        s[StickAxis::LeftStickY as usize] = Some(throttle);
        s[StickAxis::RightStickX as usize] = Some(steering);
        s[StickAxis::LeftZ as usize] = Some(-1.0);
        s
    }

    /// Feeds `samples` 20 ms apart from `start`; returns the time after the last.
    fn feed(flow: &mut CalibrationFlow, samples: &[AxesSample], start: Duration) -> Duration {
        let mut t = start;
        for s in samples {
            flow.sample(Some(s), t);
            t += 20 * MS;
        }
        t
    }

    #[test]
    fn ends_then_rest_give_the_calibration() {
        let config = JoystickConfig::default();
        let mut flow = CalibrationFlow::new();
        // Only the throttle moved: steering still has to.
        let t = feed(
            &mut flow,
            &[sticks(0.05, 0.02), sticks(0.93, 0.02), sticks(-0.88, 0.02)],
            Duration::ZERO,
        );
        assert_eq!(flow.still_to_move(&config), vec![StickAxis::RightStickX]);
        let refused = flow.next(&config).unwrap_err();
        assert!(refused.contains("RightStickX"), "{refused}");
        assert_eq!(flow.step(), &CalibrationStep::MoveToEnds);
        let t = feed(&mut flow, &[sticks(0.05, -0.97), sticks(0.05, 0.91)], t);
        flow.next(&config).unwrap();
        assert_eq!(flow.step(), &CalibrationStep::ReleaseToCentre);
        assert_eq!(
            flow.travel(StickAxis::LeftStickY),
            Some(Travel {
                min: -0.88,
                max: 0.93
            })
        );
        // Released, but the stick still springs back: the rest starts after the last move.
        let t = feed(&mut flow, &[sticks(0.3, 0.02), sticks(0.12, 0.02)], t);
        let rest_from = t;
        let mut now = t;
        while flow.step() == &CalibrationStep::ReleaseToCentre {
            let wobble = if (now.as_millis() / 20).is_multiple_of(2) {
                0.01
            } else {
                -0.01
            };
            flow.sample(Some(&sticks(0.04 + wobble, 0.02)), now);
            now += 20 * MS;
            assert!(now < rest_from + 3 * STILL_TIME, "never settled");
        }
        assert_eq!(flow.step(), &CalibrationStep::Done);
        assert!(
            now - rest_from > STILL_TIME,
            "took the centre after resting only"
        );
        let centre = flow.centre(StickAxis::LeftStickY).unwrap();
        assert!((centre - 0.04).abs() < 0.011, "{centre}");

        let mut draft = config;
        draft.steering.expo = 0.3;
        draft.throttle.invert = true;
        let out = flow.apply(&draft).unwrap();
        assert_eq!((out.throttle.min, out.throttle.max), (-0.88, 0.93));
        assert_eq!(out.throttle.centre, centre);
        assert_eq!((out.steering.min, out.steering.max), (-0.97, 0.91));
        assert!((out.steering.centre - 0.02).abs() < 1e-6);
        // What the operator set is kept.
        assert!(out.throttle.invert);
        assert_eq!(out.steering.expo, 0.3);
        assert_eq!(out.tail, draft.tail);
        out.validate("calibration").unwrap();
        // The calibrated centre reads released, the measured ends full deflection.
        assert_eq!(out.steering.shape(0.02), None);
        assert_eq!(out.steering.shape(0.91), Some(1.0));
        assert_eq!(out.steering.shape(-0.97), Some(-1.0));
    }

    #[test]
    fn a_disconnect_fails_the_flow_and_restart_forgets() {
        let config = JoystickConfig::default();
        let mut flow = CalibrationFlow::new();
        feed(
            &mut flow,
            &[sticks(1.0, 1.0), sticks(-1.0, -1.0)],
            Duration::ZERO,
        );
        flow.next(&config).unwrap();
        flow.sample(None, Duration::from_millis(100));
        assert!(
            matches!(flow.step(), CalibrationStep::Failed(why) if why.contains("disconnected"))
        );
        assert!(flow.apply(&config).is_err());
        // Failed stays failed, whatever comes next.
        feed(&mut flow, &[sticks(0.0, 0.0); 100], Duration::from_secs(1));
        assert!(matches!(flow.step(), CalibrationStep::Failed(_)));
        flow.restart();
        assert_eq!(flow, CalibrationFlow::new());
        assert_eq!(flow.travel(StickAxis::LeftStickY), None);
    }

    #[test]
    fn an_axis_resting_at_an_end_or_never_measured_is_refused() {
        let mut config = JoystickConfig::default();
        // The tail on the trigger, which rests at -1 and goes to +1.
        config.tail.axis = Some(StickAxis::LeftZ);
        let mut flow = CalibrationFlow::new();
        let mut pressed = sticks(1.0, 1.0);
        pressed[StickAxis::LeftZ as usize] = Some(1.0);
        let t = feed(&mut flow, &[sticks(-1.0, -1.0), pressed], Duration::ZERO);
        flow.next(&config).unwrap();
        feed(&mut flow, &[sticks(0.0, 0.0); 60], t);
        assert_eq!(flow.step(), &CalibrationStep::Done);
        let e = flow.apply(&config).unwrap_err();
        assert!(e.contains("tail") && e.contains("LeftZ"), "{e}");
        // An axis chosen after the measurement was never moved.
        config.tail.axis = Some(StickAxis::DPadX);
        let e = flow.apply(&config).unwrap_err();
        assert!(e.contains("tail") && e.contains("DPadX"), "{e}");
        config.tail.axis = None;
        flow.apply(&config).unwrap();
    }

    #[test]
    fn apply_before_the_end_is_refused() {
        let flow = CalibrationFlow::new();
        assert!(flow.apply(&JoystickConfig::default()).is_err());
    }

    #[test]
    fn save_writes_the_measurement_or_only_the_settings_and_checks_them() {
        let mut draft = JoystickConfig::default();
        draft.throttle.expo = 0.5;
        let mut flow = CalibrationFlow::new();
        // Before the measurement: the settings, the old calibration kept.
        assert_eq!(to_save(&flow, &draft, "g.toml"), Ok(draft));
        let t = feed(
            &mut flow,
            &[sticks(-0.9, -0.8), sticks(0.9, 0.8)],
            Duration::ZERO,
        );
        flow.next(&draft).unwrap();
        feed(&mut flow, &[sticks(0.1, 0.0); 60], t);
        let saved = to_save(&flow, &draft, "g.toml").unwrap();
        assert_eq!((saved.throttle.min, saved.throttle.max), (-0.9, 0.9));
        assert!((saved.throttle.centre - 0.1).abs() < 1e-6);
        assert_eq!(saved.throttle.expo, 0.5);
        // Two channels on one axis: refused, naming the key and the file.
        draft.tail.axis = Some(StickAxis::RightStickX);
        let e = to_save(&flow, &draft, "g.toml").unwrap_err();
        assert!(e.contains("g.toml") && e.contains("tail.axis"), "{e}");
    }
}
