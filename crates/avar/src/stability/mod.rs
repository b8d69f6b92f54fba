//! The frequency-stability family beside the Allan variance: modified Allan (MVAR/MDEV), time
//! (TVAR/TDEV), Hadamard (HVAR/HDEV non-overlapping, OHVAR/OHDEV overlapping) and total
//! (TOTVAR/TOTDEV) variances, as defined in NIST SP 1065 and computed by Stable32.
//!
//! Every member works on the phase x_k (time error, s, or angle) at spacing τ0 = 1/rate:
//! rate (fractional frequency) samples y_1..y_T are integrated to T + 1 phase points
//! x_k = x_{k−1} + y_k·τ0, angle (phase) samples are used as they are. With N = T + 1 phase
//! points, cluster size m (samples) and τ = m·τ0 (s):
//!
//! ```text
//! MVAR(τ)  = Σ_{j=0}^{N−3m} [Σ_{i=j}^{j+m−1} (x_{i+2m} − 2x_{i+m} + x_i)]² / (2 m² τ² (N − 3m + 1))
//! TVAR(τ)  = τ²/3 · MVAR(τ)                                          (phase unit², e.g. s²)
//! OHVAR(τ) = Σ_{i=0}^{N−3m−1} (x_{i+3m} − 3x_{i+2m} + 3x_{i+m} − x_i)² / (6 τ² (N − 3m))
//! HVAR(τ)  = the same sum over i = 0, m, 2m, … (⌊T/m⌋ − 2 terms)
//! TOTVAR(τ)= Σ_{i=1}^{N−2} (x*_{i−m} − 2x*_i + x*_{i+m})² / (2 τ² (N − 2)),
//!            x*_{−j} = 2x_0 − x_j,  x*_{N−1+j} = 2x_{N−1} − x_{N−1−j}   (reflection at both ends)
//! ```
//!
//! Variances are in rate unit² (TVAR in phase unit²); deviations are their square roots.
//! Each statistic has a module with its plain reference function (a literal evaluation of the
//! formula, O(T·m)) and the fast path (O(T) per scale, parallel over scales, deterministic for
//! any thread count, offset-proof: the rate series is centred with its exact mean before it is
//! integrated). ADEV and HDEV of rate data at power-of-two scales skip the cumulative sum:
//! a pyramid of block sums reads the series once. OHDEV, MDEV and TDEV of rate data without a
//! chi-square interval are streamed from the samples (`stream.rs`: third-difference recurrences
//! restarted from compensated checkpoints, one read of the series for the near scales and one
//! for the far ones, vectorised with AVX-512 or AVX2, scalar elsewhere), and so is TOTDEV of rate
//! series of at least 2^22 samples ([`totdev`]); phase (angle) input and chi-square intervals,
//! which need the phase itself, build the series-sized cumulative sum as before. The scale
//! grid comes from
//! [`crate::Scales`] (the same configuration as the AV), limited to the cluster sizes each
//! statistic admits ([`Statistic::max_m`]).
//!
//! ```
//! use avar::stability::{stability, Statistic};
//! use avar::{AvarConfig, CiMethod, Scales};
//! // NBS14 1000-point frequency set (NIST SP 1065): MDEV(τ = 10 s) = 0.06172376
//! let mut n: u64 = 1_234_567_890;
//! let y: Vec<f64> = (0..1000).map(|_| { let v = n as f64 / 2_147_483_647.0; n = 16807 * n % 2_147_483_647; v }).collect();
//! let cfg = AvarConfig { scales: Scales::Explicit(vec![10]), ci: CiMethod::None, ..Default::default() };
//! let s = stability(&y, 1.0, Statistic::Mdev, &cfg).unwrap();
//! assert!((s.points[0].dev / 0.06172376 - 1.0).abs() < 5e-7);
//! assert_eq!(s.points[0].n_terms, 1001 - 3 * 10 + 1);
//! ```

mod blocks;
pub mod edf;
pub mod hdev;
pub mod mdev;
pub mod noise_id;
mod stream;
pub mod tdev;
pub mod totdev;

use serde::{Deserialize, Serialize};

use crate::config::{AvarConfig, CiMethod, Estimator, InputKind, Scales};
use crate::error::AvarError;
use crate::haar::chi2_interval;
use crate::{MIN_SAMPLES, check_len, cumulative, validate_rate_alpha};
use stream::Diff;

/// A member of the frequency-stability family.
///
/// ```
/// use avar::stability::Statistic;
/// assert_eq!("ohdev".parse::<Statistic>().unwrap(), Statistic::Ohdev);
/// assert_eq!(Statistic::Mdev.name(), "mdev");
/// assert_eq!(Statistic::Hdev.max_m(1000), 333);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Statistic {
    /// Non-overlapping Allan deviation.
    Adev,
    /// Overlapping Allan deviation (the book's MOAV, eq. 4.2).
    Oadev,
    /// Modified Allan deviation: separates white from flicker phase noise.
    Mdev,
    /// Time deviation √(τ²/3 · MVAR), in phase units (s for clock data).
    Tdev,
    /// Non-overlapping Hadamard deviation: insensitive to a linear frequency drift.
    Hdev,
    /// Overlapping Hadamard deviation.
    Ohdev,
    /// Total deviation: reflection at both ends, tighter intervals at long τ.
    Totdev,
}

