//! Controllers by name: `kind = "..."` in `[control.throttle]`, `[control.steering]` and
//! `[control.tail]` picks one from [`KINDS`]; the rest of the section is its parameters.
//!
//! Every kind has documented default parameters ([`ControllerKind::defaults`]): naming the kind
//! is enough, and each key given in the section overrides its default. The bounds checks see
//! the merged parameters.
//!
//! Adding a controller: a file with a type that implements [`Controller`] and a
//! `from_params(&toml::Table)` constructor, and one line in [`KINDS`].

use super::controller::{Channel, ControlInput, Controller};
use super::heading_pid::HeadingPid;
use super::neutral::Neutral;
use super::speed_pid::SpeedPid;
use super::yaw_rate::{YawRate, YawRateConfig};
use super::Actuation;
use crate::config::{ControlConfig, PidConfig};

/// A controller kind: its name in the configuration and how to build it.
#[derive(Debug, Clone, Copy)]
pub struct ControllerKind {
    /// The `kind` value.
    pub name: &'static str,
    /// One line for `dima config --check` and the documentation.
    pub summary: &'static str,
    /// Its default parameters (the values the documentation recommends); a parameter the
    /// section leaves out takes its value from here. An empty table: every parameter must be
    /// given.
    pub defaults: fn() -> toml::Table,
    /// Builds one from its parameters: the section's other keys over [`Self::defaults`].
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
        defaults: toml::Table::new,
        build: |p| boxed(no_params(p).map(|()| Neutral)),
    },
    ControllerKind {
        name: "speed_pid",
        summary: "PID on the ground-speed error (m/s)",
        defaults: || params_table(&PidConfig::SPEED_PID),
        build: |p| boxed(SpeedPid::from_params(p)),
    },
    ControllerKind {
        name: "heading_pid",
        summary: "PID on the heading error (degrees), damped by the yaw rate",
        defaults: || params_table(&PidConfig::HEADING_PID),
        build: |p| boxed(HeadingPid::from_params(p)),
    },
    ControllerKind {
        name: "yaw_rate",
        summary: "PI on the yaw rate the steering demand asks for",
        defaults: || params_table(&YawRateConfig::RECOMMENDED),
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

/// A parameter struct as a table, each float the shortest decimal of its `f32` (as a file
/// would write it), so the table parses back to the same values. Controller parameters are
/// `f32`.
pub fn params_table<T: serde::Serialize>(params: &T) -> toml::Table {
    let decimal = |v: f64| {
        let single = v as f32;
        single.to_string().parse().unwrap_or(v)
    };
    match toml::Value::try_from(params) {
        Ok(toml::Value::Table(table)) => table
            .into_iter()
            .map(|(k, v)| match v {
                toml::Value::Float(f) => (k, toml::Value::Float(decimal(f))),
                other => (k, other),
            })
            .collect(),
        _ => toml::Table::new(),
    }
}

/// The kind named `kind`.
pub fn kind(kind: &str) -> Result<&'static ControllerKind, ParamError> {
    KINDS
        .iter()
        .find(|k| k.name == kind)
        .ok_or_else(|| ParamError::UnknownKind(kind.to_owned()))
}

/// `params` over the defaults of `kind`: every parameter of the kind, the given ones as given.
pub fn with_defaults(kind: &ControllerKind, params: &toml::Table) -> toml::Table {
    let mut full = (kind.defaults)();
    full.extend(params.iter().map(|(k, v)| (k.clone(), v.clone())));
    full
}

/// Builds the controller `kind` with `params` (over the kind's defaults).
pub fn build(kind_name: &str, params: &toml::Table) -> Result<Box<dyn Controller>, ParamError> {
    let k = kind(kind_name)?;
    (k.build)(&with_defaults(k, params))
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

    fn params(text: &str) -> toml::Table {
        toml::from_str(text).unwrap()
    }

    #[test]
    fn naming_a_kind_is_enough_and_given_values_override_the_defaults() {
        for k in KINDS {
            build(k.name, &toml::Table::new())
                .unwrap_or_else(|e| panic!("{} with its defaults: {e}", k.name));
            let defaults = (k.defaults)();
            for key in defaults.keys() {
                let mut one = defaults.clone();
                one.remove(key);
                assert_eq!(with_defaults(k, &one), defaults, "{}.{key}", k.name);
            }
        }
        let tail = kind("yaw_rate").unwrap();
        let merged = with_defaults(tail, &params("kp = 0.005\nmax_yaw_rate_dps = 300.0"));
        assert_eq!(merged["kp"], toml::Value::Float(0.005));
        assert_eq!(merged["max_yaw_rate_dps"], toml::Value::Float(300.0));
        assert_eq!(merged["min_speed_mm_s"], toml::Value::Float(1500.0));
        assert_eq!(merged["rate_limit_per_s"], toml::Value::Float(50.0));
    }

    #[test]
    fn defaults_do_not_lift_the_bounds_checks_or_hide_unknown_keys() {
        let e = build("yaw_rate", &params("max_yaw_rate_dps = -5.0")).unwrap_err();
        assert_eq!(e.field(), Some("max_yaw_rate_dps"));
        let e = build("speed_pid", &params("output_limit = 1.5")).unwrap_err();
        assert_eq!(e.field(), Some("output_limit"));
        let e = build("heading_pid", &params("kq = 0.1")).unwrap_err();
        assert!(e.to_string().contains("kq"), "{e}");
    }

    #[test]
    fn none_takes_no_parameters() {
        assert!(build("none", &toml::Table::new()).is_ok());
        let p: toml::Table = toml::from_str("kp = 1.0").unwrap();
        assert!(build("none", &p).is_err());
    }
}
