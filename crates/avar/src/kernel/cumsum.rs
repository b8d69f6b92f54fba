//! The centred cumulative sum C_p = Σ_{i<p} (x_i − pivot − delta) of rate samples, which every
//! estimator differences: built whole ([`centred_prefix_into`], 8 bytes per sample) or kept as
//! compensated checkpoints every [`G`] samples ([`Checkpoints`], 16 bytes per 64 samples) from
//! which any C_p, or any window of C ([`prefix_window`]), is rebuilt bit for bit. Also the checks
//! every estimator starts with ([`check_finite`]) and the pivot ([`pivot_of`]).

use rayon::prelude::*;

use super::compensated::{LANES, Neumaier, reduce_lanes, two_sum};
use crate::error::AvarError;
use crate::source::io::{Io, Release};

/// Width of the chunks used when building the cumulative sum.
pub(super) const PCHUNK: usize = 1 << 16;

/// How many leading samples form the pivot subtracted before summing.
const PIVOT_LEN: usize = 1024;

/// Granularity (samples) of the checkpoints of the centred cumulative sum.
pub(super) const G: usize = 64;

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
pub(super) fn lane_sum(x: &[f64], p: f64) -> f64 {
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

/// The centred cumulative sum C_p = Σ_{i<p} (x_i − pivot − delta) of rate samples, kept only at
/// every [`G`]-th index as compensated (hi, lo) pairs: `ck[g − g0].0 + ck[g − g0].1` = C_{gG}
/// (last entry: C_T). [`checkpoints`] centres on the mean (delta = mean − pivot) from index 0;
/// the streamed kernel also uses local frames (delta = 0, origin anywhere, entries from g0 on):
/// second differences C_s − 2C_{s−m} + C_{s−2m} do not depend on the centring constant or on the
/// origin.
pub(crate) struct Checkpoints {
    pub(super) pivot: f64,
    pub(super) delta: f64,
    /// The mean of the samples (pivot + delta); NaN in the streamed kernel's pivot-only frames,
    /// whose caller gets the mean from the job totals instead.
    pub(crate) mean: f64,
    /// Index (in units of G samples) of the first entry of `ck`.
    pub(super) g0: usize,
    pub(super) ck: Vec<(f64, f64)>,
    /// The far walk's compact form (then `ck` is empty): see [`FarFrames`].
    pub(super) far: Option<FarFrames>,
}

/// The checkpoints of the whole series for the far walk in half the memory (16 bytes per 128
/// samples): the near jobs' local entries at even g only, and each job's base (the
/// compensated sum of the earlier jobs' totals). An entry is rebuilt exactly as
/// `global_checkpoints` (streamed) would have stored it: an odd local entry by the Neumaier step of
/// `job_extend` (streamed) from the even one below it, then shifted by the job's base.
pub(super) struct FarFrames {
    /// Job length in units of G (even: job starts are even indices).
    pub(super) job_g: usize,
    pub(super) bases: Vec<(f64, f64)>,
    /// Local entries at g = 0, 2, 4, … (`loc[g / 2]`), up to the last index ⌈T/G⌉.
    pub(super) loc: Vec<(f64, f64)>,
}

impl Checkpoints {
    /// C at index gG (needs g0 ≤ g < g0 + ck.len(), or g ≤ ⌈T/G⌉ in the compact far form,
    /// which reads the samples of block g − 1 for odd g).
    #[inline(always)]
    pub(super) fn get(&self, x: &[f64], g: usize) -> (f64, f64) {
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