impl Statistic {
    /// Every member, in the order of the CLI's help.
    pub const ALL: [Statistic; 7] = [
        Statistic::Oadev,
        Statistic::Adev,
        Statistic::Mdev,
        Statistic::Tdev,
        Statistic::Hdev,
        Statistic::Ohdev,
        Statistic::Totdev,
    ];

    /// Lower-case name (`"oadev"`, `"mdev"`, …).
    ///
    /// ```
    /// assert_eq!(avar::stability::Statistic::Totdev.name(), "totdev");
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Statistic::Adev => "adev",
            Statistic::Oadev => "oadev",
            Statistic::Mdev => "mdev",
            Statistic::Tdev => "tdev",
            Statistic::Hdev => "hdev",
            Statistic::Ohdev => "ohdev",
            Statistic::Totdev => "totdev",
        }
    }

    /// Largest cluster size m (samples) for T rate samples: 2m ≤ T for the Allan and total
    /// variances, 3m ≤ T + 1 for MVAR/TVAR, 3m ≤ T for the Hadamard variances (each leaves at
    /// least one term).
    ///
    /// ```
    /// use avar::stability::Statistic;
    /// assert_eq!(Statistic::Mdev.max_m(8), 3);
    /// assert_eq!(Statistic::Ohdev.max_m(8), 2);
    /// assert_eq!(Statistic::Totdev.max_m(8), 4);
    /// ```
    pub fn max_m(self, t: usize) -> u64 {
        let t = t as u64;
        match self {
            Statistic::Adev | Statistic::Oadev | Statistic::Totdev => t / 2,
            Statistic::Mdev | Statistic::Tdev => (t + 1) / 3,
            Statistic::Hdev | Statistic::Ohdev => t / 3,
        }
    }

    /// Number of terms of the estimator at cluster size m for T rate samples (N = T + 1 phase
    /// points): ⌊T/m⌋ − 1 (ADEV), T − 2m + 1 (OADEV), N − 3m + 1 (MDEV, TDEV), ⌊T/m⌋ − 2
    /// (HDEV), N − 3m (OHDEV), N − 2 (TOTDEV).
    ///
    /// ```
    /// use avar::stability::Statistic;
    /// assert_eq!(Statistic::Ohdev.n_terms(19982, 1), 19980);
    /// assert_eq!(Statistic::Hdev.n_terms(19982, 2), 9989);
    /// ```
    pub fn n_terms(self, t: usize, m: u64) -> u64 {
        let t = t as u64;
        match self {
            Statistic::Adev => t / m - 1,
            Statistic::Oadev => t - 2 * m + 1,
            Statistic::Mdev | Statistic::Tdev => t + 2 - 3 * m,
            Statistic::Hdev => t / m - 2,
            Statistic::Ohdev => t + 1 - 3 * m,
            Statistic::Totdev => t - 1,
        }
    }

    /// Order d of the phase differences (2 for the Allan family and TOTVAR, 3 for Hadamard).
    ///
    /// ```
    /// use avar::stability::Statistic;
    /// assert_eq!(Statistic::Oadev.diff_order(), 2);
    /// assert_eq!(Statistic::Ohdev.diff_order(), 3);
    /// // a d-th difference at lag m spans d·m + 1 of the N = T + 1 phase points: N − d·m terms
    /// for st in [Statistic::Oadev, Statistic::Ohdev] {
    ///     assert_eq!(st.n_terms(100, 7), 101 - st.diff_order() as u64 * 7);
    /// }
    /// ```
    pub fn diff_order(self) -> u32 {
        match self {
            Statistic::Hdev | Statistic::Ohdev => 3,
            _ => 2,
        }
    }

    /// True for the overlapping estimators (stride 1 in the phase index).
    ///
    /// ```
    /// use avar::stability::Statistic;
    /// let non: Vec<Statistic> = Statistic::ALL.into_iter().filter(|s| !s.overlapping()).collect();
    /// assert_eq!(non, [Statistic::Adev, Statistic::Hdev]);
    /// // stride m instead of 1: ⌊T/m⌋ − 1 terms instead of T − 2m + 1
    /// assert_eq!((Statistic::Adev.n_terms(100, 10), Statistic::Oadev.n_terms(100, 10)), (9, 81));
    /// ```
    pub fn overlapping(self) -> bool {
        !matches!(self, Statistic::Adev | Statistic::Hdev)
    }

    /// True for the modified variances (MVAR, TVAR): phase averaged over m before differencing.
    ///
    /// ```
    /// use avar::stability::{stability, Statistic};
    /// use avar::{AvarConfig, CiMethod, Scales};
    /// let modified: Vec<Statistic> = Statistic::ALL.into_iter().filter(|s| s.modified()).collect();
    /// assert_eq!(modified, [Statistic::Mdev, Statistic::Tdev]);
    /// // at m = 1 there is nothing to average: MVAR = AVAR, both over the T − 1 second differences
    /// let y: Vec<f64> = (0..200).map(|i| ((i * 7919) % 101) as f64).collect();
    /// let cfg = AvarConfig { scales: Scales::Explicit(vec![1]), ci: CiMethod::None, ..Default::default() };
    /// let mvar = stability(&y, 1.0, Statistic::Mdev, &cfg).unwrap().points[0].var;
    /// let avar = stability(&y, 1.0, Statistic::Oadev, &cfg).unwrap().points[0].var;
    /// assert!((mvar - avar).abs() <= 1e-12 * avar); // two routes, rounding only
    /// ```
    pub fn modified(self) -> bool {
        matches!(self, Statistic::Mdev | Statistic::Tdev)
    }

    /// Stable32's stop ratio of the octave grid: m runs over powers of two up to T/ratio
    /// (5 for ADEV and HDEV, 4 for OADEV, MDEV, TDEV and OHDEV, 2 for TOTDEV; W. J. Riley,
    /// "The evolution of frequency stability analysis", table III).
    ///
    /// ```
    /// use avar::{stability::Statistic, Scales};
    /// assert_eq!(Statistic::Hdev.octave_stop_ratio(), 5);
    /// assert_eq!(Statistic::Totdev.octave_stop_ratio(), 2);
    /// for st in Statistic::ALL {
    ///     let ms = st.cluster_sizes(&Scales::Octave, 100).unwrap();
    ///     assert!(*ms.last().unwrap() <= 100 / st.octave_stop_ratio());
    /// }
    /// // TOTDEV's octave grid at T = 100 stops at T/2 = 50: the last power of two is 32
    /// assert_eq!(Statistic::Totdev.cluster_sizes(&Scales::Octave, 100).unwrap().last(), Some(&32));
    /// ```
    pub fn octave_stop_ratio(self) -> u64 {
        match self {
            Statistic::Adev | Statistic::Hdev => 5,
            Statistic::Totdev => 2,
            _ => 4,
        }
    }

    /// The cluster sizes of `scales` this statistic admits for `t` rate samples. Grids are cut
    /// at [`Statistic::max_m`]; the octave grid stops at T/[`Statistic::octave_stop_ratio`]
    /// as in Stable32; an explicit m beyond the limit is an error.
    ///
    /// ```
    /// use avar::{stability::Statistic, Scales};
    /// assert_eq!(Statistic::Mdev.cluster_sizes(&Scales::Octave, 20).unwrap(), vec![1, 2, 4]);
    /// assert_eq!(Statistic::Totdev.cluster_sizes(&Scales::Octave, 20).unwrap(), vec![1, 2, 4, 8]);
    /// assert_eq!(Statistic::Adev.cluster_sizes(&Scales::Octave, 20).unwrap(), vec![1, 2, 4]);
    /// assert!(Statistic::Hdev.cluster_sizes(&Scales::Explicit(vec![7]), 20).is_err());
    /// ```
    pub fn cluster_sizes(self, scales: &Scales, t: usize) -> Result<Vec<u64>, AvarError> {
        let max = self.max_m(t);
        if let Scales::Explicit(list) = scales
            && let Some(&m) = list.iter().find(|&&m| m > max && m > 0)
        {
            return Err(AvarError::ScaleTooLargeFor {
                statistic: self.name(),
                m,
                t,
                max,
            });
        }
        let ms: Vec<u64> = if matches!(scales, Scales::Octave) {
            let stop = (t as u64 / self.octave_stop_ratio()).min(max);
            (0..63)
                .map(|k| 1u64 << k)
                .take_while(|&m| m <= stop)
                .collect()
        } else {
            let mut v = scales.cluster_sizes(t)?;
            v.retain(|&m| m <= max);
            v
        };
        if ms.is_empty() {
            return Err(AvarError::InvalidScales(format!(
                "the grid {scales:?} has no cluster size for {} with T = {t} rate samples",
                self.name()
            )));
        }
        Ok(ms)
    }
}

