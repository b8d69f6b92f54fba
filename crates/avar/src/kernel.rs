//! Numerical core: the centred, compensated cumulative sum and the sums of squared second
//! differences for many cluster sizes, vectorised and deterministic.
//!
//! Determinism: every sum is defined on a fixed grid of `k` chunks ([`CHUNK`] wide, aligned to
//! absolute indices) with fixed lane accumulators, and the chunk partials are combined in index
//! order with Neumaier's compensated summation. Neither the thread count nor the SIMD width
//! changes the order of any floating-point operation (no FMA contraction is used, except where
//! written out: the streamed kernel's acc ← fma(d, d, acc), a correctly rounded fused operation
//! in every path), so results are bit-identical on every run of the same binary on the same data.
//!
//! Long rate series take a streamed path ([`overlapping_sums_stream`]; the chi-square interval
//! is streamed too, by the `ci_stream` module from [`checkpoints`] and [`prefix_window`]): no
//! series-sized buffer, only checkpoints of the centred cumulative sum every [`G`] samples (built
//! by the near-scale walk itself, job by job in local frames, while each chunk is in cache, so
//! that the series is read from memory once for the near scales and once for the far ones); each
//! segment of k starts from an exact d_k rebuilt from the checkpoints and carries
//! d_{k+1} = d_k + (x_k − x_{k−m}) − (x_{k−m} − x_{k−2m}) (SIMD across segments, the same
//! operations in the same order as the portable code). The segment length depends only on m
//! ([`SEG_NEAR`] for near scales, the power of two [`SEG_FAR`] for far ones, whose chunks are
//! walked by residue class so that their lagged blocks are still cached). With AVX-512 or AVX2
//! (the level of [`crate::simd::level`]) the segments are vector lanes (eight resp. four per
//! vector) and a chunk is walked in column blocks, all scales per block: the rows of x are
//! transposed in registers per scale, except for the small scales (2m ≤ [`XH`]), which share
//! one transposed copy of the chunk, and the far scales that are whole steps of the
//! residue-class walk, which read the transposed copies of the chunks the walk visited (a ring
//! per thread); those run four (AVX2: two) scales at a time (independent recurrences in one
//! instruction stream).

// the vector paths' helpers (chunk-walk state, lane copies) are used only on x86-64; other
// architectures build the portable path and leave them unused
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code, unused_variables))]

use rayon::prelude::*;

use crate::error::AvarError;
use crate::simd::SimdLevel;
use crate::source::io::{Io, Release, SampleWindow};

/// Width of the fixed grid of k-chunks (terms) that partial sums are formed on.
pub(crate) const CHUNK: usize = 1 << 14;
/// Width of the chunks used when building the cumulative sum.
const PCHUNK: usize = 1 << 16;
/// Number of independent accumulator lanes in the inner loops.
pub(crate) const LANES: usize = 16;
/// How many leading samples form the pivot subtracted before summing.
const PIVOT_LEN: usize = 1024;

