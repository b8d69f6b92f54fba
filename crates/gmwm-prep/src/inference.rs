//! Inference for a GMWM fit: delta-method covariance B V Bᵀ, confidence intervals with the
//! two-sided quantile z_{1−α/2}, the J goodness-of-fit test and the WIC, and model selection
//! among sub-models by WIC (REFERENCES §6).
//!
//! V is the covariance matrix of the observed moments ν̂. The AV estimates at different scales
//! are strongly correlated, so V should be a full matrix, e.g. the parametric bootstrap one of
//! [`crate::bootstrap`]; [`diagonal_covariance`] (from the curve's CIs) ignores the
//! correlations and gives optimistic standard errors; [`fit_covariance`] (the exact model
//! covariance of the AV at θ̂, [`model_covariance`]) accounts for them without a bootstrap.

use crate::curve::AvCurve;
use crate::error::{FitError, Result};
use crate::gmwm::{CovMatrix, GmwmFit, GmwmOptions, PhiRange, Weighting, fit, fit_with_starts};
use crate::stats::{chi2_sf, z_two_sided};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use processes::{Component, Model, ProcessKind};
use serde::{Deserialize, Serialize};

/// The J test of over-identifying restrictions.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, stats::chi2_sf};
/// use gmwm_prep::inference::{delta_method, fit_covariance};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let template: processes::Model = "WN + RW".parse()?;
/// let f = fit(&curve, &template, &GmwmOptions::default())?;
/// let j = delta_method(&f, &fit_covariance(&f)?, 0.05)?.j_test.unwrap();
/// assert_eq!(j.dof, 10 - 2); // scales − parameters
/// assert_eq!(j.p_value, chi2_sf(j.statistic, 8.0));
/// // as many scales as parameters: nothing to test
/// let f2 = fit(&curve.slice(0..2)?, &template, &GmwmOptions::default())?;
/// assert!(delta_method(&f2, &fit_covariance(&f2)?, 0.05)?.j_test.is_none());
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct JTest {
    /// J = eᵀ S⁺ e with e = ν̂ − ν(θ̂) and S = (I − AB) V (I − AB)ᵀ its asymptotic covariance
    /// (= the GMWM objective with Ω = V⁻¹ when the fit used that Ω).
    pub statistic: f64,
    /// Degrees of freedom J − p (number of scales minus number of parameters).
    pub dof: usize,
    /// P(χ²_dof > statistic).
    pub p_value: f64,
}

/// Delta-method inference for a fit.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}};
/// use gmwm_prep::inference::{delta_method, fit_covariance};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let inf = delta_method(&f, &fit_covariance(&f)?, 0.05)?;
/// assert_eq!(inf.alpha, 0.05);
/// for k in 0..2 {
///     // se is the root of the diagonal of B V Bᵀ
///     assert_eq!(inf.se[k], inf.cov_theta.get(k, k).sqrt());
///     // variances: CI = θ̂ e^{∓z se/θ̂}, so lo · hi = θ̂² (to rounding)
///     let (lo, hi) = inf.ci[k];
///     assert!(0.0 < lo && lo < f.theta[k] && f.theta[k] < hi);
///     assert!((lo * hi / (f.theta[k] * f.theta[k]) - 1.0).abs() < 1e-14);
/// }
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Inference {
    /// Significance level: intervals have coverage 1 − alpha.
    pub alpha: f64,
    /// Standard errors of θ̂ (per sample, same order as `theta`).
    pub se: Vec<f64>,
    /// CIs of θ̂: θ̂ ± z_{1−α/2}·se on the scale where θ is unconstrained (log for variances
    /// and β, log λ = log(−ln φ) for φ ∈ (0,1), atanh for φ ∈ (−1,1) and MA1's θ), mapped back.
    pub ci: Vec<(f64, f64)>,
    /// Covariance of θ̂, B V Bᵀ.
    pub cov_theta: CovMatrix,
    /// J test (None when there are as many scales as parameters).
    pub j_test: Option<JTest>,
    /// WIC = Q(θ̂) + 2 tr(Ω A B V).
    pub wic: f64,
    /// The objective Q(θ̂) with the fit's Ω.
    pub objective: f64,
}

