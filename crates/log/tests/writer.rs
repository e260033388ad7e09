//! The writer on a run across files: a tap sees every channel and message it writes, a split
//! loses and repeats nothing, and any file of the run reads back the whole run in order.

use std::sync::{Arc, Mutex};
use std::time::Instant;

use dima_log::naming::numbered_name;
use dima_log::schema::{self, METADATA_DIMA};
use dima_log::writer::{McapLog, RunWriter, Tap, METADATA_LOG_CONTINUED};

/// What a tap was told.
#[derive(Default)]
struct Seen {
    /// (id, topic, schema name, schema encoding, schema length, message encoding).
    channels: Vec<(u16, String, String, String, usize, String)>,
    /// (channel id, log time, data).
    messages: Vec<(u16, u64, Vec<u8>)>,
}

/// A tap that collects everything into shared storage.
struct Collect(Arc<Mutex<Seen>>);

impl Tap for Collect {
    fn channel(
        &mut self,
        id: u16,
        topic: &str,
        schema_name: &str,
        schema_encoding: &str,
        schema: &[u8],
        message_encoding: &str,
    ) {
        self.0.lock().unwrap().channels.push((
            id,
            topic.into(),
            schema_name.into(),
            schema_encoding.into(),
            schema.len(),
            message_encoding.into(),
        ));
    }

    fn message(&mut self, channel_id: u16, log_time_ns: u64, data: &[u8]) {
        self.0
            .lock()
            .unwrap()
            .messages
            .push((channel_id, log_time_ns, data.to_vec()));
    }
}

fn test_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("dima-log-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A `/dima/state`-shaped JSON message for record `i` (any bytes do for the writer).
fn payload(i: u64) -> Vec<u8> {
    format!("{{\"cycle\":{i}}}").into_bytes()
}

#[test]
fn a_tap_sees_every_channel_and_message_of_a_split_run() {
    let dir = test_dir("tap");
    let first = dir.join("run.mcap");
    let mut log = McapLog::create_file(&first).unwrap();
    log.set_time_offset(1_000);
    let header = vec![(
        METADATA_DIMA.to_owned(),
        vec![("version", "test".to_owned())],
    )];
    log.metadata(METADATA_DIMA, &header[0].1).unwrap();
    let seen = Arc::new(Mutex::new(Seen::default()));
    let mut run = RunWriter::new(Some(log), header, None);
    run.set_tap(Box::new(Collect(Arc::clone(&seen))));
    for i in 0..30 {
        if i == 10 || i == 20 {
            run.split_now(Instant::now());
        }
        run.write_record(|l| l.message_on(&schema::STATE, i, &payload(i)));
    }
    let last = run.finish().unwrap().finish().unwrap();
    assert_eq!(last, numbered_name(&first, 2));

    let seen = seen.lock().unwrap();
    // Each of the three files declares the robot's four channels, in order.
    assert_eq!(seen.channels.len(), 3 * schema::CHANNELS.len());
    for (k, c) in seen.channels.iter().enumerate() {
        let spec = schema::CHANNELS[k % schema::CHANNELS.len()];
        assert_eq!((c.1.as_str(), c.5.as_str()), (spec.topic, spec.encoding));
        assert_eq!(c.2, spec.schema_name);
        let has_schema = !spec.schema_name.is_empty();
        assert_eq!(c.3 == "jsonschema", has_schema, "{c:?}");
        assert_eq!(c.4 > 0, has_schema, "{c:?}");
    }
    let state_id = seen
        .channels
        .iter()
        .find(|c| c.1 == schema::STATE.topic)
        .unwrap()
        .0;
    let expected: Vec<_> = (0..30).map(|i| (state_id, i + 1_000, payload(i))).collect();
    assert_eq!(
        seen.messages, expected,
        "messages as written, with log times"
    );

    // What the tap saw is what the files hold: any file of the run reads all of it.
    for given in [&first, &numbered_name(&first, 1), &last] {
        let read = dima_log::run::read_run(given).unwrap();
        assert_eq!(read.files.len(), 3, "given {}", given.display());
        assert_eq!(read.files[0], first);
        let continued = read
            .metadata
            .iter()
            .filter(|m| m.name == METADATA_LOG_CONTINUED)
            .count();
        assert_eq!(continued, 2);
        assert_eq!(read.version.as_deref(), Some("test"));
    }
    let mut times = Vec::new();
    for file in dima_log::naming::run_files(&last).unwrap() {
        let bytes = std::fs::read(&file).unwrap();
        let messages = dima_log::reader::messages(&bytes).unwrap();
        assert_eq!(messages.len(), 10, "{}", file.display());
        times.extend(messages.iter().map(|m| m.log_time));
    }
    assert_eq!(times, (1_000..1_030).collect::<Vec<_>>());
    std::fs::remove_dir_all(&dir).unwrap();
}