/// Neumaier's compensated accumulator.
#[derive(Clone, Copy, Default, Debug)]
pub(crate) struct Neumaier {
    pub(crate) hi: f64,
    pub(crate) lo: f64,
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

/// The fixed pairwise reduction of [`LANES`] accumulators.
#[inline(always)]
pub(crate) fn reduce_lanes(acc: &[f64; LANES]) -> f64 {
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
const SCALE_BATCH: usize = 128;

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

/// Index and value of the first non-finite sample.
pub(crate) fn first_non_finite(x: &[f64]) -> Option<(usize, f64)> {
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

/// Series at least this long (rate input, overlapping estimator, no CI) are streamed from the
/// samples and checkpoints instead of a series-sized cumulative-sum buffer (whose first-touch
/// page faults then dominate; below it the buffered kernel is faster).
pub(crate) const STREAM_MIN_T: usize = 1 << 22;

/// Granularity (samples) of the checkpoints of the centred cumulative sum.
const G: usize = 64;
/// Length of one segment of k on which d_k is carried by its own recurrence (near scales,
/// 2m ≤ [`FAR_M`]); a k-chunk is NSEG segments. Near segment starts are SEG_NEAR·8 bytes apart,
/// 512 bytes more than a multiple of 4 KiB, so that the rows read together fall in different L1
/// sets; and they are multiples of G, so that for m a multiple of G (dyadic m ≥ G) every starting
/// d comes from three checkpoints without a local sum.
const SEG_NEAR: usize = 1024 + G;
/// Segment length of the far scales (2m > [`FAR_M`]): a power of two, so that the chunk width
/// (2048 samples, 16 KiB) divides the dyadic lags and the residue-class walk of [`stream_group`]
/// finds the lagged blocks among the chunks it visited last; short, so that those (up to
/// 2·2^25/FAR_M = 64 steps back at T = 10^8, 1 MiB) can stay cached (measured on the far scales
/// of 10^8 samples: 128 is ~10 % faster than 64 and 256, ~25 % faster than 1024 and the near
/// grid).
const SEG_FAR: usize = 128;
/// Segments per k-chunk of the streamed kernel (one fixed accumulator each).
const NSEG: usize = 16;
const _: () = assert!(
    NSEG == LANES
        && PCHUNK.is_multiple_of(G)
        && SEG_NEAR.is_multiple_of(G)
        && SEG_FAR.is_multiple_of(G)
        && FAR_M_MIN.is_multiple_of(NSEG * SEG_FAR)
);

/// The centred cumulative sum C_p = Σ_{i<p} (x_i − pivot − delta) of rate samples, kept only at
/// every [`G`]-th index as compensated (hi, lo) pairs: `ck[g − g0].0 + ck[g − g0].1` = C_{gG}
/// (last entry: C_T). [`checkpoints`] centres on the mean (delta = mean − pivot) from index 0;
/// the streamed kernel also uses local frames (delta = 0, origin anywhere, entries from g0 on):
/// second differences C_s − 2C_{s−m} + C_{s−2m} do not depend on the centring constant or on the
/// origin.
pub(crate) struct Checkpoints {
    pivot: f64,
    delta: f64,
    /// The mean of the samples (pivot + delta); NaN in the streamed kernel's pivot-only frames,
    /// whose caller gets the mean from the job totals instead.
    pub(crate) mean: f64,
    /// Index (in units of G samples) of the first entry of `ck`.
    g0: usize,
    ck: Vec<(f64, f64)>,
    /// The far walk's compact form (then `ck` is empty): see [`FarFrames`].
    far: Option<FarFrames>,
}

/// The checkpoints of the whole series for the far walk in half the memory (16 bytes per 128
/// samples): the near jobs' local entries at even g only, and each job's base (the
/// compensated sum of the earlier jobs' totals). An entry is rebuilt exactly as
/// [`global_checkpoints`] would have stored it: an odd local entry by the Neumaier step of
/// [`job_extend`] from the even one below it, then shifted by the job's base.
struct FarFrames {
    /// Job length in units of G (even: job starts are even indices).
    job_g: usize,
    bases: Vec<(f64, f64)>,
    /// Local entries at g = 0, 2, 4, … (`loc[g / 2]`), up to the last index ⌈T/G⌉.
    loc: Vec<(f64, f64)>,
}

impl Checkpoints {
    /// C at index gG (needs g0 ≤ g < g0 + ck.len(), or g ≤ ⌈T/G⌉ in the compact far form,
    /// which reads the samples of block g − 1 for odd g).
    #[inline(always)]
    fn get(&self, x: &[f64], g: usize) -> (f64, f64) {
        match &self.far {
            None => self.ck[g - self.g0],
            Some(f) => {
                let (lh, ll) = if g.is_multiple_of(2) {
                    f.loc[g / 2]
                } else {
                    let (hi, lo) = f.loc[g / 2];
                    let mut run = Neumaier { hi, lo };
                    run.add(lane_sum(&x[(g - 1) * G..(g * G).min(x.len())], self.pivot));
                    (run.hi, run.lo)
                };
                let (bh, bl) = f.bases[(g / f.job_g).min(f.bases.len() - 1)];
                let (h, e) = two_sum(bh, lh);
                (h, (e + bl) + ll)
            }
        }
    }

    /// C_p as an unevaluated sum (hi, lo): the checkpoint below p plus the short sequential
    /// local sum of the centred samples in between. A deterministic function of p.
    #[inline]
    pub(crate) fn at(&self, x: &[f64], p: usize) -> (f64, f64) {
        let g = p / G;
        let (hi, lo) = self.get(x, g);
        if p == g * G {
            return (hi, lo);
        }
        let mut l = [0.0f64; 4];
        let mut it = x[g * G..p].chunks_exact(4);
        for v in &mut it {
            for j in 0..4 {
                l[j] += (v[j] - self.pivot) - self.delta;
            }
        }
        for (j, v) in it.remainder().iter().enumerate() {
            l[j] += (v - self.pivot) - self.delta;
        }
        (hi, lo + ((l[0] + l[1]) + (l[2] + l[3])))
    }
}

/// Builds the checkpoints of the centred cumulative sum (one parallel pass over `x` writing the
/// T/G block sums into the checkpoint buffer, then a sequential compensated scan over it in
/// place). Errors on non-finite samples (naming the first index) and on overflow.
pub(crate) fn checkpoints(x: &[f64]) -> Result<Checkpoints, AvarError> {
    checkpoints_io(x, Io::NONE.release)
}

/// [`checkpoints`], telling `release` about each chunk of samples once it is summed.
pub(crate) fn checkpoints_io(x: &[f64], release: Release<'_>) -> Result<Checkpoints, AvarError> {
    let t = x.len();
    let pivot = pivot_of(x);
    let n_blocks = t.div_ceil(G);
    let mut ck = vec![(0.0f64, 0.0f64); n_blocks + 1];
    ck[..n_blocks]
        .par_chunks_mut(PCHUNK / G)
        .zip(x.par_chunks(PCHUNK))
        .enumerate()
        .for_each(|(i, (out, xs))| {
            for (o, b) in out.iter_mut().zip(xs.chunks(G)) {
                o.0 = lane_sum(b, pivot);
            }
            release(i * PCHUNK, i * PCHUNK + xs.len());
        });
    if !pivot.is_finite() || ck.iter().any(|s| !s.0.is_finite()) {
        if let Some((index, value)) = first_non_finite(x) {
            return Err(AvarError::NonFinite { index, value });
        }
        return Err(AvarError::Overflow);
    }
    let mut tot = Neumaier::default();
    for &(s, _) in &ck[..n_blocks] {
        tot.add(s);
    }
    let delta = tot.value() / t as f64;
    let mean = pivot + delta;
    let mut run = Neumaier::default();
    for (g, c) in ck.iter_mut().enumerate() {
        let s = c.0;
        *c = (run.hi, run.lo);
        if g < n_blocks {
            let len = G.min(t - g * G) as f64;
            run.add(s);
            run.add(-(len * delta));
        }
    }
    Ok(Checkpoints {
        pivot,
        delta,
        mean,
        g0: 0,
        ck,
        far: None,
    })
}

/// The pivot subtracted before summing: the mean of the first [`PIVOT_LEN`] samples.
pub(crate) fn pivot_of(x: &[f64]) -> f64 {
    let head = &x[..x.len().min(PIVOT_LEN)];
    head.iter().sum::<f64>() / head.len() as f64
}

#[inline(always)]
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// d_s = C_s − 2C_{s−m} + C_{s−2m}: for m < G directly as Σ_{i=s−m}^{s−1} (x_i − x_{i−m}) (the
/// mean and any offset cancel in each difference); otherwise from the checkpoints, the large
/// parts differenced exactly.
#[inline(always)]
fn d_start(x: &[f64], ck: &Checkpoints, m: usize, s: usize) -> f64 {
    if m < G {
        let mut l = [0.0f64; 4];
        let (xa, xb) = (&x[s - m..s], &x[s - 2 * m..s - m]);
        let mut ia = xa.chunks_exact(4);
        let mut ib = xb.chunks_exact(4);
        for (va, vb) in (&mut ia).zip(&mut ib) {
            for j in 0..4 {
                l[j] += va[j] - vb[j];
            }
        }
        for (j, (va, vb)) in ia.remainder().iter().zip(ib.remainder()).enumerate() {
            l[j] += va - vb;
        }
        return (l[0] + l[1]) + (l[2] + l[3]);
    }
    let ((ah, al), (bh, bl), (ch, cl)) = if s.is_multiple_of(G) && m.is_multiple_of(G) {
        // all three on checkpoints (the common case: segment starts are multiples of G)
        let (g, q) = (s / G, m / G);
        (ck.get(x, g), ck.get(x, g - q), ck.get(x, g - 2 * q))
    } else {
        (ck.at(x, s), ck.at(x, s - m), ck.at(x, s - 2 * m))
    };
    let (s1, e1) = two_sum(ah, -bh);
    let (s2, e2) = two_sum(ch, -bh);
    let (s3, e3) = two_sum(s1, s2);
    s3 + (((e1 + e2) + e3) + ((al - bl) + (cl - bl)))
}

/// Σ d_k² over k in [s, e) (2m ≤ s < e ≤ T + 1), carrying d_{k+1} = d_k + y_k with
/// y_k = (x_k − x_{k−m}) − (x_{k−m} − x_{k−2m}) (the mean cancels exactly), sequentially in k;
/// each d_k² is accumulated by one fused multiply-add (acc ← fma(d, d, acc), a single rounding,
/// the same in every vector path).
#[inline(always)]
fn seg_sum(x: &[f64], d0: f64, m: usize, s: usize, e: usize) -> f64 {
    let mut d = d0;
    let mut acc = 0.0f64;
    for k in s..e - 1 {
        acc = d.mul_add(d, acc);
        d += (x[k] - x[k - m]) - (x[k - m] - x[k - 2 * m]);
    }
    d.mul_add(d, acc)
}

/// Scales with 2m > FAR_M are "far": their lagged blocks are not in cache in plain chunk order.
/// They take the [`SEG_FAR`] grid and are walked by residue class of the chunk index modulo
/// FAR_M / (NSEG·SEG_FAR), a class step of exactly FAR_M samples (see [`stream_group`]). This
/// is the largest threshold; shorter series take a smaller one ([`far_m`]).
const FAR_M: usize = 1 << 20;
/// The smallest near/far threshold of [`far_m`].
const FAR_M_MIN: usize = 1 << 17;

/// The near/far threshold (and class step) for T samples: T/64 rounded up to a power of two,
/// within [`FAR_M_MIN`] … [`FAR_M`]. The far walk's lane ring then holds about T/FAR_M chunk
/// copies of 16 KiB (up to 1 MiB, the L2 cache of this machine) until T reaches 64·FAR_M,
/// while the near scales' lags (2m, up to FAR_M samples back) stay nearer in the cache
/// hierarchy and the near jobs' warm-up (FAR_M samples each) stays short. Measured at 10^7
/// samples, octave τ: OADEV 17.7 ms with 2^20, 16.2 with 2^19, 15.8 with 2^18 (this rule),
/// 15.5 with 2^17; at 10^8, 181 ms with 2^20 (this rule), 175 with 2^19, 177 with 2^18, 185
/// with 2^17. A function of T only, so that results do not depend on the thread count.
pub(crate) fn far_m(t: usize) -> usize {
    (t / 64).next_power_of_two().clamp(FAR_M_MIN, FAR_M)
}

/// Columns of a chunk that [`chunk_all_avx512`] runs for every scale of a batch before moving on
/// (the rows of x they read stay in L1 from one scale to the next; for dyadic scales the x_{k−2m}
/// rows of scale m are the x_{k−m'} rows of m' = 2m).
const BLK: usize = 64;
const _: () =
    assert!(SEG_NEAR.is_multiple_of(BLK) && SEG_FAR.is_multiple_of(BLK) && BLK.is_multiple_of(8));

/// How far past the chunk end [`block_avx512`] reads with misalignment `s` (its last window).
const fn tail_reach(s: usize) -> usize {
    if s > 0 { 8 - s } else { 0 }
}

/// Per-scale state of the NSEG segment recurrences of one chunk: the current d and the running
/// sum of d² of each segment.
#[derive(Clone, Copy)]
struct SegState {
    d: [f64; NSEG],
    acc: [f64; NSEG],
}

/// The 8 × 8 transpose of eight AVX-512 vectors (`[__m512d; 8]`, rows → columns): 24 shuffles.
/// Needs `std::arch::x86_64::*` in scope and AVX-512F enabled at the use site.
#[cfg(target_arch = "x86_64")]
macro_rules! transpose8x8 {
    ($v:expr) => {{
        let v = $v;
        let t0 = _mm512_unpacklo_pd(v[0], v[1]);
        let t1 = _mm512_unpackhi_pd(v[0], v[1]);
        let t2 = _mm512_unpacklo_pd(v[2], v[3]);
        let t3 = _mm512_unpackhi_pd(v[2], v[3]);
        let t4 = _mm512_unpacklo_pd(v[4], v[5]);
        let t5 = _mm512_unpackhi_pd(v[4], v[5]);
        let t6 = _mm512_unpacklo_pd(v[6], v[7]);
        let t7 = _mm512_unpackhi_pd(v[6], v[7]);
        let u0 = _mm512_shuffle_f64x2::<0x88>(t0, t2);
        let u1 = _mm512_shuffle_f64x2::<0xDD>(t0, t2);
        let u2 = _mm512_shuffle_f64x2::<0x88>(t1, t3);
        let u3 = _mm512_shuffle_f64x2::<0xDD>(t1, t3);
        let u4 = _mm512_shuffle_f64x2::<0x88>(t4, t6);
        let u5 = _mm512_shuffle_f64x2::<0xDD>(t4, t6);
        let u6 = _mm512_shuffle_f64x2::<0x88>(t5, t7);
        let u7 = _mm512_shuffle_f64x2::<0xDD>(t5, t7);
        [
            _mm512_shuffle_f64x2::<0x88>(u0, u4),
            _mm512_shuffle_f64x2::<0x88>(u2, u6),
            _mm512_shuffle_f64x2::<0x88>(u1, u5),
            _mm512_shuffle_f64x2::<0x88>(u3, u7),
            _mm512_shuffle_f64x2::<0xDD>(u0, u4),
            _mm512_shuffle_f64x2::<0xDD>(u2, u6),
            _mm512_shuffle_f64x2::<0xDD>(u1, u5),
            _mm512_shuffle_f64x2::<0xDD>(u3, u7),
        ]
    }};
}
#[cfg(target_arch = "x86_64")]
pub(crate) use transpose8x8;

/// Halo (columns) of the transposed copy of a near chunk: scales with 2m ≤ XH read their lagged
/// samples from the copy (see [`build_lanes_avx512`]).
const XH: usize = 512;
const _: () = assert!(XH.is_multiple_of(8) && SEG_NEAR.is_multiple_of(8));

/// Eight f64 on one cache line (the element of the transposed copy).
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
pub(crate) struct Line([f64; 8]);

/// Transposed copy of the NSEG rows of the full chunk [a, a + NSEG·SEG) with a halo of `halo`
/// columns, written to `dst` (2·(halo + SEG) lines): `dst[2c + g]` holds, in lane r,
/// x[a + (8g + r)·SEG − halo + c] for c ∈ [0, halo + SEG), so that for any column j of the chunk
/// and any lag λ ≤ halo the samples x_{k−λ} of the 16 segments are two aligned vectors (no
/// transposes left in [`block_lanes_avx512`]). Needs a ≥ halo.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn build_lanes_avx512<const SEG: usize>(
    x: &[f64],
    a: usize,
    halo: usize,
    dst: &mut [Line],
) {
    use std::arch::x86_64::*;
    let cols = halo + SEG;
    assert!(
        a >= halo
            && a + NSEG * SEG <= x.len()
            && NSEG == 16
            && halo.is_multiple_of(8)
            && dst.len() >= 2 * cols
    );
    // SAFETY: AVX-512F is available (caller contract); the loads read x[a − halo + (8g + r)·SEG + c]
    // for c < cols, r < 8, g < 2, i.e. inside [a − halo, a + NSEG·SEG) (asserted); the stores
    // write the aligned lines dst[2c + g] for c < cols (length asserted).
    unsafe {
        let px = x.as_ptr().add(a - halo);
        let pt = dst.as_mut_ptr().cast::<f64>();
        for g in 0..2 {
            let mut c0 = 0;
            while c0 < cols {
                let mut v = [_mm512_setzero_pd(); 8];
                for (r, vr) in v.iter_mut().enumerate() {
                    *vr = _mm512_loadu_pd(px.add((8 * g + r) * SEG + c0));
                }
                let col = transpose8x8!(v);
                for (cc, cv) in col.iter().enumerate() {
                    _mm512_store_pd(pt.add(8 * (2 * (c0 + cc) + g)), *cv);
                }
                c0 += 8;
            }
        }
    }
}

/// [`block_avx512`] for N scales at once from lane-layout copies ([`build_lanes_avx512`]) in
/// `buf`: for scale q the columns x_k, x_{k−m}, x_{k−2m} of chunk column j are the line pairs at
/// column `offs[q][0] + j`, `offs[q][1] + j`, `offs[q][2] + j` of `buf`. Over the columns
/// [j0, j1): per scale and column, y = (x_k − x_{k−m}) − (x_{k−m} − x_{k−2m}) from aligned loads,
/// then acc ← fma(d, d, acc); d += y: the operations of [`seg_sum`] in the same order
/// (bit-identical results). The scales only share the instruction stream: their 2N recurrences
/// are independent, which hides the latency of each one's chain of adds and fused multiply-adds.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn block_lanes_avx512<const N: usize>(
    buf: &[Line],
    offs: [[usize; 3]; N],
    j0: usize,
    j1: usize,
    st: &mut [SegState; N],
) {
    use std::arch::x86_64::*;
    assert!(j0 <= j1 && NSEG == 16 && offs.iter().flatten().all(|&o| 2 * (o + j1) <= buf.len()));
    // SAFETY: AVX-512F is available (caller contract); the loads read the aligned lines
    // buf[2(o + j) + g] for j < j1, g < 2, inside `buf` (asserted).
    unsafe {
        let pt = buf.as_ptr().cast::<f64>();
        let mut d = [[_mm512_setzero_pd(); 2]; N];
        let mut acc = [[_mm512_setzero_pd(); 2]; N];
        for q in 0..N {
            for g in 0..2 {
                d[q][g] = _mm512_loadu_pd(st[q].d.as_ptr().add(8 * g));
                acc[q][g] = _mm512_loadu_pd(st[q].acc.as_ptr().add(8 * g));
            }
        }
        for j in j0..j1 {
            for q in 0..N {
                let [oa, ob, oc] = offs[q];
                for g in 0..2 {
                    let xa = _mm512_load_pd(pt.add(16 * (oa + j) + 8 * g));
                    let xb = _mm512_load_pd(pt.add(16 * (ob + j) + 8 * g));
                    let xc = _mm512_load_pd(pt.add(16 * (oc + j) + 8 * g));
                    let y = _mm512_sub_pd(_mm512_sub_pd(xa, xb), _mm512_sub_pd(xb, xc));
                    acc[q][g] = _mm512_fmadd_pd(d[q][g], d[q][g], acc[q][g]);
                    d[q][g] = _mm512_add_pd(d[q][g], y);
                }
            }
        }
        for q in 0..N {
            for g in 0..2 {
                _mm512_storeu_pd(st[q].d.as_mut_ptr().add(8 * g), d[q][g]);
                _mm512_storeu_pd(st[q].acc.as_mut_ptr().add(8 * g), acc[q][g]);
            }
        }
    }
}

/// Runs [`block_lanes_avx512`] for the scales given by their column offsets and states, four
/// at a time.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn blocks_lanes_avx512(
    buf: &[Line],
    lanes: &mut [([usize; 3], SegState)],
    j0: usize,
    j1: usize,
) {
    macro_rules! group {
        ($n:literal, $l:expr) => {{
            let mut s: [SegState; $n] = std::array::from_fn(|q| $l[q].1);
            let o: [[usize; 3]; $n] = std::array::from_fn(|q| $l[q].0);
            // SAFETY: AVX-512F is available (caller contract).
            unsafe { block_lanes_avx512::<$n>(buf, o, j0, j1, &mut s) };
            for (q, sq) in s.iter().enumerate() {
                $l[q].1 = *sq;
            }
        }};
    }
    for l in lanes.chunks_mut(4) {
        match l.len() {
            1 => group!(1, l),
            2 => group!(2, l),
            3 => group!(3, l),
            _ => group!(4, l),
        }
    }
}

