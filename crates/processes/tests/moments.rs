//! Acceptance: the sample mean, variance and lag-1..5 autocorrelation of 10^6 simulated
//! samples match the theory within 4 standard errors, for every stationary process and a
//! 3-component composite.
//!
//! Standard errors (all asymptotic in n = 10^6, stated in `common`):
//! - mean: the exact Var(x̄) = (1/n)[γ(0) + 2 Σ (1 − h/n) γ(h)] (long-run variance);
//! - variance: Bartlett's formula n Var(γ̂(0)) → (η − 3)γ(0)² + 2 Σ_h γ(h)², η the kurtosis
//!   of the driving iid noise (3 for Gaussian; 9/5 for QN's uniform U);
//! - autocorrelation: Bartlett's formula n Var(ρ̂(h)) → Σ_{k≥1} [ρ(k+h) + ρ(k−h) − 2ρ(h)ρ(k)]².
//!
//! These hold for linear processes driven by iid noise with a finite fourth moment: WN, AR1,
//! GM, MA1 (Gaussian), QN (X_t = U_t − U_{t−1}, uniform U), and sums of independent
//! Gaussian processes (Gaussian, hence linear in Gaussian innovations). The biases of the
//! estimators are O(1/n), far below these SEs (e.g. AR1 φ = 0.99: SE of ρ̂(1) is 1.4e-4,
//! bias of ρ̂(1) ≈ (1 + 3φ)/n ≈ 4e-6).

mod common;
use common::*;
use processes::Model;

const N: usize = 1_000_000;
const RATE_HZ: f64 = 100.0;
/// Kurtosis E U⁴ / (E U²)² of a uniform variable.
const ETA_UNIFORM: f64 = 9.0 / 5.0;
const ETA_GAUSS: f64 = 3.0;

fn check_moments(text: &str, seed: u64, eta: f64) {
    let model: Model = text.parse().expect("valid model");
    let x = model.simulate(N, RATE_HZ, seed).expect("simulates");
    let x = x.values();
    assert_within(
        &format!("{text}: mean"),
        mean(x),
        0.0,
        se_mean(&model, N, RATE_HZ),
    );
    let g0 = gamma(&model, 0, RATE_HZ);
    let v = acov(x, 0);
    assert_within(
        &format!("{text}: variance"),
        v,
        g0,
        se_variance(&model, N, RATE_HZ, eta),
    );
    for h in 1..=5u64 {
        let rho_hat = acov(x, h as usize) / v;
        let rho = model.autocorrelation(h, RATE_HZ).expect("stationary");
        assert_within(
            &format!("{text}: rho({h})"),
            rho_hat,
            rho,
            se_acf(&model, h, N, RATE_HZ),
        );
    }
}

#[test]
fn white_noise() {
    check_moments("WN(sigma2=2.5)", 101, ETA_GAUSS);
}

#[test]
fn quantization_noise() {
    // γ(0) = 2Q², ρ(1) = −1/2; the mean telescopes to (U_n − U_0)/n, SE √(2Q²)/n.
    check_moments("QN(q2=0.3)", 102, ETA_UNIFORM);
}

#[test]
fn ar1_for_several_phi() {
    for (i, phi) in [-0.7, 0.0, 0.5, 0.9, 0.99].into_iter().enumerate() {
        check_moments(
            &format!("AR1(phi={phi}, sigma2=1.5)"),
            103 + i as u64,
            ETA_GAUSS,
        );
    }
}

#[test]
fn gauss_markov() {
    // β = 2 /s at 100 Hz: φ = e^{−0.02} ≈ 0.980.
    check_moments("GM(beta=2, sigma2=4)", 110, ETA_GAUSS);
}

#[test]
fn ma1() {
    check_moments("MA1(theta=0.6, sigma2=2)", 111, ETA_GAUSS);
    check_moments("MA1(theta=-1.5, sigma2=0.5)", 112, ETA_GAUSS);
}

#[test]
fn three_component_composite() {
    check_moments(
        "WN(sigma2=1) + AR1(phi=0.95, sigma2=0.1) + MA1(theta=0.5, sigma2=0.5)",
        113,
        ETA_GAUSS,
    );
}

#[test]
fn example_2_4_composite_with_two_ar1() {
    check_moments(
        "AR1(phi=0.99, sigma2=0.01) + AR1(phi=-0.6, sigma2=1) + WN(sigma2=2)",
        114,
        ETA_GAUSS,
    );
}

#[test]
fn bartlett_sum_matches_the_ar1_closed_form() {
    // The generic Bartlett sum must equal the AR1 closed form
    // w_hh = (1 + φ²)(1 − φ^{2h}) / (1 − φ²) − 2h φ^{2h} (Brockwell & Davis Ex. 7.2.2).
    for phi in [-0.7f64, 0.5, 0.99] {
        let model: Model = format!("AR1(phi={phi}, sigma2=1)").parse().unwrap();
        for h in 1..=5 {
            let p2h = phi.powi(2 * h);
            let w = (1.0 + phi * phi) * (1.0 - p2h) / (1.0 - phi * phi) - 2.0 * h as f64 * p2h;
            let se = se_acf(&model, h as u64, 1, 1.0);
            assert!(
                (se * se - w).abs() <= 1e-9 * w,
                "phi {phi} h {h}: {} vs {w}",
                se * se
            );
        }
    }
}
