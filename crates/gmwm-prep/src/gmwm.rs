//! The GMWM-type estimator on the Allan variance (or Haar wavelet variance):
//!
//! θ̂ = argmin_θ (ν̂ − ν(θ))ᵀ Ω (ν̂ − ν(θ))  (Guerrier et al. 2013; REFERENCES §6)
//!
//! for any model of the `processes` crate, ν(θ) the sum of the components' closed-form AVs
//! ([`crate::theory`]) at the curve's cluster sizes.
//!
//! - **Weighting Ω.** [`Weighting::Diagonal`] (default): Ω = diag(1 / Var̂(ν̂_j)) with
//!   Var̂(ν̂_j) = r_j ν_j², r_j the relative variance of scale j carried by the curve
//!   ([`AvCurve::relative_variances`]: EDF, CI or variance), and ν_j = ν̂_j in a first step,
//!   then ν_j = ν_j(θ̂) of the fitted curve, iterated to a fixed point (the weights no longer correlate with the
//!   residuals, which removes the downward bias of plain 1/ν̂² weighting; both steps are
//!   consistent). [`Weighting::Full`]: Ω = V⁻¹ from a covariance matrix V of ν̂ (e.g. the
//!   parametric bootstrap one of [`crate::bootstrap`]), used as given.
//!   [`Weighting::ModelFull`] / [`Weighting::ModelDiagonal`]: iterated GMM weighting
//!   Ω = V(θ̂)⁻¹ (or its diagonal) with V the exact covariance of the AV estimator under the
//!   fitted model ([`crate::inference::model_covariance`]), starting from the diagonal fit.
//!   On the WN + 2·AR1 Monte Carlo (`cargo xtask gmwm-mc`) the full form lowers the RMSE of
//!   every parameter of the three test models (crates/gmwm-prep/mc-report.md), but each
//!   reweighting step computes one model covariance (~13 ms for 20 scales at n = 10^6; a
//!   6-component fit takes ~115 ms against ~5 ms), so the default stays the diagonal one.
//! - **Transforms.** Variances are fitted on the log scale; drift as log|ω| with a fixed sign;
//!   MA1's θ = tanh(η) (invertible branch); AR1 φ ∈ (0, 1) and GM β through λ = −ln φ (= βΔt),
//!   all AR1/GM components in one chain λ₁ = e^{η₁}, λ_k = λ_{k−1}·logistic(η_k), so
//!   φ₁ < φ₂ < … in model order (identifiable). [`PhiRange::Symmetric`] lets AR1's φ range over
//!   (−1, 1) via tanh instead (no ordering: then use a single AR1).
//! - **Starting values** (deterministic, no random search). With the nonlinear parameters
//!   fixed, ν(θ) is linear in the variances, so for every combination of AR1/GM correlation
//!   times taken on the curve's own scale grid (λ = 1/m_j, ordered) the variances are solved
//!   by weighted non-negative least squares (Lawson–Hanson). The `n_starts` best combinations
//!   start the optimizer.
//! - **Optimizer.** Levenberg–Marquardt on the whitened residuals with the analytic Jacobian
//!   (chain rule through the transforms), solved with faer's Cholesky.

pub use crate::cov_matrix::CovMatrix;
use crate::curve::AvCurve;
use crate::error::{FitError, Result};
use crate::theory::{ar1_unit, component_avars, kind_avar_grad, model_avar_jac};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use processes::{Component, Model, Process, ProcessKind};
use serde::{Deserialize, Serialize};

/// Which moments the curve holds.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions, Moments}};
/// // Haar WV of a white noise σ² = 1e-4, ν²_j = AV(m)/2 = σ²/(2m), stored at m.
/// let m = [1u64, 2, 4, 8];
/// let wv: Vec<f64> = m.iter().map(|&m| 1e-4 / (2.0 * m as f64)).collect();
/// let o = GmwmOptions { moments: Moments::HaarWaveletVariance, ..Default::default() };
/// let f = fit(&AvCurve::from_m(&m, &wv, 100.0)?, &"WN".parse()?, &o)?;
/// // the optimizer stops at a Gauss–Newton decrement of 1e-12 on the χ² scale; with unit
/// // relative variances (no n, CI or EDF) that leaves at most √1e-12 relative error
/// assert!((f.theta[0] / 1e-4 - 1.0).abs() < 1e-6);
/// assert_eq!(Moments::default(), Moments::AllanVariance);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum Moments {
    /// Allan variance at cluster sizes m (default).
    #[default]
    AllanVariance,
    /// Haar wavelet variance at dyadic levels τ_j = 2m, stored at `m = τ_j / 2`:
    /// ν²_j = AV(m)/2 (REFERENCES §3).
    HaarWaveletVariance,
}

impl Moments {
    fn factor(self) -> f64 {
        match self {
            Moments::AllanVariance => 1.0,
            Moments::HaarWaveletVariance => 0.5,
        }
    }
}

/// The weighting matrix Ω.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions, Weighting}, inference::diagonal_covariance};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let v = diagonal_covariance(&curve);
/// let o = GmwmOptions { weighting: Weighting::Full(v.clone()), ..Default::default() };
/// let f = fit(&curve, &"WN + RW".parse()?, &o)?;
/// // Full(V) is used as given: Ω = V⁻¹ (to rounding)
/// let omega = f.omega();
/// assert!((0..m.len()).all(|j| (omega.get(j, j) * v.get(j, j) - 1.0).abs() < 1e-14));
/// assert_eq!(Weighting::default(), Weighting::Diagonal);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub enum Weighting {
    /// Ω = diag(1/Var̂(ν̂_j)) from the curve's CIs/EDF/variances, two-step (module doc).
    #[default]
    Diagonal,
    /// Ω = V⁻¹ for the given covariance matrix V of ν̂ (one row/column per scale).
    Full(CovMatrix),
    /// Iterated model-based weighting, diagonal: starting from the [`Weighting::Diagonal`]
    /// fit θ̂₀, Ω_k = diag(V(θ̂_{k−1}))⁻¹ with V the exact covariance of the AV estimator
    /// under the fitted model ([`crate::inference::model_covariance`]), refitted
    /// `reweight_iterations` times or to a 1e-8 fixed point. Needs the curve's series
    /// length n ([`AvCurve::with_n`]).
    ModelDiagonal,
    /// As [`Weighting::ModelDiagonal`] with the full Ω_k = V(θ̂_{k−1})⁻¹ (the correlations
    /// between scales are used).
    ModelFull,
}

/// Range of the AR1 coefficient φ.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions, PhiRange}};
/// let truth: processes::Model = "AR1(phi=-0.5, sigma2=1)".parse()?;
/// let m: Vec<u64> = (0..6).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 1.0)?;
/// let curve = AvCurve::from_m(&m, &av, 1.0)?;
/// // a negative φ is reachable with the symmetric range only
/// let o = GmwmOptions { phi_range: PhiRange::Symmetric, ..Default::default() };
/// let sym = fit(&curve, &"AR1".parse()?, &o)?;
/// let pos = fit(&curve, &"AR1".parse()?, &GmwmOptions::default())?;
/// assert!(sym.theta[0] < 0.0 && pos.theta[0] > 0.0);
/// // AV(1)/(m AV(m)) → (1 − φ)²/(1 + φ): 4.5 here, < 1 for any φ > 0, so the positive
/// // range cannot reproduce the curve
/// assert!(sym.convergence.objective < pos.convergence.objective);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum PhiRange {
    /// φ ∈ (0, 1), several AR1/GM ordered by φ (default; the inertial-sensor case).
    #[default]
    Positive,
    /// φ ∈ (−1, 1) through tanh; no ordering among AR1s.
    Symmetric,
}

/// Options of [`fit`].
///
/// ```
/// let o = gmwm_prep::gmwm::GmwmOptions::default();
/// assert_eq!((o.n_starts, o.drift_sign), (4, 1.0));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GmwmOptions {
    /// AV (default) or Haar WV moments.
    pub moments: Moments,
    /// Weighting matrix.
    pub weighting: Weighting,
    /// Range of AR1's φ.
    pub phi_range: PhiRange,
    /// Number of deterministic starts (best grid combinations) refined by the optimizer.
    pub n_starts: usize,
    /// Iteration limit of each Levenberg–Marquardt run.
    pub max_iter: usize,
    /// Sign of the drift slope ω (the AV only determines |ω|): +1 or −1.
    pub drift_sign: f64,
    /// Diagonal weighting: number of reweighting steps after the first fit (weights from the
    /// fitted curve; 0 keeps Ω = diag(1/(r_j ν̂_j²))). Stops early at a 1e-8 fixed point.
    pub reweight_iterations: usize,
    /// `Some(e)`: the curve holds the robust AV of Gaussian efficiency e
    /// ([`crate::robust::robust_curve`]); the model covariance of the moments (model-based
    /// weighting, [`crate::inference::fit_covariance`]) is then inflated by 1/e, the upper
    /// bound of `avar::robust`. `None` (default): the classical AV.
    #[serde(default)]
    pub robust: Option<f64>,
}

impl Default for GmwmOptions {
    fn default() -> Self {
        Self {
            moments: Moments::AllanVariance,
            weighting: Weighting::Diagonal,
            phi_range: PhiRange::Positive,
            n_starts: 4,
            max_iter: 300,
            drift_sign: 1.0,
            reweight_iterations: 8,
            robust: None,
        }
    }
}

/// How the optimizer ended.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let mut av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// av.iter_mut().step_by(2).for_each(|a| *a *= 1.01); // not an exact curve: Q > 0
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let c = &f.convergence;
/// assert!(c.converged && c.start < c.starts);
/// // Q(θ̂) = eᵀ Ω e with e = ν̂ − ν(θ̂) (diagonal Ω: a sum of squares, rounding only)
/// let omega = f.omega();
/// let e: Vec<f64> = f.observed.iter().zip(&f.fitted).map(|(o, v)| o - v).collect();
/// let q: f64 = (0..m.len()).map(|j| omega.get(j, j) * e[j] * e[j]).sum();
/// assert!(c.objective > 0.0 && (q / c.objective - 1.0).abs() < 1e-12);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Convergence {
    /// True when a convergence criterion was met before the iteration limit.
    pub converged: bool,
    /// Levenberg–Marquardt iterations of the retained run (all steps).
    pub iterations: usize,
    /// ‖∇Q‖∞ in the unconstrained parameters at the solution.
    pub gradient_norm: f64,
    /// Objective Q(θ̂) = (ν̂ − ν(θ̂))ᵀ Ω (ν̂ − ν(θ̂)).
    pub objective: f64,
    /// Which start (0 = best grid point; the grid's come first, then the warm starts of
    /// [`fit_with_starts`]) gave the retained solution.
    pub start: usize,
    /// Number of starts run.
    pub starts: usize,
}

