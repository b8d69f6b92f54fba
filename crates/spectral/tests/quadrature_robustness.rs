//! Lemma 4.1 quadrature beyond the acceptance grid: discrete processes at m up to 2^30
//! (odd and even), and continuous-time PSDs with 1/f, 1/f² and Lorentzian shapes over
//! ten decades of τ, each against its closed form.

mod common;
use common::fixtures::{RATE, fixtures};
use processes::{Drift, Process, RandomWalk};
use spectral::tolerances::QUADRATURE_REL;
use spectral::{
    SpectralError, allan_variance, lemma41_allan_variance, psd, quadrature_allan_variance,
};
use std::f64::consts::{LN_2, PI};

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn discrete_quadrature_holds_up_to_m_2_pow_30() {
    let ms = [
        1000001u64,
        3 * (1 << 20) + 1,
        1 << 25,
        (1 << 30) - 1,
        1 << 30,
    ];
    let mut worst = 0.0f64;
    for (name, p) in fixtures() {
        for m in ms {
            let (q, c) = (
                quadrature_allan_variance(&p, m, RATE).unwrap(),
                allan_variance(&p, m, RATE).unwrap(),
            );
            let e = rel(q, c);
            worst = worst.max(e);
            assert!(e <= QUADRATURE_REL, "{name} m={m}: {q:e} vs {c:e} ({e:e})");
        }
    }
    eprintln!("quadrature vs closed form, m up to 2^30: worst {worst:e}");
}

#[test]
fn continuous_power_laws_and_lorentzian() {
    let taus: Vec<f64> = (-3..=7).map(|k| 10f64.powi(k)).collect();
    let (n2, c, k2) = (3e-4, 2e-7, 5e-9);
    let (s2, beta) = (1e-5, 0.02);
    let mut worst = 0.0f64;
    for &tau in &taus {
        let cases: Vec<(&str, f64, f64)> = vec![
            // white: S = N² → N²/τ
            ("WN", lemma41_allan_variance(|_| n2, tau).unwrap(), n2 / tau),
            // flicker: S = c/f → 4c ln 2
            (
                "1/f",
                lemma41_allan_variance(|f| c / f, tau).unwrap(),
                4.0 * c * LN_2,
            ),
            // rate random walk: S = K²/(2πf)² → K²τ/3
            (
                "1/f^2",
                lemma41_allan_variance(|f| k2 / (4.0 * PI * PI * f * f), tau).unwrap(),
                k2 * tau / 3.0,
            ),
        ];
        for (name, q, exact) in cases {
            let e = rel(q, exact);
            worst = worst.max(e);
            assert!(
                e <= QUADRATURE_REL,
                "{name} tau={tau}: {q:e} vs {exact:e} ({e:e})"
            );
        }
        // continuous Gauss-Markov: S = 2σ²β/(β² + (2πf)²),
        // AV = σ²/(βτ)² (2βτ − 3 + 4e^{−βτ} − e^{−2βτ}) (used where βτ ≥ 0.05: no cancellation issue)
        let x = beta * tau;
        if x >= 0.05 {
            let q = lemma41_allan_variance(
                |f| 2.0 * s2 * beta / (beta * beta + 4.0 * PI * PI * f * f),
                tau,
            )
            .unwrap();
            let exact = s2 / (x * x) * (2.0 * x - 3.0 + 4.0 * (-x).exp() - (-2.0 * x).exp());
            let e = rel(q, exact);
            worst = worst.max(e);
            assert!(
                e <= QUADRATURE_REL,
                "GM tau={tau}: {q:e} vs {exact:e} ({e:e})"
            );
        }
    }
    eprintln!("continuous Lemma 4.1 vs closed forms: worst {worst:e}");
}

#[test]
fn generalized_spectra_and_bad_input() {
    let dr = Process::from(Drift::new(2e-3).unwrap());
    assert!(matches!(
        psd(&dr, 1.0, 10.0),
        Err(SpectralError::NotAFunction { .. })
    ));
    // DR: the distribution (ωr)²/(8π²)δ'' applied to the kernel gives the closed form
    let (q, c) = (
        quadrature_allan_variance(&dr, 77, 10.0).unwrap(),
        allan_variance(&dr, 77, 10.0).unwrap(),
    );
    assert!(rel(q, c) <= QUADRATURE_REL);
    let rw = Process::from(RandomWalk::new(1.0).unwrap());
    assert_eq!(psd(&rw, 0.0, 10.0).unwrap(), f64::INFINITY);
    // RW's generalized PSD ~ γ²/(4π²f²Δt) near 0: sin²x = x²(1 − x²/3 + …), x = πfΔt,
    // so the relative deviation is x²/3 to leading order
    let f = 1e-2;
    let x = PI * f * 0.1;
    let approx = 1.0 / (4.0 * PI * PI * f * f * 0.1);
    let dev = rel(psd(&rw, f, 10.0).unwrap(), approx);
    assert!(
        (dev - x * x / 3.0).abs() <= 0.01 * x * x / 3.0,
        "{dev:e} vs {:e}",
        x * x / 3.0
    );
    assert!(matches!(
        allan_variance(&rw, 0, 1.0),
        Err(SpectralError::InvalidClusterSize(0))
    ));
    assert!(matches!(
        quadrature_allan_variance(&rw, 4, -1.0),
        Err(SpectralError::InvalidRate(_))
    ));
    assert!(matches!(
        spectral::haar_wavelet_variance(&rw, 6 - 1, 1.0),
        Err(SpectralError::InvalidScale(5))
    ));
    assert!(matches!(
        lemma41_allan_variance(|f| f * f, 1.0),
        Err(SpectralError::Divergent(_))
    ));
    assert!(lemma41_allan_variance(|_| 1.0, 0.0).is_err());
    let slot: processes::Model = "WN + RW".parse().unwrap();
    assert!(matches!(
        spectral::model_allan_variance(&slot, 2, 1.0),
        Err(SpectralError::Process(_))
    ));
}

#[test]
fn discrete_quadrature_of_a_user_psd_closure() {
    // the generic entry point, fed with the process PSDs as plain closures of f (Hz)
    use processes::{Ar1, Ma1};
    use spectral::discrete_lemma41_allan_variance;
    let procs: Vec<Process> = vec![
        Ar1::new(0.999, 1e-6).unwrap().into(),
        Ar1::new(-0.999, 1e-6).unwrap().into(),
        Ma1::new(-0.9, 1e-4).unwrap().into(),
    ];
    let mut worst = 0.0f64;
    for p in procs {
        for m in [1u64, 2, 7, 64, 1000, 1 << 20, (1 << 30) + 1] {
            let q =
                discrete_lemma41_allan_variance(|f| psd(&p, f, RATE).unwrap(), m, RATE).unwrap();
            let c = allan_variance(&p, m, RATE).unwrap();
            let e = rel(q, c);
            worst = worst.max(e);
            assert!(e <= QUADRATURE_REL, "{p:?} m={m}: {q:e} vs {c:e} ({e:e})");
        }
    }
    eprintln!("discrete Lemma 4.1 on PSD closures: worst {worst:e}");
}
