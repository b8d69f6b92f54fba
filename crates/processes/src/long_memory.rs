//! Long-memory latent processes: the power-law process `PLP` (ARFIMA(0, d, 0)) and
//! fractional Gaussian noise `FGN`, with their exact autocovariances and exact simulation by
//! circulant embedding (Davies–Harte).
//!
//! # Parameterisation (the convention of the R package simts)
//! - `PLP(sigma2, d)`: (1 − B)^d X_t = ε_t, ε_t ~ N(0, σ²): **σ² is the innovation
//!   variance** (simts' `PLP(sigma2, d)` builds γ(0) = σ²Γ(1−2d)/Γ(1−d)² from it), and
//!   −1/2 < d < 1/2. d = 0 is allowed and is white noise of variance σ²; d < 0 is
//!   anti-persistent. γ(0) = σ²Γ(1−2d)/Γ(1−d)², ρ(h) = ρ(h−1)(h−1+d)/(h−d),
//!   equivalently ρ(h) = Γ(1−d)Γ(h+d)/(Γ(d)Γ(h+1−d)) ~ h^{2d−1}.
//! - `FGN(sigma2, H)`: the unit-lag increments of a fractional Brownian motion B_H with
//!   Var B_H(t) = σ² t^{2H}: **σ² is the variance of one FGN sample** (simts scales the
//!   unit-variance ACF of `longmemo::ckFGN0` by σ²), 0 < H < 1. H = 1/2 is white noise.
//!   γ(h) = (σ²/2)(|h+1|^{2H} − 2|h|^{2H} + |h−1|^{2H}).
//!
//! Both are Gaussian and stationary; their AVs (crate `spectral`) decay like m^{2d−1} and
//! m^{2H−2}: a PLP with d > 0 or an FGN with H > 1/2 is the flicker-like region of an AV
//! curve that falls more slowly than white noise.

use crate::error::{ProcessError, Result};

/// ln Γ(x) for x > 0 (Stirling's series at x + k ≥ 15, shifted down by the recurrence);
/// relative error ~1e-15 away from the zeros of ln Γ.
///
/// ```
/// use processes::long_memory::ln_gamma;
/// assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-14);
/// assert!((ln_gamma(0.5) - 0.5 * std::f64::consts::PI.ln()).abs() < 1e-14);
/// ```
pub fn ln_gamma(x: f64) -> f64 {
    let mut z = x;
    let mut prod = 1.0;
    while z < 15.0 {
        prod *= z;
        z += 1.0;
    }
    stirling(z) - prod.ln()
}

/// ln Γ(z) by Stirling's series (z ≥ 15): the main part and the correction series apart.
fn stirling(z: f64) -> f64 {
    (z - 0.5) * z.ln() - z + 0.5 * (2.0 * std::f64::consts::PI).ln() + stirling_series(z)
}

/// Σ B_{2k}/(2k(2k−1) z^{2k−1}), k = 1 … 7.
fn stirling_series(z: f64) -> f64 {
    const C: [f64; 7] = [
        1.0 / 12.0,
        -1.0 / 360.0,
        1.0 / 1260.0,
        -1.0 / 1680.0,
        1.0 / 1188.0,
        -691.0 / 360_360.0,
        1.0 / 156.0,
    ];
    let w = 1.0 / (z * z);
    let mut s = 0.0;
    for c in C.iter().rev() {
        s = s * w + c;
    }
    s / z
}

