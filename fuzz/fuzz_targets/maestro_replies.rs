//! The Pololu Maestro driver's reply reading (`get_position`, `get_errors`,
//! `get_script_status`, `get_moving_state`) against a serial line whose received bytes come
//! from the input, and the device-side `CommandDecoder` on the same bytes.
//!
//! Input: bursts of received bytes, each a length byte and up to that many bytes; between two
//! bursts the port is empty for one poll. The queries asked are drawn from the input.
//!
//! Beyond "no panic" (every wait is bounded by a poll budget, so a hang is a timeout):
//! - up to 64 bytes waiting before a query are discarded (counted in `stale_bytes`) and the
//!   query goes out, exactly the command's bytes; a 65th byte fails it with `UnexpectedData`
//!   and nothing is written;
//! - a reply is taken only from bytes that arrived after the query was written: `Ok` carries
//!   the value of exactly the reply's bytes, `Timeout` means fewer arrived, `InvalidReply`
//!   names the byte at fault;
//! - every command the device-side decoder delivers, encoded again (compact and Pololu
//!   framing, with and without CRC-7), decodes to that same command alone.
#![no_main]

use dima_fuzz::Rng;
use embedded_hal_nb::serial::{ErrorKind, ErrorType, Read, Write};
use libfuzzer_sys::fuzz_target;
use pololu_maestro::{
    encode, reply, Channel, Command, CommandDecoder, DecoderConfig, DeviceError, DeviceNumber,
    Error, Framing, Maestro, Mini12, NbSerial, PollBudget, QuarterMicros,
};

/// A serial line: received bytes in bursts, written bytes recorded.
#[derive(Debug, Default)]
struct Line {
    bursts: Vec<Vec<u8>>,
    burst: usize,
    at: usize,
    written: Vec<u8>,
    /// Bytes read since the last write.
    read_since_write: Vec<u8>,
}

impl Line {
    fn from_input(data: &[u8]) -> Line {
        let mut bursts = Vec::new();
        let mut rest = data;
        while let Some((&len, tail)) = rest.split_first() {
            let (burst, tail) = tail.split_at(usize::from(len).min(tail.len()));
            bursts.push(burst.to_vec());
            rest = tail;
        }
        Line {
            bursts,
            ..Line::default()
        }
    }

    /// Bytes waiting in the current burst.
    fn waiting(&self) -> usize {
        self.bursts.get(self.burst).map_or(0, |b| b.len() - self.at)
    }
}

impl ErrorType for Line {
    type Error = ErrorKind;
}

impl Read<u8> for Line {
    fn read(&mut self) -> nb::Result<u8, ErrorKind> {
        match self.bursts.get(self.burst) {
            Some(burst) if self.at < burst.len() => {
                let byte = burst[self.at];
                self.at += 1;
                self.read_since_write.push(byte);
                Ok(byte)
            }
            Some(_) => {
                self.burst += 1;
                self.at = 0;
                Err(nb::Error::WouldBlock)
            }
            None => Err(nb::Error::WouldBlock),
        }
    }
}

impl Write<u8> for Line {
    fn write(&mut self, byte: u8) -> nb::Result<(), ErrorKind> {
        self.written.push(byte);
        self.read_since_write.clear();
        Ok(())
    }

    fn flush(&mut self) -> nb::Result<(), ErrorKind> {
        Ok(())
    }
}

type Driver = Maestro<NbSerial<Line>, Mini12>;

/// The reply bytes a query's value must come from: the first `n` read after the write.
fn reply_bytes<const N: usize>(line: &Line) -> Option<[u8; N]> {
    line.read_since_write.get(..N)?.try_into().ok()
}

