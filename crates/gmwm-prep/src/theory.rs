//! Closed-form theoretical Allan variance of the latent processes (REFERENCES §2) and its
//! analytic gradient with respect to each process's parameters (per sample, in the order
//! of [`processes::ProcessKind::param_names`]).
//!
//! The AR1/GM forms are evaluated in a cancellation-free way: with λ = −ln φ (λ = βΔt for
//! GM) the numerator N = m − 3φ − mφ² + 4φ^{m+1} − φ^{2m+1} has a triple zero at λ = 0; we
//! write it as N = λ³ m(2m² + 1)/3 + Σ c_i r₃(a_i λ) with r₃(x) = 1 − e^{−x} − x + x²/2 − x³/6
//! evaluated by its series when (2m + 1)λ < 1, and as Σ c_i (1 − e^{−a_i λ}) via `expm1`
//! otherwise. This keeps full precision for φ → 1 (e.g. GM with a 1000 s correlation time
//! at 1 kHz), where the textbook formula loses up to 15 digits.

use crate::error::{FitError, Result};
use processes::{Model, Process, ProcessKind};

/// Switch between the series and the `expm1` evaluation of the AR1 numerator.
const SERIES_SWITCH: f64 = 1.0;
/// Switch (in φ) between the λ-form and the polynomial form of the AR1 AV.
const PHI_POLY_SWITCH: f64 = 0.5;

/// r₃(x) = 1 − e^{−x} − x + x²/2 − x³/6 and r₃'(x) = e^{−x} − 1 + x − x²/2.
fn r3(x: f64) -> (f64, f64) {
    if x < SERIES_SWITCH {
        // r3 = Σ_{k≥4} (−1)^{k+1} x^k / k!,  r3' = Σ_{k≥3} (−1)^k x^k / k!
        let mut term = x * x * x / 6.0; // x^3/3!
        let mut d = -term;
        term *= x / 4.0; // x^4/4!
        let mut v = -term;
        let mut sign = 1.0;
        for k in 5..40 {
            d += sign * term; // (−1)^{k−1} x^{k−1}/(k−1)!
            term *= x / k as f64;
            v += sign * term;
            sign = -sign;
            if term < 1e-18 * v.abs().max(1e-300) {
                break;
            }
        }
        (v, d)
    } else {
        let h = -(-x).exp_m1();
        (
            h - x + x * x / 2.0 - x * x * x / 6.0,
            (-x).exp() - 1.0 + x - x * x / 2.0,
        )
    }
}

/// N(λ) and dN/dλ for cluster size m (see module doc).
fn ar1_numerator(lambda: f64, m: f64) -> (f64, f64) {
    let a = [2.0, 1.0, m + 1.0, 2.0 * m + 1.0];
    let c = [m, 3.0, -4.0, 1.0];
    if (2.0 * m + 1.0) * lambda < SERIES_SWITCH {
        let l2 = lambda * lambda;
        let mut n = l2 * lambda * m * (2.0 * m * m + 1.0) / 3.0;
        let mut dn = l2 * m * (2.0 * m * m + 1.0);
        for i in 0..4 {
            let (v, d) = r3(a[i] * lambda);
            n += c[i] * v;
            dn += c[i] * a[i] * d;
        }
        (n, dn)
    } else {
        let mut n = 0.0;
        let mut dn = 0.0;
        for i in 0..4 {
            n += c[i] * -(-a[i] * lambda).exp_m1();
            dn += c[i] * a[i] * (-a[i] * lambda).exp();
        }
        (n, dn)
    }
}

/// AV of an AR1 with unit innovation variance, f(φ, m), and ∂f/∂φ.
pub(crate) fn ar1_unit(phi: f64, m: f64) -> (f64, f64) {
    if phi <= PHI_POLY_SWITCH {
        let pm = phi.powf(m);
        let p2m = pm * pm;
        let n = m - 3.0 * phi - m * phi * phi + 4.0 * pm * phi - p2m * phi;
        let dn = -3.0 - 2.0 * m * phi + 4.0 * (m + 1.0) * pm - (2.0 * m + 1.0) * p2m;
        let om = 1.0 - phi;
        let d = m * m * om * om * (1.0 - phi * phi);
        let dd = -2.0 * m * m * om * om * (1.0 + 2.0 * phi);
        (n / d, dn / d - n * dd / (d * d))
    } else {
        let lambda = -phi.ln();
        let (n, dn) = ar1_numerator(lambda, m);
        let eps = -(-lambda).exp_m1();
        let d = m * m * eps * eps * eps * (2.0 - eps);
        let dd = phi * m * m * eps * eps * (6.0 - 4.0 * eps);
        let df_dlambda = dn / d - n * dd / (d * d);
        (n / d, -df_dlambda / phi)
    }
}

