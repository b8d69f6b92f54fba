//! How long to record: the CI half-width a fitted noise model predicts for one of its terms at
//! a longer record, and the record length where it reaches a target, with an interval.
//!
//! For a GMWM fit θ̂ at n samples, the precision at n′ samples is what the fit's own
//! inference would give there if the model were true: the AV estimates at the scales the grid
//! has at n′ ([`avar::Scales::cluster_sizes`] up to the largest tracked cluster size) have the
//! exact covariance V(n′) of [`gmwm_prep::inference::model_covariance`] under the fitted
//! model, the GMWM with Ω = diag(V)⁻¹ has cov θ̂ = B V Bᵀ ([`delta_method`]), and the term's
//! CI follows as for the fit itself ([`noise_terms_of`], or the parameter's CI). The predicted
//! half-width h(n′) is scaled by h_now / h(n) so that it equals the fit's own half-width at
//! the current length (the fit's weighting differs slightly from diag(V)⁻¹); the record
//! needed is the n′ with h(n′) = target (secant steps on ln h against ln n′).
//!
//! The interval of that length propagates the parameters' CIs: each θ_k is moved to its CI
//! bounds (on its unconstrained scale, as [`delta_method`] gives them), which moves ln h(n′)
//! by Δ_k, hence ln n′ by Δ_k / |d ln h / d ln n′|; these shifts per standard error are
//! combined with the correlation of θ̂ into a standard deviation of ln n′, and the interval
//! is n′·e^{∓z·sd}.

use avar::Scales;
use gmwm_prep::gmwm::{CovMatrix, GmwmFit};
use gmwm_prep::inference::{Inference, delta_method, model_covariance};
use gmwm_prep::noise_terms::{NoiseTerm, TermSource, noise_terms_of};
use gmwm_prep::stats::z_two_sided;
use gmwm_prep::{AvCurve, theory};
use processes::Unit;

/// What a precision target is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// The white-noise density N (from the model's short-memory components).
    N,
    /// The rate random walk K.
    K,
    /// The bias instability B (from a bias-instability component).
    B,
    /// The model parameter at this index of θ.
    Param(usize),
}

/// The relative half-width (hi − lo) / (2·value) of a term's CI, when the term comes from
/// the model and has a CI (None for read-offs and bounds: the model cannot predict them).
///
/// ```
/// use imunoise::gmwm_prep::noise_terms::{NoiseTerm, TermSource};
/// use imunoise::pipeline::precision::model_halfwidth;
/// let mut t = NoiseTerm {
///     symbol: "K".into(), value: 2.0, unit: "°/h/√h".into(), per_second: 1e-5,
///     per_second_unit: "°/s/√s".into(), ci_lo: Some(1.8), ci_hi: Some(2.4),
///     source: TermSource::Model, basis: "RW".into(), read_off: None, disagrees: false,
/// };
/// assert!((model_halfwidth(&t).unwrap() - 0.15).abs() < 1e-15); // (2.4 − 1.8) / 4
/// t.source = TermSource::ReadOff;
/// assert_eq!(model_halfwidth(&t), None);
/// ```
pub fn model_halfwidth(t: &NoiseTerm) -> Option<f64> {
    match (t.source, t.ci_lo, t.ci_hi) {
        (TermSource::Model, Some(lo), Some(hi)) if t.value > 0.0 => {
            Some((hi - lo) / (2.0 * t.value))
        }
        _ => None,
    }
}

/// The record needed to reach a precision, in samples, with its interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Needed {
    /// Samples at which the predicted half-width reaches the target.
    pub n: f64,
    /// Lower bound of its 1 − alpha interval (samples).
    pub lo: f64,
    /// Upper bound (samples; infinite when a parameter at its CI bound never reaches it).
    pub hi: f64,
}

/// A fit and what its precision is predicted from.
pub struct Predictor<'a> {
    /// The GMWM fit at the current record (its `n` set).
    pub fit: &'a GmwmFit,
    /// The fit's delta-method inference (cov θ̂ and the parameters' CIs).
    pub inference: &'a Inference,
    /// The curve fitted (only for the read-offs [`noise_terms_of`] sets beside model values).
    pub curve: &'a AvCurve,
    /// The channel's unit.
    pub unit: &'a Unit,
    /// The scale grid of the estimator.
    pub scales: &'a Scales,
    /// The largest cluster size tracked (samples).
    pub max_m: u64,
}

