//! The far walk of the streamed MOAV kernel: the scales with 2m > far_m on the `SEG_FAR` grid,
//! their chunks walked by residue class so that the lagged blocks of a chunk are chunks the
//! walk visited shortly before, still in cache ([`stream_group`]), reading through per-thread
//! windows of a file-backed source where it has them.

use rayon::prelude::*;

use crate::kernel::buffered::SCALE_BATCH;
use crate::kernel::compensated::Neumaier;
use crate::kernel::cumsum::{Checkpoints, G};
use crate::kernel::segments::NSEG;
use crate::kernel::simd_blocks::{Scratch, VECTOR_WALK, chunk_run};
use crate::simd::SimdLevel;
use crate::source::io::{Io, SampleWindow};

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
pub(super) fn stream_group<const SEG: usize>(
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
        let slots = if VECTOR_WALK && q_max > 0 {
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
            !(VECTOR_WALK
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
