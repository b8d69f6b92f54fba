//! Plain Allan variance curves, the input of every estimator of this crate.
//!
//! A curve can come from the `avar` crate, from a published table (e.g. the R package
//! avar's curves) or from theory; it only needs the cluster sizes m (samples), the AV values
//! and the sampling rate, optionally with CIs, per-scale variances or EDFs.

use crate::error::{FitError, Result};
use serde::{Deserialize, Serialize};

/// One scale of an Allan variance curve.
///
/// `m` is the cluster size in samples, `tau = m / rate` in seconds, `avar` the AV in unit²
/// (e.g. (°/s)²). The optional fields describe its uncertainty: a CI `[avar_lo, avar_hi]`,
/// the variance `var` of the estimate (unit⁴), or its equivalent degrees of freedom `edf`.
///
/// ```
/// use gmwm_prep::CurvePoint;
/// let p = CurvePoint::new(4, 0.04, 2.5e-5);
/// assert_eq!(p.adev(), 5e-3);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// Cluster size m in samples.
    pub m: u64,
    /// Averaging time τ = m / rate in seconds.
    pub tau: f64,
    /// Allan variance (unit²).
    pub avar: f64,
    /// Lower CI bound of the AV (unit²), if known.
    pub avar_lo: Option<f64>,
    /// Upper CI bound of the AV (unit²), if known.
    pub avar_hi: Option<f64>,
    /// Variance of the AV estimate (unit⁴), if known.
    pub var: Option<f64>,
    /// Equivalent degrees of freedom of the AV estimate, if known.
    pub edf: Option<f64>,
}

impl CurvePoint {
    /// A point with no uncertainty information.
    ///
    /// ```
    /// use gmwm_prep::CurvePoint;
    /// let p = CurvePoint::new(8, 0.08, 1e-5);
    /// assert_eq!((p.m, p.tau, p.avar), (8, 0.08, 1e-5));
    /// assert!(p.avar_lo.is_none() && p.avar_hi.is_none() && p.var.is_none() && p.edf.is_none());
    /// ```
    pub fn new(m: u64, tau: f64, avar: f64) -> Self {
        Self {
            m,
            tau,
            avar,
            avar_lo: None,
            avar_hi: None,
            var: None,
            edf: None,
        }
    }
    /// The Allan deviation √AV (unit).
    ///
    /// ```
    /// let p = gmwm_prep::CurvePoint::new(1, 0.01, 0.25);
    /// assert_eq!(p.adev(), 0.5);
    /// ```
    pub fn adev(&self) -> f64 {
        self.avar.sqrt()
    }
}

/// An Allan variance curve: points at increasing cluster sizes, the sampling rate (Hz),
/// the series length `n` (samples, if known) and the confidence level `1 − alpha` of
/// the CIs it carries.
///
/// ```
/// use gmwm_prep::AvCurve;
/// // AV of a white noise σ² = 1e-4 at 100 Hz, m = 2, 4, 8.
/// let m = [2u64, 4, 8];
/// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect();
/// let c = AvCurve::from_m(&m, &av, 100.0)?;
/// assert_eq!(c.points[1].tau, 0.04);
/// assert!(AvCurve::from_m(&m, &[1.0, f64::NAN, 1.0], 100.0).is_err());
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AvCurve {
    /// Sampling rate in Hz.
    pub rate_hz: f64,
    /// Length of the series the curve was estimated from (samples), if known.
    pub n: Option<u64>,
    /// Significance level of the CIs in the points (0.05 for 95% CIs).
    pub alpha: f64,
    /// The scales, by increasing m.
    pub points: Vec<CurvePoint>,
}

/// Relative tolerance for τ·rate to be accepted as an integer cluster size.
const TAU_TO_M_REL_TOL: f64 = 1e-6;

