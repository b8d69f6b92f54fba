//! Offset robustness, thread-count determinism, bad input.

mod common;

use avar::{
    AvarConfig, AvarError, CiMethod, Estimator, InputKind, Scales, allan_variance,
    allan_variance_channels,
};
use common::*;

/// Issue item 2: AV(X + c) = AV(X) to this relative precision for c up to 1e4·std(X).
const TOL_OFFSET: f64 = 1e-9;

fn cfg(scales: Scales) -> AvarConfig {
    AvarConfig {
        scales,
        ci: CiMethod::None,
        ..AvarConfig::default()
    }
}

/// Runs `f` on a rayon pool of `threads` threads.
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

fn offset_check(x: &[f64], label: &str) {
    let sd = {
        let mu = x.iter().sum::<f64>() / x.len() as f64;
        (x.iter().map(|v| (v - mu).powi(2)).sum::<f64>() / x.len() as f64).sqrt()
    };
    let base = allan_variance(x, 100.0, &cfg(Scales::DyadicWithOne)).unwrap();
    let mut worst = 0.0f64;
    for c in [1.0, -9.81 / 0.003, 1e3, 1e4, -1e4] {
        let shifted: Vec<f64> = x.iter().map(|v| v + c * sd).collect();
        let av = allan_variance(&shifted, 100.0, &cfg(Scales::DyadicWithOne)).unwrap();
        for (p, q) in base.points.iter().zip(&av.points) {
            let r = rel(q.avar, p.avar);
            worst = worst.max(r);
            assert!(
                r <= TOL_OFFSET,
                "{label}: c={c}·sd m={} {} vs {} (rel {r:e})",
                p.m,
                q.avar,
                p.avar
            );
        }
    }
    eprintln!("{label}: worst relative change under offsets up to 1e4 sd: {worst:e}");
}

#[test]
fn offset_does_not_change_the_av_white_noise() {
    offset_check(&white_noise(1 << 20, 9e-6, 11), "WN 2^20");
}

#[test]
fn offset_does_not_change_the_av_white_plus_random_walk() {
    let w = white_noise(1 << 18, 1.0, 12);
    let r = random_walk(1 << 18, 1e-6, 13);
    let x: Vec<f64> = w.iter().zip(&r).map(|(a, b)| a + b).collect();
    offset_check(&x, "WN+RW 2^18");
}

#[test]
fn results_are_bit_identical_for_any_thread_count() {
    let x = white_noise(300_001, 1.0, 21);
    let run = |threads: usize, scales: Scales, est: Estimator| {
        let c = AvarConfig {
            estimator: est,
            ..cfg(scales)
        };
        on_threads(threads, || allan_variance(&x, 10.0, &c).unwrap())
    };
    for scales in [Scales::Dyadic, Scales::LogSpaced { per_decade: 40 }] {
        for est in [Estimator::Overlapping, Estimator::NonOverlapping] {
            let a = run(1, scales.clone(), est);
            let b = run(2, scales.clone(), est);
            let c = run(3, scales.clone(), est);
            for ((p, q), r) in a.points.iter().zip(&b.points).zip(&c.points) {
                assert_eq!(p.avar.to_bits(), q.avar.to_bits(), "m={}", p.m);
                assert_eq!(p.avar.to_bits(), r.avar.to_bits(), "m={}", p.m);
            }
        }
    }
}