/// AV of a GM with unit stationary variance as a function of λ = βΔt, and its λ-derivative.
fn gm_unit(lambda: f64, m: f64) -> (f64, f64) {
    let (n, dn) = ar1_numerator(lambda, m);
    let eps = -(-lambda).exp_m1();
    let phi = (-lambda).exp();
    let d = m * m * eps * eps;
    (n / d, dn / d - 2.0 * n * phi / (d * eps))
}

/// AV at cluster size `m` of a process of `kind` with per-sample parameters `params`,
/// writing ∂AV/∂params into `grad` (same length as `params`). `rate_hz` is used by GM only.
pub(crate) fn kind_avar_grad(
    kind: ProcessKind,
    params: &[f64],
    m: f64,
    rate_hz: f64,
    grad: &mut [f64],
) -> f64 {
    match kind {
        ProcessKind::WhiteNoise => {
            grad[0] = 1.0 / m;
            params[0] / m
        }
        ProcessKind::QuantizationNoise => {
            grad[0] = 3.0 / (m * m);
            params[0] * grad[0]
        }
        ProcessKind::RandomWalk => {
            grad[0] = (2.0 * m * m + 1.0) / (6.0 * m);
            params[0] * grad[0]
        }
        ProcessKind::Drift => {
            grad[0] = params[0] * m * m;
            params[0] * params[0] * m * m / 2.0
        }
        ProcessKind::Ar1 => {
            let (f, df) = ar1_unit(params[0], m);
            grad[0] = params[1] * df;
            grad[1] = f;
            params[1] * f
        }
        ProcessKind::GaussMarkov => {
            let (g, dg) = gm_unit(params[0] / rate_hz, m);
            grad[0] = params[1] * dg / rate_hz;
            grad[1] = g;
            params[1] * g
        }
        ProcessKind::Ma1 => {
            let (th, s2) = (params[0], params[1]);
            let core = (1.0 + th * th) * m + (2.0 * m - 3.0) * th;
            grad[0] = s2 * (2.0 * th * m + 2.0 * m - 3.0) / (m * m);
            grad[1] = core / (m * m);
            s2 * core / (m * m)
        }
    }
}

/// Theoretical AV of one process at cluster size `m` (samples), REFERENCES §2.
///
/// ```
/// use gmwm_prep::theory::process_avar;
/// use processes::{Process, RandomWalk};
/// let rw = Process::from(RandomWalk::new(1e-10)?);
/// assert_eq!(process_avar(&rw, 4, 100.0)?, 1e-10 * 33.0 / 24.0);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn process_avar(process: &Process, m: u64, rate_hz: f64) -> Result<f64> {
    let params = process.params();
    let mut g = vec![0.0; params.len()];
    check_m_rate(m, rate_hz)?;
    Ok(kind_avar_grad(
        process.kind(),
        &params,
        m as f64,
        rate_hz,
        &mut g,
    ))
}

/// Gradient ∂AV(m)/∂θ of one process, θ in the order of `Process::params()`.
///
/// ```
/// use gmwm_prep::theory::process_avar_gradient;
/// use processes::{Process, WhiteNoise};
/// let wn = Process::from(WhiteNoise::new(2.0)?);
/// assert_eq!(process_avar_gradient(&wn, 8, 1.0)?, vec![0.125]);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn process_avar_gradient(process: &Process, m: u64, rate_hz: f64) -> Result<Vec<f64>> {
    let params = process.params();
    let mut g = vec![0.0; params.len()];
    check_m_rate(m, rate_hz)?;
    kind_avar_grad(process.kind(), &params, m as f64, rate_hz, &mut g);
    Ok(g)
}

/// Theoretical AV of a fully specified model at each cluster size (the sum of its
/// components', book Cor. 4.1).
///
/// ```
/// use gmwm_prep::theory::model_avar;
/// let model: processes::Model = "WN(sigma2=1e-4) + QN(q2=1e-6)".parse()?;
/// let av = model_avar(&model, &[2, 4], 100.0)?;
/// assert!((av[0] - (1e-4 / 2.0 + 3e-6 / 4.0)).abs() < 1e-18);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn model_avar(model: &Model, m: &[u64], rate_hz: f64) -> Result<Vec<f64>> {
    let procs = model.processes()?;
    let mut out = vec![0.0; m.len()];
    for p in &procs {
        for (o, &mj) in out.iter_mut().zip(m) {
            *o += process_avar(p, mj, rate_hz)?;
        }
    }
    Ok(out)
}

