//! MA(2) and ARMA(p, q) (issue 28): the theoretical AV three ways, independent closed forms,
//! the special cases (ARMA(p,0) = AR(p), ARMA(0,1) = MA1, MA2 with θ2 = 0 = MA1), the PSD,
//! and the validation of the parameters.

use processes::arma::{ar_unit_acvf, arma_acvf};
use processes::{Ar1, ArP, Arma, Ma1, Model, Process};
use spectral::closed_form::ar1_unit_avar;
use spectral::{allan_variance, lemma42_allan_variance, psd, quadrature_allan_variance};

const MS: [u64; 10] = [1, 2, 3, 4, 5, 10, 37, 100, 1000, 10_000];

fn cases() -> Vec<Arma> {
    vec![
        Arma::new(&[], &[0.5, 0.25], 2.0).unwrap(), // MA2, invertible
        Arma::new(&[], &[-1.2, 0.6], 1e-4).unwrap(), // MA2, complex MA roots
        Arma::new(&[], &[2.0, 1.5], 1.0).unwrap(),  // MA2, not invertible
        Arma::new(&[0.9], &[0.4], 1.0).unwrap(),    // ARMA(1,1)
        Arma::new(&[-0.6], &[0.3, -0.2], 3.0).unwrap(), // ARMA(1,2), φ < 0
        Arma::new(&[1.2728, -0.81], &[0.5], 1e-5).unwrap(), // ARMA(2,1), damped oscillation
        Arma::new(&[1.6, -0.8], &[-0.4, 0.3], 1.0).unwrap(), // ARMA(2,2)
        Arma::new(&[0.2, -0.1, 0.4], &[0.7], 1.0).unwrap(), // ARMA(3,1)
        Arma::new(
            &processes::ar_p::phi_from_pacf(&[0.9, -0.7, 0.5, -0.3]),
            &[0.3, 0.1],
            1e-6,
        )
        .unwrap(), // ARMA(4,2)
    ]
}