/// A fitted model.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let template: processes::Model = "WN + RW".parse()?;
/// let f = fit(&curve, &template, &GmwmOptions::default())?;
/// assert_eq!(f.kinds, template.kinds());
/// assert_eq!(f.model, template.with_params(&f.theta)?);
/// assert_eq!((&f.m, &f.tau, &f.observed), (&curve.m(), &curve.tau(), &curve.avar()));
/// // the fitted curve is the sum of the components'
/// for j in 0..m.len() {
///     assert_eq!(f.fitted[j], f.components.iter().map(|c| c[j]).sum::<f64>());
/// }
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GmwmFit {
    /// The fitted model (per-sample parameters).
    pub model: Model,
    /// Component kinds, in model order.
    pub kinds: Vec<ProcessKind>,
    /// Flat parameter vector θ̂ (model order, each in `param_names` order), per sample.
    pub theta: Vec<f64>,
    /// Optimizer report.
    pub convergence: Convergence,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Moments fitted.
    pub moments: Moments,
    /// Cluster sizes of the fitted scales (samples).
    pub m: Vec<u64>,
    /// Averaging times (s).
    pub tau: Vec<f64>,
    /// Observed moments ν̂.
    pub observed: Vec<f64>,
    /// Fitted moments ν(θ̂).
    pub fitted: Vec<f64>,
    /// Each component's moments at θ̂ (one vector per component).
    pub components: Vec<Vec<f64>>,
    /// The whitening matrix W (J×J row-major) with Ω = WᵀW actually used in the last step.
    pub whitening: CovMatrix,
    /// Series length of the curve, if known.
    pub n: Option<u64>,
    /// Gaussian efficiency of the robust AV the fit was made on (None: classical AV).
    #[serde(default)]
    pub robust: Option<f64>,
}

impl GmwmFit {
    /// Number of parameters p.
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}};
    /// let truth: processes::Model = "WN(sigma2=1e-4) + AR1(phi=0.99, sigma2=1e-7)".parse()?;
    /// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
    /// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
    /// let f = fit(&curve, &"WN + AR1".parse()?, &GmwmOptions::default())?;
    /// assert_eq!(f.n_params(), 3); // σ²; φ, σ²
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn n_params(&self) -> usize {
        self.theta.len()
    }
    /// The weighting matrix Ω = WᵀW.
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, inference::diagonal_covariance};
    /// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
    /// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
    /// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
    /// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
    /// // no reweighting: Ω = diag(1/(r_j ν̂_j²)), the inverse of the diagonal covariance
    /// let o = GmwmOptions { reweight_iterations: 0, ..Default::default() };
    /// let omega = fit(&curve, &"WN + RW".parse()?, &o)?.omega();
    /// let v = diagonal_covariance(&curve);
    /// assert!((0..m.len()).all(|j| (omega.get(j, j) * v.get(j, j) - 1.0).abs() < 1e-14));
    /// assert_eq!(omega.get(0, 1), 0.0);
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn omega(&self) -> CovMatrix {
        let w = self.whitening.to_mat();
        CovMatrix::from_mat(&(w.transpose() * &w))
    }
    /// Jacobian ∂ν/∂θ at θ̂ (J×p).
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}};
    /// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
    /// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
    /// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
    /// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
    /// let a = f.jacobian();
    /// assert_eq!((a.nrows(), a.ncols()), (10, 2));
    /// // the AV is linear in σ² and γ²: ν(θ̂) = A θ̂ (to rounding)
    /// for j in 0..10 {
    ///     let lin = a[(j, 0)] * f.theta[0] + a[(j, 1)] * f.theta[1];
    ///     assert!((lin / f.fitted[j] - 1.0).abs() < 1e-12);
    /// }
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn jacobian(&self) -> Mat<f64> {
        let m: Vec<f64> = self.m.iter().map(|&x| x as f64).collect();
        let (j, p) = (m.len(), self.theta.len());
        let mut av = vec![0.0; j];
        let mut jac = vec![0.0; j * p];
        model_avar_jac(
            &self.kinds,
            &self.theta,
            &m,
            self.rate_hz,
            &mut av,
            &mut jac,
        );
        let f = self.moments.factor();
        Mat::from_fn(j, p, |a, b| f * jac[a * p + b])
    }
}

/// Largest number of AR1/GM grid combinations tried for starting values.
const MAX_GRID_COMBOS: usize = 4000;
/// Largest number of grid combinations (λ of AR1/GM times β of SIN) for a model with SINs.
const MAX_SIN_GRID_COMBOS: f64 = 1000.0;
/// Largest change of any unconstrained coordinate in one optimizer step.
const MAX_STEP: f64 = 5.0;
/// Floor of the Marquardt scaling relative to the largest curvature.
const DAMPING_FLOOR: f64 = 1e-10;
/// Relative change of θ below which the reweighting has reached its fixed point.
const REWEIGHT_REL_TOL: f64 = 1e-8;
/// Bound on the unconstrained coordinates: e^{±690} stays a normal f64.
const ETA_BOUND: f64 = 690.0;
/// Smallest λ = −ln φ accepted (φ closer to 1 than this is a random walk in disguise).
const MIN_LAMBDA: f64 = 1e-13;

/// The problem in unconstrained coordinates.
pub(crate) struct Problem {
    kinds: Vec<ProcessKind>,
    offsets: Vec<usize>,
    p: usize,
    m: Vec<f64>,
    nu_hat: Vec<f64>,
    w: Mat<f64>,
    rate: f64,
    factor: f64,
    phi_range: PhiRange,
    drift_sign: f64,
    /// Components in the λ chain (AR1 in Positive mode, all GM).
    chain: Vec<usize>,
}

fn logistic(x: f64) -> f64 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

impl Problem {
    /// Smallest angular frequency β (rad per sample) a fitted SIN may take: one period within
    /// the longest fitted cluster size, 2π/m_max. A sinusoid of longer period shows no peak
    /// or dip over the fitted scales; its AV there rises like a drift's (τ²) and, through its
    /// turnover, can pass for a random walk's τ slope, so the AV cannot identify it (on a
    /// simulated WN + RW record of 3 hours a SIN of period 3.7·10^6 samples was selected in
    /// place of the RW before this bound).
    fn sin_beta_min(&self) -> f64 {
        let m_max = self.m.last().copied().unwrap_or(0.0);
        if m_max > 2.0 {
            2.0 * std::f64::consts::PI / m_max
        } else {
            0.0
        }
    }

    fn in_chain(&self, c: usize) -> bool {
        match self.kinds[c] {
            ProcessKind::GaussMarkov => true,
            ProcessKind::Ar1 => self.phi_range == PhiRange::Positive,
            _ => false,
        }
    }