/// Advances the NSEG segment recurrences of a full chunk [a, a + NSEG·SEG) of scale m over the
/// columns of every segment (k = a + l·SEG + j) read in the windows j ∈ [jb − s, jb − s + 8) for
/// jb = j0, j0 + 8, … < j1 (plus the window at jb = SEG when j1 = SEG), skipping columns outside
/// [0, SEG): with `s` the misalignment of x[a] in elements (and m a multiple of 8) every load is
/// then 64-byte aligned. Eight segments per AVX-512 vector (one lane each), straight from `x`:
/// for every window the three input rows of each segment are loaded, y is formed row-wise
/// exactly as in [`seg_sum`], the 8 × 8 block is transposed in registers, and each lane then
/// performs acc ← fma(d, d, acc); d += y_k in increasing k: the operations of [`seg_sum`] in the
/// same order, so the results are bit-identical to the portable path whatever s and however the
/// columns are split into blocks.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[allow(clippy::too_many_arguments)]
unsafe fn block_avx512<const SEG: usize>(
    x: &[f64],
    m: usize,
    a: usize,
    s: usize,
    j0: usize,
    j1: usize,
    st: &mut SegState,
) {
    use std::arch::x86_64::*;
    const G8: usize = NSEG / 8;
    assert!(
        a >= 2 * m + s
            && a + (NSEG * SEG) + tail_reach(s) <= x.len()
            && s < 8
            && j0.is_multiple_of(8)
            && j1 <= SEG
    );
    // SAFETY: AVX-512F is available (caller contract). Every load reads x[k], x[k − m] and
    // x[k − 2m] for k in [a − s, a + NSEG·SEG + tail_reach(s)), inside `x` by the assertion above; the
    // state arrays hold NSEG = 8·G8 values.
    unsafe {
        let px = x.as_ptr();
        let mut dv = [_mm512_setzero_pd(); G8];
        let mut av = [_mm512_setzero_pd(); G8];
        for g in 0..G8 {
            dv[g] = _mm512_loadu_pd(st.d.as_ptr().add(8 * g));
            av[g] = _mm512_loadu_pd(st.acc.as_ptr().add(8 * g));
        }
        // the eight columns jb − s + c (c = 0..8) of rows 8g..8g + 8, transposed: lane r of
        // column c is y at k = a + (8g + r)·SEG + jb − s + c
        macro_rules! window {
            ($jb:expr, $g:expr) => {{
                let mut y = [_mm512_setzero_pd(); 8];
                for (r, yr) in y.iter_mut().enumerate() {
                    let k = a + (8 * $g + r) * SEG + $jb - s;
                    let xa = _mm512_loadu_pd(px.add(k));
                    let xb = _mm512_loadu_pd(px.add(k - m));
                    let xc = _mm512_loadu_pd(px.add(k - 2 * m));
                    *yr = _mm512_sub_pd(_mm512_sub_pd(xa, xb), _mm512_sub_pd(xb, xc));
                }
                transpose8x8!(y)
            }};
        }
        let mut jb = j0;
        while jb < j1 {
            let lo = if jb == 0 { s } else { 0 };
            for g in 0..G8 {
                let cols = window!(jb, g);
                if lo == 0 {
                    for c in cols {
                        av[g] = _mm512_fmadd_pd(dv[g], dv[g], av[g]);
                        dv[g] = _mm512_add_pd(dv[g], c);
                    }
                } else {
                    for &c in &cols[lo..] {
                        av[g] = _mm512_fmadd_pd(dv[g], dv[g], av[g]);
                        dv[g] = _mm512_add_pd(dv[g], c);
                    }
                }
            }
            jb += 8;
        }
        if j1 == SEG && s > 0 {
            for g in 0..G8 {
                let cols = window!(SEG, g);
                for &c in &cols[..s] {
                    av[g] = _mm512_fmadd_pd(dv[g], dv[g], av[g]);
                    dv[g] = _mm512_add_pd(dv[g], c);
                }
            }
        }
        for g in 0..G8 {
            _mm512_storeu_pd(st.d.as_mut_ptr().add(8 * g), dv[g]);
            _mm512_storeu_pd(st.acc.as_mut_ptr().add(8 * g), av[g]);
        }
    }
}

/// [`build_lanes_avx512`] (`W512`) or [`build_lanes_avx2`]: the same copy.
///
/// # Safety
/// The CPU must support AVX-512F (`W512`), else AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn build_lanes<const W512: bool, const SEG: usize>(
    x: &[f64],
    a: usize,
    halo: usize,
    dst: &mut [Line],
) {
    // SAFETY: caller contract.
    unsafe {
        if W512 {
            build_lanes_avx512::<SEG>(x, a, halo, dst)
        } else {
            build_lanes_avx2::<SEG>(x, a, halo, dst)
        }
    }
}

/// The 4 × 4 transpose of four AVX2 vectors (rows → columns): lane r of column c is lane c of
/// row r. Needs `std::arch::x86_64::*` in scope and AVX enabled at the use site.
#[cfg(target_arch = "x86_64")]
macro_rules! transpose4x4 {
    ($v:expr) => {{
        let v = $v;
        let t0 = _mm256_unpacklo_pd(v[0], v[1]);
        let t1 = _mm256_unpackhi_pd(v[0], v[1]);
        let t2 = _mm256_unpacklo_pd(v[2], v[3]);
        let t3 = _mm256_unpackhi_pd(v[2], v[3]);
        [
            _mm256_permute2f128_pd::<0x20>(t0, t2),
            _mm256_permute2f128_pd::<0x20>(t1, t3),
            _mm256_permute2f128_pd::<0x31>(t0, t2),
            _mm256_permute2f128_pd::<0x31>(t1, t3),
        ]
    }};
}

/// [`build_lanes_avx512`] with AVX2: the same lane-layout copy (`dst[2c + g]` holds, in lane r,
/// x[a + (8g + r)·SEG − halo + c]), from 4 × 4 transposes of rows.
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn build_lanes_avx2<const SEG: usize>(x: &[f64], a: usize, halo: usize, dst: &mut [Line]) {
    use std::arch::x86_64::*;
    let cols = halo + SEG;
    assert!(
        a >= halo
            && a + NSEG * SEG <= x.len()
            && NSEG == 16
            && halo.is_multiple_of(8)
            && dst.len() >= 2 * cols
    );
    // SAFETY: AVX2 is available (caller contract); the loads read x[a − halo + (4q + r)·SEG + c]
    // for c < cols, r < 4, q < 4, inside [a − halo, a + NSEG·SEG) (asserted); the stores write
    // the 32-byte halves of the aligned lines dst[2c + q/2] for c < cols (length asserted).
    unsafe {
        let px = x.as_ptr().add(a - halo);
        let pt = dst.as_mut_ptr().cast::<f64>();
        for q in 0..4 {
            let mut c0 = 0;
            while c0 < cols {
                let mut v = [_mm256_setzero_pd(); 4];
                for (r, vr) in v.iter_mut().enumerate() {
                    *vr = _mm256_loadu_pd(px.add((4 * q + r) * SEG + c0));
                }
                let col = transpose4x4!(v);
                for (cc, cv) in col.iter().enumerate() {
                    _mm256_store_pd(pt.add(8 * (2 * (c0 + cc) + q / 2) + 4 * (q % 2)), *cv);
                }
                c0 += 4;
            }
        }
    }
}

/// [`block_lanes_avx512`] with AVX2 and FMA (four vectors of four segments per column): the
/// operations of [`seg_sum`] in the same order, bit-identical.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn block_lanes_avx2<const N: usize>(
    buf: &[Line],
    offs: [[usize; 3]; N],
    j0: usize,
    j1: usize,
    st: &mut [SegState; N],
) {
    use std::arch::x86_64::*;
    assert!(j0 <= j1 && NSEG == 16 && offs.iter().flatten().all(|&o| 2 * (o + j1) <= buf.len()));
    // SAFETY: AVX2 and FMA are available (caller contract); the loads read the aligned halves
    // of the lines buf[2(o + j) + g/2] for j < j1, g < 4, inside `buf` (asserted).
    unsafe {
        let pt = buf.as_ptr().cast::<f64>();
        let mut d = [[_mm256_setzero_pd(); 4]; N];
        let mut acc = [[_mm256_setzero_pd(); 4]; N];
        for q in 0..N {
            for g in 0..4 {
                d[q][g] = _mm256_loadu_pd(st[q].d.as_ptr().add(4 * g));
                acc[q][g] = _mm256_loadu_pd(st[q].acc.as_ptr().add(4 * g));
            }
        }
        for j in j0..j1 {
            for q in 0..N {
                let [oa, ob, oc] = offs[q];
                for g in 0..4 {
                    let xa = _mm256_load_pd(pt.add(16 * (oa + j) + 4 * g));
                    let xb = _mm256_load_pd(pt.add(16 * (ob + j) + 4 * g));
                    let xc = _mm256_load_pd(pt.add(16 * (oc + j) + 4 * g));
                    let y = _mm256_sub_pd(_mm256_sub_pd(xa, xb), _mm256_sub_pd(xb, xc));
                    acc[q][g] = _mm256_fmadd_pd(d[q][g], d[q][g], acc[q][g]);
                    d[q][g] = _mm256_add_pd(d[q][g], y);
                }
            }
        }
        for q in 0..N {
            for g in 0..4 {
                _mm256_storeu_pd(st[q].d.as_mut_ptr().add(4 * g), d[q][g]);
                _mm256_storeu_pd(st[q].acc.as_mut_ptr().add(4 * g), acc[q][g]);
            }
        }
    }
}

