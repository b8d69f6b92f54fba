//! AR(p) (issue 28): the theoretical AV three ways, the AR(1) special case, the damped
//! oscillation of an AR(2) with complex roots, and the validation of the parameters.

use processes::{Ar1, ArP, Model, Process};
use spectral::{allan_variance, lemma42_allan_variance, quadrature_allan_variance};

const MS: [u64; 9] = [1, 2, 3, 5, 10, 37, 100, 1000, 10_000];

fn cases() -> Vec<ArP> {
    vec![
        ArP::new(&[1.6, -0.8], 1.0).unwrap(), // complex roots, r = 0.894
        ArP::new(&[0.5, 0.3], 2e-4).unwrap(), // real roots
        ArP::new(&[0.2, -0.1, 0.4], 3.0).unwrap(), // AR(3)
        ArP::from_pacf(&[0.9, -0.7, 0.5, -0.3], 1e-6).unwrap(), // AR(4)
        ArP::new(&[-0.6, 0.2], 1.0).unwrap(), // negative φ1
    ]
}

#[test]
fn ar1_special_case_equals_ar1() {
    // AR2 with φ2 = 0 is AR1(φ1) with the same innovation variance: same AV to 1e-12
    for phi in [0.9, 0.3, -0.5, 0.99] {
        let a = Process::from(ArP::new(&[phi, 0.0], 2.5).unwrap());
        let b = Process::from(Ar1::new(phi, 2.5).unwrap());
        for m in MS {
            let (x, y) = (
                allan_variance(&a, m, 100.0).unwrap(),
                allan_variance(&b, m, 100.0).unwrap(),
            );
            assert!((x - y).abs() <= 1e-12 * y, "phi={phi} m={m}: {x} vs {y}");
        }
        for h in [0, 1, 5, 50] {
            let (x, y) = (
                a.autocovariance(h, 1.0).unwrap(),
                b.autocovariance(h, 1.0).unwrap(),
            );
            assert!((x - y).abs() <= 1e-12 * b.autocovariance(0, 1.0).unwrap());
        }
    }
}

#[test]
fn av_three_ways_agree() {
    // the truncated lag sum (closed_form::arp_avar) vs Lemma 4.2 on the full exact ACF
    // (semivariogram form) vs Lemma 4.1 quadrature of σ²/|φ(e^{−iω})|²: within 1e-6
    for a in cases() {
        let p = Process::from(a);
        for m in MS {
            let c = allan_variance(&p, m, 100.0).unwrap();
            let l = lemma42_allan_variance(&p, m, 100.0).unwrap();
            let q = quadrature_allan_variance(&p, m, 100.0).unwrap();
            assert!(
                (c - l).abs() <= 1e-9 * c,
                "{a:?} m={m}: sum {c} vs lemma42 {l}"
            );
            assert!(
                (c - q).abs() <= 1e-6 * c,
                "{a:?} m={m}: sum {c} vs quadrature {q}"
            );
        }
    }
}

#[test]
fn ar2_with_complex_roots_is_a_damped_oscillation() {
    // φ1 = 1.6, φ2 = −0.8: roots of z² − φ1 z − φ2 are r e^{±iθ}, r = √0.8, cos θ = φ1/(2r);
    // ρ(h) = r^h (cos hθ + c sin hθ) with c from ρ(1) = φ1/(1 − φ2)
    let a = ArP::new(&[1.6, -0.8], 1.0).unwrap();
    let r = 0.8f64.sqrt();
    let th = (1.6 / (2.0 * r)).acos();
    let rho1 = 1.6 / 1.8;
    let c = (rho1 / r - th.cos()) / th.sin();
    let acf = a.acf(60);
    let mut sign_changes = 0;
    for h in 0..60 {
        let closed = r.powi(h as i32) * ((h as f64 * th).cos() + c * (h as f64 * th).sin());
        assert!(
            (acf[h] - closed).abs() <= 1e-12,
            "h={h}: {} vs {closed}",
            acf[h]
        );
        if h > 0 && acf[h] * acf[h - 1] < 0.0 {
            sign_changes += 1;
        }
    }
    // a cos(hθ − ψ) changes sign every π/θ ≈ 6.8 samples: lags 0 … 59 hold at least
    // ⌊59θ/π⌋ = 8 sign changes (an AR(2) with real positive roots has none)
    assert_eq!((59.0 * th / std::f64::consts::PI).floor(), 8.0);
    assert!(sign_changes >= 8, "{sign_changes}");
    let real = ArP::new(&[0.5, 0.3], 1.0).unwrap().acf(60);
    assert!(real.iter().all(|x| *x > 0.0));
    // γ(0) = σ²/((1 − κ1²)(1 − κ2²)), κ1 = φ1/(1 − φ2), κ2 = φ2
    let g0 = 1.0 / ((1.0 - rho1 * rho1) * (1.0 - 0.64));
    assert!((a.stationary_variance() - g0).abs() <= 1e-12 * g0);
}

#[test]
fn invalid_ar_parameters_are_rejected() {
    let e = ArP::new(&[0.5, 0.6], 1.0).unwrap_err().to_string();
    assert!(e.contains("not stationary"), "{e}");
    let e = ArP::new(&[2.0, -0.5], 1.0).unwrap_err().to_string();
    assert!(e.contains("not stationary"), "{e}");
    let e = ArP::new(&[0.1; 5], 1.0).unwrap_err().to_string();
    assert!(e.contains("2 to 4"), "{e}");
    assert!(
        ArP::new(&[0.1, 0.1], -1.0)
            .unwrap_err()
            .to_string()
            .contains("sigma2")
    );
    let e = "AR2(phi1=1.2, phi2=-0.1, sigma2=1)"
        .parse::<Model>()
        .unwrap_err()
        .to_string();
    assert!(e.contains("not stationary"), "{e}");
    let e = "AR5(1, 2, 3, 4, 5, 6)"
        .parse::<Model>()
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown process"), "{e}");
}

#[test]
fn model_text_round_trip() {
    let m: Model = "AR2(phi1=1.6, phi2=-0.8, sigma2=1) + WN(sigma2=0.5) + AR3"
        .parse()
        .unwrap();
    assert_eq!(m.to_string().parse::<Model>().unwrap(), m);
    assert_eq!(m.n_params(), 3 + 1 + 4);
}
