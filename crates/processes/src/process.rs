//! The latent processes of the book's §2.2 (Definitions 2.2–2.7) and the MA(1) of
//! Example 4.1, each a small immutable type whose constructor validates its parameters.
//!
//! All parameters are **per sample** (the sampling interval is Δt = 1 / rate), except
//! the Gauss-Markov process whose β is in 1/s and whose σ_G² is the stationary variance.

use crate::ar_p::ArP;
use crate::arma::Arma;
use crate::error::{ProcessError, Result};
use crate::long_memory::{Fgn, Plp};
use serde::{Deserialize, Serialize};
use std::fmt;

fn check_positive(process: &'static str, name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(ProcessError::InvalidParameter {
            process,
            name,
            value,
            requirement: "must be finite and > 0",
        })
    }
}

fn check_finite(process: &'static str, name: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(ProcessError::InvalidParameter {
            process,
            name,
            value,
            requirement: "must be finite",
        })
    }
}

fn check_rate(rate_hz: f64) -> Result<f64> {
    if rate_hz.is_finite() && rate_hz > 0.0 {
        Ok(rate_hz)
    } else {
        Err(ProcessError::InvalidRate(rate_hz))
    }
}

/// Gaussian white noise (WN, book Definition 2.2): X_t iid N(0, σ²).
///
/// `sigma2` is the per-sample variance σ² (unit², e.g. (°/s)²).
///
/// ```
/// use processes::WhiteNoise;
/// let wn = WhiteNoise::new(1e-4)?;
/// assert_eq!(wn.sigma2(), 1e-4);
/// assert!(WhiteNoise::new(-1.0).is_err());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WhiteNoise {
    sigma2: f64,
}

impl WhiteNoise {
    /// Builds WN with variance `sigma2` > 0 (finite).
    ///
    /// ```
    /// use processes::WhiteNoise;
    /// assert_eq!(WhiteNoise::new(2.5e-5)?.sigma2(), 2.5e-5); // (°/s)² per sample, say
    /// assert!(WhiteNoise::new(0.0).is_err() && WhiteNoise::new(f64::NAN).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(sigma2: f64) -> Result<Self> {
        Ok(Self {
            sigma2: check_positive("WN", "sigma2", sigma2)?,
        })
    }
    /// The variance σ² per sample.
    ///
    /// ```
    /// use processes::WhiteNoise;
    /// assert_eq!(WhiteNoise::new(1e-4)?.sigma2(), 1e-4);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }
}

/// Quantization noise (QN, book Definition 2.3) with parameter Q².
///
/// Simulated as X_t = U_t − U_{t−1} with U_t iid uniform of variance Q², so that
/// γ(0) = 2Q², γ(±1) = −Q², γ(h) = 0 otherwise, and the Allan variance is 3Q²/m²
/// (see `../shared/REFERENCES.md` §2). Q² is in unit² (per-sample form).
///
/// ```
/// use processes::QuantizationNoise;
/// let qn = QuantizationNoise::new(1e-6)?;
/// assert_eq!(qn.q2(), 1e-6);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QuantizationNoise {
    q2: f64,
}

impl QuantizationNoise {
    /// Builds QN with parameter `q2` = Q² > 0 (finite).
    ///
    /// ```
    /// use processes::QuantizationNoise;
    /// assert_eq!(QuantizationNoise::new(1e-6)?.q2(), 1e-6); // unit²
    /// assert!(QuantizationNoise::new(-1e-6).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(q2: f64) -> Result<Self> {
        Ok(Self {
            q2: check_positive("QN", "q2", q2)?,
        })
    }
    /// The parameter Q².
    ///
    /// ```
    /// use processes::QuantizationNoise;
    /// assert_eq!(QuantizationNoise::new(4e-6)?.q2(), 4e-6);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn q2(&self) -> f64 {
        self.q2
    }
}

/// Deterministic drift (DR, book Definition 2.4): X_t = ω t, t = 1, 2, …
///
/// `omega` is the slope per sample (unit per sample); any finite non-zero value.
///
/// ```
/// use processes::Drift;
/// let dr = Drift::new(-2e-7)?;
/// assert_eq!(dr.omega(), -2e-7);
/// assert!(Drift::new(0.0).is_err());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drift {
    omega: f64,
}

impl Drift {
    /// Builds DR with slope `omega` (finite, ≠ 0: the book's Ω is ℝ⁺ or ℝ⁻).
    ///
    /// ```
    /// use processes::Drift;
    /// assert_eq!(Drift::new(1e-7)?.omega(), 1e-7); // unit per sample
    /// assert!(Drift::new(f64::INFINITY).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(omega: f64) -> Result<Self> {
        if omega == 0.0 {
            return Err(ProcessError::InvalidParameter {
                process: "DR",
                name: "omega",
                value: omega,
                requirement: "must be non-zero (a zero drift is no component)",
            });
        }
        Ok(Self {
            omega: check_finite("DR", "omega", omega)?,
        })
    }
    /// The slope ω per sample.
    ///
    /// ```
    /// use processes::Drift;
    /// assert_eq!(Drift::new(-3e-8)?.omega(), -3e-8);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn omega(&self) -> f64 {
        self.omega
    }
}

/// Random walk (RW, book Definition 2.5): X_t = X_{t−1} + ε_t, ε_t iid N(0, γ²), X_0 = 0.
///
/// `gamma2` is the per-sample innovation variance γ² (unit²).
///
/// ```
/// use processes::RandomWalk;
/// let rw = RandomWalk::new(1e-9)?;
/// assert_eq!(rw.gamma2(), 1e-9);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RandomWalk {
    gamma2: f64,
}

impl RandomWalk {
    /// Builds RW with innovation variance `gamma2` > 0 (finite).
    ///
    /// ```
    /// use processes::RandomWalk;
    /// assert_eq!(RandomWalk::new(1e-10)?.gamma2(), 1e-10); // unit² per sample
    /// assert!(RandomWalk::new(0.0).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(gamma2: f64) -> Result<Self> {
        Ok(Self {
            gamma2: check_positive("RW", "gamma2", gamma2)?,
        })
    }
    /// The innovation variance γ² per sample.
    ///
    /// ```
    /// use processes::RandomWalk;
    /// assert_eq!(RandomWalk::new(4e-9)?.gamma2(), 4e-9);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn gamma2(&self) -> f64 {
        self.gamma2
    }
}

/// First-order autoregressive process (AR1, book Definition 2.6):
/// X_t = φ X_{t−1} + Z_t, Z_t iid N(0, v²).
///
/// `phi` ∈ (−1, 1); `sigma2` is the innovation variance v² (unit²). The stationary
/// variance is v² / (1 − φ²).
///
/// ```
/// use processes::Ar1;
/// let ar = Ar1::new(0.99, 1e-6)?;
/// assert_eq!(ar.phi(), 0.99);
/// assert!(Ar1::new(1.0, 1e-6).is_err());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ar1 {
    phi: f64,
    sigma2: f64,
}

