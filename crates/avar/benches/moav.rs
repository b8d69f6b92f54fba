//! MOAV throughput: all book dyadic scales for T = 10^6 and 10^7 samples (10^8 with
//! IMUNOISE_BENCH_LARGE=1), against one streaming pass summing the array (the memory-bandwidth
//! baseline), plus "all m" on 10^5 samples. Without CI (the estimator alone) and with the default
//! chi-square CI.

use std::hint::black_box;

use avar::{AvarConfig, CiMethod, Scales, allan_variance};
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

/// One vectorisable streaming pass (16 independent lanes, so it runs at memory bandwidth
/// rather than at the latency of one add chain).
fn one_pass(x: &[f64]) -> f64 {
    let mut acc = [0.0f64; 16];
    let mut it = x.chunks_exact(16);
    for c in &mut it {
        for l in 0..16 {
            acc[l] += c[l];
        }
    }
    acc.iter().sum::<f64>() + it.remainder().iter().sum::<f64>()
}

fn bench(c: &mut Criterion) {
    let mut sizes = vec![1_000_000usize, 10_000_000];
    if std::env::var("IMUNOISE_BENCH_LARGE").as_deref() == Ok("1") {
        sizes.push(100_000_000);
    }
    let no_ci = AvarConfig {
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let chi2 = AvarConfig::default();
    for n in sizes {
        let x = data(n);
        let mut g = c.benchmark_group(format!("moav_dyadic_T{n:e}"));
        g.throughput(Throughput::Elements(n as u64));
        g.sample_size(10);
        g.bench_function("one_pass_sum_baseline", |b| {
            b.iter(|| black_box(one_pass(black_box(&x))))
        });
        g.bench_function("all_dyadic_no_ci", |b| {
            b.iter(|| black_box(allan_variance(&x, 100.0, &no_ci).unwrap()))
        });
        g.bench_function("all_dyadic_chi2_ci", |b| {
            b.iter(|| black_box(allan_variance(&x, 100.0, &chi2).unwrap()))
        });
        g.finish();
    }
    let x = data(100_000);
    let all = AvarConfig {
        scales: Scales::All,
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let mut g = c.benchmark_group("moav_all_m_T1e5");
    g.sample_size(10);
    g.bench_function("all_m_no_ci", |b| {
        b.iter(|| black_box(allan_variance(&x, 100.0, &all).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
