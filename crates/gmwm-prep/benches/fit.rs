//! Speed of one GMWM fit (acceptance: a 6-component model on 20 scales in ≤ 20 ms) and of
//! the model covariance of the AV (target: 20 scales up to m = 2^18 at n = 10^6 in ≤ 50 ms).

use criterion::{Criterion, criterion_group, criterion_main};
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::{AvCurve, theory::model_avar};
use processes::Model;
use std::hint::black_box;

fn bench_fit(c: &mut Criterion) {
    let truth: Model = "QN(q2=1e-6) + WN(sigma2=1e-4) + RW(gamma2=1e-12) + DR(omega=1e-9) \
                        + AR1(phi=0.99, sigma2=1e-8) + AR1(phi=0.9995, sigma2=1e-10)"
        .parse()
        .unwrap();
    let m: Vec<u64> = (1..=20).map(|j| 1u64 << j).collect();
    // the exact curve with a deterministic ±5 % ripple, so the minimum is not at zero
    let av: Vec<f64> = model_avar(&truth, &m, 100.0)
        .unwrap()
        .iter()
        .enumerate()
        .map(|(j, v)| v * (1.0 + 0.05 * (j as f64 * 1.7).sin()))
        .collect();
    let curve = AvCurve::from_m(&m, &av, 100.0).unwrap().with_n(1 << 22);
    let template = truth.template();
    let opts = GmwmOptions::default();
    let f = fit(&curve, &template, &opts).unwrap();
    eprintln!("fit: {} — {:?}", f.model, f.convergence);
    c.bench_function("gmwm fit QN+WN+RW+DR+2*AR1 on 20 scales", |b| {
        b.iter(|| fit(black_box(&curve), black_box(&template), black_box(&opts)).unwrap())
    });
    // the iterated model-based full weighting (not the default: each step adds one
    // model_covariance of the 20 scales)
    let full = GmwmOptions {
        weighting: gmwm_prep::gmwm::Weighting::ModelFull,
        ..GmwmOptions::default()
    };
    c.bench_function("gmwm fit QN+WN+RW+DR+2*AR1 on 20 scales, ModelFull", |b| {
        b.iter(|| fit(black_box(&curve), black_box(&template), black_box(&full)).unwrap())
    });
}

fn bench_model_covariance(c: &mut Criterion) {
    let truth: Model = "QN(q2=1e-6) + WN(sigma2=1e-4) + RW(gamma2=1e-12) + DR(omega=1e-9) \
                        + AR1(phi=0.99, sigma2=1e-8) + AR1(phi=0.9995, sigma2=1e-10)"
        .parse()
        .unwrap();
    // 20 scales, log-spaced from 1 to 2^18
    let m: Vec<u64> = (0..20)
        .map(|j| (2f64.powf(18.0 * j as f64 / 19.0)).round() as u64)
        .collect();
    c.bench_function(
        "model_covariance 6 components, 20 scales to 2^18, n = 10^6",
        |b| {
            b.iter(|| {
                gmwm_prep::inference::model_covariance(black_box(&truth), &m, 100.0, 1_000_000)
                    .unwrap()
            })
        },
    );
}

criterion_group!(benches, bench_fit, bench_model_covariance);
criterion_main!(benches);