impl Predictor<'_> {
    /// The cluster sizes at `n` samples: the grid's, up to `max_m`.
    fn grid(&self, n: u64) -> Vec<u64> {
        let t = usize::try_from(n).unwrap_or(usize::MAX);
        match self.scales {
            // an explicit list: its sizes the estimator has at n (m ≤ n/2)
            Scales::Explicit(list) => list
                .iter()
                .copied()
                .filter(|&m| m >= 1 && m <= self.max_m && m <= n / 2)
                .collect(),
            s => s
                .cluster_sizes(t)
                .map(|v| v.into_iter().filter(|&m| m <= self.max_m).collect())
                .unwrap_or_default(),
        }
    }

    /// The relative half-width of `q` under the inference `inf` of parameters `theta`.
    fn halfwidth(&self, q: Quantity, theta: &[f64], inf: &Inference) -> Option<f64> {
        match q {
            Quantity::Param(k) => {
                let (lo, hi) = *inf.ci.get(k)?;
                let v = theta.get(k)?.abs();
                (v > 0.0).then(|| (hi - lo).abs() / (2.0 * v))
            }
            _ => {
                let tau_min = self.fit.tau.first().copied().unwrap_or(f64::INFINITY);
                let t = noise_terms_of(
                    &self.fit.kinds,
                    theta,
                    self.fit.rate_hz,
                    tau_min,
                    Some(inf),
                    self.curve,
                    self.unit,
                )
                .ok()?;
                model_halfwidth(match q {
                    Quantity::N => &t.n,
                    Quantity::K => &t.k,
                    _ => &t.b,
                })
            }
        }
    }

    /// The relative half-width of `q` the fit has now (its own inference).
    pub fn current(&self, q: Quantity) -> Option<f64> {
        self.halfwidth(q, &self.fit.theta, self.inference)
    }

    /// The half-width of `q` that parameters `theta` predict at `n` samples (unscaled).
    ///
    /// ```
    /// use imunoise::gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, inference::{delta_method, fit_covariance}};
    /// use imunoise::pipeline::precision::{Predictor, Quantity};
    /// // a fit to the exact AV of WN + RW at n = 2^20: 4× the record halves the half-width
    /// // of K (cov θ̂ ∝ 1/n at fixed scales; the scales here stop at m = 2^14 either way)
    /// let truth: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
    /// let m: Vec<u64> = (1..=14).map(|j| 1u64 << j).collect();
    /// let av = imunoise::gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
    /// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(1 << 20);
    /// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
    /// let inf = delta_method(&f, &fit_covariance(&f)?, 0.05)?;
    /// let p = Predictor { fit: &f, inference: &inf, curve: &curve, unit: &imunoise::processes::Unit::DegPerSec,
    ///     scales: &imunoise::avar::Scales::Dyadic, max_m: 1 << 14 };
    /// let (h1, h4) = (p.predicted(Quantity::K, &f.theta, 1 << 20).unwrap(),
    ///     p.predicted(Quantity::K, &f.theta, 1 << 22).unwrap());
    /// assert!((h1 / h4 / 2.0 - 1.0).abs() < 0.01, "{h1} {h4}");
    /// # Ok::<(), imunoise::gmwm_prep::FitError>(())
    /// ```
    pub fn predicted(&self, q: Quantity, theta: &[f64], n: u64) -> Option<f64> {
        let f = self.fit;
        let m = self.grid(n);
        if m.len() <= theta.len() {
            return None;
        }
        let model = f.model.with_params(theta).ok()?;
        let nu = theory::model_avar(&model, &m, f.rate_hz).ok()?;
        // each component's AV (the diagnosis of an unidentifiable fit reads them)
        let components = model
            .processes()
            .ok()?
            .iter()
            .map(|p| {
                m.iter()
                    .map(|&mj| theory::process_avar(p, mj, f.rate_hz))
                    .collect::<std::result::Result<Vec<f64>, _>>()
            })
            .collect::<std::result::Result<Vec<_>, _>>()
            .ok()?;
        let v = model_covariance(&model, &m, f.rate_hz, n).ok()?;
        let w: Vec<f64> = v.diag().iter().map(|d| 1.0 / d.sqrt()).collect();
        if !w.iter().all(|x| x.is_finite()) {
            return None;
        }
        let at = GmwmFit {
            model,
            kinds: f.kinds.clone(),
            theta: theta.to_vec(),
            convergence: f.convergence.clone(),
            rate_hz: f.rate_hz,
            moments: f.moments,
            tau: m.iter().map(|&x| x as f64 / f.rate_hz).collect(),
            m,
            observed: nu.clone(),
            fitted: nu,
            components,
            whitening: CovMatrix::diagonal(&w),
            n: Some(n),
            robust: f.robust,
        };
        let inf = delta_method(&at, &v, self.inference.alpha).ok()?;
        self.halfwidth(q, theta, &inf)
    }

    /// The smallest record (samples, ≥ `n_now`) where `scale`·h(n′) = `target` for parameters
    /// `theta`, with the local slope d ln h / d ln n′ there; None when it is beyond 2^40·n_now
    /// or not predictable. Secant steps on (ln n′, ln h), from the 1/√n′ guess: h is close to
    /// a power of n′ (exactly n′^(−1/2) once the grid stops growing and n′ ≫ the largest
    /// cluster size), so 3–4 evaluations reach 0.2 %.
    fn solve(
        &self,
        q: Quantity,
        theta: &[f64],
        scale: f64,
        target: f64,
        n_now: u64,
    ) -> Option<(f64, f64)> {
        let h = |n: f64| {
            self.predicted(q, theta, n.round() as u64)
                .map(|h| scale * h)
        };
        let (mut n0, mut h0) = (n_now as f64, h(n_now as f64)?);
        if h0 <= target {
            return Some((n0, -0.5));
        }
        let cap = n0 * 2f64.powi(40);
        let mut n1 = (n0 * (h0 / target).powi(2)).min(cap);
        let mut h1 = h(n1)?;
        let mut slope = -0.5;
        for _ in 0..8 {
            if (h1 / target).ln().abs() < 2e-3 {
                break;
            }
            if (n1 / n0).ln().abs() > 1e-9 {
                slope = ((h1 / h0).ln() / (n1 / n0).ln()).clamp(-2.0, -0.05);
            }
            let n2 = (n1 * ((target / h1).ln() / slope).exp()).clamp(n_now as f64, cap);
            (n0, h0) = (n1, h1);
            n1 = n2;
            h1 = h(n1)?;
        }
        if n1 >= cap && h1 > target {
            return None;
        }
        Some((n1.max(n_now as f64), slope))
    }

    /// The record (samples) where the half-width of `q` reaches `target`, with its interval
    /// (see the [module](self) docs); None when the model does not give `q` a CI now, or the
    /// target is not predicted to be reached.
    ///
    /// ```
    /// use imunoise::gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, inference::{delta_method, fit_covariance}};
    /// use imunoise::pipeline::precision::{Predictor, Quantity};
    /// let truth: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
    /// let m: Vec<u64> = (1..=12).map(|j| 1u64 << j).collect();
    /// let av = imunoise::gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
    /// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(1 << 20);
    /// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
    /// let inf = delta_method(&f, &fit_covariance(&f)?, 0.05)?;
    /// let p = Predictor { fit: &f, inference: &inf, curve: &curve, unit: &imunoise::processes::Unit::DegPerSec,
    ///     scales: &imunoise::avar::Scales::Dyadic, max_m: 1 << 12 };
    /// let h = p.current(Quantity::K).unwrap();
    /// // half the half-width: 4× the record (all scales are there at n = 2^20 already, and
    /// // n ≫ m: the variances go as 1/(n − 2m + 1) ≈ 1/n, to < 1 %)
    /// let need = p.needed(Quantity::K, h / 2.0).unwrap();
    /// assert!((need.n / (1 << 22) as f64 - 1.0).abs() < 0.02, "{need:?}");
    /// assert!(need.lo < need.n && need.n < need.hi);
    /// // reached already: the current length
    /// assert_eq!(p.needed(Quantity::K, 2.0 * h).unwrap().n, (1 << 20) as f64);
    /// # Ok::<(), imunoise::gmwm_prep::FitError>(())
    /// ```
    pub fn needed(&self, q: Quantity, target: f64) -> Option<Needed> {
        let n_now = self.fit.n?;
        let h_now = self.current(q)?;
        let scale = h_now / self.predicted(q, &self.fit.theta, n_now)?;
        if !(scale.is_finite() && scale > 0.0) {
            return None;
        }
        let (n, slope) = self.solve(q, &self.fit.theta, scale, target, n_now)?;
        if n <= n_now as f64 {
            return Some(Needed { n, lo: n, hi: n });
        }
        // d ln n′ per standard error of each θ_k: θ_k at its CI bounds moves ln h at n′ by
        // Δ, hence ln n′ by Δ / |slope| (the local power law of h in n′)
        let z = z_two_sided(self.inference.alpha);
        let p = self.fit.theta.len();
        let at_n = n.round() as u64;
        let mut per_se = vec![0.0; p];
        let mut unbounded = false;
        for (k, d) in per_se.iter_mut().enumerate() {
            if self.inference.se[k].is_nan() || self.inference.se[k] <= 0.0 {
                continue;
            }
            let (a, b) = self.inference.ci[k];
            let h_at = |x: f64| {
                let mut th = self.fit.theta.clone();
                th[k] = x;
                self.predicted(q, &th, at_n)
            };
            match (h_at(a), h_at(b)) {
                (Some(ha), Some(hb)) if ha > 0.0 && hb > 0.0 => {
                    *d = (hb / ha).ln() / slope.abs() / (2.0 * z)
                }
                _ => unbounded = true,
            }
        }
        let mut var = 0.0;
        for i in 0..p {
            for j in 0..p {
                let (si, sj) = (self.inference.se[i], self.inference.se[j]);
                if si > 0.0 && sj > 0.0 {
                    let rho = (self.inference.cov_theta.get(i, j) / (si * sj)).clamp(-1.0, 1.0);
                    var += per_se[i] * per_se[j] * rho;
                }
            }
        }
        let sd = var.max(0.0).sqrt();
        Some(Needed {
            n,
            lo: (n * (-z * sd).exp()).max(n_now as f64),
            hi: if unbounded {
                f64::INFINITY
            } else {
                n * (z * sd).exp()
            },
        })
    }
}
