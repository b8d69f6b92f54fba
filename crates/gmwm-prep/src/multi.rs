//! One model for several recordings of the same sensor, and a test that they share it.
//!
//! **Joint fit.** With R independent recordings, AV estimates ν̂_r at common cluster sizes and
//! their covariances V_r (the exact model covariance at the current θ, series length n_r,
//! [`crate::inference::model_covariance`]; ×1/e for robust AVs), the stacked GMWM objective
//! Σ_r (ν̂_r − ν(θ))ᵀ V_r⁻¹ (ν̂_r − ν(θ)) equals (ν̄ − ν(θ))ᵀ V̄⁻¹ (ν̄ − ν(θ)) + const with
//! V̄ = (Σ_r V_r⁻¹)⁻¹ and ν̄ = V̄ Σ_r V_r⁻¹ ν̂_r (the GLS combination of the curves). So the
//! joint estimate is the GMWM fit of the pooled curve ν̄ with Ω = V̄⁻¹, iterated with V_r
//! re-evaluated at the new θ (three steps), and its delta-method covariance is B V̄ Bᵀ.
//!
//! **Equality tests** (both reported):
//! - Wald test of equal parameters: each recording fitted alone (θ̂_r, delta-method covariance
//!   C_r with its own model covariance), mapped to the unconstrained scale η of the CIs (log of
//!   variances, log(−ln φ) for AR1 φ ∈ (0, 1), atanh otherwise);
//!   W = Σ_r (η̂_r − η̄)ᵀ C_r⁻¹ (η̂_r − η̄) with η̄ the precision-weighted mean,
//!   χ² with (R − 1)·p degrees of freedom under H0.
//! - Moment (J-type) test of equal AV curves: Σ_r (ν̂_r − ν̄)ᵀ V_r⁻¹ (ν̂_r − ν̄) at the joint
//!   fit, χ² with (R − 1)·J degrees of freedom (the part of the stacked objective that the
//!   common model cannot absorb, whatever the model).

use crate::curve::{AvCurve, CurvePoint};
use crate::error::{FitError, Result};
use crate::gmwm::{CovMatrix, GmwmFit, GmwmOptions, Moments, Weighting, fit};
use crate::inference::{Inference, delta_method, fit_covariance, model_covariance};
use crate::stats::chi2_sf;
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use processes::{Model, ProcessKind};
use serde::{Deserialize, Serialize};

/// A χ² test.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::GmwmOptions, multi::fit_joint, stats::chi2_sf};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let a = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let b = a.slice(0..8)?.with_n(50_000); // a shorter record: its first 8 scales
/// let j = fit_joint(&[a, b], &"WN + RW".parse()?, &GmwmOptions::default(), 0.05)?;
/// // (R − 1)·p and (R − 1)·J degrees of freedom: R = 2, p = 2, J = 8 common scales
/// assert_eq!((j.wald.dof, j.moments.dof), (2, 8));
/// for t in [j.wald, j.moments] {
///     assert_eq!(t.p_value, chi2_sf(t.statistic, t.dof as f64));
/// }
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ChiSquareTest {
    /// The statistic.
    pub statistic: f64,
    /// Degrees of freedom.
    pub dof: usize,
    /// P(χ²_dof > statistic).
    pub p_value: f64,
}

/// One recording fitted alone.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::GmwmOptions, multi::fit_joint};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let a = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let b = a.slice(0..8)?.with_n(50_000); // a shorter record: its first 8 scales
/// let j = fit_joint(&[a, b], &"WN + RW".parse()?, &GmwmOptions::default(), 0.05)?;
/// assert_eq!(j.single.len(), 2);
/// assert_eq!(j.single[1].fit.n, Some(50_000));
/// for s in &j.single {
///     assert_eq!(s.fit.m, m[..8]); // on the common scales
///     assert_eq!(s.inference.se.len(), s.fit.n_params());
/// }
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SingleFit {
    /// The fit (on the common scales).
    pub fit: GmwmFit,
    /// Its delta-method inference (V = model covariance at its own θ̂).
    pub inference: Inference,
}

/// The result of [`fit_joint`].
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::GmwmOptions, multi::fit_joint};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let a = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let b = a.slice(0..8)?.with_n(50_000); // a shorter record: its first 8 scales
/// let j = fit_joint(&[a, b], &"WN + RW".parse()?, &GmwmOptions::default(), 0.05)?;
/// assert_eq!(j.pooled.m(), m[..8]);
/// assert_eq!(j.fit.observed, j.pooled.avar()); // the joint fit is made on ν̄
/// for (k, p) in j.pooled.points.iter().enumerate() {
///     assert_eq!(p.var, Some(j.pooled_cov.get(k, k)));
/// }
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointFit {
    /// The joint fit (on the pooled curve ν̄, Ω = V̄⁻¹).
    pub fit: GmwmFit,
    /// Its delta-method inference with V̄ (CIs of the common parameters).
    pub inference: Inference,
    /// The pooled curve ν̄ (each point's `var` is the diagonal of V̄).
    pub pooled: AvCurve,
    /// V̄ = (Σ_r V_r⁻¹)⁻¹.
    pub pooled_cov: CovMatrix,
    /// Each recording alone.
    pub single: Vec<SingleFit>,
    /// Wald test of equal parameters across recordings.
    pub wald: ChiSquareTest,
    /// J-type test of equal AV curves across recordings.
    pub moments: ChiSquareTest,
}

