//! The near walk of the streamed MOAV kernel: the scales with 2m ≤ far_m on the `SEG_NEAR`
//! grid, in jobs of consecutive chunks run in parallel, each building its own checkpoints of
//! the centred cumulative sum (a local frame with a warm-up) just before running its scales on
//! a chunk that is then in cache ([`stream_near`]); and the whole-series checkpoints the jobs
//! leave for the far walk ([`global_checkpoints`]).

use rayon::prelude::*;

use crate::kernel::buffered::SCALE_BATCH;
use crate::kernel::compensated::Neumaier;
use crate::kernel::cumsum::{Checkpoints, FarFrames, G, lane_sum};
use crate::kernel::segments::{NSEG, SEG_NEAR};
use crate::kernel::simd_blocks::{Scratch, chunk_run};
use crate::simd::SimdLevel;
use crate::source::io::Release;

/// One job of the near walk: its checkpoints in a local frame (origin at the job start A, where
/// C = 0, and pivot-only centring), from A − warm-up to the job end B.
pub(super) struct NearJob {
    ck: Checkpoints,
    /// Index (units of G) of the job start A.
    g_a: usize,
    /// Whether a block sum was not finite.
    pub(super) bad: bool,
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
pub(super) fn stream_near(
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
pub(super) fn global_checkpoints(
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
