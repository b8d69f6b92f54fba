//! Tukey's biweight χ_c: its tuning constant from a Gaussian efficiency, its Gaussian
//! moments as exact sums of truncated normal moments, and a quadrature that checks them
//! (the module doc of [`crate::robust`], "Efficiency").

use serde::{Deserialize, Serialize};
use statrs::distribution::{Continuous, Normal};
use statrs::function::gamma::gamma_lr;

use crate::error::AvarError;

/// Default Gaussian efficiency of the robust estimator (as in the R package `gmwm`).
pub const DEFAULT_EFFICIENCY: f64 = 0.6;

/// Smallest and largest efficiency accepted by [`Biweight::with_efficiency`].
pub const EFFICIENCY_RANGE: (f64, f64) = (0.05, 0.99);

/// Tukey's biweight scale function χ_c with its Gaussian constants.
///
/// ```
/// use avar::robust::Biweight;
/// let b = Biweight::with_efficiency(0.6).unwrap();
/// assert!((b.efficiency() - 0.6).abs() < 1e-12);
/// assert!((b.c - 4.4003).abs() < 1e-4);
/// assert_eq!(b.chi(b.c * b.c + 1.0), 0.0); // beyond c·σ: no weight
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Biweight {
    /// Tuning constant c (in standard deviations of the differences).
    pub c: f64,
    /// a(c) = E χ_c(Z²) for Z ~ N(0, 1).
    pub a: f64,
    /// M_c = E[(Z² − 1) χ_c(Z²)] (the slope of the estimating equation).
    pub m_c: f64,
    /// Var χ_c(Z²).
    pub var_chi: f64,
}

fn std_normal() -> Normal {
    Normal::standard()
}

/// E[Z^k 1{|Z| ≤ c}] for even k = 0, 2, …, 2·(len − 1): (k − 1)!! · P((k + 1)/2, c²/2) with P
/// the regularized lower incomplete gamma function (the forward recursion in k loses all
/// digits for small c).
fn truncated_moments(c: f64, len: usize) -> Vec<f64> {
    let mut dfact = 1.0; // (k − 1)!!
    (0..len)
        .map(|i| {
            let k = 2 * i;
            if k >= 2 {
                dfact *= (k - 1) as f64;
            }
            dfact * gamma_lr((k as f64 + 1.0) / 2.0, c * c / 2.0)
        })
        .collect()
}

fn binom(n: u32, k: u32) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

impl Biweight {
    /// The biweight with tuning constant `c` (> 0, in standard deviations).
    ///
    /// Errors: c not finite, or so small (below c₀ ≈ 1.5) that M_c ≤ 0.
    ///
    /// ```
    /// use avar::robust::Biweight;
    /// let b = Biweight::with_c(4.0).unwrap();
    /// assert_eq!(b.c, 4.0);
    /// // back from its efficiency (c found by bisection to 1e-13 relative)
    /// let e = Biweight::with_efficiency(b.efficiency()).unwrap();
    /// assert!((e.c - 4.0).abs() < 1e-9);
    /// // c ≤ 1: Z² − 1 ≤ 0 wherever χ_c(Z²) > 0, so M_c < 0
    /// assert!(Biweight::with_c(1.0).is_err());
    /// assert!(Biweight::with_c(f64::INFINITY).is_err());
    /// ```
    pub fn with_c(c: f64) -> Result<Self, AvarError> {
        if !(c.is_finite() && c > 0.0) {
            return Err(AvarError::InvalidEfficiency(format!(
                "biweight tuning constant must be finite and > 0, got {c}"
            )));
        }
        let (a, m_c, var_chi) = Self::moments(c);
        if m_c <= 0.0 {
            return Err(AvarError::InvalidEfficiency(format!(
                "biweight tuning constant c = {c} is too small (M_c = {m_c} <= 0: no consistent root)"
            )));
        }
        Ok(Biweight { c, a, m_c, var_chi })
    }