/// Asks one query drawn from `rng` and checks what was discarded, written and returned.
fn query(maestro: &mut Driver, rng: &mut Rng) {
    let line = maestro.interface().inner();
    let waiting = line.waiting();
    let written_before = line.written.len();
    let stale_before = maestro.stale_bytes();
    let mut budget = PollBudget(3);
    let (command, result, reply_len): (Command, Result<(), Error<ErrorKind>>, usize) =
        match rng.next_u64() % 4 {
            0 => {
                let channel = Channel::new::<Mini12>((rng.next_u64() % 12) as u8).unwrap();
                let r = maestro.get_position(channel, &mut budget);
                let line = maestro.interface().inner();
                if let Ok(position) = r {
                    let bytes = reply_bytes::<2>(line).expect("a value without its reply");
                    assert_eq!(position.get(), reply::decode_position(bytes));
                }
                if let Err(Error::Device(DeviceError::InvalidReply(b))) = r {
                    let bytes = reply_bytes::<2>(line).expect("an invalid reply not read");
                    assert_eq!(b, bytes[1]);
                    assert!(QuarterMicros::new(reply::decode_position(bytes)).is_err());
                }
                (Command::GetPosition { channel }, r.map(drop), 2)
            }
            1 => {
                let r = maestro.get_errors(&mut budget);
                if let Ok(errors) = r {
                    let bytes = reply_bytes::<2>(maestro.interface().inner())
                        .expect("a value without its reply");
                    assert_eq!(errors, reply::decode_errors(bytes));
                }
                (Command::GetErrors, r.map(drop), 2)
            }
            2 => {
                let r = maestro.get_script_status(&mut budget);
                let bytes = reply_bytes::<1>(maestro.interface().inner());
                match r {
                    Ok(status) => assert_eq!(
                        Ok(status),
                        reply::decode_script_status(bytes.expect("a value without its reply")[0])
                    ),
                    Err(Error::Device(DeviceError::InvalidReply(b))) => {
                        assert_eq!(Some([b]), bytes);
                        assert!(b > 1);
                    }
                    _ => {}
                }
                (Command::GetScriptStatus, r.map(drop), 1)
            }
            _ => {
                let r = maestro.get_moving_state(&mut budget);
                let bytes = reply_bytes::<1>(maestro.interface().inner());
                match r {
                    Ok(moving) => assert_eq!(
                        Ok(moving),
                        reply::decode_moving_state(bytes.expect("a value without its reply")[0])
                    ),
                    Err(Error::Device(DeviceError::InvalidReply(b))) => {
                        assert_eq!(Some([b]), bytes);
                        assert!(b > 1);
                    }
                    _ => {}
                }
                (Command::GetMovingState, r.map(drop), 1)
            }
        };
    let stale = maestro.stale_bytes() - stale_before;
    let line = maestro.interface().inner();
    let written = &line.written[written_before..];
    if waiting > 64 {
        assert_eq!(result, Err(Error::Device(DeviceError::UnexpectedData)));
        assert_eq!(stale, 65);
        assert!(
            written.is_empty(),
            "a query went out behind unexpected data"
        );
        return;
    }
    assert_eq!(stale as usize, waiting, "stale bytes not discarded");
    assert_eq!(written, encode(&command, Framing::COMPACT).as_bytes());
    match result {
        Ok(()) => assert!(line.read_since_write.len() >= reply_len),
        Err(Error::Device(DeviceError::Timeout)) => {
            assert!(
                line.read_since_write.len() < reply_len,
                "a complete reply timed out"
            )
        }
        Err(Error::Device(DeviceError::InvalidReply(_))) => {}
        Err(e) => panic!("{e:?} with {waiting} bytes waiting"),
    }
}

fn check_driver(data: &[u8]) {
    let mut maestro = Maestro::new_serial(Line::from_input(data), Mini12, Framing::COMPACT);
    let mut rng = Rng::from_bytes(data, 3);
    for _ in 0..8 {
        query(&mut maestro, &mut rng);
    }
}

fn check_device_decoder(data: &[u8], config: DecoderConfig) {
    let mut decoder = CommandDecoder::new(config);
    let commands: Vec<Command> = decoder.decode(data).collect();
    assert_eq!(decoder.stats().commands as usize, commands.len());
    let _ = decoder.take_errors();
    for command in &commands {
        for framing in [
            Framing::COMPACT,
            Framing::COMPACT.with_crc(true),
            Framing::pololu(config.device),
            Framing::pololu(config.device).with_crc(true),
        ] {
            let bytes = encode(command, framing);
            let mut fresh = CommandDecoder::new(DecoderConfig {
                crc: framing.crc && !matches!(command, Command::MiniSsc { .. }),
                ..config
            });
            let again: Vec<Command> = fresh.decode(bytes.as_bytes()).collect();
            assert_eq!(
                again,
                [command.clone()],
                "{framing:?}: {:?}",
                bytes.as_bytes()
            );
        }
    }
}

fuzz_target!(|data: &[u8]| {
    check_driver(data);
    let device = DeviceNumber::new(data.first().map_or(12, |b| b & 0x7F)).unwrap();
    check_device_decoder(data, DecoderConfig { device, crc: false });
    check_device_decoder(data, DecoderConfig { device, crc: true });
});