impl std::fmt::Display for Statistic {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Statistic {
    type Err = AvarError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let l = s.trim().to_ascii_lowercase();
        Statistic::ALL
            .into_iter()
            .find(|st| st.name() == l)
            .ok_or_else(|| {
                AvarError::InvalidStatistic(format!(
                    "unknown statistic {s:?}: expected one of oadev, adev, mdev, tdev, hdev, ohdev, totdev"
                ))
            })
    }
}

/// One point of a stability curve.
///
/// Units: `tau` in seconds; `var` in rate unit² (for TDEV: phase unit², e.g. s² for clock phase
/// or rad² for angle), `dev` = √var. The interval fields are `None` without a chi-square CI.
///
/// ```
/// use avar::stability::{stability, Statistic};
/// use avar::{AvarConfig, Scales};
/// let y: Vec<f64> = (0..600).map(|i| ((i * 7919) % 101) as f64).collect();
/// // chi-square intervals (the default CI)
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![4, 16]), ..Default::default() };
/// let mdev = stability(&y, 2.0, Statistic::Mdev, &cfg).unwrap();
/// let tdev = stability(&y, 2.0, Statistic::Tdev, &cfg).unwrap();
/// for (p, q) in mdev.points.iter().zip(&tdev.points) {
///     assert_eq!(p.tau, p.m as f64 / 2.0);
///     assert_eq!(p.dev, p.var.sqrt());
///     assert_eq!(p.n_terms, Statistic::Mdev.n_terms(600, p.m));
///     assert_eq!(q.var, q.tau * q.tau / 3.0 * p.var); // TVAR = τ²/3 · MVAR
///     let (lo, hi) = (p.var_lo.unwrap(), p.var_hi.unwrap());
///     assert!(lo <= p.var && p.var <= hi);
///     assert_eq!(p.dev_lo, Some(lo.sqrt()));
/// }
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StabilityPoint {
    /// Cluster size (averaging factor, samples).
    pub m: u64,
    /// Averaging time τ = m / rate (s).
    pub tau: f64,
    /// The variance (MVAR, TVAR, HVAR, …).
    pub var: f64,
    /// The deviation √var.
    pub dev: f64,
    /// Lower chi-square bound of the variance.
    pub var_lo: Option<f64>,
    /// Upper chi-square bound of the variance.
    pub var_hi: Option<f64>,
    /// Lower bound of the deviation (√var_lo).
    pub dev_lo: Option<f64>,
    /// Upper bound of the deviation (√var_hi).
    pub dev_hi: Option<f64>,
    /// Equivalent degrees of freedom of the interval.
    pub edf: Option<f64>,
    /// Number of terms of the estimator (Stable32's "#").
    pub n_terms: u64,
    /// Identified power-law exponent α of the rate PSD S_y ∝ f^α (2 white PM, 1 flicker PM,
    /// 0 white FM, −1 flicker FM, −2 random-walk FM), when a chi-square CI was computed.
    pub alpha: Option<i32>,
}

