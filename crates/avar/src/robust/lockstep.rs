//! The stride-1 scales solved together: each pass over the prefix sums forms the differences
//! of every such scale on the fly, block by block, and serves each scale's Newton step.

use rayon::prelude::*;

use super::biweight::Biweight;
use super::m_scale::{Newton, NewtonStep, RobustScale, newton_start};

/// Differences per block of [`solve_lockstep`]'s passes (a block and its lags stay in cache
/// while every scale reads it).
const LOCKSTEP_BLOCK: usize = 1 << 14;

/// The per-block sums of [`lockstep_pass`]: (scale index, hi, mid, lo, 1/m) → N sums.
type BlockSums<'a, const N: usize> =
    dyn Fn(usize, &[f64], &[f64], &[f64], f64) -> [f64; N] + Sync + 'a;

/// One pass over the prefix sums `c` for every scale of `ms` at once: per scale j, with D_i =
/// (c[i + 2m] − 2c[i + m] + c[i])/m (i < K_j = len(c) − 2m), the sums that `f` forms over a
/// block of D (given as the three aligned slices and 1/m), summed over blocks in block order
/// (the blocks run in parallel; the result does not depend on the thread count).
fn lockstep_pass<const N: usize>(c: &[f64], ms: &[usize], f: &BlockSums<N>) -> Vec<[f64; N]> {
    let k_max = ms.iter().map(|&m| c.len() - 2 * m).max().unwrap_or(0);
    let blocks = k_max.div_ceil(LOCKSTEP_BLOCK);
    let parts: Vec<Vec<[f64; N]>> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let start = b * LOCKSTEP_BLOCK;
            ms.iter()
                .enumerate()
                .map(|(j, &m)| {
                    let end = (start + LOCKSTEP_BLOCK).min(c.len() - 2 * m);
                    if start >= end {
                        return [0.0; N];
                    }
                    let (hi, mid, lo) = (
                        &c[start + 2 * m..end + 2 * m],
                        &c[start + m..end + m],
                        &c[start..end],
                    );
                    f(j, hi, mid, lo, 1.0 / m as f64)
                })
                .collect()
        })
        .collect();
    let mut out = vec![[0.0; N]; ms.len()];
    for part in parts {
        for (o, p) in out.iter_mut().zip(part) {
            for (a, b) in o.iter_mut().zip(p) {
                *a += b;
            }
        }
    }
    out
}

simd_dispatch! {
    /// Σ χ_c(u), −Σ u χ_c'(u) (as `chi_sums` of `m_scale`) over u = D²·`inv`, D formed from
    /// the three slices.
    fn chi_sums_diff(
        hi: &[f64],
        mid: &[f64],
        lo: &[f64],
        inv_m: f64,
        inv: f64,
        inv_c2: f64,
    ) -> [f64; 2] => chi_sums_diff_lanes
}

#[inline(always)]
fn chi_sums_diff_lanes(
    hi: &[f64],
    mid: &[f64],
    lo: &[f64],
    inv_m: f64,
    inv: f64,
    inv_c2: f64,
) -> [f64; 2] {
    const L: usize = 8;
    let mut g = [0.0f64; L];
    let mut dg = [0.0f64; L];
    let n = hi.len().min(mid.len()).min(lo.len());
    let (hi, mid, lo) = (&hi[..n], &mid[..n], &lo[..n]);
    let body = |x: f64, g: &mut f64, dg: &mut f64| {
        let u = x * x * inv;
        let w = (1.0 - u * inv_c2).max(0.0);
        let w3 = w * w * w;
        let chi = u * w3 * w;
        *g += chi;
        *dg += 4.0 * u * u * inv_c2 * w3 - chi;
    };
    let full = n / L * L;
    for ((h, md), l) in hi[..full]
        .chunks_exact(L)
        .zip(mid[..full].chunks_exact(L))
        .zip(lo[..full].chunks_exact(L))
    {
        for j in 0..L {
            body((h[j] - 2.0 * md[j] + l[j]) * inv_m, &mut g[j], &mut dg[j]);
        }
    }
    for j in 0..n - full {
        let i = full + j;
        body(
            (hi[i] - 2.0 * mid[i] + lo[i]) * inv_m,
            &mut g[j],
            &mut dg[j],
        );
    }
    let sum = |a: [f64; L]| ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
    [sum(g), sum(dg)]
}

simd_dispatch! {
    /// Σ D² over D = (`hi` − 2·`mid` + `lo`)·`inv_m`, in eight accumulator lanes (so that it
    /// vectorizes; the order of summation is fixed by the code, the same on every instruction
    /// set).
    fn sq_sum_diff(hi: &[f64], mid: &[f64], lo: &[f64], inv_m: f64) -> f64 => sq_sum_diff_lanes
}