    /// θ(η) and T = ∂θ/∂η (p×p); None when θ is not admissible.
    fn theta(&self, eta_in: &[f64]) -> Option<(Vec<f64>, Mat<f64>)> {
        let p = self.p;
        // keep every exp(η) a normal positive number (a vanishing component stays valid)
        let eta: Vec<f64> = eta_in
            .iter()
            .map(|x| x.clamp(-ETA_BOUND, ETA_BOUND))
            .collect();
        if eta.iter().any(|x| x.is_nan()) {
            return None;
        }
        let mut th = vec![0.0; p];
        let mut t = Mat::<f64>::zeros(p, p);
        let mut chain_lam = 0.0;
        let mut chain_dlog: Vec<(usize, f64)> = Vec::new();
        let mut first = true;
        for (c, &k) in self.kinds.iter().enumerate() {
            let at = self.offsets[c];
            match k {
                ProcessKind::WhiteNoise
                | ProcessKind::QuantizationNoise
                | ProcessKind::RandomWalk
                | ProcessKind::BiasInstability(_) => {
                    th[at] = eta[at].exp();
                    t[(at, at)] = th[at];
                }
                ProcessKind::Drift => {
                    th[at] = self.drift_sign * eta[at].exp();
                    t[(at, at)] = th[at];
                }
                ProcessKind::Ma1 => {
                    th[at] = eta[at].tanh();
                    t[(at, at)] = 1.0 - th[at] * th[at];
                    th[at + 1] = eta[at + 1].exp();
                    t[(at + 1, at + 1)] = th[at + 1];
                }
                ProcessKind::ArP(_) => {
                    // κ_k = tanh η_k (stationary for any η), φ = step-up(κ), σ² = e^η;
                    // ∂φ/∂η by central differences in η (step 1e-6)
                    let n = k.n_params() - 1;
                    let phi_of = |e: &[f64]| {
                        let kappa: Vec<f64> = e.iter().map(|x| x.tanh()).collect();
                        processes::ar_p::phi_from_pacf(&kappa)
                    };
                    let e0 = &eta[at..at + n];
                    if e0.iter().any(|x| x.tanh().abs() >= 1.0) {
                        return None;
                    }
                    let phi = phi_of(e0);
                    th[at..at + n].copy_from_slice(&phi);
                    for jj in 0..n {
                        let h = 1e-6;
                        let (mut up, mut dn) = (e0.to_vec(), e0.to_vec());
                        up[jj] += h;
                        dn[jj] -= h;
                        let (pu, pd) = (phi_of(&up), phi_of(&dn));
                        for ii in 0..n {
                            t[(at + ii, at + jj)] = (pu[ii] - pd[ii]) / (2.0 * h);
                        }
                    }
                    th[at + n] = eta[at + n].exp();
                    t[(at + n, at + n)] = th[at + n];
                }
                ProcessKind::Arma(pp, qq) => {
                    // φ: κ = tanh η, φ = step-up(κ) (stationary); θ = −step-up(tanh η)
                    // (invertible: the identifiability rule, the AV not telling a root from
                    // its inverse); σ² = e^η; the two Jacobian blocks by central differences
                    let (pp, qq) = (pp as usize, qq as usize);
                    let e0 = &eta[at..at + pp + qq];
                    if e0.iter().any(|x| x.tanh().abs() >= 1.0) {
                        return None;
                    }
                    let coef_of = |e: &[f64]| {
                        let kp: Vec<f64> = e[..pp].iter().map(|x| x.tanh()).collect();
                        let kq: Vec<f64> = e[pp..].iter().map(|x| x.tanh()).collect();
                        let mut c = processes::ar_p::phi_from_pacf(&kp);
                        c.extend(processes::arma::theta_from_pacf(&kq));
                        c
                    };
                    th[at..at + pp + qq].copy_from_slice(&coef_of(e0));
                    for jj in 0..pp + qq {
                        let h = 1e-6;
                        let (mut up, mut dn) = (e0.to_vec(), e0.to_vec());
                        up[jj] += h;
                        dn[jj] -= h;
                        let (cu, cd) = (coef_of(&up), coef_of(&dn));
                        let block = if jj < pp { 0..pp } else { pp..pp + qq };
                        for ii in block {
                            t[(at + ii, at + jj)] = (cu[ii] - cd[ii]) / (2.0 * h);
                        }
                    }
                    let n = pp + qq;
                    th[at + n] = eta[at + n].exp();
                    t[(at + n, at + n)] = th[at + n];
                }
                ProcessKind::Sinusoid => {
                    // α² = e^η, β = β_min + (π − β_min)·logistic(η) ∈ (β_min, π)
                    th[at] = eta[at].exp();
                    t[(at, at)] = th[at];
                    let s = logistic(eta[at + 1]);
                    let lo = self.sin_beta_min();
                    let span = std::f64::consts::PI - lo;
                    th[at + 1] = lo + span * s;
                    if !(th[at + 1] > 0.0 && th[at + 1] < std::f64::consts::PI) {
                        return None;
                    }
                    t[(at + 1, at + 1)] = span * s * (1.0 - s);
                }
                ProcessKind::Ar1 | ProcessKind::GaussMarkov => {
                    if self.in_chain(c) {
                        if first {
                            chain_lam = eta[at].exp();
                            chain_dlog = vec![(at, 1.0)];
                            first = false;
                        } else {
                            let s = logistic(eta[at]);
                            chain_lam *= s;
                            chain_dlog.push((at, 1.0 - s));
                        }
                        if !(chain_lam.is_finite() && chain_lam > MIN_LAMBDA) {
                            return None;
                        }
                        if k == ProcessKind::Ar1 {
                            let phi = (-chain_lam).exp();
                            th[at] = phi;
                            for &(i, d) in &chain_dlog {
                                t[(at, i)] = -phi * chain_lam * d;
                            }
                        } else {
                            th[at] = chain_lam * self.rate;
                            for &(i, d) in &chain_dlog {
                                t[(at, i)] = th[at] * d;
                            }
                        }
                    } else {
                        th[at] = eta[at].tanh();
                        if th[at].abs() >= 1.0 {
                            return None;
                        }
                        t[(at, at)] = 1.0 - th[at] * th[at];
                    }
                    th[at + 1] = eta[at + 1].exp();
                    t[(at + 1, at + 1)] = th[at + 1];
                }
                ProcessKind::Plp | ProcessKind::Fgn => {
                    let (v, dv) = crate::long_memory::memory_theta(k, eta[at + 1]);
                    if !v.is_finite() {
                        return None;
                    }
                    th[at] = eta[at].exp();
                    t[(at, at)] = th[at];
                    th[at + 1] = v;
                    t[(at + 1, at + 1)] = dv;
                }
            }
        }
        // the clamp has zero derivative: a coordinate held at its bound does not move θ
        for (i, x) in eta_in.iter().enumerate() {
            if x.abs() > ETA_BOUND {
                for r in 0..p {
                    t[(r, i)] = 0.0;
                }
            }
        }
        if th.iter().all(|x| x.is_finite()) {
            Some((th, t))
        } else {
            None
        }
    }

    /// η(θ) (inverse of [`Self::theta`]); chain components must be ordered.
    fn eta(&self, th: &[f64]) -> Vec<f64> {
        let mut eta = vec![0.0; self.p];
        let mut prev_lam: Option<f64> = None;
        for (c, &k) in self.kinds.iter().enumerate() {
            let at = self.offsets[c];
            match k {
                ProcessKind::WhiteNoise
                | ProcessKind::QuantizationNoise
                | ProcessKind::RandomWalk
                | ProcessKind::BiasInstability(_) => eta[at] = th[at].ln(),
                ProcessKind::Drift => eta[at] = th[at].abs().ln(),
                ProcessKind::Ma1 => {
                    eta[at] = th[at].clamp(-0.999, 0.999).atanh();
                    eta[at + 1] = th[at + 1].ln();
                }
                ProcessKind::ArP(_) => {
                    let n = k.n_params() - 1;
                    let kappa = processes::ArP::new(&th[at..at + n], th[at + n].max(1e-300))
                        .map(|a| a.pacf())
                        .unwrap_or_else(|_| vec![0.0; n]);
                    for (i, kk) in kappa.iter().enumerate() {
                        eta[at + i] = kk.clamp(-0.999_999, 0.999_999).atanh();
                    }
                    eta[at + n] = th[at + n].ln();
                }
                ProcessKind::Arma(pp, qq) => {
                    let (pp, qq) = (pp as usize, qq as usize);
                    let kp = processes::arma::pacf_of_phi(&th[at..at + pp])
                        .unwrap_or_else(|| vec![0.0; pp]);
                    // a non-invertible θ starts from θ = 0 (its mirror has the same AV)
                    let kq = processes::arma::pacf_of_theta(&th[at + pp..at + pp + qq])
                        .unwrap_or_else(|| vec![0.0; qq]);
                    for (i, kk) in kp.iter().chain(&kq).enumerate() {
                        eta[at + i] = kk.clamp(-0.999_999, 0.999_999).atanh();
                    }
                    eta[at + pp + qq] = th[at + pp + qq].ln();
                }
                ProcessKind::Sinusoid => {
                    eta[at] = th[at].ln();
                    let lo = self.sin_beta_min();
                    let r =
                        ((th[at + 1] - lo) / (std::f64::consts::PI - lo)).clamp(1e-12, 1.0 - 1e-12);
                    eta[at + 1] = (r / (1.0 - r)).ln();
                }
                ProcessKind::Ar1 | ProcessKind::GaussMarkov => {
                    if self.in_chain(c) {
                        let lam = if k == ProcessKind::Ar1 {
                            -th[at].ln()
                        } else {
                            th[at] / self.rate
                        };
                        match prev_lam {
                            None => eta[at] = lam.ln(),
                            Some(pl) => {
                                let r = (lam / pl).clamp(1e-12, 1.0 - 1e-9);
                                eta[at] = (r / (1.0 - r)).ln();
                            }
                        }
                        prev_lam = Some(match prev_lam {
                            None => lam,
                            Some(pl) => pl * (lam / pl).clamp(1e-12, 1.0 - 1e-9),
                        });
                    } else {
                        eta[at] = th[at].clamp(-0.999_999, 0.999_999).atanh();
                    }
                    eta[at + 1] = th[at + 1].ln();
                }
                ProcessKind::Plp | ProcessKind::Fgn => {
                    eta[at] = th[at].ln();
                    eta[at + 1] = crate::long_memory::memory_eta(k, th[at + 1]);
                }
            }
        }
        eta
    }

    /// Whitened residuals r = W(ν̂ − ν(θ)) and their Jacobian in η (J×p).
    fn residuals(&self, eta: &[f64], with_jac: bool) -> Option<(Vec<f64>, Mat<f64>, Vec<f64>)> {
        let (th, t) = self.theta(eta)?;
        let (j, p) = (self.m.len(), self.p);
        let mut av = vec![0.0; j];
        let mut jac = vec![0.0; j * p];
        model_avar_jac(&self.kinds, &th, &self.m, self.rate, &mut av, &mut jac);
        let d = Mat::from_fn(j, 1, |a, _| self.nu_hat[a] - self.factor * av[a]);
        let r = &self.w * &d;
        let res: Vec<f64> = (0..j).map(|a| r[(a, 0)]).collect();
        if !res.iter().all(|x| x.is_finite()) {
            return None;
        }
        let jr = if with_jac {
            let a = Mat::from_fn(j, p, |x, y| -self.factor * jac[x * p + y]);
            &(&self.w * &a) * &t
        } else {
            Mat::zeros(0, 0)
        };
        Some((res, jr, th))
    }

    fn objective(&self, eta: &[f64]) -> f64 {
        match self.residuals(eta, false) {
            Some((r, _, _)) => r.iter().map(|x| x * x).sum(),
            None => f64::INFINITY,
        }
    }

