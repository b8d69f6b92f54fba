//! The stability family (issue 14): each statistic at octave τ without CI, next to OADEV on the
//! same data, for T = 10^6 (10^7 and 10^8 with IMUNOISE_BENCH_LARGE=1), and MDEV with Stable32's
//! chi-square intervals. The target (OHDEV and MDEV within 2× OADEV at 10^8) is reported by
//! `cargo xtask avar-speed --family`, which alternates the runs.

use std::hint::black_box;

use avar::stability::{Statistic, stability};
use avar::{AvarConfig, CiMethod, Scales};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn data(n: usize) -> Vec<f64> {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            1e-3 + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-6
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut sizes = vec![1_000_000usize];
    if std::env::var("IMUNOISE_BENCH_LARGE").as_deref() == Ok("1") {
        sizes.extend([10_000_000, 100_000_000]);
    }
    let octave = AvarConfig {
        scales: Scales::Octave,
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let stable32 = AvarConfig {
        scales: Scales::Octave,
        alpha: 0.317,
        ..AvarConfig::default()
    };
    for n in sizes {
        let x = data(n);
        let mut g = c.benchmark_group(format!("stability_octave_T{n:e}"));
        g.throughput(Throughput::Elements(n as u64));
        g.sample_size(10);
        for st in Statistic::ALL {
            g.bench_function(st.name(), |b| {
                b.iter(|| black_box(stability(&x, 1.0, st, &octave).unwrap()))
            });
        }
        g.bench_function("mdev_chi2_stable32", |b| {
            b.iter(|| black_box(stability(&x, 1.0, Statistic::Mdev, &stable32).unwrap()))
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
