//! Modified Allan variance MVAR / deviation MDEV (NIST SP 1065 eq. 14–15; Stable32 "Mod Sigma").
//!
//! MVAR(τ) = Σ_{j=0}^{N−3m} [Σ_{i=j}^{j+m−1} (x_{i+2m} − 2x_{i+m} + x_i)]² / (2 m² τ² (N − 3m + 1))
//! for N phase points x (s, or angle) at τ0 = 1/rate and τ = m·τ0; in rate unit².
//! Averaging the phase over m before differencing separates white from flicker phase noise
//! (MDEV falls as τ^{−3/2} for white PM, τ^{−1} for flicker PM).

use super::{
    BLOCK, Statistic, check_m, fused_sums, plain_phase, split_near_far, sum_in_blocks,
    sum_in_blocks_walk,
};
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
/// differences d_i = (c_{i+2m} − c_{i+m}) − (c_{i+m} − c_i) slide along the series (w_{j+1} =
/// w_j + d_{j+m} − d_j) and restart from a direct sum of m terms at every block of
/// max(2^14, 4m) terms, so that rounding does not accumulate beyond one block and the restarts
/// cost at most a quarter of the work. The differences are formed from contiguous slices in
/// sub-chunks (vectorised), the slide runs over them in cache. O(T) per scale; parallel over
/// scales and blocks.
pub(crate) fn mvar_fast(cum: &Cumulative<'_>, ms: &[u64]) -> Vec<f64> {
    let c: &[f64] = &cum.c;
    let n_terms = |m: usize| c.len() + 1 - 3 * m;
    let finish = |m: usize, s: f64| {
        let f = cum.factor / m as f64;
        s * f * f / ((m * m) as f64 * 2.0 * n_terms(m) as f64)
    };
    // near scales (m ≤ 2^12) have blocks of exactly 2^14 terms: fused
    split_near_far(
        ms,
        |near| {
            fused_sums(near, n_terms, |m, lo, hi| mvar_block(c, m, lo, hi))
                .into_iter()
                .zip(near)
                .map(|(s, &m)| finish(m, s))
                .collect()
        },
        |m| {
            if m >= BLOCK && m.is_multiple_of(BLOCK) {
                return finish(m, mvar_far_walk(c, m, n_terms(m)));
            }
            let len = BLOCK.max(4 * m);
            finish(
                m,
                sum_in_blocks(n_terms(m), len, |lo, hi| mvar_block(c, m, lo, hi)),
            )
        },
    )
}

/// Second differences d_i for i in lo..lo + out.len() into `out` (contiguous slices).
#[inline(always)]
fn second_diffs(c: &[f64], m: usize, lo: usize, out: &mut [f64]) {
    let k = out.len();
    let a = &c[lo..lo + k];
    let b = &c[lo + m..lo + m + k];
    let e = &c[lo + 2 * m..lo + 2 * m + k];
    for (((o, &x0), &x1), &x2) in out.iter_mut().zip(a).zip(b).zip(e) {
        *o = (x2 - x1) - (x1 - x0);
    }
}

/// Σ_{j=lo}^{hi−1} w_j² for one block.
fn mvar_block(c: &[f64], m: usize, lo: usize, hi: usize) -> f64 {
    mvar_slide(c, m, lo, hi, diffs_sum(c, m, lo, lo + m))
}

/// Σ_{i=lo}^{hi−1} d_i (second differences at lag m), in sub-chunks, in a fixed order.
fn diffs_sum(c: &[f64], m: usize, lo: usize, hi: usize) -> f64 {
    const SUB: usize = 2048;
    let mut da = [0.0f64; SUB];
    let mut w = 0.0;
    let mut i = lo;
    while i < hi {
        let k = SUB.min(hi - i);
        second_diffs(c, m, i, &mut da[..k]);
        w += da[..k].iter().sum::<f64>();
        i += k;
    }
    w
}