#[inline(always)]
fn sq_sum_diff_lanes(hi: &[f64], mid: &[f64], lo: &[f64], inv_m: f64) -> f64 {
    const L: usize = 8;
    let mut acc = [0.0f64; L];
    let n = hi.len().min(mid.len()).min(lo.len());
    let (hi, mid, lo) = (&hi[..n], &mid[..n], &lo[..n]);
    let full = n / L * L;
    for ((h, md), l) in hi[..full]
        .chunks_exact(L)
        .zip(mid[..full].chunks_exact(L))
        .zip(lo[..full].chunks_exact(L))
    {
        for j in 0..L {
            let x = (h[j] - 2.0 * md[j] + l[j]) * inv_m;
            acc[j] += x * x;
        }
    }
    for (a, i) in acc.iter_mut().zip(full..n) {
        let x = (hi[i] - 2.0 * mid[i] + lo[i]) * inv_m;
        *a += x * x;
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

simd_dispatch! {
    /// How many D = (`hi` − 2·`mid` + `lo`)·`inv_m` have D² ≥ `lim` (branch-free, so that it
    /// vectorizes).
    fn count_beyond_diff(hi: &[f64], mid: &[f64], lo: &[f64], inv_m: f64, lim: f64) -> u64 => count_beyond_diff_lanes
}

#[inline(always)]
fn count_beyond_diff_lanes(hi: &[f64], mid: &[f64], lo: &[f64], inv_m: f64, lim: f64) -> u64 {
    // f64 lanes (exact below 2^53): integer lanes from a compare vectorize into gathers
    const L: usize = 8;
    let mut acc = [0.0f64; L];
    let n = hi.len().min(mid.len()).min(lo.len());
    let (hi, mid, lo) = (&hi[..n], &mid[..n], &lo[..n]);
    let full = n / L * L;
    for ((h, md), l) in hi[..full]
        .chunks_exact(L)
        .zip(mid[..full].chunks_exact(L))
        .zip(lo[..full].chunks_exact(L))
    {
        for j in 0..L {
            let x = (h[j] - 2.0 * md[j] + l[j]) * inv_m;
            acc[j] += if x * x >= lim { 1.0 } else { 0.0 };
        }
    }
    let mut n_beyond = acc.iter().sum::<f64>() as u64;
    for i in full..n {
        let x = (hi[i] - 2.0 * mid[i] + lo[i]) * inv_m;
        n_beyond += u64::from(x * x >= lim);
    }
    n_beyond
}

/// The robust mean squares at the stride-1 cluster sizes `ms` (< 2·[`STRIDE_DIVISOR`]) from
/// the prefix sums `c`, all scales stepping together: each pass over `c` (the mean squares; g at
/// the starts ([`newton_start`]); each Newton step; the rejected counts) serves every scale, instead of one
/// difference buffer and five passes per scale. The same estimator as
/// [`robust_mean_square_detail`] on the materialized differences (it agrees to rounding: the
/// sums are taken in another order); a scale whose Newton iteration leaves the start's
/// neighbourhood is `None`, for the caller to solve alone. Per scale: (s, rejected).
///
/// [`STRIDE_DIVISOR`]: super::STRIDE_DIVISOR
/// [`robust_mean_square_detail`]: super::robust_mean_square_detail
pub(super) fn solve_lockstep(
    c: &[f64],
    ms: &[usize],
    bw: &Biweight,
) -> Vec<Option<(RobustScale, u64)>> {
    let c2 = bw.c * bw.c;
    let ks: Vec<f64> = ms.iter().map(|&m| (c.len() - 2 * m) as f64).collect();
    let sq = lockstep_pass::<1>(c, ms, &|_, hi, mid, lo, inv_m| {
        [sq_sum_diff(hi, mid, lo, inv_m)]
    });
    // per scale: the Newton state, or the final answer
    let mut newton: Vec<Option<Newton>> = vec![None; ms.len()];
    let mut x_eval: Vec<Option<f64>> = vec![None; ms.len()];
    let mut out: Vec<Option<(RobustScale, u64)>> = vec![None; ms.len()];
    let mut solved: Vec<Option<f64>> = vec![None; ms.len()];
    for (j, &m) in ms.iter().enumerate() {
        let ms_j = sq[j][0] / ks[j];
        if !ms_j.is_finite() {
            continue; // the caller's path names the culprit
        }
        if ms_j == 0.0 {
            out[j] = Some((RobustScale { s: 0.0, root: true }, 0));
            continue;
        }
        let k = c.len() - 2 * m;
        let stride = k.div_ceil(1 << 16);
        let inv_m = 1.0 / m as f64;
        let mut abs: Vec<f64> = (0..k)
            .step_by(stride)
            .map(|i| ((c[i + 2 * m] - 2.0 * c[i + m] + c[i]) * inv_m).abs())
            .collect();
        let mid = abs.len() / 2;
        let mad = *abs.select_nth_unstable_by(mid, f64::total_cmp).1 / 0.674_489_750_196_081_7;
        let s0 = newton_start(ms_j, mad);
        x_eval[j] = Some(s0.ln());
    }
    // g at the starts, then Newton steps, all scales in each pass
    while x_eval.iter().any(Option::is_some) {
        let inv_s: Vec<f64> = x_eval
            .iter()
            .map(|x| x.map_or(0.0, |x| 1.0 / x.exp()))
            .collect();
        let active: Vec<usize> = (0..ms.len()).filter(|&j| x_eval[j].is_some()).collect();
        let sub: Vec<usize> = active.iter().map(|&j| ms[j]).collect();
        let sums = lockstep_pass::<2>(c, &sub, &|a, hi, mid, lo, inv_m| {
            chi_sums_diff(hi, mid, lo, inv_m, inv_s[active[a]], 1.0 / c2)
        });
        for (a, &j) in active.iter().enumerate() {
            let (g, dg) = (sums[a][0] / ks[j] - bw.a, sums[a][1] / ks[j]);
            let x = x_eval[j].take().expect("active");
            let n = newton[j].get_or_insert_with(|| Newton::start(x, g));
            match n.step(g, dg) {
                NewtonStep::Eval(next) => x_eval[j] = Some(next),
                NewtonStep::Root(root) => solved[j] = Some(root.exp()),
                NewtonStep::Failed => {}
            }
        }
    }
    // the rejected counts at the roots
    let lims: Vec<f64> = solved
        .iter()
        .map(|s| s.map_or(f64::INFINITY, |s| c2 * s))
        .collect();
    let counts = lockstep_pass::<1>(c, ms, &|j, hi, mid, lo, inv_m| {
        [count_beyond_diff(hi, mid, lo, inv_m, lims[j]) as f64]
    });
    for j in 0..ms.len() {
        if let Some(s) = solved[j] {
            out[j] = Some((RobustScale { s, root: true }, counts[j][0] as u64));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robust::differences::{centred_prefix_sums, differences_into};
    use crate::robust::robust_mean_square_detail;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// The scales solved together ([`solve_lockstep`]) against each solved alone on its
    /// materialized differences ([`robust_mean_square_detail`], the reference): the same root to
    /// rounding (1e-12; the sums run in another order) and the same rejected counts, on white
    /// noise with a random walk and 1 % of 8σ outliers (rejections at every scale; Newton
    /// starts from the MAD) and on the same data without them (it starts from the mean
    /// square), at every m from 1 to 31 and over several blocks of the passes.
    #[test]
    fn lockstep_scales_equal_the_one_scale_solver() {
        for outlier in [8.0, 0.0] {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
            let mut walk = 0.0;
            let x: Vec<f64> = (0..3 * LOCKSTEP_BLOCK + 777)
                .map(|i| {
                    let (z, w): (f64, f64) = (
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    );
                    walk += 0.01 * w;
                    z + walk + if i % 100 == 0 { outlier } else { 0.0 }
                })
                .collect();
            let mean = x.iter().sum::<f64>() / x.len() as f64;
            let c = centred_prefix_sums(&x, mean);
            let bw = Biweight::with_efficiency(0.6).unwrap();
            let ms: Vec<usize> = (1..32).collect();
            let together = solve_lockstep(&c, &ms, &bw);
            // the same bits on one thread (blocks are summed in block order)
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap()
                .install(|| solve_lockstep(&c, &ms, &bw));
            assert_eq!(one, together);
            let mut d = Vec::new();
            let mut rejected_somewhere = false;
            for (&m, t) in ms.iter().zip(&together) {
                differences_into(&c, m, 1, &mut d);
                let r = robust_mean_square_detail(&d, &bw).unwrap();
                let lim = bw.c * bw.c * r.s;
                let rej = d.iter().filter(|v| *v * *v >= lim).count() as u64;
                let (q, qrej) = t.expect("Newton from the start converges here");
                assert!(
                    (q.s / r.s - 1.0).abs() < 1e-12,
                    "outliers {outlier}, m = {m}: {} vs {}",
                    q.s,
                    r.s
                );
                assert_eq!(qrej, rej, "outliers {outlier}, m = {m}");
                rejected_somewhere |= rej > 0;
            }
            assert!(rejected_somewhere || outlier == 0.0);
        }
    }

    /// The vectorized passes of the lockstep equal plain loops: the sum of squares to
    /// rounding and the count of D² ≥ lim exactly, with a tail shorter than the 8 lanes.
    #[test]
    fn lockstep_pass_kernels_equal_plain_loops() {
        let c: Vec<f64> = (0..1003)
            .map(|i| ((i * 7919) % 113) as f64 * 0.37)
            .collect();
        for m in [1usize, 3, 16] {
            let n = c.len() - 2 * m;
            let (hi, mid, lo) = (&c[2 * m..], &c[m..m + n], &c[..n]);
            let inv_m = 1.0 / m as f64;
            let d: Vec<f64> = (0..n)
                .map(|i| (hi[i] - 2.0 * mid[i] + lo[i]) * inv_m)
                .collect();
            let sq: f64 = d.iter().map(|v| v * v).sum();
            assert!((sq_sum_diff(hi, mid, lo, inv_m) / sq - 1.0).abs() < 1e-13);
            for lim in [0.0, 1.0, 50.0, f64::INFINITY] {
                let want = d.iter().filter(|v| *v * *v >= lim).count() as u64;
                assert_eq!(
                    count_beyond_diff(hi, mid, lo, inv_m, lim),
                    want,
                    "m {m} lim {lim}"
                );
            }
        }
    }
}
