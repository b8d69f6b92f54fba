//! Result types: one [`AvarPoint`] per cluster size, collected in [`AllanVariance`].

use serde::{Deserialize, Serialize};

use crate::config::{CiMethod, Estimator, InputKind};

/// The Allan variance at one cluster size.
///
/// Units: `tau` in seconds; `avar` in (rate unit)², `adev` in rate units (e.g. (°/s)² and °/s
/// for a gyro sampled in °/s). CI bounds are `None` when no interval was requested or when it
/// is undefined at this scale.
///
/// ```
/// use avar::{allan_variance, AvarConfig, CiMethod, Scales};
/// let x = [1.0, -1.0, 1.0, -1.0, 1.0, -1.0];
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![1]), ci: CiMethod::None, ..Default::default() };
/// let p = &allan_variance(&x, 1.0, &cfg).unwrap().points[0];
/// // every difference of neighbours is ±2: AV = 4/2 = 2 over T − 2m + 1 = 5 terms
/// assert_eq!((p.m, p.avar, p.n_terms), (1, 2.0, 5));
/// let json = serde_json::to_string(p).unwrap();
/// assert!(json.contains("\"n_terms\":5"));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AvarPoint {
    /// Cluster size (samples).
    pub m: u64,
    /// Averaging time τ = m / rate (seconds).
    pub tau: f64,
    /// Allan variance estimate (rate unit squared).
    pub avar: f64,
    /// Allan deviation √avar (rate unit).
    pub adev: f64,
    /// Lower CI bound of the AV. For the Gaussian family it may be negative (book Remark 4.7);
    /// see [`AvarPoint::lower_negative`].
    pub avar_lo: Option<f64>,
    /// Upper CI bound of the AV.
    pub avar_hi: Option<f64>,
    /// Lower CI bound of the AD (√ of `avar_lo`, clipped at 0 when that is negative).
    pub adev_lo: Option<f64>,
    /// Upper CI bound of the AD.
    pub adev_hi: Option<f64>,
    /// Equivalent degrees of freedom of the chi-square interval (η for the Haar WV family).
    pub edf: Option<f64>,
    /// Number of squared differences in the sum (T − 2m + 1 overlapping, ⌊T/m⌋ − 1 non-overlapping).
    pub n_terms: u64,
    /// Power-law exponent α (S_y ∝ f^α: 2 WPM, 1 FPM, 0 WFM/white rate noise, −1 flicker FM,
    /// −2 random walk) identified at this scale by the lag-1 ACF method (Riley & Greenhall
    /// rounding), when a chi-square CI was computed. The EDF uses the conservative variant
    /// [`crate::ci::NoiseId::alpha_edf`], which differs only when the identification is uncertain.
    #[serde(default)]
    pub noise_alpha: Option<i32>,
    /// True when the Gaussian lower bound was negative (book Remark 4.7); `avar_lo` then keeps the
    /// negative value and `adev_lo` is 0.
    #[serde(default)]
    pub lower_negative: bool,
}

impl AvarPoint {
    /// A point without CI.
    pub(crate) fn bare(m: u64, rate_hz: f64, avar: f64, n_terms: u64) -> Self {
        AvarPoint {
            m,
            tau: m as f64 / rate_hz,
            avar,
            adev: avar.sqrt(),
            avar_lo: None,
            avar_hi: None,
            adev_lo: None,
            adev_hi: None,
            edf: None,
            n_terms,
            noise_alpha: None,
            lower_negative: false,
        }
    }

    /// Sets the AV interval [lo, hi] and the derived AD interval and flag.
    pub(crate) fn set_interval(&mut self, lo: f64, hi: f64) {
        self.avar_lo = Some(lo);
        self.avar_hi = Some(hi);
        self.lower_negative = lo < 0.0;
        self.adev_lo = Some(lo.max(0.0).sqrt());
        self.adev_hi = Some(hi.max(0.0).sqrt());
    }
}

