//! Does a fitted model describe the Allan variance it was fitted to? One verdict per fit.
//!
//! The measure is the one a reader of an Allan deviation plot applies by eye: at how many of
//! the fitted scales does the model's AV lie inside the estimate's confidence interval? A
//! fit is **adequate** when it does at [`INSIDE_FRACTION_MIN`] (90 %) of the scales or more.
//! Beside it:
//! - the standardised residual of each scale, z_j = ln(ν̂_j / ν(θ̂)_j) / s_j, with s_j the
//!   standard deviation of ln ν̂_j read off the CI (s_j = ln(hi/lo) / (2 z_{1−α/2}); with an
//!   EDF and no CI, s_j = √(2/EDF), the chi-square's log-scale spread): |z| > z_{1−α/2} is
//!   outside the CI;
//! - the τ ranges the model does not explain: maximal runs of consecutive scales outside the
//!   CI on the same side ("model above" or "model below" the AV);
//! - the J test, reported but not part of the flag. With 10⁵–10⁷ samples the J test rejects
//!   every model of a real sensor, however close (its power grows with the record), so a
//!   p-value below 5 % is a reason shown, not a verdict.
//!
//! Under a correct model each scale is outside its 95 % CI with probability 5 %; with 18
//! strongly correlated scales the flag errs towards "not adequate" at a rate that depends on
//! that correlation, so a fit flagged at 16 of 18 deserves a look rather than a rejection.
//! The reasons say how far off it is.

use crate::curve::AvCurve;
use crate::error::{FitError, Result};
use crate::stats::z_two_sided;
use serde::{Deserialize, Serialize};

/// Smallest fraction of the fitted scales at which the fitted AV must lie inside the AV's CI
/// for the fit to be adequate.
pub const INSIDE_FRACTION_MIN: f64 = 0.9;

/// One scale of the check.
///
/// ```
/// use gmwm_prep::{AvCurve, CurvePoint, adequacy::assess};
/// let mut p = CurvePoint::new(1, 0.01, 1.0);
/// (p.avar_lo, p.avar_hi) = (Some(0.5), Some(2.0));
/// let a = assess(&AvCurve::new(vec![p], 100.0, None)?, &[1.5], None)?;
/// let s = &a.scales[0];
/// assert!(s.inside && s.z < 0.0); // the model is above the estimate, within its CI
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScaleCheck {
    /// Averaging time τ (s).
    pub tau: f64,
    /// Standardised residual ln(ν̂/ν(θ̂)) / s (see the module doc); NaN without a CI or EDF.
    pub z: f64,
    /// Whether the fitted AV lies inside the AV's CI at this scale.
    pub inside: bool,
}

/// A run of consecutive scales the model does not explain.
///
/// ```
/// use gmwm_prep::adequacy::TauRange;
/// let r = TauRange { tau_lo: 0.04, tau_hi: 0.08, n_scales: 2, model_above: false };
/// assert_eq!(r.describe(), "τ = 0.04–0.08 s (2 scales, model below the AV)");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TauRange {
    /// Smallest τ of the run (s).
    pub tau_lo: f64,
    /// Largest τ of the run (s).
    pub tau_hi: f64,
    /// Number of scales in it.
    pub n_scales: usize,
    /// True when the fitted AV is above the CI there (the model overstates the noise).
    pub model_above: bool,
}

impl TauRange {
    /// The range in words, τ to 4 significant digits.
    ///
    /// ```
    /// use gmwm_prep::adequacy::TauRange;
    /// let r = TauRange { tau_lo: 327.68, tau_hi: 327.68, n_scales: 1, model_above: true };
    /// assert_eq!(r.describe(), "τ = 327.7 s (1 scale, model above the AV)");
    /// ```
    pub fn describe(&self) -> String {
        let s = |x| processes::number::sig(x, 4);
        let span = if self.n_scales == 1 {
            format!("τ = {} s", s(self.tau_lo))
        } else {
            format!("τ = {}–{} s", s(self.tau_lo), s(self.tau_hi))
        };
        format!(
            "{span} ({} scale{}, model {} the AV)",
            self.n_scales,
            if self.n_scales == 1 { "" } else { "s" },
            if self.model_above { "above" } else { "below" }
        )
    }
}

