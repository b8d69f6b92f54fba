//! Parametric bootstrap: simulate the fitted model (`processes`), estimate the AV of each
//! replicate (`avar`) at the same scales, refit. Replicates run in parallel (rayon) and are
//! reproducible: replicate b draws stream b of the given seed, whatever the thread count.
//!
//! One run gives both the covariance matrix V of the AV estimates at θ̂ (to use as the full
//! weighting matrix or in the delta method) and the bootstrap distribution of θ̂ (percentile
//! CIs with the α/2 and 1 − α/2 quantiles).

use crate::avlr::{AvlrFit, avlr};
use crate::curve::AvCurve;
use crate::error::{FitError, Result};
use crate::gmwm::{CovMatrix, GmwmFit, GmwmOptions, Moments, fit};
use crate::stats::z_two_sided;
use avar::{AvarConfig, Scales};
use processes::Model;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Options of a parametric bootstrap.
///
/// ```
/// let b = gmwm_prep::bootstrap::BootstrapOptions::new(100, 42, 1_000_000);
/// assert_eq!(b.alpha, 0.05);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BootstrapOptions {
    /// Number of replications B.
    pub replications: usize,
    /// Seed; replicate b uses stream b of it.
    pub seed: u64,
    /// Length of each simulated series (samples), normally the original length.
    pub n: usize,
    /// AV estimation settings (its `scales` are replaced by the fit's cluster sizes).
    pub avar: AvarConfig,
    /// Significance level of the intervals.
    pub alpha: f64,
}

impl BootstrapOptions {
    /// AV curve of replicate `b` (stream `b` of `self.seed`) of `model` at scales `m`.
    fn replicate(&self, model: &Model, m: &[u64], rate_hz: f64, b: usize) -> Result<AvCurve> {
        simulate_curve(model, m, rate_hz, self.n, self.seed, b as u64, &self.avar)
    }

    /// B replications of length n with seed, default AV settings, 95% intervals.
    ///
    /// ```
    /// use gmwm_prep::bootstrap::BootstrapOptions;
    /// let b = BootstrapOptions::new(200, 7, 10_000);
    /// assert_eq!((b.replications, b.seed, b.n), (200, 7, 10_000));
    /// assert_eq!(b.avar, avar::AvarConfig::default());
    /// ```
    pub fn new(replications: usize, seed: u64, n: usize) -> Self {
        Self {
            replications,
            seed,
            n,
            avar: AvarConfig::default(),
            alpha: 0.05,
        }
    }
    fn check(&self) -> Result<()> {
        if self.replications < 2 {
            return Err(FitError::InvalidArgument(
                "a bootstrap needs at least 2 replications".into(),
            ));
        }
        if self.replications > MAX_REPLICATIONS {
            return Err(FitError::InvalidArgument(format!(
                "{} bootstrap replications is more than the {MAX_REPLICATIONS} this runs (each one simulates and refits a whole record)",
                self.replications
            )));
        }
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(FitError::InvalidAlpha(self.alpha));
        }
        Ok(())
    }
}

/// The most replications a bootstrap runs (a larger request is an error, not an attempt to
/// allocate and simulate it).
pub const MAX_REPLICATIONS: usize = 100_000;

/// Result of [`parametric_bootstrap`].
///
/// ```
/// use gmwm_prep::{AvCurve, bootstrap::{BootstrapOptions, parametric_bootstrap}};
/// use gmwm_prep::gmwm::{fit, GmwmOptions};
/// let truth: processes::Model = "WN(sigma2=1e-4)".parse()?;
/// let m: Vec<u64> = (1..=6).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(4096);
/// let template: processes::Model = "WN".parse()?;
/// let f = fit(&curve, &template, &GmwmOptions::default())?;
/// let boot = BootstrapOptions::new(8, 1, 4096);
/// let b = parametric_bootstrap(&f, &template, &GmwmOptions::default(), &boot)?;
/// assert_eq!((b.replications + b.failed, b.theta.len()), (8, b.replications));
/// assert_eq!((b.av_cov.n, b.av_mean.len()), (6, 6)); // one per scale
/// // se is the sample standard deviation of the θ* (to rounding)
/// let t: Vec<f64> = b.theta.iter().map(|t| t[0]).collect();
/// let mean = t.iter().sum::<f64>() / t.len() as f64;
/// let var = t.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (t.len() - 1) as f64;
/// assert!((b.se[0] / var.sqrt() - 1.0).abs() < 1e-12);
/// // percentile bounds interpolate between the θ*, so they lie within their range
/// let (lo, hi) = b.ci[0];
/// assert!(t.iter().cloned().fold(f64::INFINITY, f64::min) <= lo && lo <= hi);
/// assert!(hi <= t.iter().cloned().fold(f64::NEG_INFINITY, f64::max));
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BootstrapResult {
    /// Replications whose refit succeeded.
    pub replications: usize,
    /// Replications whose refit failed (left out).
    pub failed: usize,
    /// Refitted θ* of each successful replication.
    pub theta: Vec<Vec<f64>>,
    /// Bootstrap standard deviation of each parameter.
    pub se: Vec<f64>,
    /// Percentile CIs [q_{α/2}, q_{1−α/2}] of each parameter.
    pub ci: Vec<(f64, f64)>,
    /// Sample covariance of the replicates' AV (J×J): an estimate of Var(ν̂) at θ̂.
    pub av_cov: CovMatrix,
    /// Mean of the replicates' AV.
    pub av_mean: Vec<f64>,
}

