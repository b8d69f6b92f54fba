//! Input-layer throughput: numeric CSV parsing (target ≥ 150 MB/s) and binary f64.
//!
//! The file is generated here (6 columns like an IMU log, 17 significant digits as a
//! round-trip float printer writes them, plus a short-number variant like a logger's
//! fixed-point output), so no data file is needed.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use imunoise::io::{BinaryType, parse_binary, parse_text};
use std::hint::black_box;

/// A deterministic pseudo-random value in (-1, 1) (xorshift; the content only has to look
/// like sensor data).
fn values(n: usize) -> impl Iterator<Item = f64> {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    (0..n).map(move |_| {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    })
}

fn csv(rows: usize, long: bool) -> Vec<u8> {
    let mut s = String::from("gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z\n");
    let mut it = values(rows * 6);
    for _ in 0..rows {
        for c in 0..6 {
            let v = it.next().expect("enough values");
            if long {
                s.push_str(&format!("{v:e}"));
            } else {
                s.push_str(&format!("{:.5}", v * 10.0));
            }
            s.push(if c == 5 { '\n' } else { ',' });
        }
    }
    s.into_bytes()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("parse");
    g.sample_size(10);
    for (label, long) in [("csv_17digits", true), ("csv_5decimals", false)] {
        let data = csv(500_000, long);
        g.throughput(Throughput::Bytes(data.len() as u64));
        g.bench_function(label, |b| {
            b.iter(|| parse_text(black_box(&data), "bench.csv", None).expect("valid"))
        });
    }
    let bin: Vec<u8> = values(3_000_000).flat_map(f64::to_le_bytes).collect();
    g.throughput(Throughput::Bytes(bin.len() as u64));
    g.bench_function("binary_f64", |b| {
        b.iter(|| parse_binary(black_box(&bin), "bench.f64", BinaryType::F64, 6).expect("valid"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
