//! Robust fitting (the RGMWM of Guerrier, Molinari and Victoria-Feser): the GMWM on the
//! robust Allan variance of `avar::robust` (Tukey biweight M-estimator of scale per scale, at
//! a chosen Gaussian efficiency e, 0.6 by default), and a check that compares the classical
//! and the robust curves.
//!
//! - [`robust_curve`]: the robust AV of a series as an [`AvCurve`] (chi-square CIs with EDF
//!   e·EDF, so the default diagonal weighting uses Var = Var_classical / e).
//! - [`fit_robust`]: that curve fitted with [`crate::gmwm::fit`] and `robust: Some(e)` in the
//!   options, so that the model covariance of the moments (model-based weighting, delta-method
//!   CIs through [`crate::inference::fit_covariance`]) is inflated by 1/e.
//! - [`contamination_check`]: where the classical AV exceeds the robust one by more than the
//!   Gaussian sampling noise allows, and which time windows drive it.

use crate::curve::AvCurve;
use crate::error::{FitError, Result};
use crate::gmwm::{GmwmFit, GmwmOptions, Moments, fit};
use avar::AvarConfig;
use avar::robust::{ExcessWindow, RobustAllanVariance, excess_windows_at, robust_allan_variance};
use processes::Model;
use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, Normal};

fn av_err(e: avar::AvarError) -> FitError {
    FitError::InvalidArgument(format!("robust AV: {e}"))
}

/// Below this share of the classical AV's excess in its largest window, a contamination is
/// described as spread through the record (heavier tails than Gaussian throughout) rather
/// than by the windows, none of which drives it.
pub const SPREAD_SHARE: f64 = 0.1;

pub use crate::efficiency::inflation;

/// The robust AV of rate samples (at the scales and with the CI family of `config`) as a
/// curve, beside the full robust result (classical curve, rejected counts).
///
/// ```
/// use avar::AvarConfig;
/// let x: Vec<f64> = (0..8192).map(|i| ((i * 7919) % 97) as f64 - 48.0).collect();
/// let (curve, r) = gmwm_prep::robust::robust_curve(&x, 10.0, &AvarConfig::default(), 0.6)?;
/// assert_eq!(curve.len(), r.robust.points.len());
/// assert_eq!(curve.points[0].avar, r.robust.points[0].avar);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn robust_curve(
    data: &[f64],
    rate_hz: f64,
    config: &AvarConfig,
    efficiency: f64,
) -> Result<(AvCurve, RobustAllanVariance)> {
    inflation(Some(efficiency))?;
    let r = robust_allan_variance(data, rate_hz, config, efficiency).map_err(av_err)?;
    let c = AvCurve::from_avar(&r.robust)?;
    Ok((c, r))
}

/// A robust fit with the curves it came from.
///
/// ```
/// use gmwm_prep::{gmwm::GmwmOptions, robust::fit_robust};
/// let m: processes::Model = "WN(sigma2=1)".parse()?;
/// let x = m.simulate(4096, 1.0, 3)?.into_values();
/// let cfg = avar::AvarConfig::default();
/// let r = fit_robust(&x, 1.0, &cfg, &"WN".parse()?, &GmwmOptions::default())?;
/// // opts.robust = None: the default efficiency
/// assert_eq!(r.fit.robust, Some(avar::robust::DEFAULT_EFFICIENCY));
/// assert_eq!(r.fit.observed, r.curve.avar());
/// let robust: Vec<f64> = r.avar.robust.points.iter().map(|p| p.avar).collect();
/// assert_eq!(r.curve.avar(), robust);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobustFit {
    /// The fit on the robust AV (`fit.robust` = Some(e)).
    pub fit: GmwmFit,
    /// The robust AV curve.
    pub curve: AvCurve,
    /// The robust and classical AV.
    pub avar: RobustAllanVariance,
}