impl Ar1 {
    /// Builds AR1 with `phi` ∈ (−1, 1) and innovation variance `sigma2` > 0.
    ///
    /// ```
    /// use processes::Ar1;
    /// let ar = Ar1::new(-0.5, 3.0)?; // v² in unit²
    /// assert_eq!((ar.phi(), ar.sigma2()), (-0.5, 3.0));
    /// assert!(Ar1::new(-1.0, 1.0).is_err() && Ar1::new(0.5, 0.0).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(phi: f64, sigma2: f64) -> Result<Self> {
        if !(phi.is_finite() && phi > -1.0 && phi < 1.0) {
            return Err(ProcessError::InvalidParameter {
                process: "AR1",
                name: "phi",
                value: phi,
                requirement: "must lie in (-1, 1)",
            });
        }
        Ok(Self {
            phi,
            sigma2: check_positive("AR1", "sigma2", sigma2)?,
        })
    }
    /// The autoregressive coefficient φ.
    ///
    /// ```
    /// use processes::Ar1;
    /// assert_eq!(Ar1::new(0.9, 1.0)?.phi(), 0.9);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn phi(&self) -> f64 {
        self.phi
    }
    /// The innovation variance v².
    ///
    /// ```
    /// use processes::Ar1;
    /// assert_eq!(Ar1::new(0.9, 1e-6)?.sigma2(), 1e-6);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }
    /// The stationary variance v² / (1 − φ²).
    ///
    /// ```
    /// use processes::Ar1;
    /// // v² / (1 − φ²) = 0.75 / 0.75 (unit²).
    /// assert!((Ar1::new(0.5, 0.75)?.stationary_variance() - 1.0).abs() < 1e-15);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn stationary_variance(&self) -> f64 {
        self.sigma2 / ((1.0 - self.phi) * (1.0 + self.phi))
    }
}

/// First-order Gauss-Markov process (GM, book Definition 2.7):
/// X_t = e^{−βΔt} X_{t−1} + Z_t, Z_t iid N(0, σ_G² (1 − e^{−2βΔt})).
///
/// `beta` > 0 is the inverse correlation time in 1/s; `sigma2` = σ_G² is the stationary
/// variance (unit²). It is the AR1 with φ = e^{−βΔt} and v² = σ_G² (1 − φ²) (book
/// Remark 2.1), so it needs the sampling rate for everything but its definition.
///
/// ```
/// use processes::GaussMarkov;
/// let gm = GaussMarkov::new(0.01, 1e-6)?; // correlation time 100 s
/// let ar = gm.to_ar1(100.0)?;              // at 100 Hz
/// assert!((ar.phi() - (-0.01f64 / 100.0).exp()).abs() < 1e-15);
/// let back = GaussMarkov::from_ar1(&ar, 100.0)?;
/// assert!((back.beta() - 0.01).abs() < 1e-12);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussMarkov {
    beta: f64,
    sigma2: f64,
}

impl GaussMarkov {
    /// Builds GM with `beta` > 0 (1/s) and stationary variance `sigma2` = σ_G² > 0.
    ///
    /// ```
    /// use processes::GaussMarkov;
    /// let gm = GaussMarkov::new(0.02, 1e-6)?; // β in 1/s, σ_G² in unit²
    /// assert_eq!((gm.beta(), gm.sigma2()), (0.02, 1e-6));
    /// assert!(GaussMarkov::new(0.0, 1e-6).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(beta: f64, sigma2: f64) -> Result<Self> {
        Ok(Self {
            beta: check_positive("GM", "beta", beta)?,
            sigma2: check_positive("GM", "sigma2", sigma2)?,
        })
    }
    /// β in 1/s.
    ///
    /// ```
    /// use processes::GaussMarkov;
    /// assert_eq!(GaussMarkov::new(0.5, 1.0)?.beta(), 0.5);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn beta(&self) -> f64 {
        self.beta
    }
    /// The stationary variance σ_G².
    ///
    /// ```
    /// use processes::GaussMarkov;
    /// assert_eq!(GaussMarkov::new(0.5, 2.0)?.sigma2(), 2.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }
    /// The correlation time 1/β in seconds.
    ///
    /// ```
    /// use processes::GaussMarkov;
    /// assert_eq!(GaussMarkov::new(0.01, 1.0)?.correlation_time(), 100.0); // seconds
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn correlation_time(&self) -> f64 {
        1.0 / self.beta
    }
    /// The equivalent AR1 at sampling rate `rate_hz`: φ = e^{−β/rate}, v² = σ_G² (1 − φ²).
    ///
    /// ```
    /// use processes::GaussMarkov;
    /// let ar = GaussMarkov::new(2.0, 1.0)?.to_ar1(10.0)?; // Δt = 0.1 s
    /// assert!((ar.phi() - (-0.2f64).exp()).abs() < 1e-15);
    /// assert!((ar.stationary_variance() - 1.0).abs() < 1e-12);
    /// assert!(GaussMarkov::new(2.0, 1.0)?.to_ar1(0.0).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn to_ar1(&self, rate_hz: f64) -> Result<Ar1> {
        let dt = 1.0 / check_rate(rate_hz)?;
        let phi = (-self.beta * dt).exp();
        // 1 − φ² = −expm1(−2βΔt), accurate for small βΔt.
        let v2 = self.sigma2 * -(-2.0 * self.beta * dt).exp_m1();
        Ar1::new(phi, v2)
    }
    /// The GM equivalent to an AR1 with φ ∈ (0, 1) at sampling rate `rate_hz`:
    /// β = −ln φ · rate, σ_G² = v² / (1 − φ²).
    ///
    /// ```
    /// use processes::{Ar1, GaussMarkov};
    /// let gm = GaussMarkov::from_ar1(&Ar1::new(0.5, 0.75)?, 1.0)?;
    /// assert!((gm.beta() - 2f64.ln()).abs() < 1e-15); // 1/s
    /// assert!((gm.sigma2() - 1.0).abs() < 1e-15);
    /// assert!(GaussMarkov::from_ar1(&Ar1::new(-0.5, 1.0)?, 1.0).is_err()); // φ ≤ 0
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn from_ar1(ar1: &Ar1, rate_hz: f64) -> Result<Self> {
        let rate = check_rate(rate_hz)?;
        if ar1.phi() <= 0.0 {
            return Err(ProcessError::InvalidParameter {
                process: "AR1",
                name: "phi",
                value: ar1.phi(),
                requirement: "must lie in (0, 1) to map onto a Gauss-Markov process",
            });
        }
        Self::new(-ar1.phi().ln() * rate, ar1.stationary_variance())
    }
}

/// Moving average of order 1 (MA1, book Example 4.1): X_t = W_t + θ W_{t−1},
/// W_t iid N(0, σ²).
///
/// `theta` is any finite real; `sigma2` > 0 is the innovation variance (unit²).
///
/// ```
/// use processes::Ma1;
/// let ma = Ma1::new(0.5, 2.0)?;
/// assert_eq!((ma.theta(), ma.sigma2()), (0.5, 2.0));
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ma1 {
    theta: f64,
    sigma2: f64,
}

impl Ma1 {
    /// Builds MA1 with finite `theta` and innovation variance `sigma2` > 0.
    ///
    /// ```
    /// use processes::Ma1;
    /// assert_eq!(Ma1::new(-2.0, 1e-6)?.theta(), -2.0); // σ² in unit²
    /// assert!(Ma1::new(f64::NAN, 1.0).is_err() && Ma1::new(0.5, -1.0).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(theta: f64, sigma2: f64) -> Result<Self> {
        Ok(Self {
            theta: check_finite("MA1", "theta", theta)?,
            sigma2: check_positive("MA1", "sigma2", sigma2)?,
        })
    }
    /// The moving-average coefficient θ.
    ///
    /// ```
    /// use processes::Ma1;
    /// assert_eq!(Ma1::new(0.3, 1.0)?.theta(), 0.3);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn theta(&self) -> f64 {
        self.theta
    }
    /// The innovation variance σ².
    ///
    /// ```
    /// use processes::Ma1;
    /// assert_eq!(Ma1::new(0.3, 5.0)?.sigma2(), 5.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }
}