fn inverse(v: &CovMatrix, what: &str) -> Result<Mat<f64>> {
    let m = v.to_mat();
    let n = m.nrows();
    // scale to unit diagonal for conditioning
    let d: Vec<f64> = (0..n).map(|i| m[(i, i)].abs().sqrt().max(1e-300)).collect();
    let s = Mat::from_fn(n, n, |i, j| m[(i, j)] / (d[i] * d[j]));
    let inv = s
        .llt(Side::Lower)
        .map_err(|_| FitError::InvalidMatrix(format!("{what} is not positive definite")))?
        .solve(Mat::<f64>::identity(n, n));
    Ok(Mat::from_fn(n, n, |i, j| inv[(i, j)] / (d[i] * d[j])))
}

/// The unconstrained coordinate of each parameter and its derivative dη/dθ.
fn eta_of(kinds: &[ProcessKind], theta: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut eta = Vec::with_capacity(theta.len());
    let mut d = Vec::with_capacity(theta.len());
    let mut at = 0;
    for &k in kinds {
        for i in 0..k.n_params() {
            let x = theta[at + i];
            let (e, de) = match (k, i) {
                (ProcessKind::Ar1, 0) if x > 0.0 => {
                    let l = -x.ln();
                    (l.ln(), -1.0 / (x * l))
                }
                (ProcessKind::Ar1, 0) | (ProcessKind::Ma1, 0) => (x.atanh(), 1.0 / (1.0 - x * x)),
                _ => (x.abs().ln(), 1.0 / x),
            };
            eta.push(e);
            d.push(de);
        }
        at += k.n_params();
    }
    (eta, d)
}

