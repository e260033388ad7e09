//! Maestro models as marker types.
//!
//! The Micro Maestro lacks the PWM output, Set Multiple Targets and Get Moving State; those
//! driver methods exist only for models that implement the sealed [`MiniModel`] trait, so calling
//! them on a Micro Maestro is a compile error rather than a silently ignored command.

mod sealed {
    pub trait Sealed {}
}

/// A Maestro model. Sealed: only the four models below implement it.
pub trait Model: sealed::Sealed {
    /// The number of channels (valid channel numbers are `0..CHANNELS`).
    const CHANNELS: u8;
    /// The product name, for messages.
    const NAME: &'static str;
}

/// Models with the Mini Maestro command set (Set PWM, Set Multiple Targets, Get Moving State).
pub trait MiniModel: Model {}

macro_rules! model {
    ($(#[$doc:meta])* $name:ident, $channels:expr, $label:expr, mini = $mini:tt) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub struct $name;
        impl sealed::Sealed for $name {}
        impl Model for $name {
            const CHANNELS: u8 = $channels;
            const NAME: &'static str = $label;
        }
        model!(@mini $name, $mini);
    };
    (@mini $name:ident, true) => { impl MiniModel for $name {} };
    (@mini $name:ident, false) => {};
}

model!(
    /// Micro Maestro 6: 6 channels, no PWM output, no Set Multiple Targets, no Get Moving State.
    Micro6, 6, "Micro Maestro 6", mini = false
);
model!(
    /// Mini Maestro 12.
    Mini12, 12, "Mini Maestro 12", mini = true
);
model!(
    /// Mini Maestro 18.
    Mini18, 18, "Mini Maestro 18", mini = true
);
model!(
    /// Mini Maestro 24.
    Mini24, 24, "Mini Maestro 24", mini = true
);
