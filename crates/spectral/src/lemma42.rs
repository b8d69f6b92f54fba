//! The book's Lemma 4.2: the Allan variance from the autocorrelation function, O(m) per m.
//!
//! For a stationary process with variance σ² and ACF ρ(h):
//!
//! AV(m) = σ²/m² · ( m[1 − ρ(m)] + Σ_{i=1}^{m−1} i [2ρ(m−i) − ρ(i) − ρ(2m−i)] ).
//!
//! Since Σ i (2 − 1 − 1) = 0, the same sum can be written with the semivariogram
//! V(h) = ½ E[(X_{t+h} − X_t)²] (= γ(0) − γ(h) for a stationary process):
//!
//! AV(m) = 1/m² · ( m V(m) + Σ_{i=1}^{m−1} i [V(i) + V(2m−i) − 2V(m−i)] ).
//!
//! This form is (i) well conditioned when ρ(h) is close to 1 (AR1 with φ → 1, where
//! the ACF form cancels catastrophically), and (ii) valid for processes with stationary
//! increments that are not stationary (book Remark 4.5): it gives exactly γ²(2m²+1)/(6m)
//! for the random walk (V(h) = γ²h/2) and ω²m²/2 for the drift (V(h) = ω²h²/2), because
//! (Σ c_i X_i)² = −½ Σ_{i,j} c_i c_j (X_i − X_j)² whenever Σ c_i = 0.
//!
//! All sums use Neumaier's compensated summation.

use crate::dd::Dd;
use crate::error::{Result, SpectralError, check_m, check_rate};
use processes::Process;

/// Neumaier's compensated sum accumulator.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct KahanSum {
    s: f64,
    c: f64,
}

impl KahanSum {
    pub(crate) fn add(&mut self, x: f64) {
        let t = self.s + x;
        if self.s.abs() >= x.abs() {
            self.c += (self.s - t) + x;
        } else {
            self.c += (x - t) + self.s;
        }
        self.s = t;
    }
    /// Adds x·y exactly (the rounding error of the product is captured by an FMA).
    pub(crate) fn add_product(&mut self, x: f64, y: f64) {
        let p = x * y;
        self.add(p);
        self.add(x.mul_add(y, -p));
    }
    pub(crate) fn value(&self) -> f64 {
        self.s + self.c
    }
}

/// Lemma 4.2 in the book's form: AV(m) from the variance `variance` (σ², unit²) and the
/// autocorrelation `acf(h)` (dimensionless, h in samples, called for h = 1 … 2m−1 and m).
/// O(m). Use [`allan_variance_from_variogram`] when ρ(h) is close to 1.
///
/// ```
/// use spectral::allan_variance_from_acf;
/// // White noise: ρ(h) = 0 for h ≥ 1 → σ²/m.
/// let av = allan_variance_from_acf(2.0, |h| if h == 0 { 1.0 } else { 0.0 }, 4)?;
/// assert_eq!(av, 0.5);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn allan_variance_from_acf(variance: f64, acf: impl Fn(u64) -> f64, m: u64) -> Result<f64> {
    check_m(m)?;
    if !variance.is_finite() {
        return Err(SpectralError::InvalidArgument(format!(
            "variance must be finite, got {variance}"
        )));
    }
    let mut s = KahanSum::default();
    s.add(m as f64 * (1.0 - acf(m)));
    for i in 1..m {
        let t = 2.0 * acf(m - i) - acf(i) - acf(2 * m - i);
        s.add(i as f64 * t);
    }
    let mf = m as f64;
    Ok(variance * s.value() / (mf * mf))
}

/// Lemma 4.2 in semivariogram form: AV(m) from V(h) = ½E[(X_{t+h} − X_t)²] (unit²,
/// h in samples, called for h = 1 … 2m−1). Valid for stationary processes (V = γ(0) − γ(h))
/// and for processes with stationary increments such as RW and DR (book Remark 4.5). O(m).
///
/// ```
/// use spectral::allan_variance_from_variogram;
/// // Random walk with γ² = 6: V(h) = 3h, AV(m) = (2m²+1)/m.
/// let av = allan_variance_from_variogram(|h| 3.0 * h as f64, 5)?;
/// assert!((av - 51.0 / 5.0).abs() < 1e-13);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn allan_variance_from_variogram(variogram: impl Fn(u64) -> f64, m: u64) -> Result<f64> {
    check_m(m)?;
    let mut s = KahanSum::default();
    s.add_product(m as f64, variogram(m));
    for i in 1..m {
        let (a, b, c) = (variogram(i), variogram(2 * m - i), variogram(m - i));
        // a + b − 2c summed compensated as well: the parts may be large and close.
        let mut t = KahanSum::default();
        t.add(a);
        t.add(b);
        t.add(-2.0 * c);
        s.add_product(i as f64, t.value());
    }
    let mf = m as f64;
    Ok(s.value() / (mf * mf))
}

