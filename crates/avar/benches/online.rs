//! Online MOAV throughput: `Online::update` on 10^7 samples of one channel, all dyadic scales
//! up to m = 2^20, fed in chunks of 4096 samples (about 4 s of a 1 kHz IMU), with a snapshot
//! (AV and chi-square CI) at the end. Target: >= 10^7 samples/s on one core.

use std::hint::black_box;

use avar::{AvarConfig, Online};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn data(n: usize) -> Vec<f64> {
    // cheap deterministic pseudo-random rate samples around an offset (like an accelerometer axis)
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            -9.81 + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.01
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let n = 10_000_000;
    let x = data(n);
    let cfg = AvarConfig::default();
    let mut g = c.benchmark_group("online_T1e7");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(10);
    for chunk in [4096usize, 64] {
        g.bench_function(format!("update_dyadic_to_2^20_chunk{chunk}"), |b| {
            b.iter(|| {
                let mut on = Online::new(1000.0, 1 << 20, &cfg).unwrap();
                for ch in x.chunks(chunk) {
                    on.update(black_box(ch)).unwrap();
                }
                black_box(on.len())
            })
        });
    }
    let mut on = Online::new(1000.0, 1 << 20, &cfg).unwrap();
    on.update(&x).unwrap();
    g.throughput(Throughput::Elements(1));
    g.bench_function("snapshot_with_chi2_ci", |b| {
        b.iter(|| black_box(on.snapshot().unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