#[test]
fn bad_input_gives_clear_errors() {
    let d = AvarConfig::default();
    assert_eq!(allan_variance(&[], 1.0, &d).unwrap_err(), AvarError::Empty);
    assert_eq!(
        allan_variance(&[1.0, 2.0, 3.0], 1.0, &d).unwrap_err(),
        AvarError::TooShort { got: 3, need: 4 }
    );
    let ang = AvarConfig {
        input: InputKind::Angle,
        ..d.clone()
    };
    assert_eq!(
        allan_variance(&[1.0, 2.0, 3.0, 4.0], 1.0, &ang).unwrap_err(),
        AvarError::TooShort { got: 3, need: 4 }
    );
    let mut x = vec![0.5; 100];
    x[37] = f64::NAN;
    let e = allan_variance(&x, 1.0, &d).unwrap_err();
    assert!(matches!(e, AvarError::NonFinite { index: 37, .. }), "{e}");
    assert!(e.to_string().contains("index 37"));
    x[37] = 0.0;
    x[99] = f64::NEG_INFINITY;
    assert!(matches!(
        allan_variance(&x, 1.0, &d).unwrap_err(),
        AvarError::NonFinite { index: 99, .. }
    ));
    assert!(matches!(
        allan_variance(&x, 1.0, &ang).unwrap_err(),
        AvarError::NonFinite { index: 99, .. }
    ));
    // samples near f64::MAX: computed on a rescaled copy, whose AV (~1e616) is not representable
    let huge = vec![f64::MAX, -f64::MAX, f64::MAX, f64::MAX, f64::MAX];
    assert!(matches!(
        allan_variance(&huge, 1.0, &d).unwrap_err(),
        AvarError::NotRepresentable { .. }
    ));
    let y = vec![1.0; 100];
    for r in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            allan_variance(&y, r, &d).unwrap_err(),
            AvarError::InvalidRate(_)
        ));
    }
    for a in [0.0, 1.0, -0.1, 1.5, f64::NAN] {
        let c = AvarConfig {
            alpha: a,
            ..d.clone()
        };
        assert!(matches!(
            allan_variance(&y, 1.0, &c).unwrap_err(),
            AvarError::InvalidAlpha(_)
        ));
    }
    let e = allan_variance(&y, 1.0, &cfg(Scales::Explicit(vec![2, 51]))).unwrap_err();
    assert_eq!(
        e,
        AvarError::ScaleTooLarge {
            m: 51,
            t: 100,
            max: 50
        }
    );
    assert_eq!(
        allan_variance(&y, 1.0, &cfg(Scales::Explicit(vec![0]))).unwrap_err(),
        AvarError::ZeroScale
    );
    assert!(matches!(
        allan_variance(&y, 1.0, &cfg(Scales::Explicit(vec![]))).unwrap_err(),
        AvarError::InvalidScales(_)
    ));
    assert!(matches!(
        allan_variance(&y, 1.0, &cfg(Scales::RealJ { step: 0.0 })).unwrap_err(),
        AvarError::InvalidScales(_)
    ));
    assert!(matches!(
        allan_variance(&y, 1.0, &cfg(Scales::LogSpaced { per_decade: 0 })).unwrap_err(),
        AvarError::InvalidScales(_)
    ));
    // T = 4: the book's dyadic grid (j < log2 T − 1 = 1) is empty
    assert!(matches!(
        allan_variance(&[1.0, 2.0, 3.0, 5.0], 1.0, &d).unwrap_err(),
        AvarError::InvalidScales(_)
    ));
    // multi-channel errors name the channel
    let good = vec![0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 2.0];
    let e = allan_variance_channels(&[&good, &[1.0]], 1.0, &d).unwrap_err();
    assert!(e.to_string().starts_with("channel 1:"), "{e}");
    let e = avar::haar_wavelet_variance(&good, 1.0, Some(4), 0.05).unwrap_err();
    assert!(matches!(e, AvarError::ScaleTooLarge { .. }));
}

#[test]
fn constant_series_has_zero_av() {
    let x = vec![1234.5678; 4096];
    let av = allan_variance(&x, 1.0, &cfg(Scales::DyadicWithOne)).unwrap();
    for p in &av.points {
        assert_eq!(p.avar, 0.0, "m={}", p.m);
    }
}

#[test]
fn scale_grids_are_as_documented() {
    // T = 1e6: the book's 18 dyadic scales m = 2..2^18 (REFERENCES §1)
    let d = Scales::Dyadic.cluster_sizes(1_000_000).unwrap();
    assert_eq!(d, (1..=18).map(|j| 1u64 << j).collect::<Vec<_>>());
    // T a power of two: j < log2 T − 1 strictly
    assert_eq!(
        *Scales::Dyadic.cluster_sizes(1024).unwrap().last().unwrap(),
        256
    );
    assert_eq!(Scales::All.cluster_sizes(11).unwrap(), vec![1, 2, 3, 4, 5]);
    assert_eq!(
        Scales::Decade.cluster_sizes(250).unwrap(),
        vec![1, 2, 5, 10, 20, 50, 100]
    );
    let l = Scales::LogSpaced { per_decade: 10 }
        .cluster_sizes(100)
        .unwrap();
    assert_eq!(l, vec![1, 2, 3, 4, 5, 6, 8, 10, 13, 16, 20, 25, 32, 40, 50]);
}

