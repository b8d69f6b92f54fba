//! The spectral ambiguity of the Allan variance (book §4.1) made concrete.
//!
//! If Φ(f) = 2Φ(2f) then ∫_0^∞ sin⁴(πfτ)/(πfτ)² Φ(f) df = 0 for every τ (the book's proof
//! uses sin⁴x = sin²x − ¼ sin²2x and u = 2f), so S_X = S_Y + Φ and S_Y have the same AV
//! at every averaging time while the PSDs differ. The family used here
//! (`REFERENCES.md` §2) is
//!
//! Φ(f) = a · sin(2π log₂ f) / f   (f in Hz, a in unit²),
//!
//! for which Φ(2f) = a sin(2π log₂ f + 2π)/(2f) = Φ(f)/2. With S_Y(f) = c/f (flicker
//! noise, "bias instability") S_X = (c + a sin(2π log₂ f))/f is a valid PSD iff |a| ≤ c,
//! and both have AV = 4c ln 2 at every τ.
//!
//! This is a **continuous-time** statement (the book's Remark 4.3: τ ∈ ℝ): both AVs are
//! computed by the continuous Lemma 4.1 quadrature ([`crate::lemma41_allan_variance`]) at
//! τ = m / rate.

use crate::error::{Result, SpectralError};
use crate::quadrature::lemma41_allan_variance;

/// Φ(f) = a · sin(2π log₂ f)/f (unit²/Hz for f in Hz), the log-periodic perturbation with
/// Φ(f) = 2Φ(2f); 0 at f = 0 by convention (it has no limit there; the set is null).
///
/// ```
/// use spectral::ambiguity::log_periodic_perturbation;
/// let phi = log_periodic_perturbation(0.3);
/// for f in [0.01, 0.7, 3.0, 1e3] {
///     assert!((phi(f) - 2.0 * phi(2.0 * f)).abs() < 1e-12 * phi(f).abs().max(1e-300));
/// }
/// ```
pub fn log_periodic_perturbation(a: f64) -> impl Fn(f64) -> f64 + Copy {
    move |f: f64| {
        if f > 0.0 {
            a * (2.0 * std::f64::consts::PI * f.log2()).sin() / f
        } else {
            0.0
        }
    }
}

/// S_X = S_Y + Φ with Φ = [`log_periodic_perturbation`]`(a)`: a second PSD with the same
/// Allan variance as `s_y` at every τ. It is a valid (non-negative) PSD iff
/// S_Y(f) ≥ |a|/f for all f > 0 — the caller's responsibility for a general S_Y; see
/// [`FlickerAmbiguity`] for the checked flicker case.
///
/// ```
/// use spectral::{ambiguity::ambiguous_psd, lemma41_allan_variance};
/// let s_y = |f: f64| 2.0 / f + 1.0; // flicker + white
/// let s_x = ambiguous_psd(s_y, 1.5)?;
/// let (ay, ax) = (lemma41_allan_variance(s_y, 0.3)?, lemma41_allan_variance(&s_x, 0.3)?);
/// assert!((ax - ay).abs() < 1e-9 * ay);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn ambiguous_psd(s_y: impl Fn(f64) -> f64, a: f64) -> Result<impl Fn(f64) -> f64> {
    if !a.is_finite() || a == 0.0 {
        return Err(SpectralError::InvalidArgument(format!(
            "the perturbation amplitude a must be finite and non-zero, got {a}"
        )));
    }
    let phi = log_periodic_perturbation(a);
    Ok(move |f: f64| s_y(f) + phi(f))
}

/// The flicker-noise instance of the ambiguity: S_Y(f) = c/f and
/// S_X(f) = (c + a sin(2π log₂ f))/f with 0 < |a| ≤ c (two-sided, unit²/Hz, f in Hz).
///
/// ```
/// use spectral::ambiguity::FlickerAmbiguity;
/// let amb = FlickerAmbiguity::new(1e-6, 5e-7)?;
/// let f = 2f64.powf(0.25); // where sin(2π log₂ f) = 1
/// assert!((amb.psd_x(f) / amb.psd_y(f) - 1.5).abs() < 1e-12);
/// let tau = 0.37;
/// let (ay, ax) = (amb.allan_variance_y(tau)?, amb.allan_variance_x(tau)?);
/// assert!((ay - ax).abs() < 1e-8 * ay);
/// assert!((ay - amb.closed_form_allan_variance()).abs() < 1e-8 * ay);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlickerAmbiguity {
    c: f64,
    a: f64,
}