/// An Allan-variance point under the names of the stability family (`avar` → `var`, `adev` →
/// `dev`, …; the values unchanged).
///
/// ```
/// use avar::{AvarConfig, allan_variance, stability::StabilityPoint};
/// let x: Vec<f64> = (0..400).map(|i| ((i * 37) % 11) as f64).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let p = &av.points[0];
/// let q = StabilityPoint::from(p);
/// assert_eq!((q.m, q.tau, q.var, q.dev, q.n_terms), (p.m, p.tau, p.avar, p.adev, p.n_terms));
/// # Ok::<(), avar::AvarError>(())
/// ```
impl From<&crate::AvarPoint> for StabilityPoint {
    fn from(p: &crate::AvarPoint) -> StabilityPoint {
        StabilityPoint {
            m: p.m,
            tau: p.tau,
            var: p.avar,
            dev: p.adev,
            var_lo: p.avar_lo,
            var_hi: p.avar_hi,
            dev_lo: p.adev_lo,
            dev_hi: p.adev_hi,
            edf: p.edf,
            n_terms: p.n_terms,
            alpha: p.noise_alpha,
        }
    }
}

crate::range::quadratic_point!(StabilityPoint: var, var_lo, var_hi; dev, dev_lo, dev_hi);

/// A stability curve: one [`StabilityPoint`] per cluster size, ascending in m.
///
/// ```
/// use avar::stability::{stability, Statistic};
/// use avar::{allan_variance, AvarConfig, CiMethod, InputKind};
/// let y: Vec<f64> = (0..500).map(|i| ((i * 7919) % 101) as f64).collect();
/// let cfg = AvarConfig { ci: CiMethod::None, ..Default::default() };
/// let s = stability(&y, 10.0, Statistic::Oadev, &cfg).unwrap();
/// assert_eq!((s.statistic, s.rate_hz, s.n, s.input), (Statistic::Oadev, 10.0, 500, InputKind::Rate));
/// assert!(s.points.windows(2).all(|w| w[0].m < w[1].m));
/// // OADEV is the crate's overlapping AV, scale by scale
/// let av = allan_variance(&y, 10.0, &cfg).unwrap();
/// let vars: Vec<f64> = s.points.iter().map(|p| p.var).collect();
/// assert_eq!(vars, av.avars());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stability {
    /// The statistic.
    pub statistic: Statistic,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Number of rate samples T (angle input: angle samples − 1).
    pub n: usize,
    /// Rate or angle input.
    pub input: InputKind,
    /// The interval family (only [`CiMethod::ChiSquare`] and [`CiMethod::None`] are defined for
    /// the family; [`CiMethod::Gaussian`] is refused except for the Allan deviations).
    pub ci: CiMethod,
    /// CI level: intervals cover 1 − alpha (Stable32's confidence factor 0.683 is alpha = 0.317).
    pub alpha: f64,
    /// One entry per cluster size.
    pub points: Vec<StabilityPoint>,
}