/// The band of a [`BiasInstability`]: the cluster sizes m_lo ≤ m ≤ m_hi (samples) over
/// which its Allan variance is flat, i.e. the scales of the record it describes. Fixed from
/// the record (never fitted); [`BiBand::AUTO`] stands for "the scales of the record at hand"
/// and is resolved by the fit (from the curve) or the simulation (m = 1 … n).
///
/// ```
/// use processes::BiBand;
/// let b = BiBand::new(1, 1 << 19)?;
/// assert_eq!((b.m_lo(), b.m_hi()), (1, 524_288));
/// assert!(BiBand::new(8, 8).is_err() && BiBand::new(0, 8).is_err());
/// assert!(BiBand::AUTO.is_auto() && !b.is_auto());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct BiBand {
    m_lo: u64,
    m_hi: u64,
}

/// States per decade of correlation time of a [`BiasInstability`] (see its docs for why 2).
pub const BI_STATES_PER_DECADE: f64 = 2.0;
/// Shortest correlation time (samples) of a [`BiasInstability`] state: a state much faster
/// than this is white noise at every cluster size, no longer a 1/f brick.
pub const BI_MIN_CORRELATION_SAMPLES: f64 = 2.0;
/// Smallest cluster size (samples) from which the [`BiasInstability`] AV is flat within
/// [`BI_FLAT_TOLERANCE`]: below it the band cannot be built from states of at least
/// [`BI_MIN_CORRELATION_SAMPLES`] (at m = 1 the AV is 35 % below the plateau).
pub const BI_FLAT_FROM_M: u64 = 16;
/// Relative tolerance of the flat AV of a [`BiasInstability`] over
/// max(m_lo, [`BI_FLAT_FROM_M`]) ≤ m ≤ m_hi (checked in the tests on every integer-spaced
/// log grid point; measured −0.9 % … +0.2 %).
pub const BI_FLAT_TOLERANCE: f64 = 0.01;

impl BiBand {
    /// The unresolved band ("the record's scales"), printed as a bare `BI`.
    pub const AUTO: BiBand = BiBand { m_lo: 0, m_hi: 0 };

    /// A band of cluster sizes 1 ≤ `m_lo` < `m_hi` (samples).
    ///
    /// ```
    /// use processes::BiBand;
    /// assert_eq!(BiBand::new(2, 1024)?.m_hi(), 1024);
    /// assert!(BiBand::new(1024, 2).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(m_lo: u64, m_hi: u64) -> Result<Self> {
        if m_lo == 0 || m_hi <= m_lo || m_hi > 1 << 53 {
            return Err(ProcessError::InvalidParameter {
                process: "BI",
                name: "m_hi",
                value: m_hi as f64,
                requirement: "the band needs 1 <= m_lo < m_hi <= 2^53 samples",
            });
        }
        Ok(Self { m_lo, m_hi })
    }
    /// Whether this is [`BiBand::AUTO`].
    ///
    /// ```
    /// assert!(processes::BiBand::AUTO.is_auto());
    /// ```
    pub fn is_auto(&self) -> bool {
        self.m_lo == 0
    }
    /// Lower edge m_lo (samples; 0 for AUTO).
    ///
    /// ```
    /// assert_eq!(processes::BiBand::new(4, 64)?.m_lo(), 4);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn m_lo(&self) -> u64 {
        self.m_lo
    }
    /// Upper edge m_hi (samples; 0 for AUTO).
    ///
    /// ```
    /// assert_eq!(processes::BiBand::new(4, 64)?.m_hi(), 64);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn m_hi(&self) -> u64 {
        self.m_hi
    }
    /// The band itself, or `fallback` when AUTO.
    ///
    /// ```
    /// use processes::BiBand;
    /// let b = BiBand::new(1, 100)?;
    /// assert_eq!(BiBand::AUTO.or(b), b);
    /// assert_eq!(BiBand::new(2, 50)?.or(b).m_hi(), 50);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn or(self, fallback: BiBand) -> BiBand {
        if self.is_auto() { fallback } else { self }
    }
    /// The correlation times T_i (samples) of the Gauss-Markov states and their stationary
    /// variances per unit B² (see [`BiasInstability`]). Errors for AUTO.
    ///
    /// ```
    /// use processes::BiBand;
    /// let (t, u) = BiBand::new(1, 1 << 19)?.states()?;
    /// assert_eq!(t.len(), 14); // 2 → 5.2·10⁶ samples, two per decade
    /// assert_eq!((t[0], u.len()), (2.0, 14));
    /// assert!(BiBand::AUTO.states().is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn states(&self) -> Result<(Vec<f64>, Vec<f64>)> {
        if self.is_auto() {
            return Err(ProcessError::NotDefined {
                what: "the Gauss-Markov states",
                process: "BI",
                why: "its band is not set (BI without m_lo/m_hi takes the record's scales: fit it to a curve or simulate it)",
            });
        }
        let k = BI_STATES_PER_DECADE;
        let r = 10f64.powf(1.0 / k);
        let t_lo = (self.m_lo as f64 / 10.0).max(BI_MIN_CORRELATION_SAMPLES);
        let t_hi = 10.0 * self.m_hi as f64;
        let n = ((t_hi / t_lo).log10() * k - 1e-9).ceil().max(1.0) as usize + 1;
        let times: Vec<f64> = (0..n).map(|i| t_lo * r.powi(i as i32)).collect();
        // Equal variances w give the plateau w·(k/ln 10)·2 ln 2 (continuum limit of the sum of
        // AR1 AVs over log-spaced T); the plateau must be (2 ln 2/π)·B², so w = ln 10/(π k).
        // The end states also stand for the states beyond the ends (a geometric tail with
        // ratio 1/r): weight r/(r − 1).
        let w = std::f64::consts::LN_10 / (std::f64::consts::PI * k);
        let mut var = vec![w; n];
        var[0] *= r / (r - 1.0);
        var[n - 1] *= r / (r - 1.0);
        Ok((times, var))
    }
}

impl fmt::Display for BiBand {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "m_lo={}, m_hi={}", self.m_lo, self.m_hi)
    }
}

/// Bias instability (flicker, IEEE Std 952 coefficient B): a sum of independent
/// Gauss-Markov (AR1) states whose Allan variance is flat, σ²(τ) = (2 ln 2/π)·B² ≈ 0.4413 B²
/// (AD floor 0.664 B, REFERENCES §1 and §11), over the band of cluster sizes of the record
/// ([`BiBand`]). A Kalman filter can hold it: it is the listed states, nothing else.
///
/// `b` is B in the unit of the data (e.g. °/s); the band is fixed, not fitted.
///
/// # The states
/// Correlation times T_i = T₀·10^{i/2} samples, two per decade, from T₀ = max(m_lo/10, 2)
/// to at least 10·m_hi; stationary variances (ln 10/(2π))·B² each, ×√10/(√10 − 1) for the
/// two end states. Why so:
/// - A sum of AR1s with equal variances w at log-spaced T has AV w·(k/ln 10)·2 ln 2 in the
///   continuum limit (k states per decade), hence w. The discrete sum ripples log-periodically
///   around it: measured ±2.0 % at k = 1, ±0.9 % at k = 1.5, ±0.2 % at k = 2 (±0.15 % at
///   k = 3 and 4: the remainder is the ends). k = 2 is the fewest states for a 1 % tolerance.
/// - An AR1 contributes 2σ²T/m at m ≫ T and (2/3)σ²m/T at m ≪ T, so the states missing
///   beyond either end are a geometric tail that the end state's extra weight r/(r − 1)
///   (r = √10) replaces; one decade beyond each edge then keeps the edges within 1 %
///   (without it they sag by 10–30 %).
/// - States faster than 2 samples are white noise at every m, so below m = 16 the AV falls
///   under the plateau (−3 % at m = 8, −35 % at m = 1); it is flat within
///   [`BI_FLAT_TOLERANCE`] over max(m_lo, 16) ≤ m ≤ m_hi.
///
/// A record of 5·10⁵ scales (m up to 2¹⁹) takes 14 states.
///
/// ```
/// use processes::{BiBand, BiasInstability, Process};
/// let bi = BiasInstability::new(1e-3, BiBand::new(1, 1 << 16)?)?;
/// assert_eq!(bi.b(), 1e-3);
/// // γ(0): the sum of the states' variances
/// let (_, u) = bi.band().states()?;
/// let g0: f64 = u.iter().sum::<f64>() * 1e-6;
/// assert!((Process::from(bi).autocovariance(0, 100.0)? - g0).abs() < 1e-18);
/// assert!(BiasInstability::new(0.0, BiBand::AUTO).is_err());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasInstability {
    b: f64,
    band: BiBand,
}