/// Fits `template` to the robust AV of `data` (AV moments; `opts.robust` gives the efficiency,
/// [`avar::robust::DEFAULT_EFFICIENCY`] when `None`).
///
/// ```
/// use gmwm_prep::{gmwm::GmwmOptions, robust::fit_robust};
/// let m: processes::Model = "WN(sigma2=1) + RW(gamma2=1e-6)".parse()?;
/// let mut x = m.simulate(1 << 16, 1.0, 3)?.into_values();
/// for i in (0..x.len()).step_by(500) { x[i] += 30.0; } // 0.2 % spikes of 30σ
/// let f = fit_robust(&x, 1.0, &avar::AvarConfig::default(), &"WN + RW".parse()?, &GmwmOptions::default())?;
/// assert!((f.fit.theta[0] - 1.0).abs() < 0.1, "{:?}", f.fit.theta);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_robust(
    data: &[f64],
    rate_hz: f64,
    config: &AvarConfig,
    template: &Model,
    opts: &GmwmOptions,
) -> Result<RobustFit> {
    if opts.moments != Moments::AllanVariance {
        return Err(FitError::InvalidArgument(
            "the robust fit works on AV moments".into(),
        ));
    }
    let e = opts.robust.unwrap_or(avar::robust::DEFAULT_EFFICIENCY);
    let (curve, avar) = robust_curve(data, rate_hz, config, e)?;
    let o = GmwmOptions {
        robust: Some(e),
        ..opts.clone()
    };
    let f = fit(&curve, template, &o)?;
    Ok(RobustFit {
        fit: f,
        curve,
        avar,
    })
}

/// Classical against robust AV at one scale.
///
/// ```
/// use avar::{AvarConfig, robust::robust_allan_variance};
/// let m: processes::Model = "WN(sigma2=1)".parse()?;
/// let x = m.simulate(4096, 100.0, 5)?.into_values();
/// let r = robust_allan_variance(&x, 100.0, &AvarConfig::default(), 0.6)?;
/// let c = gmwm_prep::robust::contamination_check(&x, &r, 0.01, 3)?;
/// for (s, p) in c.scales.iter().zip(&r.classical.points) {
///     assert_eq!((s.m, s.tau, s.classical), (p.m, p.tau, p.avar));
///     assert_eq!(s.ratio, s.classical / s.robust);
///     assert_eq!(s.z > 0.0, s.classical > s.robust); // z has the sign of the difference
/// }
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ScaleComparison {
    /// Cluster size m (samples).
    pub m: u64,
    /// τ (s).
    pub tau: f64,
    /// Classical AV (unit²).
    pub classical: f64,
    /// Robust AV (unit²).
    pub robust: f64,
    /// classical / robust.
    pub ratio: f64,
    /// z = (classical − robust) / sd, sd² = robust² · r · (1/e − 1), r = 2/EDF the classical
    /// relative variance: under Gaussian noise Var(classical − robust) ≈ Var(robust) −
    /// Var(classical) (the classical estimator is the efficient one), and 1/e bounds the ratio
    /// from above, so z is conservative.
    pub z: f64,
}

/// The outcome of [`contamination_check`].
///
/// ```
/// use avar::{AvarConfig, robust::robust_allan_variance};
/// let m: processes::Model = "WN(sigma2=1)".parse()?;
/// let x = m.simulate(4096, 100.0, 5)?.into_values();
/// let r = robust_allan_variance(&x, 100.0, &AvarConfig::default(), 0.6)?;
/// let c = gmwm_prep::robust::contamination_check(&x, &r, 0.01, 3)?;
/// let j = c.scales.len();
/// assert_eq!((j, c.alpha), (r.robust.points.len(), 0.01));
/// // one-sided z_{1−α/J} is the two-sided quantile at level 2α/J
/// assert_eq!(c.threshold, gmwm_prep::stats::z_two_sided(2.0 * 0.01 / j as f64));
/// // flagged exactly when some scale exceeds it; windows are located only then
/// assert_eq!(c.contaminated, c.scales.iter().any(|s| s.z > c.threshold));
/// assert_eq!(c.contaminated, c.window_m.is_some());
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContaminationCheck {
    /// True when some scale has z above `threshold`.
    pub contaminated: bool,
    /// One-sided threshold z_{1−α/J} (Bonferroni over the J scales).
    pub threshold: f64,
    /// Level α of the check (the chance of a false alarm on clean Gaussian data is ≤ α).
    pub alpha: f64,
    /// Every scale.
    pub scales: Vec<ScaleComparison>,
    /// Cluster size at which the windows were located (the smallest flagged one).
    pub window_m: Option<u64>,
    /// The time windows contributing most to the excess of the classical AV at `window_m`.
    pub windows: Vec<ExcessWindow>,
    /// A one-line verdict.
    pub message: String,
}

