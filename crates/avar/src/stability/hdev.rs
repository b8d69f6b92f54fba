//! Hadamard variance: non-overlapping HVAR/HDEV and overlapping OHVAR/OHDEV (NIST SP 1065
//! eq. 18–20; Stable32 "Hadamard" and "Overlapping Hadamard").
//!
//! OHVAR(τ) = Σ_{i=0}^{N−3m−1} (x_{i+3m} − 3x_{i+2m} + 3x_{i+m} − x_i)² / (6 τ² (N − 3m)) for N
//! phase points at τ0 = 1/rate, τ = m·τ0; HVAR takes only i = 0, m, 2m, … (⌊T/m⌋ − 2 terms).
//! Third differences of phase: a linear frequency drift (IMU warm-up, rate ramp) cancels
//! exactly, and the variance converges for random-walk and flicker-walk FM (α ≥ −4).

use rayon::prelude::*;

use super::{
    BLOCK, Statistic, check_m, fused_sums, plain_phase, split_near_far, sum_in_blocks,
    sum_in_blocks_walk, sumsq_range,
};
use crate::Cumulative;
use crate::config::InputKind;
use crate::error::AvarError;

/// The plain reference: the overlapping (`overlapping = true`, OHVAR) or non-overlapping (HVAR)
/// Hadamard variance at cluster size `m` by the literal formula. Rate unit². For verification.
///
/// ```
/// use avar::stability::hdev::hvar_reference;
/// use avar::InputKind;
/// // NBS14 9-point frequency set (NIST SP 1065 §12.1): HDEV(τ = 1) = 70.80608
/// let y = [892.0, 809.0, 823.0, 798.0, 671.0, 644.0, 883.0, 903.0, 677.0];
/// let h = hvar_reference(&y, 1.0, InputKind::Rate, 1, false).unwrap().sqrt();
/// assert!((h / 70.80608 - 1.0).abs() < 5e-7);
/// ```
pub fn hvar_reference(
    data: &[f64],
    rate_hz: f64,
    input: InputKind,
    m: u64,
    overlapping: bool,
) -> Result<f64, AvarError> {
    let x = plain_phase(data, rate_hz, input)?;
    let n = x.len();
    check_m(Statistic::Ohdev, m, n - 1)?;
    let m = m as usize;
    let tau = m as f64 / rate_hz;
    let stride = if overlapping { 1 } else { m };
    let mut s = 0.0;
    let mut terms = 0usize;
    let mut i = 0;
    while i + 3 * m < n {
        let v = x[i + 3 * m] - 3.0 * x[i + 2 * m] + 3.0 * x[i + m] - x[i];
        s += v * v;
        terms += 1;
        i += stride;
    }
    Ok(s / (6.0 * tau * tau * terms as f64))
}

/// HVAR (stride m) or OHVAR (stride 1) at each m: third differences of the cumulative sum,
/// grouped as differences of first differences. O(T) (overlapping) or O(T/m) per scale.
pub(crate) fn hvar_fast(cum: &Cumulative<'_>, ms: &[u64], overlapping: bool) -> Vec<f64> {
    let c: &[f64] = &cum.c;
    let n = c.len();
    let finish = |m: usize, s: f64, n_terms: usize| {
        let f = cum.factor / m as f64;
        s * f * f / (6.0 * n_terms as f64)
    };
    if !overlapping {
        return ms
            .par_iter()
            .map(|&m| {
                let m = m as usize;
                let n_terms = (n - 1 - 3 * m) / m + 1;
                let d3 = |k: usize| {
                    let i = k * m;
                    let a = c[i + m] - c[i];
                    let b = c[i + 2 * m] - c[i + m];
                    let e = c[i + 3 * m] - c[i + 2 * m];
                    (e - b) - (b - a)
                };
                finish(
                    m,
                    sum_in_blocks(n_terms, BLOCK, |lo, hi| sumsq_range(lo, hi, d3)),
                    n_terms,
                )
            })
            .collect();
    }
    let n_terms = |m: usize| n - 3 * m;
    split_near_far(
        ms,
        |near| {
            fused_sums(near, n_terms, |m, lo, hi| third_diff_sumsq(c, m, lo, hi))
                .into_iter()
                .zip(near)
                .map(|(s, &m)| finish(m, s, n_terms(m)))
                .collect()
        },
        |m| {
            let nt = n_terms(m);
            let block = |lo, hi| third_diff_sumsq(c, m, lo, hi);
            let s = if m >= BLOCK && m.is_multiple_of(BLOCK) {
                sum_in_blocks_walk(nt, BLOCK, m / BLOCK, block)
            } else {
                sum_in_blocks(nt, BLOCK, block)
            };
            finish(m, s, nt)
        },
    )
}

/// Σ_{i=lo}^{hi−1} (third difference of c at lag m, at i)², from four contiguous slices in
/// four lanes (vectorisable).
pub(crate) fn third_diff_sumsq(c: &[f64], m: usize, lo: usize, hi: usize) -> f64 {
    let k = hi - lo;
    if k == 0 {
        return 0.0;
    }
    let x0 = &c[lo..lo + k];
    let x1 = &c[lo + m..lo + m + k];
    let x2 = &c[lo + 2 * m..lo + 2 * m + k];
    let x3 = &c[lo + 3 * m..lo + 3 * m + k];
    let mut acc = [0.0f64; 4];
    let term = |p: f64, q: f64, r: f64, u: f64| {
        let a = q - p;
        let b = r - q;
        let e = u - r;
        let v = (e - b) - (b - a);
        v * v
    };
    let (c0, c1, c2, c3) = (
        x0.chunks_exact(4),
        x1.chunks_exact(4),
        x2.chunks_exact(4),
        x3.chunks_exact(4),
    );
    let tail = (
        c0.remainder(),
        c1.remainder(),
        c2.remainder(),
        c3.remainder(),
    );
    for (((p, q), r), u) in c0.zip(c1).zip(c2).zip(c3) {
        for l in 0..4 {
            acc[l] += term(p[l], q[l], r[l], u[l]);
        }
    }
    for (((p, q), r), u) in tail.0.iter().zip(tail.1).zip(tail.2).zip(tail.3) {
        acc[0] += term(*p, *q, *r, *u);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}
