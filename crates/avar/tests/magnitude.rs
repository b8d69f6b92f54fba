//! Huge and tiny magnitudes: the estimators are exactly scale-equivariant under powers of two,
//! and an AV beyond the range of f64 is an error that says so (never an infinity, NaN or a zero
//! that stands for an underflow).

mod common;

use avar::{
    AllanVariance, AvarConfig, AvarError, CiMethod, Estimator, InputKind, Scales, allan_variance,
    allan_variance_channels, haar_wavelet_variance,
};
use common::*;

fn scaled(x: &[f64], k: i32) -> Vec<f64> {
    x.iter().map(|v| v * 2f64.powi(k)).collect()
}

/// Every value of `b` equals the matching value of `a` times 2^(2k) (AV) or 2^k (AD), bit for bit.
fn assert_scaled_exactly(a: &AllanVariance, b: &AllanVariance, k: i32, label: &str) {
    let f2 = |v: f64| v * 2f64.powi(2 * k);
    let f1 = |v: f64| v * 2f64.powi(k);
    assert_eq!(a.points.len(), b.points.len());
    for (p, q) in a.points.iter().zip(&b.points) {
        let ctx = format!("{label} k={k} m={}", p.m);
        assert!(q.avar.is_finite(), "{ctx}");
        assert_eq!(q.avar, f2(p.avar), "{ctx} avar");
        assert_eq!(q.adev, f1(p.adev), "{ctx} adev");
        assert_eq!(q.avar_lo, p.avar_lo.map(f2), "{ctx} lo");
        assert_eq!(q.avar_hi, p.avar_hi.map(f2), "{ctx} hi");
        assert_eq!(q.adev_lo, p.adev_lo.map(f1), "{ctx} adev lo");
        assert_eq!(q.adev_hi, p.adev_hi.map(f1), "{ctx} adev hi");
        assert_eq!(q.edf, p.edf, "{ctx} edf");
        assert_eq!(q.noise_alpha, p.noise_alpha, "{ctx} alpha");
        assert_eq!(q.lower_negative, p.lower_negative, "{ctx} flag");
    }
}

/// AV(2^k·x) = 4^k·AV(x) bit for bit, for every estimator, input kind and CI family, from
/// 2^−500 (samples near 1e−150, AV near 1e−300) to 2^500 (samples near 1e150, AV near 1e300):
/// magnitudes at which the squares of the unscaled arithmetic underflow or overflow.
#[test]
fn power_of_two_scaling_is_exact_for_every_configuration() {
    let x: Vec<f64> = white_noise(5000, 1.0, 3)
        .iter()
        .zip(random_walk(5000, 1e-4, 4))
        .map(|(w, r)| w + r)
        .collect();
    for estimator in [Estimator::Overlapping, Estimator::NonOverlapping] {
        for input in [InputKind::Rate, InputKind::Angle] {
            for ci in [CiMethod::ChiSquare, CiMethod::Gaussian, CiMethod::None] {
                let cfg = AvarConfig {
                    scales: Scales::DyadicWithOne,
                    estimator,
                    input,
                    ci,
                    ..AvarConfig::default()
                };
                let label = format!("{estimator:?}/{input:?}/{ci:?}");
                let base = allan_variance(&x, 100.0, &cfg).unwrap();
                for k in [-500, -300, -130, -1, 1, 7, 130, 300, 500] {
                    let av = allan_variance(&scaled(&x, k), 100.0, &cfg)
                        .unwrap_or_else(|e| panic!("{label} k={k}: {e}"));
                    assert_scaled_exactly(&base, &av, k, &label);
                }
            }
        }
    }
}