/// Lemma 4.2 on a sampled autocovariance γ(0), γ(1), … (e.g. the empirical ACV of
/// [`crate::empirical::autocovariance`]); needs `acv.len() ≥ 2m`. Unit² in, unit² out.
///
/// ```
/// use spectral::allan_variance_from_acv;
/// // MA1 with θ = 1, σ² = 1: γ = (2, 1, 0, 0, …): AV(2) = (2·4 − 3)/4.
/// let acv = [2.0, 1.0, 0.0, 0.0];
/// assert_eq!(allan_variance_from_acv(&acv, 2)?, 1.25);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn allan_variance_from_acv(acv: &[f64], m: u64) -> Result<f64> {
    check_m(m)?;
    if (acv.len() as u64) < 2 * m {
        return Err(SpectralError::TooShort(format!(
            "Lemma 4.2 at m = {m} needs the autocovariance at lags 0..{}, got {} lags",
            2 * m - 1,
            acv.len()
        )));
    }
    if let Some((index, &value)) = acv.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(SpectralError::NonFinite { index, value });
    }
    let g0 = acv[0];
    allan_variance_from_variogram(|h| g0 - acv[h as usize], m)
}

/// The semivariogram V(h) = ½E[(X_{t+h} − X_t)²] of a process at lag `h` (samples), in
/// unit², evaluated without cancellation (e.g. AR1: γ(0)(1 − φ^h) with `expm1`).
/// Defined for every process, including RW (γ²h/2) and DR (ω²h²/2). `rate_hz` for GM.
///
/// ```
/// use processes::{Process, QuantizationNoise};
/// use spectral::variogram;
/// let qn = Process::from(QuantizationNoise::new(1.0)?);
/// assert_eq!(variogram(&qn, 1, 1.0)?, 3.0); // γ(0) − γ(1) = 2Q² + Q²
/// assert_eq!(variogram(&qn, 5, 1.0)?, 2.0);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn variogram(process: &Process, h: u64, rate_hz: f64) -> Result<f64> {
    let rate = check_rate(rate_hz)?;
    crate::error::check_process(process)?;
    let (scale, unit) = variogram_parts(process, h, rate);
    Ok(scale * unit)
}

/// V(h) split as scale × unit value, the scale being the process's variance parameter
/// (σ², Q², γ², ω², γ(0), σ_G²): the unit values of WN, QN, RW, DR and MA1(θ = −1) are
/// exact small integers, so the Lemma 4.2 sum on them is exact.
fn variogram_parts(process: &Process, h: u64, rate: f64) -> (f64, f64) {
    let hf = h as f64;
    if h == 0 {
        return (0.0, 0.0);
    }
    match *process {
        Process::WhiteNoise(p) => (p.sigma2(), 1.0),
        Process::QuantizationNoise(p) => (p.q2(), if h == 1 { 3.0 } else { 2.0 }),
        Process::Ma1(p) => {
            let t = p.theta();
            let g0 = 1.0 + t * t;
            (p.sigma2(), if h == 1 { g0 - t } else { g0 })
        }
        Process::RandomWalk(p) => (p.gamma2(), 0.5 * hf),
        Process::Drift(p) => (p.omega() * p.omega(), 0.5 * hf * hf),
        Process::Ar1(p) => {
            let phi = p.phi();
            let one_minus_pow = if phi == 0.0 {
                1.0
            } else if phi > 0.0 {
                let ln = if phi >= 0.5 {
                    (phi - 1.0).ln_1p()
                } else {
                    phi.ln()
                };
                -(hf * ln).exp_m1()
            } else {
                let ln_abs = if phi <= -0.5 {
                    (-(1.0 + phi)).ln_1p()
                } else {
                    (-phi).ln()
                };
                if h.is_multiple_of(2) {
                    -(hf * ln_abs).exp_m1()
                } else {
                    1.0 + (hf * ln_abs).exp()
                }
            };
            (p.stationary_variance(), one_minus_pow)
        }
        Process::GaussMarkov(g) => (g.sigma2(), -(-g.beta() * hf / rate).exp_m1()),
        Process::BiasInstability(b) => match b.band().states() {
            // Σ u_i (1 − e^{−h/T_i}) per unit B²
            Ok((t, u)) => (
                b.b() * b.b(),
                t.iter()
                    .zip(&u)
                    .map(|(&t, &u)| u * -(-hf / t).exp_m1())
                    .sum(),
            ),
            Err(_) => (f64::NAN, f64::NAN),
        },
        // γ(0) − γ(h) = (α²/2)(1 − cos βh) = α² sin²(βh/2), no cancellation
        Process::Sinusoid(p) => (p.alpha2(), (0.5 * p.beta() * hf).sin().powi(2)),
        Process::ArP(a) => {
            let rho = a.acf(h as usize + 1);
            (a.stationary_variance(), 1.0 - rho[h as usize])
        }
        Process::Arma(a) => {
            let g = a.acvf(h as usize + 1);
            (g[0], 1.0 - g[h as usize] / g[0])
        }
        Process::Plp(p) => (p.variance(), 1.0 - p.autocorrelation(h)),
        Process::Fgn(f) => (f.sigma2(), 1.0 - f.autocovariance(h) / f.sigma2()),
    }
}

