//! Configuration of an Allan-variance computation: scales, estimator, input kind, CI.

use serde::{Deserialize, Serialize};

use crate::error::AvarError;

/// Which cluster sizes `m` (in samples; τ = m / rate seconds) to evaluate.
///
/// `T` below is the number of **rate** samples (for [`InputKind::Angle`], the number of angle
/// samples minus one). Every scale must leave at least one squared difference, i.e. `2m <= T`.
///
/// ```
/// use avar::Scales;
/// assert_eq!(Scales::Dyadic.cluster_sizes(1000).unwrap(), vec![2, 4, 8, 16, 32, 64, 128, 256]);
/// assert_eq!(Scales::Octave.cluster_sizes(1000).unwrap(), vec![1, 2, 4, 8, 16, 32, 64, 128]);
/// assert_eq!(Scales::Explicit(vec![3, 1]).cluster_sizes(10).unwrap(), vec![1, 3]);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Scales {
    /// The book's scales (Def. 4.1): m = 2^j for integer j with 1 <= j < log2(T) − 1,
    /// i.e. j = 1..=⌈log2 T⌉ − 2 (= ⌊log2 T⌋ − 1 when T is not a power of two).
    #[default]
    Dyadic,
    /// m = 1 followed by the book's dyadic scales.
    DyadicWithOne,
    /// Stable32's "octave" grid: m = 1, 2, 4, … while m <= ⌊T/4⌋ (at least 4 clusters).
    Octave,
    /// Stable32-style decade grid m ∈ {1, 2, 5} × 10^k, while 2m <= T.
    Decade,
    /// About `per_decade` logarithmically spaced m per decade: m = round(10^(i/per_decade)),
    /// duplicates removed, 1 <= m <= ⌊T/2⌋.
    LogSpaced {
        /// Number of grid points per factor 10 in m (>= 1).
        per_decade: usize,
    },
    /// Every m = 1..=⌊T/2⌋ (the largest m still has T − 2m + 1 >= 1 terms).
    All,
    /// An explicit list of cluster sizes (sorted and deduplicated; each must satisfy 1 <= m <= T/2).
    Explicit(Vec<u64>),
    /// The real-j scales of the book's Remark 4.1: m = ⌊2^j⌋ for j = 1, 1 + step, 1 + 2·step, …
    /// while j < log2(T) − 1; duplicates removed.
    RealJ {
        /// Increment of the real exponent j (> 0, finite).
        step: f64,
    },
}

