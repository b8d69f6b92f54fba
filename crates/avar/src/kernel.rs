//! Numerical core: the centred, compensated cumulative sum and the sums of squared second
//! differences for many cluster sizes, vectorised and deterministic.
//!
//! Determinism: every sum is defined on a fixed grid of `k` chunks ([`CHUNK`] wide, aligned to
//! absolute indices) with fixed lane accumulators, and the chunk partials are combined in index
//! order with Neumaier's compensated summation. Neither the thread count nor the SIMD width
//! changes the order of any floating-point operation (no FMA contraction is used), so results
//! are bit-identical on every run of the same binary on the same data.

use rayon::prelude::*;

use crate::error::AvarError;

/// Width of the fixed grid of k-chunks (terms) that partial sums are formed on.
pub(crate) const CHUNK: usize = 1 << 14;
/// Width of the chunks used when building the cumulative sum.
const PCHUNK: usize = 1 << 16;
/// Number of independent accumulator lanes in the inner loops.
const LANES: usize = 16;
/// How many leading samples form the pivot subtracted before summing.
const PIVOT_LEN: usize = 1024;

/// Neumaier's compensated accumulator.
#[derive(Clone, Copy, Default, Debug)]
pub(crate) struct Neumaier {
    hi: f64,
    lo: f64,
}

impl Neumaier {
    #[inline(always)]
    pub(crate) fn add(&mut self, x: f64) {
        let t = self.hi + x;
        if self.hi.abs() >= x.abs() {
            self.lo += (self.hi - t) + x;
        } else {
            self.lo += (x - t) + self.hi;
        }
        self.hi = t;
    }
    #[inline(always)]
    pub(crate) fn value(&self) -> f64 {
        self.hi + self.lo
    }
}

#[inline(always)]
fn reduce_lanes(acc: &[f64; LANES]) -> f64 {
    // fixed pairwise tree
    let mut v = *acc;
    let mut w = LANES;
    while w > 1 {
        w /= 2;
        for i in 0..w {
            v[i] += v[i + w];
        }
    }
    v[0]
}

