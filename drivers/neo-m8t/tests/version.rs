//! PROTVER parsing from MON-VER extension strings.

use neo_m8t::ProtocolVersion;

fn v(major: u8, minor: u8) -> Option<ProtocolVersion> {
    Some(ProtocolVersion { major, minor })
}

#[test]
fn protver_forms_seen_on_m8_firmware() {
    // `ublox` crate test data: ROM CORE 3.01 reports "PROTVER=18.00", ADR 4.11 "PROTVER=19.10".
    assert_eq!(ProtocolVersion::parse_extension("PROTVER=18.00"), v(18, 0));
    assert_eq!(ProtocolVersion::parse_extension("PROTVER=19.10"), v(19, 10));
    // Older firmware separates with a space.
    assert_eq!(ProtocolVersion::parse_extension("PROTVER 15.00"), v(15, 0));
    assert_eq!(ProtocolVersion::parse_extension("PROTVER=22"), v(22, 0));
}

#[test]
fn other_extensions_and_junk_are_not_versions() {
    for ext in [
        "FWVER=TIM 1.10",
        "PROTVER=",
        "PROTVER=x.y",
        "PROTVER=300.00",
        "GPS;GLO",
    ] {
        assert_eq!(ProtocolVersion::parse_extension(ext), None, "{ext}");
    }
}

#[test]
fn display_and_order() {
    assert_eq!(v(18, 0).unwrap().to_string(), "18.00");
    assert!(v(19, 10) > v(18, 0));
}