/// Runs [`block_lanes_avx2`] for the scales given by their column offsets and states, two at
/// a time (16 state vectors: the AVX2 register file).
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn blocks_lanes_avx2(
    buf: &[Line],
    lanes: &mut [([usize; 3], SegState)],
    j0: usize,
    j1: usize,
) {
    macro_rules! group {
        ($n:literal, $l:expr) => {{
            let mut s: [SegState; $n] = std::array::from_fn(|q| $l[q].1);
            let o: [[usize; 3]; $n] = std::array::from_fn(|q| $l[q].0);
            // SAFETY: AVX2 and FMA are available (caller contract).
            unsafe { block_lanes_avx2::<$n>(buf, o, j0, j1, &mut s) };
            for (q, sq) in s.iter().enumerate() {
                $l[q].1 = *sq;
            }
        }};
    }
    for l in lanes.chunks_mut(AVX2_GROUP) {
        match l.len() {
            1 => group!(1, l),
            _ => group!(2, l),
        }
    }
}

/// Scales per instruction stream of [`blocks_lanes_avx2`] (1 or 2).
const AVX2_GROUP: usize = 2;

/// [`block_avx512`] with AVX2 and FMA, rows read unaligned from k = a: over the columns
/// [j0, j1) (multiples of 4) of the full chunk [a, a + NSEG·SEG) of scale m, for each window of
/// four columns the three input rows of each segment are loaded, y is formed row-wise as in
/// [`seg_sum`], each 4 × 4 block is transposed in registers, and each lane performs
/// acc ← fma(d, d, acc); d += y_k in increasing k: bit-identical to the portable path.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn block_avx2<const SEG: usize>(
    x: &[f64],
    m: usize,
    a: usize,
    j0: usize,
    j1: usize,
    st: &mut SegState,
) {
    use std::arch::x86_64::*;
    assert!(
        a >= 2 * m
            && a + NSEG * SEG <= x.len()
            && j0.is_multiple_of(4)
            && j1.is_multiple_of(4)
            && j1 <= SEG
    );
    // SAFETY: AVX2 and FMA are available (caller contract). Every load reads x[k], x[k − m] and
    // x[k − 2m] for k in [a, a + NSEG·SEG), inside `x` by the assertion above; the state arrays
    // hold NSEG = 16 values.
    unsafe {
        let px = x.as_ptr();
        let mut dv = [_mm256_setzero_pd(); 4];
        let mut av = [_mm256_setzero_pd(); 4];
        for g in 0..4 {
            dv[g] = _mm256_loadu_pd(st.d.as_ptr().add(4 * g));
            av[g] = _mm256_loadu_pd(st.acc.as_ptr().add(4 * g));
        }
        let mut jb = j0;
        while jb < j1 {
            for g in 0..4 {
                let mut y = [_mm256_setzero_pd(); 4];
                for (r, yr) in y.iter_mut().enumerate() {
                    let k = a + (4 * g + r) * SEG + jb;
                    let xa = _mm256_loadu_pd(px.add(k));
                    let xb = _mm256_loadu_pd(px.add(k - m));
                    let xc = _mm256_loadu_pd(px.add(k - 2 * m));
                    *yr = _mm256_sub_pd(_mm256_sub_pd(xa, xb), _mm256_sub_pd(xb, xc));
                }
                for c in transpose4x4!(y) {
                    av[g] = _mm256_fmadd_pd(dv[g], dv[g], av[g]);
                    dv[g] = _mm256_add_pd(dv[g], c);
                }
            }
            jb += 4;
        }
        for g in 0..4 {
            _mm256_storeu_pd(st.d.as_mut_ptr().add(4 * g), dv[g]);
            _mm256_storeu_pd(st.acc.as_mut_ptr().add(4 * g), av[g]);
        }
    }
}

/// Chunk partials of chunk `i` for every scale of `batch` (each as [`stream_chunk`] would
/// return it, bit for bit), with the AVX-512 block kernel: the chunk is walked in column blocks
/// of [`BLK`], all scales per block. Scales whose chunk is not full go through [`stream_chunk`].
/// `next`, when given, is the start of the chunk the caller runs next: its samples are
/// prefetched towards L2 one slice per column block, so that the requests are spread over the
/// chunk's work (the far grid's residue-class walk jumps FAR_M samples from chunk to chunk, out
/// of reach of the hardware prefetchers; on the far scales 2^21..2^25 of 10^8 samples, timed
/// alternately with and without: 104–108 ms → 94–97 ms including the checkpoint pass).
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn chunk_all_avx512<const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    batch: &[u64],
    i: usize,
    next: Option<usize>,
    scratch: &mut Scratch,
    out: &mut [f64],
) {
    // SAFETY: AVX-512F is available (caller contract).
    unsafe { chunk_all::<true, SEG>(x, ck, batch, i, next, scratch, out) }
}

/// [`chunk_all_avx512`] with AVX2 and FMA: the same walk (column blocks of [`BLK`], all scales
/// per block; the halo copy, the lane ring and the rows of x), four segments per vector
/// ([`build_lanes_avx2`], [`blocks_lanes_avx2`], [`block_avx2`]); the same values bit for bit.
///
/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn chunk_all_avx2<const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    batch: &[u64],
    i: usize,
    next: Option<usize>,
    scratch: &mut Scratch,
    out: &mut [f64],
) {
    // SAFETY: AVX2 and FMA are available (caller contract).
    unsafe { chunk_all::<false, SEG>(x, ck, batch, i, next, scratch, out) }
}

/// The body of [`chunk_all_avx512`] (`W512`) and [`chunk_all_avx2`].
///
/// # Safety
/// The CPU must support AVX-512F (`W512`), else AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn chunk_all<const W512: bool, const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    batch: &[u64],
    i: usize,
    next: Option<usize>,
    scratch: &mut Scratch,
    out: &mut [f64],
) {
    let t = x.len();
    let a = i * (NSEG * SEG);
    // misalignment (elements) of x[a] and of every row start (SEG is a multiple of 8); the
    // AVX2 rows are read unaligned from k = a
    let mis = (x.as_ptr().wrapping_add(a) as usize % 64) / 8;
    let shift = |m: usize| if W512 && m.is_multiple_of(8) { mis } else { 0 };
    let full = |m: usize| a >= 2 * m + shift(m) && a + (NSEG * SEG) + tail_reach(shift(m)) <= t;
    let chunk_full = a + NSEG * SEG <= t;
    // far walk: the lane-layout copy of this chunk goes to its ring slot (every full chunk of
    // the class, for the later chunks that lag back to it)
    let ring = match scratch.ring_pos {
        Some((tc, step)) if chunk_full && scratch.ring_slots > 0 => {
            let slot = tc % scratch.ring_slots;
            let dst = &mut scratch.ring[2 * SEG * slot..2 * SEG * (slot + 1)];
            // SAFETY: the vector level is available (caller contract); the chunk is full.
            unsafe { build_lanes::<W512, SEG>(x, a, 0, dst) };
            Some((tc, step))
        }
        _ => None,
    };
    // scales with 2m ≤ XH read the halo copy of the chunk, built once for all of them; far
    // scales that are whole class steps (m = q·step) read the ring; the others transpose in
    // registers
    let halo_ok = a >= XH && chunk_full;
    let slots = scratch.ring_slots;
    let halo_offs = |m: usize| (halo_ok && 2 * m <= XH).then(|| [XH, XH - m, XH - 2 * m]);
    let ring_offs = |m: usize| {
        let (tc, step) = ring?;
        let q = m / step;
        (m.is_multiple_of(step) && 2 * q <= tc && 2 * q < slots)
            .then(|| [tc, tc - q, tc - 2 * q].map(|v| (v % slots) * SEG))
    };
    let Scratch {
        states,
        regs,
        xt,
        halo,
        ring_lanes,
        ring: ring_buf,
        ..
    } = scratch;
    states.clear();
    regs.clear();
    halo.clear();
    ring_lanes.clear();
    for m in batch.iter().map(|&m| m as usize).filter(|&m| full(m)) {
        let mut d = [0.0f64; NSEG];
        for (l, dl) in d.iter_mut().enumerate() {
            *dl = d_start(x, ck, m, a + l * SEG);
        }
        let st = SegState {
            d,
            acc: [0.0f64; NSEG],
        };
        let at = if let Some(offs) = halo_offs(m) {
            halo.push((offs, st));
            StateAt::Halo(halo.len() - 1)
        } else if let Some(offs) = ring_offs(m) {
            ring_lanes.push((offs, st));
            StateAt::Ring(ring_lanes.len() - 1)
        } else {
            regs.push((m, st));
            StateAt::Regs(regs.len() - 1)
        };
        states.push(at);
    }
    if !halo.is_empty() {
        if xt.len() < 2 * (XH + SEG) {
            xt.resize(2 * (XH + SEG), Line::default());
        }
        // SAFETY: the vector level is available (caller contract); a ≥ XH, the chunk is full.
        unsafe { build_lanes::<W512, SEG>(x, a, XH, xt) };
    }
    // the samples of `next`, in one slice per column block (a hint only: no effect on values)
    let per_blk = NSEG * BLK;
    for j0 in (0..SEG).step_by(BLK) {
        if let Some(nx) = next {
            use std::arch::x86_64::{_MM_HINT_T1, _mm_prefetch};
            let lo = nx + (j0 / BLK) * per_blk;
            let mut p = lo;
            while p < (lo + per_blk).min(t) {
                // SAFETY: a hint that never faults; `wrapping_add` keeps the address defined
                // past the end
                unsafe { _mm_prefetch::<_MM_HINT_T1>(x.as_ptr().wrapping_add(p).cast()) };
                p += 8;
            }
        }
        if W512 {
            // SAFETY: AVX-512F is available (caller contract); the halo copy was built above.
            unsafe { blocks_lanes_avx512(xt, halo, j0, j0 + BLK) };
            // SAFETY: AVX-512F is available; this chunk's copy was built above, and the lagged
            // ones when the walk visited their chunks (2q ≤ t, 2q < slots).
            unsafe { blocks_lanes_avx512(ring_buf, ring_lanes, j0, j0 + BLK) };
            for (m, st) in regs.iter_mut() {
                // SAFETY: AVX-512F is available (caller contract); the chunk is full for m.
                unsafe { block_avx512::<SEG>(x, *m, a, shift(*m), j0, j0 + BLK, st) };
            }
        } else {
            // SAFETY: AVX2 and FMA are available (caller contract); the copies as above.
            unsafe { blocks_lanes_avx2(xt, halo, j0, j0 + BLK) };
            // SAFETY: as above.
            unsafe { blocks_lanes_avx2(ring_buf, ring_lanes, j0, j0 + BLK) };
            for (m, st) in regs.iter_mut() {
                // SAFETY: AVX2 and FMA are available (caller contract); the chunk is full for m.
                unsafe { block_avx2::<SEG>(x, *m, a, j0, j0 + BLK, st) };
            }
        }
    }
    let mut done = states.iter();
    for (o, &m) in out.iter_mut().zip(batch) {
        let m = m as usize;
        *o = if full(m) {
            let st = match done.next().expect("one state per full scale") {
                StateAt::Regs(k) => &regs[*k].1,
                StateAt::Halo(k) => &halo[*k].1,
                StateAt::Ring(k) => &ring_lanes[*k].1,
            };
            reduce_lanes(&st.acc)
        } else {
            stream_chunk::<SEG>(x, ck, m, i, SimdLevel::Scalar)
        };
    }
}

