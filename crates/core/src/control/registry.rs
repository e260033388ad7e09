//! Controllers by name: `kind = "..."` in `[control.throttle]`, `[control.steering]` and
//! `[control.tail]` picks one from [`KINDS`]; the rest of the section is its parameters.
//!
//! Adding a controller: a file with a type that implements [`Controller`] and a
//! `from_params(&toml::Table)` constructor, and one line in [`KINDS`].

use super::controller::{Channel, ControlInput, Controller};
use super::heading_pid::HeadingPid;
use super::neutral::Neutral;
use super::speed_pid::SpeedPid;
use super::yaw_rate::YawRate;
use super::Actuation;
use crate::config::ControlConfig;

/// A controller kind: its name in the configuration and how to build it.
#[derive(Debug, Clone, Copy)]
pub struct ControllerKind {
    /// The `kind` value.
    pub name: &'static str,
    /// One line for `dima config --check` and the documentation.
    pub summary: &'static str,
    /// Builds one from the section's other keys.
    pub build: fn(&toml::Table) -> Result<Box<dyn Controller>, ParamError>,
}

fn boxed<C: Controller + 'static>(
    c: Result<C, ParamError>,
) -> Result<Box<dyn Controller>, ParamError> {
    c.map(|c| Box::new(c) as Box<dyn Controller>)
}

/// Every controller the configuration can name.
pub const KINDS: &[ControllerKind] = &[
    ControllerKind {
        name: "none",
        summary: "neutral in AUTO",
        build: |p| boxed(no_params(p).map(|()| Neutral)),
    },
    ControllerKind {
        name: "speed_pid",
        summary: "PID on the ground-speed error (m/s)",
        build: |p| boxed(SpeedPid::from_params(p)),
    },
    ControllerKind {
        name: "heading_pid",
        summary: "PID on the heading error (degrees), damped by the yaw rate",
        build: |p| boxed(HeadingPid::from_params(p)),
    },
    ControllerKind {
        name: "yaw_rate",
        summary: "PI on the yaw rate the steering demand asks for",
        build: |p| boxed(YawRate::from_params(p)),
    },
];

/// A controller's parameters are wrong.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ParamError {
    /// The parameters do not parse (unknown or missing key, wrong type).
    #[error("{0}")]
    Parse(String),
    /// A value is out of range.
    #[error("{field} = {value}: {allowed}")]
    Invalid {
        /// The parameter's key.
        field: &'static str,
        /// The value given.
        value: String,
        /// What is allowed.
        allowed: String,
    },
    /// No controller of that kind.
    #[error("unknown controller kind `{0}` (expected one of: {names})", names = kind_names())]
    UnknownKind(String),
}

impl ParamError {
    /// An out-of-range `field`.
    pub fn invalid(field: &'static str, value: impl std::fmt::Display, allowed: &str) -> Self {
        ParamError::Invalid {
            field,
            value: value.to_string(),
            allowed: allowed.to_owned(),
        }
    }

    /// The parameter at fault, when one is.
    pub fn field(&self) -> Option<&'static str> {
        match self {
            ParamError::Invalid { field, .. } => Some(field),
            _ => None,
        }
    }
}

/// The kinds' names, comma-separated.
pub fn kind_names() -> String {
    KINDS.iter().map(|k| k.name).collect::<Vec<_>>().join(", ")
}

/// Deserializes a controller's parameters (use `#[serde(deny_unknown_fields)]` on `T`).
pub fn parse<T: serde::de::DeserializeOwned>(params: &toml::Table) -> Result<T, ParamError> {
    toml::Value::Table(params.clone())
        .try_into()
        .map_err(|e: toml::de::Error| ParamError::Parse(e.to_string().trim_end().to_owned()))
}

fn no_params(params: &toml::Table) -> Result<(), ParamError> {
    match params.keys().next() {
        None => Ok(()),
        Some(key) => Err(ParamError::Parse(format!(
            "unknown parameter `{key}` (this kind takes none)"
        ))),
    }
}

/// Builds the controller `kind` with `params`.
pub fn build(kind: &str, params: &toml::Table) -> Result<Box<dyn Controller>, ParamError> {
    let k = KINDS
        .iter()
        .find(|k| k.name == kind)
        .ok_or_else(|| ParamError::UnknownKind(kind.to_owned()))?;
    (k.build)(params)
}

/// One controller per channel, run in channel order.
#[derive(Debug)]
pub struct ControllerSet {
    controllers: [Box<dyn Controller>; 3],
}

impl ControllerSet {
    /// From `[control]`; the error names the channel.
    pub fn new(config: &ControlConfig) -> Result<ControllerSet, (Channel, ParamError)> {
        let one = |ch: Channel| {
            let c = config.channel(ch);
            build(&c.kind, &c.params).map_err(|e| (ch, e))
        };
        Ok(ControllerSet {
            controllers: [
                one(Channel::Throttle)?,
                one(Channel::Steering)?,
                one(Channel::Tail)?,
            ],
        })
    }

    /// Runs throttle, steering and tail in order, each seeing the (limited) outputs before it.
    /// Every output is limited to `-1..=1`, a non-finite one is neutral, and the throttle never
    /// goes below neutral: AUTO is forward-only whatever a controller returns.
    pub fn update(&mut self, input: ControlInput<'_>) -> Actuation {
        let mut out = Actuation::default();
        for (c, channel) in self.controllers.iter_mut().zip(Channel::ALL) {
            let u = c.update(&ControlInput {
                earlier: out,
                ..input
            });
            let u = if u.is_finite() {
                u.clamp(-1.0, 1.0)
            } else {
                0.0
            };
            match channel {
                Channel::Throttle => out.throttle = u.max(0.0),
                Channel::Steering => out.steering = u,
                Channel::Tail => out.tail = u,
            }
        }
        out
    }

    /// Resets every controller.
    pub fn reset(&mut self) {
        for c in &mut self.controllers {
            c.reset();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_has_a_unique_name_and_unknown_ones_are_listed() {
        for (i, k) in KINDS.iter().enumerate() {
            assert!(KINDS[..i].iter().all(|o| o.name != k.name), "{}", k.name);
        }
        let e = build("lqr", &toml::Table::new()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown controller kind `lqr` (expected one of: none, speed_pid, heading_pid, yaw_rate)"
        );
    }

    /// A controller that returns whatever it is told to.
    #[derive(Debug)]
    struct Returns(f32);

    impl Controller for Returns {
        fn update(&mut self, _: &ControlInput<'_>) -> f32 {
            self.0
        }

        fn reset(&mut self) {}
    }

    #[test]
    fn outputs_are_limited_and_the_throttle_never_reverses() {
        let mut set = ControllerSet {
            controllers: [
                Box::new(Returns(-0.7)),
                Box::new(Returns(f32::NAN)),
                Box::new(Returns(3.0)),
            ],
        };
        let estimate = crate::estimate::StateEstimate::default();
        let out = set.update(ControlInput {
            estimate: &estimate,
            setpoints: &crate::safety::Setpoints::default(),
            mode: crate::safety::Mode::Auto,
            dt_s: 0.004,
            earlier: Actuation::default(),
        });
        assert_eq!(
            out,
            Actuation {
                throttle: 0.0,
                steering: 0.0,
                tail: 1.0
            }
        );
    }

    #[test]
    fn none_takes_no_parameters() {
        assert!(build("none", &toml::Table::new()).is_ok());
        let p: toml::Table = toml::from_str("kp = 1.0").unwrap();
        assert!(build("none", &p).is_err());
    }
}