/// ln(Γ(x + a)/Γ(x + b)) for x + a > 0, x + b > 0, without the cancellation of two large
/// ln Γ values: exact recurrence factors ln(1 + (a−b)/(x+i+b)) up to x ≥ 15 − min(a, b),
/// then (z₁ − ½)·ln(1 + (a−b)/z₂) + (a − b)(ln z₂ − 1) + the difference of the Stirling
/// corrections (z₁ = x + a, z₂ = x + b). Relative error ~1e-15 for any size of x.
///
/// ```
/// use processes::long_memory::ln_gamma_ratio;
/// // Γ(n + 1)/Γ(n) = n
/// assert!((ln_gamma_ratio(1e6, 1.0, 0.0) - 1e6f64.ln()).abs() < 1e-14);
/// assert!((ln_gamma_ratio(3.0, 0.5, 0.5)).abs() == 0.0);
/// ```
pub fn ln_gamma_ratio(x: f64, a: f64, b: f64) -> f64 {
    let mut x = x;
    let mut acc = 0.0;
    while x + a.min(b) < 15.0 {
        acc -= ((a - b) / (x + b)).ln_1p();
        x += 1.0;
    }
    let (z1, z2) = (x + a, x + b);
    acc + (z1 - 0.5) * ((a - b) / z2).ln_1p() + (a - b) * (z2.ln() - 1.0) + stirling_series(z1)
        - stirling_series(z2)
}

/// Power-law process ARFIMA(0, d, 0): innovation variance `sigma2` (unit²) and memory
/// parameter `d` ∈ (−1/2, 1/2) (dimensionless). Model-string syntax `PLP(sigma2=…, d=…)`.
/// See the [module docs](self) for the convention.
///
/// ```
/// use processes::Plp;
/// let p = Plp::new(1.0, 0.25)?;
/// // γ(0) = Γ(1/2)/Γ(3/4)² and ρ(1) = d/(1 − d)
/// assert!((p.variance() - 1.180_340_599_016_096).abs() < 1e-12);
/// assert!((p.acf(2)[1] - 1.0 / 3.0).abs() < 1e-15);
/// assert!(Plp::new(1.0, 0.5).is_err() && Plp::new(0.0, 0.1).is_err());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plp {
    pub(crate) sigma2: f64,
    pub(crate) d: f64,
}

impl Plp {
    /// Builds a PLP from σ² > 0 (unit², innovation variance) and |d| < 1/2; d = 0 (white
    /// noise) is allowed. Errors name the parameter.
    ///
    /// ```
    /// use processes::Plp;
    /// assert!(Plp::new(2.0, -0.3).is_ok());
    /// assert!(Plp::new(2.0, 0.0).is_ok());
    /// assert!(Plp::new(2.0, -0.5).is_err());
    /// ```
    pub fn new(sigma2: f64, d: f64) -> Result<Self> {
        if !(sigma2.is_finite() && sigma2 > 0.0) {
            return Err(ProcessError::InvalidParameter {
                process: "PLP",
                name: "sigma2",
                value: sigma2,
                requirement: "must be finite and > 0",
            });
        }
        if !(d.is_finite() && d.abs() < 0.5) {
            return Err(ProcessError::InvalidParameter {
                process: "PLP",
                name: "d",
                value: d,
                requirement: "must lie in (-1/2, 1/2) (stationary and invertible)",
            });
        }
        Ok(Plp { sigma2, d })
    }

    /// Innovation variance σ² (unit²).
    ///
    /// ```
    /// assert_eq!(processes::Plp::new(3.0, 0.1)?.sigma2(), 3.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }

