//! The chi-square intervals of a long rate series without its series-sized cumulative sum.
//!
//! The default interval ([`crate::ci`]) identifies the noise at each scale from the m-cluster
//! means, which the in-memory path reads from the centred cumulative sum C (8 bytes per
//! sample). Here C is never held whole: its checkpoints ([`kernel::cumsum::checkpoints`], 16 bytes per
//! 64 samples) are built in one pass, and the series is then read two or three more times in
//! windows of [`WINDOW`] samples, each window rebuilding its stretch of C exactly as the
//! in-memory path stores it ([`kernel::cumsum::prefix_window`]):
//!
//! * scales m < [`BIG_M`] (more than T/128 cluster means): the identification's blocks are
//!   computed where they start, from the window: the least-squares line in the first pass,
//!   the lag-1 sums of the residuals in the second, and those of their first and second
//!   differences in a third, only for the scales whose residuals are too correlated at level
//!   0 (random-walk-like noise);
//! * scales m ≥ [`BIG_M`]: the first pass copies C at the cluster boundaries (T/m values), and
//!   the identification runs on that copy.
//!
//! Every block of every scale is computed by the same function on the same values of C as in
//! memory and the parts are added in block order, so the intervals are bit-identical to the
//! in-memory path's for any thread count. Memory: the checkpoints (250 MB at 10^9 samples),
//! one window of C per thread (16 MiB plus the reach of the last blocks, reused across the
//! passes), the boundary copies (at most [`BOUNDS_BUDGET`] bytes at a time: scales beyond it
//! take further passes).

use rayon::prelude::*;

use crate::ci::{
    ClusterMeans, ID_BLOCK, IdLine, MIN_ID_CLUSTERS, NoiseId, decide_level, fit_block,
    identify_cluster_means, level_block,
};
use crate::error::AvarError;
use crate::kernel;

/// Samples per window of the passes (a multiple of the prefix chunks).
const WINDOW: usize = 1 << 21;
/// Scales with at least this cluster size keep a copy of C at their cluster boundaries.
const BIG_M: usize = 128;
/// Bytes of boundary copies held at once (more scales take more passes).
const BOUNDS_BUDGET: usize = 256 << 20;

/// A scale identified window by window (m < [`BIG_M`]).
struct Small {
    /// Index of the scale in the caller's list.
    at: usize,
    m: usize,
    /// Number of cluster means ⌊T/m⌋.
    n: usize,
}

impl Small {
    /// The blocks of the identification that start in the window of samples [lo, hi): block b
    /// starts at C index b·ID_BLOCK·m.
    fn blocks_in(&self, lo: usize, hi: usize, n_blocks: usize) -> std::ops::Range<usize> {
        let span = ID_BLOCK * self.m;
        lo.div_ceil(span).min(n_blocks)..hi.div_ceil(span).min(n_blocks)
    }

    /// The last C index that blocks ..b_end read (the lag and second differences reach three
    /// means past a block).
    fn reach(&self, b_end: usize) -> usize {
        ((b_end * ID_BLOCK + 3) * self.m).min(self.n * self.m)
    }

    fn means<'a>(&self, c: &'a [f64], k0: usize) -> ClusterMeans<'a> {
        ClusterMeans {
            c,
            step: self.m,
            k0,
            inv: 1.0 / self.m as f64,
        }
    }
}