/// The verdict on one fit (see the module doc).
///
/// ```
/// use gmwm_prep::{AvCurve, adequacy::assess};
/// use avar::{allan_variance, AvarConfig};
/// // white noise of variance 1e-4 at 100 Hz, checked against its own theoretical AV σ²/m
/// let wn: processes::Model = "WN(sigma2=1e-4)".parse()?;
/// let x = wn.simulate(1 << 16, 100.0, 7)?;
/// let av = allan_variance(x.values(), 100.0, &AvarConfig::default())?;
/// let curve = AvCurve::from_avar(&av)?;
/// let truth: Vec<f64> = curve.m().iter().map(|&m| 1e-4 / m as f64).collect();
/// let a = assess(&curve, &truth, None)?;
/// assert_eq!(a.n_scales, curve.len());
/// assert!(a.n_inside <= a.n_scales && a.adequate == (a.inside_fraction >= 0.9));
/// // ten times the truth is outside the CIs of the well-estimated scales (the last few,
/// // of one to three EDFs, have CIs wide enough to hold it): not adequate, model above
/// let a = assess(&curve, &truth.iter().map(|v| 10.0 * v).collect::<Vec<_>>(), None)?;
/// assert!(!a.adequate && a.n_inside < a.n_scales / 2);
/// assert!(a.unexplained[0].model_above && a.unexplained[0].tau_lo == curve.points[0].tau);
/// assert!(a.reasons[0].starts_with("fitted AV inside"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Adequacy {
    /// Whether the model describes the AV: inside the CI at ≥ [`INSIDE_FRACTION_MIN`] of the
    /// scales that have one.
    pub adequate: bool,
    /// Fraction of the scales with a CI at which the fitted AV is inside it.
    pub inside_fraction: f64,
    /// Scales with a CI (or an EDF).
    pub n_scales: usize,
    /// Of those, how many have the fitted AV inside.
    pub n_inside: usize,
    /// CI level the check used (1 − α of the curve).
    pub ci_level: f64,
    /// J-test p-value, when the fit has one.
    pub j_test_p: Option<f64>,
    /// The τ ranges the model does not explain.
    pub unexplained: Vec<TauRange>,
    /// The verdict in words: the first line gives the inside count, then each unexplained
    /// range, then the J test when it rejects.
    pub reasons: Vec<String>,
    /// Each scale's check (for the residual panel).
    pub scales: Vec<ScaleCheck>,
}