impl BiasInstability {
    /// Builds BI with B = `b` > 0 (unit of the data) over `band` (may be AUTO).
    ///
    /// ```
    /// use processes::{BiBand, BiasInstability};
    /// assert_eq!(BiasInstability::new(2e-4, BiBand::AUTO)?.band(), BiBand::AUTO);
    /// assert!(BiasInstability::new(f64::NAN, BiBand::AUTO).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(b: f64, band: BiBand) -> Result<Self> {
        Ok(Self {
            b: check_positive("BI", "B", b)?,
            band,
        })
    }
    /// The IEEE coefficient B (unit of the data).
    ///
    /// ```
    /// assert_eq!(processes::BiasInstability::new(3e-4, processes::BiBand::AUTO)?.b(), 3e-4);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn b(&self) -> f64 {
        self.b
    }
    /// The band.
    ///
    /// ```
    /// use processes::{BiBand, BiasInstability};
    /// assert_eq!(BiasInstability::new(1.0, BiBand::new(1, 8)?)?.band().m_hi(), 8);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn band(&self) -> BiBand {
        self.band
    }
    /// The plateau of the AV, (2 ln 2/π)·B² (unit²).
    ///
    /// ```
    /// let bi = processes::BiasInstability::new(1.0, processes::BiBand::AUTO)?;
    /// assert!((bi.plateau() - 0.441_271_2).abs() < 1e-7);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn plateau(&self) -> f64 {
        2.0 * std::f64::consts::LN_2 / std::f64::consts::PI * self.b * self.b
    }
    /// The states as AR1s (φ_i = e^{−1/T_i}, v_i² = σ_i²(1 − φ_i²)), fastest first.
    /// Errors for an AUTO band.
    ///
    /// ```
    /// use processes::{BiBand, BiasInstability};
    /// let s = BiasInstability::new(1.0, BiBand::new(1, 1000)?)?.ar1_states()?;
    /// assert!((s[0].phi() - (-0.5f64).exp()).abs() < 1e-15); // T₀ = 2 samples
    /// assert!(s.windows(2).all(|w| w[0].phi() < w[1].phi()));
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn ar1_states(&self) -> Result<Vec<Ar1>> {
        let (t, u) = self.band.states()?;
        let b2 = self.b * self.b;
        t.iter()
            .zip(&u)
            .map(|(&t, &u)| Ar1::new((-1.0 / t).exp(), b2 * u * -(-2.0 / t).exp_m1()))
            .collect()
    }
}

/// Random-phase sinusoid (SIN, simts' `SIN(alpha2, beta)`, IEEE Std 952's sinusoidal
/// term): X_t = α·sin(β·t + U), U uniform on [0, 2π).
///
/// `alpha2` = α² > 0 (unit²; the variance is α²/2), `beta` ∈ (0, π) the angular frequency in
/// rad per sample (f = β·rate/(2π) Hz, below Nyquist). γ(h) = (α²/2)·cos(βh) and
/// AV(m) = α²·sin⁴(βm/2) / (m·sin(β/2))² (REFERENCES §11). Stationary but not ergodic: one
/// record sees one phase, and the AV estimator's variance is not the Gaussian one.
///
/// ```
/// use processes::{Process, Sinusoid};
/// let s = Sinusoid::from_hz(2e-4, 8.0, 100.0)?; // 8 Hz at 100 Hz
/// assert!((s.beta() - 2.0 * std::f64::consts::PI * 0.08).abs() < 1e-15);
/// assert!((Process::from(s).autocovariance(0, 100.0)? - 1e-4).abs() < 1e-18); // α²/2
/// assert!(Sinusoid::new(1.0, std::f64::consts::PI).is_err());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sinusoid {
    alpha2: f64,
    beta: f64,
}

impl Sinusoid {
    /// Builds SIN with `alpha2` > 0 and `beta` ∈ (0, π) rad per sample.
    ///
    /// ```
    /// use processes::Sinusoid;
    /// assert_eq!(Sinusoid::new(1e-4, 0.5)?.beta(), 0.5);
    /// assert!(Sinusoid::new(0.0, 0.5).is_err() && Sinusoid::new(1.0, 0.0).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(alpha2: f64, beta: f64) -> Result<Self> {
        if !(beta.is_finite() && beta > 0.0 && beta < std::f64::consts::PI) {
            return Err(ProcessError::InvalidParameter {
                process: "SIN",
                name: "beta",
                value: beta,
                requirement: "must lie in (0, pi) rad per sample (below the Nyquist frequency)",
            });
        }
        Ok(Self {
            alpha2: check_positive("SIN", "alpha2", alpha2)?,
            beta,
        })
    }
    /// Builds SIN from α² and a frequency `f_hz` (Hz) at sampling rate `rate_hz`:
    /// β = 2π·f/rate.
    ///
    /// ```
    /// use processes::Sinusoid;
    /// assert!(Sinusoid::from_hz(1.0, 60.0, 100.0).is_err()); // above Nyquist
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn from_hz(alpha2: f64, f_hz: f64, rate_hz: f64) -> Result<Self> {
        let rate = check_rate(rate_hz)?;
        Self::new(alpha2, 2.0 * std::f64::consts::PI * f_hz / rate)
    }
    /// α² (unit²).
    ///
    /// ```
    /// assert_eq!(processes::Sinusoid::new(3.0, 1.0)?.alpha2(), 3.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn alpha2(&self) -> f64 {
        self.alpha2
    }
    /// β (rad per sample).
    ///
    /// ```
    /// assert_eq!(processes::Sinusoid::new(3.0, 1.0)?.beta(), 1.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn beta(&self) -> f64 {
        self.beta
    }
    /// The frequency β·rate/(2π) in Hz at `rate_hz`.
    ///
    /// ```
    /// let s = processes::Sinusoid::from_hz(1.0, 7.5, 100.0)?;
    /// assert!((s.frequency_hz(100.0) - 7.5).abs() < 1e-12);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn frequency_hz(&self, rate_hz: f64) -> f64 {
        self.beta * rate_hz / (2.0 * std::f64::consts::PI)
    }
}

