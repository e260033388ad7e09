//! The MCAP reader of `dima log` (`dima_log::LoggedRun::from_bytes`) on any bytes
//! as a log file, followed by what `dima log info` and `dima log export` do with the result.
//!
//! Any bytes give a clear error or a result: no panic, no abort on allocation (libFuzzer's
//! `-malloc_limit_mb` catches a large allocation sized by a damaged length field), no hang
//! (`-timeout`).
#![no_main]

use dima_tools::logtools::export::{self, Channel, Format};
use dima_tools::logtools::info;
use dima_log::LoggedRun;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let run = match LoggedRun::from_bytes(data) {
        Ok(run) => run,
        Err(e) => {
            assert!(!format!("{e:#}").is_empty());
            return;
        }
    };
    let _ = info::report(&run);
    for channel in [Channel::Cycle, Channel::Gnss, Channel::State] {
        let rows = export::rows(&run, channel, 0.0, f64::INFINITY);
        for format in [Format::Csv, Format::Jsonl] {
            export::write(&rows, format, &mut std::io::sink()).expect("export to a sink");
        }
    }
});