/// A stability statistic of one series at the configured scales.
///
/// * `data`: rate (fractional frequency) samples, or phase/angle samples with
///   `config.input = InputKind::Angle`.
/// * `rate_hz`: sampling rate (Hz); τ0 = 1/rate_hz.
/// * `statistic`: which member of the family.
/// * `config`: scales, input kind, CI (chi-square with Stable32's noise identification and
///   Greenhall's EDF, or none) and level; `config.estimator` is ignored (the statistic decides).
///
/// Errors: as [`crate::allan_variance`], plus a scale beyond [`Statistic::max_m`] and a Gaussian
/// CI for a statistic other than ADEV/OADEV.
///
/// Memory (rate input): the values of MDEV, TDEV and OHDEV, of OADEV and TOTDEV from 2^22
/// samples on, and of ADEV and HDEV at power-of-two scales are computed without a series-sized
/// buffer; the chi-square interval then adds the 8-sums of the samples (1 byte per sample) for
/// its noise identification. Angle input, shorter OADEV/TOTDEV series and ADEV/HDEV at other
/// scales build the cumulative sum (8 bytes per sample).
///
/// ```
/// use avar::stability::{stability, Statistic};
/// use avar::{AvarConfig, CiMethod, Scales};
/// // a linear frequency drift: the Hadamard variance removes it exactly, the AV does not
/// let y: Vec<f64> = (0..300).map(|i| 1e-3 * i as f64).collect();
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![4]), ci: CiMethod::None, ..Default::default() };
/// assert!(stability(&y, 1.0, Statistic::Ohdev, &cfg).unwrap().points[0].dev < 1e-15);
/// assert!(stability(&y, 1.0, Statistic::Oadev, &cfg).unwrap().points[0].dev > 1e-3);
/// ```
pub fn stability(
    data: &[f64],
    rate_hz: f64,
    statistic: Statistic,
    config: &AvarConfig,
) -> Result<Stability, AvarError> {
    validate_rate_alpha(rate_hz, config.alpha)?;
    // huge or tiny samples: an exact power-of-two rescaled copy, as for the AV
    let first = stability_unscaled(data, rate_hz, statistic, config);
    if !crate::range::suspicious(first.as_ref().map(|s| &s.points[..])) {
        return first;
    }
    let Some(e) = crate::range::rescale_exponent(data) else {
        return first;
    };
    let scaled = crate::range::scaled_copy(data, e);
    let mut out = stability_unscaled(&scaled, rate_hz, statistic, config)?;
    crate::range::scale_back(&mut out.points, e)?;
    Ok(out)
}