/// Checks `fitted` (the model's AV at each scale of `curve`) against the CIs of `curve`;
/// `j_test_p` is the fit's J-test p-value if it has one. Scales with neither a CI nor an EDF
/// are left out of the count; a curve with none at all is an error (nothing to check against).
///
/// ```
/// use gmwm_prep::{AvCurve, adequacy::assess};
/// let c = AvCurve::from_m(&[1, 2], &[1.0, 0.5], 100.0)?; // no CIs, no EDFs
/// assert!(assess(&c, &[1.0, 0.5], None).is_err());
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn assess(curve: &AvCurve, fitted: &[f64], j_test_p: Option<f64>) -> Result<Adequacy> {
    if fitted.len() != curve.len() {
        return Err(FitError::InvalidArgument(format!(
            "adequacy: {} fitted values for {} scales",
            fitted.len(),
            curve.len()
        )));
    }
    let z_crit = z_two_sided(curve.alpha);
    let mut scales = Vec::with_capacity(curve.len());
    for (p, &f) in curve.points.iter().zip(fitted) {
        let (lo, hi, s) = match (p.avar_lo, p.avar_hi, p.edf) {
            (Some(lo), Some(hi), _) if lo > 0.0 && hi > lo => {
                (lo, hi, (hi / lo).ln() / (2.0 * z_crit))
            }
            (_, _, Some(edf)) if edf > 0.0 => {
                let s = (2.0 / edf).sqrt();
                (p.avar * (-z_crit * s).exp(), p.avar * (z_crit * s).exp(), s)
            }
            _ => continue,
        };
        scales.push((
            ScaleCheck {
                tau: p.tau,
                z: (p.avar / f).ln() / s,
                inside: lo <= f && f <= hi,
            },
            f > hi,
        ));
    }
    if scales.is_empty() {
        return Err(FitError::InvalidArgument(
            "adequacy: the curve has no confidence intervals or EDFs to check the fit against"
                .into(),
        ));
    }
    let n_scales = scales.len();
    let n_inside = scales.iter().filter(|(s, _)| s.inside).count();
    let inside_fraction = n_inside as f64 / n_scales as f64;
    let mut unexplained: Vec<TauRange> = Vec::new();
    let mut prev_outside = false;
    for (s, above) in &scales {
        if s.inside {
            prev_outside = false;
            continue;
        }
        match unexplained.last_mut() {
            Some(r) if prev_outside && r.model_above == *above => {
                r.tau_hi = s.tau;
                r.n_scales += 1;
            }
            _ => unexplained.push(TauRange {
                tau_lo: s.tau,
                tau_hi: s.tau,
                n_scales: 1,
                model_above: *above,
            }),
        }
        prev_outside = true;
    }
    let ci_level = 1.0 - curve.alpha;
    let adequate = inside_fraction >= INSIDE_FRACTION_MIN;
    let mut reasons = vec![format!(
        "fitted AV inside the {} % CI at {n_inside} of {n_scales} scales ({} %; adequate from {} %)",
        processes::number::sig(100.0 * ci_level, 4),
        processes::number::sig(100.0 * inside_fraction, 3),
        processes::number::sig(100.0 * INSIDE_FRACTION_MIN, 3),
    )];
    reasons.extend(
        unexplained
            .iter()
            .map(|r| format!("not explained: {}", r.describe())),
    );
    if let Some(p) = j_test_p
        && p < 0.05
    {
        reasons.push(format!(
            "J test rejects the model at 5 % (p {}); with long records it rejects small misfits too",
            if p < 1e-3 {
                "< 0.001".to_string()
            } else {
                format!("= {}", processes::number::sig(p, 2))
            }
        ));
    }
    Ok(Adequacy {
        adequate,
        inside_fraction,
        n_scales,
        n_inside,
        ci_level,
        j_test_p,
        unexplained,
        reasons,
        scales: scales.into_iter().map(|(s, _)| s).collect(),
    })
}