impl FlickerAmbiguity {
    /// Builds the pair; `c` > 0 (unit²) and 0 < |`a`| ≤ c so that S_X ≥ 0.
    ///
    /// ```
    /// use spectral::ambiguity::FlickerAmbiguity;
    /// assert!(FlickerAmbiguity::new(1.0, -1.0).is_ok()); // |a| = c: S_X touches 0
    /// assert!(FlickerAmbiguity::new(1.0, 1.5).is_err()); // S_X < 0 where sin(2π log₂ f) = −1
    /// assert!(FlickerAmbiguity::new(1.0, 0.0).is_err()); // no perturbation
    /// assert!(FlickerAmbiguity::new(0.0, 0.5).is_err());
    /// ```
    pub fn new(c: f64, a: f64) -> Result<Self> {
        if !(c.is_finite() && c > 0.0) {
            return Err(SpectralError::InvalidArgument(format!(
                "flicker level c must be finite and > 0, got {c}"
            )));
        }
        if !(a.is_finite() && a != 0.0 && a.abs() <= c) {
            return Err(SpectralError::InvalidArgument(format!(
                "perturbation amplitude a must satisfy 0 < |a| <= c = {c} (S_X >= 0), got {a}"
            )));
        }
        Ok(Self { c, a })
    }
    /// The flicker level c.
    ///
    /// ```
    /// use spectral::ambiguity::FlickerAmbiguity;
    /// let amb = FlickerAmbiguity::new(2e-6, -1e-6)?;
    /// assert_eq!(amb.c(), 2e-6);
    /// assert_eq!(amb.psd_y(1.0), amb.c()); // S_Y(1 Hz) = c
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn c(&self) -> f64 {
        self.c
    }
    /// The perturbation amplitude a.
    ///
    /// ```
    /// use spectral::ambiguity::FlickerAmbiguity;
    /// let amb = FlickerAmbiguity::new(2e-6, -1e-6)?;
    /// assert_eq!(amb.a(), -1e-6);
    /// // at f = 2^(1/4) Hz, sin(2π log₂ f) = 1: S_X − S_Y = a/f
    /// let f = 2f64.powf(0.25);
    /// assert!((amb.psd_x(f) - amb.psd_y(f) - amb.a() / f).abs() < 1e-14 * amb.c()); // rounding
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn a(&self) -> f64 {
        self.a
    }
    /// S_Y(f) = c/f (f in Hz, unit²/Hz).
    ///
    /// ```
    /// use spectral::ambiguity::FlickerAmbiguity;
    /// let amb = FlickerAmbiguity::new(3.0, 1.0)?;
    /// assert_eq!(amb.psd_y(0.25), 12.0); // 3 / 0.25
    /// assert_eq!(amb.psd_y(1e3), 3e-3);
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn psd_y(&self, f_hz: f64) -> f64 {
        self.c / f_hz
    }
    /// S_X(f) = (c + a sin(2π log₂ f))/f (f in Hz, unit²/Hz).
    ///
    /// ```
    /// use spectral::ambiguity::FlickerAmbiguity;
    /// let amb = FlickerAmbiguity::new(1.0, 1.0)?;
    /// // log₂ 1 = 0: sin = 0 exactly, S_X = S_Y
    /// assert_eq!(amb.psd_x(1.0), amb.psd_y(1.0));
    /// // log₂ f = 3/4: sin = −1, and with a = c the PSD touches 0 (to rounding)
    /// assert!(amb.psd_x(2f64.powf(0.75)).abs() < 1e-15);
    /// // both parts fall as 1/f: S_X(f) = 2 S_X(2f)
    /// let f = 0.3;
    /// assert!((amb.psd_x(f) - 2.0 * amb.psd_x(2.0 * f)).abs() < 1e-14 * amb.psd_x(f));
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn psd_x(&self, f_hz: f64) -> f64 {
        self.psd_y(f_hz) + log_periodic_perturbation(self.a)(f_hz)
    }
    /// AV of S_Y at τ (s) by the Lemma 4.1 quadrature, in unit².
    ///
    /// ```
    /// use spectral::{ambiguity::FlickerAmbiguity, tolerances::QUADRATURE_REL};
    /// let amb = FlickerAmbiguity::new(1e-6, 5e-7)?;
    /// // flicker noise: the same AV, 4c ln 2, at every τ
    /// for tau in [0.01, 100.0] {
    ///     let av = amb.allan_variance_y(tau)?;
    ///     assert!((av - amb.closed_form_allan_variance()).abs() < QUADRATURE_REL * av);
    /// }
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn allan_variance_y(&self, tau_s: f64) -> Result<f64> {
        lemma41_allan_variance(|f| self.psd_y(f), tau_s)
    }
    /// AV of S_X at τ (s) by the Lemma 4.1 quadrature, in unit².
    ///
    /// ```
    /// use spectral::{ambiguity::FlickerAmbiguity, tolerances::AMBIGUITY_AV_REL};
    /// // a negative perturbation: S_X dips to c/(2f) where sin(2π log₂ f) = 1
    /// let amb = FlickerAmbiguity::new(1e-6, -5e-7)?;
    /// let tau = 5.0;
    /// let (ax, ay) = (amb.allan_variance_x(tau)?, amb.allan_variance_y(tau)?);
    /// assert!((ax - ay).abs() < AMBIGUITY_AV_REL * ay);
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn allan_variance_x(&self, tau_s: f64) -> Result<f64> {
        lemma41_allan_variance(|f| self.psd_x(f), tau_s)
    }
    /// The common closed form 4c ln 2 (∫_0^∞ sin⁴u/u³ du = ln 2), independent of τ, in unit².
    ///
    /// ```
    /// use spectral::ambiguity::FlickerAmbiguity;
    /// let (p, q) = (FlickerAmbiguity::new(1e-6, 5e-7)?, FlickerAmbiguity::new(1e-6, -2e-7)?);
    /// // it depends on c only, not on the perturbation a
    /// assert_eq!(p.closed_form_allan_variance(), q.closed_form_allan_variance());
    /// assert_eq!(p.closed_form_allan_variance(), 4.0 * 1e-6 * std::f64::consts::LN_2);
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn closed_form_allan_variance(&self) -> f64 {
        4.0 * self.c * std::f64::consts::LN_2
    }
}