/// [`stability`] on data of ordinary magnitude.
fn stability_unscaled(
    data: &[f64],
    rate_hz: f64,
    statistic: Statistic,
    config: &AvarConfig,
) -> Result<Stability, AvarError> {
    // ADEV and HDEV of rate data at power-of-two scales: the block-sum pyramid, one read of
    // the series (the cumulative sum is built only for a chi-square interval)
    if matches!(statistic, Statistic::Adev | Statistic::Hdev)
        && config.input == InputKind::Rate
        && config.ci != CiMethod::Gaussian
        && data.len() >= MIN_SAMPLES
        && let Ok(ms) = statistic.cluster_sizes(&config.scales, data.len())
        && let Some(vars) = blocks::nonoverlapping_vars(data, &ms, statistic.diff_order() as usize)
    {
        let t = data.len();
        let mut points = new_points(statistic, &ms, vars, t, rate_hz);
        chi_square_from_data(data, rate_hz, statistic, config, &mut points)?;
        return Ok(curve(statistic, rate_hz, t, config, points));
    }
    if matches!(statistic, Statistic::Adev | Statistic::Oadev) {
        let est = if statistic == Statistic::Adev {
            Estimator::NonOverlapping
        } else {
            Estimator::Overlapping
        };
        let t = match config.input {
            InputKind::Rate => data.len(),
            InputKind::Angle => data.len().saturating_sub(1),
        };
        check_len(data.len(), t)?;
        let ms = statistic.cluster_sizes(&config.scales, t)?;
        let cfg = AvarConfig {
            estimator: est,
            scales: Scales::Explicit(ms),
            // the family's chi-square intervals (Stable32's identification) are set below
            ci: match config.ci {
                CiMethod::ChiSquare => CiMethod::None,
                c => c,
            },
            ..config.clone()
        };
        let av = crate::allan_variance(data, rate_hz, &cfg)?;
        let mut out = Stability {
            statistic,
            rate_hz,
            n: av.n,
            input: config.input,
            ci: config.ci,
            alpha: config.alpha,
            points: av.points.iter().map(StabilityPoint::from).collect(),
        };
        chi_square_from_data(data, rate_hz, statistic, config, &mut out.points)?;
        return Ok(out);
    }
    if config.ci == CiMethod::Gaussian {
        return Err(AvarError::InvalidStatistic(format!(
            "the Gaussian interval is defined for the Allan variance only, not for {statistic}: \
             use the chi-square interval"
        )));
    }
    // OHDEV, MDEV and TDEV (any length) and TOTDEV (long series) of rate data: streamed from
    // the samples, no series-sized cumulative sum (see `stream`); the chi-square interval's
    // noise identification then reads the cumulative sum, built after the values (before, the
    // values came from it too, by the buffered paths: MDEV at 10^7 samples, octave τ, took
    // 326 ms with the interval against 27 without)
    if config.input == InputKind::Rate
        && matches!(config.ci, CiMethod::None | CiMethod::ChiSquare)
        && (matches!(
            statistic,
            Statistic::Ohdev | Statistic::Mdev | Statistic::Tdev
        ) || (statistic == Statistic::Totdev
            && data.len() >= crate::kernel::streamed::STREAM_MIN_T))
    {
        let t = data.len();
        check_len(t, t)?;
        let ms = statistic.cluster_sizes(&config.scales, t)?;
        let vars = match statistic {
            Statistic::Ohdev => stream::variances(data, &ms, Diff::Hadamard)?,
            Statistic::Mdev => stream::variances(data, &ms, Diff::Modified)?,
            Statistic::Totdev => totdev::totvar_stream(data, &ms)?,
            _ => tdev::tvar_from_mvar(stream::variances(data, &ms, Diff::Modified)?, rate_hz, &ms),
        };
        let mut points = new_points(statistic, &ms, vars, t, rate_hz);
        chi_square_from_data(data, rate_hz, statistic, config, &mut points)?;
        return Ok(curve(statistic, rate_hz, t, config, points));
    }
    let mut scratch = Vec::new();
    let cum = cumulative(data, rate_hz, config.input, &mut scratch)?;
    let t = cum.t();
    let ms = statistic.cluster_sizes(&config.scales, t)?;
    let vars = match statistic {
        Statistic::Mdev => mdev::mvar_fast(&cum, &ms),
        Statistic::Tdev => tdev::tvar_fast(&cum, rate_hz, &ms),
        Statistic::Hdev => hdev::hvar_fast(&cum, &ms, false),
        Statistic::Ohdev => hdev::hvar_fast(&cum, &ms, true),
        Statistic::Totdev => totdev::totvar_fast(&cum, &ms),
        Statistic::Adev | Statistic::Oadev => unreachable!("handled above"),
    };
    let mut points = new_points(statistic, &ms, vars, t, rate_hz);
    if config.ci == CiMethod::ChiSquare {
        let ids = noise_id::IdData::Cum(&cum);
        apply_chi_square(&ids, statistic, config.input, config.alpha, &mut points);
    }
    Ok(curve(statistic, rate_hz, t, config, points))
}

/// The curve of `statistic` for T = `t` rate samples with the configuration's input kind and
/// interval.
fn curve(
    statistic: Statistic,
    rate_hz: f64,
    t: usize,
    config: &AvarConfig,
    points: Vec<StabilityPoint>,
) -> Stability {
    Stability {
        statistic,
        rate_hz,
        n: t,
        input: config.input,
        ci: config.ci,
        alpha: config.alpha,
        points,
    }
}

/// The points of a curve from its variances (no interval yet).
fn new_points(
    statistic: Statistic,
    ms: &[u64],
    vars: Vec<f64>,
    t: usize,
    rate_hz: f64,
) -> Vec<StabilityPoint> {
    ms.iter()
        .zip(vars)
        .map(|(&m, var)| StabilityPoint {
            m,
            tau: m as f64 / rate_hz,
            var,
            dev: var.sqrt(),
            var_lo: None,
            var_hi: None,
            dev_lo: None,
            dev_hi: None,
            edf: None,
            n_terms: statistic.n_terms(t, m),
            alpha: None,
        })
        .collect()
}

/// Several statistics of one series (e.g. for an overlay plot), in the order given.
///
/// ```
/// use avar::stability::{stability_many, Statistic};
/// use avar::{AvarConfig, CiMethod};
/// let y: Vec<f64> = (0..400).map(|i| ((i * 7919) % 13) as f64).collect();
/// let cfg = AvarConfig { ci: CiMethod::None, ..Default::default() };
/// let out = stability_many(&y, 1.0, &[Statistic::Oadev, Statistic::Mdev], &cfg).unwrap();
/// assert_eq!(out[1].statistic, Statistic::Mdev);
/// ```
pub fn stability_many(
    data: &[f64],
    rate_hz: f64,
    statistics: &[Statistic],
    config: &AvarConfig,
) -> Result<Vec<Stability>, AvarError> {
    statistics
        .iter()
        .map(|&s| stability(data, rate_hz, s, config))
        .collect()
}

