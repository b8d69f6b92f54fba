//! The buffered MOAV kernel: the sums of squared second differences
//! Σ_{k=2m}^{T} (c_k − 2c_{k−m} + c_{k−2m})² of a whole cumulative sum `c` in memory, for many
//! cluster sizes at once ([`overlapping_sums`]; the non-overlapping ones in
//! [`nonoverlapping_sums`]). Lanes are tied to the absolute index k and the chunk partials are
//! combined in chunk order, so the AVX-512, AVX2 and portable builds of the lane loop give the
//! same bits.

use rayon::prelude::*;

use super::compensated::{LANES, Neumaier, reduce_lanes};
use crate::simd::SimdLevel;

/// Width of the fixed grid of k-chunks (terms) that partial sums are formed on.
pub(crate) const CHUNK: usize = 1 << 14;

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

/// The sum kernel of `level` (at most [`crate::simd::level`]).
fn sumsq_fn(level: SimdLevel) -> SumFn {
    let level = level.min(crate::simd::level());
    crate::simd::note(level);
    #[cfg(target_arch = "x86_64")]
    match level {
        // SAFETY: `level()` never exceeds what the CPU has (AVX-512F).
        SimdLevel::Avx512 => return |c, m, lo, hi, acc| unsafe { sumsq_avx512(c, m, lo, hi, acc) },
        // SAFETY: as above (AVX2).
        SimdLevel::Avx2 => return |c, m, lo, hi, acc| unsafe { sumsq_avx2(c, m, lo, hi, acc) },
        SimdLevel::Scalar => {}
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
pub(super) const SCALE_BATCH: usize = 128;

/// Σ_{k=2m}^{T} (c_k − 2c_{k−m} + c_{k−2m})² for each m in `ms`, where `c` has T + 1 entries
/// (the maximum-overlapping sums of eq. 4.2). Deterministic for any rayon thread count: the value
/// for a given m is the Neumaier sum, in chunk order, of the fixed-lane chunk partials, whatever
/// other scales are requested.
pub(crate) fn overlapping_sums(c: &[f64], ms: &[u64]) -> Vec<f64> {
    overlapping_sums_at(c, ms, crate::simd::level())
}

/// [`overlapping_sums`] with the kernel of `level` (the same bits at every level).
fn overlapping_sums_at(c: &[f64], ms: &[u64], level: SimdLevel) -> Vec<f64> {
    let f = sumsq_fn(level);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::cumsum::centred_prefix_into;
    use crate::kernel::tests::series;

    /// The buffered kernel gives the same bits at every SIMD level up to the process's level
    /// (lanes tied to the absolute index, no FMA contraction), for near batches (sub-block walk)
    /// and spread scales.
    #[test]
    fn buffered_sums_are_identical_at_every_level() {
        let x = series(2 * CHUNK + 777, 0.5);
        let mut c = Vec::new();
        centred_prefix_into(&x, &mut c).unwrap();
        let near: Vec<u64> = (1..=40).collect();
        let spread: Vec<u64> = vec![1, 3, 64, 1000, 4097, 16_384];
        for ms in [&near, &spread] {
            let want = overlapping_sums_at(&c, ms, SimdLevel::Scalar);
            for level in crate::simd::levels() {
                let got = overlapping_sums_at(&c, ms, level);
                for ((a, b), m) in got.iter().zip(&want).zip(ms.iter()) {
                    assert_eq!(a.to_bits(), b.to_bits(), "{level} m {m}");
                }
            }
        }
    }
}