fn check_m_rate(m: u64, rate_hz: f64) -> Result<()> {
    if m == 0 {
        return Err(FitError::InvalidArgument(
            "cluster size m must be ≥ 1".into(),
        ));
    }
    crate::curve::check_rate(rate_hz)
}

/// Model AV at scales `m` and its Jacobian (row-major J × p) for kinds and flat parameters.
pub(crate) fn model_avar_jac(
    kinds: &[ProcessKind],
    theta: &[f64],
    m: &[f64],
    rate_hz: f64,
    av: &mut [f64],
    jac: &mut [f64],
) {
    let p = theta.len();
    av.iter_mut().for_each(|x| *x = 0.0);
    let mut g = [0.0; 2];
    for (j, &mj) in m.iter().enumerate() {
        let mut at = 0;
        for &k in kinds {
            let n = k.n_params();
            av[j] += kind_avar_grad(k, &theta[at..at + n], mj, rate_hz, &mut g[..n]);
            jac[j * p + at..j * p + at + n].copy_from_slice(&g[..n]);
            at += n;
        }
    }
}

/// Each component's AV at scales `m` (one vector per component).
pub(crate) fn component_avars(
    kinds: &[ProcessKind],
    theta: &[f64],
    m: &[f64],
    rate_hz: f64,
) -> Vec<Vec<f64>> {
    let mut g = [0.0; 2];
    let mut at = 0;
    kinds
        .iter()
        .map(|&k| {
            let n = k.n_params();
            let v = m
                .iter()
                .map(|&mj| kind_avar_grad(k, &theta[at..at + n], mj, rate_hz, &mut g[..n]))
                .collect();
            at += n;
            v
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Agreement of two evaluations of the same closed form in well-conditioned regions.
    const CLOSED_FORM_REL_TOL: f64 = 1e-12;

    /// Book Lemma 4.2 with ρ(h) = φ^|h| (AR1, unit innovation variance), summed directly.
    fn lemma_4_2(phi: f64, m: u64) -> f64 {
        let s2 = 1.0 / (1.0 - phi * phi);
        let rho = |h: u64| phi.powi(h as i32);
        let mut acc = m as f64 * (1.0 - rho(m));
        for i in 1..m {
            acc += i as f64 * (2.0 * rho(m - i) - rho(i) - rho(2 * m - i));
        }
        s2 * acc / (m * m) as f64
    }

    #[test]
    fn ar1_matches_lemma_4_2_and_the_textbook_formula() {
        for &phi in &[-0.8, -0.2, 0.1, 0.45, 0.55, 0.7, 0.9] {
            for &m in &[1u64, 2, 3, 8, 32] {
                let (f, _) = ar1_unit(phi, m as f64);
                let l = lemma_4_2(phi, m);
                let mf = m as f64;
                let text = (mf - 3.0 * phi - mf * phi * phi + 4.0 * phi.powi(m as i32 + 1)
                    - phi.powi(2 * m as i32 + 1))
                    / (mf * mf * (1.0 - phi).powi(2) * (1.0 - phi * phi));
                assert!((f - l).abs() <= 1e-10 * l, "phi={phi} m={m}: {f} vs {l}");
                assert!((f - text).abs() <= 1e-10 * text, "phi={phi} m={m}");
            }
        }
    }

    #[test]
    fn ar1_near_unit_root_tends_to_random_walk() {
        // As φ → 1 with m fixed, AR1 AV / v² → the RW shape (2m² + 1)/(6m) (first order in λ:
        // relative deviation ≈ λ·m, so at λ = 1e-9 it must agree to ~1e-8 · m).
        let lambda: f64 = 1e-9;
        let phi = (-lambda).exp();
        for &m in &[1u64, 2, 16, 1024] {
            let mf = m as f64;
            let (f, _) = ar1_unit(phi, mf);
            let rw = (2.0 * mf * mf + 1.0) / (6.0 * mf);
            assert!(
                (f / rw - 1.0).abs() < 4.0 * lambda * mf + 1e-12,
                "m={m}: {f} vs {rw}"
            );
        }
    }

    #[test]
    fn branches_agree_at_the_switch() {
        // Series and expm1 evaluations of N agree on both sides of (2m+1)λ = 1.
        for &m in &[1.0f64, 4.0, 100.0] {
            let l = SERIES_SWITCH / (2.0 * m + 1.0);
            let (a, da) = ar1_numerator(l * (1.0 - 1e-9), m);
            let (b, db) = ar1_numerator(l * (1.0 + 1e-9), m);
            assert!((a / b - 1.0).abs() < 1e-8, "m={m}: {a} vs {b}");
            assert!((da / db - 1.0).abs() < 1e-8, "m={m}: {da} vs {db}");
        }
    }

    #[test]
    fn gradients_match_central_differences() {
        // Five-point differences: truncation O(h⁴), rounding O(ε f/(h f')) ≲ 1e-10 here.
        const FD_REL_TOL: f64 = 1e-6;
        let cases: Vec<(ProcessKind, Vec<f64>)> = vec![
            (ProcessKind::WhiteNoise, vec![2e-4]),
            (ProcessKind::QuantizationNoise, vec![3e-6]),
            (ProcessKind::RandomWalk, vec![1e-10]),
            (ProcessKind::Drift, vec![-2e-7]),
            (ProcessKind::Ar1, vec![0.995, 1e-7]),
            (ProcessKind::Ar1, vec![0.3, 1e-3]),
            (ProcessKind::Ar1, vec![-0.6, 1e-3]),
            (ProcessKind::Ar1, vec![0.99999, 1e-9]),
            (ProcessKind::GaussMarkov, vec![0.5, 1e-5]),
            (ProcessKind::Ma1, vec![0.4, 2.0]),
        ];
        for (k, th) in cases {
            for &m in &[1.0, 2.0, 64.0, 4096.0, 262144.0] {
                let mut g = vec![0.0; th.len()];
                kind_avar_grad(k, &th, m, 100.0, &mut g);
                for i in 0..th.len() {
                    // φ: a step well inside (−1, 1) yet large enough against rounding.
                    let h = if k == ProcessKind::Ar1 && i == 0 {
                        1e-3 * (1.0 - th[0].abs()).min(1.0 / m)
                    } else {
                        1e-5 * th[i].abs()
                    };
                    let mut t = vec![0.0; th.len()];
                    let mut at = |d: f64| {
                        let mut a = th.clone();
                        a[i] += d;
                        kind_avar_grad(k, &a, m, 100.0, &mut t)
                    };
                    // five-point stencil: truncation O(h⁴)
                    let fd = (8.0 * (at(h) - at(-h)) - (at(2.0 * h) - at(-2.0 * h))) / (12.0 * h);
                    let scale = g[i].abs().max(1e-300);
                    assert!(
                        (g[i] - fd).abs() <= FD_REL_TOL * scale,
                        "{k} {th:?} m={m} param {i}: analytic {} vs fd {fd}",
                        g[i]
                    );
                }
            }
        }
    }

    #[test]
    fn gm_is_the_ar1_of_the_book_map() {
        let (beta, s2, rate) = (0.2, 3e-6, 50.0);
        let gm = Process::from(processes::GaussMarkov::new(beta, s2).unwrap());
        let ar = Process::from(
            processes::GaussMarkov::new(beta, s2)
                .unwrap()
                .to_ar1(rate)
                .unwrap(),
        );
        for m in [1u64, 2, 64, 1 << 16] {
            let a = process_avar(&gm, m, rate).unwrap();
            let b = process_avar(&ar, m, rate).unwrap();
            assert!(
                (a - b).abs() <= CLOSED_FORM_REL_TOL * 1e3 * a,
                "m={m}: {a} vs {b}"
            );
        }
    }

    #[test]
    fn simple_closed_forms() {
        let q = Process::from(processes::QuantizationNoise::new(2.0).unwrap());
        assert_eq!(process_avar(&q, 2, 1.0).unwrap(), 1.5);
        let d = Process::from(processes::Drift::new(-3.0).unwrap());
        assert_eq!(process_avar(&d, 2, 1.0).unwrap(), 18.0);
        // MA1 at m = 1: γ(0) − γ(1) = σ²(1 + θ² − θ).
        let ma = Process::from(processes::Ma1::new(0.5, 2.0).unwrap());
        let v = process_avar(&ma, 1, 1.0).unwrap();
        assert!((v - 2.0 * 0.75).abs() < CLOSED_FORM_REL_TOL);
        assert!(process_avar(&ma, 0, 1.0).is_err());
    }
}
