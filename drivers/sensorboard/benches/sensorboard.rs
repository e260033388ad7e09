//! CRC and decoding cost per 132-byte packet.
//!
//! ```text
//! cargo bench -p dima-sensorboard --features slice16 -- --warm-up-time 1 --measurement-time 3
//! ```

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use dima_sensorboard::nav_pvt;
use dima_sensorboard::{crc32_bitwise, INITIAL};
use dima_sensorboard::{Frame, GnssFrame, NavPvt, SensorPacket, StreamDecoder};

const PACKETS: usize = 100;

fn packet(i: usize) -> [u8; 132] {
    let i = i as i16;
    SensorPacket {
        accel: [i, -i, 1000],
        gyro: [100 * i, 7, -i],
        mag: [i, -i, 3 * i],
        rhall: 6000,
        press_raw: 415_148,
        temp_raw: 519_888,
        gnss: GnssFrame::from_nav_pvt(&NavPvt {
            itow_ms: 1000 * i as u32,
            year: 2026,
            month: 11,
            day: 22,
            hour: 8,
            min: 0,
            sec: 0,
            valid: nav_pvt::VALID_DATE | nav_pvt::VALID_TIME,
            t_acc_ns: 20,
            nano_ns: 0,
            fix_type: 3,
            flags: 1,
            flags2: 0,
            num_sv: 10,
            lon_deg_e7: 85_465_123,
            lat_deg_e7: 473_976_543,
            height_mm: 500_000,
            h_msl_mm: 452_000,
            h_acc_mm: 1200,
            v_acc_mm: 2000,
            vel_n_mm_s: 1000,
            vel_e_mm_s: 0,
            vel_d_mm_s: 0,
            g_speed_mm_s: 1000,
            head_mot_deg_e5: 0,
            s_acc_mm_s: 100,
            head_acc_deg_e5: 500_000,
            p_dop_e2: 120,
            reserved1: [0; 6],
            head_veh_deg_e5: 0,
            mag_dec_deg_e2: 0,
            mag_acc_deg_e2: 0,
        }),
    }
    .encode()
}

fn crc(c: &mut Criterion) {
    let bytes = packet(1);
    let covered = &bytes[..128];
    let mut group = c.benchmark_group("crc_per_packet");
    group.throughput(Throughput::Elements(1));
    group.bench_function("bitwise_model", |b| {
        b.iter(|| crc32_bitwise(black_box(covered)));
    });
    group.bench_function("slice4", |b| {
        b.iter(|| dima_sensorboard::update_slice4(INITIAL, black_box(covered)));
    });
    #[cfg(feature = "slice16")]
    group.bench_function("slice16", |b| {
        b.iter(|| dima_sensorboard::update_slice16(INITIAL, black_box(covered)));
    });
    group.finish();
}

fn decode(c: &mut Criterion) {
    let stream: Vec<u8> = (0..PACKETS).flat_map(packet).collect();
    let mut group = c.benchmark_group("decode_stream");
    // Bytes per second: 100 packets of 132 bytes per iteration.
    group.throughput(Throughput::Bytes(stream.len() as u64));
    // Framing and CRC only: what the realtime loop pays to get validated packets.
    group.bench_function("frames", |b| {
        b.iter(|| {
            let mut decoder = StreamDecoder::new();
            decoder.frames(black_box(&stream)).count()
        });
    });
    // Framing, CRC, field decoding and the NAV-PVT parse.
    group.bench_function("frames_fields_nav_pvt", |b| {
        b.iter(|| {
            let mut decoder = StreamDecoder::new();
            let mut sum = 0i64;
            for frame in decoder.frames(black_box(&stream)) {
                if let Frame::Packet(raw) = frame {
                    let p = raw.decode();
                    sum += i64::from(p.accel[0]);
                    sum += p.nav_pvt().map_or(0, |g| i64::from(g.num_sv));
                }
            }
            sum
        });
    });
    // The same stream pushed one byte at a time, as a byte-wise serial port delivers it.
    group.bench_function("push_byte_by_byte", |b| {
        b.iter(|| {
            let mut decoder = StreamDecoder::new();
            let mut n = 0;
            for &byte in black_box(&stream) {
                n += usize::from(decoder.push(byte).is_some());
            }
            n
        });
    });
    group.finish();
}

criterion_group!(benches, crc, decode);
criterion_main!(benches);
