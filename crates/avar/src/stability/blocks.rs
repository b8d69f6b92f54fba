//! The non-overlapping estimators (ADEV, HDEV) of rate data at power-of-two cluster sizes in
//! one read of the series: a pyramid of block sums.
//!
//! Level k holds the sums of the blocks of m = 2^k consecutive rate samples, each the sum of
//! two level-(k − 1) sums (a fixed pairwise tree, so a block sum does not depend on how the
//! series is cut into jobs). AVAR(m) = Σ_b (ȳ_{b+1} − ȳ_b)² / (2(K − 1)) and
//! HVAR(m) = Σ_b (ȳ_{b+2} − 2ȳ_{b+1} + ȳ_b)² / (6(K − 2)) over the K = ⌊T/m⌋ block means
//! ȳ_b (NIST SP 1065 eq. 6 and 18 with frequency data). The samples are taken relative to a
//! reference (the mean of the first 1024 samples), so an offset does not enter the sums.
//!
//! The series is cut into chunks of [`CHUNK`] samples (a grid fixed by T, never by the thread
//! count); a chunk builds its levels up to [`SMALL_MAX`] in a local buffer that reaches a few
//! blocks past its end, so the terms that start in it need nothing from other jobs. Its
//! level-[`SMALL_MAX`] sums are kept for the long scales, which are paired up sequentially
//! (T/2^10 values). Chunk partial sums are added in chunk order (Neumaier): the results are
//! bit-identical for any thread count.

use rayon::prelude::*;

use crate::kernel::compensated::Neumaier;

/// Samples per parallel job.
const CHUNK: usize = 1 << 14;
/// Largest level (log2 m) computed inside the chunks; longer scales come from its sums.
const SMALL_MAX: u32 = 10;

