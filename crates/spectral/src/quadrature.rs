//! The book's Lemma 4.1 by numerical quadrature: AV(τ) = 4∫_0^∞ sin⁴(πfτ)/(πfτ)² S(f) df,
//! with S the two-sided PSD in unit²/Hz (see [`mod@crate::psd`]).
//!
//! # Continuous time ([`lemma41_allan_variance`])
//! With u = πfτ the integral is (4/(πτ)) ∫_0^∞ h(u) sin⁴u du, h(u) = S(u/(πτ))/u². It is
//! split at the zeros u = kπ of sin u: the first K = 32 half-periods are integrated by
//! 20-point Gauss-Legendre panels (the first panel graded geometrically toward u = 0 over 60
//! levels, which resolves 1/f and 1/f² behaviour and log-periodic PSDs there). On the tail
//! [U, ∞), U = Kπ, sin⁴u = 3/8 − cos(2u)/2 + cos(4u)/8: the mean part (3/8)∫h is integrated
//! on geometric panels [U2^k, U2^(k+1)] until they stop contributing, and the oscillating
//! part by its asymptotic expansion (repeated integration by parts, exact at u = Kπ where
//! the odd antiderivatives vanish): (15/128) h'(U) − (63/2048) h'''(U) + O(h⁽⁵⁾), the
//! derivatives by 6th/4th-order central differences. For h(u) ~ u^(−2…−4) the neglected
//! term is below 1e-12 relative.
//!
//! # Discrete time ([`discrete_lemma41_allan_variance`], [`quadrature_allan_variance`])
//! A process sampled at rate r has a PSD that is periodic in f (period r). For the averages
//! of m samples the AV is exactly
//!
//! AV(m) = 4∫_0^{r/2} S(f) sin⁴(πfτ) / (m sin(πfΔt))² df,  τ = mΔt,
//!
//! and since Σ_k 1/(x + kπ)² = 1/sin²x and sin⁴ is π-periodic in πfτ, this *is* Lemma 4.1
//! with the periodic S over all f ≥ 0 (the aliased copies of the band are summed into the
//! discrete kernel). With x = πfΔt ∈ [0, π/2] it reads (4r/(πm²))∫ S sin⁴(mx)/sin²x dx,
//! integrated the same way from both ends (x = 0 and the Nyquist end x = π/2, where S of
//! an AR1 with φ near −1 peaks): half-period panels near the ends, and for m > 4K the middle
//! as (3/8)∫g + endpoint asymptotic corrections, g = S/sin²x, with the split points at zeros
//! of sin(mx). The cost is O(K + log m) PSD evaluations (≈ 4000 for m = 2^30).
//!
//! The generalized 1/f² spectrum of RW is handled by the same code; the drift's spectrum is
//! the distribution (ωr)²/(8π²) δ''(f), applied to the kernel analytically (AV = ω²m²/2),
//! so for DR the quadrature column is not an independent check (Lemma 4.2 in semivariogram
//! form is).

use crate::error::{Result, SpectralError, check_m, check_rate};
use crate::lemma42::KahanSum;
use crate::psd::psd_sc;
use processes::{Model, Process};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::sync::OnceLock;

/// Gauss-Legendre points per panel.
const GL_N: usize = 20;
/// Half-period panels integrated directly before the asymptotic treatment.
const K_PANELS: u64 = 32;
/// Levels of geometric grading of the panel touching a singular end.
const GRADING_LEVELS: i32 = 60;
/// Cap on the geometric tail panels (each doubles u).
const MAX_TAIL_PANELS: usize = 1000;
/// A tail panel below this fraction of the running total counts as converged.
const TAIL_REL_EPS: f64 = 1e-17;

/// Gauss-Legendre nodes and weights on [−1, 1] by Newton's method on P_n.
fn gauss_legendre() -> &'static ([f64; GL_N], [f64; GL_N]) {
    static GL: OnceLock<([f64; GL_N], [f64; GL_N])> = OnceLock::new();
    GL.get_or_init(|| {
        let n = GL_N;
        let mut x = [0.0; GL_N];
        let mut w = [0.0; GL_N];
        for i in 0..n.div_ceil(2) {
            let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, z);
                for k in 2..=n {
                    let kf = k as f64;
                    let p2 = ((2.0 * kf - 1.0) * z * p1 - (kf - 1.0) * p0) / kf;
                    p0 = p1;
                    p1 = p2;
                }
                dp = n as f64 * (z * p1 - p0) / (z * z - 1.0);
                let dz = p1 / dp;
                z -= dz;
                if dz.abs() < 1e-16 {
                    break;
                }
            }
            let wi = 2.0 / ((1.0 - z * z) * dp * dp);
            x[i] = -z;
            x[n - 1 - i] = z;
            w[i] = wi;
            w[n - 1 - i] = wi;
        }
        (x, w)
    })
}