/// Phase of the input as plain f64 (reference functions): rate samples are integrated from
/// x_0 = 0 with x_k = x_{k−1} + y_k/rate, angle samples are copied.
pub(crate) fn plain_phase(
    data: &[f64],
    rate_hz: f64,
    input: InputKind,
) -> Result<Vec<f64>, AvarError> {
    validate_rate_alpha(rate_hz, 0.5)?;
    let t = match input {
        InputKind::Rate => data.len(),
        InputKind::Angle => data.len().saturating_sub(1),
    };
    check_len(data.len(), t)?;
    crate::kernel::cumsum::check_finite(data)?;
    Ok(match input {
        InputKind::Rate => {
            let mut x = Vec::with_capacity(data.len() + 1);
            let mut acc = 0.0;
            x.push(0.0);
            for v in data {
                acc += v / rate_hz;
                x.push(acc);
            }
            x
        }
        InputKind::Angle => data.to_vec(),
    })
}

/// Checks m against the statistic's limit (reference functions).
pub(crate) fn check_m(statistic: Statistic, m: u64, t: usize) -> Result<(), AvarError> {
    if m == 0 {
        return Err(AvarError::ZeroScale);
    }
    let max = statistic.max_m(t);
    if m > max {
        return Err(AvarError::ScaleTooLargeFor {
            statistic: statistic.name(),
            m,
            t,
            max,
        });
    }
    Ok(())
}

/// [`apply_chi_square`] for points whose values came without the cumulative sum (streamed,
/// the pyramid, the AV): when `config` asks for the chi-square interval, rate samples are read
/// as they are (with their 8-sums, 1 byte per sample; see [`noise_id::IdData::rate`]) and
/// angle samples are the phase itself (the cumulative representation, no copy).
fn chi_square_from_data(
    data: &[f64],
    rate_hz: f64,
    statistic: Statistic,
    config: &AvarConfig,
    points: &mut [StabilityPoint],
) -> Result<(), AvarError> {
    if config.ci == CiMethod::ChiSquare {
        if config.input == InputKind::Rate {
            // the m-sums straight from the samples: no cumulative sum (8 bytes per sample)
            let ids = noise_id::IdData::rate(data);
            apply_chi_square(&ids, statistic, config.input, config.alpha, points);
        } else {
            let mut scratch = Vec::new();
            let cum = cumulative(data, rate_hz, config.input, &mut scratch)?;
            let ids = noise_id::IdData::Cum(&cum);
            apply_chi_square(&ids, statistic, config.input, config.alpha, points);
        }
    }
    Ok(())
}

/// Fills the chi-square intervals: Stable32's noise identification at each m, the statistic's
/// EDF, and bounds at level 1 − alpha.
pub(crate) fn apply_chi_square(
    data: &noise_id::IdData<'_>,
    statistic: Statistic,
    input: InputKind,
    alpha: f64,
    points: &mut [StabilityPoint],
) {
    let alphas = noise_id::identify_all(data, statistic, input, points);
    let t = data.t();
    for (p, a) in points.iter_mut().zip(alphas) {
        p.alpha = Some(a);
        let e = edf::edf(statistic, a, p.m, t as u64 + 1);
        if e.is_finite() && e > 0.0 {
            p.edf = Some(e);
            let (lo, hi) = chi2_interval(p.var, e, alpha);
            p.var_lo = Some(lo);
            p.var_hi = Some(hi);
            p.dev_lo = Some(lo.max(0.0).sqrt());
            p.dev_hi = Some(hi.max(0.0).sqrt());
        }
    }
}

/// Length of the fixed blocks of terms the fast paths sum (the grid depends only on the number
/// of terms, so results are bit-identical for any thread count).
pub(crate) const BLOCK: usize = 1 << 14;

/// Σ over the terms 0..n of a statistic, summed block by block: `block(lo, hi)` returns the
/// plain sum of terms lo..hi; blocks of `len` terms (a grid fixed by the caller from n and m,
/// never by the thread count) run in parallel and their sums are added in block order with
/// Neumaier compensation.
pub(crate) fn sum_in_blocks<F>(n: usize, len: usize, block: F) -> f64
where
    F: Fn(usize, usize) -> f64 + Sync,
{
    use rayon::prelude::*;
    let nb = n.div_ceil(len);
    let parts: Vec<f64> = (0..nb)
        .into_par_iter()
        .map(|b| block(b * len, ((b + 1) * len).min(n)))
        .collect();
    let mut acc = crate::kernel::compensated::Neumaier::default();
    for p in parts {
        acc.add(p);
    }
    acc.value()
}