impl Scales {
    /// The cluster sizes `m` (samples, ascending, unique) for `t` rate samples.
    ///
    /// Errors: [`AvarError::ZeroScale`] / [`AvarError::ScaleTooLarge`] for an explicit list,
    /// [`AvarError::InvalidScales`] for a bad parameter or an empty grid.
    ///
    /// ```
    /// use avar::Scales;
    /// // Remark 4.1 real-j scales with step 1/2 on T = 64: j = 1, 1.5, …, 4.5 (j < 5)
    /// assert_eq!(Scales::RealJ { step: 0.5 }.cluster_sizes(64).unwrap(), vec![2, 4, 5, 8, 11, 16, 22]);
    /// ```
    pub fn cluster_sizes(&self, t: usize) -> Result<Vec<u64>, AvarError> {
        let max = (t / 2) as u64;
        let log2t = (t as f64).log2();
        let mut out: Vec<u64> = match self {
            Scales::Dyadic | Scales::DyadicWithOne => {
                let mut v = Vec::new();
                if matches!(self, Scales::DyadicWithOne) && max >= 1 {
                    v.push(1);
                }
                // j < log2(T) - 1  <=>  2^(j+1) < T  (exact integer test)
                let mut j = 1u32;
                while j < 63 && (1u128 << (j + 1)) < t as u128 {
                    v.push(1u64 << j);
                    j += 1;
                }
                v
            }
            Scales::Octave => {
                let mut v = Vec::new();
                let mut m = 1u64;
                while m <= (t / 4) as u64 {
                    v.push(m);
                    m *= 2;
                }
                v
            }
            Scales::Decade => {
                let mut v = Vec::new();
                let mut p = 1u64;
                'outer: loop {
                    for f in [1u64, 2, 5] {
                        match p.checked_mul(f) {
                            Some(m) if m <= max => v.push(m),
                            _ => break 'outer,
                        }
                    }
                    p = match p.checked_mul(10) {
                        Some(p) => p,
                        None => break,
                    };
                }
                v
            }
            Scales::LogSpaced { per_decade } => {
                if *per_decade == 0 {
                    return Err(AvarError::InvalidScales(
                        "LogSpaced needs per_decade >= 1".into(),
                    ));
                }
                let mut v = Vec::new();
                let mut i = 0u64;
                loop {
                    let m = 10f64.powf(i as f64 / *per_decade as f64).round() as u64;
                    if m > max {
                        break;
                    }
                    v.push(m);
                    i += 1;
                }
                v
            }
            Scales::All => (1..=max).collect(),
            Scales::Explicit(list) => {
                for &m in list {
                    if m == 0 {
                        return Err(AvarError::ZeroScale);
                    }
                    if m > max {
                        return Err(AvarError::ScaleTooLarge { m, t, max });
                    }
                }
                list.clone()
            }
            Scales::RealJ { step } => {
                if !(step.is_finite() && *step > 0.0) {
                    return Err(AvarError::InvalidScales(format!(
                        "RealJ needs a finite step > 0, got {step}"
                    )));
                }
                let mut v = Vec::new();
                let mut i = 0u64;
                loop {
                    let j = 1.0 + i as f64 * step;
                    if j >= log2t - 1.0 {
                        break;
                    }
                    let m = j.exp2().floor() as u64;
                    if m > max {
                        break;
                    }
                    v.push(m);
                    i += 1;
                }
                v
            }
        };
        out.sort_unstable();
        out.dedup();
        if out.is_empty() {
            return Err(AvarError::InvalidScales(format!(
                "the grid {self:?} has no cluster size for T = {t} rate samples"
            )));
        }
        Ok(out)
    }
}

/// The estimator of the Allan variance.
///
/// ```
/// use avar::{allan_variance, AvarConfig, CiMethod, Estimator, Scales};
/// let x = [1.0, 3.0, 2.0, 6.0, 5.0, 5.0, 0.0, 2.0];
/// let cfg = |estimator| AvarConfig { scales: Scales::Explicit(vec![2]), ci: CiMethod::None, estimator, ..Default::default() };
/// let over = &allan_variance(&x, 1.0, &cfg(Estimator::Overlapping)).unwrap().points[0];
/// let non = &allan_variance(&x, 1.0, &cfg(Estimator::NonOverlapping)).unwrap().points[0];
/// // pair means 2, 2.5, 4, 5.5, 5, 2.5, 1; differences m apart 2, 3, 1, −3, −4 (T − 2m + 1)
/// assert_eq!((over.n_terms, over.avar), (5, (4.0 + 9.0 + 1.0 + 9.0 + 16.0) / (2.0 * 5.0)));
/// // disjoint pair means 2, 4, 5, 1; differences 2, 1, −4 (⌊T/m⌋ − 1)
/// assert_eq!((non.n_terms, non.avar), (3, (4.0 + 1.0 + 16.0) / (2.0 * 3.0)));
/// assert_eq!(Estimator::default(), Estimator::Overlapping);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Estimator {
    /// The maximum-overlapping estimator of the book's eq. 4.2 (all T − 2m + 1 differences).
    #[default]
    Overlapping,
    /// The classical non-overlapping estimator: ⌊T/m⌋ disjoint cluster means ȳ_i,
    /// AV = Σ (ȳ_{i+1} − ȳ_i)² / (2(⌊T/m⌋ − 1)).
    NonOverlapping,
}