/// V = diag(r_j ν̂_j²) from the curve's relative variances (ignores correlations).
///
/// ```
/// use gmwm_prep::{AvCurve, CurvePoint, inference::diagonal_covariance};
/// let mut p = CurvePoint::new(2, 0.02, 3.0);
/// p.edf = Some(2.0); // relative variance 2/edf = 1
/// let v = diagonal_covariance(&AvCurve::new(vec![p], 100.0, None)?);
/// assert_eq!(v.get(0, 0), 9.0);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn diagonal_covariance(curve: &AvCurve) -> CovMatrix {
    let r = curve.relative_variances();
    let d: Vec<f64> = curve
        .points
        .iter()
        .zip(&r)
        .map(|(p, r)| r * p.avar * p.avar)
        .collect();
    CovMatrix::diagonal(&d)
}

pub use crate::avcov::model_covariance;

/// [`model_covariance`] at a fit: the covariance (J×J) of its moments ν̂ under the fitted
/// model, at its scales and series length (Haar WV moments: ×¼; robust AV of efficiency e:
/// ×1/e, see [`crate::robust`]). With [`delta_method`] this
/// gives asymptotic standard errors that account for the correlation between scales without
/// a bootstrap — the honest default (unlike [`diagonal_covariance`]).
///
/// Errors: the fit's curve had no series length n.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, inference::{delta_method, fit_covariance}};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=18).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(1_000_000);
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let inf = delta_method(&f, &fit_covariance(&f)?, 0.05)?;
/// // WN σ² is known to ~0.2 % from 10^6 samples
/// assert!(inf.se[0] > 1e-7 && inf.se[0] < 5e-7);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn fit_covariance(fit: &GmwmFit) -> Result<CovMatrix> {
    let n = fit.n.ok_or_else(|| {
        FitError::InvalidArgument(
            "the model covariance needs the series length n of the curve (AvCurve::with_n)".into(),
        )
    })?;
    let mut v = model_covariance(&fit.model, &fit.m, fit.rate_hz, n)?;
    if fit.moments == crate::gmwm::Moments::HaarWaveletVariance {
        v.data.iter_mut().for_each(|x| *x *= 0.25);
    }
    let infl = crate::efficiency::inflation(fit.robust)?;
    if infl != 1.0 {
        v.data.iter_mut().for_each(|x| *x *= infl);
    }
    Ok(v)
}

fn phi_range_of(fit: &GmwmFit, at: usize) -> PhiRange {
    if fit.theta[at] > 0.0 {
        PhiRange::Positive
    } else {
        PhiRange::Symmetric
    }
}

/// The largest condition number of the column-scaled AᵀΩA (unit diagonal) for which a fit's
/// covariance is computed. Its inverse then carries a relative rounding error of at most about
/// 10¹² · 2.2·10⁻¹⁶ ≈ 2·10⁻⁴, within the 4 digits the standard errors are printed to; beyond
/// it the matrix is singular to this precision and the fit not identifiable. A fixed threshold
/// far from 1/ε also makes the verdict the same on every CPU: whether a Cholesky factorisation
/// of a matrix of condition ~10¹⁶ succeeds depends on the rounding of the last operations,
/// which differs between instruction sets (an x86-64 and an aarch64 build of the same fit of a
/// level-shifted record disagreed on it), while an eigenvalue ratio near 10⁻¹² is computed to
/// about 10⁻⁴ relative on each.
pub(crate) const MAX_CONDITION: f64 = 1e12;

