//! Theoretical AV and PSD of the long-memory processes `PLP` (ARFIMA(0, d, 0)) and `FGN`
//! (see [`processes::long_memory`] for their parameterisation).
//!
//! # FGN: AV in closed form
//! An FGN sample is a unit-lag increment of a fractional Brownian motion B_H with
//! Var B_H(t) = σ² t^{2H} (t in samples), so the sum of m consecutive samples is an increment
//! of B_H over m samples and a cluster mean is X̄ = (B_H(t + m) − B_H(t))/m. With
//! I₁ = B_H(m) − B_H(0) and I₂ = B_H(2m) − B_H(m): Var I₁ = Var I₂ = σ² m^{2H},
//! Cov(I₁, I₂) = ½(Var(I₁ + I₂) − Var I₁ − Var I₂) = ½σ²((2m)^{2H} − 2m^{2H}), so
//!
//! AV(m) = E[(I₂ − I₁)²]/(2m²) = σ² m^{2H−2} (2 − 2^{2H−1}),
//!
//! σ²/m at H = 1/2 (white noise). 2 − 2^{2H−1} = −2·expm1((2H − 2) ln 2) avoids the
//! cancellation at H → 1. The gradient is analytic.
//!
//! # PLP: AV in closed form and by Lemma 4.2
//! With ρ(k) = C Γ(k+d)/Γ(k+1−d), C = Γ(1−d)/Γ(d), the telescoping identity
//! Σ_{k=0}^{K} Γ(k+a)/Γ(k+b) = [Γ(K+1+a)/Γ(K+b) − Γ(a)/Γ(b−1)]/(a−b+1), applied twice,
//! gives the variance of a sum of n samples
//!
//! S(n) = Var(X₁ + … + X_n) = γ(0) [g G(n) + d]/(1 + 2d),  g = Γ(1−d)/Γ(1+d),
//! G(n) = Γ(n+1+d)/Γ(n−d)
//!
//! (S(1) = γ(0); S(n) = nγ(0) at d = 0), and with E[(T₂ − T₁)²] = 4S(m) − S(2m) for the
//! sums T₁, T₂ of two adjacent clusters,
//!
//! AV(m) = (4S(m) − S(2m))/(2m²) = γ(0) [g G(m)(4 − G(2m)/G(m)) + 3d] / (2m²(1 + 2d)).
//!
//! The Gamma ratios come from [`processes::long_memory::ln_gamma_ratio`] (no cancellation
//! of large ln Γ values), so the form is accurate to ~1e-14 relative for every m.
//! [`plp_lemma42_avar`] is the second, independent route: the book's Lemma 4.2 on the exact
//! ACF up to lag 2m (compensated sum), O(m). ∂AV/∂d is a central difference.
//!
//! # PSD (two-sided, unit²/Hz, the convention of [`mod@crate::psd`]; s = sin²(πfΔt))
//! - PLP: S(f) = σ²Δt |1 − e^{−iω}|^{−2d} = σ²Δt (4s)^{−d}, ω = 2πfΔt (∞ at f = 0 for
//!   d > 0: a 1/f^{2d} law, integrable);
//! - FGN: S(f) = σ²Δt Γ(2H+1) sin(πH) · 2(1 − cos ω) Σ_{j∈ℤ} |ω + 2πj|^{−2H−1}
//!   (Sinai 1976; Beran 1994 §2.3), the sum as (2π)^{−2H−1}[ζ(2H+1, x) + ζ(2H+1, 1−x)],
//!   x = ω/2π, with the Hurwitz zeta by Euler–Maclaurin; S ~ f^{1−2H} near 0 (∞ for
//!   H > 1/2, integrable). S = σ²Δt at H = 1/2.
//!
//! Both singularities at f = 0 are integrable and are multiplied in Lemma 4.1 by a kernel
//! that vanishes like f², so the quadrature integrand behaves like f^{2−2d} (f^{3−2H}) and
//! goes to 0; the geometric grading of the first panel of [`crate::quadrature`] resolves it.

use processes::long_memory::{ln_gamma, ln_gamma_ratio};
use processes::{Fgn, Plp};

