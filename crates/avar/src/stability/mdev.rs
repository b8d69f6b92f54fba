//! Modified Allan variance MVAR / deviation MDEV (NIST SP 1065 eq. 14–15; Stable32 "Mod Sigma").
//!
//! MVAR(τ) = Σ_{j=0}^{N−3m} [Σ_{i=j}^{j+m−1} (x_{i+2m} − 2x_{i+m} + x_i)]² / (2 m² τ² (N − 3m + 1))
//! for N phase points x (s, or angle) at τ0 = 1/rate and τ = m·τ0; in rate unit².
//! Averaging the phase over m before differencing separates white from flicker phase noise
//! (MDEV falls as τ^{−3/2} for white PM, τ^{−1} for flicker PM).

use rayon::prelude::*;

use super::{Statistic, check_m, plain_phase, sum_in_blocks};
use crate::Cumulative;
use crate::config::InputKind;
use crate::error::AvarError;

/// The plain reference: MVAR at cluster size `m` by the literal double sum (O(T·m) work).
///
/// `data` are rate samples or phase/angle samples (`input`), `rate_hz` the sampling rate (Hz).
/// Returns MVAR in rate unit². For verification only.
///
/// ```
/// use avar::stability::mdev::mvar_reference;
/// use avar::InputKind;
/// // NBS14 9-point frequency set (NIST SP 1065 §12.1): MDEV(τ = 2) = 74.78849
/// let y = [892.0, 809.0, 823.0, 798.0, 671.0, 644.0, 883.0, 903.0, 677.0];
/// let mdev = mvar_reference(&y, 1.0, InputKind::Rate, 2).unwrap().sqrt();
/// assert!((mdev / 74.78849 - 1.0).abs() < 5e-7);
/// ```
pub fn mvar_reference(
    data: &[f64],
    rate_hz: f64,
    input: InputKind,
    m: u64,
) -> Result<f64, AvarError> {
    let x = plain_phase(data, rate_hz, input)?;
    let n = x.len();
    check_m(Statistic::Mdev, m, n - 1)?;
    let m = m as usize;
    let tau = m as f64 / rate_hz;
    let mut s = 0.0;
    for j in 0..=n - 3 * m {
        let mut inner = 0.0;
        for i in j..j + m {
            inner += x[i + 2 * m] - 2.0 * x[i + m] + x[i];
        }
        s += inner * inner;
    }
    let terms = (n - 3 * m + 1) as f64;
    Ok(s / (2.0 * (m * m) as f64 * tau * tau * terms))
}

/// MVAR at each m from the (centred) cumulative representation: the window sums of the second
/// differences d_i = (c_{i+2m} − c_{i+m}) − (c_{i+m} − c_i) slide along the series (one add and
/// one subtract per term) and restart from a direct sum at every block, so that rounding does
/// not accumulate beyond one block. O(T) per scale; parallel over scales and blocks.
pub(crate) fn mvar_fast(cum: &Cumulative<'_>, ms: &[u64]) -> Vec<f64> {
    let c: &[f64] = &cum.c;
    ms.par_iter()
        .map(|&m| {
            let m = m as usize;
            let n_terms = c.len() + 1 - 3 * m;
            let d = |i: usize| (c[i + 2 * m] - c[i + m]) - (c[i + m] - c[i]);
            let s = sum_in_blocks(n_terms, |lo, hi| {
                let mut w: f64 = (lo..lo + m).map(d).sum();
                let mut acc = [0.0f64; 2];
                for j in lo..hi {
                    acc[j & 1] += w * w;
                    if j + 1 < hi {
                        w += d(j + m) - d(j);
                    }
                }
                acc[0] + acc[1]
            });
            let f = cum.factor / m as f64;
            s * f * f / ((m * m) as f64 * 2.0 * n_terms as f64)
        })
        .collect()
}