    /// Levenberg–Marquardt from `eta0`.
    fn levenberg_marquardt(&self, eta0: &[f64], max_iter: usize) -> (Vec<f64>, Convergence) {
        let p = self.p;
        let mut eta = eta0.to_vec();
        let mut conv = Convergence {
            converged: false,
            iterations: 0,
            gradient_norm: f64::INFINITY,
            objective: f64::INFINITY,
            start: 0,
            starts: 1,
        };
        let Some((mut r, mut jr, _)) = self.residuals(&eta, true) else {
            return (eta, conv);
        };
        let mut f: f64 = r.iter().map(|x| x * x).sum();
        let mut mu = -1.0;
        let mut nu = 2.0;
        for it in 0..max_iter {
            conv.iterations = it + 1;
            let jt = jr.transpose();
            let h = jt * &jr;
            let rv = Mat::from_fn(r.len(), 1, |a, _| r[a]);
            let g = jt * &rv;
            let gnorm = (0..p).map(|i| g[(i, 0)].abs()).fold(0.0, f64::max);
            conv.gradient_norm = 2.0 * gnorm;
            // Gauss–Newton decrement gᵀH⁻¹g: the largest decrease a full step could still
            // bring (invariant to the parametrization). Q is on a χ² scale, so a possible
            // decrease below 1e-12·(1 + Q) is irrelevant.
            let dec = newton_decrement(&h, &g);
            if gnorm == 0.0 || dec <= GN_DECREMENT_TOL * (1.0 + f) {
                conv.converged = true;
                break;
            }
            if mu < 0.0 {
                mu = 1e-3 * (0..p).map(|i| h[(i, i)]).fold(0.0, f64::max);
            }
            let mut accepted = false;
            let hmax = (0..p).map(|i| h[(i, i)]).fold(0.0, f64::max);
            for _ in 0..60 {
                let mut a = h.clone();
                for i in 0..p {
                    // Marquardt scaling, floored so that near-flat directions stay damped
                    a[(i, i)] += mu * h[(i, i)].max(DAMPING_FLOOR * hmax) + 1e-300;
                }
                let Ok(llt) = a.llt(Side::Lower) else {
                    mu *= nu;
                    nu *= 2.0;
                    continue;
                };
                let mut step = llt.solve(-&g);
                // trust region in η: at most MAX_STEP per coordinate (a factor e^MAX_STEP)
                let smax = (0..p).map(|i| step[(i, 0)].abs()).fold(0.0, f64::max);
                if smax > MAX_STEP {
                    let c = MAX_STEP / smax;
                    for i in 0..p {
                        step[(i, 0)] *= c;
                    }
                }
                let cand: Vec<f64> = (0..p).map(|i| eta[i] + step[(i, 0)]).collect();
                let f_new = self.objective(&cand);
                // predicted reduction of the Gauss–Newton model
                let mut pred = 0.0;
                for i in 0..p {
                    let mut hs = 0.0;
                    for k in 0..p {
                        hs += h[(i, k)] * step[(k, 0)];
                    }
                    pred -= step[(i, 0)] * (2.0 * g[(i, 0)] + hs);
                }
                if f_new.is_finite() && f_new < f {
                    let rho = (f - f_new) / pred.max(1e-300);
                    let rel = (f - f_new) / f.max(1e-300);
                    let smax = (0..p).map(|i| step[(i, 0)].abs()).fold(0.0, f64::max);
                    eta = cand;
                    mu *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                    nu = 2.0;
                    let (r2, j2, _) = self.residuals(&eta, true).expect("finite objective");
                    r = r2;
                    jr = j2;
                    f = f_new;
                    accepted = true;
                    if rel < 1e-13 || smax < 1e-11 {
                        conv.converged = true;
                    }
                    break;
                }
                mu *= nu;
                nu *= 2.0;
                if !mu.is_finite() {
                    break;
                }
            }
            if !accepted || conv.converged {
                if !accepted {
                    // no decrease possible: at a (numerical) minimum when the gradient is tiny
                    // relative to the curvature
                    conv.converged = dec <= GN_FLOOR_TOL * (1.0 + f);
                }
                break;
            }
        }
        // final gradient norm
        if let Some((r, jr, _)) = self.residuals(&eta, true) {
            let rv = Mat::from_fn(r.len(), 1, |a, _| r[a]);
            let g = jr.transpose() * &rv;
            conv.gradient_norm = 2.0 * (0..p).map(|i| g[(i, 0)].abs()).fold(0.0, f64::max);
        }
        conv.objective = f;
        (eta, conv)
    }
}

/// Convergence when the Gauss–Newton decrement is below this fraction of 1 + Q.
const GN_DECREMENT_TOL: f64 = 1e-12;
/// When no step decreases Q any more (rounding floor), the point counts as converged if the
/// decrement is below this fraction of 1 + Q.
const GN_FLOOR_TOL: f64 = 1e-8;

/// gᵀ(H + tiny ridge)⁻¹g.
fn newton_decrement(h: &Mat<f64>, g: &Mat<f64>) -> f64 {
    let p = h.nrows();
    let mut a = h.clone();
    for i in 0..p {
        a[(i, i)] += 1e-14 * h[(i, i)].abs() + 1e-300;
    }
    let x = match a.llt(Side::Lower) {
        Ok(l) => l.solve(g),
        Err(_) => return f64::INFINITY,
    };
    (0..p).map(|i| x[(i, 0)] * g[(i, 0)]).sum::<f64>().abs()
}

/// Non-negative least squares min ‖A x − b‖, x ≥ 0 (Lawson–Hanson), A given by columns.
pub(crate) fn nnls(cols: &[Vec<f64>], b: &[f64]) -> (Vec<f64>, f64) {
    let n = cols.len();
    let rows = b.len();
    // scale columns to unit norm for the tolerances
    let norms: Vec<f64> = cols
        .iter()
        .map(|c| c.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300))
        .collect();
    let a = |i: usize, k: usize| cols[k][i] / norms[k];
    let mut x = vec![0.0; n];
    let mut passive = vec![false; n];
    let resid = |x: &[f64]| -> Vec<f64> {
        (0..rows)
            .map(|i| b[i] - (0..n).map(|k| a(i, k) * x[k]).sum::<f64>())
            .collect()
    };
    let solve_passive = |passive: &[bool]| -> Vec<f64> {
        let idx: Vec<usize> = (0..n).filter(|&k| passive[k]).collect();
        let q = idx.len();
        let mut s = vec![0.0; n];
        if q == 0 {
            return s;
        }
        let mut h = Mat::<f64>::from_fn(q, q, |u, v| {
            (0..rows).map(|i| a(i, idx[u]) * a(i, idx[v])).sum()
        });
        for u in 0..q {
            h[(u, u)] *= 1.0 + 1e-12;
        }
        let rhs = Mat::<f64>::from_fn(q, 1, |u, _| (0..rows).map(|i| a(i, idx[u]) * b[i]).sum());
        let sol = match h.llt(Side::Lower) {
            Ok(l) => l.solve(&rhs),
            Err(_) => h.partial_piv_lu().solve(&rhs),
        };
        for (u, &k) in idx.iter().enumerate() {
            s[k] = sol[(u, 0)];
        }
        s
    };
    let tol = 1e-12 * (rows as f64);
    for _ in 0..3 * n + 3 {
        let r = resid(&x);
        let w: Vec<f64> = (0..n)
            .map(|k| (0..rows).map(|i| a(i, k) * r[i]).sum())
            .collect();
        let Some(t) = (0..n)
            .filter(|&k| !passive[k] && w[k] > tol)
            .max_by(|&u, &v| w[u].total_cmp(&w[v]))
        else {
            break;
        };
        passive[t] = true;
        for _ in 0..3 * n + 3 {
            let s = solve_passive(&passive);
            if (0..n).filter(|&k| passive[k]).all(|k| s[k] > 0.0) {
                x = s;
                break;
            }
            let mut alpha = 1.0f64;
            for k in 0..n {
                if passive[k] && s[k] <= 0.0 {
                    alpha = alpha.min(x[k] / (x[k] - s[k]));
                }
            }
            for k in 0..n {
                x[k] += alpha * (s[k] - x[k]);
                if passive[k] && x[k] <= 1e-15 {
                    passive[k] = false;
                    x[k] = 0.0;
                }
            }
        }
    }
    let r = resid(&x);
    let ss = r.iter().map(|v| v * v).sum();
    for k in 0..n {
        x[k] /= norms[k];
    }
    (x, ss)
}

/// Builds the whitening matrix W (Ω = WᵀW) from relative variances and reference values.
fn diag_whitening(reference: &[f64], rel_var: &[f64]) -> Mat<f64> {
    let j = reference.len();
    Mat::from_fn(j, j, |a, b| {
        if a == b {
            1.0 / (reference[a].abs() * rel_var[a].sqrt())
        } else {
            0.0
        }
    })
}

/// W = L⁻¹ for V = L Lᵀ, computed on the correlation scale for conditioning.
pub(crate) fn full_whitening(v: &CovMatrix) -> Result<Mat<f64>> {
    let j = v.n;
    let d: Vec<f64> = (0..j).map(|i| v.get(i, i)).collect();
    if let Some(x) = d.iter().find(|x| x.is_nan() || **x <= 0.0) {
        return Err(FitError::InvalidMatrix(format!(
            "covariance has a non-positive variance {x}"
        )));
    }
    let s: Vec<f64> = d.iter().map(|x| x.sqrt()).collect();
    let c = Mat::<f64>::from_fn(j, j, |a, b| v.get(a, b) / (s[a] * s[b]));
    let llt = c
        .llt(Side::Lower)
        .map_err(|_| FitError::InvalidMatrix("covariance is not positive definite".into()))?;
    let mut inv = Mat::<f64>::identity(j, j);
    llt.L().solve_lower_triangular_in_place(&mut inv);
    // W = L_C⁻¹ D⁻¹
    Ok(Mat::from_fn(j, j, |a, b| inv[(a, b)] / s[b]))
}

/// Shapes g_k(m_j) (AV per unit variance) of component `c` for given nonlinear parameter.
fn shape(kind: ProcessKind, nonlin: f64, m: &[f64], rate: f64, factor: f64) -> Vec<f64> {
    let mut g = [0.0; 7];
    m.iter()
        .map(|&mj| {
            factor
                * match kind {
                    ProcessKind::Drift => mj * mj / 2.0,
                    ProcessKind::Ar1 => ar1_unit(nonlin, mj).0,
                    ProcessKind::GaussMarkov => {
                        kind_avar_grad(kind, &[nonlin * rate, 1.0], mj, rate, &mut g)
                    }
                    ProcessKind::Ma1 => kind_avar_grad(kind, &[nonlin, 1.0], mj, rate, &mut g),
                    ProcessKind::Sinusoid => kind_avar_grad(kind, &[1.0, nonlin], mj, rate, &mut g),
                    ProcessKind::ArP(_) => {
                        let mut v = arp_start_phi(kind, nonlin);
                        v.push(1.0);
                        kind_avar_grad(kind, &v, mj, rate, &mut g)
                    }
                    ProcessKind::Arma(..) => {
                        let mut v = arma_start_coef(kind, nonlin);
                        v.push(1.0);
                        kind_avar_grad(kind, &v, mj, rate, &mut g)
                    }
                    ProcessKind::Plp | ProcessKind::Fgn => {
                        kind_avar_grad(kind, &[1.0, nonlin], mj, rate, &mut g)
                    }
                    k => kind_avar_grad(k, &[1.0], mj, rate, &mut g),
                }
        })
        .collect()
}

/// The AR(p) of a start: the damped oscillation at β rad/sample (the SIN grid), pole radius
/// r = e^{−β/2} (φ_1 = 2r cos β, φ_2 = −r², higher coefficients 0).
fn arp_start_phi(kind: ProcessKind, beta: f64) -> Vec<f64> {
    let n = kind.n_params() - 1;
    let r = (-0.5 * beta).exp();
    let mut phi = vec![0.0; n];
    phi[0] = 2.0 * r * beta.cos();
    phi[1] = -r * r;
    phi
}