    /// (a, M_c, Var χ) at c.
    fn moments(c: f64) -> (f64, f64, f64) {
        // χ(z²) = Σ_i C(4,i) (−1)^i z^{2+2i} / c^{2i};  χ² = Σ_i C(8,i) (−1)^i z^{4+2i} / c^{2i}
        let mu = truncated_moments(c, 11); // up to z^20
        let c2 = c * c;
        let mut a = 0.0;
        let mut z2chi = 0.0;
        for i in 0..=4u32 {
            let w = binom(4, i) * if i % 2 == 0 { 1.0 } else { -1.0 } / c2.powi(i as i32);
            a += w * mu[1 + i as usize];
            z2chi += w * mu[2 + i as usize];
        }
        let mut chi2 = 0.0;
        for i in 0..=8u32 {
            let w = binom(8, i) * if i % 2 == 0 { 1.0 } else { -1.0 } / c2.powi(i as i32);
            chi2 += w * mu[2 + i as usize];
        }
        (a, z2chi - a, chi2 - a * a)
    }

    /// The biweight whose Gaussian efficiency (relative to the mean square) is `eff`, in
    /// [`EFFICIENCY_RANGE`]. The efficiency grows with c; c is found by bisection to 1e-13.
    ///
    /// Errors: eff outside [`EFFICIENCY_RANGE`] or not finite.
    ///
    /// ```
    /// use avar::robust::{Biweight, DEFAULT_EFFICIENCY, EFFICIENCY_RANGE};
    /// let b = Biweight::with_efficiency(DEFAULT_EFFICIENCY).unwrap();
    /// let b95 = Biweight::with_efficiency(0.95).unwrap();
    /// assert!(b95.c > b.c); // the efficiency grows with c
    /// // c to 1e-13 relative: the efficiency to about as much
    /// assert!((b95.efficiency() - 0.95).abs() < 1e-10);
    /// assert!(Biweight::with_efficiency(EFFICIENCY_RANGE.1 + 0.005).is_err());
    /// assert!(Biweight::with_efficiency(f64::NAN).is_err());
    /// ```
    pub fn with_efficiency(eff: f64) -> Result<Self, AvarError> {
        let (lo_e, hi_e) = EFFICIENCY_RANGE;
        if !(eff.is_finite() && (lo_e..=hi_e).contains(&eff)) {
            return Err(AvarError::InvalidEfficiency(format!(
                "robust efficiency must lie in [{lo_e}, {hi_e}], got {eff}"
            )));
        }
        // below c₀ ≈ 1.5, M_c ≤ 0 and e(c) is meaningless; e grows from 0 at c₀ to 1
        let (mut lo, mut hi) = (0.5_f64, 5.0_f64);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if Self::moments(mid).1 <= 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let (mut lo, mut hi) = (hi, 40.0_f64);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if Self::with_c(mid)?.efficiency() < eff {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo < 1e-13 * hi {
                break;
            }
        }
        Self::with_c(0.5 * (lo + hi))
    }

    /// Gaussian efficiency e(c) = M_c² / (2 Var χ_c(Z²)) from the closed-form moments.
    ///
    /// ```
    /// use avar::robust::Biweight;
    /// let b = Biweight::with_c(4.0).unwrap();
    /// let e = b.efficiency();
    /// assert_eq!(e, b.m_c * b.m_c / (2.0 * b.var_chi));
    /// assert!(0.0 < e && e < 1.0); // the mean square is the efficient one at the Gaussian model
    /// assert!((b.efficiency_quadrature() - e).abs() < 1e-10); // the independent quadrature
    /// ```
    pub fn efficiency(&self) -> f64 {
        self.m_c * self.m_c / (2.0 * self.var_chi)
    }

    /// The same efficiency by numerical integration (composite 16-point Gauss–Legendre on
    /// [0, c] with 64 panels), independently of the truncated-moment sums.
    ///
    /// ```
    /// use avar::robust::Biweight;
    /// let b = Biweight::with_efficiency(0.6).unwrap();
    /// assert!((b.efficiency_quadrature() - 0.6).abs() < 1e-10);
    /// ```
    pub fn efficiency_quadrature(&self) -> f64 {
        let n = std_normal();
        let e = |f: &dyn Fn(f64) -> f64| 2.0 * gauss_legendre(|z| f(z) * n.pdf(z), 0.0, self.c);
        let a = e(&|z| self.chi(z * z));
        let m = e(&|z| (z * z - 1.0) * self.chi(z * z));
        let v = e(&|z| self.chi(z * z).powi(2)) - a * a;
        m * m / (2.0 * v)
    }