/// B = (AᵀΩA)⁻¹AᵀΩ with column scaling for conditioning (p×J). AᵀΩA is singular when its
/// column-scaled condition number exceeds [`MAX_CONDITION`].
fn b_matrix(a: &Mat<f64>, omega: &Mat<f64>) -> Result<Mat<f64>> {
    let (j, p) = (a.nrows(), a.ncols());
    let s: Vec<f64> = (0..p)
        .map(|k| {
            let n = (0..j)
                .map(|i| {
                    let x = a[(i, k)] * omega[(i, i)].abs().sqrt();
                    x * x
                })
                .sum::<f64>()
                .sqrt();
            if n > 0.0 { 1.0 / n } else { 1.0 }
        })
        .collect();
    let a_s = Mat::from_fn(j, p, |i, k| a[(i, k)] * s[k]);
    let ato = a_s.transpose() * omega;
    let h = &ato * &a_s;
    let singular = || {
        FitError::Unidentifiable(
            "AᵀΩA is singular at θ̂: the parameters are not identifiable from these scales".into(),
        )
    };
    // eigenvalues in nondecreasing order; a failed decomposition (non-finite entries) is singular
    let eig = h
        .self_adjoint_eigenvalues(Side::Lower)
        .map_err(|_| singular())?;
    let (Some(&lo), Some(&hi)) = (eig.first(), eig.last()) else {
        return Err(singular());
    };
    if !(lo > 0.0 && hi <= lo * MAX_CONDITION) {
        return Err(singular());
    }
    let bs = h.llt(Side::Lower).map_err(|_| singular())?.solve(&ato);
    Ok(Mat::from_fn(p, j, |k, i| bs[(k, i)] * s[k]))
}

/// Delta-method inference (see module doc) with V the covariance of the observed moments.
///
/// Errors: [`FitError::NotIdentifiable`], naming the components, when AᵀΩA at θ̂ is singular:
/// its condition number, columns scaled to unit norm, above 10¹² (the standard errors would
/// not be determined to the 4 digits they are printed to, and the verdict would depend on the
/// CPU's rounding).
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, inference::{delta_method, diagonal_covariance}};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=18).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(1_000_000);
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let inf = delta_method(&f, &diagonal_covariance(&curve), 0.05)?;
/// assert!(inf.ci[0].0 < 1e-4 && 1e-4 < inf.ci[0].1);
/// assert_eq!(inf.j_test.unwrap().dof, 16);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn delta_method(fit: &GmwmFit, v: &CovMatrix, alpha: f64) -> Result<Inference> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(FitError::InvalidAlpha(alpha));
    }
    let j = fit.m.len();
    let p = fit.n_params();
    if v.n != j {
        return Err(FitError::InvalidMatrix(format!(
            "V is {}×{} but the fit has {j} scales",
            v.n, v.n
        )));
    }
    let a = fit.jacobian();
    let omega = fit.omega().to_mat();
    let vm = v.to_mat();
    let b = b_matrix(&a, &omega).map_err(|e| match e {
        FitError::Unidentifiable(_) => crate::diagnose::unidentifiable(fit),
        e => e,
    })?;
    let cov = &(&b * &vm) * b.transpose();
    let se: Vec<f64> = (0..p).map(|k| cov[(k, k)].max(0.0).sqrt()).collect();
    let z = z_two_sided(alpha);
    // per-parameter CI on its unconstrained scale
    let mut ci = Vec::with_capacity(p);
    let mut at = 0;
    for &kind in &fit.kinds {
        for (i, _) in kind.param_names().iter().enumerate() {
            let th = fit.theta[at + i];
            let s = se[at + i];
            let log_ci = |x: f64| {
                let r = (z * s / x.abs()).min(700.0);
                let (lo, hi) = (x.abs() * (-r).exp(), x.abs() * r.exp());
                if x < 0.0 { (-hi, -lo) } else { (lo, hi) }
            };
            let atanh_ci = |x: f64| {
                let zz = x.atanh();
                let sz = s / (1.0 - x * x);
                ((zz - z * sz).tanh(), (zz + z * sz).tanh())
            };
            let c = match (kind, i) {
                (ProcessKind::Ar1, 0) if phi_range_of(fit, at) == PhiRange::Positive => {
                    let lam = -th.ln();
                    let s_ll = s / (th * lam);
                    let (l_lo, l_hi) = (lam * (-z * s_ll).exp(), lam * (z * s_ll).exp());
                    ((-l_hi).exp(), (-l_lo).exp())
                }
                (ProcessKind::Ar1, 0) | (ProcessKind::Ma1, 0) => atanh_ci(th),
                _ => log_ci(th),
            };
            ci.push(c);
        }
        at += kind.n_params();
    }
    // residuals, objective, J test, WIC
    let e = Mat::from_fn(j, 1, |i, _| fit.observed[i] - fit.fitted[i]);
    let q = (e.transpose() * &omega * &e)[(0, 0)];
    let ab = &a * &b;
    let wic = q + 2.0 * (&(&omega * &ab) * &vm).diagonal().column_vector().sum();
    // no J test where the model gives some AV estimate no variance (a drift alone is
    // deterministic): the statistic is undefined there
    let degenerate = (0..j).any(|i| !(vm[(i, i)] > 0.0 && vm[(i, i)].is_finite()));
    let j_test = if j > p && !degenerate {
        let pmat = Mat::<f64>::identity(j, j) - &ab;
        let s = &(&pmat * &vm) * pmat.transpose();
        let d: Vec<f64> = (0..j).map(|i| vm[(i, i)].sqrt()).collect();
        let s_sc = Mat::from_fn(j, j, |x, y| s[(x, y)] / (d[x] * d[y]));
        let e_sc: Vec<f64> = (0..j).map(|i| e[(i, 0)] / d[i]).collect();
        let evd = s_sc
            .self_adjoint_eigen(Side::Lower)
            .map_err(|_| FitError::InvalidMatrix("eigendecomposition of S failed".into()))?;
        let vals = evd.S().column_vector();
        let vecs = evd.U();
        let dof = j - p;
        let mut stat = 0.0;
        for k in (j - dof)..j {
            let lk = vals[k];
            if lk <= 0.0 {
                continue;
            }
            let proj: f64 = (0..j).map(|i| vecs[(i, k)] * e_sc[i]).sum();
            stat += proj * proj / lk;
        }
        Some(JTest {
            statistic: stat,
            dof,
            p_value: chi2_sf(stat, dof as f64),
        })
    } else {
        None
    };
    Ok(Inference {
        alpha,
        se,
        ci,
        cov_theta: CovMatrix::from_mat(&cov),
        j_test,
        wic,
        objective: q,
    })
}