/// The φ, θ of an ARMA start at β rad/sample (the SIN grid): p ≥ 2 the damped oscillation
/// of [`arp_start_phi`], p = 1 the AR1 φ = e^{−β} (AV largest near m ≈ 2/β), p = 0 (MA2)
/// none; θ = 0 (the MA part starts as white).
fn arma_start_coef(kind: ProcessKind, beta: f64) -> Vec<f64> {
    let ProcessKind::Arma(p, q) = kind else {
        return Vec::new();
    };
    let (p, q) = (p as usize, q as usize);
    let mut c = vec![0.0; p + q];
    if p >= 2 {
        let r = (-0.5 * beta).exp();
        c[0] = 2.0 * r * beta.cos();
        c[1] = -r * r;
    } else if p == 1 {
        c[0] = (-beta).exp();
    }
    c
}

/// All strictly increasing index tuples of length k from 0..n.
fn combinations(n: usize, k: usize) -> Vec<Vec<usize>> {
    let mut out = Vec::new();
    if k == 0 {
        out.push(Vec::new());
        return out;
    }
    if k > n {
        return out;
    }
    let mut idx: Vec<usize> = (0..k).collect();
    loop {
        out.push(idx.clone());
        let mut i = k;
        while i > 0 {
            i -= 1;
            if idx[i] != i + n - k {
                idx[i] += 1;
                for t in i + 1..k {
                    idx[t] = idx[t - 1] + 1;
                }
                break;
            }
            if i == 0 {
                return out;
            }
        }
    }
}