fn gl_panel(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let (x, w) = gauss_legendre();
    let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
    let mut s = 0.0;
    for i in 0..GL_N {
        s += w[i] * f(c + h * x[i]);
    }
    s * h
}

/// ∫_0^w f, the panel graded geometrically toward 0.
fn graded_panel(f: &dyn Fn(f64) -> f64, w: f64) -> f64 {
    let mut s = KahanSum::default();
    let mut hi = w;
    for _ in 0..GRADING_LEVELS {
        let lo = 0.5 * hi;
        s.add(gl_panel(f, lo, hi));
        hi = lo;
    }
    s.add(gl_panel(f, 0.0, hi));
    s.value()
}

/// Panels of width `w` from 0 to `end` (the first graded), i.e. split at multiples of `w`.
fn oscillatory_panels(f: &dyn Fn(f64) -> f64, w: f64, end: f64) -> f64 {
    let mut s = KahanSum::default();
    let first = w.min(end);
    s.add(graded_panel(f, first));
    let mut k = 1u64;
    loop {
        let a = k as f64 * w;
        if a >= end {
            break;
        }
        let b = ((k + 1) as f64 * w).min(end);
        s.add(gl_panel(f, a, b));
        k += 1;
    }
    s.value()
}

/// ∫_{z0}^{end} g on geometric panels [z0 2^k, z0 2^(k+1)] (g smooth at the scale of z).
fn geometric_panels(g: &dyn Fn(f64) -> f64, z0: f64, end: f64) -> f64 {
    let mut s = KahanSum::default();
    let mut a = z0;
    while a < end {
        let b = (2.0 * a).min(end);
        s.add(gl_panel(g, a, b));
        a = b;
    }
    s.value()
}

/// g'(z) and g'''(z) by central differences of order 6 and 4, step z/16.
fn derivatives(g: &dyn Fn(f64) -> f64, z: f64) -> (f64, f64) {
    let h = z / 16.0;
    let d = |k: f64| g(z + k * h) - g(z - k * h);
    let (d1, d2, d3) = (d(1.0), d(2.0), d(3.0));
    let first = (45.0 * d1 - 9.0 * d2 + d3) / (60.0 * h);
    let third = (-d3 + 8.0 * d2 - 13.0 * d1) / (8.0 * h * h * h);
    (first, third)
}

/// Oscillating part ∫_{z0}^{…} g(z) (sin⁴(mz) − 3/8) dz from its lower end z0 (m z0 a
/// multiple of π), by integration by parts: (15/128) g'/m² − (63/2048) g'''/m⁴.
fn endpoint_correction(g: &dyn Fn(f64) -> f64, z0: f64, m: f64) -> f64 {
    let (d1, d3) = derivatives(g, z0);
    15.0 / 128.0 * d1 / (m * m) - 63.0 / 2048.0 * d3 / (m * m * m * m)
}

/// ∫_0^{π/2} S(x) sin⁴(mx)/sin²x dx, `spec(x, t)` giving S (unit²/Hz) at x = πfΔt with
/// t = π/2 − x, both passed accurately.
fn discrete_band_integral(spec: &dyn Fn(f64, f64) -> f64, m: u64) -> f64 {
    let mf = m as f64;
    let even = m.is_multiple_of(2);
    // kernel near x = 0 (x-coordinates) and near π/2 (t-coordinates)
    let fx = |x: f64| {
        let r = (mf * x).sin().powi(2) / x.sin();
        spec(x, FRAC_PI_2 - x) * r * r
    };
    let ft = |t: f64| {
        let k = if even { (mf * t).sin() } else { (mf * t).cos() };
        let r = k * k / t.cos();
        spec(FRAC_PI_2 - t, t) * r * r
    };
    let w = PI / mf;
    if m <= 4 * K_PANELS {
        return oscillatory_panels(&fx, w, FRAC_PI_4) + oscillatory_panels(&ft, w, FRAC_PI_4);
    }
    // both ends: K half-periods (plus half a period at the Nyquist end when m is odd, so
    // that the interior split point x_c satisfies m x_c = jπ)
    let a = K_PANELS as f64 * w;
    let tb = (K_PANELS as f64 + if even { 0.0 } else { 0.5 }) * w;
    let ends = oscillatory_panels(&fx, w, a) + oscillatory_panels(&ft, w, tb);
    let gx = |x: f64| spec(x, FRAC_PI_2 - x) / x.sin().powi(2);
    let gt = |t: f64| spec(FRAC_PI_2 - t, t) / t.cos().powi(2);
    let smooth = geometric_panels(&gx, a, FRAC_PI_4) + geometric_panels(&gt, tb, FRAC_PI_4);
    let corr = endpoint_correction(&gx, a, mf) + endpoint_correction(&gt, tb, mf);
    ends + 0.375 * smooth + corr
}

