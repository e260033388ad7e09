//! Blocking command mode with a `DelayNs`: enter, run commands, leave.
//!
//! The same state machine as [`XBee::poll`], polled every 250 µs on a clock counted from
//! the delays. The session leaves command mode when dropped (best effort), so an early `?`
//! return does not strand the module in command mode.

use embedded_hal::delay::DelayNs;
use embedded_hal_nb::serial::{Read, Write};

use super::CommandOutcome;
use super::Transparent;
use crate::at::{AtCommand, AtRequest, Parameter};
use crate::setting_types::{ApiMode, BaudRate, PowerLevel, Role};
use crate::settings;
use crate::types::{Address64, DeviceError, Error};
use crate::xbee::XBee;

/// Poll period of the blocking API, in µs: under one byte time at 9600 baud (1.04 ms), so a
/// one-byte receive register does not overrun while a reply comes in.
pub const POLL_STEP_US: u32 = 250;

impl<S, E> XBee<S, Transparent>
where
    S: Read<u8, Error = E> + Write<u8, Error = E>,
{
    /// Enters command mode, blocking for about two guard times (2 s by default).
    ///
    /// Calls on the returned session must follow each other without long pauses: time is
    /// counted from the delays only, and a command is refused with
    /// [`DeviceError::NotInCommandMode`] once half of `CT` minus the reply timeout (4.5 s by default)
    /// has passed on that clock since the last accepted command, rather than risk it arriving
    /// after the module has left. Leave with [`CommandSession::exit`]; dropping the session
    /// leaves too, ignoring errors.
    ///
    /// If entering fails, the module may still have switched: data stays refused until
    /// [`wait_until_transparent`](Self::wait_until_transparent) returns.
    pub fn command_mode<'a, D: DelayNs>(
        &'a mut self,
        delay: &'a mut D,
    ) -> Result<CommandSession<'a, S, D>, Error<E>> {
        self.start_command_mode()?;
        match self.run(delay)? {
            CommandOutcome::Entered => Ok(CommandSession {
                xbee: self,
                delay,
                open: true,
            }),
            _ => Err(Error::Device(DeviceError::InvalidReply)),
        }
    }

    /// Blocks until data may flow again: finishes the command-mode operation in progress and,
    /// if the module may still be in command mode (after a failed entry or a failed `ATCN`),
    /// waits until `CT` has surely run out. At most `CT` plus the reply timeout (11 s by
    /// default) after the last command-mode input.
    pub fn wait_until_transparent<D: DelayNs>(&mut self, delay: &mut D) -> Result<(), Error<E>> {
        while !self.is_transparent() {
            let now_ms = (self.mode.clock_us / 1000) as u32;
            match self.poll_delay_clock(now_ms) {
                Ok(_) | Err(nb::Error::WouldBlock) => {}
                Err(nb::Error::Other(e)) => return Err(e),
            }
            if !self.is_transparent() {
                self.sleep_step(delay);
            }
        }
        Ok(())
    }

    fn sleep_step<D: DelayNs>(&mut self, delay: &mut D) {
        delay.delay_us(POLL_STEP_US);
        self.mode.clock_us = self.mode.clock_us.wrapping_add(u64::from(POLL_STEP_US));
    }

    /// Polls until the operation in progress ends, on the blocking API's own clock.
    pub(crate) fn run<D: DelayNs>(&mut self, delay: &mut D) -> Result<CommandOutcome, Error<E>> {
        loop {
            let now_ms = (self.mode.clock_us / 1000) as u32;
            match self.poll_delay_clock(now_ms) {
                Ok(outcome) => return Ok(outcome),
                Err(nb::Error::Other(e)) => return Err(e),
                Err(nb::Error::WouldBlock) => self.sleep_step(delay),
            }
        }
    }
}

/// An open command-mode session (blocking). Obtained from [`XBee::command_mode`].
pub struct CommandSession<'a, S, D>
where
    S: Read<u8> + Write<u8>,
    D: DelayNs,
{
    xbee: &'a mut XBee<S, Transparent>,
    delay: &'a mut D,
    open: bool,
}

