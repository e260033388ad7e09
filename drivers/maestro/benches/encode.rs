//! Set Target frames for three channels (what a control loop writes every cycle), and the
//! decoder reading them back.
//!
//! ```text
//! cargo bench -p pololu-maestro -- --warm-up-time 1 --measurement-time 2
//! ```

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use pololu_maestro::{
    encode_set_targets, Channel, CommandDecoder, DecoderConfig, Framing, Mini24, QuarterMicros,
};

fn targets(i: u16) -> [(Channel, QuarterMicros); 3] {
    let ch = |n| Channel::new::<Mini24>(n).expect("a Mini 24 channel");
    let q = |us: u16| QuarterMicros::new(us * 4).expect("in range");
    [
        (ch(0), q(1_000 + i % 1_000)),
        (ch(1), q(1_250 + i % 590)),
        (ch(2), q(1_500)),
    ]
}

fn encode(c: &mut Criterion) {
    let mut group = c.benchmark_group("maestro_set_targets");
    group.throughput(Throughput::Elements(1));
    for (name, framing) in [
        ("compact", Framing::COMPACT),
        ("compact_crc7", Framing::COMPACT.with_crc(true)),
    ] {
        group.bench_function(name, |b| {
            let mut i = 0u16;
            b.iter(|| {
                i = i.wrapping_add(1);
                encode_set_targets(framing, black_box(&targets(i))).map(|f| f.as_bytes().len())
            });
        });
    }
    let stream: Vec<u8> = (0..1_000u16)
        .flat_map(|i| {
            encode_set_targets(Framing::COMPACT, &targets(i))
                .expect("three targets")
                .as_bytes()
                .to_vec()
        })
        .collect();
    group.throughput(Throughput::Bytes(stream.len() as u64));
    group.bench_function("decode_stream", |b| {
        b.iter(|| {
            let mut d = CommandDecoder::new(DecoderConfig::default());
            black_box(&stream)
                .iter()
                .filter(|&&byte| d.push(byte).is_some())
                .count()
        });
    });
    group.finish();
}

criterion_group!(benches, encode);
criterion_main!(benches);