/// One pass over the windows of C: `f(c, k0, lo, hi)` for each window of C indices [lo, hi)
/// (C_k = `c[k − k0]`, rebuilt far enough for the blocks of `reach` that start in it); the
/// results in window order. One worker per thread takes the windows in turn from a counter,
/// rebuilding them in its own buffer of `bufs` (kept across passes: no fresh pages to fault
/// in and zero for every window).
fn window_pass<R: Send>(
    x: &[f64],
    ck: &kernel::cumsum::Checkpoints,
    reach: &[&Small],
    bufs: &[std::sync::Mutex<Vec<f64>>],
    release: &(dyn Fn(usize, usize) + Sync),
    f: impl Fn(&[f64], usize, usize, usize) -> R + Sync,
) -> Vec<R> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let t = x.len();
    let n_win = (t + 1).div_ceil(WINDOW);
    let next = AtomicUsize::new(0);
    let done: Vec<Vec<(usize, R)>> = bufs
        .par_iter()
        .map(|buf| {
            let mut buf = buf.lock().unwrap_or_else(|e| e.into_inner());
            let mut out = Vec::new();
            loop {
                let w = next.fetch_add(1, Ordering::Relaxed);
                if w >= n_win {
                    break out;
                }
                let (lo, hi) = (w * WINDOW, ((w + 1) * WINDOW).min(t + 1));
                let mut k_hi = hi - 1;
                for s in reach {
                    let r = s.blocks_in(lo, hi, s.n.div_ceil(ID_BLOCK));
                    if !r.is_empty() {
                        k_hi = k_hi.max(s.reach(r.end));
                    }
                }
                let k0 = kernel::cumsum::prefix_window(x, ck, lo, k_hi.min(t), &mut buf);
                out.push((w, f(&buf, k0, lo, hi)));
                release(lo, hi.min(t));
            }
        })
        .collect();
    let mut all: Vec<(usize, R)> = done.into_iter().flatten().collect();
    all.sort_unstable_by_key(|(w, _)| *w);
    all.into_iter().map(|(_, r)| r).collect()
}

