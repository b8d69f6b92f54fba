//! The variance inflation of a robust Allan variance: its estimates at Gaussian efficiency e
//! vary 1/e times as much as the classical ones. A leaf, shared by the fit's model-based
//! weighting ([`crate::gmwm`]), the inference ([`crate::inference`]) and the robust fit
//! ([`crate::robust`], which re-exports it).

use crate::error::{FitError, Result};

/// The variance inflation 1/e of the robust AV of efficiency e (1 for `None`).
///
/// Errors: e outside `avar::robust::EFFICIENCY_RANGE`.
///
/// ```
/// assert_eq!(gmwm_prep::robust::inflation(None).unwrap(), 1.0);
/// assert!((gmwm_prep::robust::inflation(Some(0.6)).unwrap() - 1.0 / 0.6).abs() < 1e-9);
/// assert!(gmwm_prep::robust::inflation(Some(1.2)).is_err());
/// ```
pub fn inflation(robust: Option<f64>) -> Result<f64> {
    match robust {
        None => Ok(1.0),
        Some(e) => {
            let (lo, hi) = avar::robust::EFFICIENCY_RANGE;
            if !(e.is_finite() && (lo..=hi).contains(&e)) {
                return Err(FitError::InvalidArgument(format!(
                    "robust efficiency must lie in [{lo}, {hi}], got {e}"
                )));
            }
            Ok(1.0 / e)
        }
    }
}