/// Lemma 4.1 for a **continuous-time** two-sided PSD `psd(f)` (f in Hz, unit²/Hz) at the
/// averaging time `tau_s` (s): AV = 4∫_0^∞ sin⁴(πfτ)/(πfτ)² S(f) df, in unit². The PSD
/// must be integrable against the kernel: S(f) = o(f) at ∞ and O(f^(−3+δ)) at 0.
/// See the module docs for the method.
///
/// ```
/// use spectral::lemma41_allan_variance;
/// // Flicker (bias-instability) noise S = c/f: AV = 4 c ln 2 at every τ.
/// let c = 1e-6;
/// for tau in [0.01, 1.0, 1e4] {
///     let av = lemma41_allan_variance(|f| c / f, tau)?;
///     assert!((av - 4.0 * c * 2f64.ln()).abs() < 1e-9 * av);
/// }
/// // Continuous white noise of PSD N²: AV = N²/τ.
/// let av = lemma41_allan_variance(|_| 2.0, 8.0)?;
/// assert!((av - 0.25).abs() < 1e-9 * av);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn lemma41_allan_variance(psd: impl Fn(f64) -> f64, tau_s: f64) -> Result<f64> {
    if !(tau_s.is_finite() && tau_s > 0.0) {
        return Err(SpectralError::InvalidArgument(format!(
            "tau must be finite and > 0 s, got {tau_s}"
        )));
    }
    let scale = PI * tau_s;
    let h = |u: f64| psd(u / scale) / (u * u);
    let fu = |u: f64| {
        let s = u.sin();
        let r = s * s / u;
        psd(u / scale) * r * r
    };
    let u0 = K_PANELS as f64 * PI;
    let head = oscillatory_panels(&fu, PI, u0);
    // mean part of the tail on geometric panels
    let mut tail = KahanSum::default();
    let mut a = u0;
    let mut converged = 0;
    let mut last = f64::INFINITY;
    for _ in 0..MAX_TAIL_PANELS {
        let p = gl_panel(&h, a, 2.0 * a);
        tail.add(p);
        a *= 2.0;
        last = p;
        if p.abs() <= TAIL_REL_EPS * (head + 0.375 * tail.value()).abs() {
            converged += 1;
            if converged >= 3 {
                break;
            }
        } else {
            converged = 0;
        }
        if !a.is_finite() {
            break;
        }
    }
    if converged < 3 {
        return Err(SpectralError::Divergent(format!(
            "the tail panels still contribute {last:e} after {MAX_TAIL_PANELS} doublings of f: the PSD must decay faster than f at infinity"
        )));
    }
    let total = head + 0.375 * tail.value() + endpoint_correction(&h, u0, 1.0);
    let av = 4.0 / scale * total;
    if av.is_finite() {
        Ok(av)
    } else {
        Err(SpectralError::Divergent(format!(
            "non-finite value {av}: the PSD must be integrable against sin^4(pi f tau)/(pi f tau)^2"
        )))
    }
}

/// Lemma 4.1 for a **discrete-time** process sampled at `rate_hz`, given its two-sided PSD
/// `psd(f)` on the Nyquist band 0 ≤ f ≤ rate/2 (unit²/Hz): AV at cluster size `m` (samples),
/// = 4∫_0^{r/2} S(f) sin⁴(πfτ)/(m sin(πfΔt))² df, i.e. Lemma 4.1 with the periodic S
/// (module docs). Unit².
///
/// ```
/// use spectral::discrete_lemma41_allan_variance;
/// // Discrete white noise σ² = 3 at 10 Hz: S = σ²Δt; AV = σ²/m.
/// let av = discrete_lemma41_allan_variance(|_| 0.3, 5, 10.0)?;
/// assert!((av - 0.6).abs() < 1e-9 * av);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn discrete_lemma41_allan_variance(
    psd: impl Fn(f64) -> f64,
    m: u64,
    rate_hz: f64,
) -> Result<f64> {
    let rate = check_rate(rate_hz)?;
    check_m(m)?;
    let to_f = rate / PI;
    let spec = |x: f64, _t: f64| psd(x * to_f);
    finish_discrete(discrete_band_integral(&spec, m), m, rate)
}

