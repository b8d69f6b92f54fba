//! The segment recurrence of the streamed MOAV kernel, portable code: a chunk of k is
//! [`NSEG`] segments, each starting from an exact d_k = C_k − 2C_{k−m} + C_{k−2m} rebuilt from the
//! checkpoints ([`d_start`]) and carrying d_{k+1} = d_k + (x_k − x_{k−m}) − (x_{k−m} − x_{k−2m})
//! with acc ← acc + d·d ([`seg_sum`]). The vector paths (`simd_blocks`) perform these
//! operations in the same order, lane by lane, and are checked against [`chunk_portable`].

// the segment state is used only by the vector paths of x86-64
#![cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]

use super::compensated::{LANES, reduce_lanes, two_sum};
use super::cumsum::{Checkpoints, G, PCHUNK};

/// Length of one segment of k on which d_k is carried by its own recurrence (near scales,
/// 2m ≤ `FAR_M` (the streamed kernel's near/far threshold)); a k-chunk is NSEG segments. Near segment starts are SEG_NEAR·8 bytes apart,
/// 512 bytes more than a multiple of 4 KiB, so that the rows read together fall in different L1
/// sets; and they are multiples of G, so that for m a multiple of G (dyadic m ≥ G) every starting
/// d comes from three checkpoints without a local sum.
pub(super) const SEG_NEAR: usize = 1024 + G;

/// Segment length of the far scales (2m > `FAR_M` (the streamed kernel's near/far threshold)): a power of two, so that the chunk width
/// (2048 samples, 16 KiB) divides the dyadic lags and the residue-class walk of `stream_group` (streamed)
/// finds the lagged blocks among the chunks it visited last; short, so that those (up to
/// 2·2^25/FAR_M = 64 steps back at T = 10^8, 1 MiB) can stay cached (measured on the far scales
/// of 10^8 samples: 128 is ~10 % faster than 64 and 256, ~25 % faster than 1024 and the near
/// grid).
pub(super) const SEG_FAR: usize = 128;

/// Segments per k-chunk of the streamed kernel (one fixed accumulator each).
pub(super) const NSEG: usize = 16;

const _: () = assert!(
    NSEG == LANES
        && PCHUNK.is_multiple_of(G)
        && SEG_NEAR.is_multiple_of(G)
        && SEG_FAR.is_multiple_of(G)
);

/// d_s = C_s − 2C_{s−m} + C_{s−2m}: for m < G directly as Σ_{i=s−m}^{s−1} (x_i − x_{i−m}) (the
/// mean and any offset cancel in each difference); otherwise from the checkpoints, the large
/// parts differenced exactly.
#[inline(always)]
pub(super) fn d_start(x: &[f64], ck: &Checkpoints, m: usize, s: usize) -> f64 {
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
/// each d_k² is rounded, then added (acc ← acc + d·d; no fused multiply-add, the same in every
/// vector path).
#[inline(always)]
pub(super) fn seg_sum(x: &[f64], d0: f64, m: usize, s: usize, e: usize) -> f64 {
    let mut d = d0;
    let mut acc = 0.0f64;
    for k in s..e - 1 {
        acc += d * d;
        d += (x[k] - x[k - m]) - (x[k - m] - x[k - 2 * m]);
    }
    acc + d * d
}

/// Per-scale state of the NSEG segment recurrences of one chunk: the current d and the running
/// sum of d² of each segment.
#[derive(Clone, Copy)]
pub(super) struct SegState {
    pub(super) d: [f64; NSEG],
    pub(super) acc: [f64; NSEG],
}

/// Chunk partial for scale m over chunk `i` of the grid of segment length SEG, portable code:
/// each SEG-segment of k starts from an exact d (checkpoints) and carries the recurrence of
/// [`seg_sum`]; the NSEG segment sums are reduced by the fixed tree.
#[inline(always)]
pub(super) fn chunk_portable<const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    m: usize,
    i: usize,
) -> f64 {
    let t = x.len();
    let a = i * (NSEG * SEG);
    let mut acc = [0.0f64; NSEG];
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
                acc[l] += d[l] * d[l];
                d[l] += (x[k] - x[k - m]) - (x[k - m] - x[k - 2 * m]);
            }
        }
        for l in 0..NSEG {
            acc[l] += d[l] * d[l];
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::cumsum::checkpoints;
    use crate::kernel::tests::series;

    /// Every full chunk of the portable path (its segments in lockstep) equals the fixed
    /// reduction of the per-segment sums of [`seg_sum`] bit for bit: on data near 1, scaled by
    /// 2^480 and 2^−480 (squares near the ends of the exponent range), and on integer data
    /// whose d are often exactly 0.
    #[test]
    fn portable_chunks_equal_the_segment_sums() {
        let n = 3 * NSEG * SEG_FAR + 5000;
        let base = series(n, 0.25);
        let ints: Vec<f64> = base.iter().map(|v| (v * 3.0).round()).collect();
        for (name, x) in [
            ("near 1", base.clone()),
            ("x 2^480", base.iter().map(|v| v * 2f64.powi(480)).collect()),
            (
                "x 2^-480",
                base.iter().map(|v| v * 2f64.powi(-480)).collect(),
            ),
            ("integers", ints),
        ] {
            let ck = checkpoints(&x).unwrap();
            for m in [1usize, 3, 64, 100, 1024] {
                let mut full = 0;
                for i in 0..n / (NSEG * SEG_FAR) {
                    let a = i * NSEG * SEG_FAR;
                    if a < 2 * m {
                        continue;
                    }
                    let want: [f64; NSEG] = std::array::from_fn(|l| {
                        let s = a + l * SEG_FAR;
                        seg_sum(&x, d_start(&x, &ck, m, s), m, s, s + SEG_FAR)
                    });
                    let got = chunk_portable::<SEG_FAR>(&x, &ck, m, i);
                    assert_eq!(
                        got.to_bits(),
                        reduce_lanes(&want).to_bits(),
                        "{name} m {m} chunk {i}"
                    );
                    full += 1;
                }
                assert!(full > 0);
            }
        }
    }
}
