//! Closed forms against the book's Example 4.1, the ACF form of Lemma 4.2, REFERENCES §3
//! (Haar WV), and the analytic gradients against finite differences. The full
//! three-way table is in `three_ways.rs`.

mod common;
use common::fixtures::{RATE, fixtures};
use processes::{Ar1, Ma1, Process};
use spectral::tolerances::{FINITE_DIFF_REL, SUM_REL};
use spectral::{
    allan_variance, allan_variance_from_acf, allan_variance_gradient, haar_wavelet_variance,
};

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn book_acf_form_agrees_where_it_is_well_conditioned() {
    // The literal ACF form of Lemma 4.2 on ρ(h) = φ^h, for moderate φ.
    for phi in [-0.7, 0.2, 0.8] {
        let p = Process::from(Ar1::new(phi, 0.5).unwrap());
        let var = 0.5 / (1.0 - phi * phi);
        for m in [1u64, 2, 3, 10, 100] {
            let s = allan_variance_from_acf(var, |h| phi.powi(h as i32), m).unwrap();
            let c = allan_variance(&p, m, 1.0).unwrap();
            assert!(rel(c, s) <= SUM_REL, "phi={phi} m={m}: {c} vs {s}");
        }
    }
}

#[test]
fn ma1_reproduces_book_example_4_1() {
    // (1+θ²)σ²/m² · (m + (2m − 3) θ/(1+θ²)), the book's expression, for θ away from −1
    // where it is well conditioned.
    for (theta, s2) in [(0.5, 2.0), (-0.3, 1.0), (3.0, 0.1)] {
        let p = Process::from(Ma1::new(theta, s2).unwrap());
        for m in [1u64, 2, 3, 5, 64, 1000] {
            let mf = m as f64;
            let t2 = 1.0 + theta * theta;
            let book = t2 * s2 / (mf * mf) * (mf + (2.0 * mf - 3.0) * theta / t2);
            let c = allan_variance(&p, m, 1.0).unwrap();
            assert!(
                rel(c, book) <= SUM_REL,
                "theta={theta} m={m}: {c} vs {book}"
            );
        }
    }
}

#[test]
fn haar_wv_matches_references_section_3() {
    for (name, p) in fixtures() {
        let pr = p.params();
        for j in 1..=20u32 {
            let tau = 1u64 << j;
            let t = tau as f64;
            let v = haar_wavelet_variance(&p, tau, RATE).unwrap();
            let expect = match p {
                Process::WhiteNoise(_) => pr[0] / t,
                Process::QuantizationNoise(_) => 6.0 * pr[0] / (t * t),
                Process::RandomWalk(_) => pr[0] * (t * t + 2.0) / (12.0 * t),
                Process::Drift(_) => pr[0] * pr[0] * t * t / 16.0,
                // REFERENCES §3 AR1 form; well conditioned for |φ| ≤ 0.9 and moderate τ.
                Process::Ar1(a) if a.phi().abs() <= 0.9 => {
                    let (f, v2) = (a.phi(), a.sigma2());
                    v2 * ((f * f - 1.0) * t + 2.0 * f * (f.powf(t) - 4.0 * f.powf(t / 2.0) + 3.0))
                        / ((f - 1.0).powi(3) * (f + 1.0) * t * t)
                }
                _ => continue,
            };
            assert!(
                rel(v, expect) <= SUM_REL,
                "{name} tau={tau}: {v} vs {expect}"
            );
        }
    }
}

/// Central difference with one Richardson step: error O(h⁴).
fn richardson(f: impl Fn(f64) -> f64, x: f64, h: f64) -> f64 {
    let d = |h: f64| (f(x + h) - f(x - h)) / (2.0 * h);
    (4.0 * d(h / 2.0) - d(h)) / 3.0
}

#[test]
fn gradients_match_finite_differences() {
    for (name, p) in fixtures() {
        let kind = p.kind();
        let theta = p.params();
        for m in [1u64, 2, 3, 7, 64, 1000, 1 << 14, 1 << 20] {
            let g = allan_variance_gradient(&p, m, RATE).unwrap();
            for (k, &x) in theta.iter().enumerate() {
                // step: 1e-3 of the parameter, and within 1e-3 of the distance to φ = ±1
                let mut h = 1e-3 * if x == 0.0 { 1e-3 } else { x.abs() };
                if kind.code() == "AR1" && k == 0 {
                    h = h.min(1e-3 * (1.0 - x.abs()));
                }
                let f = |v: f64| {
                    let mut t = theta.clone();
                    t[k] = v;
                    allan_variance(&Process::from_params(kind, &t).unwrap(), m, RATE).unwrap()
                };
                let fd = richardson(f, x, h);
                // scale: |g| or, near a zero of the derivative, |AV|/|θ|
                let scale = g[k].abs().max(f(x) / x.abs().max(1e-300) * 1e-6);
                let err = (g[k] - fd).abs() / scale;
                assert!(
                    err <= FINITE_DIFF_REL,
                    "{name} m={m} d/d{}: analytic {:e} vs FD {:e} ({err:e})",
                    kind.param_names()[k],
                    g[k],
                    fd
                );
            }
        }
    }
}

