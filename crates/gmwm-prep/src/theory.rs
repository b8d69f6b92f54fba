//! Theoretical Allan variance of models for the fitter, with the analytic gradient with
//! respect to each process's parameters (per sample, in the order of
//! [`processes::ProcessKind::param_names`]).
//!
//! A thin layer over the closed forms of the `spectral` crate
//! ([`spectral::allan_variance_with_gradient`]), which evaluates AR1/GM without
//! cancellation as φ → 1 and is checked there against the book's Lemma 4.2 sum and the
//! Lemma 4.1 quadrature. This module only adapts it to the flat parameter vectors of the
//! optimizer.

use crate::error::Result;
use processes::{Model, Process, ProcessKind};

/// AV at cluster size `m` (a whole number of samples ≥ 1, held as f64 by the optimizer) of
/// a process of `kind` with per-sample parameters `params`, writing ∂AV/∂params into
/// the first `params.len()` entries of `grad`. `rate_hz` is used by GM only.
///
/// Parameters outside the process's domain (which the optimizer's transforms only reach
/// through overflow, e.g. φ rounded to 1) give NaN value and gradient, which the optimizer
/// treats as a rejected step.
pub(crate) fn kind_avar_grad(
    kind: ProcessKind,
    params: &[f64],
    m: f64,
    rate_hz: f64,
    grad: &mut [f64],
) -> f64 {
    if let ProcessKind::BiasInstability(band) = kind
        && !band.is_auto()
        && params.len() == 1
        && params[0].is_finite()
        && params[0] > 0.0
    {
        // AV = B²·u(m) with u the band's unit AV: computed once per (band, m) and thread
        // (the optimizer evaluates the same scales thousands of times; u needs one GM
        // closed form per state)
        let u = bi_unit_avar(band, m as u64);
        if let Some(g) = grad.first_mut() {
            *g = 2.0 * params[0] * u;
        }
        return params[0] * params[0] * u;
    }
    // the closed forms of `spectral::closed_form` without the validation and the allocation
    // of the general route (the optimizer evaluates them millions of times)
    if m >= 1.0 && params.iter().all(|x| x.is_finite()) {
        let mu = m as u64;
        match kind {
            ProcessKind::Ar1 if params[1] > 0.0 && grad.len() >= 2 => {
                let (f, fp) = spectral::closed_form::ar1_unit_avar(params[0], mu);
                grad[0] = params[1] * fp;
                grad[1] = f;
                return params[1] * f;
            }
            ProcessKind::GaussMarkov
                if params[0] > 0.0 && params[1] > 0.0 && rate_hz > 0.0 && grad.len() >= 2 =>
            {
                let dt = 1.0 / rate_hz;
                let (h, h_l) = spectral::closed_form::gm_unit_avar(params[0] * dt, mu);
                grad[0] = params[1] * h_l * dt;
                grad[1] = h;
                return params[1] * h;
            }
            ProcessKind::Sinusoid
                if params[0] > 0.0
                    && params[1] > 0.0
                    && params[1] < std::f64::consts::PI
                    && grad.len() >= 2 =>
            {
                let (alpha2, beta) = (params[0], params[1]);
                let (sa, ca) = (0.5 * beta * m).sin_cos();
                let (sc, cc) = (0.5 * beta).sin_cos();
                let unit = sa.powi(4) / (m * m * sc * sc);
                grad[0] = unit;
                grad[1] = alpha2 / (m * m)
                    * (2.0 * m * sa.powi(3) * ca / (sc * sc) - sa.powi(4) * cc / sc.powi(3));
                return alpha2 * unit;
            }
            _ => {}
        }
        let linear = match kind {
            ProcessKind::WhiteNoise => Some(1.0 / m),
            ProcessKind::QuantizationNoise => Some(3.0 / (m * m)),
            ProcessKind::RandomWalk => Some(m / 3.0 + 1.0 / (6.0 * m)),
            _ => None,
        };
        if let (Some(k), Some(g)) = (linear, grad.first_mut())
            && params[0] > 0.0
        {
            *g = k;
            return params[0] * k;
        }
    }
    let evaluated = Process::from_params(kind, params)
        .ok()
        .and_then(|p| spectral::allan_variance_with_gradient(&p, m as u64, rate_hz).ok());
    match evaluated {
        Some((v, g)) => {
            // Callers may pass a longer scratch buffer: fill its first n_params entries.
            grad.iter_mut().zip(&g).for_each(|(o, x)| *o = *x);
            v
        }
        None => {
            grad.fill(f64::NAN);
            f64::NAN
        }
    }
}

thread_local! {
    static BI_UNIT: std::cell::RefCell<std::collections::HashMap<(u64, u64, u64), f64>> =
        std::cell::RefCell::new(std::collections::HashMap::new());
}

/// The AV at B = 1 of a BI over `band` at cluster size `m` (memoized per thread; NaN if the
/// closed form fails).
fn bi_unit_avar(band: processes::BiBand, m: u64) -> f64 {
    let key = (band.m_lo(), band.m_hi(), m);
    if let Some(u) = BI_UNIT.with(|c| c.borrow().get(&key).copied()) {
        return u;
    }
    let u = processes::BiasInstability::new(1.0, band)
        .ok()
        .and_then(|b| spectral::allan_variance(&Process::from(b), m, 1.0).ok())
        .unwrap_or(f64::NAN);
    BI_UNIT.with(|c| {
        let mut c = c.borrow_mut();
        if c.len() > 1 << 16 {
            c.clear();
        }
        c.insert(key, u);
    });
    u
}