#[test]
fn av_three_ways_agree() {
    // the lag sum with the AR recursion (closed_form, via spectral::arma::arma_avar) vs
    // Lemma 4.2 on the full exact autocovariance (semivariogram form): 1e-10; vs Lemma 4.1
    // quadrature of σ²|θ(e^{−iω})|²/|φ(e^{−iω})|²: 1e-6 (the quadrature's own tolerance)
    for a in cases() {
        let p = Process::from(a);
        for m in MS {
            let c = allan_variance(&p, m, 100.0).unwrap();
            let l = lemma42_allan_variance(&p, m, 100.0).unwrap();
            let q = quadrature_allan_variance(&p, m, 100.0).unwrap();
            assert!(
                (c - l).abs() <= 1e-10 * c,
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
fn ma2_closed_form() {
    // γ0 = σ²(1 + θ1² + θ2²), γ1 = σ²θ1(1 + θ2), γ2 = σ²θ2; AV(1) = γ0 − γ1,
    // AV(2) = (2γ0 + γ1 − 2γ2)/4, AV(m ≥ 3) = [mγ0 + (2m − 3)γ1 + (2m − 6)γ2]/m²
    for (t1, t2, s2) in [(0.5, 0.25, 2.0), (-1.2, 0.6, 1e-4), (2.0, 1.5, 1.0)] {
        let p = Process::from(Arma::new(&[], &[t1, t2], s2).unwrap());
        let (g0, g1, g2) = (
            s2 * (1.0 + t1 * t1 + t2 * t2),
            s2 * t1 * (1.0 + t2),
            s2 * t2,
        );
        for m in MS {
            let mf = m as f64;
            let want = match m {
                1 => g0 - g1,
                2 => (2.0 * g0 + g1 - 2.0 * g2) / 4.0,
                _ => (mf * g0 + (2.0 * mf - 3.0) * g1 + (2.0 * mf - 6.0) * g2) / (mf * mf),
            };
            let got = allan_variance(&p, m, 1.0).unwrap();
            assert!((got - want).abs() <= 1e-10 * want, "m={m}: {got} vs {want}");
        }
    }
}

#[test]
fn arma11_closed_form_as_wn_plus_ar1() {
    // ARMA(1,1): γ(h) = γ1 φ^{h−1} for h ≥ 1, so γ = (γ0 − γ1/φ)δ_h + (γ1/φ)φ^{|h|}: the AV
    // of a WN of variance γ0 − γ1/φ plus an AR1 of stationary variance γ1/φ (closed form
    // of the AR1 AV, Cor. 4.1), γ0 = σ²(1 + 2φθ + θ²)/(1 − φ²), γ1 = σ²(1 + φθ)(φ + θ)/(1 − φ²)
    for (phi, th, s2) in [
        (0.9, 0.4, 1.0),
        (0.5, -0.3, 2.0),
        (-0.6, 0.8, 1e-3),
        (0.99, -0.9, 1.0),
    ] {
        let p = Process::from(Arma::new(&[phi], &[th], s2).unwrap());
        let d = 1.0 - phi * phi;
        let g0 = s2 * (1.0 + 2.0 * phi * th + th * th) / d;
        let g1 = s2 * (1.0 + phi * th) * (phi + th) / d;
        let (wn, ar) = (g0 - g1 / phi, g1 / phi);
        for m in MS {
            // ar1_unit_avar is the AV of an AR1 with unit innovation variance
            let want = wn / m as f64 + ar * d * ar1_unit_avar(phi, m).0;
            let got = allan_variance(&p, m, 1.0).unwrap();
            assert!(
                (got - want).abs() <= 1e-10 * want.abs(),
                "φ={phi} θ={th} m={m}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn special_cases() {
    // ARMA(p, 0) = AR(p): the general autocovariance with no MA part is the AR(p)'s
    for phi in [vec![1.6, -0.8], vec![0.2, -0.1, 0.4], vec![0.5, 0.3]] {
        let a = ArP::new(&phi, 2.5).unwrap();
        let g = arma_acvf(&phi, &[], 2.5, 60).unwrap();
        let r = a.acf(60);
        for h in 0..60 {
            let want = a.stationary_variance() * r[h];
            assert!((g[h] - want).abs() <= 1e-12 * a.stationary_variance());
        }
        // and ARMA(p, 1) with θ1 = 0 has the AR(p)'s AV
        let (x, y) = (
            Process::from(Arma::new(&phi, &[0.0], 2.5).unwrap()),
            Process::from(a),
        );
        for m in MS {
            let (u, v) = (
                allan_variance(&x, m, 1.0).unwrap(),
                allan_variance(&y, m, 1.0).unwrap(),
            );
            assert!((u - v).abs() <= 1e-12 * v, "{phi:?} m={m}: {u} vs {v}");
        }
    }
    // AR(1) through the unit AR autocovariance
    let g = ar_unit_acvf(&[0.7], 10).unwrap();
    let a1 = Process::from(Ar1::new(0.7, 1.0).unwrap());
    for (h, gh) in g.iter().enumerate() {
        assert!((gh - a1.autocovariance(h as u64, 1.0).unwrap()).abs() <= 1e-12);
    }
    // ARMA(0, 1) = MA1, ARMA(1, 1) with φ = 0 = MA1, MA2 with θ2 = 0 = MA1
    for th in [0.5, -0.9, 1.7] {
        let ma = Process::from(Ma1::new(th, 3.0).unwrap());
        let g = arma_acvf(&[], &[th], 3.0, 5).unwrap();
        for (h, gh) in g.iter().enumerate() {
            let want = ma.autocovariance(h as u64, 1.0).unwrap();
            assert!((gh - want).abs() <= 1e-12 * 3.0 * (1.0 + th * th));
        }
        for other in [
            Arma::new(&[0.0], &[th], 3.0).unwrap(),
            Arma::new(&[], &[th, 0.0], 3.0).unwrap(),
        ] {
            let x = Process::from(other);
            for m in MS {
                let (u, v) = (
                    allan_variance(&x, m, 1.0).unwrap(),
                    allan_variance(&ma, m, 1.0).unwrap(),
                );
                assert!((u - v).abs() <= 1e-12 * v, "{other:?} m={m}: {u} vs {v}");
            }
            for f in [0.0, 3.0, 17.0, 49.0] {
                let (u, v) = (psd(&x, f, 100.0).unwrap(), psd(&ma, f, 100.0).unwrap());
                assert!((u - v).abs() <= 1e-12 * v.max(1e-300), "{other:?} f={f}");
            }
        }
    }
}

#[test]
fn psd_is_the_rational_spectrum() {
    // σ²Δt |θ(e^{−iω})|²/|φ(e^{−iω})|² evaluated with complex arithmetic here, at 100 Hz;
    // and θ = 0 gives the AR(p)'s PSD
    let rate = 100.0;
    for a in cases() {
        let p = Process::from(a);
        for f in [0.0, 1.0, 12.5, 30.0, 50.0] {
            let w = 2.0 * std::f64::consts::PI * f / rate;
            let poly = |c: &[f64], sign: f64| {
                let (mut re, mut im) = (1.0, 0.0);
                for (k, x) in c.iter().enumerate() {
                    let kw = (k + 1) as f64 * w;
                    re += sign * x * kw.cos();
                    im -= sign * x * kw.sin();
                }
                re * re + im * im
            };
            let want = a.sigma2() / rate * poly(a.theta(), 1.0) / poly(a.phi(), -1.0);
            let got = psd(&p, f, rate).unwrap();
            assert!(
                (got - want).abs() <= 1e-10 * want,
                "{a:?} f={f}: {got} vs {want}"
            );
        }
    }
    let ar = Process::from(ArP::new(&[1.6, -0.8], 2.0).unwrap());
    let arma = Process::from(Arma::new(&[1.6, -0.8], &[0.0, 0.0], 2.0).unwrap());
    for f in [0.0, 7.0, 20.0] {
        let (u, v) = (psd(&arma, f, 100.0).unwrap(), psd(&ar, f, 100.0).unwrap());
        assert!((u - v).abs() <= 1e-12 * v);
    }
}

#[test]
fn invalid_parameters_are_rejected() {
    let e = Arma::new(&[0.5, 0.6], &[0.1], 1.0).unwrap_err().to_string();
    assert!(e.contains("not stationary"), "{e}");
    let e = Arma::new(&[0.5], &[f64::INFINITY], 1.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("theta1"), "{e}");
    let e = Arma::new(&[0.5], &[0.1], -1.0).unwrap_err().to_string();
    assert!(e.contains("sigma2"), "{e}");
    assert!(Arma::new(&[], &[0.5], 1.0).is_err()); // MA1
    assert!(Arma::new(&[0.5, 0.1], &[], 1.0).is_err()); // AR2
    assert!(Arma::new(&[0.1; 5], &[0.1], 1.0).is_err());
    assert!(Arma::new(&[0.1], &[0.1; 3], 1.0).is_err());
    let e = "ARMA21(phi1=1.2, phi2=-0.1, theta1=0.3, sigma2=1)"
        .parse::<Model>()
        .unwrap_err()
        .to_string();
    assert!(e.contains("not stationary"), "{e}");
    for bad in ["ARMA13(1, 2, 3, 4, 5)", "ARMA51", "MA3", "ARMA01", "ARMA20"] {
        let e = bad.parse::<Model>().unwrap_err().to_string();
        assert!(e.contains("unknown process"), "{bad}: {e}");
    }
    // a non-invertible MA2 is a valid process (same AV as its invertible mirror up to σ²)
    let a = Arma::new(&[], &[2.0, 1.5], 1.0).unwrap();
    assert!(!a.is_invertible());
}

#[test]
fn model_text_round_trip() {
    let m: Model = "MA2(theta1=0.5, theta2=-0.2, sigma2=1) + WN(sigma2=0.5) + ARMA21(phi1=1.2, phi2=-0.8, theta1=0.4, sigma2=1e-4) + ARMA42 + ARMA11(0.5, 0.3, 2)"
        .parse()
        .unwrap();
    assert_eq!(m.to_string().parse::<Model>().unwrap(), m);
    assert_eq!(m.n_params(), 3 + 1 + 4 + 7 + 3);
    // two MA2 are not identifiable (their sum is an MA2); ARMA may repeat like AR(p)
    assert!("MA2 + MA2".parse::<Model>().is_err());
    assert!("ARMA11 + ARMA11".parse::<Model>().is_ok());
}
