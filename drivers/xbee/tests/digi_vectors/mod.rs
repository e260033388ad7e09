//! Golden API frames from Digi's `digi-xbee` library (copied verbatim from the project's
//! test-vector list), in API 1 and API 2 form: shared by the blocking and the async tests.
#![allow(dead_code)] // each test crate uses its own part

use xbee_driver::{Address16, Address64, AtCommand, CommandStatus, Frame};
use xbee_driver::{AtCommandFrame, AtResponse, ReceivePacket, TransmitRequest};

// digi-xbee: AT `NI` query, frame id 1 (API 1 and API 2 identical).
pub const AT_NI_QUERY: &[u8] = &[0x7E, 0x00, 0x04, 0x08, 0x01, 0x4E, 0x49, 0x5F];
// digi-xbee: AT `ID` = 0x7FFF, frame id 0x52 (API 1 and API 2 identical).
pub const AT_ID_SET: &[u8] = &[0x7E, 0x00, 0x06, 0x08, 0x52, 0x49, 0x44, 0x7F, 0xFF, 0x9A];
// digi-xbee: AT response `NI` OK "ROBOT", frame id 1 (API 1 and API 2 identical).
pub const AT_NI_RESPONSE: &[u8] = &[
    0x7E, 0x00, 0x0A, 0x88, 0x01, 0x4E, 0x49, 0x00, 0x52, 0x4F, 0x42, 0x4F, 0x54, 0x59,
];
// digi-xbee: transmit request 0x10, id 1, to 0013A20040A1B2C3 / FFFE, radius 0, options 0, "Hi".
pub const TX_API1: &[u8] = &[
    0x7E, 0x00, 0x10, 0x10, 0x01, 0x00, 0x13, 0xA2, 0x00, 0x40, 0xA1, 0xB2, 0xC3, 0xFF, 0xFE, 0x00,
    0x00, 0x48, 0x69, 0x35,
];
pub const TX_API2: &[u8] = &[
    0x7E, 0x00, 0x10, 0x10, 0x01, 0x00, 0x7D, 0x33, 0xA2, 0x00, 0x40, 0xA1, 0xB2, 0xC3, 0xFF, 0xFE,
    0x00, 0x00, 0x48, 0x69, 0x35,
];
// digi-xbee: receive packet 0x90 from 0013A20040522BAA / 7D84, options 0x01, "RxData".
pub const RX_API1: &[u8] = &[
    0x7E, 0x00, 0x12, 0x90, 0x00, 0x13, 0xA2, 0x00, 0x40, 0x52, 0x2B, 0xAA, 0x7D, 0x84, 0x01, 0x52,
    0x78, 0x44, 0x61, 0x74, 0x61, 0x0D,
];
pub const RX_API2: &[u8] = &[
    0x7E, 0x00, 0x12, 0x90, 0x00, 0x7D, 0x33, 0xA2, 0x00, 0x40, 0x52, 0x2B, 0xAA, 0x7D, 0x5D, 0x84,
    0x01, 0x52, 0x78, 0x44, 0x61, 0x74, 0x61, 0x0D,
];

/// Each vector as a typed frame, its API 1 bytes and its API 2 bytes.
pub fn frames() -> Vec<(Frame<'static>, &'static [u8], &'static [u8])> {
    vec![
        (
            Frame::AtCommand(AtCommandFrame {
                frame_id: 1,
                command: AtCommand::NI,
                parameter: &[],
            }),
            AT_NI_QUERY,
            AT_NI_QUERY,
        ),
        (
            Frame::AtCommand(AtCommandFrame {
                frame_id: 0x52,
                command: AtCommand::ID,
                parameter: &[0x7F, 0xFF],
            }),
            AT_ID_SET,
            AT_ID_SET,
        ),
        (
            Frame::AtResponse(AtResponse {
                frame_id: 1,
                command: AtCommand::NI,
                status: CommandStatus::Ok,
                data: b"ROBOT",
            }),
            AT_NI_RESPONSE,
            AT_NI_RESPONSE,
        ),
        (
            Frame::TransmitRequest(TransmitRequest {
                frame_id: 1,
                destination: Address64(0x0013_A200_40A1_B2C3),
                destination_16: Address16::UNKNOWN,
                broadcast_radius: 0,
                options: 0,
                data: b"Hi",
            }),
            TX_API1,
            TX_API2,
        ),
        (
            Frame::ReceivePacket(ReceivePacket {
                source: Address64(0x0013_A200_4052_2BAA),
                source_16: Address16(0x7D84),
                options: 0x01,
                data: b"RxData",
            }),
            RX_API1,
            RX_API2,
        ),
    ]
}