/// The kind of a latent process, without values; also a model's "slot" to be estimated.
///
/// ```
/// use processes::ProcessKind;
/// assert_eq!(ProcessKind::Ar1.code(), "AR1");
/// assert_eq!(ProcessKind::Ar1.param_names(), &["phi", "sigma2"]);
/// assert_eq!("rw".parse::<ProcessKind>()?, ProcessKind::RandomWalk);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum ProcessKind {
    /// Quantization noise, `QN`.
    #[serde(rename = "QN")]
    QuantizationNoise,
    /// White noise, `WN`.
    #[serde(rename = "WN")]
    WhiteNoise,
    /// Random walk, `RW`.
    #[serde(rename = "RW")]
    RandomWalk,
    /// Drift, `DR`.
    #[serde(rename = "DR")]
    Drift,
    /// First-order autoregressive, `AR1`.
    #[serde(rename = "AR1")]
    Ar1,
    /// Gauss-Markov, `GM`.
    #[serde(rename = "GM")]
    GaussMarkov,
    /// Moving average of order 1, `MA1`.
    #[serde(rename = "MA1")]
    Ma1,
    /// Bias instability, `BI`, over a band of cluster sizes ([`BiBand::AUTO`] until the
    /// record is known).
    #[serde(rename = "BI")]
    BiasInstability(BiBand),
    /// Random-phase sinusoid, `SIN`.
    #[serde(rename = "SIN")]
    Sinusoid,
    /// Autoregressive process of order p ∈ {2, 3, 4}, `AR2`/`AR3`/`AR4` ([`crate::ArP`]).
    /// Not in [`ProcessKind::ALL`] (the classes built from it stay as they were).
    #[serde(rename = "ARP")]
    ArP(u8),
    /// MA(2) (`MA2`, p = 0) or ARMA(p, q) (`ARMApq`, 1 ≤ p ≤ 4, q ∈ {1, 2}) as (p, q)
    /// ([`crate::Arma`]). Not in [`ProcessKind::ALL`].
    #[serde(rename = "ARMA")]
    Arma(u8, u8),
    /// Power-law process ARFIMA(0, d, 0), `PLP` ([`crate::Plp`]). Not in
    /// [`ProcessKind::ALL`].
    #[serde(rename = "PLP")]
    Plp,
    /// Fractional Gaussian noise, `FGN` ([`crate::Fgn`]). Not in [`ProcessKind::ALL`].
    #[serde(rename = "FGN")]
    Fgn,
}

impl ProcessKind {
    /// Every kind, in the conventional order QN, WN, RW, DR, AR1, GM, MA1, BI, SIN (BI with
    /// an AUTO band), except AR2/AR3/AR4 ([`ProcessKind::ArP`]): the classes built from
    /// this list stay as they were.
    ///
    /// ```
    /// use processes::ProcessKind;
    /// let codes: Vec<_> = ProcessKind::ALL.iter().map(|k| k.code()).collect();
    /// assert_eq!(codes, ["QN", "WN", "RW", "DR", "AR1", "GM", "MA1", "BI", "SIN"]);
    /// ```
    pub const ALL: [ProcessKind; 9] = [
        ProcessKind::QuantizationNoise,
        ProcessKind::WhiteNoise,
        ProcessKind::RandomWalk,
        ProcessKind::Drift,
        ProcessKind::Ar1,
        ProcessKind::GaussMarkov,
        ProcessKind::Ma1,
        ProcessKind::BiasInstability(BiBand::AUTO),
        ProcessKind::Sinusoid,
    ];

    /// The short code used in model strings: `WN`, `QN`, `DR`, `RW`, `AR1`, `GM`, `MA1`.
    ///
    /// ```
    /// use processes::ProcessKind;
    /// assert_eq!(ProcessKind::GaussMarkov.code(), "GM");
    /// ```
    pub fn code(self) -> &'static str {
        match self {
            ProcessKind::WhiteNoise => "WN",
            ProcessKind::QuantizationNoise => "QN",
            ProcessKind::Drift => "DR",
            ProcessKind::RandomWalk => "RW",
            ProcessKind::Ar1 => "AR1",
            ProcessKind::GaussMarkov => "GM",
            ProcessKind::Ma1 => "MA1",
            ProcessKind::BiasInstability(_) => "BI",
            ProcessKind::Sinusoid => "SIN",
            ProcessKind::ArP(3) => "AR3",
            ProcessKind::ArP(4) => "AR4",
            ProcessKind::ArP(_) => "AR2",
            ProcessKind::Arma(p, q) => crate::arma::CODES[(p as usize).min(4)][(q as usize).min(2)],
            ProcessKind::Plp => "PLP",
            ProcessKind::Fgn => "FGN",
        }
    }

    /// Parameter names in the order of [`Process::params`].
    ///
    /// ```
    /// use processes::ProcessKind;
    /// assert_eq!(ProcessKind::GaussMarkov.param_names(), ["beta", "sigma2"]);
    /// ```
    pub fn param_names(self) -> &'static [&'static str] {
        match self {
            ProcessKind::WhiteNoise => &["sigma2"],
            ProcessKind::QuantizationNoise => &["q2"],
            ProcessKind::Drift => &["omega"],
            ProcessKind::RandomWalk => &["gamma2"],
            ProcessKind::Ar1 => &["phi", "sigma2"],
            ProcessKind::GaussMarkov => &["beta", "sigma2"],
            ProcessKind::Ma1 => &["theta", "sigma2"],
            ProcessKind::BiasInstability(_) => &["B"],
            ProcessKind::Sinusoid => &["alpha2", "beta"],
            ProcessKind::ArP(3) => &["phi1", "phi2", "phi3", "sigma2"],
            ProcessKind::ArP(4) => &["phi1", "phi2", "phi3", "phi4", "sigma2"],
            ProcessKind::ArP(_) => &["phi1", "phi2", "sigma2"],
            ProcessKind::Arma(p, q) => crate::arma::NAMES[(p as usize).min(4)][(q as usize).min(2)],
            ProcessKind::Plp => &["sigma2", "d"],
            ProcessKind::Fgn => &["sigma2", "H"],
        }
    }

    /// Number of parameters.
    ///
    /// ```
    /// use processes::ProcessKind;
    /// assert_eq!((ProcessKind::WhiteNoise.n_params(), ProcessKind::Ma1.n_params()), (1, 2));
    /// ```
    pub fn n_params(self) -> usize {
        self.param_names().len()
    }

    /// Whether the process is (weakly) stationary (book Remark 2.6): WN, QN, AR1, GM and
    /// MA1 are; DR and RW are not.
    ///
    /// ```
    /// use processes::ProcessKind;
    /// assert!(ProcessKind::QuantizationNoise.is_stationary());
    /// assert!(!ProcessKind::RandomWalk.is_stationary());
    /// ```
    pub fn is_stationary(self) -> bool {
        !matches!(self, ProcessKind::Drift | ProcessKind::RandomWalk)
    }

    /// Whether a model may hold several components of this kind and stay identifiable
    /// (only AR1 and GM may repeat).
    ///
    /// ```
    /// use processes::ProcessKind;
    /// assert!(ProcessKind::Ar1.may_repeat() && !ProcessKind::WhiteNoise.may_repeat());
    /// assert!(ProcessKind::Sinusoid.may_repeat()); // at different frequencies
    /// ```
    pub fn may_repeat(self) -> bool {
        matches!(
            self,
            ProcessKind::Ar1
                | ProcessKind::GaussMarkov
                | ProcessKind::Sinusoid
                | ProcessKind::ArP(_)
        ) || matches!(self, ProcessKind::Arma(p, _) if p > 0)
    }
}

impl fmt::Display for ProcessKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.code())
    }
}

impl std::str::FromStr for ProcessKind {
    type Err = ProcessError;
    fn from_str(s: &str) -> Result<Self> {
        let t = s.trim();
        ProcessKind::ALL
            .into_iter()
            .chain((2..=crate::ar_p::AR_MAX_ORDER as u8).map(ProcessKind::ArP))
            .chain(crate::arma::orders().map(|(p, q)| ProcessKind::Arma(p as u8, q as u8)))
            .chain([ProcessKind::Plp, ProcessKind::Fgn])
            .find(|k| k.code().eq_ignore_ascii_case(t))
            .ok_or_else(|| ProcessError::Parse {
                input: s.to_string(),
                position: 0,
                message: format!(
                    "unknown process {t:?}; expected one of WN, QN, DR, RW, AR1, AR2, AR3, AR4, GM, MA1, BI, SIN, MA2, ARMApq (p = 1…4, q = 1, 2), PLP, FGN"
                ),
            })
    }
}