/// Compares the classical and robust AV of `data` (as computed in `r`) scale by scale (see
/// [`ScaleComparison::z`]) and, when the classical one is significantly larger somewhere
/// (level `alpha`, Bonferroni over the scales), locates the `top` time windows (of
/// max(1 s, 8m) samples) whose differences drive the excess at the smallest such scale.
/// Non-Gaussian but clean noise (e.g. heavy quantization at m = 1) can also be flagged:
/// the message says "contaminated or non-Gaussian".
///
/// ```
/// use avar::{AvarConfig, robust::robust_allan_variance};
/// let m: processes::Model = "WN(sigma2=1)".parse()?;
/// let mut x = m.simulate(1 << 16, 100.0, 5)?.into_values();
/// x[30_000] += 200.0; // one spike at t = 300 s (100 Hz)
/// let r = robust_allan_variance(&x, 100.0, &AvarConfig::default(), 0.6)?;
/// let c = gmwm_prep::robust::contamination_check(&x, &r, 0.01, 3)?;
/// assert!(c.contaminated);
/// assert!(c.windows[0].start_s <= 300.0 && 300.0 <= c.windows[0].end_s);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn contamination_check(
    data: &[f64],
    r: &RobustAllanVariance,
    alpha: f64,
    top: usize,
) -> Result<ContaminationCheck> {
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(FitError::InvalidAlpha(alpha));
    }
    let j = r.robust.points.len().max(1);
    let threshold = Normal::standard().inverse_cdf(1.0 - alpha / j as f64);
    let extra = (1.0 / r.efficiency - 1.0).max(0.0);
    let n = r.classical.n as f64;
    let scales: Vec<ScaleComparison> = r
        .classical
        .points
        .iter()
        .zip(&r.robust.points)
        .map(|(c, q)| {
            let rel = match c.edf {
                Some(e) if e > 0.0 => 2.0 / e,
                _ => 1.0 / (2.0 * (n / c.m as f64 - 1.0).max(0.5)),
            };
            let sd = q.avar * (rel * extra).sqrt();
            ScaleComparison {
                m: c.m,
                tau: c.tau,
                classical: c.avar,
                robust: q.avar,
                ratio: c.avar / q.avar,
                z: if sd > 0.0 {
                    (c.avar - q.avar) / sd
                } else {
                    0.0
                },
            }
        })
        .collect();
    let flagged = scales.iter().find(|s| s.z > threshold).copied();
    let rate = r.classical.rate_hz;
    let (window_m, windows) = match flagged {
        Some(s) => {
            let w = (rate.round() as usize).max(8 * s.m as usize).max(1);
            let bw = r.biweight;
            (
                Some(s.m),
                // beyond c·σ̂ with σ̂² = 2·(the robust AV at m), the robust estimate already
                // at hand (every ⌊m/16⌋-th difference; one pass over the samples instead of
                // solving again on all of them)
                excess_windows_at(data, rate, s.m, &bw, 2.0 * s.robust, w, top).map_err(av_err)?,
            )
        }
        None => (None, Vec::new()),
    };
    let message = match flagged {
        None => format!(
            "no sign of contamination: the classical and robust AV agree within the Gaussian \
             sampling noise at every scale (level {alpha}, Bonferroni over {j} scales)"
        ),
        Some(s) => {
            let n_flag = scales.iter().filter(|x| x.z > threshold).count();
            let win = windows
                .iter()
                .map(|w| {
                    format!(
                        "{:.1}–{:.1} s ({:.0} %)",
                        w.start_s,
                        w.end_s,
                        100.0 * w.share
                    )
                })
                .collect::<Vec<_>>()
                .join(", ");
            let largest = windows.iter().map(|w| w.share).fold(0.0, f64::max);
            let head = format!(
                "data look contaminated or non-Gaussian: the classical AV exceeds the robust one \
                 beyond the sampling noise at {n_flag} of {j} scales (first at τ = {} s, ×{})",
                processes::number::sig(s.tau, 4),
                processes::number::sig(s.ratio, 4),
            );
            if largest < SPREAD_SHARE {
                // no window stands out: say what the data are, not where
                format!(
                    "{head}; no part of the record drives it (no window carries {} % of the \
                     excess): the samples are heavier-tailed than Gaussian throughout, which \
                     the robust AV discounts everywhere, not a local disturbance",
                    processes::number::sig(100.0 * SPREAD_SHARE, 2)
                )
            } else {
                format!("{head}; windows driving it: {win}")
            }
        }
    };
    Ok(ContaminationCheck {
        contaminated: flagged.is_some(),
        threshold,
        alpha,
        scales,
        window_m,
        windows,
        message,
    })
}