/// The streamed kernel (T ≥ 2^22, no CI) and the CI path beside it scale exactly too.
#[test]
fn power_of_two_scaling_is_exact_on_the_streamed_path() {
    let x = white_noise((1 << 22) + 3, 1.0, 9);
    let cfg = AvarConfig {
        scales: Scales::Explicit(vec![1, 2, 64, 4096, 1 << 20]),
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let base = allan_variance(&x, 1.0, &cfg).unwrap();
    for k in [-490, 490] {
        let av = allan_variance(&scaled(&x, k), 1.0, &cfg).unwrap();
        assert_scaled_exactly(&base, &av, k, "streamed");
    }
}

/// Samples near 1e300 (AV near 1e600) and near 1e−300 (AV near 1e−600): an error naming the
/// first scale and the magnitude, not `inf`/`null` or zeros.
#[test]
fn an_av_beyond_the_range_of_f64_is_an_error() {
    let x = white_noise(1000, 1.0, 5);
    let cfg = AvarConfig::default();
    for (k, log10) in [(997, 600.0), (-997, -600.0)] {
        let err = allan_variance(&scaled(&x, k), 1.0, &cfg).unwrap_err();
        match &err {
            AvarError::NotRepresentable { m, log10: l } => {
                assert_eq!(*m, 2);
                // AV(m = 2) of unit white noise is about 1/2: 10^(±600.2 − 0.3)
                assert!((l - log10).abs() < 1.0, "{l}");
            }
            e => panic!("k={k}: unexpected {e:?}"),
        }
        let msg = err.to_string();
        assert!(msg.contains("outside the range of f64"), "{msg}");
    }
    // one channel of several: the error names it
    let ok = white_noise(1000, 1.0, 6);
    let huge = scaled(&x, 1000);
    let err = allan_variance_channels(&[&ok, &huge], 1.0, &cfg).unwrap_err();
    assert!(
        matches!(err, AvarError::Channel { channel: 1, .. }),
        "{err:?}"
    );
}

/// A square wave has AV exactly 0 at even m at any magnitude: zeros that are true stay zeros.
#[test]
fn true_zeros_are_kept_at_any_magnitude() {
    let cfg = AvarConfig {
        scales: Scales::Explicit(vec![1, 2, 4]),
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    for c in [1.0, 1e-300, 1e300] {
        let x: Vec<f64> = (0..64).map(|i| if i % 2 == 0 { c } else { -c }).collect();
        let av = allan_variance(&x, 1.0, &cfg);
        if c == 1.0 {
            let av = av.unwrap();
            assert_eq!(av.points[0].avar, 2.0);
            assert_eq!(av.points[1].avar, 0.0);
        } else {
            // m = 1 gives 2c² (unrepresentable), the others are exact zeros
            assert!(matches!(av, Err(AvarError::NotRepresentable { m: 1, .. })));
            let cfg2 = AvarConfig {
                scales: Scales::Explicit(vec![2, 4]),
                ..cfg.clone()
            };
            let av = allan_variance(&x, 1.0, &cfg2).unwrap();
            assert!(av.points.iter().all(|p| p.avar == 0.0));
        }
    }
}

/// The Haar wavelet variance (AV/2 at dyadic scales) inherits the exact scaling.
#[test]
fn haar_wv_scales_exactly() {
    let x = white_noise(4096, 1.0, 8);
    let a = haar_wavelet_variance(&x, 1.0, None, 0.05).unwrap();
    let b = haar_wavelet_variance(&scaled(&x, 400), 1.0, None, 0.05).unwrap();
    for (p, q) in a.points.iter().zip(&b.points) {
        assert_eq!(q.wv, p.wv * 2f64.powi(800));
        assert_eq!(q.wv_hi, p.wv_hi * 2f64.powi(800));
    }
}

/// Every member of the stability family scales exactly too (MDEV, TDEV, HDEV, OHDEV, TOTDEV,
/// ADEV, OADEV; rate and angle input; chi-square intervals included), and a variance beyond
/// f64 is an error, not NaN.
#[test]
fn the_stability_family_scales_exactly() {
    use avar::stability::{Statistic, stability};
    let x: Vec<f64> = white_noise(3000, 1.0, 12)
        .iter()
        .zip(random_walk(3000, 1e-3, 13))
        .map(|(w, r)| w + r)
        .collect();
    for st in Statistic::ALL {
        for input in [InputKind::Rate, InputKind::Angle] {
            let cfg = AvarConfig {
                scales: Scales::Octave,
                input,
                ..AvarConfig::default()
            };
            let a = stability(&x, 1.0, st, &cfg).unwrap();
            for k in [-450, 450] {
                let b = stability(&scaled(&x, k), 1.0, st, &cfg)
                    .unwrap_or_else(|e| panic!("{st:?} {input:?} k={k}: {e}"));
                for (p, q) in a.points.iter().zip(&b.points) {
                    let f2 = |v: f64| v * 2f64.powi(2 * k);
                    assert_eq!(q.var, f2(p.var), "{st:?} {input:?} k={k} m={}", p.m);
                    assert_eq!(q.var_lo, p.var_lo.map(f2));
                    assert_eq!(q.var_hi, p.var_hi.map(f2));
                    assert_eq!(q.dev, p.dev * 2f64.powi(k));
                    assert_eq!(q.alpha, p.alpha);
                }
            }
            let e = stability(&scaled(&x, 1000), 1.0, st, &cfg).unwrap_err();
            assert!(
                matches!(e, AvarError::NotRepresentable { .. }),
                "{st:?}: {e:?}"
            );
        }
    }
}