/// Theoretical AV of an FGN at cluster size `m` (unit², m in samples), closed form
/// σ² m^{2H−2}(2 − 2^{2H−1}) (derivation in the module docs).
///
/// ```
/// use processes::Fgn;
/// use spectral::long_memory::fgn_avar;
/// // H = 1/2 is white noise: σ²/m
/// assert!((fgn_avar(&Fgn::new(2.0, 0.5)?, 8) - 0.25).abs() < 1e-16);
/// // m = 1: AV = γ(0) − γ(1) = σ²(2 − 2^{2H−1})
/// let f = Fgn::new(1.0, 0.8)?;
/// assert!((fgn_avar(&f, 1) - (f.autocovariance(0) - f.autocovariance(1))).abs() < 1e-15);
/// # Ok::<(), processes::ProcessError>(())
/// ```
pub fn fgn_avar(f: &Fgn, m: u64) -> f64 {
    fgn_avar_grad(f, m).0
}

/// FGN AV and its analytic gradient (∂/∂σ², ∂/∂H).
pub(crate) fn fgn_avar_grad(f: &Fgn, m: u64) -> (f64, [f64; 2]) {
    let (s2, h) = (f.sigma2(), f.hurst());
    let lm = (m as f64).ln();
    let ln2 = std::f64::consts::LN_2;
    let pw = ((2.0 * h - 2.0) * lm).exp(); // m^{2H−2}
    let k = -2.0 * ((2.0 * h - 2.0) * ln2).exp_m1(); // 2 − 2^{2H−1}
    let unit = pw * k;
    // ∂/∂H [m^{2H−2}(2 − 2^{2H−1})] = m^{2H−2}(2 ln m · k − 2^{2H} ln 2)
    let dh = s2 * pw * (2.0 * lm * k - (2.0 * h * ln2).exp() * ln2);
    (s2 * unit, [unit, dh])
}

/// Theoretical AV of a PLP at cluster size `m` (unit², m in samples), by the closed form
/// of the module docs (the variance of cluster sums through telescoped Gamma ratios).
///
/// ```
/// use processes::Plp;
/// use spectral::long_memory::plp_avar;
/// // d = 0 is white noise: σ²/m
/// assert!((plp_avar(&Plp::new(3.0, 0.0)?, 6) - 0.5).abs() < 1e-15);
/// // m = 1: AV = γ(0)(1 − ρ(1)), ρ(1) = d/(1 − d)
/// let p = Plp::new(1.0, 0.3)?;
/// assert!((plp_avar(&p, 1) - p.variance() * (1.0 - 0.3 / 0.7)).abs() < 1e-14);
/// # Ok::<(), processes::ProcessError>(())
/// ```
pub fn plp_avar(p: &Plp, m: u64) -> f64 {
    let d = p.d();
    let mf = m as f64;
    // g = Γ(1−d)/Γ(1+d), G(n) = Γ(n+1+d)/Γ(n−d)
    let g = ln_gamma_ratio(1.0, -d, d).exp();
    let ln_g_m = ln_gamma_ratio(mf, 1.0 + d, -d);
    let ln_g_2m = ln_gamma_ratio(2.0 * mf, 1.0 + d, -d);
    let ratio = (ln_g_2m - ln_g_m).exp();
    let bracket = g * ln_g_m.exp() * (4.0 - ratio) + 3.0 * d;
    p.variance() * bracket / (2.0 * mf * mf * (1.0 + 2.0 * d))
}

/// PLP AV and its gradient (∂/∂σ² = AV/σ², ∂/∂d by a central difference of step 1e-6,
/// one-sided within 1e-6 of ±1/2).
pub(crate) fn plp_avar_grad(p: &Plp, m: u64) -> (f64, [f64; 2]) {
    let av = plp_avar(p, m);
    let h = 1e-6;
    let at = |dd: f64| {
        Plp::new(p.sigma2(), p.d() + dd)
            .ok()
            .map(|q| plp_avar(&q, m))
    };
    let dd = match (at(h), at(-h)) {
        (Some(u), Some(l)) => (u - l) / (2.0 * h),
        (Some(u), None) => (u - av) / h,
        (None, Some(l)) => (av - l) / h,
        (None, None) => f64::NAN,
    };
    (av, [av / p.sigma2(), dd])
}