/// AV curve of one simulated replicate of `model` (cluster sizes `m` and length `n` in
/// samples, `rate_hz` in Hz).
///
/// ```
/// use gmwm_prep::bootstrap::simulate_curve;
/// let model: processes::Model = "WN(sigma2=1)".parse()?;
/// let cfg = avar::AvarConfig::default();
/// let a = simulate_curve(&model, &[1, 4, 16], 10.0, 1024, 42, 0, &cfg)?;
/// assert_eq!((a.m(), a.n, a.rate_hz), (vec![1, 4, 16], Some(1024), 10.0));
/// // reproducible: the same seed and stream give the same curve
/// assert_eq!(a, simulate_curve(&model, &[1, 4, 16], 10.0, 1024, 42, 0, &cfg)?);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn simulate_curve(
    model: &Model,
    m: &[u64],
    rate_hz: f64,
    n: usize,
    seed: u64,
    stream: u64,
    config: &AvarConfig,
) -> Result<AvCurve> {
    let x = model.simulate_stream(n, rate_hz, seed, stream)?;
    let cfg = AvarConfig {
        scales: Scales::Explicit(m.to_vec()),
        ..config.clone()
    };
    let av = avar::allan_variance(x.values(), rate_hz, &cfg)?;
    AvCurve::from_avar(&av)
}

/// Quantile of sorted data (linear interpolation, R type 7).
pub(crate) fn quantile(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

fn mean_cov(rows: &[Vec<f64>]) -> (Vec<f64>, CovMatrix) {
    let n = rows.len() as f64;
    let d = rows[0].len();
    let mean: Vec<f64> = (0..d)
        .map(|k| rows.iter().map(|r| r[k]).sum::<f64>() / n)
        .collect();
    let mut data = vec![0.0; d * d];
    for r in rows {
        for a in 0..d {
            for b in 0..d {
                data[a * d + b] += (r[a] - mean[a]) * (r[b] - mean[b]);
            }
        }
    }
    data.iter_mut().for_each(|x| *x /= n - 1.0);
    (mean, CovMatrix { n: d, data })
}

/// Parametric bootstrap of a GMWM fit: B replicates simulated from `fit.model`, each refitted
/// with `template` and `opts` (see module doc). AV moments only.
///
/// ```
/// use gmwm_prep::{AvCurve, bootstrap::{BootstrapOptions, parametric_bootstrap}};
/// use gmwm_prep::gmwm::{fit, GmwmOptions};
/// let truth: processes::Model = "WN(sigma2=1e-4)".parse()?;
/// let m: Vec<u64> = (1..=6).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(4096);
/// let template: processes::Model = "WN".parse()?;
/// let f = fit(&curve, &template, &GmwmOptions::default())?;
/// let boot = BootstrapOptions::new(8, 1, 4096);
/// let b = parametric_bootstrap(&f, &template, &GmwmOptions::default(), &boot)?;
/// assert_eq!(b.replications + b.failed, 8);
/// // reproducible: replicate b draws stream b of the seed, whatever the thread count
/// assert_eq!(b, parametric_bootstrap(&f, &template, &GmwmOptions::default(), &boot)?);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn parametric_bootstrap(
    fit_: &GmwmFit,
    template: &Model,
    opts: &GmwmOptions,
    boot: &BootstrapOptions,
) -> Result<BootstrapResult> {
    parametric_bootstrap_with_progress(fit_, template, opts, boot, &|| {})
}