/// Chunk partial for scale m over chunk `i` of the k-grid, streamed from `x`: each SEG-segment
/// of k starts from an exact d (checkpoints) and carries the recurrence; the NSEG segment sums
/// are reduced by the fixed tree.
#[inline(always)]
fn stream_chunk<const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    m: usize,
    i: usize,
    simd: SimdLevel,
) -> f64 {
    let t = x.len();
    let a = i * (NSEG * SEG);
    let mut acc = [0.0f64; NSEG];
    #[cfg(target_arch = "x86_64")]
    if simd != SimdLevel::Scalar && a >= 2 * m && a + (NSEG * SEG) <= t {
        let mut d0 = [0.0f64; NSEG];
        for (l, d) in d0.iter_mut().enumerate() {
            *d = d_start(x, ck, m, a + l * SEG);
        }
        crate::simd::note(simd);
        let mut st = SegState { d: d0, acc };
        if simd == SimdLevel::Avx512 {
            // SAFETY: `simd` is at most `simd::level()` (the callers pass it or, in tests, a
            // lower level), so AVX-512F is present; the range is checked above.
            unsafe { block_avx512::<SEG>(x, m, a, 0, 0, SEG, &mut st) };
        } else {
            // SAFETY: `simd` ≤ `simd::level()` (see above): AVX2 and FMA are present; the range
            // is checked above.
            unsafe { block_avx2::<SEG>(x, m, a, 0, SEG, &mut st) };
        }
        return reduce_lanes(&st.acc);
    }
    let _ = simd;
    if a >= 2 * m && a + (NSEG * SEG) <= t {
        // a full chunk: the NSEG segments in lockstep (independent chains, so that their
        // latencies overlap), each lane the operations of [`seg_sum`] in the same order
        let mut d = [0.0f64; NSEG];
        for (l, dl) in d.iter_mut().enumerate() {
            *dl = d_start(x, ck, m, a + l * SEG);
        }
        for j in 0..SEG - 1 {
            for l in 0..NSEG {
                let k = a + l * SEG + j;
                acc[l] = d[l].mul_add(d[l], acc[l]);
                d[l] += (x[k] - x[k - m]) - (x[k - m] - x[k - 2 * m]);
            }
        }
        for l in 0..NSEG {
            acc[l] = d[l].mul_add(d[l], acc[l]);
        }
        return reduce_lanes(&acc);
    }
    for (l, al) in acc.iter_mut().enumerate() {
        let s = (a + l * SEG).max(2 * m);
        let e = (a + (l + 1) * SEG).min(t + 1);
        if s < e {
            *al = seg_sum(x, d_start(x, ck, m, s), m, s, e);
        }
    }
    reduce_lanes(&acc)
}

/// Σ_{k=2m}^{T} (C_k − 2C_{k−m} + C_{k−2m})² for each m in `ms`, streamed from the rate
/// samples `x` (no series-sized buffer), and the mean of the samples. Deterministic for any
/// thread count and any set of requested scales: the value for m is the Neumaier sum, in chunk
/// order, of chunk partials that depend only on (x, m, chunk); the chunk grid depends only on m
/// ([`SEG_NEAR`] for 2m ≤ [`FAR_M`], [`SEG_FAR`] above), and so do the checkpoints that start its
/// segments (see [`stream_near`]). Errors on non-finite samples (naming the first) and on
/// overflow.
pub(crate) fn overlapping_sums_stream(x: &[f64], ms: &[u64]) -> Result<(Vec<f64>, f64), AvarError> {
    overlapping_sums_stream_io(x, ms, &Io::NONE)
}

/// [`overlapping_sums_stream`] talking to a source: `release` is called on the ranges of
/// samples the near walk is done with (chunk by chunk, behind the warm-up reach) and on the
/// chunks of each residue class of the far walk when the class ends; with windows, each job of
/// the far walk reads its chunks (and their lagged blocks where the lane ring does not hold
/// them) into its own window instead of `x`. The values are those of
/// [`overlapping_sums_stream`], bit for bit (the same samples reach the same operations).
pub(crate) fn overlapping_sums_stream_io(
    x: &[f64],
    ms: &[u64],
    io: &Io<'_>,
) -> Result<(Vec<f64>, f64), AvarError> {
    let job_chunks = job_chunks(x.len());
    overlapping_sums_stream_split(x, ms, far_m(x.len()), job_chunks, crate::simd::level(), io)
        .map(|(sums, mean, _)| (sums, mean))
}

/// Near chunks per job of the near walk for T samples: jobs of equal length, about
/// [`JOB_CHUNKS`] chunks each but at least [`MIN_JOBS`] of them, so that shorter series still
/// spread over the threads. A function of T only (the checkpoint frames, hence the sums, must
/// not depend on the thread count).
fn job_chunks(t: usize) -> usize {
    let n_chunks = (t + 1).div_ceil(NSEG * SEG_NEAR);
    let jobs = n_chunks.div_ceil(JOB_CHUNKS).max(MIN_JOBS);
    n_chunks.div_ceil(jobs).max(1)
}

/// Fewest jobs of the near walk (see [`job_chunks`]).
const MIN_JOBS: usize = 8;

/// [`overlapping_sums_stream`] that also hands back the checkpoints of the far walk (the
/// global frame, pivot-centred: C_p = Σ_{i<p} (x_i − pivot)), when there were far scales; `None`
/// otherwise (the near walk keeps none of its own). TOTVAR's reflected ends read the phase
/// from them instead of summing the series once more.
pub(crate) fn overlapping_sums_stream_checkpoints(
    x: &[f64],
    ms: &[u64],
) -> Result<(Vec<f64>, Option<Checkpoints>), AvarError> {
    let (sums, _, ck) = overlapping_sums_stream_split(
        x,
        ms,
        far_m(x.len()),
        job_chunks(x.len()),
        crate::simd::level(),
        &Io::NONE,
    )?;
    Ok((sums, ck.far.is_some().then_some(ck)))
}

/// [`overlapping_sums_stream`] with the near/far threshold and the job length as parameters:
/// scales with 2m > `far_m` take the far grid and the residue-class walk of step `far_m`; the
/// near walk runs in jobs of `job_chunks` near chunks with a warm-up of `far_m` samples (tests
/// use small values to cover those paths on short series), and the vector kernel `simd`.
/// Returns the sums, the mean and the far walk's global checkpoints (see
/// [`overlapping_sums_stream_checkpoints`]).
fn overlapping_sums_stream_split(
    x: &[f64],
    ms: &[u64],
    far_m: usize,
    job_chunks: usize,
    simd: SimdLevel,
    io: &Io<'_>,
) -> Result<(Vec<f64>, f64, Checkpoints), AvarError> {
    // never above the process's level (the vector paths' safety rests on it)
    let simd = simd.min(crate::simd::level());
    crate::simd::note(SimdLevel::Scalar);
    let release = io.release;
    let mut out = vec![0.0f64; ms.len()];
    let (near, far): (Vec<usize>, Vec<usize>) =
        (0..ms.len()).partition(|&s| 2 * ms[s] as usize <= far_m);
    let pivot = pivot_of(x);
    // the far walk's checkpoints, filled by the near jobs as they end
    let mut loc = if far.is_empty() {
        Vec::new()
    } else {
        vec![(0.0f64, 0.0f64); (x.len().div_ceil(G) + 1).div_ceil(2)]
    };
    let jobs = stream_near(
        x, pivot, ms, &near, far_m, job_chunks, simd, release, &mut loc, &mut out,
    );
    if !pivot.is_finite() || jobs.iter().any(|j| j.bad) {
        if let Some((index, value)) = first_non_finite(x) {
            return Err(AvarError::NonFinite { index, value });
        }
        return Err(AvarError::Overflow);
    }
    let (ck, total) = global_checkpoints(x, pivot, jobs, job_chunks * NSEG * SEG_NEAR, loc);
    if !total.is_finite() {
        return Err(AvarError::Overflow);
    }
    stream_group::<SEG_FAR>(x, &ck, ms, &far, far_m, simd, io, &mut out);
    release(0, x.len());
    Ok((out, pivot + total / x.len() as f64, ck))
}

/// Target near chunks per job of the near walk ([`stream_near`], [`job_chunks`]): 480 chunks of
/// 17 408 samples, 8.4 M samples (12 jobs at T = 10^8), so that the warm-up of [`FAR_M`] samples
/// adds 12.5 % to the checkpoint sums and the jobs still balance over the threads.
const JOB_CHUNKS: usize = 480;

/// One job of the near walk: its checkpoints in a local frame (origin at the job start A, where
/// C = 0, and pivot-only centring), from A − warm-up to the job end B.
struct NearJob {
    ck: Checkpoints,
    /// Index (units of G) of the job start A.
    g_a: usize,
    /// Whether a block sum was not finite.
    bad: bool,
    /// After [`NearJob::compact`] (`ck` is then empty): the entry at the job end.
    end: Option<(f64, f64)>,
}

impl NearJob {
    /// The local entry at the job end B = min((j + 1)·`job_len`, T) (rounded up to G).
    fn end(&self, x: &[f64], job_len: usize, j: usize) -> (f64, f64) {
        self.end
            .unwrap_or_else(|| self.ck.get(x, ((j + 1) * job_len).min(x.len()).div_ceil(G)))
    }

    /// Keeps only what the far walk and the totals need: the even entries of the job's own
    /// range [A, next job's A), written to `dst` (its part of [`FarFrames::loc`]; empty when
    /// there are no far scales), and its end entry; frees the rest, so that the whole-series
    /// checkpoints take 16 bytes per 128 samples while the near walk runs, not 16 per 64 per
    /// job plus warm-up.
    fn compact(&mut self, x: &[f64], job_len: usize, j: usize, dst: &mut [(f64, f64)]) {
        if self.end.is_some() {
            return;
        }
        let end = self.end(x, job_len, j);
        for (k, d) in dst.iter_mut().enumerate() {
            *d = self.ck.get(x, self.g_a + 2 * k);
        }
        self.end = Some(end);
        self.ck.ck = Vec::new();
    }
}

/// The parts of [`FarFrames::loc`] (16 bytes per 128 samples, up to the last index ⌈T/G⌉)
/// that each of `n_jobs` near jobs of `job_len` samples fills; all empty when `loc` is.
fn loc_parts(loc: &mut [(f64, f64)], n_jobs: usize, job_len: usize) -> Vec<&mut [(f64, f64)]> {
    let mut parts = Vec::with_capacity(n_jobs);
    let mut rest = loc;
    for j in 0..n_jobs {
        let n = if j + 1 == n_jobs {
            rest.len()
        } else {
            (job_len / G / 2).min(rest.len())
        };
        let (a, b) = std::mem::take(&mut rest).split_at_mut(n);
        parts.push(a);
        rest = b;
    }
    parts
}

