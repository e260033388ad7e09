//! The driver, written once: `maybe_async_cfg` generates the blocking [`Maestro`] from this
//! async source by dropping `async` and `.await`, and keeps the async `MaestroAsync` with the
//! `async` feature. Both check and encode the same way and write the same bytes; only waiting
//! for a reply differs (polling against a [`Deadline`], or racing an `AsyncDeadline`).

use crate::codec::{encode, Framing, Packet, TargetFrame};
use crate::command::Command;
use crate::error::Error;
#[cfg(feature = "async")]
use crate::interface::AsyncWriteInterface;
use crate::interface::{self as transport, Deadline, NbSerial, ReadInterface, WriteInterface};
#[cfg(feature = "async")]
use crate::io_async::{self as async_transport, AsyncDeadline, AsyncReadInterface};
use crate::limits::Limits;
use crate::model::{MiniModel, Model};
use crate::reply;
use crate::status::ErrorFlags;
use crate::targets::TargetEncoder;
use crate::types::{
    Acceleration, Channel, MiniSscServo, MiniSscValue, PwmTiming, QuarterMicros, ScriptParameter,
    ScriptStatus, Speed, Subroutine,
};

/// Stale bytes discarded at most before a query (a late reply to an earlier, timed-out query).
const MAX_STALE_BYTES: usize = 64;

crate::blocking_and_async! {
    /// A Pololu Maestro of model `M` on transport `I`; `MaestroAsync` (feature `async`) is the
    /// same driver on an async transport with the same methods, the I/O ones `async`.
    ///
    /// Every command is encoded completely before one [`WriteInterface::write_all`] call. Targets
    /// are checked by a [`TargetEncoder`] (the model's channel count and the configured
    /// [`Limits`]) before anything is sent.
    #[derive(Debug)]
    pub struct Maestro<I, M> {
        iface: I,
        encoder: TargetEncoder<M>,
        stale_bytes: u32,
    }
}

impl<S, M: Model> Maestro<NbSerial<S>, M>
where
    S: embedded_hal_nb::serial::Write<u8>,
{
    /// A driver on an embedded-hal-nb serial port (e.g. linux-embedded-hal's `Serial` on
    /// `/dev/ttyACM0`), without limits.
    pub fn new_serial(serial: S, model: M, framing: Framing) -> Self {
        Self::new(NbSerial::new(serial), model, framing)
    }

    /// Gives the serial port back (what [`Maestro::new_serial`] was given).
    pub fn release(self) -> S {
        self.iface.release()
    }
}

#[cfg(feature = "embedded-io")]
impl<T, M: Model> Maestro<crate::interface::IoSerial<T>, M>
where
    T: embedded_io::Write,
{
    /// A driver on an embedded-io 0.7 port, without limits.
    pub fn new_io(io: T, model: M, framing: Framing) -> Self {
        Self::new(crate::interface::IoSerial::new(io), model, framing)
    }

    /// Gives the port back (what [`Maestro::new_io`] was given).
    pub fn release(self) -> T {
        self.iface.release()
    }
}