/// Fits one `template` to several recordings' AV curves (same sampling rate; the scales
/// common to all are used; each curve needs its series length n) and tests whether they share
/// it (module doc). `opts` drives the single fits (its `robust` flag says the curves are robust
/// AVs); the joint fit always uses Ω = V̄⁻¹. CIs at level 1 − `alpha`.
///
/// Errors: fewer than two curves, different rates, AV moments not selected, a curve without
/// n, fewer common scales than parameters, or any fit error.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::GmwmOptions, multi::fit_joint};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=16).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let a = AvCurve::from_m(&m, &av, 100.0)?.with_n(1_000_000);
/// let b = a.clone().with_n(500_000);
/// let j = fit_joint(&[a, b], &"WN + RW".parse()?, &GmwmOptions::default(), 0.05)?;
/// assert!((j.fit.theta[0] / 1e-4 - 1.0).abs() < 1e-6);
/// assert!(j.wald.statistic < 1e-6 && j.wald.dof == 2);
/// // the joint CI is narrower than either alone
/// let w = |c: (f64, f64)| c.1 - c.0;
/// assert!(w(j.inference.ci[0]) < w(j.single[0].inference.ci[0]));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_joint(
    curves: &[AvCurve],
    template: &Model,
    opts: &GmwmOptions,
    alpha: f64,
) -> Result<JointFit> {
    if curves.len() < 2 {
        return Err(FitError::InvalidArgument(format!(
            "a joint fit needs at least two recordings, got {}",
            curves.len()
        )));
    }
    if opts.moments != Moments::AllanVariance {
        return Err(FitError::InvalidArgument(
            "the joint fit works on AV moments".into(),
        ));
    }
    let rate = curves[0].rate_hz;
    for (i, c) in curves.iter().enumerate() {
        c.validate()?;
        if (c.rate_hz - rate).abs() > 1e-12 * rate {
            return Err(FitError::InvalidArgument(format!(
                "recording {i} is sampled at {} Hz, recording 0 at {rate} Hz",
                c.rate_hz
            )));
        }
        if c.n.is_none() {
            return Err(FitError::InvalidArgument(format!(
                "recording {i}: the joint fit needs the series length n of each curve"
            )));
        }
    }
    // common scales
    let common: Vec<u64> = curves[0]
        .m()
        .into_iter()
        .filter(|m| {
            curves[1..]
                .iter()
                .all(|c| c.points.iter().any(|p| p.m == *m))
        })
        .collect();
    let p = template.n_params();
    if common.len() < p {
        return Err(FitError::TooFewScales {
            what: format!("the joint {p}-parameter model {}", template.template()),
            needed: p,
            got: common.len(),
        });
    }
    let sub: Vec<AvCurve> = curves
        .iter()
        .map(|c| AvCurve {
            points: c
                .points
                .iter()
                .filter(|q| common.contains(&q.m))
                .copied()
                .collect(),
            ..c.clone()
        })
        .collect();
    let infl = crate::robust::inflation(opts.robust)?;
    // each alone
    let mut single = Vec::with_capacity(sub.len());
    for c in &sub {
        let f = fit(c, template, opts)?;
        let v = fit_covariance(&f)?;
        let inf = delta_method(&f, &v, alpha)?;
        single.push(SingleFit {
            fit: f,
            inference: inf,
        });
    }
    // joint: GLS pooling with V_r at the current θ
    let j = common.len();
    let nu: Vec<Vec<f64>> = sub.iter().map(|c| c.avar()).collect();
    let pool = |theta_model: &[&Model]| -> Result<(Vec<f64>, CovMatrix, Vec<Mat<f64>>)> {
        let mut prec = Mat::<f64>::zeros(j, j);
        let mut rhs = Mat::<f64>::zeros(j, 1);
        let mut invs = Vec::new();
        for (r, c) in sub.iter().enumerate() {
            let mut v = model_covariance(theta_model[r], &common, rate, c.n.unwrap_or(0))?;
            v.data.iter_mut().for_each(|x| *x *= infl);
            let vi = inverse(&v, "the AV covariance")?;
            let y = Mat::from_fn(j, 1, |a, _| nu[r][a]);
            rhs += &vi * &y;
            prec += &vi;
            invs.push(vi);
        }
        let vbar = inverse(&CovMatrix::from_mat(&prec), "Σ V_r⁻¹")?;
        let nubar = &vbar * &rhs;
        Ok((
            (0..j).map(|a| nubar[(a, 0)]).collect(),
            CovMatrix::from_mat(&vbar),
            invs,
        ))
    };
    let models: Vec<&Model> = single.iter().map(|s| &s.fit.model).collect();
    let (mut nubar, mut vbar, mut invs) = pool(&models)?;
    let mut joint: Option<GmwmFit> = None;
    for _ in 0..3 {
        let points: Vec<CurvePoint> = common
            .iter()
            .enumerate()
            .map(|(a, &m)| {
                let mut q = CurvePoint::new(m, m as f64 / rate, nubar[a]);
                q.var = Some(vbar.get(a, a));
                q
            })
            .collect();
        let pooled = AvCurve::new(points, rate, None)?;
        let o = GmwmOptions {
            weighting: Weighting::Full(vbar.clone()),
            ..opts.clone()
        };
        let f = fit(&pooled, template, &o)?;
        let ms: Vec<&Model> = vec![&f.model; sub.len()];
        let next = pool(&ms)?;
        joint = Some(f);
        nubar = next.0;
        vbar = next.1;
        invs = next.2;
    }
    // final fit on the last pooling
    let points: Vec<CurvePoint> = common
        .iter()
        .enumerate()
        .map(|(a, &m)| {
            let mut q = CurvePoint::new(m, m as f64 / rate, nubar[a]);
            q.var = Some(vbar.get(a, a));
            q
        })
        .collect();
    let pooled = AvCurve::new(points, rate, None)?;
    let start = joint.ok_or_else(|| FitError::OptimizationFailed("no joint step".into()))?;
    let o = GmwmOptions {
        weighting: Weighting::Full(vbar.clone()),
        ..opts.clone()
    };
    let f = fit(&pooled, template, &o).unwrap_or(start);
    let inference = delta_method(&f, &vbar, alpha)?;
    // moment test
    let mut jstat = 0.0;
    for (r, vi) in invs.iter().enumerate() {
        let e = Mat::from_fn(j, 1, |a, _| nu[r][a] - nubar[a]);
        jstat += (e.transpose() * vi * &e)[(0, 0)];
    }
    let jdof = (sub.len() - 1) * j;
    let moments = ChiSquareTest {
        statistic: jstat,
        dof: jdof,
        p_value: chi2_sf(jstat, jdof as f64),
    };
    // Wald test on the unconstrained scale
    let mut prec = Mat::<f64>::zeros(p, p);
    let mut rhs = Mat::<f64>::zeros(p, 1);
    let mut etas = Vec::new();
    let mut cinvs = Vec::new();
    for s in &single {
        let (eta, d) = eta_of(&s.fit.kinds, &s.fit.theta);
        let c = &s.inference.cov_theta;
        let ce = CovMatrix::from_mat(&Mat::from_fn(p, p, |a, b| d[a] * c.get(a, b) * d[b]));
        let ci = inverse(&ce, "the parameter covariance").map_err(|_| {
            FitError::Unidentifiable(
                "a recording's parameter covariance is singular: no Wald test".into(),
            )
        })?;
        let y = Mat::from_fn(p, 1, |a, _| eta[a]);
        rhs += &ci * &y;
        prec += &ci;
        etas.push(y);
        cinvs.push(ci);
    }
    let pinv = inverse(&CovMatrix::from_mat(&prec), "Σ C_r⁻¹")?;
    let etabar = &pinv * &rhs;
    let mut w = 0.0;
    for (y, ci) in etas.iter().zip(&cinvs) {
        let e = y - &etabar;
        w += (e.transpose() * ci * &e)[(0, 0)];
    }
    let wdof = (sub.len() - 1) * p;
    let wald = ChiSquareTest {
        statistic: w,
        dof: wdof,
        p_value: chi2_sf(w, wdof as f64),
    };
    Ok(JointFit {
        fit: f,
        inference,
        pooled,
        pooled_cov: vbar,
        single,
        wald,
        moments,
    })
}