    /// Memory parameter d (dimensionless).
    ///
    /// ```
    /// assert_eq!(processes::Plp::new(3.0, 0.1)?.d(), 0.1);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn d(&self) -> f64 {
        self.d
    }

    /// Stationary variance γ(0) = σ²Γ(1−2d)/Γ(1−d)² (unit²).
    ///
    /// ```
    /// // d = 0: white noise
    /// assert_eq!(processes::Plp::new(3.0, 0.0)?.variance(), 3.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn variance(&self) -> f64 {
        let d = self.d;
        if d == 0.0 {
            // white noise, exactly (ln Γ(1) evaluates to a few ulp, not to 0)
            return self.sigma2;
        }
        self.sigma2 * (ln_gamma(1.0 - 2.0 * d) - 2.0 * ln_gamma(1.0 - d)).exp()
    }

    /// Γ(1−d)/Γ(1+d).
    fn g_ratio(&self) -> f64 {
        ln_gamma_ratio(1.0, -self.d, self.d).exp()
    }

    /// Autocorrelation at lag h, ρ(h) = d·Γ(1−d)/Γ(1+d)·Γ(h+d)/Γ(h+1−d) (closed form,
    /// accurate at any lag; 0 for h ≥ 1 when d = 0).
    ///
    /// ```
    /// let p = processes::Plp::new(1.0, 0.3)?;
    /// let r = p.acf(1001);
    /// assert!((p.autocorrelation(1000) - r[1000]).abs() < 1e-12 * r[1000]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn autocorrelation(&self, h: u64) -> f64 {
        if h == 0 {
            return 1.0;
        }
        let d = self.d;
        d * self.g_ratio() * ln_gamma_ratio(h as f64, d, 1.0 - d).exp()
    }

    /// ρ(0) … ρ(n−1) by the ratio recursion ρ(h) = ρ(h−1)(h−1+d)/(h−d) (relative
    /// rounding ≤ 2h·ε at lag h).
    ///
    /// ```
    /// let r = processes::Plp::new(1.0, -0.2)?.acf(3);
    /// assert!((r[1] + 0.2 / 1.2).abs() < 1e-16 && (r[2] - r[1] * 0.8 / 2.2).abs() < 1e-16);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn acf(&self, n: usize) -> Vec<f64> {
        let d = self.d;
        let mut r = Vec::with_capacity(n);
        let mut v = 1.0;
        for h in 0..n {
            if h > 0 {
                let hf = h as f64;
                v *= (hf - 1.0 + d) / (hf - d);
            }
            r.push(v);
        }
        r
    }

    /// Autocovariance γ(h) (unit²).
    ///
    /// ```
    /// let p = processes::Plp::new(2.0, 0.2)?;
    /// assert!((p.autocovariance(1) - p.variance() * 0.25).abs() < 1e-15);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn autocovariance(&self, h: u64) -> f64 {
        self.variance() * self.autocorrelation(h)
    }

    /// Exact stationary simulation of X_1 … X_n by circulant embedding (Davies–Harte),
    /// reproducible from `seed`; see [`circulant_embedding`].
    ///
    /// ```
    /// let p = processes::Plp::new(1.0, 0.4)?;
    /// let x = p.simulate(1000, 3)?;
    /// assert_eq!(x.len(), 1000);
    /// assert_eq!(x, p.simulate(1000, 3)?);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn simulate(&self, n: usize, seed: u64) -> Result<Vec<f64>> {
        let len = embedding_half(n)? + 1;
        let g0 = self.variance();
        let acv: Vec<f64> = self.acf(len).into_iter().map(|r| g0 * r).collect();
        circulant_embedding(&acv, n, seed, "PLP")
    }
}

/// Fractional Gaussian noise: variance `sigma2` of one sample (unit²) and Hurst exponent
/// `H` ∈ (0, 1). Model-string syntax `FGN(sigma2=…, H=…)`. See the [module docs](self).
///
/// ```
/// use processes::Fgn;
/// let f = Fgn::new(1.0, 0.8)?;
/// // γ(1) = σ²(2^{2H−1} − 1)
/// assert!((f.autocovariance(1) - (2f64.powf(0.6) - 1.0)).abs() < 1e-15);
/// assert!(Fgn::new(1.0, 1.0).is_err());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fgn {
    pub(crate) sigma2: f64,
    pub(crate) h: f64,
}

