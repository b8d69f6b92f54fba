//! The streamed MOAV kernel ([`overlapping_sums_stream`]): the sums of squared second
//! differences of a long rate series with no series-sized buffer, only checkpoints of the
//! centred cumulative sum every [`G`] samples. The near scales (2m ≤ [`far_m`]) run on the
//! [`SEG_NEAR`] grid in jobs that build their checkpoints as they go ([`stream_near`]), so that
//! the series is read from memory once for them; the far scales run on the [`SEG_FAR`] grid,
//! their chunks walked by residue class so that the lagged blocks are still cached
//! ([`stream_group`]). Each chunk goes through [`chunk_run`] (`simd_blocks`).

use rayon::prelude::*;

use super::buffered::SCALE_BATCH;
use super::compensated::Neumaier;
use super::cumsum::{Checkpoints, FarFrames, G, first_non_finite, lane_sum, pivot_of};
use super::segments::{NSEG, SEG_FAR, SEG_NEAR};
use super::simd_blocks::{Scratch, chunk_run};
use crate::error::AvarError;
use crate::simd::SimdLevel;
use crate::source::io::{Io, Release, SampleWindow};

/// Series at least this long (rate input, overlapping estimator, no CI) are streamed from the
/// samples and checkpoints instead of a series-sized cumulative-sum buffer (whose first-touch
/// page faults then dominate; below it the buffered kernel is faster).
pub(crate) const STREAM_MIN_T: usize = 1 << 22;

/// Scales with 2m > FAR_M are "far": their lagged blocks are not in cache in plain chunk order.
/// They take the [`SEG_FAR`] grid and are walked by residue class of the chunk index modulo
/// FAR_M / (NSEG·SEG_FAR), a class step of exactly FAR_M samples (see [`stream_group`]). This
/// is the largest threshold; shorter series take a smaller one ([`far_m`]).
const FAR_M: usize = 1 << 20;
/// The smallest near/far threshold of [`far_m`].
const FAR_M_MIN: usize = 1 << 17;

const _: () = assert!(FAR_M_MIN.is_multiple_of(NSEG * SEG_FAR));

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::buffered::overlapping_sums;
    use crate::kernel::cumsum::centred_prefix_into;
    use crate::kernel::tests::series;

    const SCHUNK: usize = NSEG * SEG_NEAR;

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
}
