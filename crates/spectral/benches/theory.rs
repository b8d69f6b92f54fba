//! Speed of the theoretical AV: the closed form of a 6-component model at 30 dyadic scales
//! (what the GMWM evaluates per objective call), with and without gradients, and the cost
//! of the Lemma 4.1 quadrature and of the Lemma 4.2 sum per (process, m).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use processes::{
    Ar1, Drift, GaussMarkov, Ma1, Model, Process, QuantizationNoise, RandomWalk, WhiteNoise,
};
use spectral::{
    lemma42_allan_variance, model_allan_variance, model_allan_variance_with_gradient,
    quadrature_allan_variance,
};
use std::hint::black_box;

const RATE: f64 = 100.0;

fn six_component_model() -> Model {
    (QuantizationNoise::new(1e-7).unwrap()
        + WhiteNoise::new(1e-4).unwrap()
        + RandomWalk::new(1e-10).unwrap()
        + Drift::new(1e-8).unwrap()
        + Ar1::new(0.9995, 1e-8).unwrap()
        + GaussMarkov::new(0.01, 1e-6).unwrap())
    .unwrap()
}

fn closed_form(c: &mut Criterion) {
    let model = six_component_model();
    let ms: Vec<u64> = (1..=30).map(|j| 1u64 << j).collect();
    c.bench_function("closed_form/6-component model, 30 dyadic scales", |b| {
        b.iter(|| {
            let mut s = 0.0;
            for &m in &ms {
                s += model_allan_variance(black_box(&model), m, RATE).unwrap();
            }
            s
        })
    });
    c.bench_function(
        "closed_form/6-component model, 30 scales, AV + gradient",
        |b| {
            b.iter(|| {
                let mut s = 0.0;
                for &m in &ms {
                    let (v, g) =
                        model_allan_variance_with_gradient(black_box(&model), m, RATE).unwrap();
                    s += v + g[0];
                }
                s
            })
        },
    );
}

fn processes_to_time() -> Vec<(&'static str, Process)> {
    vec![
        ("WN", WhiteNoise::new(1e-4).unwrap().into()),
        ("QN", QuantizationNoise::new(1e-7).unwrap().into()),
        ("RW", RandomWalk::new(1e-10).unwrap().into()),
        ("AR1", Ar1::new(0.9995, 1e-8).unwrap().into()),
        ("GM", GaussMarkov::new(0.01, 1e-6).unwrap().into()),
        ("MA1", Ma1::new(0.4, 1e-4).unwrap().into()),
    ]
}

fn quadrature(c: &mut Criterion) {
    let mut g = c.benchmark_group("quadrature");
    for (name, p) in processes_to_time() {
        for j in [0u32, 4, 10, 20, 30] {
            let m = 1u64 << j;
            g.bench_with_input(BenchmarkId::new(name, format!("m=2^{j}")), &m, |b, &m| {
                b.iter(|| quadrature_allan_variance(black_box(&p), m, RATE).unwrap())
            });
        }
    }
    g.finish();
}

fn lemma42(c: &mut Criterion) {
    let mut g = c.benchmark_group("lemma42");
    for (name, p) in processes_to_time()
        .into_iter()
        .filter(|(n, _)| *n == "AR1" || *n == "WN")
    {
        for j in [4u32, 10, 16] {
            let m = 1u64 << j;
            g.bench_with_input(BenchmarkId::new(name, format!("m=2^{j}")), &m, |b, &m| {
                b.iter(|| lemma42_allan_variance(black_box(&p), m, RATE).unwrap())
            });
        }
    }
    g.finish();
}

criterion_group!(benches, closed_form, quadrature, lemma42);
criterion_main!(benches);
