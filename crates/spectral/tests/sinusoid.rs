//! Random-phase sinusoid (SIN, issue 28): its AV three ways — the closed form
//! α² sin⁴(βm/2)/(m sin(β/2))², the Lemma 4.2 sum of its exact variogram α² sin²(βh/2), and
//! its line spectrum through the AV filter's frequency response (the Lemma 4.1 route for a
//! line: a direct sum of 2m complex exponentials) — and its analytic gradient.

use processes::{Process, Sinusoid};
use spectral::{
    SpectralError, allan_variance, allan_variance_gradient, lemma42_allan_variance, psd,
    quadrature_allan_variance,
};

const RATE: f64 = 100.0;
/// Closed form vs the Lemma 4.2 sum (issue 28 acceptance 1e-10), relative to the envelope
/// α²/(m sin(β/2))² of the AV: at its nulls (βm/2 a multiple of π) the AV is 0 and every
/// route is left with rounding of the size of its terms. The variogram of a sinusoid does
/// not decay, so the O(m) sum adds 2m terms of size up to 2m·α² before dividing by m²: its
/// rounding is up to ~4ε·m²·sin²(β/2) of the envelope, allowed with a factor 8 on top of
/// 1e-10 (it matters from m ≈ 2^12 on).
const SUM_REL: f64 = 1e-10;

fn sum_tolerance(m: f64, beta: f64) -> f64 {
    SUM_REL + 8.0 * 4.0 * f64::EPSILON * m * m * (0.5 * beta).sin().powi(2)
}
/// Closed form vs the line route (issue 28 acceptance for the quadrature: 1e-6), same scale.
const LINE_REL: f64 = 1e-6;

#[test]
fn closed_form_lemma42_and_line_route_agree() {
    for (a2, beta) in [(2e-4, 0.9), (1.0, 0.035), (3.0, 3.0), (0.5, 1e-3)] {
        let p = Process::from(Sinusoid::new(a2, beta).unwrap());
        let mut grid = vec![1u64, 2, 3, 4, 7];
        grid.extend((3..=18).map(|j| 1u64 << j));
        for m in grid {
            let mf = m as f64;
            let env = a2 / (mf * (0.5 * beta).sin()).powi(2);
            let c = allan_variance(&p, m, RATE).unwrap();
            let s = lemma42_allan_variance(&p, m, RATE).unwrap();
            let q = quadrature_allan_variance(&p, m, RATE).unwrap();
            assert!(
                (s - c).abs() <= sum_tolerance(mf, beta) * env,
                "β={beta} m={m}: {c:e} vs sum {s:e}"
            );
            assert!(
                (q - c).abs() <= LINE_REL * env,
                "β={beta} m={m}: {c:e} vs line {q:e}"
            );
        }
    }
}

#[test]
fn av_peaks_near_beta_m_2_33_and_vanishes_at_whole_periods() {
    // sin⁴x/x² is largest at x ≈ 1.1656 (tan x = 2x); m = 2π/β is a null
    let beta = 2.0 * std::f64::consts::PI / 64.0;
    let p = Process::from(Sinusoid::new(1.0, beta).unwrap());
    let peak = (1..200u64)
        .max_by(|&a, &b| {
            allan_variance(&p, a, RATE)
                .unwrap()
                .total_cmp(&allan_variance(&p, b, RATE).unwrap())
        })
        .unwrap();
    assert_eq!(peak, (2.0 * 1.1656 / beta).round() as u64);
    assert!(allan_variance(&p, 64, RATE).unwrap() < 1e-28);
}

#[test]
fn gradient_matches_central_differences() {
    // five-point differences, steps small against the 1/m turnover in β (truncation O(h⁴))
    let (a2, beta) = (2e-4, 0.9);
    for m in [1u64, 2, 7, 64, 4096] {
        let g = allan_variance_gradient(&Process::from(Sinusoid::new(a2, beta).unwrap()), m, RATE)
            .unwrap();
        let f = |a: f64, b: f64| {
            allan_variance(&Process::from(Sinusoid::new(a, b).unwrap()), m, RATE).unwrap()
        };
        let h = 1e-4 * beta / m as f64;
        let fd = (8.0 * (f(a2, beta + h) - f(a2, beta - h))
            - (f(a2, beta + 2.0 * h) - f(a2, beta - 2.0 * h)))
            / (12.0 * h);
        assert!(
            (g[1] - fd).abs() <= 1e-6 * g[1].abs().max(1e-300),
            "m={m}: {} vs {fd}",
            g[1]
        );
        // AV is linear in α²: ∂AV/∂α² = AV/α² (rounding only)
        assert!((g[0] - f(a2, beta) / a2).abs() <= 1e-15 * g[0]);
    }
}

#[test]
fn line_spectrum_is_not_a_function_and_acf_is_the_cosine() {
    let p = Process::from(Sinusoid::new(2.0, 0.7).unwrap());
    assert!(matches!(
        psd(&p, 1.0, RATE),
        Err(SpectralError::NotAFunction { process: "SIN", .. })
    ));
    for h in [0u64, 1, 5, 1000] {
        let want = (0.7 * h as f64).cos();
        assert!((p.autocovariance(h, RATE).unwrap() - want).abs() < 1e-12);
    }
}