/// One candidate of a model selection.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::GmwmOptions};
/// use gmwm_prep::inference::{diagonal_covariance, select_by_wic};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let v = diagonal_covariance(&curve);
/// let c = select_by_wic(&curve, &"WN + RW".parse()?, &GmwmOptions::default(), &v)?;
/// for c in &c {
///     let template: processes::Model = c.template.parse()?;
///     assert_eq!(c.n_params, template.n_params());
///     // the fitted model is its template with values
///     assert_eq!(c.model.parse::<processes::Model>()?.template(), template);
/// }
/// assert!(c.windows(2).all(|w| w[0].wic <= w[1].wic)); // best first
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// The fitted sub-model (text form, per-sample values).
    pub model: String,
    /// Its template (e.g. `"WN + RW"`).
    pub template: String,
    /// Number of parameters.
    pub n_params: usize,
    /// Objective with the common Ω.
    pub objective: f64,
    /// WIC with the common Ω and V.
    pub wic: f64,
    /// Whether the optimizer converged.
    pub converged: bool,
}

/// The fit of the largest proper sub-model of `full` (most components first, then the order
/// of the components) that converges and is identifiable with `opts`; `None` if none is.
fn largest_fitting_submodel(curve: &AvCurve, full: &Model, opts: &GmwmOptions) -> Option<GmwmFit> {
    let kinds = full.kinds();
    let k = kinds.len().min(12);
    let mut masks: Vec<u32> = (1u32..(1 << k) - 1).collect();
    masks.sort_by_key(|m| std::cmp::Reverse(m.count_ones()));
    masks.into_iter().find_map(|mask| {
        let sub: Vec<Component> = (0..k)
            .filter(|i| mask & (1 << i) != 0)
            .map(|i| Component::Slot(kinds[i]))
            .collect();
        fit(curve, &Model::new(sub).ok()?, opts).ok()
    })
}