/// Any one latent process with its parameter values.
///
/// ```
/// use processes::{Process, ProcessKind, Ar1};
/// let p = Process::from(Ar1::new(0.5, 3.0)?);
/// assert_eq!(p.kind(), ProcessKind::Ar1);
/// assert_eq!(p.params(), vec![0.5, 3.0]);
/// assert_eq!(p.autocovariance(1, 1.0)?, 0.5 * 3.0 / (1.0 - 0.25));
/// let q = Process::from_params(ProcessKind::Ar1, &[0.5, 3.0])?;
/// assert_eq!(p, q);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ProcessRepr", into = "ProcessRepr")]
pub enum Process {
    /// White noise.
    WhiteNoise(WhiteNoise),
    /// Quantization noise.
    QuantizationNoise(QuantizationNoise),
    /// Drift.
    Drift(Drift),
    /// Random walk.
    RandomWalk(RandomWalk),
    /// First-order autoregressive process.
    Ar1(Ar1),
    /// Gauss-Markov process.
    GaussMarkov(GaussMarkov),
    /// Moving average of order 1.
    Ma1(Ma1),
    /// Bias instability.
    BiasInstability(BiasInstability),
    /// Random-phase sinusoid.
    Sinusoid(Sinusoid),
    /// Autoregressive process of order 2 … 4.
    ArP(ArP),
    /// MA(2) or ARMA(p, q).
    Arma(Arma),
    /// Power-law process ARFIMA(0, d, 0).
    Plp(Plp),
    /// Fractional Gaussian noise.
    Fgn(Fgn),
}

macro_rules! impl_from_process {
    ($($t:ident),*) => {$(
        impl From<$t> for Process {
            fn from(p: $t) -> Self { Process::$t(p) }
        }
    )*};
}
impl_from_process!(
    WhiteNoise,
    QuantizationNoise,
    Drift,
    RandomWalk,
    Ar1,
    GaussMarkov,
    Ma1,
    BiasInstability,
    Sinusoid,
    ArP,
    Arma,
    Plp,
    Fgn
);

impl Process {
    /// The kind of this process.
    ///
    /// ```
    /// use processes::{Drift, Process, ProcessKind};
    /// assert_eq!(Process::from(Drift::new(1e-7)?).kind(), ProcessKind::Drift);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn kind(&self) -> ProcessKind {
        match self {
            Process::WhiteNoise(_) => ProcessKind::WhiteNoise,
            Process::QuantizationNoise(_) => ProcessKind::QuantizationNoise,
            Process::Drift(_) => ProcessKind::Drift,
            Process::RandomWalk(_) => ProcessKind::RandomWalk,
            Process::Ar1(_) => ProcessKind::Ar1,
            Process::GaussMarkov(_) => ProcessKind::GaussMarkov,
            Process::Ma1(_) => ProcessKind::Ma1,
            Process::BiasInstability(b) => ProcessKind::BiasInstability(b.band()),
            Process::Sinusoid(_) => ProcessKind::Sinusoid,
            Process::ArP(a) => ProcessKind::ArP(a.p),
            Process::Arma(a) => ProcessKind::Arma(a.p, a.q),
            Process::Plp(_) => ProcessKind::Plp,
            Process::Fgn(_) => ProcessKind::Fgn,
        }
    }

    /// Parameter values in the order of [`ProcessKind::param_names`].
    ///
    /// ```
    /// use processes::{GaussMarkov, Process};
    /// assert_eq!(Process::from(GaussMarkov::new(0.1, 2.0)?).params(), [0.1, 2.0]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn params(&self) -> Vec<f64> {
        match *self {
            Process::WhiteNoise(p) => vec![p.sigma2],
            Process::QuantizationNoise(p) => vec![p.q2],
            Process::Drift(p) => vec![p.omega],
            Process::RandomWalk(p) => vec![p.gamma2],
            Process::Ar1(p) => vec![p.phi, p.sigma2],
            Process::GaussMarkov(p) => vec![p.beta, p.sigma2],
            Process::Ma1(p) => vec![p.theta, p.sigma2],
            Process::BiasInstability(p) => vec![p.b],
            Process::Sinusoid(p) => vec![p.alpha2, p.beta],
            Process::ArP(a) => {
                let mut v = a.phi().to_vec();
                v.push(a.sigma2);
                v
            }
            Process::Arma(a) => a.params(),
            Process::Plp(p) => vec![p.sigma2, p.d],
            Process::Fgn(p) => vec![p.sigma2, p.h],
        }
    }

    /// Builds a process of `kind` from its parameter values (same order as
    /// [`ProcessKind::param_names`]), validating them.
    ///
    /// ```
    /// use processes::{Ar1, Process, ProcessKind};
    /// assert_eq!(Process::from_params(ProcessKind::Ar1, &[0.9, 1e-6])?, Process::from(Ar1::new(0.9, 1e-6)?));
    /// assert!(Process::from_params(ProcessKind::Ar1, &[0.9]).is_err()); // φ and v² needed
    /// assert!(Process::from_params(ProcessKind::Ar1, &[1.5, 1e-6]).is_err()); // |φ| ≥ 1
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn from_params(kind: ProcessKind, values: &[f64]) -> Result<Self> {
        if values.len() != kind.n_params() {
            return Err(ProcessError::InvalidArgument(format!(
                "{} takes {} parameter(s) ({}), got {}",
                kind.code(),
                kind.n_params(),
                kind.param_names().join(", "),
                values.len()
            )));
        }
        let v = values;
        Ok(match kind {
            ProcessKind::WhiteNoise => WhiteNoise::new(v[0])?.into(),
            ProcessKind::QuantizationNoise => QuantizationNoise::new(v[0])?.into(),
            ProcessKind::Drift => Drift::new(v[0])?.into(),
            ProcessKind::RandomWalk => RandomWalk::new(v[0])?.into(),
            ProcessKind::Ar1 => Ar1::new(v[0], v[1])?.into(),
            ProcessKind::GaussMarkov => GaussMarkov::new(v[0], v[1])?.into(),
            ProcessKind::Ma1 => Ma1::new(v[0], v[1])?.into(),
            ProcessKind::BiasInstability(band) => BiasInstability::new(v[0], band)?.into(),
            ProcessKind::Sinusoid => Sinusoid::new(v[0], v[1])?.into(),
            ProcessKind::ArP(_) => {
                let n = v.len();
                ArP::new(&v[..n - 1], v[n - 1])?.into()
            }
            ProcessKind::Arma(p, q) => Arma::from_params(p as usize, q as usize, v)?.into(),
            ProcessKind::Plp => Plp::new(v[0], v[1])?.into(),
            ProcessKind::Fgn => Fgn::new(v[0], v[1])?.into(),
        })
    }

    /// Whether the process is (weakly) stationary (book Remark 2.6).
    ///
    /// ```
    /// use processes::{Process, RandomWalk, WhiteNoise};
    /// assert!(Process::from(WhiteNoise::new(1.0)?).is_stationary());
    /// assert!(!Process::from(RandomWalk::new(1.0)?).is_stationary());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn is_stationary(&self) -> bool {
        self.kind().is_stationary()
    }

    /// The process as an AR1 at sampling rate `rate_hz` when it is one (AR1 itself, or GM
    /// through the book's map); `None` for the other kinds.
    ///
    /// ```
    /// use processes::{GaussMarkov, Process, WhiteNoise};
    /// let gm = Process::from(GaussMarkov::new(1.0, 1.0)?);
    /// assert!((gm.as_ar1(1.0)?.unwrap().phi() - (-1f64).exp()).abs() < 1e-15);
    /// assert!(Process::from(WhiteNoise::new(1.0)?).as_ar1(1.0)?.is_none());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn as_ar1(&self, rate_hz: f64) -> Result<Option<Ar1>> {
        match self {
            Process::Ar1(a) => Ok(Some(*a)),
            Process::GaussMarkov(g) => g.to_ar1(rate_hz).map(Some),
            _ => Ok(None),
        }
    }

    /// Mean E\[X_t\] at time index `t` = 1, 2, … (ω t for drift, 0 otherwise).
    ///
    /// ```
    /// use processes::{Drift, Process, WhiteNoise};
    /// assert_eq!(Process::from(Drift::new(0.25)?).mean_at(8), 2.0); // ω t, unit
    /// assert_eq!(Process::from(WhiteNoise::new(1.0)?).mean_at(8), 0.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn mean_at(&self, t: u64) -> f64 {
        match self {
            Process::Drift(d) => d.omega * t as f64,
            _ => 0.0,
        }
    }

    /// Variance Var(X_t) at time index `t` = 1, 2, … : t γ² for RW, 0 for DR, and the
    /// stationary variance γ(0) otherwise. `rate_hz` is needed for GM only.
    ///
    /// ```
    /// use processes::{Process, QuantizationNoise, RandomWalk};
    /// assert_eq!(Process::from(RandomWalk::new(0.5)?).variance_at(10, 1.0)?, 5.0); // t γ², unit²
    /// assert_eq!(Process::from(QuantizationNoise::new(1.0)?).variance_at(10, 1.0)?, 2.0); // 2Q²
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn variance_at(&self, t: u64, rate_hz: f64) -> Result<f64> {
        check_rate(rate_hz)?;
        match self {
            Process::RandomWalk(r) => Ok(r.gamma2 * t as f64),
            Process::Drift(_) => Ok(0.0),
            _ => self.autocovariance(0, rate_hz),
        }
    }

    /// Autocovariance γ(h) at lag `h` (samples) of a stationary process.
    /// `rate_hz` is needed for GM only. Errors for RW and DR, which are not stationary.
    ///
    /// ```
    /// use processes::{Ma1, Process, RandomWalk};
    /// let ma = Process::from(Ma1::new(0.5, 2.0)?);
    /// assert_eq!(ma.autocovariance(0, 1.0)?, 2.5); // (1 + θ²) σ², unit²
    /// assert_eq!(ma.autocovariance(1, 1.0)?, 1.0); // θ σ²
    /// assert_eq!(ma.autocovariance(2, 1.0)?, 0.0);
    /// assert!(Process::from(RandomWalk::new(1.0)?).autocovariance(1, 1.0).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn autocovariance(&self, h: u64, rate_hz: f64) -> Result<f64> {
        check_rate(rate_hz)?;
        Ok(match *self {
            Process::WhiteNoise(p) => {
                if h == 0 {
                    p.sigma2
                } else {
                    0.0
                }
            }
            Process::QuantizationNoise(p) => match h {
                0 => 2.0 * p.q2,
                1 => -p.q2,
                _ => 0.0,
            },
            Process::Ma1(p) => match h {
                0 => (1.0 + p.theta * p.theta) * p.sigma2,
                1 => p.theta * p.sigma2,
                _ => 0.0,
            },
            Process::Ar1(p) => p.stationary_variance() * powi_u64(p.phi, h),
            Process::GaussMarkov(g) => {
                // σ_G² e^{−β h Δt}, computed directly (no rounding through φ^h).
                g.sigma2 * (-g.beta * h as f64 / rate_hz).exp()
            }
            Process::BiasInstability(b) => {
                // Σ σ_i² e^{−h/T_i} over the states.
                let (t, u) = b.band.states()?;
                let b2 = b.b * b.b;
                t.iter()
                    .zip(&u)
                    .map(|(&t, &u)| b2 * u * (-(h as f64) / t).exp())
                    .sum()
            }
            // (α²/2)·cos(βh), with βh reduced exactly enough for any h < 2^53
            Process::Sinusoid(p) => 0.5 * p.alpha2 * (p.beta * h as f64).cos(),
            Process::ArP(a) => {
                let h = usize::try_from(h).unwrap_or(usize::MAX);
                // ρ decays geometrically: beyond ~1e-300 the value is 0 in f64
                let rho = a.acf(h.min(1 << 24).saturating_add(1));
                a.stationary_variance() * if h < rho.len() { rho[h] } else { 0.0 }
            }
            Process::Arma(a) => {
                let h = usize::try_from(h).unwrap_or(usize::MAX);
                // γ decays geometrically (exactly 0 beyond q for MA2)
                let g = a.acvf(h.min(1 << 24).saturating_add(1));
                if h < g.len() { g[h] } else { 0.0 }
            }
            Process::Plp(p) => p.autocovariance(h),
            Process::Fgn(p) => p.autocovariance(h),
            Process::RandomWalk(_) | Process::Drift(_) => {
                return Err(ProcessError::NotDefined {
                    what: "autocovariance γ(h)",
                    process: self.kind().code(),
                    why: "the process is not stationary (book Remark 2.6)",
                });
            }
        })
    }

    /// Autocorrelation ρ(h) = γ(h)/γ(0) of a stationary process (see [`Self::autocovariance`]).
    ///
    /// ```
    /// use processes::{Process, QuantizationNoise};
    /// assert_eq!(Process::from(QuantizationNoise::new(3.0)?).autocorrelation(1, 1.0)?, -0.5);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn autocorrelation(&self, h: u64, rate_hz: f64) -> Result<f64> {
        Ok(self.autocovariance(h, rate_hz)? / self.autocovariance(0, rate_hz)?)
    }
}

