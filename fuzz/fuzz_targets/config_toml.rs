//! The configuration loader: `dima_core::config::Config::from_toml`, the function `dima` runs
//! on a configuration file's text (parse, migrate an old layout, validate), on any text.
//!
//! Beyond "no panic": a configuration that is accepted
//! - is written back by `toml::to_string` (as `dima` does into every log's metadata) to text
//!   that is accepted again as the same configuration, so a log's configuration replays;
//! - builds its controllers, and its derived timings are consistent: the packet's time on the
//!   wire is shorter than its deadline, and deadline plus servo write budget fit in a period.
#![no_main]

use dima_core::config::Config;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(config) = Config::from_toml(text, "fuzz input") else {
        return;
    };
    let written = toml::to_string(&config).expect("an accepted configuration serialises");
    match Config::from_toml(&written, "written back") {
        Ok(again) => assert_eq!(again, config, "{written}"),
        Err(e) => panic!("written back, the configuration is refused: {e}\n{written}"),
    }
    config
        .controllers()
        .expect("an accepted configuration builds its controllers");
    let period_ns = config.period_ns();
    assert!(config.packet_wire_ns() < u64::from(config.sensor.packet_deadline_us) * 1_000);
    assert!(
        u64::from(config.sensor.packet_deadline_us) + u64::from(config.servo_write_budget_us())
            <= period_ns / 1_000
    );
    assert!((1..=config.realtime.loop_rate_hz).contains(&config.servo_write_hz()));
    let _ = config.packet_deadline_after_request_ns();
});
