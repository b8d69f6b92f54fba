//! The time windows whose differences drive the excess of the classical AV over the robust
//! one at a cluster size.

use serde::{Deserialize, Serialize};

use super::biweight::Biweight;
use super::differences::{centred_prefix_sums_into, differences_into};
use super::m_scale::robust_mean_square;
use crate::error::AvarError;

/// A stretch of the record that drives the difference between the classical and the robust
/// AV at one cluster size.
///
/// ```
/// use avar::robust::{Biweight, excess_windows_at};
/// // a flat record at 10 Hz with spikes of 10 and 20: at m = 1 each gives two differences ±A
/// let mut x = vec![0.0; 1000];
/// x[250] = 10.0;
/// x[750] = 20.0;
/// let b = Biweight::with_efficiency(0.6).unwrap();
/// // σ̂² = 1 given, windows of 100 samples (10 s)
/// let w = excess_windows_at(&x, 10.0, 1, &b, 1.0, 100, 5).unwrap();
/// assert_eq!(w.len(), 2);
/// assert_eq!((w[0].start_s, w[0].end_s), (70.0, 80.0)); // the larger excess first
/// assert_eq!((w[1].start_s, w[1].end_s), (20.0, 30.0));
/// // excess D² − c²σ̂² per difference: 400 − c² against 100 − c²; |D|/σ̂ = 20
/// let c2 = b.c * b.c;
/// assert!((w[0].share - (400.0 - c2) / (500.0 - 2.0 * c2)).abs() < 1e-12);
/// assert!((w[0].share + w[1].share - 1.0).abs() < 1e-12);
/// assert!((w[0].max_z - 20.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExcessWindow {
    /// Start of the window (s from the first sample).
    pub start_s: f64,
    /// End of the window (s).
    pub end_s: f64,
    /// Its share (0..1) of the total excess Σ_k max(0, D_k² − c²σ̂²) over the record.
    pub share: f64,
    /// The largest |D_k| / σ̂ in the window.
    pub max_z: f64,
}

/// The time windows whose differences at cluster size `m` contribute most to the excess of
/// the classical AV over the robust one: the differences D_k beyond c·σ̂ (σ̂² the robust mean
/// square of the D_k), grouped into consecutive windows of `window` samples, the `top` largest
/// by summed excess D_k² − c²σ̂², largest first. Empty when no difference is beyond c·σ̂.
///
/// Errors: as [`robust_allan_variance`] at one scale; `window` = 0.
///
/// ```
/// use avar::robust::{Biweight, excess_windows};
/// let mut x: Vec<f64> = (0..10000).map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5).collect();
/// x[5000] += 40.0; // one spike at t = 50 s (100 Hz)
/// let b = Biweight::with_efficiency(0.6).unwrap();
/// let w = excess_windows(&x, 100.0, 1, &b, 100, 3).unwrap();
/// assert!(w[0].start_s <= 50.0 && 50.0 <= w[0].end_s);
/// assert!(w[0].share > 0.99);
/// ```
///
/// [`robust_allan_variance`]: super::robust_allan_variance
pub fn excess_windows(
    data: &[f64],
    rate_hz: f64,
    m: u64,
    bw: &Biweight,
    window: usize,
    top: usize,
) -> Result<Vec<ExcessWindow>, AvarError> {
    let (t, mean) = check_excess_args(data, rate_hz, m, window)?;
    let m = m as usize;
    let c = centred_prefix_sums_into(data, mean, Vec::new());
    let mut d = Vec::new();
    differences_into(&c, m, 1, &mut d);
    drop(c);
    let s = robust_mean_square(&d, bw)?;
    Ok(excess_from(
        d.iter().copied(),
        t,
        m,
        bw.c * bw.c * s,
        s,
        window,
        rate_hz,
        top,
    ))
}

/// [`excess_windows`] with the robust mean square σ̂² of the differences at cluster size m
/// given (`s`, unit² of the data; e.g. twice the robust AV at m, which estimates the same
/// quantity from every ⌊m/16⌋-th difference) instead of solved for: one pass over the
/// samples with no buffer (the differences are formed from three running prefix sums, the
/// same values as [`excess_windows`] forms), instead of two series-sized buffers and the
/// passes of the estimating equation. With the σ̂² that [`excess_windows`] solves for, the
/// same windows, bit for bit.
///
/// Errors: as [`excess_windows`]; an `s` that is not finite and ≥ 0.
///
/// ```
/// use avar::robust::{Biweight, excess_windows_at};
/// let mut x: Vec<f64> = (0..10000).map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5).collect();
/// x[5000] += 40.0; // one spike at t = 50 s (100 Hz)
/// let b = Biweight::with_efficiency(0.6).unwrap();
/// // the mean square of D_k = x_k − x_{k−1} of the clean sequence (steps of +41/101 and
/// // −60/101): 60·41/101²
/// let w = excess_windows_at(&x, 100.0, 1, &b, 2460.0 / 10201.0, 100, 3).unwrap();
/// assert!(w[0].start_s <= 50.0 && 50.0 <= w[0].end_s);
/// assert!(w[0].share > 0.99);
/// ```
pub fn excess_windows_at(
    data: &[f64],
    rate_hz: f64,
    m: u64,
    bw: &Biweight,
    s: f64,
    window: usize,
    top: usize,
) -> Result<Vec<ExcessWindow>, AvarError> {
    let (t, mean) = check_excess_args(data, rate_hz, m, window)?;
    if !(s.is_finite() && s >= 0.0) {
        return Err(AvarError::InvalidScales(format!(
            "the robust mean square must be finite and >= 0, got {s}"
        )));
    }
    let m = m as usize;
    // c_j = Σ_{i<j} (x_i − mean) at j = k, k + m, k + 2m: three running sums, each adding the
    // same terms in the same order as the stored prefix sums
    let (mut lo, mut mid, mut hi) = (0.0f64, 0.0f64, 0.0f64);
    for &x in &data[..m] {
        mid += x - mean;
    }
    for &x in &data[..2 * m] {
        hi += x - mean;
    }
    let inv = 1.0 / m as f64;
    let ds = (0..=t - 2 * m).map(|k| {
        let d = (hi - 2.0 * mid + lo) * inv;
        if k < t - 2 * m {
            lo += data[k] - mean;
            mid += data[k + m] - mean;
            hi += data[k + 2 * m] - mean;
        }
        d
    });
    Ok(excess_from(
        ds,
        t,
        m,
        bw.c * bw.c * s,
        s,
        window,
        rate_hz,
        top,
    ))
}