/// x^n for a non-negative integer exponent of any size.
pub(crate) fn powi_u64(x: f64, n: u64) -> f64 {
    if n <= i32::MAX as u64 {
        x.powi(n as i32)
    } else {
        x.powf(n as f64)
    }
}

/// Plain serde form of [`Process`]; deserializing goes through the validating constructors.
#[derive(Serialize, Deserialize)]
#[serde(tag = "process")]
enum ProcessRepr {
    #[serde(rename = "WN")]
    WhiteNoise { sigma2: f64 },
    #[serde(rename = "QN")]
    QuantizationNoise { q2: f64 },
    #[serde(rename = "DR")]
    Drift { omega: f64 },
    #[serde(rename = "RW")]
    RandomWalk { gamma2: f64 },
    #[serde(rename = "AR1")]
    Ar1 { phi: f64, sigma2: f64 },
    #[serde(rename = "GM")]
    GaussMarkov { beta: f64, sigma2: f64 },
    #[serde(rename = "MA1")]
    Ma1 { theta: f64, sigma2: f64 },
    #[serde(rename = "SIN")]
    Sinusoid { alpha2: f64, beta: f64 },
    #[serde(rename = "ARP")]
    ArP { phi: Vec<f64>, sigma2: f64 },
    #[serde(rename = "ARMA")]
    Arma {
        phi: Vec<f64>,
        theta: Vec<f64>,
        sigma2: f64,
    },
    #[serde(rename = "PLP")]
    Plp { sigma2: f64, d: f64 },
    #[serde(rename = "FGN")]
    Fgn {
        sigma2: f64,
        #[serde(rename = "H")]
        h: f64,
    },
    #[serde(rename = "BI")]
    BiasInstability {
        #[serde(rename = "B")]
        b: f64,
        m_lo: u64,
        m_hi: u64,
    },
}