/// Far scales that are whole multiples s of [`BLOCK`] (m = s·BLOCK): the window sum at the
/// start of term block b is the sum of the per-block sums B_q of the second differences over
/// the s blocks q = b … b + s − 1 (one pass computes every B_q; they telescope, so their
/// running sum stays of the size of the window sums), and the blocks are walked by residue
/// class so that the four lags of a block are in cache: about one read of the series per
/// scale, instead of four and an O(m) restart per block.
fn mvar_far_walk(c: &[f64], m: usize, n_terms: usize) -> f64 {
    let s = m / BLOCK;
    // second differences d_i exist for i < c.len() − 2m; the windows use i < n_terms + m − 1
    let n_d = c.len() - 2 * m;
    let nb_d = n_d.div_ceil(BLOCK);
    let b_sums: Vec<f64> = {
        use rayon::prelude::*;
        let walked: Vec<Vec<f64>> = (0..s.min(nb_d))
            .into_par_iter()
            .map(|r| {
                (r..nb_d)
                    .step_by(s)
                    .map(|q| diffs_sum(c, m, q * BLOCK, ((q + 1) * BLOCK).min(n_d)))
                    .collect()
            })
            .collect();
        (0..nb_d).map(|q| walked[q % s][q / s]).collect()
    };
    // prefix over the block sums: w at the start of term block b = P[b + s] − P[b]
    let mut prefix = Vec::with_capacity(nb_d + 1);
    let mut acc = 0.0;
    prefix.push(acc);
    for v in &b_sums {
        acc += v;
        prefix.push(acc);
    }
    sum_in_blocks_walk(n_terms, BLOCK, s, |lo, hi| {
        let b = lo / BLOCK;
        mvar_slide(c, m, lo, hi, prefix[b + s] - prefix[b])
    })
}

/// Σ_{j=lo}^{hi−1} w_j² sliding from the window sum `w` at lo.
fn mvar_slide(c: &[f64], m: usize, lo: usize, hi: usize, mut w: f64) -> f64 {
    const SUB: usize = 2048;
    let mut da = [0.0f64; SUB];
    let mut db = [0.0f64; SUB];
    let mut acc = [0.0f64; 2];
    let mut j = lo;
    while j < hi {
        let k = SUB.min(hi - j);
        // d_j … and d_{j+m} … (the last term of the block needs no update)
        let kd = k.min(hi - 1 - j);
        second_diffs(c, m, j, &mut da[..kd]);
        second_diffs(c, m, j + m, &mut db[..kd]);
        if kd == SUB {
            // the slide w_{t+1} = w_t + e_t as LANES interleaved prefix sums over segments,
            // each started from w plus the sums of the segments before it (no serial chain
            // through all SUB terms)
            const LANES: usize = 8;
            const SEG: usize = SUB / LANES;
            for (a, &b) in da.iter_mut().zip(db.iter()) {
                *a = b - *a;
            }
            let e = &da;
            let mut base = [0.0f64; LANES];
            base[0] = w;
            for l in 1..LANES {
                base[l] = base[l - 1] + e[(l - 1) * SEG..l * SEG].iter().sum::<f64>();
            }
            let mut p = [0.0f64; LANES];
            let mut lane_acc = [0.0f64; LANES];
            for t in 0..SEG {
                for l in 0..LANES {
                    let v = base[l] + p[l];
                    lane_acc[l] += v * v;
                    p[l] += e[l * SEG + t];
                }
            }
            w = base[LANES - 1] + p[LANES - 1];
            acc[0] += lane_acc[..LANES / 2].iter().sum::<f64>();
            acc[1] += lane_acc[LANES / 2..].iter().sum::<f64>();
        } else {
            for t in 0..kd {
                acc[t & 1] += w * w;
                w += db[t] - da[t];
            }
        }
        if kd < k {
            acc[0] += w * w;
        }
        j += k;
    }
    acc[0] + acc[1]
}