impl AvCurve {
    /// Builds a curve from points, validating it (see [`AvCurve::validate`]).
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, CurvePoint};
    /// let pts = vec![CurvePoint::new(1, 0.01, 4e-4), CurvePoint::new(2, 0.02, 2e-4)];
    /// let c = AvCurve::new(pts.clone(), 100.0, Some(1000))?;
    /// assert_eq!((c.len(), c.n, c.alpha), (2, Some(1000), 0.05));
    /// // cluster sizes must increase strictly
    /// assert!(AvCurve::new(vec![pts[1], pts[0]], 100.0, None).is_err());
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn new(points: Vec<CurvePoint>, rate_hz: f64, n: Option<u64>) -> Result<Self> {
        let c = Self {
            rate_hz,
            n,
            alpha: 0.05,
            points,
        };
        c.validate()?;
        Ok(c)
    }

    /// Builds a curve from cluster sizes m (samples) and AV values; τ = m / rate.
    ///
    /// ```
    /// use gmwm_prep::AvCurve;
    /// let c = AvCurve::from_m(&[1, 10], &[1e-4, 1e-5], 50.0)?;
    /// assert_eq!(c.tau(), vec![0.02, 0.2]); // τ = m / rate
    /// assert!(AvCurve::from_m(&[1, 10], &[1e-4], 50.0).is_err()); // lengths differ
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn from_m(m: &[u64], avar: &[f64], rate_hz: f64) -> Result<Self> {
        if m.len() != avar.len() {
            return Err(FitError::InvalidCurve(format!(
                "{} cluster sizes but {} AV values",
                m.len(),
                avar.len()
            )));
        }
        check_rate(rate_hz)?;
        let pts = m
            .iter()
            .zip(avar)
            .map(|(&m, &a)| CurvePoint::new(m, m as f64 / rate_hz, a))
            .collect();
        Self::new(pts, rate_hz, None)
    }

    /// Builds a curve from averaging times τ (s) and AV values; m = round(τ · rate), which
    /// must be an integer to 1e-6 relative.
    ///
    /// ```
    /// use gmwm_prep::AvCurve;
    /// let c = AvCurve::from_tau(&[0.01, 0.04], &[1e-4, 2.5e-5], 100.0)?;
    /// assert_eq!(c.m(), vec![1, 4]);
    /// assert_eq!(c.tau(), vec![0.01, 0.04]); // the given τ are kept
    /// // 0.015 s at 100 Hz is 1.5 samples
    /// assert!(AvCurve::from_tau(&[0.015], &[1e-4], 100.0).is_err());
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn from_tau(tau: &[f64], avar: &[f64], rate_hz: f64) -> Result<Self> {
        check_rate(rate_hz)?;
        let mut m = Vec::with_capacity(tau.len());
        for (i, &t) in tau.iter().enumerate() {
            if !(t.is_finite() && t > 0.0) {
                return Err(FitError::NonFinite {
                    index: i,
                    what: "tau",
                    value: t,
                });
            }
            let x = t * rate_hz;
            let r = x.round();
            if r < 1.0 || (x - r).abs() > TAU_TO_M_REL_TOL * x {
                return Err(FitError::InvalidCurve(format!(
                    "tau = {t} s at {rate_hz} Hz is not a whole number of samples"
                )));
            }
            m.push(r as u64);
        }
        let mut c = Self::from_m(&m, avar, rate_hz)?;
        for (p, &t) in c.points.iter_mut().zip(tau) {
            p.tau = t;
        }
        Ok(c)
    }

    /// The curve of an `avar` result: its cluster sizes, AV values, CI bounds and EDFs, series
    /// length and CI level. Errors when an AV is zero or not finite.
    ///
    /// ```
    /// use avar::{allan_variance, AvarConfig};
    /// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
    /// let av = allan_variance(&x, 10.0, &AvarConfig::default()).unwrap();
    /// let c = gmwm_prep::AvCurve::from_avar(&av)?;
    /// assert_eq!(c.len(), av.points.len());
    /// assert_eq!(c.n, Some(4096));
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn from_avar(av: &avar::AllanVariance) -> Result<Self> {
        let points = av
            .points
            .iter()
            .map(|p| CurvePoint {
                m: p.m,
                tau: p.tau,
                avar: p.avar,
                avar_lo: p.avar_lo,
                avar_hi: p.avar_hi,
                var: None,
                edf: p.edf,
            })
            .collect();
        let c = Self {
            rate_hz: av.rate_hz,
            n: Some(av.n as u64),
            alpha: av.alpha,
            points,
        };
        c.validate()?;
        Ok(c)
    }

    /// Sets the series length `n` (samples).
    ///
    /// ```
    /// let c = gmwm_prep::AvCurve::from_m(&[1, 2], &[2.0, 1.0], 1.0)?;
    /// assert_eq!(c.n, None);
    /// assert_eq!(c.with_n(1000).n, Some(1000));
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn with_n(mut self, n: u64) -> Self {
        self.n = Some(n);
        self
    }

    /// Number of scales.
    ///
    /// ```
    /// let c = gmwm_prep::AvCurve::from_m(&[1, 2, 4], &[4.0, 2.0, 1.0], 1.0)?;
    /// assert_eq!(c.len(), 3);
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when the curve has no scale.
    ///
    /// ```
    /// use gmwm_prep::AvCurve;
    /// let c = AvCurve::from_m(&[1], &[1.0], 1.0)?;
    /// assert!(!c.is_empty());
    /// // only a curve built field by field can be empty, and it does not validate
    /// let empty = AvCurve { points: Vec::new(), ..c };
    /// assert!(empty.is_empty() && empty.validate().is_err());
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Cluster sizes m (samples).
    ///
    /// ```
    /// // m = τ · rate
    /// let c = gmwm_prep::AvCurve::from_tau(&[0.5, 1.0, 2.0], &[4.0, 2.0, 1.0], 4.0)?;
    /// assert_eq!(c.m(), vec![2, 4, 8]);
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn m(&self) -> Vec<u64> {
        self.points.iter().map(|p| p.m).collect()
    }

    /// Averaging times τ (s).
    ///
    /// ```
    /// // τ = m / rate
    /// let c = gmwm_prep::AvCurve::from_m(&[2, 4, 8], &[4.0, 2.0, 1.0], 4.0)?;
    /// assert_eq!(c.tau(), vec![0.5, 1.0, 2.0]);
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn tau(&self) -> Vec<f64> {
        self.points.iter().map(|p| p.tau).collect()
    }

    /// AV values (unit²).
    ///
    /// ```
    /// let c = gmwm_prep::AvCurve::from_m(&[2, 4, 8], &[4.0, 2.0, 1.0], 4.0)?;
    /// assert_eq!(c.avar(), vec![4.0, 2.0, 1.0]);
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn avar(&self) -> Vec<f64> {
        self.points.iter().map(|p| p.avar).collect()
    }

    /// The sub-curve of the points at indices `range`.
    ///
    /// ```
    /// let c = gmwm_prep::AvCurve::from_m(&[1, 2, 4, 8], &[8.0, 4.0, 2.0, 1.0], 1.0)?.with_n(64);
    /// let s = c.slice(1..3)?;
    /// assert_eq!((s.m(), s.avar()), (vec![2, 4], vec![4.0, 2.0]));
    /// assert_eq!((s.rate_hz, s.n), (c.rate_hz, c.n)); // the rest is kept
    /// assert!(c.slice(2..5).is_err()); // past the end
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn slice(&self, range: std::ops::Range<usize>) -> Result<Self> {
        if range.start >= range.end || range.end > self.len() {
            return Err(FitError::InvalidCurve(format!(
                "range {range:?} out of a {}-scale curve",
                self.len()
            )));
        }
        Ok(Self {
            points: self.points[range].to_vec(),
            ..self.clone()
        })
    }

    /// Checks the curve: finite positive rate, at least one point, strictly increasing m ≥ 1,
    /// finite positive τ and AV, CI bounds (if any) finite with 0 ≤ lo ≤ AV ≤ hi... (a
    /// negative Gaussian lower bound is accepted and ignored), variances/EDF finite and > 0,
    /// alpha in (0, 1).
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, FitError};
    /// let mut c = AvCurve::from_m(&[1, 2], &[2.0, 1.0], 1.0)?;
    /// assert!(c.validate().is_ok());
    /// c.points[1].avar = -1.0;
    /// assert!(matches!(c.validate(), Err(FitError::NonFinite { index: 1, what: "avar", .. })));
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn validate(&self) -> Result<()> {
        check_rate(self.rate_hz)?;
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(FitError::InvalidAlpha(self.alpha));
        }
        if self.points.is_empty() {
            return Err(FitError::TooFewScales {
                what: "an AV curve".into(),
                needed: 1,
                got: 0,
            });
        }
        for (i, p) in self.points.iter().enumerate() {
            let pos = |what, v: f64| {
                if v.is_finite() && v > 0.0 {
                    Ok(())
                } else {
                    Err(FitError::NonFinite {
                        index: i,
                        what,
                        value: v,
                    })
                }
            };
            if p.m == 0 {
                return Err(FitError::NonFinite {
                    index: i,
                    what: "m",
                    value: 0.0,
                });
            }
            pos("tau", p.tau)?;
            pos("avar", p.avar)?;
            if let Some(v) = p.avar_hi {
                pos("avar_hi", v)?;
            }
            if let Some(v) = p.avar_lo
                && !v.is_finite()
            {
                return Err(FitError::NonFinite {
                    index: i,
                    what: "avar_lo",
                    value: v,
                });
            }
            if let Some(v) = p.var {
                pos("var", v)?;
            }
            if let Some(v) = p.edf {
                pos("edf", v)?;
            }
            if i > 0 && p.m <= self.points[i - 1].m {
                return Err(FitError::InvalidCurve(format!(
                    "cluster sizes must increase strictly (m = {} after {})",
                    p.m,
                    self.points[i - 1].m
                )));
            }
        }
        Ok(())
    }

    /// The relative variance Var(AV̂_j)/AV̂_j² of each scale, from the best information
    /// the curve carries, in this order: the variance `var`; the EDF (χ² model:
    /// 2/edf); the CI (log-normal reading: ((ln hi − ln lo) / (2 z_{1−α/2}))², or from the
    /// upper bound alone when the lower one is ≤ 0); the series length n (white-noise rule
    /// of thumb 1/(2(n/m − 1)), the "percentage error" of R avar, squared); otherwise 1
    /// (unit relative weights).
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, CurvePoint};
    /// let mut p = CurvePoint::new(2, 0.02, 1.0);
    /// p.edf = Some(50.0);
    /// let c = AvCurve::new(vec![p], 100.0, None)?;
    /// assert_eq!(c.relative_variances(), vec![0.04]);
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn relative_variances(&self) -> Vec<f64> {
        let z = crate::stats::z_two_sided(self.alpha);
        self.points
            .iter()
            .map(|p| {
                if let Some(v) = p.var {
                    return v / (p.avar * p.avar);
                }
                if let Some(e) = p.edf {
                    return 2.0 / e;
                }
                if let Some(hi) = p.avar_hi
                    && hi > p.avar
                {
                    let s = match p.avar_lo {
                        Some(lo) if lo > 0.0 && lo < p.avar => (hi / lo).ln() / (2.0 * z),
                        _ => (hi / p.avar).ln() / z,
                    };
                    return s * s;
                }
                if let Some(n) = self.n {
                    let k = n as f64 / p.m as f64 - 1.0;
                    if k > 0.5 {
                        return 1.0 / (2.0 * k);
                    }
                }
                1.0
            })
            .collect()
    }
}

pub(crate) fn check_rate(rate_hz: f64) -> Result<()> {
    if rate_hz.is_finite() && rate_hz > 0.0 {
        Ok(())
    } else {
        Err(FitError::InvalidArgument(format!(
            "sampling rate must be finite and > 0 Hz, got {rate_hz}"
        )))
    }
}