fn finish_discrete(integral: f64, m: u64, rate: f64) -> Result<f64> {
    let mf = m as f64;
    let av = 4.0 * rate / (PI * mf * mf) * integral;
    if av.is_finite() {
        Ok(av)
    } else {
        Err(SpectralError::Divergent(format!(
            "non-finite value {av} of the discrete Lemma 4.1 integral"
        )))
    }
}

/// Theoretical AV of a process by the Lemma 4.1 quadrature of its PSD ([`crate::psd()`]):
/// the book's third route, independent of the closed forms and of Lemma 4.2 (except for DR,
/// whose distributional spectrum is applied analytically — see the module docs). Unit².
///
/// ```
/// use processes::{Ar1, Process};
/// use spectral::{allan_variance, quadrature_allan_variance};
/// let ar = Process::from(Ar1::new(0.999, 1e-6)?);
/// for m in [1, 10, 1000, 1 << 20] {
///     let (q, c) = (quadrature_allan_variance(&ar, m, 100.0)?, allan_variance(&ar, m, 100.0)?);
///     assert!((q - c).abs() <= 1e-8 * c);
/// }
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn quadrature_allan_variance(process: &Process, m: u64, rate_hz: f64) -> Result<f64> {
    let rate = check_rate(rate_hz)?;
    check_m(m)?;
    crate::error::check_process(process)?;
    if let Process::Drift(d) = process {
        // ⟨(ωr)²/(8π²) δ'', K⟩ over the real line, halved for ∫_0^∞, times 4:
        // 2 · (ωr)²/(8π²) · K''(0), K''(0) = 2π²τ².
        let tau = m as f64 / rate;
        let rr = d.omega() * rate;
        return Ok(2.0 * rr * rr / (8.0 * PI * PI) * 2.0 * PI * PI * tau * tau);
    }
    if let Process::Sinusoid(p) = process {
        // The line at ±β through the AV filter: AV = (α²/4)|G(β)|² with the filter's response
        // G(β) = (1/m)[Σ_{k<m} e^{iβk} − Σ_{m≤k<2m} e^{iβk}], summed directly (O(m)): an
        // independent route to the closed form α² sin⁴(βm/2)/(m sin(β/2))².
        let (mut re, mut im) = (0.0f64, 0.0f64);
        for k in 0..2 * m {
            let sign = if k < m { 1.0 } else { -1.0 };
            let (s, c) = (p.beta() * k as f64).sin_cos();
            re += sign * c;
            im += sign * s;
        }
        let mf = m as f64;
        return Ok(0.25 * p.alpha2() * (re * re + im * im) / (mf * mf));
    }
    let dt = 1.0 / rate;
    let spec = |x: f64, t: f64| {
        let (s, c) = (x.sin().powi(2), t.sin().powi(2));
        psd_sc(process, s, c, dt).unwrap_or(f64::NAN)
    };
    finish_discrete(discrete_band_integral(&spec, m), m, rate)
}

/// [`quadrature_allan_variance`] summed over a fully specified model (Corollary 4.1).
///
/// ```
/// use processes::{WhiteNoise, RandomWalk};
/// use spectral::{model_allan_variance, model_quadrature_allan_variance};
/// let model = (WhiteNoise::new(1e-4)? + RandomWalk::new(1e-8)?)?;
/// let (q, c) = (model_quadrature_allan_variance(&model, 64, 100.0)?, model_allan_variance(&model, 64, 100.0)?);
/// assert!((q - c).abs() <= 1e-8 * c);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn model_quadrature_allan_variance(model: &Model, m: u64, rate_hz: f64) -> Result<f64> {
    let mut s = 0.0;
    for p in model.processes()? {
        s += quadrature_allan_variance(&p, m, rate_hz)?;
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_degree_39_exactly() {
        // ∫_{-1}^{1} x^k dx = 2/(k+1) for even k; a 20-point rule is exact to degree 39.
        for k in (0..40).step_by(2) {
            let s = gl_panel(&|x: f64| x.powi(k), -1.0, 1.0);
            let exact = 2.0 / (k as f64 + 1.0);
            assert!(
                (s - exact).abs() <= crate::tolerances::GAUSS_LEGENDRE_REL * exact,
                "k={k}: {s} vs {exact}"
            );
        }
        let (_, w) = gauss_legendre();
        assert!((w.iter().sum::<f64>() - 2.0).abs() < 2.0 * crate::tolerances::GAUSS_LEGENDRE_REL);
    }
}