impl<S, D, E> CommandSession<'_, S, D>
where
    S: Read<u8, Error = E> + Write<u8, Error = E>,
    D: DelayNs,
{
    /// Sends any AT command and returns the reply line (without `\r`).
    pub fn send(&mut self, request: &AtRequest<'_>) -> Result<&[u8], Error<E>> {
        self.xbee.start_command(request)?;
        match self.xbee.run(self.delay)? {
            CommandOutcome::Reply => Ok(self.xbee.reply()),
            _ => Err(Error::Device(DeviceError::InvalidReply)),
        }
    }

    /// Sends a command that must be answered `OK`.
    pub fn set(&mut self, request: &AtRequest<'_>) -> Result<(), Error<E>> {
        if crate::at::is_ok(self.send(request)?) {
            Ok(())
        } else {
            Err(Error::Device(DeviceError::InvalidReply))
        }
    }

    /// Queries a numeric setting.
    pub fn query_number(&mut self, command: AtCommand) -> Result<u64, Error<E>> {
        let reply = self.send(&AtRequest::query(command))?;
        settings::parse_number(reply).ok_or(Error::Device(DeviceError::InvalidReply))
    }

    fn query_with<T>(
        &mut self,
        command: AtCommand,
        parse: fn(&[u8]) -> Option<T>,
    ) -> Result<T, Error<E>> {
        let reply = self.send(&AtRequest::query(command))?;
        parse(reply).ok_or(Error::Device(DeviceError::InvalidReply))
    }

    /// PAN id (`ID`).
    pub fn pan_id(&mut self) -> Result<u64, Error<E>> {
        self.query_number(AtCommand::ID)
    }
    /// Sets the PAN id (`ID`); both modules of a pair need the same.
    pub fn set_pan_id(&mut self, id: u64) -> Result<(), Error<E>> {
        self.set(&settings::set_pan_id(id))
    }

    /// Operating channel (`CH`).
    pub fn channel(&mut self) -> Result<u8, Error<E>> {
        self.query_with(AtCommand::CH, settings::parse_channel)
    }
    /// Sets the operating channel (`CH`, 0x0B to 0x1A; not on Zigbee firmware).
    pub fn set_channel(&mut self, channel: u8) -> Result<(), Error<E>> {
        let request =
            settings::set_channel(channel).ok_or(Error::Device(DeviceError::InvalidInput))?;
        self.set(&request)
    }

    /// Node identifier (`NI`), copied into `out`; returns its length.
    pub fn node_identifier(&mut self, out: &mut [u8]) -> Result<usize, Error<E>> {
        let reply = self.send(&AtRequest::query(AtCommand::NI))?;
        let slot = out
            .get_mut(..reply.len())
            .ok_or(Error::Device(DeviceError::InvalidInput))?;
        slot.copy_from_slice(reply);
        Ok(reply.len())
    }
    /// Sets the node identifier (`NI`, up to 20 printable characters).
    pub fn set_node_identifier(&mut self, name: &str) -> Result<(), Error<E>> {
        let request =
            settings::set_node_identifier(name).ok_or(Error::Device(DeviceError::InvalidInput))?;
        self.set(&request)
    }

    /// UART baud rate (`BD`).
    pub fn baud_rate(&mut self) -> Result<BaudRate, Error<E>> {
        self.query_with(AtCommand::BD, settings::parse_baud_rate)
    }
    /// Sets the UART baud rate (`BD`). The module switches when command mode ends or after
    /// [`apply_changes`](Self::apply_changes): reopen the host port at [`BaudRate::bps`] then.
    pub fn set_baud_rate(&mut self, rate: BaudRate) -> Result<(), Error<E>> {
        self.set(&settings::set_baud_rate(rate))
    }

    /// Serial operating mode (`AP`).
    pub fn api_mode(&mut self) -> Result<ApiMode, Error<E>> {
        self.query_with(AtCommand::AP, settings::parse_api_mode)
    }
    /// Sets the serial operating mode (`AP`). After leaving, a module set to an API mode speaks
    /// frames: use [`XBee<S, Api>`](crate::Api) then.
    pub fn set_api_mode(&mut self, mode: ApiMode) -> Result<(), Error<E>> {
        self.set(&settings::set_api_mode(mode))
    }

    /// Transmit power level (`PL`).
    pub fn power_level(&mut self) -> Result<PowerLevel, Error<E>> {
        self.query_with(AtCommand::PL, settings::parse_power_level)
    }
    /// Sets the transmit power level (`PL`).
    pub fn set_power_level(&mut self, level: PowerLevel) -> Result<(), Error<E>> {
        self.set(&settings::set_power_level(level))
    }

    /// Whether encryption is on (`EE`).
    pub fn encryption(&mut self) -> Result<bool, Error<E>> {
        self.query_with(AtCommand::EE, settings::parse_encryption)
    }
    /// Turns encryption on or off (`EE`).
    pub fn set_encryption(&mut self, enabled: bool) -> Result<(), Error<E>> {
        self.set(&settings::set_encryption(enabled))
    }
    /// Writes the 128-bit AES key (`KY`). Write-only: there is no getter, the module never
    /// reveals it. The line buffer is zeroed after sending.
    pub fn set_encryption_key(&mut self, key: &[u8; 16]) -> Result<(), Error<E>> {
        self.set(&settings::set_encryption_key(key))
    }

    /// Network role (`CE`).
    pub fn role(&mut self) -> Result<Role, Error<E>> {
        self.query_with(AtCommand::CE, settings::parse_role)
    }
    /// Sets the network role (`CE`).
    pub fn set_role(&mut self, role: Role) -> Result<(), Error<E>> {
        self.set(&settings::set_role(role))
    }

    /// Firmware version (`VR`), as the module prints it in hexadecimal (e.g. 0x100D).
    pub fn firmware_version(&mut self) -> Result<u32, Error<E>> {
        let v = self.query_number(AtCommand::VR)?;
        u32::try_from(v).map_err(|_| Error::Device(DeviceError::InvalidReply))
    }
    /// Hardware version (`HV`).
    pub fn hardware_version(&mut self) -> Result<u32, Error<E>> {
        let v = self.query_number(AtCommand::HV)?;
        u32::try_from(v).map_err(|_| Error::Device(DeviceError::InvalidReply))
    }
    /// The module's 64-bit address (`SH`, `SL`).
    pub fn serial_number(&mut self) -> Result<Address64, Error<E>> {
        let high = self.query_number(AtCommand::SH)?;
        let low = self.query_number(AtCommand::SL)?;
        if high > u64::from(u32::MAX) || low > u64::from(u32::MAX) {
            return Err(Error::Device(DeviceError::InvalidReply));
        }
        Ok(Address64((high << 32) | low))
    }

    /// Saves the settings to non-volatile memory (`WR`), so they survive a power cycle.
    pub fn write_settings(&mut self) -> Result<(), Error<E>> {
        self.set(&AtRequest::query(AtCommand::WR))
    }
    /// Applies queued changes now (`AC`).
    pub fn apply_changes(&mut self) -> Result<(), Error<E>> {
        self.set(&AtRequest::query(AtCommand::AC))
    }

    /// Sends a command with a raw parameter and expects `OK` (for settings without a helper).
    pub fn set_raw(
        &mut self,
        command: AtCommand,
        parameter: Parameter<'_>,
    ) -> Result<(), Error<E>> {
        self.set(&AtRequest::set(command, parameter))
    }

    /// Leaves command mode (`ATCN`); data passes again afterwards. If `CT` is too close for
    /// `ATCN`, it waits until the module has surely left instead. On an error the module may
    /// still be in command mode: data stays refused until
    /// [`XBee::wait_until_transparent`] returns.
    pub fn exit(mut self) -> Result<(), Error<E>> {
        self.open = false;
        self.leave()
    }

    fn leave(&mut self) -> Result<(), Error<E>> {
        self.xbee.start_exit()?;
        match self.xbee.run(self.delay)? {
            CommandOutcome::Exited => Ok(()),
            _ => Err(Error::Device(DeviceError::InvalidReply)),
        }
    }
}

impl<S, D> Drop for CommandSession<'_, S, D>
where
    S: Read<u8> + Write<u8>,
    D: DelayNs,
{
    fn drop(&mut self) {
        if self.open {
            self.open = false;
            // Best effort: on failure the driver keeps refusing data until `CT` has run out.
            let _ = self.leave_on_drop();
        }
    }
}

impl<S, D> CommandSession<'_, S, D>
where
    S: Read<u8> + Write<u8>,
    D: DelayNs,
{
    fn leave_on_drop(&mut self) -> Result<(), ()> {
        if self.xbee.start_exit().is_err() {
            return Err(());
        }
        self.xbee.run(self.delay).map(|_| ()).map_err(|_| ())
    }
}