/// The PLP AV by the book's Lemma 4.2 (ACF form, compensated sum of the second
/// differences 2ρ(m−i) − ρ(i) − ρ(2m−i)) on the exact ACF (ρ(0 … 2m) by the ratio recursion
/// ρ(h) = ρ(h−1)(h−1+d)/(h−d), relative error ≤ 2hε): an O(m) route independent of
/// [`plp_avar`].
///
/// ```
/// use processes::Plp;
/// use spectral::long_memory::{plp_avar, plp_lemma42_avar};
/// let p = Plp::new(1.0, -0.3)?;
/// let (a, b) = (plp_avar(&p, 100), plp_lemma42_avar(&p, 100)?);
/// assert!((a - b).abs() < 1e-12 * a);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn plp_lemma42_avar(p: &Plp, m: u64) -> crate::Result<f64> {
    crate::error::check_m(m)?;
    let rho = p.acf(2 * m as usize + 1);
    crate::lemma42::allan_variance_from_acf(p.variance(), |h| rho[h as usize], m)
}

/// Two-sided PSD of a PLP from s = sin²(πfΔt): σ²Δt(4s)^{−d} (unit²/Hz).
pub(crate) fn plp_psd(p: &Plp, s: f64, dt: f64) -> f64 {
    p.sigma2() * dt * (4.0 * s).powf(-p.d())
}

/// Two-sided PSD of an FGN from s = sin²(πfΔt), c = cos²(πfΔt) (unit²/Hz); see the module
/// docs. At f = 0: 0 for H < 1/2, ∞ for H > 1/2.
pub(crate) fn fgn_psd(f: &Fgn, s: f64, c: f64, dt: f64) -> f64 {
    let h = f.hurst();
    let s2dt = f.sigma2() * dt;
    if h == 0.5 {
        return s2dt;
    }
    if s == 0.0 {
        return if h < 0.5 { 0.0 } else { f64::INFINITY };
    }
    let a = 2.0 * h + 1.0;
    // ω ∈ (0, π] by atan2 (accurate at both ends), x = ω/2π ∈ (0, 1/2]
    let w = 2.0 * s.sqrt().atan2(c.sqrt());
    let x = w / (2.0 * std::f64::consts::PI);
    let sum =
        (2.0 * std::f64::consts::PI).powf(-a) * (hurwitz_zeta(a, x) + hurwitz_zeta(a, 1.0 - x));
    let k = (ln_gamma(a)).exp() * (std::f64::consts::PI * h).sin();
    // 2(1 − cos ω) = 4s
    s2dt * k * 4.0 * s * sum
}

/// Hurwitz zeta ζ(a, q) = Σ_{k≥0} (q + k)^{−a} for a > 1, q > 0: 16 terms summed directly,
/// the rest by Euler–Maclaurin with 8 Bernoulli corrections (relative error < 1e-15 for
/// a ∈ (1, 3]).
///
/// ```
/// use spectral::long_memory::hurwitz_zeta;
/// // ζ(2, 1) = π²/6
/// let z = hurwitz_zeta(2.0, 1.0);
/// assert!((z - std::f64::consts::PI.powi(2) / 6.0).abs() < 1e-15);
/// ```
pub fn hurwitz_zeta(a: f64, q: f64) -> f64 {
    const N: usize = 16;
    // B_{2j}/(2j)!
    const B: [f64; 8] = [
        1.0 / 12.0,
        -1.0 / 720.0,
        1.0 / 30240.0,
        -1.0 / 1_209_600.0,
        1.0 / 47_900_160.0,
        -691.0 / 1_307_674_368_000.0,
        1.0 / 74_724_249_600.0,
        -3617.0 / 10_670_622_842_880_000.0,
    ];
    let mut s = 0.0;
    for k in (0..N).rev() {
        s += (q + k as f64).powf(-a);
    }
    let z = q + N as f64;
    let zp = z.powf(-a);
    let mut tail = z * zp / (a - 1.0) + 0.5 * zp;
    // term j: B_{2j}/(2j)! · a(a+1)…(a+2j−2) · z^{−a−2j+1}
    let mut rise = a; // a(a+1)…(a+2j−2)
    let mut zpow = zp / z; // z^{−a−1}
    for (j, b) in B.iter().enumerate() {
        if j > 0 {
            let jj = (2 * j) as f64;
            rise *= (a + jj - 1.0) * (a + jj);
            zpow /= z * z;
        }
        tail += b * rise * zpow;
    }
    s + tail
}
