//! Ground-link codecs: command and display frames, encoded and found in a byte stream.
//!
//! ```text
//! cargo bench -p dima-groundlink -- --warm-up-time 1 --measurement-time 3
//! ```

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use dima_groundlink::{Command, CommandDecoder, DisplayDecoder, DisplayFrame, Percent};

const FRAMES: usize = 1_000;

fn commands(c: &mut Criterion) {
    let cmds: Vec<Command> = (0..FRAMES)
        .map(|i| Command::Throttle(Percent::new((i % 101) as u8).unwrap()))
        .collect();
    let stream: Vec<u8> = cmds.iter().flat_map(|c| c.encode()).collect();
    let mut group = c.benchmark_group("command_frames");
    group.throughput(Throughput::Bytes(stream.len() as u64));
    group.bench_function("encode", |b| {
        b.iter(|| {
            black_box(&cmds)
                .iter()
                .map(|c| c.encode()[9])
                .fold(0u8, u8::wrapping_add)
        });
    });
    group.bench_function("decode_stream", |b| {
        b.iter(|| CommandDecoder::new().feed(black_box(&stream)).count());
    });
    group.finish();
}

fn displays(c: &mut Criterion) {
    let stream: Vec<u8> = (0..FRAMES)
        .flat_map(|i| {
            DisplayFrame {
                g_speed_mm_s: i as i32,
                ..DisplayFrame::default()
            }
            .encode()
        })
        .collect();
    let mut group = c.benchmark_group("display_frames");
    group.throughput(Throughput::Bytes(stream.len() as u64));
    group.throughput(Throughput::Bytes(68));
    group.bench_function("encode", |b| {
        let frame = DisplayFrame::default();
        b.iter(|| black_box(&frame).encode());
    });
    group.throughput(Throughput::Bytes(stream.len() as u64));
    group.bench_function("decode_stream", |b| {
        b.iter(|| DisplayDecoder::new().feed(black_box(&stream)).count());
    });
    group.finish();
}

criterion_group!(benches, commands, displays);
criterion_main!(benches);
