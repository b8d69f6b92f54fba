//! Time variance TVAR / deviation TDEV (NIST SP 1065 eq. 17; Stable32 "Time Sigma"):
//! TVAR(τ) = τ²/3 · MVAR(τ), in phase unit² (s² for clock phase, angle² for angle data).
//! The time error a clock accumulates over τ; flat for white PM, rising as τ^{1/2} for white FM.

use super::mdev;
use crate::Cumulative;
use crate::config::InputKind;
use crate::error::AvarError;

/// The plain reference: TVAR = τ²/3 · MVAR with MVAR from [`mdev::mvar_reference`]
/// (τ = m / rate_hz, s). Returns TVAR in phase unit².
///
/// ```
/// use avar::stability::tdev::tvar_reference;
/// use avar::InputKind;
/// // NBS14 9-point frequency set (NIST SP 1065 §12.1): TDEV(τ = 1) = 52.67135
/// let y = [892.0, 809.0, 823.0, 798.0, 671.0, 644.0, 883.0, 903.0, 677.0];
/// let tdev = tvar_reference(&y, 1.0, InputKind::Rate, 1).unwrap().sqrt();
/// assert!((tdev / 52.67135 - 1.0).abs() < 5e-7);
/// ```
pub fn tvar_reference(
    data: &[f64],
    rate_hz: f64,
    input: InputKind,
    m: u64,
) -> Result<f64, AvarError> {
    let tau = m as f64 / rate_hz;
    Ok(tau * tau / 3.0 * mdev::mvar_reference(data, rate_hz, input, m)?)
}

/// TVAR at each m from the fast MVAR.
pub(crate) fn tvar_fast(cum: &Cumulative<'_>, rate_hz: f64, ms: &[u64]) -> Vec<f64> {
    tvar_from_mvar(mdev::mvar_fast(cum, ms), rate_hz, ms)
}

/// TVAR = τ²/3 · MVAR at each m (τ = m / rate_hz), from the MVAR values in the order of `ms`.
pub(crate) fn tvar_from_mvar(mvar: Vec<f64>, rate_hz: f64, ms: &[u64]) -> Vec<f64> {
    mvar.into_iter()
        .zip(ms)
        .map(|(v, &m)| {
            let tau = m as f64 / rate_hz;
            tau * tau / 3.0 * v
        })
        .collect()
}