/// Adds d_k² to `acc[k % LANES]` for k in [lo, hi), d_k = (c[k] − c[k−m]) − (c[k−m] − c[k−2m]).
/// Needs 2m <= lo <= hi <= c.len(). Lanes are tied to the absolute index k, so splitting a
/// range at multiples of LANES leaves every lane's order of additions unchanged.
#[inline(always)]
fn sumsq_generic(c: &[f64], m: usize, lo: usize, hi: usize, acc: &mut [f64; LANES]) {
    let head_end = lo.next_multiple_of(LANES).min(hi);
    for k in lo..head_end {
        let x = (c[k] - c[k - m]) - (c[k - m] - c[k - 2 * m]);
        acc[k % LANES] += x * x;
    }
    if head_end >= hi {
        return;
    }
    let lo = head_end;
    let a = &c[lo..hi];
    let b = &c[lo - m..hi - m];
    let d = &c[lo - 2 * m..hi - 2 * m];
    let mut ia = a.chunks_exact(LANES);
    let mut ib = b.chunks_exact(LANES);
    let mut id = d.chunks_exact(LANES);
    for ((ca, cb), cd) in (&mut ia).zip(&mut ib).zip(&mut id) {
        for l in 0..LANES {
            let x = (ca[l] - cb[l]) - (cb[l] - cd[l]);
            acc[l] += x * x;
        }
    }
    let (ra, rb, rd) = (ia.remainder(), ib.remainder(), id.remainder());
    for l in 0..ra.len() {
        let x = (ra[l] - rb[l]) - (rb[l] - rd[l]);
        acc[l] += x * x;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn sumsq_avx512(c: &[f64], m: usize, lo: usize, hi: usize, acc: &mut [f64; LANES]) {
    sumsq_generic(c, m, lo, hi, acc)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn sumsq_avx2(c: &[f64], m: usize, lo: usize, hi: usize, acc: &mut [f64; LANES]) {
    sumsq_generic(c, m, lo, hi, acc)
}

fn sumsq_portable(c: &[f64], m: usize, lo: usize, hi: usize, acc: &mut [f64; LANES]) {
    sumsq_generic(c, m, lo, hi, acc)
}

type SumFn = fn(&[f64], usize, usize, usize, &mut [f64; LANES]);

fn sumsq_fn() -> SumFn {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F (checked above).
            return |c, m, lo, hi, acc| unsafe { sumsq_avx512(c, m, lo, hi, acc) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked above).
            return |c, m, lo, hi, acc| unsafe { sumsq_avx2(c, m, lo, hi, acc) };
        }
    }
    sumsq_portable
}

/// Sub-block width (a multiple of LANES dividing CHUNK) for batches of nearby scales.
const SUB: usize = 1 << 11;

/// Partial sums of squared second differences over chunk `i` of the fixed k-grid (k ranges over
/// 2m..c.len()) for every m of `batch`; 0 where the chunk lies outside the range. Each partial
/// is the fixed lane reduction of per-lane sums in increasing k, however the chunk is walked.
fn chunk_partials(f: SumFn, c: &[f64], batch: &[u64], i: usize) -> Vec<f64> {
    let c_lo = i * CHUNK;
    let c_hi = ((i + 1) * CHUNK).min(c.len());
    let mut accs = vec![[0.0f64; LANES]; batch.len()];
    let span = batch.last().copied().unwrap_or(0) - batch.first().copied().unwrap_or(0);
    // nearby scales share their lag windows: walk the chunk in L1-sized sub-blocks, all scales
    // per sub-block; otherwise each scale streams through the whole chunk
    let step = if span as usize <= SUB { SUB } else { CHUNK };
    let mut sb = c_lo;
    while sb < c_hi {
        let sb_hi = (sb + step).min(c_hi);
        for (acc, &m) in accs.iter_mut().zip(batch) {
            let m = m as usize;
            let lo = sb.max(2 * m);
            if lo < sb_hi {
                f(c, m, lo, sb_hi, acc);
            }
        }
        sb = sb_hi;
    }
    accs.iter().map(reduce_lanes).collect()
}

/// Scales handled together per pass over the k-chunks (bounds the partial-sum table to
/// n_chunks × SCALE_BATCH values; consecutive scales of a batch share cached lag blocks).
const SCALE_BATCH: usize = 128;

/// Σ_{k=2m}^{T} (c_k − 2c_{k−m} + c_{k−2m})² for each m in `ms`, where `c` has T + 1 entries
/// (the maximum-overlapping sums of eq. 4.2). Deterministic for any rayon thread count: the value
/// for a given m is the Neumaier sum, in chunk order, of the fixed-lane chunk partials, whatever
/// other scales are requested.
pub(crate) fn overlapping_sums(c: &[f64], ms: &[u64]) -> Vec<f64> {
    let f = sumsq_fn();
    let n_chunks = c.len().div_ceil(CHUNK);
    let mut out = Vec::with_capacity(ms.len());
    for batch in ms.chunks(SCALE_BATCH) {
        // parallel over chunks; each chunk runs every scale of the batch while it is in cache
        let parts: Vec<Vec<f64>> = (0..n_chunks)
            .into_par_iter()
            .map(|i| chunk_partials(f, c, batch, i))
            .collect();
        for (s, &m) in batch.iter().enumerate() {
            let mut acc = Neumaier::default();
            for part in parts.iter().skip((2 * m as usize) / CHUNK) {
                acc.add(part[s]);
            }
            out.push(acc.value());
        }
    }
    out
}

/// Non-overlapping sums: Σ over k = 2m, 3m, …, ⌊T/m⌋·m of (c_k − 2c_{k−m} + c_{k−2m})².
pub(crate) fn nonoverlapping_sums(c: &[f64], ms: &[u64]) -> Vec<f64> {
    ms.par_iter()
        .map(|&m| {
            let m = m as usize;
            let mut acc = Neumaier::default();
            let mut k = 2 * m;
            while k < c.len() {
                let x = (c[k] - c[k - m]) - (c[k - m] - c[k - 2 * m]);
                acc.add(x * x);
                k += m;
            }
            acc.value()
        })
        .collect()
}

/// Index and value of the first non-finite sample.
fn first_non_finite(x: &[f64]) -> Option<(usize, f64)> {
    x.iter().position(|v| !v.is_finite()).map(|i| (i, x[i]))
}

/// Checks that every sample is finite (parallel, chunked): v·0 is NaN exactly when v is not finite.
pub(crate) fn check_finite(x: &[f64]) -> Result<(), AvarError> {
    let bad = x.par_chunks(PCHUNK).any(|ch| {
        let mut acc = [0.0f64; LANES];
        let mut it = ch.chunks_exact(LANES);
        for v in &mut it {
            for l in 0..LANES {
                acc[l] += v[l] * 0.0;
            }
        }
        for (l, v) in it.remainder().iter().enumerate() {
            acc[l] += v * 0.0;
        }
        reduce_lanes(&acc).is_nan()
    });
    if bad && let Some((index, value)) = first_non_finite(x) {
        return Err(AvarError::NonFinite { index, value });
    }
    Ok(())
}

#[inline(always)]
fn lane_sum(x: &[f64], p: f64) -> f64 {
    let mut acc = [0.0f64; LANES];
    let mut it = x.chunks_exact(LANES);
    for ch in &mut it {
        for l in 0..LANES {
            acc[l] += ch[l] - p;
        }
    }
    for (l, v) in it.remainder().iter().enumerate() {
        acc[l] += v - p;
    }
    reduce_lanes(&acc)
}

/// The centred cumulative sum of rate samples, written into `c` (its allocation is reused):
/// returns the mean, with `c[0] = 0` and
/// `c[k] = Σ_{i<k} (x_i − mean)` (T + 1 entries), accumulated with a pivot and compensated
/// running offsets so that each stored `c[k]` carries only its own final rounding.
///
/// Errors on non-finite samples (naming the first index) and on overflow.
pub(crate) fn centred_prefix_into(x: &[f64], c: &mut Vec<f64>) -> Result<f64, AvarError> {
    let t = x.len();
    let head = &x[..t.min(PIVOT_LEN)];
    let pivot = head.iter().sum::<f64>() / head.len() as f64;
    // pass 1: chunk sums of (x - pivot)
    let sums: Vec<f64> = x.par_chunks(PCHUNK).map(|ch| lane_sum(ch, pivot)).collect();
    if !pivot.is_finite() || sums.iter().any(|s| !s.is_finite()) {
        if let Some((index, value)) = first_non_finite(x) {
            return Err(AvarError::NonFinite { index, value });
        }
        return Err(AvarError::Overflow);
    }
    let mut tot = Neumaier::default();
    for &s in &sums {
        tot.add(s);
    }
    let delta = tot.value() / t as f64;
    let mean = pivot + delta;
    // exclusive scan of centred chunk sums -> compensated starting offsets
    let mut offsets = Vec::with_capacity(sums.len());
    let mut run = Neumaier::default();
    for (i, &s) in sums.iter().enumerate() {
        offsets.push(run);
        let len = PCHUNK.min(t - i * PCHUNK) as f64;
        run.add(s);
        run.add(-(len * delta));
    }
    // pass 2: write c[1..] chunk by chunk
    c.clear();
    c.reserve(t + 1);
    let spare = &mut c.spare_capacity_mut()[..t + 1];
    spare[0].write(0.0);
    spare[1..]
        .par_chunks_mut(PCHUNK)
        .zip(x.par_chunks(PCHUNK))
        .zip(offsets.par_iter())
        .for_each(|((out, xs), off)| {
            let mut run = *off;
            const B: usize = 8;
            let mut io = out.chunks_exact_mut(B);
            let mut ix = xs.chunks_exact(B);
            for (o, v) in (&mut io).zip(&mut ix) {
                let mut local = [0.0f64; B];
                let mut s = 0.0;
                for l in 0..B {
                    s += (v[l] - pivot) - delta;
                    local[l] = s;
                }
                for l in 0..B {
                    o[l].write(run.hi + (run.lo + local[l]));
                }
                run.add(s);
            }
            let mut s = 0.0;
            for (o, v) in io.into_remainder().iter_mut().zip(ix.remainder()) {
                s += (v - pivot) - delta;
                o.write(run.hi + (run.lo + s));
            }
        });
    // SAFETY: the loop above wrote all t + 1 elements (index 0, then every chunk of
    // `spare[1..]` in full: exact blocks of 8 plus the remainder).
    unsafe { c.set_len(t + 1) };
    Ok(mean)
}
