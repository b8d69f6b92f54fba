//! Numerical core: the centred, compensated cumulative sum and the sums of squared second
//! differences for many cluster sizes, vectorised and deterministic.
//!
//! Determinism: every sum is defined on a fixed grid of `k` chunks (aligned to absolute
//! indices) with fixed lane accumulators, and the chunk partials are combined in index order
//! with Neumaier's compensated summation. Neither the thread count nor the SIMD width changes
//! the order of any floating-point operation, and no fused multiply-add is used anywhere (a
//! square is rounded, then added: acc ← acc + d·d, at every level and on every architecture;
//! Rust never contracts a multiply and an add into one instruction), so results are
//! bit-identical on every run, at every SIMD level, on the same data.
//!
//! The files, each a concept, from the bottom up (each uses only those above it in this list):
//!
//! * [`compensated`]: Neumaier's running sum, the exact two-sum, the fixed reduction of lanes.
//! * [`cumsum`]: the centred cumulative sum, whole or as checkpoints every 64 samples from which
//!   any window of it is rebuilt bit for bit; the finiteness check and the pivot.
//! * [`buffered`]: the buffered MOAV kernel, on a whole cumulative sum in memory (and the
//!   non-overlapping sums).
//! * [`segments`]: the segment recurrence of the streamed kernel, portable code: each segment
//!   of k starts from an exact d_k rebuilt from the checkpoints and carries
//!   d_{k+1} = d_k + (x_k − x_{k−m}) − (x_{k−m} − x_{k−2m}).
//! * [`vector`]: the AVX-512, AVX2 and SSE2 f64 vectors as one trait, so that each vector kernel
//!   is written once; their in-register transposes and the lane-layout copy of a chunk.
//! * [`simd_blocks`]: the SIMD block sums: the segments of a chunk as AVX-512, AVX2 or SSE2 lanes,
//!   walked in column blocks, all scales per block, each kernel generic over the vector type;
//!   the same operations in the same order as the portable code.
//! * [`streamed`]: the streamed MOAV kernel for long rate series: no series-sized buffer, the
//!   near scales in jobs that build the checkpoints as they go (`streamed/near.rs`), the far
//!   scales walked by residue class so that their lagged blocks are still cached
//!   (`streamed/far.rs`).
//!
//! The chi-square interval of a long series is streamed too, by the `ci_stream` module, from
//! [`cumsum::checkpoints`] and [`cumsum::prefix_window`].

pub(crate) mod buffered;
pub(crate) mod compensated;
pub(crate) mod cumsum;
pub(crate) mod segments;
pub(crate) mod simd_blocks;
pub(crate) mod streamed;
pub(crate) mod vector;

#[cfg(test)]
pub(crate) mod tests {
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
}