fn n_choose_k(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

impl Problem {
    /// The nonlinear parameter a start gives a component that is not gridded: d (PLP) or
    /// H (FGN) from the log-log slope of the curve's upper half
    /// ([`crate::long_memory::memory_start`]), 0 for the others (unused by their shapes).
    fn fixed_nonlin(&self, kd: ProcessKind) -> f64 {
        match kd {
            ProcessKind::Plp | ProcessKind::Fgn => {
                crate::long_memory::memory_start(kd, &self.m, &self.nu_hat)
            }
            _ => 0.0,
        }
    }

    /// Deterministic starting points (θ), best first.
    fn starts(&self, n_starts: usize) -> Vec<Vec<f64>> {
        let j = self.m.len();
        let ncomp = self.kinds.len();
        // candidate λ (per sample) on the curve's own grid: λ = 1/m_j, plus 2/m_1
        let mut lam: Vec<f64> = std::iter::once(2.0 / self.m[0])
            .chain(self.m.iter().map(|&m| 1.0 / m))
            .collect();
        let nonlin: Vec<usize> = (0..ncomp)
            .filter(|&c| matches!(self.kinds[c], ProcessKind::Ar1 | ProcessKind::GaussMarkov))
            .collect();
        let k = nonlin.len();
        let n_sin = self
            .kinds
            .iter()
            .filter(|k| {
                matches!(**k, ProcessKind::Sinusoid | ProcessKind::ArP(_))
                    || matches!(**k, ProcessKind::Arma(p, _) if p > 0)
            })
            .count();
        // with SINs the grid is their β combinations times the λ ones: the λ grid gets a
        // share of the budget (its square root for two SINs, measured to change neither
        // the ADIS16405 fits nor their WIC ranking while cutting the NNLS solves 4×)
        let lam_budget = if n_sin > 0 {
            MAX_SIN_GRID_COMBOS.powf(1.0 / (1.0 + n_sin as f64).max(1.0)) * 4.0
        } else {
            MAX_GRID_COMBOS as f64
        };
        while k > 0 && n_choose_k(lam.len(), k) > lam_budget && lam.len() > k {
            lam = lam.iter().step_by(2).cloned().collect();
        }
        let combos = combinations(lam.len(), k);
        let ma_grid: Vec<f64> = if self.kinds.contains(&ProcessKind::Ma1) {
            vec![-0.5, 0.0, 0.5]
        } else {
            vec![0.0]
        };
        // SIN: β whose AV peaks at a scale of the curve (sin⁴x/x² is largest at x ≈ 1.1656,
        // x = βm/2), ordered increasing for several SINs
        // (only periods within the fitted scales: β above 2π/m_max, see `sin_beta_min`)
        let beta_lo = self.sin_beta_min();
        let mut beta_grid: Vec<f64> = self
            .m
            .iter()
            .rev()
            .map(|&m| (2.0 * 1.1656 / m).min(3.0))
            .filter(|&b| b > beta_lo * 1.05)
            .collect();
        if beta_grid.is_empty() {
            beta_grid.push((2.0 * beta_lo).min(3.0));
        }
        beta_grid.dedup();
        let budget = (MAX_SIN_GRID_COMBOS / combos.len().max(1) as f64).max(1.0);
        while n_sin > 0 && n_choose_k(beta_grid.len(), n_sin) > budget && beta_grid.len() > n_sin {
            beta_grid = beta_grid.iter().step_by(2).cloned().collect();
        }
        let sin_combos = combinations(beta_grid.len(), n_sin);
        let wb: Vec<f64> = {
            let b = Mat::from_fn(j, 1, |a, _| self.nu_hat[a]);
            let wb = &self.w * &b;
            (0..j).map(|a| wb[(a, 0)]).collect()
        };
        let fixed: Vec<Option<Vec<f64>>> = (0..ncomp)
            .map(|c| match self.kinds[c] {
                ProcessKind::Ar1
                | ProcessKind::GaussMarkov
                | ProcessKind::Ma1
                | ProcessKind::Sinusoid
                | ProcessKind::ArP(_) => None,
                ProcessKind::Arma(p, _) if p > 0 => None,
                kd => Some(shape(
                    kd,
                    self.fixed_nonlin(kd),
                    &self.m,
                    self.rate,
                    self.factor,
                )),
            })
            .collect();
        let is_diag = (0..j).all(|a| (0..j).all(|b| a == b || self.w[(a, b)] == 0.0));
        let whiten = |g: &[f64]| -> Vec<f64> {
            if is_diag {
                return (0..j).map(|a| self.w[(a, a)] * g[a]).collect();
            }
            let v = Mat::from_fn(j, 1, |a, _| g[a]);
            let w = &self.w * &v;
            (0..j).map(|a| w[(a, 0)]).collect()
        };
        let fixed_w: Vec<Option<Vec<f64>>> = fixed
            .iter()
            .map(|g| g.as_ref().map(|g| whiten(g)))
            .collect();
        let mut scored: Vec<(f64, Vec<f64>, Vec<f64>, f64)> = Vec::new(); // (ss, coef, nonlin, ma)
        // the whitened shape of every grid value, computed once (the combinations reuse them)
        let shape_of =
            |kd: ProcessKind, v: f64| whiten(&shape(kd, v, &self.m, self.rate, self.factor));
        let mut cached: Vec<((ProcessKind, u64), Vec<f64>)> = Vec::new();
        for c in 0..ncomp {
            let kd = self.kinds[c];
            let values: Vec<f64> = match kd {
                ProcessKind::Ar1 => lam.iter().map(|l| (-l).exp()).collect(),
                ProcessKind::GaussMarkov => lam.clone(),
                ProcessKind::Ma1 => ma_grid.clone(),
                ProcessKind::Sinusoid | ProcessKind::ArP(_) => beta_grid.clone(),
                ProcessKind::Arma(p, _) if p > 0 => beta_grid.clone(),
                _ => Vec::new(),
            };
            for v in values {
                if !cached
                    .iter()
                    .any(|((k, b), _)| *k == kd && *b == v.to_bits())
                {
                    cached.push(((kd, v.to_bits()), shape_of(kd, v)));
                }
            }
        }
        let lookup = |kd: ProcessKind, v: f64| -> Vec<f64> {
            cached
                .iter()
                .find(|((k, b), _)| *k == kd && *b == v.to_bits())
                .map(|(_, g)| g.clone())
                .unwrap_or_else(|| shape_of(kd, v))
        };
        for (combo, sc) in combos
            .iter()
            .flat_map(|c| sin_combos.iter().map(move |s| (c, s)))
        {
            // chain order: first AR1/GM gets the largest λ (fastest)
            let lams: Vec<f64> = combo.iter().map(|&i| lam[i]).collect();
            let betas: Vec<f64> = sc.iter().map(|&i| beta_grid[i]).collect();
            for &th_ma in &ma_grid {
                let mut cols = Vec::with_capacity(ncomp);
                let mut nl = vec![0.0; ncomp];
                let mut q = 0;
                let mut qs = 0;
                for c in 0..ncomp {
                    match &fixed_w[c] {
                        Some(g) => cols.push(g.clone()),
                        None => {
                            let kd = self.kinds[c];
                            let v = match kd {
                                ProcessKind::Ma1 => th_ma,
                                ProcessKind::Sinusoid
                                | ProcessKind::ArP(_)
                                | ProcessKind::Arma(..) => {
                                    qs += 1;
                                    betas[qs - 1]
                                }
                                ProcessKind::Ar1 => {
                                    let l = lams[q];
                                    q += 1;
                                    (-l).exp()
                                }
                                _ => {
                                    let l = lams[q];
                                    q += 1;
                                    l
                                }
                            };
                            nl[c] = v;
                            cols.push(lookup(kd, v));
                        }
                    }
                }
                let (coef, ss) = nnls(&cols, &wb);
                scored.push((ss, coef, nl, th_ma));
            }
        }
        scored.sort_by(|a, b| a.0.total_cmp(&b.0));
        scored.truncate(n_starts.max(1));
        // floor for inactive components: 1e-3 of the largest variance the curve allows
        scored
            .into_iter()
            .map(|(_, coef, nl, _)| {
                let mut th = vec![0.0; self.p];
                for c in 0..ncomp {
                    let kd = self.kinds[c];
                    let at = self.offsets[c];
                    let nlc = match kd {
                        ProcessKind::Plp | ProcessKind::Fgn => self.fixed_nonlin(kd),
                        _ => nl[c],
                    };
                    let g = shape(kd, nlc, &self.m, self.rate, self.factor);
                    let bound = (0..j)
                        .map(|a| self.nu_hat[a] / g[a].max(1e-300))
                        .fold(f64::INFINITY, f64::min);
                    let cv = if coef[c] > 1e-6 * bound {
                        coef[c]
                    } else {
                        1e-3 * bound
                    };
                    match kd {
                        ProcessKind::Drift => th[at] = self.drift_sign * cv.sqrt(),
                        // AV ∝ B²: the linear coefficient is B²
                        ProcessKind::BiasInstability(_) => th[at] = cv.sqrt(),
                        ProcessKind::Ar1 => {
                            th[at] = nl[c];
                            th[at + 1] = cv;
                        }
                        ProcessKind::GaussMarkov => {
                            th[at] = nl[c] * self.rate;
                            th[at + 1] = cv;
                        }
                        ProcessKind::Ma1 => {
                            th[at] = nl[c];
                            th[at + 1] = cv;
                        }
                        ProcessKind::Sinusoid => {
                            th[at] = cv;
                            th[at + 1] = nl[c];
                        }
                        ProcessKind::ArP(_) => {
                            let phi = arp_start_phi(kd, nl[c]);
                            th[at..at + phi.len()].copy_from_slice(&phi);
                            th[at + phi.len()] = cv;
                        }
                        ProcessKind::Arma(..) => {
                            let c = arma_start_coef(kd, nl[c]);
                            th[at..at + c.len()].copy_from_slice(&c);
                            th[at + c.len()] = cv;
                        }
                        ProcessKind::Plp | ProcessKind::Fgn => {
                            th[at] = cv;
                            th[at + 1] = nlc;
                        }
                        _ => th[at] = cv,
                    }
                }
                th
            })
            .collect()
    }

    fn run(&self, starts: &[Vec<f64>], max_iter: usize) -> Result<(Vec<f64>, Convergence)> {
        let mut best: Option<(Vec<f64>, Convergence)> = None;
        for (i, th) in starts.iter().enumerate() {
            let eta0 = self.eta(th);
            let (eta, mut conv) = self.levenberg_marquardt(&eta0, max_iter);
            conv.start = i;
            conv.starts = starts.len();
            if conv.objective.is_finite()
                && best
                    .as_ref()
                    .is_none_or(|(_, b)| conv.objective < b.objective * (1.0 - 1e-12))
            {
                best = Some((eta, conv));
            }
        }
        best.ok_or_else(|| FitError::OptimizationFailed("no start gave a finite objective".into()))
    }
}

/// Factor on the variance of a component that a warm start lacks ([`fit_with_starts`]): its
/// AV is 1e-10 of the best grid start's for that component (B and a drift's ω, whose AV goes
/// as their square, get its square root). Small enough that the start's objective is the
/// warm model's to ~1e-8 relative (each whitened residual moves by at most 1e-10·√(EDF/2)
/// times the component's share of the AV), so the fit ends at most there; a second start
/// from the same model gives the lacking components the grid start's full value, from
/// which they need not grow.
pub const WARM_START_SCALE: f64 = 1e-10;

impl Problem {
    /// The θ of each warm start (see [`fit_with_starts`]), with `grid` (the best grid start)
    /// filling the components it lacks.
    fn warm_starts(&self, warm: &[Model], grid: &[f64]) -> Result<Vec<Vec<f64>>> {
        let mut out = Vec::new();
        for w in warm {
            out.push(self.warm_start(w, grid, WARM_START_SCALE)?);
            if w.components().len() < self.kinds.len() {
                out.push(self.warm_start(w, grid, 1.0)?);
            }
        }
        Ok(out)
    }

    /// One warm start; `scale`: the factor on the variance of the components `warm` lacks.
    fn warm_start(&self, warm: &Model, grid: &[f64], scale: f64) -> Result<Vec<f64>> {
        let same = |a: ProcessKind, b: ProcessKind| {
            a == b
                || matches!(
                    (a, b),
                    (
                        ProcessKind::BiasInstability(_),
                        ProcessKind::BiasInstability(_)
                    )
                )
        };
        let mut th = grid.to_vec();
        let mut used = vec![false; self.kinds.len()];
        for comp in warm.components() {
            let Some(p) = comp.process() else {
                return Err(FitError::InvalidArgument(format!(
                    "a warm start needs values: {warm}"
                )));
            };
            let c = (0..self.kinds.len())
                .find(|&c| !used[c] && same(self.kinds[c], p.kind()))
                .ok_or_else(|| {
                    FitError::InvalidArgument(format!(
                        "the warm start {warm} has a component {} that the model lacks",
                        p.kind()
                    ))
                })?;
            used[c] = true;
            let at = self.offsets[c];
            let v = p.params();
            if v.len() != self.kinds[c].n_params() {
                return Err(FitError::InvalidArgument(format!(
                    "the warm start's {} has {} parameters, not {}",
                    p.kind(),
                    v.len(),
                    self.kinds[c].n_params()
                )));
            }
            th[at..at + v.len()].copy_from_slice(&v);
        }
        for c in (0..self.kinds.len()).filter(|&c| !used[c]) {
            let at = self.offsets[c];
            let kd = self.kinds[c];
            let n = kd.n_params();
            match kd {
                ProcessKind::BiasInstability(_) | ProcessKind::Drift => th[at] *= scale.sqrt(),
                ProcessKind::Sinusoid | ProcessKind::Plp | ProcessKind::Fgn => th[at] *= scale,
                // the variance comes last: WN, QN, RW (one parameter), AR1, GM, MA1, AR(p), ARMA
                _ => th[at + n - 1] *= scale,
            }
        }
        // the λ chain in model order: φ increasing (AR1), β decreasing (GM), within a kind
        for kd in [ProcessKind::Ar1, ProcessKind::GaussMarkov] {
            let idx: Vec<usize> = self
                .chain
                .iter()
                .copied()
                .filter(|&c| self.kinds[c] == kd)
                .collect();
            let mut pairs: Vec<[f64; 2]> = idx
                .iter()
                .map(|&c| [th[self.offsets[c]], th[self.offsets[c] + 1]])
                .collect();
            if kd == ProcessKind::Ar1 {
                pairs.sort_by(|a, b| a[0].total_cmp(&b[0]));
            } else {
                pairs.sort_by(|a, b| b[0].total_cmp(&a[0]));
            }
            for (&c, v) in idx.iter().zip(pairs) {
                th[self.offsets[c]..self.offsets[c] + 2].copy_from_slice(&v);
            }
        }
        Ok(th)
    }
}

/// The template with every BI's AUTO band set to the curve's scales (first to last m).
pub(crate) fn resolve_bands(curve: &AvCurve, template: &Model) -> Result<Model> {
    let has_auto = template
        .kinds()
        .iter()
        .any(|k| matches!(k, ProcessKind::BiasInstability(b) if b.is_auto()));
    if !has_auto {
        return Ok(template.clone());
    }
    let (lo, hi) = match (curve.points.first(), curve.points.last()) {
        (Some(a), Some(b)) => (a.m, b.m),
        _ => (0, 0),
    };
    let band = processes::BiBand::new(lo, hi)?;
    Ok(template.with_bi_band(band)?)
}

/// Checks a template model for what the AV can identify.
fn check_template(model: &Model, phi_range: PhiRange) -> Result<Vec<ProcessKind>> {
    let kinds = model.kinds();
    // processes::Model already rejects duplicated WN/QN/RW/DR/MA1.
    let n_ar = kinds.iter().filter(|k| **k == ProcessKind::Ar1).count();
    if phi_range == PhiRange::Symmetric && n_ar > 1 {
        return Err(FitError::Unidentifiable(
            "several AR1 with φ ∈ (−1, 1) cannot be ordered; use PhiRange::Positive".into(),
        ));
    }
    Ok(kinds)
}

fn offsets(kinds: &[ProcessKind]) -> (Vec<usize>, usize) {
    let mut o = Vec::with_capacity(kinds.len());
    let mut at = 0;
    for k in kinds {
        o.push(at);
        at += k.n_params();
    }
    (o, at)
}

pub(crate) fn build_problem(
    curve: &AvCurve,
    kinds: Vec<ProcessKind>,
    opts: &GmwmOptions,
    reference: Option<&[f64]>,
) -> Result<Problem> {
    let j = curve.len();
    let nu_hat = curve.avar();
    let w = match &opts.weighting {
        Weighting::Diagonal | Weighting::ModelDiagonal | Weighting::ModelFull => {
            diag_whitening(reference.unwrap_or(&nu_hat), &curve.relative_variances())
        }
        Weighting::Full(v) => {
            if v.n != j {
                return Err(FitError::InvalidMatrix(format!(
                    "covariance is {}×{} but the curve has {j} scales",
                    v.n, v.n
                )));
            }
            full_whitening(v)?
        }
    };
    Ok(problem_with_whitening(curve, kinds, opts, w))
}

fn problem_with_whitening(
    curve: &AvCurve,
    kinds: Vec<ProcessKind>,
    opts: &GmwmOptions,
    w: Mat<f64>,
) -> Problem {
    let (offs, p) = offsets(&kinds);
    let nu_hat = curve.avar();
    let mut prob = Problem {
        kinds,
        offsets: offs,
        p,
        m: curve.points.iter().map(|q| q.m as f64).collect(),
        nu_hat,
        w,
        rate: curve.rate_hz,
        factor: opts.moments.factor(),
        phi_range: opts.phi_range,
        drift_sign: if opts.drift_sign < 0.0 { -1.0 } else { 1.0 },
        chain: Vec::new(),
    };
    prob.chain = (0..prob.kinds.len())
        .filter(|&c| prob.in_chain(c))
        .collect();
    prob
}

/// Fits `template` (its values, if any, are ignored) to the curve (see module doc).
///
/// Errors: an invalid curve (non-finite or non-positive AV, …), fewer scales than
/// parameters, several AR1 with [`PhiRange::Symmetric`], a bad covariance matrix.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, theory::model_avar};
/// let truth: processes::Model = "WN(sigma2=1e-4) + AR1(phi=0.99, sigma2=1e-7)".parse()?;
/// let m: Vec<u64> = (1..=16).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let f = fit(&curve, &"WN + AR1".parse()?, &GmwmOptions::default())?;
/// assert!(f.convergence.converged);
/// assert!((f.theta[1] - 0.99).abs() < 1e-8);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn fit(curve: &AvCurve, template: &Model, opts: &GmwmOptions) -> Result<GmwmFit> {
    fit_with_starts(curve, template, opts, &[])
}