/// Starts the local checkpoints of a job at sample `a` (a multiple of G) and of `len` samples:
/// entries from (a − warm) / G up to a / G, summed backwards from C_a = 0.
fn job_checkpoints(x: &[f64], pivot: f64, a: usize, warm: usize, len: usize) -> NearJob {
    let (g_w, g_a) = (a.saturating_sub(warm) / G, a / G);
    let mut ck = Vec::with_capacity(g_a - g_w + 2 + len.min(x.len() - a) / G);
    ck.resize(g_a - g_w + 1, (0.0f64, 0.0f64));
    let mut bad = false;
    let mut run = Neumaier::default();
    for g in (g_w..g_a).rev() {
        let b = lane_sum(&x[g * G..(g + 1) * G], pivot);
        bad |= !b.is_finite();
        run.add(-b);
        ck[g - g_w] = (run.hi, run.lo);
    }
    NearJob {
        ck: Checkpoints {
            pivot,
            delta: 0.0,
            mean: f64::NAN,
            g0: g_w,
            ck,
            far: None,
        },
        g_a,
        bad,
        end: None,
    }
}

/// Extends the job's checkpoints forwards to index ⌈min(upto, T)/G⌉ (the last entry is C_T).
fn job_extend(x: &[f64], job: &mut NearJob, upto: usize) {
    let t = x.len();
    let g_end = upto.min(t).div_ceil(G);
    let ck = &mut job.ck;
    let mut g = ck.g0 + ck.ck.len() - 1;
    let (hi, lo) = ck.ck[ck.ck.len() - 1];
    let mut run = Neumaier { hi, lo };
    while g < g_end {
        let b = lane_sum(&x[g * G..((g + 1) * G).min(t)], ck.pivot);
        job.bad |= !b.is_finite();
        run.add(b);
        ck.ck.push((run.hi, run.lo));
        g += 1;
    }
}

/// The near scales `ms[s]`, s in `near`, written to `out[s]`, on the [`SEG_NEAR`] grid, in one
/// pass that also builds the checkpoints: the chunks are cut into jobs of `job_chunks`, run in
/// parallel, each walking its chunks in order and summing the blocks of a chunk (now in cache)
/// just before running its scales. A job's segment starts read checkpoints of its own local
/// frame, which reaches `warm` samples back (every near scale has 2m ≤ warm): a fixed function
/// of (x, job grid), so the sums stay deterministic. Returns the jobs' checkpoints.
#[allow(clippy::too_many_arguments)]
fn stream_near(
    x: &[f64],
    pivot: f64,
    ms: &[u64],
    near: &[usize],
    warm: usize,
    job_chunks: usize,
    simd: SimdLevel,
    release: Release<'_>,
    loc: &mut [(f64, f64)],
    out: &mut [f64],
) -> Vec<NearJob> {
    let schunk = NSEG * SEG_NEAR;
    let n_chunks = (x.len() + 1).div_ceil(schunk);
    let n_jobs = n_chunks.div_ceil(job_chunks);
    let batches: Vec<Vec<usize>> = near.chunks(SCALE_BATCH).map(<[usize]>::to_vec).collect();
    let scales = |idx: &[usize]| -> Vec<u64> { idx.iter().map(|&s| ms[s]).collect() };
    let first = scales(batches.first().map_or(&[], |b| b));
    let range = |j: usize| j * job_chunks..((j + 1) * job_chunks).min(n_chunks);
    // the samples job j read: its chunks and the warm-up before them
    let start = |j: usize| (range(j).start * schunk).saturating_sub(warm);
    let done = |j: usize| release(start(j), range(j).end * schunk);
    // the first batch of scales runs while the checkpoints are built
    let w = first.len();
    let single = batches.len() <= 1;
    let dsts = loc_parts(&mut *loc, n_jobs, job_chunks * schunk);
    let (mut jobs, parts): (Vec<NearJob>, Vec<Vec<f64>>) = dsts
        .into_par_iter()
        .enumerate()
        .map_init(Scratch::new::<SEG_NEAR>, |scratch, (j, dst)| {
            let mut job =
                job_checkpoints(x, pivot, range(j).start * schunk, warm, job_chunks * schunk);
            let c0 = range(j).start;
            let mut parts = vec![0.0f64; range(j).len() * w];
            for i in range(j) {
                job_extend(x, &mut job, (i + 1) * schunk);
                let out = &mut parts[(i - c0) * w..(i - c0 + 1) * w];
                chunk_run::<SEG_NEAR>(x, &job.ck, &first, i, simd, scratch, None, out);
                // the job's later chunks read back at most `warm` samples
                release(
                    start(j).max((i * schunk).saturating_sub(warm)),
                    ((i + 1) * schunk).saturating_sub(warm),
                );
            }
            done(j);
            if single {
                job.compact(x, job_chunks * schunk, j, dst);
            }
            (job, parts)
        })
        .unzip();
    let mut parts = parts.concat();
    for (b, idx) in batches.iter().enumerate() {
        let batch = scales(idx);
        let w = batch.len();
        if b > 0 {
            parts = (0..n_jobs)
                .into_par_iter()
                .map_init(Scratch::new::<SEG_NEAR>, |scratch, j| {
                    let mut parts = vec![0.0f64; range(j).len() * w];
                    for (i, out) in range(j).zip(parts.chunks_exact_mut(w)) {
                        chunk_run::<SEG_NEAR>(x, &jobs[j].ck, &batch, i, simd, scratch, None, out);
                        release(
                            start(j).max((i * schunk).saturating_sub(warm)),
                            ((i + 1) * schunk).saturating_sub(warm),
                        );
                    }
                    done(j);
                    parts
                })
                .collect::<Vec<_>>()
                .concat();
        }
        combine(&parts, &batch, schunk, idx, out);
    }
    if !single {
        let dsts = loc_parts(loc, n_jobs, job_chunks * schunk);
        for (j, (job, dst)) in jobs.iter_mut().zip(dsts).enumerate() {
            job.compact(x, job_chunks * schunk, j, dst);
        }
    }
    jobs
}

/// The checkpoints of the whole series in one frame (origin 0, pivot-only centring), in the
/// compact form of [`FarFrames`]: `loc` (the jobs' local even entries, filled by
/// [`NearJob::compact`]; empty without far scales) and each job's base, the compensated sum
/// of the earlier jobs' totals; and the total Σ (x_i − pivot).
fn global_checkpoints(
    x: &[f64],
    pivot: f64,
    jobs: Vec<NearJob>,
    job_len: usize,
    loc: Vec<(f64, f64)>,
) -> (Checkpoints, f64) {
    let mut bases = Vec::with_capacity(jobs.len());
    let mut run = Neumaier::default();
    for (j, job) in jobs.iter().enumerate() {
        bases.push((run.hi, run.lo));
        let (hi, lo) = job.end(x, job_len, j);
        run.add(hi);
        run.add(lo);
    }
    drop(jobs);
    let far = (!loc.is_empty()).then_some(FarFrames {
        job_g: job_len / G,
        bases,
        loc,
    });
    let ck = Checkpoints {
        pivot,
        delta: 0.0,
        mean: f64::NAN,
        g0: 0,
        ck: Vec::new(),
        far,
    };
    (ck, run.value())
}

/// Where the segment state of a scale lives during the vector chunk walk ([`chunk_all_avx512`], [`chunk_all_avx2`]).
enum StateAt {
    /// At this index of the scales transposing in registers ([`Scratch::regs`]).
    Regs(usize),
    /// At this index of the scales reading the halo copy ([`Scratch::halo`]).
    Halo(usize),
    /// At this index of the scales reading the ring ([`Scratch::ring_lanes`]).
    Ring(usize),
}

/// Per-thread scratch of the chunk kernels (reused from chunk to chunk).
struct Scratch {
    /// Where the segment state of each full scale of the vector chunk walk lives, in batch order.
    states: Vec<StateAt>,
    /// Scales (and states) that transpose their rows in registers ([`block_avx512`]).
    regs: Vec<(usize, SegState)>,
    /// The halo copy of the chunk ([`build_lanes_avx512`]).
    xt: Vec<Line>,
    /// Column offsets and states of the scales that read `xt`, and of those that read `ring`.
    halo: Vec<([usize; 3], SegState)>,
    ring_lanes: Vec<([usize; 3], SegState)>,
    /// Far walk: lane copies of the chunks of the current residue class, chunk t of the class in
    /// slot t mod `ring_slots` (0: no ring).
    ring: Vec<Line>,
    ring_slots: usize,
    /// Far walk: (index t of the current chunk in its class, class step in samples).
    ring_pos: Option<(usize, usize)>,
}

impl Scratch {
    fn new<const SEG: usize>() -> Scratch {
        Scratch {
            states: Vec::with_capacity(SCALE_BATCH),
            regs: Vec::with_capacity(SCALE_BATCH),
            xt: Vec::new(),
            halo: Vec::new(),
            ring_lanes: Vec::new(),
            ring: Vec::new(),
            ring_slots: 0,
            ring_pos: None,
        }
    }

    /// A ring of `slots` lane copies of SEG-grid chunks (see [`stream_group`]).
    fn with_ring<const SEG: usize>(slots: usize) -> Scratch {
        let mut s = Scratch::new::<SEG>();
        s.ring = vec![Line::default(); 2 * SEG * slots];
        s.ring_slots = slots;
        s
    }
}

/// Chunk partials of chunk `i` on the grid of segment length SEG for every scale of `batch`,
/// written to `out` (the AVX-512 or AVX2 chunk walk, or [`stream_chunk`] per scale). `next`: see
/// [`chunk_all_avx512`].
#[inline]
#[allow(clippy::too_many_arguments)]
fn chunk_run<const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    batch: &[u64],
    i: usize,
    simd: SimdLevel,
    scratch: &mut Scratch,
    next: Option<usize>,
    out: &mut [f64],
) {
    #[cfg(target_arch = "x86_64")]
    match simd {
        SimdLevel::Avx512 => {
            crate::simd::note(simd);
            // SAFETY: `simd` is at most `simd::level()` (see [`stream_chunk`]): AVX-512F present.
            unsafe { chunk_all_avx512::<SEG>(x, ck, batch, i, next, scratch, out) };
            return;
        }
        SimdLevel::Avx2 => {
            crate::simd::note(simd);
            // SAFETY: as above: AVX2 and FMA present.
            unsafe { chunk_all_avx2::<SEG>(x, ck, batch, i, next, scratch, out) };
            return;
        }
        SimdLevel::Scalar => {}
    }
    let _ = next;
    for (o, &m) in out.iter_mut().zip(batch) {
        *o = stream_chunk::<SEG>(x, ck, m as usize, i, simd);
    }
}

/// out[s] = Neumaier sum, in chunk order, of the chunk partials `parts[i·w + s]` (w = batch
/// width) over the chunks i ≥ 2m / schunk (those that hold terms of scale m = `batch[s]`).
fn combine(parts: &[f64], batch: &[u64], schunk: usize, idx: &[usize], out: &mut [f64]) {
    let w = batch.len();
    for (s, (&o, &m)) in idx.iter().zip(batch).enumerate() {
        let mut acc = Neumaier::default();
        for part in parts.chunks_exact(w).skip((2 * m as usize) / schunk) {
            acc.add(part[s]);
        }
        out[o] = acc.value();
    }
}

