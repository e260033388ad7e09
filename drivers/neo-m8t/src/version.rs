//! Receiver identity from MON-VER: software, hardware, firmware and protocol version.

use heapless::String;
use ublox::mon_ver::MonVerRef;

/// UBX protocol version (`PROTVER` extension of MON-VER), e.g. 18.00 for M8T firmware 3.01.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ProtocolVersion {
    /// Major version.
    pub major: u8,
    /// Minor version (two decimal digits: 19.10 has minor 10).
    pub minor: u8,
}

impl ProtocolVersion {
    /// Parses a MON-VER extension such as `PROTVER=18.00` or `PROTVER 15.00`.
    pub fn parse_extension(ext: &str) -> Option<Self> {
        let rest = ext.strip_prefix("PROTVER")?;
        let rest = rest.trim_start_matches(['=', ' ']).trim_end();
        let (major, minor) = rest.split_once('.').unwrap_or((rest, "0"));
        Some(Self {
            major: major.parse().ok()?,
            minor: minor.parse().ok()?,
        })
    }
}

impl core::fmt::Display for ProtocolVersion {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}.{:02}", self.major, self.minor)
    }
}

/// What MON-VER reported.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReceiverVersion {
    /// Software version, e.g. `ROM CORE 3.01 (107888)`.
    pub software: String<30>,
    /// Hardware version, e.g. `00080000`.
    pub hardware: String<10>,
    /// Firmware (`FWVER=` extension), e.g. `TIM 1.10`; empty if absent.
    pub firmware: String<30>,
    /// Protocol version (`PROTVER` extension); `None` if absent or unreadable.
    pub protocol: Option<ProtocolVersion>,
}

impl ReceiverVersion {
    /// Reads the `ublox` crate's MON-VER view.
    pub fn from_mon_ver(ver: &MonVerRef<'_>) -> Self {
        let mut out = Self {
            software: truncated(ver.software_version()),
            hardware: truncated(ver.hardware_version()),
            ..Self::default()
        };
        for ext in ver.extension() {
            if let Some(fw) = ext.strip_prefix("FWVER=") {
                out.firmware = truncated(fw);
            } else if let Some(protocol) = ProtocolVersion::parse_extension(ext) {
                out.protocol = Some(protocol);
            }
        }
        out
    }
}

/// Copies as many whole characters of `s` as fit.
fn truncated<const N: usize>(s: &str) -> String<N> {
    let mut out = String::new();
    for c in s.chars() {
        if out.push(c).is_err() {
            break;
        }
    }
    out
}