/// The checks of [`excess_windows`]: (T, the mean of the samples).
fn check_excess_args(
    data: &[f64],
    rate_hz: f64,
    m: u64,
    window: usize,
) -> Result<(usize, f64), AvarError> {
    crate::validate_rate_alpha(rate_hz, 0.05)?;
    crate::check_len(data.len(), data.len())?;
    if window == 0 {
        return Err(AvarError::InvalidScales(
            "window must be >= 1 sample".into(),
        ));
    }
    if m == 0 {
        return Err(AvarError::ZeroScale);
    }
    let t = data.len();
    if 2 * m > t as u64 {
        return Err(AvarError::ScaleTooLarge {
            m,
            t,
            max: (t / 2) as u64,
        });
    }
    crate::kernel::cumsum::check_finite(data)?;
    Ok((t, data.iter().sum::<f64>() / t as f64))
}

/// The windows of [`excess_windows`] from the differences D_i (i = 0 … T − 2m, spanning
/// samples i … i + 2m − 1), the limit c²σ̂² and σ̂².
#[allow(clippy::too_many_arguments)]
fn excess_from(
    ds: impl Iterator<Item = f64>,
    t: usize,
    m: usize,
    lim: f64,
    s: f64,
    window: usize,
    rate_hz: f64,
    top: usize,
) -> Vec<ExcessWindow> {
    let nw = t.div_ceil(window);
    let mut ex = vec![0.0; nw];
    let mut mz = vec![0.0f64; nw];
    for (i, x) in ds.enumerate() {
        let e = x * x - lim;
        if e > 0.0 {
            // D_k (k = 2m + i, 1-based) spans samples k − 2m + 1..=k, i.e. 0-based i..i + 2m
            let w = (i + m) / window; // centre of its span
            ex[w] += e;
            mz[w] = mz[w].max((x * x / s).sqrt());
        }
    }
    let total: f64 = ex.iter().sum();
    if total <= 0.0 {
        return Vec::new();
    }
    let mut idx: Vec<usize> = (0..nw).filter(|&w| ex[w] > 0.0).collect();
    idx.sort_by(|&a, &b| ex[b].total_cmp(&ex[a]));
    idx.into_iter()
        .take(top)
        .map(|w| ExcessWindow {
            start_s: (w * window) as f64 / rate_hz,
            end_s: (((w + 1) * window).min(t)) as f64 / rate_hz,
            share: ex[w] / total,
            max_z: mz[w],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robust::differences::centred_prefix_sums;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// With the σ̂² that [`excess_windows`] solves for, [`excess_windows_at`] (differences from
    /// running prefix sums, no buffers) gives the same windows bit for bit, at m = 1 and at a
    /// larger m, with a window that does not divide T; a bad σ̂² is an error.
    #[test]
    fn excess_windows_at_the_solved_scale_are_the_same_bits() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(8);
        let mut x: Vec<f64> = (0..50_003)
            .map(|_| StandardNormal.sample(&mut rng))
            .map(|z: f64| z + 3.0)
            .collect();
        for i in [777usize, 20_000, 20_050, 41_234] {
            x[i] += 60.0;
        }
        let bw = Biweight::with_efficiency(0.6).unwrap();
        for m in [1u64, 37] {
            let want = excess_windows(&x, 100.0, m, &bw, 999, 4).unwrap();
            assert!(!want.is_empty());
            let mean = x.iter().sum::<f64>() / x.len() as f64;
            let c = centred_prefix_sums(&x, mean);
            let mut d = Vec::new();
            differences_into(&c, m as usize, 1, &mut d);
            let s = robust_mean_square(&d, &bw).unwrap();
            let got = excess_windows_at(&x, 100.0, m, &bw, s, 999, 4).unwrap();
            assert_eq!(got, want, "m = {m}");
        }
        assert!(excess_windows_at(&x, 100.0, 1, &bw, f64::NAN, 999, 4).is_err());
        assert!(excess_windows_at(&x, 100.0, 1, &bw, -1.0, 999, 4).is_err());
    }
}