/// What the samples are.
///
/// ```
/// use avar::{allan_variance, AvarConfig, CiMethod, InputKind, Scales};
/// let rate = [1.0, 3.0, 2.0, 6.0, 5.0, 5.0, 0.0, 2.0];
/// // the same record integrated at 1 Hz: 9 angle samples θ_0 = 0, θ_k = θ_{k−1} + x_k
/// let angle: Vec<f64> = std::iter::once(0.0)
///     .chain(rate.iter().scan(0.0, |th, x| { *th += x; Some(*th) }))
///     .collect();
/// let cfg = |input| AvarConfig { scales: Scales::Explicit(vec![1, 2]), ci: CiMethod::None, input, ..Default::default() };
/// let a = allan_variance(&rate, 1.0, &cfg(InputKind::Rate)).unwrap();
/// let b = allan_variance(&angle, 1.0, &cfg(InputKind::Angle)).unwrap();
/// assert_eq!(b.n, 8); // T + 1 angle samples hold T rate samples
/// assert_eq!(a.avars(), b.avars()); // small integers: both routes are exact
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum InputKind {
    /// Rate samples (gyro output in °/s, accelerometer output, fractional frequency, …).
    #[default]
    Rate,
    /// Integrated samples (angle, velocity, phase in seconds). T angle samples θ_0..θ_{T−1}
    /// stand for the T − 1 rate samples (θ_k − θ_{k−1})·rate; the AV is in rate units squared.
    Angle,
}

/// Confidence-interval family.
///
/// ```
/// use avar::{allan_variance, AvarConfig, CiMethod};
/// let x: Vec<f64> = (0..512).map(|i| ((i * 7919) % 101) as f64).collect();
/// let av = |ci| allan_variance(&x, 1.0, &AvarConfig { ci, ..Default::default() }).unwrap();
/// let (none, chi2, gauss) = (av(CiMethod::None), av(CiMethod::ChiSquare), av(CiMethod::Gaussian));
/// assert!(none.points.iter().all(|p| p.avar_lo.is_none() && p.edf.is_none()));
/// assert_eq!(none.avars(), chi2.avars()); // the same estimate, whatever the interval
/// for (p, q) in chi2.points.iter().zip(&gauss.points) {
///     assert_eq!(p.avar, q.avar);
///     let (lo, hi) = (p.avar_lo.unwrap(), p.avar_hi.unwrap());
///     assert!(0.0 <= lo && lo <= p.avar && p.avar <= hi); // never negative
///     // AV ± z·se: symmetric up to the rounding of lo and hi (ε·hi each)
///     let (lo, hi) = (q.avar_lo.unwrap(), q.avar_hi.unwrap());
///     assert!((lo + hi - 2.0 * q.avar).abs() <= 4.0 * f64::EPSILON * hi);
/// }
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CiMethod {
    /// Chi-square with equivalent degrees of freedom (EDF) from the identified power-law noise
    /// (default). See [`crate::ci`].
    #[default]
    ChiSquare,
    /// Gaussian interval of the book's Lemma 4.4 / §4.3.3 with a long-run variance estimate.
    Gaussian,
    /// No interval.
    None,
}

/// Everything [`crate::allan_variance`] needs besides the data and the rate.
///
/// Default: book dyadic scales, overlapping estimator (eq. 4.2), rate input, chi-square CI,
/// α = 0.05 (95 % intervals).
///
/// ```
/// use avar::{AvarConfig, CiMethod, Scales};
/// let cfg = AvarConfig { scales: Scales::All, ci: CiMethod::None, ..AvarConfig::default() };
/// assert_eq!(cfg.alpha, 0.05);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AvarConfig {
    /// Cluster sizes to evaluate.
    pub scales: Scales,
    /// Overlapping (eq. 4.2) or non-overlapping estimator.
    pub estimator: Estimator,
    /// Rate or angle samples.
    pub input: InputKind,
    /// CI family.
    pub ci: CiMethod,
    /// Two-sided CI level: the interval has coverage 1 − alpha (0 < alpha < 1).
    pub alpha: f64,
}

impl Default for AvarConfig {
    fn default() -> Self {
        AvarConfig {
            scales: Scales::Dyadic,
            estimator: Estimator::Overlapping,
            input: InputKind::Rate,
            ci: CiMethod::ChiSquare,
            alpha: 0.05,
        }
    }
}