/// Largest number of distinct sub-models that [`select_by_wic`] fits all of; a larger class
/// is searched by backward elimination (see there).
pub const EXHAUSTIVE_MAX_SUBMODELS: usize = 24;
/// Starting points of each candidate fit in the backward search (see [`select_by_wic`]).
pub const CANDIDATE_STARTS: usize = 2;

/// Ranks sub-models of `full` (subsets of its components) by WIC, each fitted with one
/// common weighting matrix — the Ω of the full model's fit (of its largest sub-model that can
/// be fitted, when the full model's optimization fails or it has more parameters than the
/// curve has scales) — the WIC computed with the moments'
/// covariance `v` (best first). Sub-models with more parameters than scales, and those that
/// fail to converge or are not identifiable from these scales (singular AᵀΩA at their
/// estimate), are skipped; an empty list means none could be fitted.
///
/// # The search
/// - Up to [`EXHAUSTIVE_MAX_SUBMODELS`] distinct sub-models (e.g. the 24 of
///   `QN+WN+RW+2*AR1`): all of them are fitted.
/// - Beyond (e.g. `QN+WN+RW+BI+2*SIN+2*AR1`, 96): every sub-model of the core (the class
///   without BI and SIN, e.g. the 24 of `QN+WN+RW+2*AR1`), so the result is never worse in
///   WIC than the exhaustive search over the core; then backward elimination. From the full model, every
///   model with one component fewer is fitted and the one of least WIC kept, as long as it
///   improves the WIC (a model that cannot be fitted or identified counts as WIC = +∞, so the
///   search always moves off it); then the same from the kept model, down to one component.
///   At most k + (k−1) + … + 1 fits for k components (36 for 8, against 96), every fitted
///   model a candidate. The candidate fits start from the best [`CANDIDATE_STARTS`] grid
///   points and from warm starts ([`fit_with_starts`]): before the full model, a forward
///   chain from the whole core adds the BI/SIN components one at a time (e.g.
///   `QN+WN+RW+BI+2*AR1`, then `QN+WN+RW+BI+SIN+2*AR1`), each link and then the full model
///   also started from the best fitted model nested in it (least objective; with the one Ω
///   its objective bounds theirs); each model of the backward walk also from its parent's
///   optimum without the removed component. A model with two SINs has local optima far apart
///   (on the ADIS16405 imu1 gyro z curve objectives ~4 and ~3400, the grid reaching one or
///   the other as the CPU's last bits of rounding fell, so x86-64 and aarch64 walked
///   different paths); grown from its nested models it does not hang on that. Models the record cannot fit (more parameters than scales) or identify (a
///   component the data do not need vanishes: singular AᵀΩA) count as WIC = +∞, so the
///   search walks through them, and the core's exhaustive part covers what such a walk can
///   miss (on an exact WN + RW curve of 10 scales the walk alone ends at WN + AR1). Backward rather than forward: the small models miss whole regions of
///   the curve, and their WIC (dominated by that misfit) says little about which component to
///   add; the larger ones all describe the curve, and removing the component the data do not
///   need is what the WIC penalty measures. It finds the exhaustive optimum whenever the WIC
///   decreases along a path of single removals (the usual case: a superfluous component
///   costs its penalty without lowering the objective).
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::GmwmOptions};
/// use gmwm_prep::inference::{diagonal_covariance, select_by_wic};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let v = diagonal_covariance(&curve);
/// let c = select_by_wic(&curve, &"WN + RW".parse()?, &GmwmOptions::default(), &v)?;
/// // the sub-models WN, RW and WN + RW; on this exact curve each smaller one misses a
/// // component that dominates some scales, so the true model ranks first
/// assert_eq!(c.len(), 3);
/// assert_eq!(c[0].template, "WN + RW");
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn select_by_wic(
    curve: &AvCurve,
    full: &Model,
    opts: &GmwmOptions,
    v: &CovMatrix,
) -> Result<Vec<Candidate>> {
    // Ω from the full model's fit, or, when its optimization fails (e.g. a second AR1 the
    // data do not support), from the largest sub-model that can be fitted
    let full_fit = match fit(curve, full, opts) {
        Ok(f) => f,
        // a full model with more parameters than a short record has scales, too
        Err(
            e @ (FitError::OptimizationFailed(_)
            | FitError::Unidentifiable(_)
            | FitError::NotIdentifiable { .. }
            | FitError::TooFewScales { .. }),
        ) => largest_fitting_submodel(curve, full, opts).ok_or(e)?,
        Err(e) => return Err(e),
    };
    let omega = full_fit.omega();
    let om = omega.to_mat();
    let j = om.nrows();
    // V_Ω = Ω⁻¹, so that Weighting::Full(V_Ω) reproduces Ω.
    let om_inv = om
        .llt(Side::Lower)
        .map_err(|_| FitError::InvalidMatrix("Ω is not positive definite".into()))?
        .solve(Mat::<f64>::identity(j, j));
    let common = GmwmOptions {
        weighting: Weighting::Full(CovMatrix::from_mat(&om_inv)),
        ..opts.clone()
    };
    let kinds = full.kinds();
    let k = kinds.len();
    // the backward search fits bigger models than the exhaustive one; its candidates start
    // from the best CANDIDATE_STARTS grid points (the selected model is refitted by the
    // caller with all of `opts.n_starts`)
    let search = GmwmOptions {
        n_starts: common.n_starts.min(CANDIDATE_STARTS),
        ..common.clone()
    };
    if k > 12 {
        return Err(FitError::InvalidArgument(
            "model selection over more than 12 components is not supported".into(),
        ));
    }
    // one fit per distinct sub-model (memoized): Some(candidate), or None when it cannot be
    // fitted or identified
    let mut seen: Vec<(Vec<ProcessKind>, Option<Candidate>)> = Vec::new();
    type Seen = Vec<(Vec<ProcessKind>, Option<Candidate>)>;
    let evaluate = |seen: &mut Seen, sub: Vec<ProcessKind>| -> Result<Option<Candidate>> {
        if let Some((_, c)) = seen.iter().find(|(s, _)| *s == sub) {
            return Ok(c.clone());
        }
        let warm: Vec<Model> = best_nested(seen, &sub).into_iter().collect();
        let c = fit_candidate(curve, &sub, &common, v, j, &warm)?;
        seen.push((sub, c.clone()));
        Ok(c)
    };
    let subsets: Vec<Vec<ProcessKind>> = {
        let mut all: Vec<Vec<ProcessKind>> = Vec::new();
        for mask in 1u32..(1 << k) {
            let sub: Vec<ProcessKind> = (0..k)
                .filter(|i| mask & (1 << i) != 0)
                .map(|i| kinds[i])
                .collect();
            if !all.contains(&sub) {
                all.push(sub);
            }
        }
        all
    };
    if subsets.len() <= EXHAUSTIVE_MAX_SUBMODELS {
        for sub in subsets {
            evaluate(&mut seen, sub)?;
        }
    } else {
        // every sub-model of the core (the class without BI and SIN, e.g. QN+WN+RW+2*AR1),
        // when small enough: the search then never ends worse than the exhaustive one over it
        let core: Vec<Vec<ProcessKind>> = subsets
            .iter()
            .filter(|s| {
                s.iter()
                    .all(|k| !matches!(k, ProcessKind::BiasInstability(_) | ProcessKind::Sinusoid))
            })
            .cloned()
            .collect();
        if core.len() <= EXHAUSTIVE_MAX_SUBMODELS {
            let fitted: Vec<Result<Option<Candidate>>> = {
                use rayon::prelude::*;
                core.par_iter()
                    .map(|sub| fit_candidate(curve, sub, &search, v, j, &[]))
                    .collect()
            };
            for (sub, c) in core.into_iter().zip(fitted) {
                seen.push((sub, c?));
            }
        }
        // the forward chain from the whole core to the full model, one BI/SIN added at a
        // time (model order), each link warm-started from the best fitted model nested in it
        // (the previous link, or a better one): every link, and then the full model, starts
        // from where the smaller ones got, so the full model's optimum does not hang on
        // which local optimum its grid starts happen to reach
        let is_core =
            |k: &ProcessKind| !matches!(k, ProcessKind::BiasInstability(_) | ProcessKind::Sinusoid);
        let mut keep: Vec<bool> = kinds.iter().map(is_core).collect();
        for add in 0..k {
            if keep[add] {
                continue;
            }
            keep[add] = true;
            if keep.iter().all(|x| *x) {
                break;
            }
            let link: Vec<ProcessKind> = (0..k).filter(|&i| keep[i]).map(|i| kinds[i]).collect();
            if seen.iter().any(|(s, _)| *s == link) {
                continue;
            }
            let warm: Vec<Model> = best_nested(&seen, &link).into_iter().collect();
            let c = fit_candidate(curve, &link, &search, v, j, &warm)?;
            seen.push((link, c));
        }
        let wic_of = |c: &Option<Candidate>| c.as_ref().map_or(f64::INFINITY, |c| c.wic);
        let mut current = kinds.clone();
        let mut current_wic = wic_of(&evaluate(&mut seen, current.clone())?);
        while current.len() > 1 {
            // the children not fitted yet, in parallel (they are independent fits)
            // each child with its warm starts: the parent's optimum without the removed
            // component (one per distinct removal), and the best fitted model nested in it
            let parent = seen
                .iter()
                .find(|(s, _)| *s == current)
                .and_then(|(_, c)| c.as_ref())
                .map(|c| c.model.parse::<Model>())
                .transpose()?;
            let mut children: Vec<(Vec<ProcessKind>, Vec<Model>)> = Vec::new();
            for drop in 0..current.len() {
                let mut sub = current.clone();
                sub.remove(drop);
                let warm = match &parent {
                    Some(p) => {
                        let mut comps = p.components().to_vec();
                        comps.remove(drop);
                        Some(Model::new(comps)?)
                    }
                    None => None,
                };
                match children.iter_mut().find(|(s, _)| *s == sub) {
                    Some((_, w)) => {
                        if let Some(m) = warm
                            && !w.contains(&m)
                        {
                            w.push(m);
                        }
                    }
                    None => children.push((sub, warm.into_iter().collect())),
                }
            }
            for (sub, w) in &mut children {
                if let Some(m) = best_nested(&seen, sub)
                    && !w.contains(&m)
                {
                    w.push(m);
                }
            }
            let todo: Vec<&(Vec<ProcessKind>, Vec<Model>)> = children
                .iter()
                .filter(|(c, _)| !seen.iter().any(|(s, _)| s == c))
                .collect();
            let fitted: Vec<Result<Option<Candidate>>> = {
                use rayon::prelude::*;
                todo.par_iter()
                    .map(|(sub, warm)| fit_candidate(curve, sub, &search, v, j, warm))
                    .collect()
            };
            for ((sub, _), c) in todo.iter().zip(fitted) {
                seen.push((sub.clone(), c?));
            }
            let mut best: Option<(Vec<ProcessKind>, f64)> = None;
            for (sub, _) in children {
                let w = wic_of(&evaluate(&mut seen, sub.clone())?);
                if best.as_ref().is_none_or(|(_, b)| w < *b) {
                    best = Some((sub, w));
                }
            }
            match best {
                Some((sub, w)) if w < current_wic || current_wic.is_infinite() => {
                    current = sub;
                    current_wic = w;
                }
                _ => break,
            }
        }
    }
    let mut out: Vec<Candidate> = seen.into_iter().filter_map(|(_, c)| c).collect();
    out.sort_by(|a, b| a.wic.total_cmp(&b.wic));
    Ok(out)
}