/// Σ of squared order-`order` differences (2: first differences, 3: second differences) of a
/// block-sum sequence, for the terms whose first block index is in `lo..hi`: eight accumulator
/// lanes over aligned slices (so that it vectorizes), reduced in a fixed order.
#[inline(always)]
fn sum_sq_diffs(s: &[f64], order: usize, lo: usize, hi: usize) -> f64 {
    const L: usize = 8;
    let mut acc = [0.0f64; L];
    if hi > lo {
        if order == 2 {
            let (a, b) = (&s[lo + 1..hi + 1], &s[lo..hi]);
            let (mut ia, mut ib) = (a.chunks_exact(L), b.chunks_exact(L));
            for (ca, cb) in (&mut ia).zip(&mut ib) {
                for l in 0..L {
                    let d = ca[l] - cb[l];
                    acc[l] += d * d;
                }
            }
            for (l, (va, vb)) in ia.remainder().iter().zip(ib.remainder()).enumerate() {
                let d = va - vb;
                acc[l] += d * d;
            }
        } else {
            let (a, b, c) = (&s[lo + 2..hi + 2], &s[lo + 1..hi + 1], &s[lo..hi]);
            let (mut ia, mut ib, mut ic) =
                (a.chunks_exact(L), b.chunks_exact(L), c.chunks_exact(L));
            for ((ca, cb), cc) in (&mut ia).zip(&mut ib).zip(&mut ic) {
                for l in 0..L {
                    let d = (ca[l] - cb[l]) - (cb[l] - cc[l]);
                    acc[l] += d * d;
                }
            }
            let rest = ia
                .remainder()
                .iter()
                .zip(ib.remainder())
                .zip(ic.remainder());
            for (l, ((va, vb), vc)) in rest.enumerate() {
                let d = (va - vb) - (vb - vc);
                acc[l] += d * d;
            }
        }
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

/// What one chunk contributes: the partial sums of every requested level up to `small_top`
/// (`sums`, in the order of `levels`), and the level-`small_top` block sums of the blocks that
/// start in it. `z` is the chunk with the reach of its last terms, `own` the length of the chunk
/// itself, `r` the reference subtracted from the samples, `buf` scratch of at least
/// `z.len() / 2` values.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn chunk_levels_body(
    z: &[f64],
    own: usize,
    r: f64,
    order: usize,
    levels: &[u32],
    small_top: u32,
    buf: &mut [f64],
) -> (Vec<f64>, Vec<f64>) {
    let mut sums = vec![0.0f64; levels.len()];
    if let Some(i) = levels.iter().position(|&k| k == 0) {
        // m = 1: the samples themselves (their differences need no reference)
        let n_terms = z.len().saturating_sub(order - 1).min(own);
        sums[i] = sum_sq_diffs(z, order, 0, n_terms);
    }
    if small_top == 0 {
        let top_own = own.min(z.len());
        return (sums, z[..top_own].iter().map(|v| v - r).collect());
    }
    // level 1 from the samples, then each level in place over the one below
    let mut len = z.len() / 2;
    for (o, p) in buf[..len].iter_mut().zip(z.chunks_exact(2)) {
        *o = (p[0] - r) + (p[1] - r);
    }
    for k in 1..=small_top {
        if k > 1 {
            len /= 2;
            for j in 0..len {
                buf[j] = buf[2 * j] + buf[2 * j + 1];
            }
        }
        for (slot, &lk) in sums.iter_mut().zip(levels) {
            if lk == k {
                // terms whose first block starts in this chunk and whose last block is
                // complete within the series
                let first_blocks = own.div_ceil(1 << k);
                let n_terms = len.saturating_sub(order - 1).min(first_blocks);
                *slot = sum_sq_diffs(&buf[..len], order, 0, n_terms);
            }
        }
    }
    // level small_top sums of the blocks that start in this chunk
    let top_own = (own >> small_top).min(len);
    (sums, buf[..top_own].to_vec())
}

simd_dispatch! {
    /// [`chunk_levels_body`] with AVX-512 or AVX2 as [`crate::simd::level`] allows (the same values:
    /// fixed lanes, no FMA contraction).
    fn chunk_levels(
        z: &[f64],
        own: usize,
        r: f64,
        order: usize,
        levels: &[u32],
        small_top: u32,
        buf: &mut [f64],
    ) -> (Vec<f64>, Vec<f64>) => chunk_levels_body
}

/// AVAR (`order` = 2) or HVAR (`order` = 3) of rate samples `y` at every m of `ms`, all powers
/// of two, in rate unit². `None` when an m is not a power of two or leaves fewer than
/// `order` blocks, or when a value is not finite (the caller then takes the general path,
/// which reports bad input).
pub(crate) fn nonoverlapping_vars(y: &[f64], ms: &[u64], order: usize) -> Option<Vec<f64>> {
    let t = y.len();
    if !(2..=3).contains(&order)
        || t < CHUNK
        || ms
            .iter()
            .any(|&m| !m.is_power_of_two() || (t as u64 / m) < order as u64)
    {
        return None;
    }
    let levels: Vec<u32> = ms.iter().map(|m| m.trailing_zeros()).collect();
    let kmax = *levels.iter().max()?;
    let small_top = kmax.min(SMALL_MAX);
    // the reference: mean of the first 1024 samples
    let r = y[..1024].iter().sum::<f64>() / 1024.0;
    let reach = (order - 1) << small_top;
    let n_chunks = t.div_ceil(CHUNK);
    // per chunk: the partial sums of every requested small level, and its level-10 sums
    let parts: Vec<(Vec<f64>, Vec<f64>)> = (0..n_chunks)
        .into_par_iter()
        .map_init(
            || vec![0.0f64; (CHUNK + reach) / 2 + 1],
            |buf, c| {
                let lo = c * CHUNK;
                let hi = (lo + CHUNK + reach).min(t);
                let own = (lo + CHUNK).min(t) - lo;
                chunk_levels(&y[lo..hi], own, r, order, &levels, small_top, buf)
            },
        )
        .collect();
    let mut out = vec![0.0f64; ms.len()];
    for (i, &k) in levels.iter().enumerate() {
        let m = 1usize << k;
        let n_terms = t / m - (order - 1);
        let s = if k <= small_top {
            let mut acc = Neumaier::default();
            for p in &parts {
                acc.add(p.0[i]);
            }
            acc.value()
        } else {
            // long scales: pair up the level-small_top sums, in order
            let mut cur: Vec<f64> = parts.iter().flat_map(|p| p.1.iter().copied()).collect();
            for _ in small_top..k {
                cur = cur.chunks_exact(2).map(|p| p[0] + p[1]).collect();
            }
            sum_sq_diffs(&cur, order, 0, cur.len() - (order - 1))
        };
        let norm = if order == 2 { 2.0 } else { 6.0 };
        let v = s / ((m * m) as f64 * norm * n_terms as f64);
        if !v.is_finite() {
            return None;
        }
        out[i] = v;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The literal definition on block means (plain loops): the second implementation.
    fn plain(y: &[f64], m: usize, order: usize) -> f64 {
        let k = y.len() / m;
        let means: Vec<f64> = (0..k)
            .map(|b| y[b * m..(b + 1) * m].iter().sum::<f64>() / m as f64)
            .collect();
        let mut s = 0.0;
        let n = k - (order - 1);
        for b in 0..n {
            let d = if order == 2 {
                means[b + 1] - means[b]
            } else {
                means[b + 2] - 2.0 * means[b + 1] + means[b]
            };
            s += d * d;
        }
        s / (if order == 2 { 2.0 } else { 6.0 } * n as f64)
    }

    fn series(n: usize) -> Vec<f64> {
        crate::kernel::tests::series(n, 5.0)
    }

    #[test]
    fn pyramid_matches_the_plain_definition() {
        // several chunks and an incomplete last one; levels inside and beyond the chunks
        let y = series(3 * CHUNK + 5_001);
        let ms: Vec<u64> = (0..15).map(|k| 1u64 << k).collect();
        for order in [2, 3] {
            let ms: Vec<u64> = ms
                .iter()
                .copied()
                .filter(|&m| y.len() as u64 / m >= order as u64)
                .collect();
            let v = nonoverlapping_vars(&y, &ms, order).unwrap();
            for (&m, got) in ms.iter().zip(v) {
                let want = plain(&y, m as usize, order);
                // the same terms summed in another order: rounding of order 1e-15 per term
                assert!(
                    (got / want - 1.0).abs() < 1e-11,
                    "order {order} m={m}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn declines_what_it_does_not_cover() {
        let y = series(CHUNK + 10);
        assert!(nonoverlapping_vars(&y, &[3], 2).is_none());
        assert!(nonoverlapping_vars(&y[..100], &[1], 2).is_none());
        let mut bad = y.clone();
        bad[17] = f64::NAN;
        assert!(nonoverlapping_vars(&bad, &[1, 2], 2).is_none());
    }
}