/// [`fit`] with warm starts: besides the grid's `opts.n_starts` starting points, the
/// optimizer starts from each model of `warm` — a fitted model with values, typically the
/// optimum of a nested sub-model of `template` (fewer components; e.g. [`GmwmFit::model`]).
/// Each of its components goes to the first unused component of `template` of the same kind
/// (BI of any band); a component of `template` that it lacks takes its value from the best
/// grid start, its variance scaled by [`WARM_START_SCALE`] (practically absent; a second
/// start from the same model keeps the grid's value); AR1/GM of
/// one kind are then put in the order [`PhiRange::Positive`] needs (φ increasing). Of all
/// starts the solution of least objective is kept, a grid start's on a tie, so the fit is
/// never worse than [`fit`]'s with the same Ω. With one Ω for both fits (e.g.
/// [`Weighting::Full`]) the objective is at most the warm start's, i.e. the nested model's
/// plus the tiny contribution of the components it lacks (the optimizer only accepts
/// decreasing steps), whatever local optimum the grid starts reach: adding components can
/// then never raise the minimum found. ([`Weighting::Diagonal`] reweights Ω from the fitted
/// curve after the first fit; the warm starts enter that first fit.)
///
/// Errors: those of [`fit`], and a warm start without values or with a component that
/// `template` lacks ([`FitError::InvalidArgument`]).
///
/// ```
/// use gmwm_prep::{AvCurve, inference::diagonal_covariance, theory::model_avar};
/// use gmwm_prep::gmwm::{fit, fit_with_starts, GmwmOptions, Weighting};
/// let truth: processes::Model = "WN(sigma2=1e-4) + AR1(phi=0.99, sigma2=1e-7)".parse()?;
/// let m: Vec<u64> = (1..=16).map(|j| 1u64 << j).collect();
/// let mut av = model_avar(&truth, &m, 100.0)?;
/// av.iter_mut().step_by(2).for_each(|a| *a *= 1.01); // not an exact curve: Q > 0
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(1_000_000);
/// // one Ω for all fits, so that their objectives compare
/// let w = Weighting::Full(diagonal_covariance(&curve));
/// let o = GmwmOptions { weighting: w, ..Default::default() };
/// // WN + RW + AR1 warm-started from the fit of its sub-model WN + AR1
/// let sub = fit(&curve, &"WN + AR1".parse()?, &o)?;
/// let f = fit_with_starts(&curve, &"WN + RW + AR1".parse()?, &o, &[sub.model.clone()])?;
/// // the grid's, then two warm ones (RW practically absent, and RW at the grid's value)
/// assert_eq!(f.convergence.starts, o.n_starts + 2);
/// assert!(f.convergence.objective <= sub.convergence.objective * (1.0 + 1e-8));
/// // a component the template does not have is an error
/// assert!(fit_with_starts(&curve, &"WN".parse()?, &o, &[sub.model]).is_err());
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn fit_with_starts(
    curve: &AvCurve,
    template: &Model,
    opts: &GmwmOptions,
    warm: &[Model],
) -> Result<GmwmFit> {
    crate::magnitude::check(curve)?;
    let template = &resolve_bands(curve, template)?;
    if matches!(
        opts.weighting,
        Weighting::ModelDiagonal | Weighting::ModelFull
    ) {
        return fit_model_weighted(curve, template, opts, warm);
    }
    curve.validate()?;
    let kinds = check_template(template, opts.phi_range)?;
    let p = template.n_params();
    if curve.len() < p {
        return Err(FitError::TooFewScales {
            what: format!("the {p}-parameter model {}", template.template()),
            needed: p,
            got: curve.len(),
        });
    }
    let prob = build_problem(curve, kinds.clone(), opts, None)?;
    let mut starts = prob.starts(opts.n_starts);
    let warm = starts
        .first()
        .map(|grid| prob.warm_starts(warm, grid))
        .transpose()?
        .unwrap_or_default();
    starts.extend(warm);
    let (mut eta, mut conv) = prob.run(&starts, opts.max_iter)?;
    let mut prob_final = prob;
    if opts.weighting == Weighting::Diagonal {
        // Weights from the fitted curve, iterated to the fixed point θ̂ = argmin with
        // Ω = diag(1/(r_j ν_j(θ̂)²)) (iteratively reweighted, quasi-likelihood-like: the
        // estimating equations Σ (ν̂_j − ν_j(θ)) ∂ν_j/∂θ / (r_j ν_j(θ)²) have mean zero at
        // the truth, so the weights no longer pull the estimate towards low ν̂).
        let m: Vec<f64> = curve.points.iter().map(|q| q.m as f64).collect();
        let f = opts.moments.factor();
        let mut others = starts.into_iter().skip(1).collect::<Vec<_>>();
        for step in 0..opts.reweight_iterations {
            let (th_prev, _) = prob_final.theta(&eta).ok_or_else(|| {
                FitError::OptimizationFailed("a step ended outside the parameter space".into())
            })?;
            let comps = component_avars(&kinds, &th_prev, &m, curve.rate_hz);
            let reference: Vec<f64> = (0..m.len())
                .map(|a| f * comps.iter().map(|c| c[a]).sum::<f64>())
                .collect();
            let prob2 = build_problem(curve, kinds.clone(), opts, Some(&reference))?;
            // start from the previous solution (and, once, from the grid's other candidates)
            let mut starts2 = vec![th_prev.clone()];
            starts2.append(&mut others);
            let (eta2, mut conv2) = prob2.run(&starts2, opts.max_iter)?;
            conv2.iterations += conv.iterations;
            eta = eta2;
            conv = conv2;
            prob_final = prob2;
            let (th_new, _) = prob_final.theta(&eta).ok_or_else(|| {
                FitError::OptimizationFailed("a step ended outside the parameter space".into())
            })?;
            let change = th_new
                .iter()
                .zip(&th_prev)
                .map(|(a, b)| ((a - b) / b.abs().max(1e-300)).abs())
                .fold(0.0, f64::max);
            if step > 0 && change < REWEIGHT_REL_TOL {
                break;
            }
        }
    }
    let (theta, _) = prob_final.theta(&eta).ok_or_else(|| {
        FitError::OptimizationFailed("solution outside the parameter space".into())
    })?;
    finish(curve, template, opts, prob_final, theta, conv)
}

/// [`Weighting::ModelDiagonal`] / [`Weighting::ModelFull`]: the diagonal fit, then Ω from
/// the model covariance of the AV at the previous estimate, iterated.
fn fit_model_weighted(
    curve: &AvCurve,
    template: &Model,
    opts: &GmwmOptions,
    warm: &[Model],
) -> Result<GmwmFit> {
    let n = curve.n.ok_or_else(|| {
        FitError::InvalidArgument(
            "model-based weighting needs the series length n of the curve (AvCurve::with_n)".into(),
        )
    })?;
    let full = opts.weighting == Weighting::ModelFull;
    let first = fit_with_starts(
        curve,
        template,
        &GmwmOptions {
            weighting: Weighting::Diagonal,
            ..opts.clone()
        },
        warm,
    )?;
    let kinds = first.kinds.clone();
    let m = curve.m();
    let f2 = opts.moments.factor() * opts.moments.factor();
    let mut theta = first.theta.clone();
    let mut conv = first.convergence.clone();
    let mut last: Option<Problem> = None;
    for step in 0..opts.reweight_iterations.max(1) {
        let model = template.with_params(&theta)?;
        let mut v = crate::avcov::model_covariance(&model, &m, curve.rate_hz, n)?;
        let infl = crate::efficiency::inflation(opts.robust)?;
        v.data.iter_mut().for_each(|x| *x *= f2 * infl);
        let w = if full {
            full_whitening(&v)?
        } else {
            let d = v.diag();
            if let Some(x) = d.iter().find(|x| x.is_nan() || **x <= 0.0) {
                return Err(FitError::InvalidMatrix(format!(
                    "model covariance has a non-positive variance {x}"
                )));
            }
            Mat::from_fn(d.len(), d.len(), |a, b| {
                if a == b { 1.0 / d[a].sqrt() } else { 0.0 }
            })
        };
        let prob = problem_with_whitening(curve, kinds.clone(), opts, w);
        let (eta, mut c) = prob.run(std::slice::from_ref(&theta), opts.max_iter)?;
        c.iterations += conv.iterations;
        conv = c;
        let (th_new, _) = prob.theta(&eta).ok_or_else(|| {
            FitError::OptimizationFailed("a step ended outside the parameter space".into())
        })?;
        let change = th_new
            .iter()
            .zip(&theta)
            .map(|(a, b)| ((a - b) / b.abs().max(1e-300)).abs())
            .fold(0.0, f64::max);
        theta = th_new;
        last = Some(prob);
        if step > 0 && change < REWEIGHT_REL_TOL {
            break;
        }
    }
    let prob = last.ok_or_else(|| FitError::OptimizationFailed("no weighting step ran".into()))?;
    finish(curve, template, opts, prob, theta, conv)
}

fn finish(
    curve: &AvCurve,
    template: &Model,
    opts: &GmwmOptions,
    prob: Problem,
    theta: Vec<f64>,
    conv: Convergence,
) -> Result<GmwmFit> {
    let kinds = prob.kinds.clone();
    let model = template.with_params(&theta)?;
    let m: Vec<f64> = prob.m.clone();
    let f = opts.moments.factor();
    let components: Vec<Vec<f64>> = component_avars(&kinds, &theta, &m, curve.rate_hz)
        .into_iter()
        .map(|c| c.into_iter().map(|v| f * v).collect())
        .collect();
    let fitted: Vec<f64> = (0..m.len())
        .map(|a| components.iter().map(|c| c[a]).sum())
        .collect();
    Ok(GmwmFit {
        model,
        kinds,
        theta,
        convergence: conv,
        rate_hz: curve.rate_hz,
        moments: opts.moments,
        m: curve.m(),
        tau: curve.tau(),
        observed: curve.avar(),
        fitted,
        components,
        whitening: CovMatrix::from_mat(&prob.w),
        n: curve.n,
        robust: opts.robust,
    })
}