/// The noise identification of [`crate::ci`] at each cluster size of `ms` for the rate
/// samples `x` (T ≥ 2), streamed as the module says; `release(lo, hi)` is told when a window's
/// samples are done with (a hint). Errors on non-finite samples and on overflow.
pub(crate) fn identify_streamed(
    x: &[f64],
    ms: &[u64],
    release: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<Option<NoiseId>>, AvarError> {
    identify_within(x, ms, release, BOUNDS_BUDGET)
}

/// [`identify_streamed`] with at most `budget` bytes of boundary copies at a time.
fn identify_within(
    x: &[f64],
    ms: &[u64],
    release: &(dyn Fn(usize, usize) + Sync),
    budget: usize,
) -> Result<Vec<Option<NoiseId>>, AvarError> {
    let t = x.len();
    let ck = kernel::cumsum::checkpoints_io(x, release)?;
    let bufs: Vec<std::sync::Mutex<Vec<f64>>> = (0..rayon::current_num_threads().max(1))
        .map(|_| std::sync::Mutex::new(Vec::new()))
        .collect();
    let mut ids: Vec<Option<NoiseId>> = vec![None; ms.len()];
    let mut small = Vec::new();
    let mut big = Vec::new();
    for (at, &m) in ms.iter().enumerate() {
        let m = m as usize;
        let n = t.checked_div(m).unwrap_or(0);
        if n < MIN_ID_CLUSTERS {
            continue;
        }
        if m < BIG_M {
            small.push(Small { at, m, n });
        } else {
            big.push((at, m, n));
        }
    }
    let all_small: Vec<&Small> = small.iter().collect();
    // the boundary copies, in groups within the budget; the first group's pass also sums the
    // small scales' lines
    let mut groups: Vec<&[(usize, usize, usize)]> = Vec::new();
    let mut rest = &big[..];
    while !rest.is_empty() {
        let mut bytes = 0;
        let k = rest
            .iter()
            .take_while(|&&(_, _, n)| {
                bytes += 8 * (n + 1);
                bytes <= budget
            })
            .count()
            .max(1);
        groups.push(&rest[..k]);
        rest = &rest[k..];
    }
    if groups.is_empty() {
        groups.push(&[]);
    }
    let mut fits: Vec<Vec<(f64, f64)>> = vec![Vec::new(); small.len()];
    for (g, group) in groups.iter().enumerate() {
        let with_fits: &[&Small] = if g == 0 { &all_small } else { &[] };
        let per_window = window_pass(x, &ck, with_fits, &bufs, release, |c, k0, lo, hi| {
            let fit_parts: Vec<Vec<(f64, f64)>> = with_fits
                .iter()
                .map(|s| {
                    let y = s.means(c, k0);
                    s.blocks_in(lo, hi, s.n.div_ceil(ID_BLOCK))
                        .map(|b| fit_block(&y, b, s.n))
                        .collect()
                })
                .collect();
            let bounds: Vec<Vec<f64>> = group
                .iter()
                .map(|&(_, m, n)| {
                    (lo.div_ceil(m)..hi.div_ceil(m).min(n + 1))
                        .map(|i| c[i * m - k0])
                        .collect()
                })
                .collect();
            (fit_parts, bounds)
        });
        let mut bounds: Vec<Vec<f64>> = group
            .iter()
            .map(|&(_, _, n)| Vec::with_capacity(n + 1))
            .collect();
        for (f, b) in per_window {
            for (all, part) in fits.iter_mut().zip(f) {
                all.extend(part);
            }
            for (all, part) in bounds.iter_mut().zip(b) {
                all.extend(part);
            }
        }
        let found: Vec<Option<NoiseId>> = group
            .par_iter()
            .zip(&bounds)
            .map(|(&(_, m, n), b)| {
                let y = ClusterMeans {
                    c: b,
                    step: 1,
                    k0: 0,
                    inv: 1.0 / m as f64,
                };
                identify_cluster_means(&y, n)
            })
            .collect();
        for (&(at, _, _), id) in group.iter().zip(found) {
            ids[at] = id;
        }
    }
    if small.is_empty() {
        return Ok(ids);
    }
    // the lines of the small scales (end points from C at single indices)
    let c_at = |k: usize| {
        let mut buf = Vec::new();
        let k0 = kernel::cumsum::prefix_window(x, &ck, k, k, &mut buf);
        buf[k - k0]
    };
    let lines: Vec<IdLine> = small
        .iter()
        .zip(&fits)
        .map(|(s, parts)| {
            let y = |i: usize| (c_at((i + 1) * s.m) - c_at(i * s.m)) * (1.0 / s.m as f64);
            IdLine::new(s.n, parts, [y(0), y(1), y(s.n - 2), y(s.n - 1)])
        })
        .collect();
    // level 0 of every small scale in the second pass; levels 1 and 2 of the scales that
    // difference (ρ ≥ 0.25 at level 0: random-walk-like noise) in a third
    let mut open: Vec<usize> = (0..small.len()).collect();
    for levels in [&[0usize][..], &[1, 2]] {
        let reach: Vec<&Small> = open.iter().map(|&i| &small[i]).collect();
        let per_window = window_pass(x, &ck, &reach, &bufs, release, |c, k0, lo, hi| {
            open.iter()
                .map(|&i| {
                    let (s, line) = (&small[i], &lines[i]);
                    let y = s.means(c, k0);
                    levels
                        .iter()
                        .map(|&d| {
                            s.blocks_in(lo, hi, line.blocks(d))
                                .map(|b| level_block(&y, line, d, b))
                                .collect::<Vec<_>>()
                        })
                        .collect::<Vec<_>>()
                })
                .collect::<Vec<_>>()
        });
        let mut parts: Vec<Vec<Vec<(f64, f64)>>> = vec![vec![Vec::new(); levels.len()]; open.len()];
        for win in per_window {
            for (all, part) in parts.iter_mut().zip(win) {
                for (a, p) in all.iter_mut().zip(part) {
                    a.extend(p);
                }
            }
        }
        let mut still = Vec::new();
        for (&i, lv) in open.iter().zip(&parts) {
            let s = &small[i];
            match levels
                .iter()
                .zip(lv)
                .find_map(|(&d, p)| decide_level(p, d, s.n).ok())
            {
                Some(id) => ids[s.at] = id,
                None => still.push(i),
            }
        }
        open = still;
        if open.is_empty() {
            break;
        }
    }
    Ok(ids)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Cumulative;
    use std::borrow::Cow;

    /// `white`·(white noise) + a random walk (steps `walk`·u) + an integrated random walk
    /// (slope steps `ramp`·u) around 3, u uniform on ±1/2.
    fn series(n: usize, white: f64, walk: f64, ramp: f64) -> Vec<f64> {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut w, mut slope, mut r) = (0.0, 0.0, 0.0);
        (0..n)
            .map(|_| {
                w += walk * next();
                slope += ramp * next();
                r += slope;
                3.0 + white * next() + w + r
            })
            .collect()
    }

    /// The in-memory identification at each m (the whole cumulative sum).
    fn in_memory(x: &[f64], ms: &[u64]) -> Vec<Option<NoiseId>> {
        let mut c = Vec::new();
        let mean = kernel::cumsum::centred_prefix_into(x, &mut c).unwrap();
        let cum = Cumulative {
            c: Cow::Owned(c),
            factor: 1.0,
            mean,
            t: x.len(),
        };
        ms.iter()
            .map(|&m| crate::ci::identify_from_cumulative(&cum, m as usize))
            .collect()
    }

    /// Streamed and in-memory identifications are equal bit for bit (ρ, α, d) at small and big,
    /// power-of-two and other scales, over several windows, on 1–3 threads and with the
    /// boundary copies split into several passes; every level (d = 0, 1, 2) occurs.
    #[test]
    fn streamed_identification_equals_in_memory() {
        let n = 2 * WINDOW + 12_345;
        let ms: Vec<u64> = vec![
            1, 2, 3, 5, 64, 100, 127, 128, 129, 1000, 4096, 10_007, 65_536, 80_000, 200_000,
        ];
        // white noise with walks: levels 0 and 1 at the small scales, 1 and 2 at the big ones;
        // an integrated random walk alone: level 2 everywhere
        let mut levels = std::collections::BTreeSet::new();
        for x in [series(n, 1.0, 1e-4, 6e-9), series(n, 0.0, 0.0, 1e-6)] {
            let want = in_memory(&x, &ms);
            assert!(
                want[ms.len() - 1].is_none(),
                "too few clusters at the last m"
            );
            for (w, &m) in want.iter().zip(&ms) {
                if let Some(w) = w {
                    levels.insert((m as usize >= BIG_M, w.d));
                }
            }
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                for budget in [BOUNDS_BUDGET, 1] {
                    let got = pool
                        .install(|| identify_within(&x, &ms, &|_, _| {}, budget))
                        .unwrap();
                    for ((g, w), m) in got.iter().zip(&want).zip(&ms) {
                        match (g, w) {
                            (Some(g), Some(w)) => {
                                assert_eq!(g.rho.to_bits(), w.rho.to_bits(), "m={m}");
                                assert_eq!((g.alpha_rg, g.d), (w.alpha_rg, w.d), "m={m}");
                            }
                            (None, None) => {}
                            _ => panic!("m={m}: {g:?} vs {w:?}"),
                        }
                    }
                }
            }
        }
        // every level, in the windowed passes (small m) and on the boundary copies (big m)
        for big in [false, true] {
            for d in 0..=2 {
                assert!(levels.contains(&(big, d)) || (big && d == 0), "{levels:?}");
            }
        }
    }

    /// A non-finite sample is reported with its index, as by the in-memory path.
    #[test]
    fn non_finite_sample_is_an_error() {
        let mut x = series(1000, 1.0, 0.0, 0.0);
        x[777] = f64::NAN;
        let err = identify_streamed(&x, &[1, 2], &|_, _| {}).unwrap_err();
        assert!(
            matches!(err, AvarError::NonFinite { index: 777, .. }),
            "{err:?}"
        );
    }
}