/// Asks the cache hierarchy for what the chunk [a, a + len) of the far grid will read first:
/// its samples (towards L2) and the checkpoints that its segment starts look up for every scale
/// of `batch` (at a, a − m and a − 2m). The residue-class walk jumps too far for the hardware
/// prefetchers, and these reads are otherwise cache misses. Hints only: no effect on any value.
#[inline]
fn prefetch_next(x: &[f64], ck: &Checkpoints, a: usize, len: usize, batch: &[u64]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _MM_HINT_T1, _mm_prefetch};
        // prefetch is a hint and never faults; `wrapping_add` keeps the address computation
        // defined (the ranges are clamped to the buffers anyway)
        let mut p = a;
        while p < x.len().min(a + len) {
            // SAFETY: see above.
            unsafe { _mm_prefetch::<_MM_HINT_T1>(x.as_ptr().wrapping_add(p).cast()) };
            p += 8;
        }
        // the entries of g in [p, p + len) / G: every one, or every other in the compact form
        let (entries, g0, per) = match &ck.far {
            None => (&ck.ck, ck.g0, 1),
            Some(f) => (&f.loc, 0, 2),
        };
        let n = entries.len();
        let ck_range = |p: usize| {
            let mut g = (p / G).saturating_sub(g0) / per;
            while g < ((p + len) / G).saturating_sub(g0).div_ceil(per).min(n) {
                // SAFETY: see above.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(entries.as_ptr().wrapping_add(g).cast()) };
                g += 4;
            }
        };
        ck_range(a);
        for &m in batch {
            let m = m as usize;
            if a >= 2 * m {
                ck_range(a - m);
                ck_range(a - 2 * m);
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (x, ck, a, len, batch);
}

/// The sums for the scales `ms[s]`, s in `group`, on the chunk grid of segment length SEG,
/// written to `out[s]`. With `residue_step = Some(r)` the chunks are walked by residue class of
/// the chunk index modulo r / (NSEG·SEG): for the far grid (NSEG·SEG a power of two dividing r)
/// and dyadic m ≥ r, the lagged blocks a − m and a − 2m are then exactly members of the same
/// class visited m/r and 2m/r steps earlier, still in cache (L2 for the far grid), so that
/// each far block is read from main memory about once for all far scales.
#[allow(clippy::too_many_arguments)]
fn stream_group<const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    ms: &[u64],
    group: &[usize],
    residue_step: usize,
    simd: SimdLevel,
    io: &Io<'_>,
    out: &mut [f64],
) {
    let schunk = NSEG * SEG;
    let n_chunks = (x.len() + 1).div_ceil(schunk);
    let n_cls = (residue_step / schunk).clamp(1, n_chunks);
    for idx in group.chunks(SCALE_BATCH) {
        let batch: Vec<u64> = idx.iter().map(|&s| ms[s]).collect();
        let w = batch.len();
        // lane copies of the class's chunks, back to the largest lag 2m = 2q·step of a scale
        // that is a whole number q of class steps (vector walks only)
        let step = n_cls * schunk;
        let q_max = batch
            .iter()
            .map(|&m| m as usize)
            .filter(|m| m.is_multiple_of(step))
            .map(|m| m / step)
            .max()
            .unwrap_or(0);
        let slots = if simd >= SimdLevel::Avx2 && q_max > 0 {
            2 * q_max + 1
        } else {
            0
        };
        // each class walks its chunks in order, writing their partials to its own buffer
        let t = x.len();
        // whether chunk a (the tc-th of its class) reads the lagged samples of scale m from x:
        // all but the scales the vector walks take from the lane ring (conservative: reading
        // more into a window is harmless)
        let lags_from_x = |m: usize, a: usize, tc: usize| {
            let q = m / step;
            !(simd >= SimdLevel::Avx2
                && slots > 0
                && m.is_multiple_of(step)
                && 2 * q <= tc
                && 2 * q < slots
                && a >= 2 * m + 8
                && a + schunk + 8 <= t)
        };
        // each class sums its chunks' partials in chunk order (Neumaier, per scale, only the
        // chunks that hold terms of the scale); the class totals are added in class order
        // below. A fixed order (the classes depend on T and the grid, not on the threads),
        // and no table of partials: that was 8 bytes per far scale and 2048 samples
        // (35 MiB at 10^9 samples)
        let first_chunk: Vec<usize> = batch.iter().map(|&m| (2 * m as usize) / schunk).collect();
        //
        // One worker per thread, each with its scratch (lane ring) and window made once, takes
        // the classes in turn from a counter: a window's pages are faulted in once and at
        // most one window and ring per thread are alive (rayon's `map_init` made new ones for
        // every split of the range: 16 windows at 10^9 samples, ~100 MiB resident at once)
        let n_workers = rayon::current_num_threads().clamp(1, n_cls);
        let next_class = std::sync::atomic::AtomicUsize::new(0);
        let walk_class = |scratch: &mut Scratch,
                          win: &mut Option<Box<dyn SampleWindow + '_>>,
                          r: usize|
         -> Vec<Neumaier> {
            let mut sums = vec![Neumaier::default(); w];
            let mut part = vec![0.0f64; w];
            let walk = (r..n_chunks).step_by(n_cls);
            if let Some(win) = win {
                win.rebase(r * schunk, step);
            }
            for (tc, i) in walk.enumerate() {
                let out = &mut part[..];
                scratch.ring_pos = Some((tc, step));
                let next = (i + n_cls) * schunk;
                let a = i * schunk;
                let xs: &[f64] = match win {
                    None => x,
                    Some(win) => {
                        // the chunk (with the reach of the local sums before it and
                        // of the vector tail after it), and the lagged blocks
                        let reach = |lo: usize| (lo.saturating_sub(2 * G), lo + schunk + 8);
                        let (lo, hi) = reach(a);
                        win.fill(lo, hi);
                        // only the scales whose partial of this chunk is kept (chunks
                        // before a scale's first term are summed for none of its terms:
                        // reading their lagged blocks cost a third of the reads at 10^9)
                        for (&m, &first) in batch.iter().zip(&first_chunk) {
                            let m = m as usize;
                            if i >= first && lags_from_x(m, a, tc) {
                                for lag in [m, 2 * m] {
                                    if a + schunk > lag {
                                        let (lo, hi) = reach(a.saturating_sub(lag));
                                        win.fill(lo, hi);
                                    }
                                }
                            }
                        }
                        win.view()
                    }
                };
                prefetch_next(xs, ck, next, schunk, &batch);
                chunk_run::<SEG>(xs, ck, &batch, i, simd, scratch, Some(next), out);
                for ((acc, &p), &first) in sums.iter_mut().zip(&part).zip(&first_chunk) {
                    if i >= first {
                        acc.add(p);
                    }
                }
            }
            match win {
                Some(win) => win.clear(),
                None => {
                    for i in (r..n_chunks).step_by(n_cls) {
                        (io.release)(i * schunk, (i + 1) * schunk);
                    }
                }
            }
            sums
        };
        let done: Vec<Vec<(usize, Vec<Neumaier>)>> = (0..n_workers)
            .into_par_iter()
            .map(|_| {
                let mut scratch = Scratch::with_ring::<SEG>(slots);
                let mut win = (io.windows)();
                let mut done = Vec::new();
                loop {
                    let r = next_class.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    if r >= n_cls {
                        break done;
                    }
                    done.push((r, walk_class(&mut scratch, &mut win, r)));
                }
            })
            .collect();
        let mut by_class = vec![Vec::new(); n_cls];
        for (r, sums) in done.into_iter().flatten() {
            by_class[r] = sums;
        }
        for (s, &o) in idx.iter().enumerate() {
            let mut acc = Neumaier::default();
            for class in &by_class {
                acc.add(class[s].hi);
                acc.add(class[s].lo);
            }
            out[o] = acc.value();
        }
    }
}

/// The full centred cumulative sum (T + 1 entries) written into `c` from the checkpoints.
pub(crate) fn prefix_from_checkpoints(x: &[f64], ck: &Checkpoints, c: &mut Vec<f64>) {
    let t = x.len();
    c.clear();
    c.reserve(t + 1);
    let spare = &mut c.spare_capacity_mut()[..t + 1];
    spare[0].write(0.0);
    spare[1..]
        .par_chunks_mut(PCHUNK)
        .enumerate()
        .for_each(|(i, out)| prefix_chunk(x, ck, i, out));
    // SAFETY: the loop above wrote all t + 1 elements (index 0, then every chunk of
    // `spare[1..]` in full: `prefix_chunk` writes one value per sample of its chunk).
    unsafe { c.set_len(t + 1) };
}

/// C_k for the samples of PCHUNK-chunk `i` (k = i·PCHUNK + 1 ..= i·PCHUNK + its length),
/// written to `out` (as long as the chunk): from the checkpoint at the chunk start, a running
/// compensated sum of local sums of 8 centred samples. Every stored C_k is a deterministic
/// function of k and the checkpoints, whichever range of chunks is rebuilt.
#[inline]
fn prefix_chunk(x: &[f64], ck: &Checkpoints, i: usize, out: &mut [std::mem::MaybeUninit<f64>]) {
    let (pivot, delta) = (ck.pivot, ck.delta);
    let xs = &x[i * PCHUNK..((i + 1) * PCHUNK).min(x.len())];
    debug_assert_eq!(out.len(), xs.len());
    let (hi, lo) = ck.get(x, i * (PCHUNK / G));
    let mut run = Neumaier { hi, lo };
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
}

/// The centred cumulative sum C_k for k in [k0, k_hi] written to `c` (its allocation is
/// reused), with the same values as [`prefix_from_checkpoints`] (the same checkpoints from
/// [`checkpoints`]), bit for bit: the whole chunks that hold k_lo ..= k_hi are rebuilt, so k0 ≤
/// k_lo is 0 or a chunk start. Returns k0 (`c[k − k0]` = C_k). Needs k_lo ≤ k_hi ≤ T.
pub(crate) fn prefix_window(
    x: &[f64],
    ck: &Checkpoints,
    k_lo: usize,
    k_hi: usize,
    c: &mut Vec<f64>,
) -> usize {
    let t = x.len();
    debug_assert!(k_lo <= k_hi && k_hi <= t);
    c.clear();
    if k_hi == 0 {
        c.push(0.0);
        return 0;
    }
    // C_k (k ≥ 1) lies in chunk (k − 1) / PCHUNK; C_0 = 0 is not in any chunk
    let i0 = k_lo.saturating_sub(1) / PCHUNK;
    let k0 = if k_lo == 0 { 0 } else { 1 + i0 * PCHUNK };
    let i1 = k_hi.saturating_sub(1) / PCHUNK;
    let end = (1 + (i1 + 1) * PCHUNK).min(t + 1);
    c.reserve_exact(end - k0);
    let spare = &mut c.spare_capacity_mut()[..end - k0];
    let mut at = 0;
    if k0 == 0 {
        spare[0].write(0.0);
        at = 1;
    }
    for i in i0..=i1 {
        let len = PCHUNK.min(t - i * PCHUNK);
        prefix_chunk(x, ck, i, &mut spare[at..at + len]);
        at += len;
    }
    debug_assert_eq!(at, end - k0);
    // SAFETY: `at` values were written from the start of `spare`, and at = end − k0.
    unsafe { c.set_len(at) };
    k0
}