impl TryFrom<ProcessRepr> for Process {
    type Error = ProcessError;
    fn try_from(r: ProcessRepr) -> Result<Self> {
        Ok(match r {
            ProcessRepr::WhiteNoise { sigma2 } => WhiteNoise::new(sigma2)?.into(),
            ProcessRepr::QuantizationNoise { q2 } => QuantizationNoise::new(q2)?.into(),
            ProcessRepr::Drift { omega } => Drift::new(omega)?.into(),
            ProcessRepr::RandomWalk { gamma2 } => RandomWalk::new(gamma2)?.into(),
            ProcessRepr::Ar1 { phi, sigma2 } => Ar1::new(phi, sigma2)?.into(),
            ProcessRepr::GaussMarkov { beta, sigma2 } => GaussMarkov::new(beta, sigma2)?.into(),
            ProcessRepr::Ma1 { theta, sigma2 } => Ma1::new(theta, sigma2)?.into(),
            ProcessRepr::Sinusoid { alpha2, beta } => Sinusoid::new(alpha2, beta)?.into(),
            ProcessRepr::ArP { phi, sigma2 } => ArP::new(&phi, sigma2)?.into(),
            ProcessRepr::Arma { phi, theta, sigma2 } => Arma::new(&phi, &theta, sigma2)?.into(),
            ProcessRepr::Plp { sigma2, d } => Plp::new(sigma2, d)?.into(),
            ProcessRepr::Fgn { sigma2, h } => Fgn::new(sigma2, h)?.into(),
            ProcessRepr::BiasInstability { b, m_lo, m_hi } => {
                let band = if m_lo == 0 && m_hi == 0 {
                    BiBand::AUTO
                } else {
                    BiBand::new(m_lo, m_hi)?
                };
                BiasInstability::new(b, band)?.into()
            }
        })
    }
}

impl From<Process> for ProcessRepr {
    fn from(p: Process) -> Self {
        match p {
            Process::WhiteNoise(p) => ProcessRepr::WhiteNoise { sigma2: p.sigma2 },
            Process::QuantizationNoise(p) => ProcessRepr::QuantizationNoise { q2: p.q2 },
            Process::Drift(p) => ProcessRepr::Drift { omega: p.omega },
            Process::RandomWalk(p) => ProcessRepr::RandomWalk { gamma2: p.gamma2 },
            Process::Ar1(p) => ProcessRepr::Ar1 {
                phi: p.phi,
                sigma2: p.sigma2,
            },
            Process::GaussMarkov(p) => ProcessRepr::GaussMarkov {
                beta: p.beta,
                sigma2: p.sigma2,
            },
            Process::Ma1(p) => ProcessRepr::Ma1 {
                theta: p.theta,
                sigma2: p.sigma2,
            },
            Process::Sinusoid(p) => ProcessRepr::Sinusoid {
                alpha2: p.alpha2,
                beta: p.beta,
            },
            Process::ArP(a) => ProcessRepr::ArP {
                phi: a.phi().to_vec(),
                sigma2: a.sigma2,
            },
            Process::BiasInstability(p) => ProcessRepr::BiasInstability {
                b: p.b,
                m_lo: p.band.m_lo,
                m_hi: p.band.m_hi,
            },
            Process::Arma(a) => ProcessRepr::Arma {
                phi: a.phi().to_vec(),
                theta: a.theta().to_vec(),
                sigma2: a.sigma2,
            },
            Process::Plp(p) => ProcessRepr::Plp {
                sigma2: p.sigma2,
                d: p.d,
            },
            Process::Fgn(p) => ProcessRepr::Fgn {
                sigma2: p.sigma2,
                h: p.h,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_invalid_parameter_is_rejected_with_its_name() {
        let cases: Vec<(Result<Process>, &str)> = vec![
            (WhiteNoise::new(0.0).map(Into::into), "sigma2"),
            (WhiteNoise::new(f64::NAN).map(Into::into), "sigma2"),
            (QuantizationNoise::new(-1.0).map(Into::into), "q2"),
            (Drift::new(f64::INFINITY).map(Into::into), "omega"),
            (Drift::new(0.0).map(Into::into), "omega"),
            (RandomWalk::new(-1e-9).map(Into::into), "gamma2"),
            (Ar1::new(1.0, 1.0).map(Into::into), "phi"),
            (Ar1::new(-1.0, 1.0).map(Into::into), "phi"),
            (Ar1::new(f64::NAN, 1.0).map(Into::into), "phi"),
            (Ar1::new(0.5, 0.0).map(Into::into), "sigma2"),
            (GaussMarkov::new(0.0, 1.0).map(Into::into), "beta"),
            (
                GaussMarkov::new(1.0, f64::INFINITY).map(Into::into),
                "sigma2",
            ),
            (Ma1::new(f64::NEG_INFINITY, 1.0).map(Into::into), "theta"),
            (Ma1::new(0.3, -2.0).map(Into::into), "sigma2"),
        ];
        for (r, name) in cases {
            match r {
                Err(ProcessError::InvalidParameter { name: n, .. }) => assert_eq!(n, name),
                other => panic!("expected an invalid {name}, got {other:?}"),
            }
        }
    }

    #[test]
    fn gm_and_ar1_map_both_ways() {
        let gm = GaussMarkov::new(0.5, 2.0).unwrap();
        let ar = gm.to_ar1(10.0).unwrap();
        assert!((ar.phi() - (-0.05f64).exp()).abs() < 1e-15);
        assert!((ar.stationary_variance() - 2.0).abs() < 1e-13);
        let back = GaussMarkov::from_ar1(&ar, 10.0).unwrap();
        assert!((back.beta() - 0.5).abs() < 1e-13);
        assert!((back.sigma2() - 2.0).abs() < 1e-13);
        assert!(GaussMarkov::from_ar1(&Ar1::new(-0.5, 1.0).unwrap(), 10.0).is_err());
        assert!(gm.to_ar1(0.0).is_err());
        // GM and its AR1 have the same autocovariance.
        let (pg, pa) = (Process::from(gm), Process::from(ar));
        for h in [0, 1, 7, 100] {
            let (a, b) = (
                pg.autocovariance(h, 10.0).unwrap(),
                pa.autocovariance(h, 10.0).unwrap(),
            );
            assert!((a - b).abs() <= 1e-12 * a.abs(), "h={h}: {a} vs {b}");
        }
    }

    #[test]
    fn theory_of_each_process() {
        let qn = Process::from(QuantizationNoise::new(2.0).unwrap());
        assert_eq!(qn.autocovariance(0, 1.0).unwrap(), 4.0);
        assert_eq!(qn.autocorrelation(1, 1.0).unwrap(), -0.5);
        assert_eq!(qn.autocovariance(2, 1.0).unwrap(), 0.0);
        let ma = Process::from(Ma1::new(0.5, 2.0).unwrap());
        assert_eq!(ma.autocorrelation(1, 1.0).unwrap(), 0.5 / 1.25); // book Example 4.1
        let rw = Process::from(RandomWalk::new(3.0).unwrap());
        assert_eq!(rw.variance_at(10, 1.0).unwrap(), 30.0);
        assert!(rw.autocovariance(0, 1.0).is_err());
        let dr = Process::from(Drift::new(-0.5).unwrap());
        assert_eq!(dr.mean_at(4), -2.0);
        assert_eq!(dr.variance_at(4, 1.0).unwrap(), 0.0);
        assert!(!dr.is_stationary() && !rw.is_stationary() && qn.is_stationary());
    }

    #[test]
    fn serde_round_trip_validates() {
        let p = Process::from(Ar1::new(0.9, 1e-6).unwrap());
        let json = serde_json::to_string(&p).unwrap();
        assert_eq!(json, r#"{"process":"AR1","phi":0.9,"sigma2":1e-6}"#);
        assert_eq!(serde_json::from_str::<Process>(&json).unwrap(), p);
        let bad = serde_json::from_str::<Process>(r#"{"process":"AR1","phi":2.0,"sigma2":1.0}"#);
        assert!(bad.unwrap_err().to_string().contains("phi"));
    }
}