/// The processes of a fitted model, in model order.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, fitted_processes, GmwmOptions}};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let p = fitted_processes(&f);
/// assert_eq!(p.iter().map(|p| p.kind()).collect::<Vec<_>>(), f.kinds);
/// assert_eq!(p.iter().flat_map(|p| p.params()).collect::<Vec<_>>(), f.theta);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn fitted_processes(fit: &GmwmFit) -> Vec<Process> {
    fit.model
        .components()
        .iter()
        .filter_map(|c| match c {
            Component::Known(p) => Some(*p),
            Component::Slot(_) => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CurvePoint;
    use crate::theory::model_avar;

    fn exact_curve(model: &str, rate: f64, jmax: u32) -> AvCurve {
        let truth: Model = model.parse().unwrap();
        let m: Vec<u64> = (1..=jmax).map(|j| 1u64 << j).collect();
        let av = model_avar(&truth, &m, rate).unwrap();
        AvCurve::from_m(&m, &av, rate)
            .unwrap()
            .with_n(1 << (jmax + 2))
    }

    #[test]
    fn nnls_matches_a_known_solution() {
        // b = 2·a0 + 0·a1 with a1 pointing away: the constrained solution is (2, 0).
        let cols = vec![vec![1.0, 0.0, 1.0], vec![-1.0, 1.0, 0.0]];
        let b = vec![2.0 + 0.5, -0.5, 2.0];
        let (x, _) = nnls(&cols, &b);
        // the passive-set solve carries a 1e-12 relative ridge
        assert!(x[1] == 0.0 && (x[0] - 2.25).abs() < 1e-10, "{x:?}");
    }

    #[test]
    fn combinations_are_complete() {
        assert_eq!(combinations(4, 2).len(), 6);
        assert_eq!(combinations(5, 3).len(), 10);
        assert_eq!(combinations(3, 0), vec![Vec::<usize>::new()]);
    }

    #[test]
    fn transforms_round_trip_and_order_ar1s() {
        let curve = exact_curve(
            "WN(sigma2=1) + AR1(phi=0.9, sigma2=1) + AR1(phi=0.99, sigma2=1)",
            1.0,
            10,
        );
        let prob = build_problem(
            &curve,
            "WN + 2*AR1".parse::<Model>().unwrap().kinds(),
            &GmwmOptions::default(),
            None,
        )
        .unwrap();
        let th = vec![2.0, 0.9, 3.0, 0.99, 4.0];
        let (back, t) = prob.theta(&prob.eta(&th)).unwrap();
        for (a, b) in th.iter().zip(&back) {
            assert!((a - b).abs() < 1e-12 * a.abs(), "{th:?} vs {back:?}");
        }
        // Jacobian of the transform against central differences
        let eta = prob.eta(&th);
        for i in 0..5 {
            let h = 1e-6;
            let (mut a, mut b) = (eta.clone(), eta.clone());
            a[i] += h;
            b[i] -= h;
            let (ta, _) = prob.theta(&a).unwrap();
            let (tb, _) = prob.theta(&b).unwrap();
            for k in 0..5 {
                let fd = (ta[k] - tb[k]) / (2.0 * h);
                assert!(
                    (fd - t[(k, i)]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "T[{k},{i}]"
                );
            }
        }
    }

    /// Exact theoretical curves must be fitted back to the truth (no noise: the minimum is 0
    /// at the truth). 1e-6 relative leaves room for the optimizer's stopping rule.
    const EXACT_FIT_REL_TOL: f64 = 1e-6;

    #[test]
    fn exact_curves_are_fitted_back() {
        let cases = [
            (
                "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.995, sigma2=1e-7)",
                "WN + RW + AR1",
            ),
            (
                "QN(q2=1e-5) + WN(sigma2=1e-4) + RW(gamma2=1e-10)",
                "QN + WN + RW",
            ),
            (
                "WN(sigma2=1e-4) + AR1(phi=0.99, sigma2=1e-7) + AR1(phi=0.999, sigma2=1e-9)",
                "WN + 2*AR1",
            ),
            ("WN(sigma2=1e-4) + DR(omega=1e-8)", "WN + DR"),
        ];
        for (truth, tpl) in cases {
            let curve = exact_curve(truth, 100.0, 18);
            let f = fit(&curve, &tpl.parse().unwrap(), &GmwmOptions::default()).unwrap();
            let t: Model = truth.parse().unwrap();
            let want: Vec<f64> = t
                .processes()
                .unwrap()
                .iter()
                .flat_map(|p| p.params())
                .collect();
            for (a, b) in f.theta.iter().zip(&want) {
                assert!(
                    (a / b - 1.0).abs() < EXACT_FIT_REL_TOL,
                    "{tpl}: got {:?} want {want:?} ({:?})",
                    f.theta,
                    f.convergence
                );
            }
            assert!(f.convergence.converged, "{tpl}: {:?}", f.convergence);
        }
    }

    #[test]
    fn bad_inputs_are_clear_errors() {
        let curve = exact_curve("WN(sigma2=1e-4) + RW(gamma2=1e-10)", 100.0, 4);
        let e = fit(
            &curve,
            &"QN + WN + RW + AR1".parse().unwrap(),
            &GmwmOptions::default(),
        );
        assert!(
            matches!(
                e,
                Err(FitError::TooFewScales {
                    needed: 5,
                    got: 4,
                    ..
                })
            ),
            "{e:?}"
        );
        let mut bad = curve.clone();
        bad.points[2].avar = f64::NAN;
        assert!(matches!(
            fit(&bad, &"WN".parse().unwrap(), &GmwmOptions::default()),
            Err(FitError::NonFinite { index: 2, .. })
        ));
        let sym = GmwmOptions {
            phi_range: PhiRange::Symmetric,
            ..Default::default()
        };
        assert!(matches!(
            fit(&curve, &"2*AR1".parse().unwrap(), &sym),
            Err(FitError::Unidentifiable(_))
        ));
        assert!("WN + WN".parse::<Model>().is_err());
        let full = GmwmOptions {
            weighting: Weighting::Full(CovMatrix::diagonal(&[1.0; 3])),
            ..Default::default()
        };
        assert!(matches!(
            fit(&curve, &"WN".parse().unwrap(), &full),
            Err(FitError::InvalidMatrix(_))
        ));
    }

    /// The ADIS16405 imu1 gyro z curve (`imunoise analyze adis16405_imu1.csv.gz --rate 100`,
    /// n = 10^6; m, AV in (°/s)², EDF of the chi-square CI): a sinusoid of β ≈ 1.26 rad per
    /// sample over a short correlation and a random walk. A fit with two SINs on this curve
    /// has local optima far apart (objective ~5 against ~3400 with one common Ω).
    fn adis16405_gyro_z() -> AvCurve {
        let rows: [(u64, f64, f64); 18] = [
            (2, 0.14743427230281697, 534354.9679113559),
            (4, 0.03617363212167488, 304282.5975937749),
            (8, 0.02179317730781588, 167832.05777992654),
            (16, 0.009306091345277014, 86289.03771084605),
            (32, 0.004672943321210476, 43345.82086314648),
            (64, 0.002285729804591918, 21347.104620467144),
            (128, 0.0011933216256583402, 11250.45590167642),
            (256, 0.0005967903245408985, 5680.34456120731),
            (512, 0.0003014118428026595, 2655.2729958719337),
            (1024, 0.00016332261901976094, 1144.370676382192),
            (2048, 9.833474912742827e-5, 571.2702791845778),
            (4096, 7.155582223529285e-5, 242.0967527305695),
            (8192, 6.54770671152592e-5, 115.28415939195195),
            (16384, 7.595539094440219e-5, 55.03082076921167),
            (32768, 8.561470905289341e-5, 26.749576845267242),
            (65536, 0.00017670617981550707, 12.612479598392481),
            (131072, 0.00034108806581313356, 5.5537109803259455),
            (262144, 0.00043326879683824117, 2.071831572287974),
        ];
        let points = rows
            .iter()
            .map(|&(m, avar, edf)| CurvePoint {
                edf: Some(edf),
                ..CurvePoint::new(m, m as f64 / 100.0, avar)
            })
            .collect();
        AvCurve::new(points, 100.0, Some(1_000_000)).unwrap()
    }

    /// Adding components can never raise the minimum of the objective with one Ω: the model
    /// reproduces any nested one with the added components at zero. So the fit of
    /// QN + WN + RW + BI + 2·SIN + 2·AR1 warm-started from the optimum of its sub-model
    /// QN + WN + RW + BI + SIN + 2·AR1 must end at most at that model's objective (the
    /// optimizer accepts only decreasing steps; the tolerance 1e-8 covers the start's excess
    /// from the second SIN at [`WARM_START_SCALE`] of its grid AV). From the grid alone
    /// (2 starts, as in the backward search) it did not: 3376.9 against the sub-model's
    /// 46.5 on x86-64, the local optimum that aarch64 also reached for the full model in
    /// `analyze`; warm-started 5.01.
    #[test]
    fn a_warm_start_from_a_nested_model_bounds_the_objective() {
        let curve = adis16405_gyro_z();
        let o = GmwmOptions {
            weighting: Weighting::Full(crate::inference::diagonal_covariance(&curve)),
            n_starts: 2,
            ..Default::default()
        };
        let sub = fit(
            &curve,
            &"QN + WN + RW + BI + SIN + 2*AR1".parse().unwrap(),
            &o,
        )
        .unwrap();
        let full: Model = "QN + WN + RW + BI + 2*SIN + 2*AR1".parse().unwrap();
        let f = fit_with_starts(&curve, &full, &o, std::slice::from_ref(&sub.model)).unwrap();
        let (q, q_sub) = (f.convergence.objective, sub.convergence.objective);
        assert!(q <= q_sub * (1.0 + 1e-8), "{q} > {q_sub}");
        // two warm starts after the grid's: the second SIN practically absent, and at the
        // grid's value
        assert_eq!(f.convergence.starts, 4);
    }

    #[test]
    fn a_warm_start_must_fit_the_template() {
        let curve = adis16405_gyro_z();
        let o = GmwmOptions::default();
        let wn: Model = "WN".parse().unwrap();
        // a component the template lacks, a slot without values
        for w in ["RW(gamma2=1e-9)", "WN"] {
            let r = fit_with_starts(&curve, &wn, &o, &[w.parse().unwrap()]);
            assert!(matches!(r, Err(FitError::InvalidArgument(_))), "{w}: {r:?}");
        }
        // a BI of another band goes to the template's BI
        let bi: Model = "WN + BI".parse().unwrap();
        let w: Model = "BI(B=0.01, m_lo=4, m_hi=64)".parse().unwrap();
        assert!(fit_with_starts(&curve, &bi, &o, &[w]).is_ok());
    }
}