/// The centred cumulative sum of rate samples, written into `c` (its allocation is reused):
/// returns the mean, with `c[0] = 0` and `c[k] = Σ_{i<k} (x_i − mean)` (T + 1 entries),
/// accumulated from compensated checkpoints so that each stored `c[k]` carries only its own
/// final rounding. Errors on non-finite samples (naming the first index) and on overflow.
pub(crate) fn centred_prefix_into(x: &[f64], c: &mut Vec<f64>) -> Result<f64, AvarError> {
    let ck = checkpoints(x)?;
    prefix_from_checkpoints(x, &ck, c);
    Ok(ck.mean)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    const SCHUNK: usize = NSEG * SEG_NEAR;

    /// Uniform white noise on [−0.5, 0.5) plus a slow random walk, plus `offset` (xorshift,
    /// deterministic).
    pub(crate) fn series(n: usize, offset: f64) -> Vec<f64> {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut walk = 0.0;
        (0..n)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let u = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                walk += 1e-3 * u;
                offset + u + walk
            })
            .collect()
    }

    /// The streamed kernel (full chunks through the SIMD path, partial chunks and the portable
    /// path through `seg_sum`) agrees with the buffered kernel, is bit-identical between the
    /// SIMD and portable paths, does not depend on the other requested scales, and is offset
    /// invariant.
    #[test]
    fn streamed_sums_match_buffered_and_are_path_independent() {
        let n = 3 * SCHUNK + 12_345;
        let ms: Vec<u64> = vec![
            1, 2, 3, 7, 8, 64, 1000, 1024, 5000, 8192, 16_384, 20_000, 30_000,
        ];
        let x = series(n, 0.0);
        let (streamed, mean) = overlapping_sums_stream(&x, &ms).unwrap();
        let mut c = Vec::new();
        let mean_buffered = centred_prefix_into(&x, &mut c).unwrap();
        assert!((mean - mean_buffered).abs() <= 1e-15 * mean_buffered.abs().max(1.0));
        let buffered = overlapping_sums(&c, &ms);
        for (a, b) in streamed.iter().zip(&buffered) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}");
        }
        check_paths::<SEG_NEAR>(n, &ms);
        check_paths::<SEG_FAR>(n, &ms);
        // the far grid and its residue-class walk (threshold lowered so that m > 2048 are far
        // here), with one job per near chunk (local checkpoint frames with a warm-up of
        // 4096 samples): same sums as the buffered kernel
        let far_m = 4096;
        let split =
            overlapping_sums_stream_split(&x, &ms, far_m, 1, crate::simd::level(), &Io::NONE)
                .unwrap()
                .0;
        for ((a, b), &m) in split.iter().zip(&buffered).zip(&ms) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "m {m}: {a} vs {b}");
        }
        // every vector path gives the same bits as the portable one, near and far (the far
        // scales 8192 and 16 384 are whole class steps here and read the ring of lane copies)
        for (far_m, jobs) in [(FAR_M, JOB_CHUNKS), (far_m, 1)] {
            let best = overlapping_sums_stream_split(
                &x,
                &ms,
                far_m,
                jobs,
                crate::simd::level(),
                &Io::NONE,
            )
            .unwrap();
            for simd in crate::simd::levels() {
                let p =
                    overlapping_sums_stream_split(&x, &ms, far_m, jobs, simd, &Io::NONE).unwrap();
                for ((a, b), &m) in p.0.iter().zip(&best.0).zip(&ms) {
                    assert_eq!(a.to_bits(), b.to_bits(), "far_m {far_m} {simd:?} m {m}");
                }
                assert_eq!(p.1.to_bits(), best.1.to_bits());
            }
        }
        // one job instead of the default grid (here four one-chunk jobs): the checkpoint frames
        // differ, the sums only by rounding
        let one_job = overlapping_sums_stream_split(
            &x,
            &ms,
            far_m,
            JOB_CHUNKS,
            crate::simd::level(),
            &Io::NONE,
        )
        .unwrap()
        .0;
        assert_eq!(job_chunks(n), 1);
        for ((a, d), &m) in one_job.iter().zip(&streamed).zip(&ms) {
            assert!((a - d).abs() <= 1e-13 * d.abs(), "m {m}: {a} vs {d}");
        }
        // the value for m does not depend on the other requested scales
        let single_far =
            overlapping_sums_stream_split(&x, &[20_000], far_m, 1, crate::simd::level(), &Io::NONE)
                .unwrap()
                .0;
        assert_eq!(single_far[0].to_bits(), split[11].to_bits());
        let single_near =
            overlapping_sums_stream_split(&x, &[1000], far_m, 1, crate::simd::level(), &Io::NONE)
                .unwrap()
                .0;
        assert_eq!(single_near[0].to_bits(), split[6].to_bits());
        let single = overlapping_sums_stream(&x, &[5000]).unwrap().0;
        assert_eq!(single[0].to_bits(), streamed[8].to_bits());
        // offset invariance
        let std = 0.3;
        let y: Vec<f64> = x.iter().map(|v| v + 1e4 * std).collect();
        let off = overlapping_sums_stream(&y, &ms).unwrap().0;
        for (a, b) in off.iter().zip(&streamed) {
            assert!((a - b).abs() <= 1e-10 * b.abs(), "{a} vs {b}");
        }
        let off_split =
            overlapping_sums_stream_split(&y, &ms, far_m, 1, crate::simd::level(), &Io::NONE)
                .unwrap()
                .0;
        for (a, b) in off_split.iter().zip(&split) {
            assert!((a - b).abs() <= 1e-10 * b.abs(), "{a} vs {b}");
        }
    }

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

    /// More near scales than one batch ([`SCALE_BATCH`]): the later batches reuse the jobs'
    /// checkpoints, and each value is the one the scale gets when requested alone.
    #[test]
    fn streamed_sums_span_several_scale_batches() {
        let n = 3 * SCHUNK + 12_345;
        let x = series(n, 0.0);
        let ms: Vec<u64> = (1..=300).map(|k| 7 * k).collect();
        let (sums, ..) =
            overlapping_sums_stream_split(&x, &ms, FAR_M, 1, crate::simd::level(), &Io::NONE)
                .unwrap();
        let mut c = Vec::new();
        centred_prefix_into(&x, &mut c).unwrap();
        let buffered = overlapping_sums(&c, &ms);
        for ((a, b), &m) in sums.iter().zip(&buffered).zip(&ms) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "m {m}: {a} vs {b}");
        }
        for k in [0, 150, 299] {
            let one = overlapping_sums_stream_split(
                &x,
                &ms[k..=k],
                FAR_M,
                1,
                crate::simd::level(),
                &Io::NONE,
            );
            assert_eq!(
                one.unwrap().0[0].to_bits(),
                sums[k].to_bits(),
                "m {}",
                ms[k]
            );
        }
    }

    /// The streamed kernel names the first non-finite sample, in whichever job it lies, and
    /// reports overflow of finite samples.
    #[test]
    fn streamed_sums_reject_non_finite_and_overflow() {
        let n = 3 * SCHUNK + 12_345;
        for (index, value) in [
            (0, f64::NAN),
            (SCHUNK + 5, f64::INFINITY),
            (n - 1, f64::NAN),
        ] {
            let mut x = series(n, 0.0);
            x[index] = value;
            for job_chunks in [1, JOB_CHUNKS] {
                match overlapping_sums_stream_split(
                    &x,
                    &[2, 8192],
                    4096,
                    job_chunks,
                    crate::simd::level(),
                    &Io::NONE,
                ) {
                    Err(AvarError::NonFinite { index: i, .. }) => assert_eq!(i, index),
                    other => panic!("index {index}: {:?}", other.map(|r| r.0)),
                }
            }
        }
        // the pivot overflows; then only the block sums do (alternating signs, pivot 0)
        let x = vec![1.7e308; n];
        assert!(matches!(
            overlapping_sums_stream(&x, &[2]),
            Err(AvarError::Overflow)
        ));
        let x: Vec<f64> = (0..n)
            .map(|i| if i % 2 == 0 { 1.7e308 } else { -1.7e308 })
            .collect();
        assert!(matches!(
            overlapping_sums_stream_split(&x, &[2], 4096, 1, crate::simd::level(), &Io::NONE),
            Err(AvarError::Overflow)
        ));
    }

    /// On the chunk grid of segment length SEG: every chunk partial is bit-identical between the
    /// portable, AVX2 and AVX-512 paths (up to the process's level), and between the AVX2 and
    /// AVX-512 chunk walks (all scales per column block, aligned windows, transposed copy for
    /// small scales) and the portable path at every misalignment of the data within a cache line.
    fn check_paths<const SEG: usize>(n: usize, ms: &[u64]) {
        let x = series(n, 0.0);
        let ck = checkpoints(&x).unwrap();
        let n_chunks = (n + 1).div_ceil(NSEG * SEG);
        let best = crate::simd::level();
        let paths = crate::simd::levels();
        for &m in ms {
            for i in 0..n_chunks {
                let p = stream_chunk::<SEG>(&x, &ck, m as usize, i, SimdLevel::Scalar);
                for &simd in &paths[1..] {
                    let q = stream_chunk::<SEG>(&x, &ck, m as usize, i, simd);
                    assert_eq!(
                        p.to_bits(),
                        q.to_bits(),
                        "SEG {SEG} m {m} chunk {i} {simd:?}"
                    );
                }
            }
        }
        #[cfg(target_arch = "x86_64")]
        for walk in [SimdLevel::Avx2, SimdLevel::Avx512]
            .into_iter()
            .filter(|w| *w <= best)
        {
            let big = series(n + 8, 0.0);
            for o in 0..8 {
                let xo = &big[o..o + n];
                let cko = checkpoints(xo).unwrap();
                // all scales, and the first 1 and 3 (groups of every size in the xt walk)
                for (i, ms) in (0..n_chunks).flat_map(|i| [(i, ms), (i, &ms[..1]), (i, &ms[..3])]) {
                    // (prefetching the following chunk, past the end for the last one)
                    let nx = Some((i + 1) * NSEG * SEG);
                    let mut q = vec![0.0; ms.len()];
                    let mut scratch = Scratch::new::<SEG>();
                    let sc = &mut scratch;
                    // SAFETY: `walk` ≤ `level()`: the CPU has its instructions.
                    unsafe {
                        if walk == SimdLevel::Avx512 {
                            chunk_all_avx512::<SEG>(xo, &cko, ms, i, nx, sc, &mut q)
                        } else {
                            chunk_all_avx2::<SEG>(xo, &cko, ms, i, nx, sc, &mut q)
                        }
                    };
                    for (&m, qm) in ms.iter().zip(&q) {
                        let p = stream_chunk::<SEG>(xo, &cko, m as usize, i, SimdLevel::Scalar);
                        assert_eq!(
                            p.to_bits(),
                            qm.to_bits(),
                            "SEG {SEG} {walk} offset {o} m {m} chunk {i}"
                        );
                    }
                }
            }
        }
    }
}
