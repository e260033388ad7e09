//! `dima inspect sensor|command|display`: `dima_tools::logtools::inspect::inspect` on any bytes as a
//! capture of each link.
//!
//! Beyond "no panic": one output line per frame counted, each line one JSON object, and the
//! counts match the link's own decoder run on the same bytes.
#![no_main]

use dima_tools::logtools::inspect::{inspect, InspectStats, Link};
use dima_groundlink::{CommandDecoder, DisplayDecoder};
use dima_sensorboard::StreamDecoder;
use libfuzzer_sys::fuzz_target;

fn decoder_counts(link: Link, data: &[u8]) -> InspectStats {
    match link {
        Link::Sensor => {
            let mut d = StreamDecoder::new();
            d.frames(data).for_each(drop);
            let s = d.stats();
            InspectStats {
                frames: s.packets + s.info_frames,
                errors: s.crc_errors,
                skipped_bytes: s.bytes_skipped,
            }
        }
        Link::Command => {
            let mut d = CommandDecoder::new();
            d.feed(data).for_each(drop);
            let s = d.stats();
            InspectStats {
                frames: u64::from(s.frames),
                errors: u64::from(s.rejected()),
                skipped_bytes: u64::from(s.skipped_bytes),
            }
        }
        Link::Display => {
            let mut d = DisplayDecoder::new();
            d.feed(data).for_each(drop);
            let s = d.stats();
            InspectStats {
                frames: u64::from(s.frames),
                errors: u64::from(s.out_of_range),
                skipped_bytes: u64::from(s.skipped_bytes),
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    for link in [Link::Sensor, Link::Command, Link::Display] {
        let mut out = Vec::new();
        let stats = inspect(link, data, &mut out).expect("writing to memory");
        let text = String::from_utf8(out).expect("JSON lines are UTF-8");
        let mut lines = 0u64;
        for line in text.lines() {
            let value: serde_json::Value = serde_json::from_str(line).expect("a JSON line");
            assert!(value.is_object(), "{line}");
            lines += 1;
        }
        assert_eq!(lines, stats.frames, "{link:?}");
        assert_eq!(stats, decoder_counts(link, data), "{link:?}");
    }
});