#[test]
fn the_value_at_a_scale_does_not_depend_on_the_grid() {
    // lanes are tied to absolute indices, so batched/sub-blocked and per-scale walks agree bit for bit
    let x = white_noise(70_001, 1.0, 61);
    let all = allan_variance(&x, 1.0, &cfg(Scales::Explicit((1..=3000).collect()))).unwrap();
    let dy = allan_variance(&x, 1.0, &cfg(Scales::DyadicWithOne)).unwrap();
    for p in &dy.points {
        let one = allan_variance(&x, 1.0, &cfg(Scales::Explicit(vec![p.m]))).unwrap();
        assert_eq!(p.avar.to_bits(), one.points[0].avar.to_bits(), "m={}", p.m);
        if let Some(q) = all.points.iter().find(|q| q.m == p.m) {
            assert_eq!(p.avar.to_bits(), q.avar.to_bits(), "m={}", p.m);
        }
    }
}

/// Long rate series (T ≥ 2^22, overlapping estimator) take the streamed kernel: on such a
/// series it gives bit-identical results on 1, 2 and 3 threads and with or without a CI, agrees
/// with the from-scratch reference, and keeps item 2's offset bound.
#[test]
fn streamed_path_is_deterministic_exact_and_offset_proof() {
    let n = (1 << 22) + 4097;
    let w = white_noise(n, 1.0, 31);
    let r = random_walk(n, 1e-4, 32);
    let x: Vec<f64> = w.iter().zip(&r).map(|(a, b)| a + b).collect();
    let run = |threads: usize, x: &[f64], ci: CiMethod| {
        let c = AvarConfig {
            ci,
            ..cfg(Scales::DyadicWithOne)
        };
        on_threads(threads, || allan_variance(x, 100.0, &c).unwrap())
    };
    let a = run(1, &x, CiMethod::None);
    for threads in [2, 3] {
        let b = run(threads, &x, CiMethod::None);
        for (p, q) in a.points.iter().zip(&b.points) {
            assert_eq!(
                p.avar.to_bits(),
                q.avar.to_bits(),
                "{threads} threads, m={}",
                p.m
            );
        }
    }
    // asking for a CI does not change the AV (same kernel), and the CI brackets it
    let with_ci = run(2, &x, CiMethod::default());
    assert_eq!(a.points.len(), with_ci.points.len());
    for (p, q) in a.points.iter().zip(&with_ci.points) {
        assert_eq!(p.avar.to_bits(), q.avar.to_bits(), "m={}", p.m);
        assert_eq!(p.n_terms, q.n_terms);
        let (lo, hi) = (q.avar_lo.unwrap(), q.avar_hi.unwrap());
        assert!(
            lo < q.avar && q.avar < hi,
            "m={}: {lo} {} {hi}",
            p.m,
            q.avar
        );
    }
    assert_eq!(a.mean.to_bits(), with_ci.mean.to_bits());
    // the summation-free reference (cluster means from scratch) at the small scales, where a
    // rounded cumulative sum would lose the most
    for p in &a.points[..3] {
        let r = avar::moav_reference(&x, p.m).unwrap();
        assert!(rel(p.avar, r) <= 1e-12, "m={}: {} vs {r}", p.m, p.avar);
    }
    let sd = 1.0;
    for c in [-1e4, 1e4] {
        let shifted: Vec<f64> = x.iter().map(|v| v + c * sd).collect();
        let s = run(2, &shifted, CiMethod::None);
        for (p, q) in a.points.iter().zip(&s.points) {
            assert!(rel(q.avar, p.avar) <= TOL_OFFSET, "c={c} m={}", p.m);
        }
    }
}