/// AV of an AR1 with unit innovation variance, f(φ, m), and ∂f/∂φ.
pub(crate) fn ar1_unit(phi: f64, m: f64) -> (f64, f64) {
    let mut g = [0.0; 7];
    let f = kind_avar_grad(ProcessKind::Ar1, &[phi, 1.0], m, 1.0, &mut g);
    (f, g[0])
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
    Ok(spectral::allan_variance(process, m, rate_hz)?)
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
    Ok(spectral::allan_variance_gradient(process, m, rate_hz)?)
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
    let mut g = [0.0; 7];
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
    let mut g = [0.0; 7];
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

    /// Agreement of two routes through the same closed form (rounding only).
    const CLOSED_FORM_REL_TOL: f64 = 1e-12;

    #[test]
    fn gradients_match_central_differences() {
        // Checks the adapter's parameter order and the Jacobian the optimizer sees.
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
            (ProcessKind::Sinusoid, vec![2e-4, 0.9]),
            (ProcessKind::Sinusoid, vec![1.0, 0.01]),
            (
                ProcessKind::BiasInstability(processes::BiBand::new(1, 1 << 18).unwrap()),
                vec![3e-4],
            ),
        ];
        for (k, th) in cases {
            for &m in &[1.0, 2.0, 64.0, 4096.0, 262144.0] {
                let mut g = vec![0.0; th.len()];
                kind_avar_grad(k, &th, m, 100.0, &mut g);
                for i in 0..th.len() {
                    // φ: a step well inside (−1, 1) yet large enough against rounding.
                    let h = if k == ProcessKind::Ar1 && i == 0 {
                        1e-3 * (1.0 - th[0].abs()).min(1.0 / m)
                    } else if k == ProcessKind::Sinusoid && i == 1 {
                        // sin⁴(βm/2) turns over in Δβ ~ 1/m
                        1e-3 * th[1] / m
                    } else {
                        1e-5 * th[i].abs()
                    };
                    let mut t = vec![0.0; th.len()];
                    let mut at = |d: f64| {
                        let mut a = th.clone();
                        a[i] += d;
                        kind_avar_grad(k, &a, m, 100.0, &mut t)
                    };
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
    fn fast_paths_equal_the_spectral_closed_forms() {
        // the optimizer's allocation-free routes against `spectral::allan_variance_with_gradient`
        // (the same formulas, evaluated in the same order: rounding only)
        let band = processes::BiBand::new(2, 1 << 16).unwrap();
        let cases: Vec<(ProcessKind, Vec<f64>)> = vec![
            (ProcessKind::WhiteNoise, vec![2e-4]),
            (ProcessKind::QuantizationNoise, vec![3e-6]),
            (ProcessKind::RandomWalk, vec![1e-10]),
            (ProcessKind::Ar1, vec![0.995, 1e-7]),
            (ProcessKind::Ar1, vec![-0.6, 1e-3]),
            (ProcessKind::GaussMarkov, vec![0.5, 1e-5]),
            (ProcessKind::Sinusoid, vec![2e-4, 0.9]),
            (ProcessKind::BiasInstability(band), vec![3e-4]),
        ];
        for (k, th) in cases {
            let p = Process::from_params(k, &th).unwrap();
            for m in [1u64, 3, 64, 4096, 65536] {
                let mut g = vec![0.0; th.len()];
                let v = kind_avar_grad(k, &th, m as f64, 100.0, &mut g);
                let (v2, g2) = spectral::allan_variance_with_gradient(&p, m, 100.0).unwrap();
                assert!(
                    (v - v2).abs() <= CLOSED_FORM_REL_TOL * v2.abs(),
                    "{k} m={m}"
                );
                for (a, b) in g.iter().zip(&g2) {
                    assert!((a - b).abs() <= CLOSED_FORM_REL_TOL * b.abs(), "{k} m={m}");
                }
            }
        }
    }

    #[test]
    fn simple_closed_forms_and_errors() {
        let q = Process::from(processes::QuantizationNoise::new(2.0).unwrap());
        assert_eq!(process_avar(&q, 2, 1.0).unwrap(), 1.5); // 3Q²/m²
        let d = Process::from(processes::Drift::new(-3.0).unwrap());
        assert_eq!(process_avar(&d, 2, 1.0).unwrap(), 18.0); // ω²m²/2
        // MA1 at m = 1: γ(0) − γ(1) = σ²(1 + θ² − θ).
        let ma = Process::from(processes::Ma1::new(0.5, 2.0).unwrap());
        let v = process_avar(&ma, 1, 1.0).unwrap();
        assert!((v - 2.0 * 0.75).abs() < CLOSED_FORM_REL_TOL);
        assert!(process_avar(&ma, 0, 1.0).is_err());
        let mut g = [0.0; 2];
        assert!(kind_avar_grad(ProcessKind::Ar1, &[1.0, 1.0], 4.0, 1.0, &mut g).is_nan());
        assert!(g.iter().all(|x| x.is_nan()));
    }
}