/// The fitted model of least objective among the candidates in `seen` whose components are
/// a proper sub-multiset of `kinds` (a warm start for the fit of `kinds`, see
/// [`fit_with_starts`]); with one Ω for all candidates its objective bounds the fit's.
fn best_nested(
    seen: &[(Vec<ProcessKind>, Option<Candidate>)],
    kinds: &[ProcessKind],
) -> Option<Model> {
    let nested = |s: &[ProcessKind]| {
        s.len() < kinds.len() && {
            let mut left = kinds.to_vec();
            s.iter().all(|k| match left.iter().position(|x| x == k) {
                Some(i) => {
                    left.remove(i);
                    true
                }
                None => false,
            })
        }
    };
    seen.iter()
        .filter(|(s, _)| nested(s))
        .filter_map(|(_, c)| c.as_ref())
        .min_by(|a, b| a.objective.total_cmp(&b.objective))
        .and_then(|c| c.model.parse().ok())
}

/// The candidate of one sub-model with the common weighting, or None when it has more
/// parameters than the `j` scales, cannot be fitted or is not identifiable; `warm`: extra
/// starting points ([`fit_with_starts`]).
fn fit_candidate(
    curve: &AvCurve,
    sub: &[ProcessKind],
    common: &GmwmOptions,
    v: &CovMatrix,
    j: usize,
    warm: &[Model],
) -> Result<Option<Candidate>> {
    let template = Model::new(sub.iter().map(|&x| Component::Slot(x)).collect())?;
    if template.n_params() > j {
        return Ok(None);
    }
    // a sub-model that cannot be fitted or whose parameters are not identifiable from
    // these scales (e.g. an AR1 that collapsed onto another component) is not a candidate;
    // it must not abort the selection among the others
    let f = match fit_with_starts(curve, &template, common, warm) {
        Ok(f) => f,
        Err(
            FitError::OptimizationFailed(_)
            | FitError::Unidentifiable(_)
            | FitError::NotIdentifiable { .. },
        ) => return Ok(None),
        Err(e) => return Err(e),
    };
    let inf = match delta_method(&f, v, 0.05) {
        Ok(inf) => inf,
        Err(FitError::Unidentifiable(_) | FitError::NotIdentifiable { .. }) => return Ok(None),
        Err(e) => return Err(e),
    };
    Ok(Some(Candidate {
        model: f.model.to_string(),
        template: template.to_string(),
        n_params: f.n_params(),
        objective: inf.objective,
        wic: inf.wic,
        converged: f.convergence.converged,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two unit columns at angle δ (Ω = I): the scaled AᵀΩA is [[1, c], [c, 1]] with c = cos δ,
    /// eigenvalues 1 ± c, so its condition number is (1 + c)/(1 − c) ≈ 4/δ².
    fn two_columns(delta: f64) -> (Mat<f64>, Mat<f64>) {
        let a = Mat::from_fn(3, 2, |i, k| match (i, k) {
            (0, 0) => 1.0,
            (0, 1) => delta.cos(),
            (1, 1) => delta.sin(),
            _ => 0.0,
        });
        (a, Mat::<f64>::identity(3, 3))
    }

    #[test]
    fn singular_means_a_condition_number_above_max_condition() {
        // cond ≈ 4/δ²: 1e11 at δ = 6.32e-6, 1e13 at δ = 6.32e-7 (the threshold is 1e12)
        let (a, om) = two_columns(6.32e-6);
        let b = b_matrix(&a, &om).expect("condition 1e11 is below the threshold");
        // B A = I for a non-singular AᵀΩA, to the precision that condition allows (1e11 · ε)
        let ba = &b * &a;
        for (i, k) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            let want = if i == k { 1.0 } else { 0.0 };
            assert!((ba[(i, k)] - want).abs() < 1e-4, "{i},{k}: {}", ba[(i, k)]);
        }
        // condition 1e13 and 1e14: a Cholesky factorisation still succeeds there (the verdict
        // used to be whether it did), the threshold refuses both
        for delta in [6.32e-7, 2.0e-7] {
            let (a, om) = two_columns(delta);
            assert!(matches!(
                b_matrix(&a, &om),
                Err(FitError::Unidentifiable(_))
            ));
        }
        // exactly collinear columns, and a non-finite entry
        let (a, om) = two_columns(0.0);
        assert!(matches!(
            b_matrix(&a, &om),
            Err(FitError::Unidentifiable(_))
        ));
        let (mut a, om) = two_columns(0.5);
        a[(2, 0)] = f64::NAN;
        assert!(b_matrix(&a, &om).is_err());
    }
}
