//! Quantiles used for intervals and tests (statrs), with the correct two-sided forms.

use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

/// z_{1−α/2}, the two-sided standard normal quantile (1.959964… for α = 0.05).
///
/// This is the quantile, not the density (R avar's bug), and 1 − α/2, not 1 − α (R gmwm's bug).
///
/// ```
/// let z = gmwm_prep::stats::z_two_sided(0.05);
/// assert!((z - 1.959963984540054).abs() < 1e-9);
/// ```
pub fn z_two_sided(alpha: f64) -> f64 {
    Normal::standard().inverse_cdf(1.0 - alpha / 2.0)
}

/// Upper-tail probability P(χ²_dof > x) (the J-test p-value); NaN when dof ≤ 0 or x is NaN
/// (an undefined statistic must not read as a perfect fit).
///
/// ```
/// let p = gmwm_prep::stats::chi2_sf(3.841458820694124, 1.0);
/// assert!((p - 0.05).abs() < 1e-9);
/// assert!(gmwm_prep::stats::chi2_sf(f64::NAN, 3.0).is_nan());
/// ```
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    match ChiSquared::new(dof) {
        Ok(d) => d.sf(x.max(0.0)),
        Err(_) => f64::NAN,
    }
}