impl Fgn {
    /// Builds an FGN from σ² > 0 (unit², the variance of a sample) and 0 < H < 1; H = 1/2
    /// is white noise. Errors name the parameter.
    ///
    /// ```
    /// use processes::Fgn;
    /// assert!(Fgn::new(1.0, 0.5).is_ok());
    /// assert!(Fgn::new(1.0, 0.0).is_err() && Fgn::new(-1.0, 0.5).is_err());
    /// ```
    pub fn new(sigma2: f64, h: f64) -> Result<Self> {
        if !(sigma2.is_finite() && sigma2 > 0.0) {
            return Err(ProcessError::InvalidParameter {
                process: "FGN",
                name: "sigma2",
                value: sigma2,
                requirement: "must be finite and > 0",
            });
        }
        if !(h.is_finite() && h > 0.0 && h < 1.0) {
            return Err(ProcessError::InvalidParameter {
                process: "FGN",
                name: "H",
                value: h,
                requirement: "must lie in (0, 1)",
            });
        }
        Ok(Fgn { sigma2, h })
    }

    /// Variance of one sample σ² (unit²).
    ///
    /// ```
    /// assert_eq!(processes::Fgn::new(3.0, 0.7)?.sigma2(), 3.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }

    /// Hurst exponent H (dimensionless).
    ///
    /// ```
    /// assert_eq!(processes::Fgn::new(3.0, 0.7)?.hurst(), 0.7);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn hurst(&self) -> f64 {
        self.h
    }

    /// Autocovariance γ(h) = (σ²/2)(|h+1|^{2H} − 2|h|^{2H} + |h−1|^{2H}) (unit²). For
    /// h ≥ 2 it is evaluated as σ² h^{2H} Σ_{k≥1} C(2H, 2k) h^{−2k} (the binomial series of
    /// the second difference), which avoids the cancellation of the three powers at
    /// large lags.
    ///
    /// ```
    /// let f = processes::Fgn::new(1.0, 0.7)?;
    /// let direct = |h: f64| 0.5 * ((h + 1.0).powf(1.4) - 2.0 * h.powf(1.4) + (h - 1.0).powf(1.4));
    /// assert!((f.autocovariance(5) - direct(5.0)).abs() < 1e-14);
    /// assert_eq!(processes::Fgn::new(2.0, 0.5)?.autocovariance(7), 0.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn autocovariance(&self, h: u64) -> f64 {
        let a = 2.0 * self.h;
        match h {
            0 => self.sigma2,
            1 => self.sigma2 * (2f64.powf(a - 1.0) - 1.0),
            _ => {
                let hf = h as f64;
                let x2 = 1.0 / (hf * hf);
                // C(a, j) by C(a, j) = C(a, j−1)(a − j + 1)/j
                let mut c = 1.0;
                let mut p = 1.0;
                let mut s = 0.0;
                for k in 1..200 {
                    let j = 2 * k;
                    c *= (a - (j - 2) as f64) / (j - 1) as f64;
                    c *= (a - (j - 1) as f64) / j as f64;
                    p *= x2;
                    let t = c * p;
                    s += t;
                    if t.abs() <= 1e-18 * s.abs() || t == 0.0 {
                        break;
                    }
                }
                self.sigma2 * hf.powf(a) * s
            }
        }
    }

    /// Exact stationary simulation of X_1 … X_n by circulant embedding (Davies–Harte),
    /// reproducible from `seed`; see [`circulant_embedding`].
    ///
    /// ```
    /// let f = processes::Fgn::new(1.0, 0.9)?;
    /// let x = f.simulate(500, 1)?;
    /// assert_eq!(x, f.simulate(500, 1)?);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn simulate(&self, n: usize, seed: u64) -> Result<Vec<f64>> {
        let len = embedding_half(n)? + 1;
        let acv: Vec<f64> = (0..len as u64).map(|h| self.autocovariance(h)).collect();
        circulant_embedding(&acv, n, seed, "FGN")
    }
}

/// Half size N of the circulant embedding of n samples: the power of two ≥ max(n − 1, 1).
fn embedding_half(n: usize) -> Result<usize> {
    if n == 0 {
        return Err(ProcessError::InvalidArgument(
            "cannot simulate 0 samples (n must be at least 1)".into(),
        ));
    }
    (n - 1)
        .max(1)
        .checked_next_power_of_two()
        .filter(|h| h.checked_mul(2).is_some())
        .ok_or_else(|| ProcessError::InvalidArgument(format!("{n} samples: too many")))
}