/// Log-log slope of the AV between two adjacent scales.
///
/// `avar_slope` = Δ ln AV / Δ ln τ; the AD slope is half of it. Reference slopes of the AD:
/// −1 quantization, −1/2 white noise, 0 flicker, +1/2 random walk, +1 drift (REFERENCES §5).
///
/// ```
/// use avar::{allan_variance, AvarConfig, CiMethod, Scales};
/// // a rate ramp of 0.5 per sample at 4 Hz: AV = 0.25·m²/2, i.e. 0.5 at m = 2 and 8 at m = 8
/// let x: Vec<f64> = (0..64).map(|i| 0.5 * i as f64).collect();
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![2, 8]), ci: CiMethod::None, ..Default::default() };
/// let s = allan_variance(&x, 4.0, &cfg).unwrap().slopes()[0];
/// assert_eq!((s.tau_lo, s.tau_hi), (0.5, 2.0));
/// // ln 16 / ln 4 = 2, up to the rounding of the logarithms
/// assert!((s.avar_slope - 2.0).abs() < 1e-12);
/// assert_eq!(s.adev_slope, s.avar_slope / 2.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Slope {
    /// Smaller τ (s).
    pub tau_lo: f64,
    /// Larger τ (s).
    pub tau_hi: f64,
    /// Slope of ln AV against ln τ.
    pub avar_slope: f64,
    /// Slope of ln AD against ln τ (= avar_slope / 2).
    pub adev_slope: f64,
}

/// An Allan-variance curve: one [`AvarPoint`] per cluster size, ascending in m.
///
/// ```
/// use avar::{allan_variance, AvarConfig};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 13) as f64).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default()).unwrap();
/// assert_eq!(av.n, 4096);
/// assert_eq!(av.points.first().unwrap().m, 2);
/// assert_eq!(av.points.last().unwrap().m, 1024); // j = 1..=10 since 2^(j+1) < 4096
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AllanVariance {
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Number of rate samples T (angle input: angle samples − 1).
    pub n: usize,
    /// The estimator used.
    pub estimator: Estimator,
    /// The kind of input the curve was computed from.
    pub input: InputKind,
    /// The CI family of the bounds in `points`.
    pub ci: CiMethod,
    /// CI level: intervals have nominal coverage 1 − alpha.
    pub alpha: f64,
    /// Mean of the rate samples (rate unit); subtracted before summing (the AV does not depend on it).
    pub mean: f64,
    /// One entry per cluster size, ascending.
    pub points: Vec<AvarPoint>,
}

impl AllanVariance {
    /// Log-log slopes between adjacent scales (one fewer than points). Pairs where either AV
    /// is zero give a non-finite slope (±inf or NaN) rather than an error.
    ///
    /// ```
    /// use avar::{allan_variance, AvarConfig, CiMethod, Scales};
    /// // a pure ramp of rate (drift): AV = ω² m² / 2 exactly, so the AV slope is +2
    /// let x: Vec<f64> = (0..1000).map(|i| 0.5 * i as f64).collect();
    /// let cfg = AvarConfig { ci: CiMethod::None, ..Default::default() };
    /// let av = allan_variance(&x, 1.0, &cfg).unwrap();
    /// for s in av.slopes() { assert!((s.avar_slope - 2.0).abs() < 1e-9); }
    /// ```
    pub fn slopes(&self) -> Vec<Slope> {
        self.points
            .windows(2)
            .map(|w| {
                let s = (w[1].avar.ln() - w[0].avar.ln()) / (w[1].tau.ln() - w[0].tau.ln());
                Slope {
                    tau_lo: w[0].tau,
                    tau_hi: w[1].tau,
                    avar_slope: s,
                    adev_slope: s / 2.0,
                }
            })
            .collect()
    }

    /// The τ values (s).
    ///
    /// ```
    /// # use avar::{allan_variance, AvarConfig};
    /// let av = allan_variance(&[0.0, 1.0, 0.0, 2.0, 0.0, 1.0, 3.0, 1.0], 2.0, &AvarConfig::default()).unwrap();
    /// assert_eq!(av.taus(), vec![1.0]);
    /// ```
    pub fn taus(&self) -> Vec<f64> {
        self.points.iter().map(|p| p.tau).collect()
    }

    /// The AV values (rate unit²).
    ///
    /// ```
    /// # use avar::{allan_variance, AvarConfig};
    /// let av = allan_variance(&[0.0, 1.0, 0.0, 2.0, 0.0, 1.0, 3.0, 1.0], 2.0, &AvarConfig::default()).unwrap();
    /// assert_eq!(av.avars().len(), 1);
    /// ```
    pub fn avars(&self) -> Vec<f64> {
        self.points.iter().map(|p| p.avar).collect()
    }

    /// The AD values (rate unit).
    ///
    /// ```
    /// # use avar::{allan_variance, AvarConfig};
    /// let av = allan_variance(&[0.0, 1.0, 0.0, 2.0, 0.0, 1.0, 3.0, 1.0], 2.0, &AvarConfig::default()).unwrap();
    /// assert_eq!(av.adevs()[0], av.avars()[0].sqrt());
    /// ```
    pub fn adevs(&self) -> Vec<f64> {
        self.points.iter().map(|p| p.adev).collect()
    }
}