/// The theoretical AV of a process by Lemma 4.2 in semivariogram form, with the exact
/// [`variogram`] of the process: the book's second, independent route to the closed forms
/// of [`crate::allan_variance`]. O(m). `rate_hz` for GM.
///
/// ```
/// use processes::{Ma1, Process};
/// use spectral::{allan_variance, lemma42_allan_variance};
/// let ma = Process::from(Ma1::new(-0.4, 2.0)?);
/// let (a, b) = (lemma42_allan_variance(&ma, 7, 1.0)?, allan_variance(&ma, 7, 1.0)?);
/// assert!((a - b).abs() <= 1e-15 * b);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn lemma42_allan_variance(process: &Process, m: u64, rate_hz: f64) -> Result<f64> {
    let rate = check_rate(rate_hz)?;
    check_m(m)?;
    crate::error::check_process(process)?;
    if let Process::Ar1(p) = process
        && p.phi() < 0.0
    {
        return Ok(ar1_negative_phi_dd(p.phi(), p.sigma2(), m));
    }
    if let Process::ArP(a) = process {
        // the exact ACF once up to 2m (O(m)), then the semivariogram form
        let rho = a.acf(2 * m as usize + 1);
        let unit = allan_variance_from_variogram(|h| 1.0 - rho[h as usize], m)?;
        return Ok(a.stationary_variance() * unit);
    }
    if let Process::Arma(a) = process {
        // the exact autocovariance once up to 2m (O(m)), then the semivariogram form
        let g = a.acvf(2 * m as usize + 1);
        let unit = allan_variance_from_variogram(|h| 1.0 - g[h as usize] / g[0], m)?;
        return Ok(g[0] * unit);
    }
    if let Process::Plp(p) = process {
        // the exact ACF once up to 2m (its ratio recursion), then the ACF form
        let rho = p.acf(2 * m as usize + 1);
        return allan_variance_from_acf(p.variance(), |h| rho[h as usize], m);
    }
    if let Process::Fgn(f) = process {
        // the ACF form: its second differences of ρ carry no rounding of 1 − ρ(h), which
        // the semivariogram form would amplify ~m^{3/2−2H} times for small H
        return allan_variance_from_acf(f.sigma2(), |h| f.autocovariance(h) / f.sigma2(), m);
    }
    let scale = variogram_parts(process, 1, rate).0;
    let unit = allan_variance_from_variogram(|h| variogram_parts(process, h, rate).1, m)?;
    Ok(scale * unit)
}

/// Lemma 4.2 (ACF form) for an AR1 with φ < 0 in double-double arithmetic. With φ near −1
/// the ACF alternates in sign and the sum's terms exceed its value by a factor up to
/// ~m²/(1+φ) for even m; ~32 digits keep the result at f64 precision. φ is a double, so
/// φ^h is formed exactly up to dd rounding. O(m) time, O(1) memory.
fn ar1_negative_phi_dd(phi: f64, v2: f64, m: u64) -> f64 {
    // B = m(1 − ρ_m) + Σ_{i<m} i[2ρ_{m−i} − ρ_i − ρ_{2m−i}], regrouped by lag k so that one
    // ascending pass with a running power φ^k suffices (O(1) memory):
    // B = m(1 − ρ_m) + Σ_{k=1}^{m−1} (2m − 3k) ρ_k − Σ_{k=m+1}^{2m−1} (2m − k) ρ_k.
    let f = Dd::from(phi);
    let mut p = Dd::from(1.0);
    let mut b = Dd::from(m as f64);
    for k in 1..2 * m {
        p = p * f;
        let w = if k < m {
            2.0 * m as f64 - 3.0 * k as f64
        } else if k == m {
            -(m as f64)
        } else {
            -(2.0 * m as f64 - k as f64)
        };
        b = b + Dd::from(w) * p;
    }
    // σ_X² = v² / ((1 − φ)(1 + φ)), with 1 ± φ formed exactly in dd.
    let den = (Dd::from(1.0) - Dd::from(phi)) * (Dd::from(1.0) + Dd::from(phi));
    let mf = Dd::from(m as f64);
    (Dd::from(v2) * b).div(den * mf * mf).to_f64()
}