/// Exact simulation of n samples of a stationary Gaussian process from its autocovariance
/// γ(0) … γ(N) (`acv`, unit², N ≥ n − 1) by circulant embedding (Davies & Harte 1987;
/// Wood & Chan 1994): the circulant vector c = (γ(0), …, γ(N), γ(N−1), …, γ(1)) of size
/// M = 2N has eigenvalues λ_j = Σ_k c_k e^{−2πijk/M} (one FFT). When every λ_j ≥ 0, with
/// Z_j = A_j + iB_j (A, B iid N(0, 1), drawn in order j = 0 … M−1 from a
/// Xoshiro256++ seeded with `seed`), Y_k = Σ_j √(λ_j/M) Z_j e^{2πijk/M} has
/// E[Y_k Ȳ_l] = 2c_{k−l} and E[Y_k Y_l] = 0, so Re Y_0 … Re Y_{n−1} has exactly the
/// Toeplitz covariance of γ. Negative eigenvalues above rounding (|λ_j| > 1e-10·max λ)
/// mean that the embedding is not nonnegative definite and give an error; rounding-level
/// negatives are set to 0. O(M log M) (two FFTs).
///
/// ```
/// use processes::long_memory::circulant_embedding;
/// // white noise: the eigenvalues are all γ(0)
/// let x = circulant_embedding(&[1.0, 0.0, 0.0, 0.0, 0.0], 4, 7, "WN")?;
/// assert_eq!(x.len(), 4);
/// // not a covariance: λ = (1 + 2·0.9 + …) and 1 − 2·0.9 < 0
/// assert!(circulant_embedding(&[1.0, 0.9, 0.0], 2, 7, "X").is_err());
/// # Ok::<(), processes::ProcessError>(())
/// ```
pub fn circulant_embedding(acv: &[f64], n: usize, seed: u64, what: &str) -> Result<Vec<f64>> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rustfft::{FftPlanner, num_complex::Complex};
    let half = acv.len().saturating_sub(1);
    if n == 0 || half == 0 || half + 1 < n {
        return Err(ProcessError::InvalidArgument(format!(
            "circulant embedding of {n} samples needs the autocovariance at lags 0..{} (got {} lags, n ≥ 1)",
            n.max(2) - 1,
            acv.len()
        )));
    }
    if let Some(bad) = acv.iter().find(|x| !x.is_finite()) {
        return Err(ProcessError::InvalidArgument(format!(
            "{what}: non-finite autocovariance {bad}"
        )));
    }
    let m = 2 * half;
    let mut c: Vec<Complex<f64>> = (0..m)
        .map(|k| Complex::new(acv[if k <= half { k } else { m - k }], 0.0))
        .collect();
    let mut planner = FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(m);
    fft.process(&mut c);
    let lmax = c.iter().map(|z| z.re).fold(0.0f64, f64::max);
    let lmin = c.iter().map(|z| z.re).fold(f64::INFINITY, f64::min);
    if lmax.is_nan() || lmax <= 0.0 || lmin < -1e-10 * lmax {
        return Err(ProcessError::InvalidArgument(format!(
            "{what}: the circulant embedding of size {m} is not nonnegative definite (smallest eigenvalue {lmin:e}, largest {lmax:e}); exact simulation by Davies-Harte is not possible"
        )));
    }
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    let scale = 1.0 / m as f64;
    for z in c.iter_mut() {
        let a = (z.re.max(0.0) * scale).sqrt();
        let (u, v): (f64, f64) = (
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
        );
        *z = Complex::new(a * u, a * v);
    }
    fft.process(&mut c);
    Ok(c[..n].iter().map(|z| z.re).collect())
}
