//! The range of AV magnitudes the fit and its inference handle.
//!
//! The GMWM is equivariant under a change of units: scaling the samples by c scales the AV by
//! c², the variance-like parameters by c² and the drift by c. In floating point this holds as
//! long as the products in the delta method (AᵀΩA ∝ 1/AV²) stay in range, which is the case for
//! median AVs between 2^−440 and 2^440 (about 1e±132; the test below checks the fit and its
//! intervals across that range). Curves beyond it (samples near 1e±150, a unit mix-up) get an
//! error that says so, instead of a "not identifiable" that would blame the model.

use crate::curve::AvCurve;
use crate::error::{FitError, Result};

/// log2 of the largest (and of the inverse of the smallest) median AV that is fitted (the fit
/// and its intervals were checked to 2^±478 in the median AV).
const LIMIT_LOG2: f64 = 440.0;

/// Errors when the median AV of `curve` lies outside [2^−440, 2^440].
pub(crate) fn check(curve: &AvCurve) -> Result<()> {
    let mut v: Vec<f64> = curve.points.iter().map(|p| p.avar).collect();
    if v.is_empty() {
        return Ok(());
    }
    let mid = v.len() / 2;
    let med = *v.select_nth_unstable_by(mid, f64::total_cmp).1;
    if med.is_finite() && med > 0.0 && med.log2().abs() > LIMIT_LOG2 {
        return Err(FitError::MagnitudeOutOfRange { median_avar: med });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::gmwm::{GmwmOptions, fit};
    use crate::inference::{delta_method, fit_covariance};
    use crate::theory::model_avar;
    use crate::{AvCurve, FitError};

    /// The same model fitted at its own scale and with the samples scaled by 2^k, k = ±100 and
    /// ±200 (AV ×4^k): the parameters scale as their units do, to the optimizer's tolerance
    /// (1e-9), and so do the intervals; beyond 2^±440 in the median AV, an error that names the magnitude.
    #[test]
    fn fits_are_equivariant_across_the_supported_range() {
        let truth: processes::Model =
            "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.99, sigma2=1e-7)"
                .parse()
                .unwrap();
        let m: Vec<u64> = (1..=18).map(|j| 1u64 << j).collect();
        let av = model_avar(&truth, &m, 100.0).unwrap();
        let base = AvCurve::from_m(&m, &av, 100.0).unwrap().with_n(1_000_000);
        let template = "WN + RW + AR1".parse().unwrap();
        let f0 = fit(&base, &template, &GmwmOptions::default()).unwrap();
        let i0 = delta_method(&f0, &fit_covariance(&f0).unwrap(), 0.05).unwrap();
        for k in [-200, -100, 100, 200] {
            let s = 2f64.powi(k) * 2f64.powi(k); // 4^k
            let scaled: Vec<f64> = av.iter().map(|v| v * s).collect();
            let c = AvCurve::from_m(&m, &scaled, 100.0)
                .unwrap()
                .with_n(1_000_000);
            let f = fit(&c, &template, &GmwmOptions::default()).unwrap();
            let i = delta_method(&f, &fit_covariance(&f).unwrap(), 0.05).unwrap();
            let unit = [s, s, 1.0, s]; // WN σ², RW γ², AR1 φ, AR1 σ²
            for (p, u) in unit.iter().enumerate() {
                let rel = (f.theta[p] / u / f0.theta[p] - 1.0).abs();
                assert!(
                    rel < 1e-9,
                    "k={k} p={p} {} vs {}",
                    f.theta[p] / u,
                    f0.theta[p]
                );
                let rel_ci = (i.ci[p].1 / u / i0.ci[p].1 - 1.0).abs();
                assert!(rel_ci < 1e-6, "k={k} p={p} CI");
            }
        }
        for k in [-260, 260] {
            let s = 2f64.powi(k) * 2f64.powi(k);
            let scaled: Vec<f64> = av.iter().map(|v| v * s).collect();
            let c = AvCurve::from_m(&m, &scaled, 100.0)
                .unwrap()
                .with_n(1_000_000);
            let e = fit(&c, &template, &GmwmOptions::default()).unwrap_err();
            assert!(matches!(e, FitError::MagnitudeOutOfRange { .. }), "{e:?}");
            assert!(e.to_string().contains("rescale"), "{e}");
        }
    }
}