/// Whether the smallest scales of `curve` are shaped by an anti-aliasing or decimation
/// filter, and from which τ (s) to fit if so.
///
/// White noise has AV(τ)·τ constant (the slope −½ line of the Allan deviation); a low-pass
/// filter removes variance at the shortest τ, so there the AV falls *below* that line, a
/// shape no sum of the latent processes with a white-noise part reproduces (quantization
/// noise lies above it). The rule: among the first six scales, find the first pair whose
/// Allan-deviation slope is within [`crate::ieee::SLOPE_TOLERANCE`] of −½; if every scale
/// before it has its upper CI bound (or, without one, its value) below the white-noise line
/// through that pair's first scale, return that scale's τ as the suggested `--tau-min`.
///
/// ```
/// use gmwm_prep::{AvCurve, adequacy::filtered_small_scales, theory::model_avar};
/// // a moving average X_t = e_t + 0.9 e_{t−1} (a low-pass filter) sampled at 100 Hz:
/// // m·AV(m) = σ²((1 + θ)² − 3θ/m): 0.91, 2.26, 2.94, 3.27 … at m = 1, 2, 4, 8 (below the
/// // white-noise line up to m = 4, where the slope first comes within 0.1 of −½)
/// let m: Vec<u64> = (0..14).map(|j| 1u64 << j).collect();
/// let ma: processes::Model = "MA1(theta=0.9, sigma2=1)".parse()?;
/// let c = AvCurve::from_m(&m, &model_avar(&ma, &m, 100.0)?, 100.0)?;
/// assert_eq!(filtered_small_scales(&c), Some(0.04)); // fit from m = 4 on
/// // white noise and quantization noise are not flagged
/// let wn: processes::Model = "WN(sigma2=1) + QN(q2=0.1)".parse()?;
/// let c = AvCurve::from_m(&m, &model_avar(&wn, &m, 100.0)?, 100.0)?;
/// assert_eq!(filtered_small_scales(&c), None);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn filtered_small_scales(curve: &AvCurve) -> Option<f64> {
    let p = &curve.points;
    if p.len() < 4 {
        return None;
    }
    for j0 in 1..p.len().min(6) - 1 {
        let (a, b) = (&p[j0], &p[j0 + 1]);
        if !(a.avar > 0.0 && b.avar > 0.0) {
            return None;
        }
        let slope = 0.5 * (b.avar / a.avar).ln() / (b.tau / a.tau).ln();
        if (slope + 0.5).abs() <= crate::ieee::SLOPE_TOLERANCE {
            let below = p[..j0].iter().all(|q| {
                let line = a.avar * a.tau / q.tau;
                q.avar_hi.unwrap_or(q.avar) < line
            });
            return below.then_some(a.tau);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CurvePoint;

    fn curve(av: &[f64], lo: &[f64], hi: &[f64]) -> AvCurve {
        let pts = (0..av.len())
            .map(|j| {
                let mut p = CurvePoint::new(1 << j, 0.01 * (1 << j) as f64, av[j]);
                (p.avar_lo, p.avar_hi) = (Some(lo[j]), Some(hi[j]));
                p
            })
            .collect();
        AvCurve::new(pts, 100.0, None).unwrap()
    }

    /// Runs split where the side changes or a scale is inside; counts are exact.
    #[test]
    fn ranges_follow_runs_and_sides() {
        let av = [1.0; 8];
        let (lo, hi) = ([0.5; 8], [2.0; 8]);
        let fit = [3.0, 3.0, 1.0, 0.1, 0.1, 3.0, 1.0, 1.0];
        let a = assess(&curve(&av, &lo, &hi), &fit, Some(0.2)).unwrap();
        assert_eq!((a.n_inside, a.n_scales), (3, 8));
        let got: Vec<(usize, bool)> = a
            .unexplained
            .iter()
            .map(|r| (r.n_scales, r.model_above))
            .collect();
        assert_eq!(got, [(2, true), (2, false), (1, true)]);
        assert_eq!(
            (a.unexplained[0].tau_lo, a.unexplained[0].tau_hi),
            (0.01, 0.02)
        );
        assert!(!a.adequate);
        // 1 header + 3 ranges; the J test does not reject at p = 0.2
        assert_eq!(a.reasons.len(), 4);
    }

    /// The CI bounds count as inside; 9 of 10 is adequate, 8 of 10 is not.
    #[test]
    fn threshold_is_ninety_percent_inclusive() {
        let av = [1.0; 10];
        let (lo, hi) = ([0.5; 10], [2.0; 10]);
        let mut fit = [2.0; 10];
        fit[0] = 2.5;
        let a = assess(&curve(&av, &lo, &hi), &fit, None).unwrap();
        assert!(a.adequate && a.n_inside == 9);
        fit[1] = 0.4;
        let a = assess(&curve(&av, &lo, &hi), &fit, Some(1e-6)).unwrap();
        assert!(!a.adequate && a.n_inside == 8);
        assert!(a.reasons.last().unwrap().contains("p < 0.001"));
    }

    /// z is ln(ν̂/ν)/s with s from the CI: at the upper CI bound z = −z_crit exactly.
    #[test]
    fn residual_at_the_bound_is_the_critical_value() {
        let a = assess(&curve(&[1.0], &[0.5], &[2.0]), &[2.0], None).unwrap();
        let zc = z_two_sided(0.05);
        assert!((a.scales[0].z + zc).abs() < 1e-12);
    }

    #[test]
    fn length_mismatch_is_an_error() {
        assert!(assess(&curve(&[1.0], &[0.5], &[2.0]), &[1.0, 2.0], None).is_err());
    }
}