crate::blocking_and_async! {
    impl<I: WriteInterface, M: Model> Maestro<I, M> {
        /// A driver on any transport, without limits.
        pub fn new(iface: I, model: M, framing: Framing) -> Self {
            Self {
                iface,
                encoder: TargetEncoder::new(model, framing),
                stale_bytes: 0,
            }
        }

        /// The same driver with per-channel `limits` (builder style).
        pub fn with_limits(mut self, limits: Limits) -> Self {
            self.encoder.set_limits(limits);
            self
        }

        /// Replace the per-channel limits.
        pub fn set_limits(&mut self, limits: Limits) {
            self.encoder.set_limits(limits);
        }

        /// The per-channel limits.
        pub fn limits(&self) -> &Limits {
            self.encoder.limits()
        }

        /// The framing in use.
        pub fn framing(&self) -> Framing {
            self.encoder.framing()
        }

        /// The checked target encoder the driver uses; a copy of it lets an application encode
        /// targets without owning the driver.
        pub fn encoder(&self) -> &TargetEncoder<M> {
            &self.encoder
        }

        /// Bytes discarded before queries because they arrived unasked (late replies, noise).
        pub fn stale_bytes(&self) -> u32 {
            self.stale_bytes
        }

        /// Wait until the transport has sent everything written so far (bounded like writes).
        /// Not needed between commands; useful before closing the port or cutting power.
        pub async fn flush(&mut self) -> Result<(), Error<I::Error>> {
            self.iface.flush().await
        }

        /// The transport.
        pub fn interface(&mut self) -> &mut I {
            &mut self.iface
        }

        /// Gives the transport back (what [`Maestro::new`] was given; a driver made with
        /// `new_serial` or `new_io` gives the port back with `release`).
        pub fn into_interface(self) -> I {
            self.iface
        }

        fn check_channel(&self, channel: Channel) -> Result<(), Error<I::Error>> {
            Ok(self.encoder.check_channel(channel)?)
        }

        async fn send(&mut self, command: &Command) -> Result<(), Error<I::Error>> {
            let packet = encode(command, self.encoder.framing());
            self.iface.write_all(&packet).await
        }

        /// Encode Set Target packets for `targets` without sending them, after checking every
        /// channel and limit: for an application that writes the bytes itself, with its own
        /// deadline. One buffer, no allocation.
        pub fn encode_targets(
            &self,
            targets: &[(Channel, QuarterMicros)],
        ) -> Result<TargetFrame, Error<I::Error>> {
            Ok(self.encoder.encode_targets(targets)?)
        }

        /// Set the target of `channel` (pulse width in quarter-microseconds).
        ///
        /// Errors with [`TargetError::OutOfRange`](crate::TargetError::OutOfRange) if the channel has limits and `target` is outside
        /// them (including [`QuarterMicros::OFF`]: use [`stop_pulses`](Self::stop_pulses)).
        pub async fn set_target(
            &mut self,
            channel: Channel,
            target: QuarterMicros,
        ) -> Result<(), Error<I::Error>> {
            let packet = self.encoder.encode_target(channel, target)?;
            self.iface.write_all(&packet).await
        }

        /// Set the targets of several channels with one write: one Set Target packet per channel,
        /// concatenated. Nothing is sent unless every target passes its checks.
        pub async fn set_targets(
            &mut self,
            targets: &[(Channel, QuarterMicros)],
        ) -> Result<(), Error<I::Error>> {
            let frame = self.encode_targets(targets)?;
            self.iface.write_all(&frame).await
        }

        /// Set `channel` to its configured neutral target; [`TargetError::InvalidInput`](crate::TargetError::InvalidInput) if it has no
        /// limits (and so no neutral).
        pub async fn set_neutral(&mut self, channel: Channel) -> Result<(), Error<I::Error>> {
            let neutral = self
                .limits()
                .neutral(channel)
                .ok_or(Error::Target(crate::TargetError::InvalidInput))?;
            self.set_target(channel, neutral).await
        }

        /// Stop sending pulses on `channel` (target 0), regardless of limits. Most ESCs treat a
        /// missing pulse as failsafe; send the neutral first if the ESC needs to see it.
        pub async fn stop_pulses(&mut self, channel: Channel) -> Result<(), Error<I::Error>> {
            let packet = self.encoder.encode_stop_pulses(channel)?;
            self.iface.write_all(&packet).await
        }

        /// Set the speed limit of `channel`.
        pub async fn set_speed(
            &mut self,
            channel: Channel,
            speed: Speed,
        ) -> Result<(), Error<I::Error>> {
            self.check_channel(channel)?;
            self.send(&Command::SetSpeed { channel, speed }).await
        }

        /// Set the acceleration limit of `channel`.
        pub async fn set_acceleration(
            &mut self,
            channel: Channel,
            acceleration: Acceleration,
        ) -> Result<(), Error<I::Error>> {
            self.check_channel(channel)?;
            self.send(&Command::SetAcceleration {
                channel,
                acceleration,
            }).await
        }

        /// Send every channel to its home position (as configured in the Maestro).
        pub async fn go_home(&mut self) -> Result<(), Error<I::Error>> {
            self.send(&Command::GoHome).await
        }

        /// Stop the user script.
        pub async fn stop_script(&mut self) -> Result<(), Error<I::Error>> {
            self.send(&Command::StopScript).await
        }

        /// Restart the user script at `subroutine`.
        pub async fn restart_script(
            &mut self,
            subroutine: Subroutine,
        ) -> Result<(), Error<I::Error>> {
            self.send(&Command::RestartScript(subroutine)).await
        }

        /// Restart the user script at `subroutine` with `parameter` on its stack.
        pub async fn restart_script_with_parameter(
            &mut self,
            subroutine: Subroutine,
            parameter: ScriptParameter,
        ) -> Result<(), Error<I::Error>> {
            self.send(&Command::RestartScriptWithParameter {
                subroutine,
                parameter,
            }).await
        }

        /// Mini SSC Set Target (0xFF, servo, value). The value maps onto the range configured in
        /// the Maestro itself, so the [`Limits`] here do not apply; the framing (device number,
        /// CRC) does not either.
        pub async fn mini_ssc_set(
            &mut self,
            servo: MiniSscServo,
            value: MiniSscValue,
        ) -> Result<(), Error<I::Error>> {
            self.send(&Command::MiniSsc { servo, value }).await
        }
    }

    impl<I: WriteInterface, M: MiniModel> Maestro<I, M> {
        /// Encode Set Multiple Targets for consecutive channels from `first` without sending it,
        /// after checking every channel and limit (Mini Maestro only): the shortest per-cycle frame
        /// (2 bytes per channel plus 3), for an application that writes it with its own deadline.
        pub fn encode_multiple_targets(
            &self,
            first: Channel,
            targets: &[QuarterMicros],
        ) -> Result<Packet, Error<I::Error>> {
            Ok(self.encoder.encode_multiple_targets(first, targets)?)
        }

        /// Set Multiple Targets (Mini Maestro only): targets for consecutive channels in one
        /// packet and one write, each checked against the model and the limits first.
        pub async fn set_multiple_targets(
            &mut self,
            first: Channel,
            targets: &[QuarterMicros],
        ) -> Result<(), Error<I::Error>> {
            let packet = self.encode_multiple_targets(first, targets)?;
            self.iface.write_all(&packet).await
        }

        /// Set the PWM output (Mini Maestro only).
        pub async fn set_pwm(&mut self, pwm: PwmTiming) -> Result<(), Error<I::Error>> {
            self.send(&Command::SetPwm(pwm)).await
        }
    }

    impl<I: ReadInterface, M: Model> Maestro<I, M> {
        /// Send `command` and read exactly `reply.len()` bytes before `deadline` expires.
        ///
        /// Bytes waiting before the command is sent are discarded first (counted in
        /// [`stale_bytes`](Self::stale_bytes)), so a late answer to an earlier query is never
        /// taken for this one; if more than 64 are waiting, [`DeviceError::UnexpectedData`](crate::DeviceError::UnexpectedData).
        async fn query(
            &mut self,
            command: &Command,
            reply: &mut [u8],
            deadline: &mut impl Deadline,
        ) -> Result<(), Error<I::Error>> {
            self.discard_pending().await?;
            self.send(command).await?;
            transport::read_reply(&mut self.iface, reply, deadline).await
        }

        /// Discards up to [`MAX_STALE_BYTES`]; it takes one read more to see that the port is
        /// empty after the last of them, so only a byte beyond the limit fails the query.
        async fn discard_pending(&mut self) -> Result<(), Error<I::Error>> {
            for _ in 0..=MAX_STALE_BYTES {
                match transport::take_pending(&mut self.iface).await? {
                    Some(_) => self.stale_bytes = self.stale_bytes.saturating_add(1),
                    None => return Ok(()),
                }
            }
            Err(Error::Device(crate::DeviceError::UnexpectedData))
        }

        /// Get Position: the pulse width `channel` outputs now (for an input channel, the measured
        /// value). A reply above 16383 quarter-microseconds is [`DeviceError::InvalidReply`] with
        /// its high byte.
        ///
        /// [`DeviceError::InvalidReply`]: crate::DeviceError::InvalidReply
        pub async fn get_position(
            &mut self,
            channel: Channel,
            deadline: &mut impl Deadline,
        ) -> Result<QuarterMicros, Error<I::Error>> {
            self.check_channel(channel)?;
            let mut reply = [0u8; 2];
            self.query(&Command::GetPosition { channel }, &mut reply, deadline).await?;
            QuarterMicros::new(reply::decode_position(reply))
                .map_err(|_| Error::Device(crate::DeviceError::InvalidReply(reply[1])))
        }

        /// Get Errors: read and clear the Maestro's error register.
        pub async fn get_errors(
            &mut self,
            deadline: &mut impl Deadline,
        ) -> Result<ErrorFlags, Error<I::Error>> {
            let mut reply = [0u8; 2];
            self.query(&Command::GetErrors, &mut reply, deadline).await?;
            Ok(reply::decode_errors(reply))
        }

        /// Get Script Status.
        pub async fn get_script_status(
            &mut self,
            deadline: &mut impl Deadline,
        ) -> Result<ScriptStatus, Error<I::Error>> {
            let mut reply = [0u8; 1];
            self.query(&Command::GetScriptStatus, &mut reply, deadline).await?;
            reply::decode_script_status(reply[0])
                .map_err(|b| Error::Device(crate::DeviceError::InvalidReply(b)))
        }
    }

    impl<I: ReadInterface, M: MiniModel> Maestro<I, M> {
        /// Get Moving State (Mini Maestro only): true while any servo is still moving towards its
        /// target under speed or acceleration limits.
        pub async fn get_moving_state(
            &mut self,
            deadline: &mut impl Deadline,
        ) -> Result<bool, Error<I::Error>> {
            let mut reply = [0u8; 1];
            self.query(&Command::GetMovingState, &mut reply, deadline).await?;
            reply::decode_moving_state(reply[0])
                .map_err(|b| Error::Device(crate::DeviceError::InvalidReply(b)))
        }
    }
}