/// [`parametric_bootstrap`] calling `on_replicate` once per finished replicate (from the
/// worker threads, in any order), e.g. to advance a progress bar. The result does not depend
/// on the hook.
///
/// ```
/// use gmwm_prep::{AvCurve, bootstrap::{BootstrapOptions, parametric_bootstrap_with_progress}};
/// use gmwm_prep::gmwm::{fit, GmwmOptions};
/// use std::sync::atomic::{AtomicUsize, Ordering};
/// let truth: processes::Model = "WN(sigma2=1e-4)".parse()?;
/// let m: Vec<u64> = (1..=6).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(4096);
/// let template: processes::Model = "WN".parse()?;
/// let f = fit(&curve, &template, &GmwmOptions::default())?;
/// let done = AtomicUsize::new(0);
/// let b = parametric_bootstrap_with_progress(&f, &template, &GmwmOptions::default(),
///     &BootstrapOptions::new(8, 1, 4096), &|| { done.fetch_add(1, Ordering::Relaxed); })?;
/// assert_eq!((done.load(Ordering::Relaxed), b.replications), (8, 8));
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn parametric_bootstrap_with_progress(
    fit_: &GmwmFit,
    template: &Model,
    opts: &GmwmOptions,
    boot: &BootstrapOptions,
    on_replicate: &(dyn Fn() + Sync),
) -> Result<BootstrapResult> {
    boot.check()?;
    if fit_.moments != Moments::AllanVariance {
        return Err(FitError::InvalidArgument(
            "the parametric bootstrap simulates Allan variances only".into(),
        ));
    }
    type Replicate = Result<(Vec<f64>, Option<Vec<f64>>)>;
    let reps: Vec<Replicate> = (0..boot.replications)
        .into_par_iter()
        .map(|b| {
            let c = boot.replicate(&fit_.model, &fit_.m, fit_.rate_hz, b)?;
            let th = fit(&c, template, opts).ok().map(|f| f.theta);
            on_replicate();
            Ok((c.avar(), th))
        })
        .collect();
    let mut avs = Vec::new();
    let mut thetas = Vec::new();
    for r in reps {
        let (av, th) = r?;
        avs.push(av);
        if let Some(t) = th {
            thetas.push(t);
        }
    }
    let failed = boot.replications - thetas.len();
    if thetas.len() < 2 {
        return Err(FitError::OptimizationFailed(format!(
            "{failed} of {} bootstrap refits failed",
            boot.replications
        )));
    }
    let (av_mean, av_cov) = mean_cov(&avs);
    let (_, th_cov) = mean_cov(&thetas);
    let p = thetas[0].len();
    let se = (0..p).map(|k| th_cov.get(k, k).sqrt()).collect();
    let ci = (0..p)
        .map(|k| {
            let mut v: Vec<f64> = thetas.iter().map(|t| t[k]).collect();
            v.sort_by(f64::total_cmp);
            (
                quantile(&v, boot.alpha / 2.0),
                quantile(&v, 1.0 - boot.alpha / 2.0),
            )
        })
        .collect();
    Ok(BootstrapResult {
        replications: thetas.len(),
        failed,
        theta: thetas,
        se,
        ci,
        av_cov,
        av_mean,
    })
}

/// Parametric bootstrap CIs for AVLR (as R avar's `avlr(ci = TRUE)`, with the normal
/// *quantile* z_{1−α/2}, not the density): simulate the AVLR model on the fit's scales, re-apply
/// AVLR with the same windows, and set each estimate's `sd` and `ci = θ̂ ± z_{1−α/2} sd`
/// (per-sample parameters). The point estimates are left as they are (no bias correction).
///
/// ```
/// use gmwm_prep::{AvCurve, avlr::{avlr, AvlrWindows}};
/// use gmwm_prep::bootstrap::{avlr_bootstrap, BootstrapOptions};
/// let m: Vec<u64> = (0..6).map(|j| 1u64 << j).collect();
/// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect();
/// let w = AvlrWindows { wn: Some((0, 5)), ..Default::default() };
/// let f = avlr(&AvCurve::from_m(&m, &av, 100.0)?, &w)?;
/// let b = avlr_bootstrap(&f, &m, &BootstrapOptions::new(8, 1, 4096))?;
/// let e = &b.estimates[0];
/// assert_eq!(e.per_sample, f.estimates[0].per_sample); // point estimate unchanged
/// // CI = θ̂ ± z_{0.975} sd (to the rounding of θ̂ ± z sd)
/// let z = gmwm_prep::stats::z_two_sided(0.05);
/// let (sd, lo, hi) = (e.sd.unwrap(), e.ci_lo.unwrap(), e.ci_hi.unwrap());
/// assert!(((hi - lo) / (2.0 * z * sd) - 1.0).abs() < 1e-9);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn avlr_bootstrap(fit_: &AvlrFit, m: &[u64], boot: &BootstrapOptions) -> Result<AvlrFit> {
    boot.check()?;
    let reps: Vec<Result<Vec<f64>>> = (0..boot.replications)
        .into_par_iter()
        .map(|b| {
            let c = boot.replicate(&fit_.model, m, fit_.rate_hz, b)?;
            let f = avlr(&c, &fit_.windows)?;
            Ok(f.estimates.iter().map(|e| e.per_sample).collect())
        })
        .collect();
    let rows: Vec<Vec<f64>> = reps.into_iter().collect::<Result<_>>()?;
    let (_, cov) = mean_cov(&rows);
    let z = z_two_sided(boot.alpha);
    let mut out = fit_.clone();
    for (k, e) in out.estimates.iter_mut().enumerate() {
        let sd = cov.get(k, k).sqrt();
        e.sd = Some(sd);
        e.ci_lo = Some(e.per_sample - z * sd);
        e.ci_hi = Some(e.per_sample + z * sd);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantile_type_7() {
        let v = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(quantile(&v, 0.5), 3.0);
        assert_eq!(quantile(&v, 0.25), 2.0);
        assert_eq!(quantile(&v, 0.1), 1.4);
    }
}