/// [`sum_in_blocks`] for terms that read the series at lags that are whole multiples
/// `stride` (≥ 1) of the block length (far scales, m = stride·len): the blocks are visited by
/// residue class, b = r, r + stride, r + 2·stride, …, so that the lagged blocks a term block
/// reads were, but for one, already read by the previous block of its class and are still in
/// cache (one pass over the series per scale instead of one per lag). The classes run in
/// parallel; every block's sum is the same as in [`sum_in_blocks`] and the block sums are
/// added in the same order, so the result is bit-identical.
pub(crate) fn sum_in_blocks_walk<F>(n: usize, len: usize, stride: usize, block: F) -> f64
where
    F: Fn(usize, usize) -> f64 + Sync,
{
    use rayon::prelude::*;
    let nb = n.div_ceil(len);
    let stride = stride.clamp(1, nb.max(1));
    let walked: Vec<Vec<f64>> = (0..stride)
        .into_par_iter()
        .map(|r| {
            (r..nb)
                .step_by(stride)
                .map(|b| block(b * len, ((b + 1) * len).min(n)))
                .collect()
        })
        .collect();
    let mut acc = crate::kernel::compensated::Neumaier::default();
    for b in 0..nb {
        acc.add(walked[b % stride][b / stride]);
    }
    acc.value()
}

/// Largest cluster size whose scales are summed together, block by block ([`fused_sums`]):
/// every lag of a block then stays within a few hundred kB of it, in cache.
pub(crate) const FUSE_MAX_M: usize = BLOCK / 4;

/// [`sum_in_blocks`] (blocks of [`BLOCK`] terms) for several scales at once: each parallel job
/// takes one block index and runs every scale in `ms` over it while that stretch of the series
/// is in cache, so the near scales read the series from memory once in all instead of once
/// each. `n_terms(m)` is the number of terms at m, `block(m, lo, hi)` the plain sum of terms
/// lo..hi. The block sums are the same as in [`sum_in_blocks`] and are added in the same order,
/// so the results are bit-identical.
pub(crate) fn fused_sums<N, F>(ms: &[usize], n_terms: N, block: F) -> Vec<f64>
where
    N: Fn(usize) -> usize + Sync,
    F: Fn(usize, usize, usize) -> f64 + Sync,
{
    use rayon::prelude::*;
    let ns: Vec<usize> = ms.iter().map(|&m| n_terms(m)).collect();
    let nb = ns.iter().map(|n| n.div_ceil(BLOCK)).max().unwrap_or(0);
    let parts: Vec<Vec<f64>> = (0..nb)
        .into_par_iter()
        .map(|b| {
            let lo = b * BLOCK;
            ms.iter()
                .zip(&ns)
                .map(|(&m, &n)| {
                    if lo < n {
                        block(m, lo, (lo + BLOCK).min(n))
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    ns.iter()
        .enumerate()
        .map(|(k, &n)| {
            let mut acc = crate::kernel::compensated::Neumaier::default();
            for part in &parts[..n.div_ceil(BLOCK)] {
                acc.add(part[k]);
            }
            acc.value()
        })
        .collect()
}

/// Runs `near` on the cluster sizes m ≤ [`FUSE_MAX_M`] (all together) and `far(m)` on each
/// other one (in parallel), returning the values in the order of `ms`.
pub(crate) fn split_near_far<Near, Far>(ms: &[u64], near: Near, far: Far) -> Vec<f64>
where
    Near: FnOnce(&[usize]) -> Vec<f64>,
    Far: Fn(usize) -> f64 + Sync + Send,
{
    use rayon::prelude::*;
    let near_ms: Vec<usize> = ms
        .iter()
        .map(|&m| m as usize)
        .filter(|&m| m <= FUSE_MAX_M)
        .collect();
    let near_vals = near(&near_ms);
    let far_vals: Vec<f64> = ms
        .par_iter()
        .map(|&m| m as usize)
        .filter(|&m| m > FUSE_MAX_M)
        .map(&far)
        .collect();
    let (mut i, mut j) = (0, 0);
    ms.iter()
        .map(|&m| {
            if m as usize <= FUSE_MAX_M {
                i += 1;
                near_vals[i - 1]
            } else {
                j += 1;
                far_vals[j - 1]
            }
        })
        .collect()
}

/// Σ of the squares of `f(i)` for i in lo..hi, in four interleaved lanes (a fixed order).
#[inline(always)]
pub(crate) fn sumsq_range(lo: usize, hi: usize, f: impl Fn(usize) -> f64) -> f64 {
    let mut a = [0.0f64; 4];
    let mut i = lo;
    while i + 4 <= hi {
        for (l, al) in a.iter_mut().enumerate() {
            let v = f(i + l);
            *al += v * v;
        }
        i += 4;
    }
    while i < hi {
        let v = f(i);
        a[0] += v * v;
        i += 1;
    }
    (a[0] + a[1]) + (a[2] + a[3])
}
