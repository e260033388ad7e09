//! Typed values of the common settings: baud rate, API mode, power level, role.

/// UART baud rate (`BD`). Digi's codes 0 to 0x0A select standard rates; larger values are the
/// rate itself in bit/s (XBee 3 accepts 0x12C to 0x0EC400, not every rate is exact).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BaudRate {
    /// Code 0.
    Bps1200,
    /// Code 1.
    Bps2400,
    /// Code 2.
    Bps4800,
    /// Code 3, the factory default and what DIMA uses.
    Bps9600,
    /// Code 4.
    Bps19200,
    /// Code 5.
    Bps38400,
    /// Code 6.
    Bps57600,
    /// Code 7.
    Bps115200,
    /// Code 8.
    Bps230400,
    /// Code 9 (XBee 3, newer S2C firmware).
    Bps460800,
    /// Code 0x0A (XBee 3, newer S2C firmware).
    Bps921600,
    /// A non-standard rate in bit/s (must be above 0x0A).
    Custom(u32),
}

const STANDARD_RATES: [u32; 11] = [
    1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600,
];

impl BaudRate {
    /// The `BD` parameter value.
    pub const fn code(self) -> u32 {
        match self {
            Self::Bps1200 => 0,
            Self::Bps2400 => 1,
            Self::Bps4800 => 2,
            Self::Bps9600 => 3,
            Self::Bps19200 => 4,
            Self::Bps38400 => 5,
            Self::Bps57600 => 6,
            Self::Bps115200 => 7,
            Self::Bps230400 => 8,
            Self::Bps460800 => 9,
            Self::Bps921600 => 0x0A,
            Self::Custom(bps) => bps,
        }
    }

    /// Reads a `BD` value as the module reports it.
    pub const fn from_code(code: u32) -> Self {
        match code {
            0 => Self::Bps1200,
            1 => Self::Bps2400,
            2 => Self::Bps4800,
            3 => Self::Bps9600,
            4 => Self::Bps19200,
            5 => Self::Bps38400,
            6 => Self::Bps57600,
            7 => Self::Bps115200,
            8 => Self::Bps230400,
            9 => Self::Bps460800,
            0x0A => Self::Bps921600,
            other => Self::Custom(other),
        }
    }

    /// The standard rate for `bps`, or [`BaudRate::Custom`].
    pub fn from_bps(bps: u32) -> Self {
        match STANDARD_RATES.iter().position(|&r| r == bps) {
            Some(code) => Self::from_code(code as u32),
            None => Self::Custom(bps),
        }
    }

    /// The rate in bit/s (for configuring the host's serial port to match).
    pub fn bps(self) -> u32 {
        match self {
            Self::Custom(bps) => bps,
            standard => STANDARD_RATES
                .get(standard.code() as usize)
                .copied()
                .unwrap_or_default(),
        }
    }
}

/// Operating mode of the serial interface (`AP`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ApiMode {
    /// 0: transparent byte pipe plus `+++` command mode (what DIMA uses).
    Transparent,
    /// 1: API frames without escaping.
    Api,
    /// 2: API frames with escaping.
    ApiEscaped,
    /// 4: MicroPython REPL (XBee 3).
    MicroPython,
}

impl ApiMode {
    /// The `AP` parameter value.
    pub const fn code(self) -> u8 {
        match self {
            Self::Transparent => 0,
            Self::Api => 1,
            Self::ApiEscaped => 2,
            Self::MicroPython => 4,
        }
    }
    /// Reads an `AP` value; `None` for values this crate does not know.
    pub const fn from_code(code: u64) -> Option<Self> {
        match code {
            0 => Some(Self::Transparent),
            1 => Some(Self::Api),
            2 => Some(Self::ApiEscaped),
            4 => Some(Self::MicroPython),
            _ => None,
        }
    }
    /// The frame escaping of an API mode (`None` for the non-API modes).
    pub const fn escaping(self) -> Option<crate::ApiEscaping> {
        match self {
            Self::Api => Some(crate::ApiEscaping::Unescaped),
            Self::ApiEscaped => Some(crate::ApiEscaping::Escaped),
            _ => None,
        }
    }
}

/// Transmit power level (`PL`). The dBm values depend on the module (XBee 3: -5 to +8 dBm;
/// PRO variants more).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PowerLevel {
    /// 0.
    Lowest,
    /// 1.
    Low,
    /// 2.
    Medium,
    /// 3.
    High,
    /// 4, the factory default.
    Highest,
}

impl PowerLevel {
    /// The `PL` parameter value.
    pub const fn code(self) -> u8 {
        self as u8
    }
    /// Reads a `PL` value.
    pub const fn from_code(code: u64) -> Option<Self> {
        match code {
            0 => Some(Self::Lowest),
            1 => Some(Self::Low),
            2 => Some(Self::Medium),
            3 => Some(Self::High),
            4 => Some(Self::Highest),
            _ => None,
        }
    }
}

/// Network role (`CE`, coordinator enable). A DIMA pair is one coordinator (ground station)
/// and one router (robot).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Role {
    /// `CE = 1`: forms the network.
    Coordinator,
    /// `CE = 0` (with `SM = 0`, the default): joins the network and routes.
    Router,
}

/// Longest node identifier (`NI`), in characters.
pub const MAX_NODE_IDENTIFIER_LEN: usize = 20;

/// Lowest 2.4 GHz channel (`CH`), 0x0B.
pub const MIN_CHANNEL: u8 = 0x0B;
/// Highest 2.4 GHz channel (`CH`), 0x1A.
pub const MAX_CHANNEL: u8 = 0x1A;