    /// χ_c(u) = u (1 − u/c²)⁴ for 0 ≤ u ≤ c², else 0 (u = squared standardized difference).
    ///
    /// ```
    /// use avar::robust::Biweight;
    /// let b = Biweight::with_c(4.0).unwrap(); // c² = 16
    /// assert_eq!(b.chi(0.0), 0.0);
    /// assert_eq!(b.chi(4.0), 4.0 * 0.75f64.powi(4)); // 1.265625
    /// assert_eq!(b.chi(8.0), 0.5); // 8 · (1/2)⁴
    /// assert_eq!(b.chi(16.0), 0.0);
    /// assert_eq!(b.chi(1e6), 0.0);
    /// ```
    #[inline]
    pub fn chi(&self, u: f64) -> f64 {
        let c2 = self.c * self.c;
        if u >= c2 {
            0.0
        } else {
            let w = 1.0 - u / c2;
            let w2 = w * w;
            u * w2 * w2
        }
    }

    /// The factor 1/e(c) ≥ 1 by which the variance of the robust estimate exceeds at most that
    /// of the classical one under Gaussian noise (module doc).
    ///
    /// ```
    /// use avar::robust::Biweight;
    /// let b = Biweight::with_efficiency(0.6).unwrap();
    /// assert_eq!(b.variance_inflation(), 1.0 / b.efficiency());
    /// // the efficiency is 0.6 to 1e-12, so 1/e is 1/0.6 to about 3e-12
    /// assert!((b.variance_inflation() - 1.0 / 0.6).abs() < 1e-11);
    /// ```
    pub fn variance_inflation(&self) -> f64 {
        1.0 / self.efficiency()
    }
}

/// ∫_a^b f with 64 panels of 16-point Gauss–Legendre.
fn gauss_legendre(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    // nodes and weights of the 16-point rule on [−1, 1] (positive half)
    const X: [f64; 8] = [
        0.095_012_509_837_637_44,
        0.281_603_550_779_258_9,
        0.458_016_777_657_227_4,
        0.617_876_244_402_643_7,
        0.755_404_408_355_003,
        0.865_631_202_387_831_8,
        0.944_575_023_073_232_6,
        0.989_400_934_991_649_9,
    ];
    const W: [f64; 8] = [
        0.189_450_610_455_068_5,
        0.182_603_415_044_923_6,
        0.169_156_519_395_002_5,
        0.149_595_988_816_576_7,
        0.124_628_971_255_533_9,
        0.095_158_511_682_492_78,
        0.062_253_523_938_647_89,
        0.027_152_459_411_754_09,
    ];
    let panels = 64;
    let h = (b - a) / panels as f64;
    let mut s = 0.0;
    for p in 0..panels {
        let mid = a + (p as f64 + 0.5) * h;
        let half = 0.5 * h;
        for i in 0..8 {
            s += W[i] * half * (f(mid - half * X[i]) + f(mid + half * X[i]));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truncated_moments_tend_to_the_gaussian_ones() {
        // c = 12: E Z^k = (k − 1)!! to ~1e-25 relative truncation
        let mu = truncated_moments(12.0, 6);
        let exact = [1.0, 1.0, 3.0, 15.0, 105.0, 945.0];
        for (a, b) in mu.iter().zip(exact) {
            assert!((a / b - 1.0).abs() < 1e-12, "{a} vs {b}");
        }
    }

    #[test]
    fn efficiency_two_ways_and_monotone() {
        let mut prev = 0.0;
        assert!(Biweight::with_c(1.0).is_err());
        for c in [2.5, 3.0, 4.0, 6.0, 10.0] {
            let b = Biweight::with_c(c).unwrap();
            let (e1, e2) = (b.efficiency(), b.efficiency_quadrature());
            assert!((e1 - e2).abs() < 1e-10, "c = {c}: {e1} vs {e2}");
            assert!(e1 > prev && e1 < 1.0, "c = {c}: {e1}");
            prev = e1;
        }
        // large c: χ → u, a → 1, M_c → 2, Var χ → 2, efficiency → 1
        let b = Biweight::with_c(200.0).unwrap();
        assert!((b.efficiency() - 1.0).abs() < 1e-3);
        for eff in [0.3, 0.6, 0.9] {
            let b = Biweight::with_efficiency(eff).unwrap();
            assert!((b.efficiency_quadrature() - eff).abs() < 1e-10);
        }
        assert!(Biweight::with_efficiency(1.0).is_err());
        assert!(Biweight::with_efficiency(f64::NAN).is_err());
        assert!(Biweight::with_c(-1.0).is_err());
    }
}