#[test]
fn model_gradients_follow_with_params_order() {
    use processes::Model;
    use spectral::{
        model_allan_variance, model_allan_variance_gradient, model_haar_wavelet_variance,
        model_haar_wavelet_variance_gradient,
    };
    let model: Model =
        "QN(1e-6) + WN(1e-4) + RW(1e-9) + DR(2e-7) + AR1(0.999, 1e-7) + GM(0.05, 1e-6) + MA1(0.4, 1e-5)"
            .parse()
            .unwrap();
    let theta: Vec<f64> = model
        .processes()
        .unwrap()
        .iter()
        .flat_map(|p| p.params())
        .collect();
    for m in [1u64, 16, 4096] {
        let g = model_allan_variance_gradient(&model, m, RATE).unwrap();
        let gw = model_haar_wavelet_variance_gradient(&model, 2 * m, RATE).unwrap();
        assert_eq!(g.len(), theta.len());
        for k in 0..theta.len() {
            let mut h = 1e-3 * theta[k].abs();
            if k == 4 {
                h = h.min(1e-3 * (1.0 - theta[k])); // φ of the AR1
            }
            let f = |v: f64| {
                let mut t = theta.clone();
                t[k] = v;
                model_allan_variance(&model.with_params(&t).unwrap(), m, RATE).unwrap()
            };
            let fd = richardson(f, theta[k], h);
            // truncation O(h⁴) within FINITE_DIFF_REL, plus the FD roundoff ≈ ε|AV|/h
            let allowed = FINITE_DIFF_REL * g[k].abs() + 10.0 * f64::EPSILON * f(theta[k]) / h;
            assert!(
                (g[k] - fd).abs() <= allowed,
                "m={m} k={k}: {} vs {fd}",
                g[k]
            );
            assert!(rel(gw[k], 0.5 * g[k]) <= SUM_REL || g[k] == 0.0);
        }
        let wv = model_haar_wavelet_variance(&model, 2 * m, RATE).unwrap();
        assert!(rel(wv, 0.5 * model_allan_variance(&model, m, RATE).unwrap()) <= SUM_REL);
    }
}

#[test]
fn extreme_parameters_reach_their_limits() {
    use processes::GaussMarkov;
    // φ = 1 − 2^-52: the AR1 is a random walk with γ² = v² up to O(m(1−φ)) relative.
    let phi = 1.0 - f64::EPSILON;
    for m in [1u64, 4, 1000] {
        let p = Process::from(Ar1::new(phi, 1.0).unwrap());
        let rw = (2.0 * (m * m) as f64 + 1.0) / (6.0 * m as f64);
        let av = allan_variance(&p, m, 1.0).unwrap();
        assert!(
            rel(av, rw) <= 4.0 * m as f64 * f64::EPSILON,
            "m={m}: {av} vs {rw}"
        );
    }
    // GM with βΔt = 1e-200: AV = σ_G² (1 − φ²) · RW-factor → σ_G² 2L (2m²+1)/(6m),
    // dAV/dβ → σ_G² Δt 2 (2m²+1)/(6m), dAV/dσ_G² → 2L (2m²+1)/(6m); all to O(mL).
    let (rate, s2) = (10.0, 3.0);
    let beta = 1e-200 * rate;
    let l = beta / rate;
    for m in [1u64, 64, 1 << 30] {
        let p = Process::from(GaussMarkov::new(beta, s2).unwrap());
        let (av, g) = spectral::allan_variance_with_gradient(&p, m, rate).unwrap();
        let k = (2.0 * (m as f64).powi(2) + 1.0) / (6.0 * m as f64);
        assert!(rel(av, s2 * 2.0 * l * k) <= SUM_REL, "m={m}: {av:e}");
        assert!(
            rel(g[0], s2 * 2.0 * k / rate) <= SUM_REL,
            "m={m}: dbeta {:e}",
            g[0]
        );
        assert!(rel(g[1], 2.0 * l * k) <= SUM_REL, "m={m}: ds2 {:e}", g[1]);
    }
}
