//! The streamed kernel of the overlapping Hadamard (OHVAR) and modified Allan (MVAR, hence TVAR)
//! variances of rate data: no series-sized buffer, one read of the series for all near scales
//! (which also builds the checkpoints) and one for all far ones.
//!
//! With c_k = Σ_{i<k} (y_i − pivot) the phase (in rate units, τ0 = 1; the pivot is the mean of
//! the first samples and cancels in every difference below) and P_k = Σ_{i<k} c_i the summed
//! phase, the terms are third differences at lag m, indexed by their newest point k:
//!
//! ```text
//! OHVAR: h_k = c_k − 3c_{k−m} + 3c_{k−2m} − c_{k−3m},  k = 3m … T      (T + 1 − 3m terms)
//! MVAR:  w_k = P_k − 3P_{k−m} + 3P_{k−2m} − P_{k−3m},  k = 3m … T + 1  (T + 2 − 3m terms)
//! ```
//!
//! (w_k is the sum of the m second differences of phase of the MVAR term j = k − 3m.) They obey
//! h_{k+1} = h_k + e_k, e_k = (y_k − y_{k−3m}) + 3(y_{k−2m} − y_{k−m}), and w_{k+1} = w_k + h_k:
//! a recurrence in four lagged streams of the rate samples. The k-axis is cut into chunks of
//! [`NSEG`] segments; every segment starts from values rebuilt exactly from checkpoints (c and P
//! every [`G`] samples as compensated pairs, [`Frames`]; directly from the samples for m < G)
//! and carries the recurrence over its length only, so rounding cannot drift beyond one segment.
//! With AVX-512 the 16 segments of a chunk are the lanes of two vectors (the e rows are
//! transposed in registers, the loads aligned to cache lines), with AVX2 of four and with SSE2
//! or NEON (the scalar level on x86-64 and aarch64) of eight (the rows read unaligned); the
//! kernels are written once over the vector type ([`Stream`]). Other architectures run the
//! portable code.
//!
//! Near scales (m ≤ [`NEAR_MAX_M`]) walk the chunks in order, in parallel jobs, all scales per
//! chunk while its samples are in cache (the lagged rows were read shortly before); each job
//! keeps its checkpoints in a local frame that it extends block by block as it goes (third
//! differences do not depend on the frame), and hands its block sums on to the global frame.
//! Far scales take shorter segments ([`SEG_FAR`]) and walk the chunks by residue class of step
//! [`CLASS_STEP`]: for m a multiple of the step the lagged rows are chunks the class visited a
//! few steps earlier, read from a ring of copies ([`Ring`]) that stays in cache.
//!
//! Determinism: a chunk's partial sum depends only on the samples, m, the chunk index and the
//! frame of its checkpoints (the near jobs' grid depends only on T), and partials are added in
//! chunk order with Neumaier's compensation, so results are bit-identical for any thread count
//! and whatever other scales are requested. The vector and portable paths perform the same
//! operations in the same order (acc ← acc + v·v, the square rounded before the addition; no
//! fused multiply-add anywhere).
//!
//! The portable path (other architectures, and the tests' reference) runs the loop of
//! [`seg_run`] for every segment (the same values, slower).
//! Phase (angle) input keeps the buffered path of the modules (the phase samples are not rate
//! samples). With a chi-square interval the values still come from here; only the noise
//! identification reads the cumulative sum.

// the vector paths' helpers (chunk-walk state, lane copies) are used only where the vector
// paths are built (cfg `simd_vectors`: x86-64, aarch64); other architectures build the
// portable path and leave them unused
#![cfg_attr(not(simd_vectors), allow(dead_code, unused_variables))]

use rayon::prelude::*;

use crate::error::AvarError;
use crate::kernel::compensated::{LANES, Neumaier, reduce_lanes, two_sum};
use crate::kernel::cumsum::{first_non_finite, pivot_of};
use crate::kernel::vector::Line;
#[cfg(simd_vectors)]
use crate::kernel::vector::{Base, F64x, build_lanes_at};
use crate::simd::SimdLevel;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{__m256d, __m512d};

/// Spacing (samples) of the checkpoints of c and P.
const G: usize = 64;
/// Segments per chunk (one vector lane each; reduced by the kernel's fixed tree).
const NSEG: usize = LANES;
/// Segment length of the near scales: a multiple of G (segment starts are checkpoints), and
/// 512 bytes more than a multiple of 4 KiB so that the 16 rows fall in different L1 sets.
const SEG_NEAR: usize = 1024 + G;
/// Segment length of the far scales: a power of two, so that the chunk width divides the class
/// step and the dyadic far lags.
const SEG_FAR: usize = 128;
/// Largest near cluster size: its lags reach 3m samples (1.5 MiB) back. Larger scales would
/// read their lagged rows from the last-level cache or memory in the near walk (four streams
/// per row, where the AV reads two) and take the far walk instead, whose ring holds them as
/// lane copies; the near jobs' warm-up (3m samples) is shorter too. Measured at 10^7 samples,
/// octave τ: OHDEV 30 → 24 ms against 2^19 with a class step of 2^20 (2^15 and 2^17 no
/// better); at 10^8, 348 → 306 ms.
const NEAR_MAX_M: usize = 1 << 16;
/// Class step (samples) of the far walk: the smallest far dyadic m, so that every far dyadic
/// scale reads its lagged chunks from the ring.
const CLASS_STEP: usize = 2 * NEAR_MAX_M;
/// Columns of a chunk run for every scale of a batch before moving on (rows stay in L1).
const BLK: usize = 64;
/// Scales per pass over the chunks (bounds the table of chunk partials).
const SCALE_BATCH: usize = 64;
const _: () = assert!(
    SEG_NEAR.is_multiple_of(G)
        && SEG_FAR.is_multiple_of(G)
        && SEG_NEAR.is_multiple_of(BLK)
        && SEG_FAR.is_multiple_of(BLK)
        && BLK.is_multiple_of(8)
        && CLASS_STEP.is_multiple_of(NSEG * SEG_FAR)
);

/// Which third difference is summed.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum Diff {
    /// h_k, of the phase (OHVAR).
    Hadamard,
    /// w_k, of the summed phase (MVAR).
    Modified,
}

impl Diff {
    /// One past the newest point of the last term: T + 1 (OHVAR), T + 2 (MVAR).
    fn k_end(self, t: usize) -> usize {
        match self {
            Diff::Hadamard => t + 1,
            Diff::Modified => t + 2,
        }
    }
}

/// A checkpoint: c and P at a multiple of G, each as an unevaluated compensated pair (hi, lo).
#[derive(Clone, Copy, Default)]
struct Entry {
    c: (f64, f64),
    p: (f64, f64),
}

/// The checkpoints of the phase c and the summed phase P (pivot-centred) at every G-th index,
/// from index `g0` on (entry g − g0 holds c and P at gG), in one frame: the global one (origin
/// 0, `g0` = 0, built by [`Frames::scan`]) or a near job's local one (origin g0·G, where c = P = 0,
/// extended block by block by [`Frames::extend`]). Third differences at lag m do not depend on
/// the frame (a change of origin adds a constant to c and a linear function of k to P), as long
/// as their four points lie in it.
struct Frames {
    pivot: f64,
    g0: usize,
    /// Index of the last checkpoint of the series, ⌊T/G⌋ (every later point is reached by a
    /// local sum from it).
    last: usize,
    ck: Vec<Entry>,
    /// The running compensated c and P of a local frame's next entry.
    run: ((f64, f64), (f64, f64)),
}

/// Σ (v − pivot) and Σ (v − pivot)·(G − 1 − r) over one full block of G samples (r the index in
/// the block), in eight lanes reduced by a fixed tree: the block's contribution to c and, with
/// G·c at its start, to P.
#[inline(always)]
fn block_sums(b: &[f64], pivot: f64) -> (f64, f64) {
    let mut s1 = [0.0f64; 8];
    let mut s2 = [0.0f64; 8];
    for (ch, wt) in b.chunks_exact(8).zip(WEIGHTS.chunks_exact(8)) {
        for l in 0..8 {
            let v = ch[l] - pivot;
            s1[l] += v;
            s2[l] += v * wt[l];
        }
    }
    (lane_tree(s1), lane_tree(s2))
}

/// [`block_sums`] with AVX-512 or AVX2 at those levels, the portable code at the scalar level
/// (the same lanes, operations and tree, so the same values). `level` must not exceed
/// [`crate::simd::level`].
#[inline(always)]
fn block_sums_fast(b: &[f64], pivot: f64, level: SimdLevel) -> (f64, f64) {
    #[cfg(target_arch = "x86_64")]
    match level {
        // SAFETY: `level` ≤ `simd::level()` (caller contract): the CPU has AVX-512F.
        SimdLevel::Avx512 => return unsafe { <__m512d as Stream>::block_sums(b, pivot) },
        // SAFETY: as above: the CPU has AVX2.
        SimdLevel::Avx2 => return unsafe { <__m256d as Stream>::block_sums(b, pivot) },
        SimdLevel::Scalar => {}
    }
    let _ = level;
    block_sums(b, pivot)
}

/// [`block_sums`] in 8/W vectors of V per accumulator (lane r of vector h is the portable lane
/// W·h + r), then the same tree.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
#[inline(always)]
unsafe fn block_sums_with<V: F64x>(b: &[f64], pivot: f64) -> (f64, f64) {
    let (w, n) = (V::W, 8 / V::W);
    assert!(b.len() == G && n <= 4 && n * w == 8);
    // SAFETY: V's instruction set is available (caller contract); the loads read b[8j..8j + 8]
    // and WEIGHTS[8j..8j + 8] for j < G/8 (length asserted).
    unsafe {
        let pv = V::splat(pivot);
        let mut s1 = [V::splat(0.0); 4];
        let mut s2 = s1;
        for j in 0..G / 8 {
            for h in 0..n {
                let v = V::sub(V::loadu(b.as_ptr().add(8 * j + w * h)), pv);
                s1[h] = V::add(s1[h], v);
                let wt = V::loadu(WEIGHTS.as_ptr().add(8 * j + w * h));
                s2[h] = V::add(s2[h], V::mul(v, wt));
            }
        }
        let (mut a1, mut a2) = ([0.0f64; 8], [0.0f64; 8]);
        for h in 0..n {
            V::storeu(a1.as_mut_ptr().add(w * h), s1[h]);
            V::storeu(a2.as_mut_ptr().add(w * h), s2[h]);
        }
        (lane_tree(a1), lane_tree(a2))
    }
}

/// The fixed pairwise reduction of eight lanes.
#[inline(always)]
fn lane_tree(s: [f64; 8]) -> f64 {
    ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]))
}

/// The weights G − 1 − r of the samples r of a block in its sum of partial sums.
const WEIGHTS: [f64; G] = {
    let mut w = [0.0f64; G];
    let mut r = 0;
    while r < G {
        w[r] = (G - 1 - r) as f64;
        r += 1;
    }
    w
};

/// Veltkamp's split of `a` into a 26-bit high part and the rest (both exact).
#[inline(always)]
fn split(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a;
    let hi = c - (c - a);
    (hi, a - hi)
}

/// Rows of samples per job of the parallel block pass.
const PCH: usize = 1 << 16;

/// The block sums of every full block of `y` into `sums[g].p` (one parallel pass).
fn block_pass(y: &[f64], pivot: f64, sums: &mut [Entry]) {
    let nb = y.len() / G;
    sums[..nb]
        .par_chunks_mut(PCH / G)
        .zip(y[..nb * G].par_chunks(PCH))
        .for_each(|(out, ys)| {
            for (o, b) in out.iter_mut().zip(ys.chunks_exact(G)) {
                o.p = block_sums(b, pivot);
            }
        });
}

impl Frames {
    /// The global frame from the block sums in `sums[g].p` (g < ⌊T/G⌋; `sums` has ⌊T/G⌋ + 1
    /// entries): a sequential compensated scan in place. Errors on non-finite samples (naming
    /// the first) and overflow.
    fn scan(y: &[f64], pivot: f64, mut ck: Vec<Entry>) -> Result<Frames, AvarError> {
        let nb = y.len() / G;
        let bad = |e: &Entry| !(e.p.0.is_finite() && e.p.1.is_finite());
        if !pivot.is_finite()
            || ck[..nb].iter().any(bad)
            || y[nb * G..].iter().any(|v| !v.is_finite())
        {
            return Err(non_finite_or_overflow(y));
        }
        let mut fr = Frames::local(pivot, 0, nb, Vec::new());
        fr.ck = Vec::new();
        for e in ck.iter_mut() {
            let b = e.p;
            *e = fr.next_entry(b);
        }
        let last = ck[nb];
        if !(last.c.0.is_finite() && last.p.0.is_finite() && last.p.1.is_finite()) {
            return Err(AvarError::Overflow);
        }
        fr.ck = ck;
        Ok(fr)
    }

    /// An empty local frame with origin g0·G (c = P = 0 there), for a series of `last`·G to
    /// `last`·G + G − 1 samples, in the buffer `ck` (its allocation is reused).
    fn local(pivot: f64, g0: usize, last: usize, mut ck: Vec<Entry>) -> Frames {
        ck.clear();
        ck.push(Entry::default());
        Frames {
            pivot,
            g0,
            last,
            ck,
            run: Default::default(),
        }
    }

    /// The entry at the current block start, then the running values advanced over the block
    /// with block sums `(b1, b2)`: P_{g+1} = P_g + (G·c_g + b2) (G·c exact; the block's part
    /// summed off the running chain, then one exact step), c_{g+1} = c_g + b1; each running
    /// value an unevaluated pair whose low part collects the rounding errors.
    #[inline(always)]
    fn next_entry(&mut self, (b1, b2): (f64, f64)) -> Entry {
        let ((ch, cl), (ph, pl)) = self.run;
        let (u, eu) = two_sum(G as f64 * ch, b2);
        let (p, ep) = two_sum(ph, u);
        let (c, ec) = two_sum(ch, b1);
        self.run = ((c, cl + ec), (p, pl + ((ep + eu) + G as f64 * cl)));
        Entry {
            c: (ch, cl),
            p: (ph, pl),
        }
    }

    /// Extends a local frame to the entries up to min(g_end, last), summing each new block of
    /// `y` (now in cache) and handing its sums to `keep(g, sums)`.
    /// The block sums run at `level` (at most [`crate::simd::level`]; the same values at
    /// every level).
    fn extend(
        &mut self,
        y: &[f64],
        g_end: usize,
        level: SimdLevel,
        keep: impl FnMut(usize, (f64, f64)),
    ) {
        #[cfg(target_arch = "x86_64")]
        match level {
            SimdLevel::Avx512 => {
                crate::simd::note(level);
                // SAFETY: `level` ≤ `simd::level()` (caller contract): the CPU has AVX-512F.
                return unsafe { self.extend_avx512(y, g_end, keep) };
            }
            SimdLevel::Avx2 => {
                crate::simd::note(level);
                // SAFETY: as above: the CPU has AVX2.
                return unsafe { self.extend_avx2(y, g_end, keep) };
            }
            SimdLevel::Scalar => {}
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = level;
        self.extend_impl(y, g_end, SimdLevel::Scalar, keep)
    }

    /// [`Frames::extend`] compiled for AVX2 (the same values: lane-wise operations only).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn extend_avx2(&mut self, y: &[f64], g_end: usize, keep: impl FnMut(usize, (f64, f64))) {
        self.extend_impl(y, g_end, SimdLevel::Avx2, keep)
    }

    /// [`Frames::extend`] compiled for AVX-512 (the same values: lane-wise operations only).
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn extend_avx512(
        &mut self,
        y: &[f64],
        g_end: usize,
        keep: impl FnMut(usize, (f64, f64)),
    ) {
        self.extend_impl(y, g_end, SimdLevel::Avx512, keep)
    }

    #[inline(always)]
    fn extend_impl(
        &mut self,
        y: &[f64],
        g_end: usize,
        level: SimdLevel,
        mut keep: impl FnMut(usize, (f64, f64)),
    ) {
        let g_end = g_end.min(self.last);
        while self.g0 + self.ck.len() <= g_end {
            let g = self.g0 + self.ck.len() - 1;
            let b = block_sums_fast(&y[g * G..(g + 1) * G], self.pivot, level);
            keep(g, b);
            let _ = self.next_entry(b);
            let (c, p) = self.run;
            self.ck.push(Entry { c, p });
        }
    }

    /// The entry at gG (g0 ≤ g ≤ last, and extended that far).
    #[inline(always)]
    fn entry(&self, g: usize) -> Entry {
        self.ck[g - self.g0]
    }

    /// c_p as an unevaluated pair: the checkpoint below p plus the local sum of the centred
    /// samples in between (fewer than 2G; p ≤ T).
    #[inline]
    fn c_at(&self, y: &[f64], p: usize) -> (f64, f64) {
        let g = (p / G).min(self.last);
        let (hi, lo) = self.entry(g).c;
        if p == g * G {
            return (hi, lo);
        }
        let mut l = [0.0f64; 4];
        for (i, v) in y[g * G..p].iter().enumerate() {
            l[i % 4] += v - self.pivot;
        }
        (hi, lo + ((l[0] + l[1]) + (l[2] + l[3])))
    }

    /// P_p as an unevaluated pair (p ≤ T + 1): P_g + r·c_g + Σ_{i=gG}^{p−2} (y_i − pivot)(p − 1 − i)
    /// with r = p − gG (r·c_g exact: r < 2^7 times the two halves of a split).
    #[inline]
    fn p_at(&self, y: &[f64], p: usize) -> (f64, f64) {
        let g = (p / G).min(self.last);
        let e = self.entry(g);
        if p == g * G {
            return e.p;
        }
        let r = (p - g * G) as f64;
        let mut l = [0.0f64; 4];
        for (j, v) in y[g * G..p - 1].iter().enumerate() {
            l[j % 4] += (v - self.pivot) * (p - 1 - g * G - j) as f64;
        }
        let (ah, al) = split(e.c.0);
        let (s, err) = two_sum(e.p.0, r * ah);
        (
            s,
            ((err + r * al) + (e.p.1 + r * e.c.1)) + ((l[0] + l[1]) + (l[2] + l[3])),
        )
    }
}

/// The error for samples whose sums are not finite: the first non-finite sample, or overflow.
fn non_finite_or_overflow(y: &[f64]) -> AvarError {
    match first_non_finite(y) {
        Some((index, value)) => AvarError::NonFinite { index, value },
        None => AvarError::Overflow,
    }
}

/// a − 3b + 3c − d of four unevaluated pairs, the large parts differenced exactly.
#[inline(always)]
fn third_diff(a: (f64, f64), b: (f64, f64), c: (f64, f64), d: (f64, f64)) -> f64 {
    let (s1, e1) = two_sum(a.0, -d.0);
    let (s2, e2) = two_sum(c.0, -b.0);
    let (t3, e3) = two_sum(s2, 2.0 * s2);
    let (s, e4) = two_sum(s1, t3);
    s + (((e1 + e4) + (e3 + 3.0 * e2)) + ((a.1 - d.1) + 3.0 * (c.1 - b.1)))
}

/// f(k) − 3f(k − m) + 3f(k − 2m) − f(k − 3m) of a function returning unevaluated pairs.
#[inline(always)]
fn third_diff_at(f: impl Fn(usize) -> (f64, f64), m: usize, k: usize) -> f64 {
    third_diff(f(k), f(k - m), f(k - 2 * m), f(k - 3 * m))
}

/// The exact starting values (h_k, w_k) of a segment at k (3m ≤ k; w is 0 for OHVAR). For
/// m < G straight from the samples: h_k = Σ_{i=k−m}^{k−1} (y_i − 2y_{i−m} + y_{i−2m}) and
/// w_k = Σ_{i=k−2m}^{k−2} (y_i − y_{i−m})·min(i − k + 2m + 1, k − 1 − i) (the pivot cancels);
/// otherwise from the checkpoints.
#[inline]
fn start(y: &[f64], fr: &Frames, kind: Diff, m: usize, k: usize) -> (f64, f64) {
    // at k = T + 1 (MVAR's last term, a segment of its own when T + 1 is a multiple of the
    // segment length) h_k would need the sample y_T, which does not exist; the segment reads
    // only w there (see `seg_run`), so h is 0
    let past_end = k > y.len();
    if m < G {
        let h = if past_end {
            0.0
        } else {
            (k - m..k)
                .map(|i| (y[i] - y[i - m]) - (y[i - m] - y[i - 2 * m]))
                .sum()
        };
        let w = match kind {
            Diff::Hadamard => 0.0,
            Diff::Modified => (k - 2 * m..k - 1)
                .map(|i| (y[i] - y[i - m]) * (i + 2 * m + 1 - k).min(k - 1 - i) as f64)
                .sum(),
        };
        return (h, w);
    }
    let h = if past_end {
        0.0
    } else {
        third_diff_at(|p| fr.c_at(y, p), m, k)
    };
    let w = match kind {
        Diff::Hadamard => 0.0,
        Diff::Modified => third_diff_at(|p| fr.p_at(y, p), m, k),
    };
    (h, w)
}

/// Σ v_k² over the segment [s, e) of scale m from the starting values (h, w) at s, where v is
/// h (OHVAR) or w (MVAR): acc ← acc + v·v; w += h (MVAR); h += e_k (for k < T).
#[inline(always)]
fn seg_run<const MOD: bool>(y: &[f64], m: usize, s: usize, e: usize, (h, w): (f64, f64)) -> f64 {
    let (mut h, mut w) = (h, w);
    let t = y.len();
    let mut acc = 0.0f64;
    for k in s..e {
        if MOD {
            acc += w * w;
            w += h;
        } else {
            acc += h * h;
        }
        if k < t {
            let p = y[k] - y[k - 3 * m];
            let q = y[k - 2 * m] - y[k - m];
            h += q * 3.0 + p;
        }
    }
    acc
}

/// [`seg_run`] of the kind of `kind`.
fn seg_sum(y: &[f64], kind: Diff, m: usize, s: usize, e: usize, hw: (f64, f64)) -> f64 {
    match kind {
        Diff::Hadamard => seg_run::<false>(y, m, s, e, hw),
        Diff::Modified => seg_run::<true>(y, m, s, e, hw),
    }
}

/// The starting values of the NSEG segments of the chunk at `a` (a multiple of G) for m ≥ G a
/// multiple of G, when every point is a checkpoint: lane by lane the operations of [`start`]
/// (so the same values), on arrays of the 16 segments (vectorised).
#[inline(always)]
fn starts_on_checkpoints<const SEG: usize>(
    fr: &Frames,
    kind: Diff,
    m: usize,
    a: usize,
    st: &mut SegState,
) {
    let entries: [[Entry; NSEG]; 4] =
        std::array::from_fn(|j| std::array::from_fn(|l| fr.entry((a + l * SEG - j * m) / G)));
    third_on_lanes(&entries, |e| e.c, &mut st.h);
    if kind == Diff::Modified {
        third_on_lanes(&entries, |e| e.p, &mut st.w);
    }
}

/// `out[l]` = [`third_diff`] of the pairs `f(entries[j][l])`, j = 0 … 3, for every lane l.
#[inline(always)]
fn third_on_lanes(
    entries: &[[Entry; NSEG]; 4],
    f: impl Fn(&Entry) -> (f64, f64),
    out: &mut [f64; NSEG],
) {
    let mut hi = [[0.0f64; NSEG]; 4];
    let mut lo = [[0.0f64; NSEG]; 4];
    for j in 0..4 {
        for l in 0..NSEG {
            (hi[j][l], lo[j][l]) = f(&entries[j][l]);
        }
    }
    for (l, o) in out.iter_mut().enumerate() {
        *o = third_diff(
            (hi[0][l], lo[0][l]),
            (hi[1][l], lo[1][l]),
            (hi[2][l], lo[2][l]),
            (hi[3][l], lo[3][l]),
        );
    }
}

/// The recurrences of the NSEG segments of one chunk for one scale.
#[derive(Clone, Copy, Default)]
struct SegState {
    h: [f64; NSEG],
    w: [f64; NSEG],
    acc: [f64; NSEG],
}

/// The vector kernels of the streamed walk, each written once over the vector type
/// ([`block_with`], [`lanes_with`], [`block_sums_with`], and [`starts_on_checkpoints`] and
/// [`Frames::extend`] compiled with its instruction set), for AVX-512 (`__m512d`), AVX2
/// (`__m256d`) and the scalar level's [`Base`] (SSE2's `__m128d`, NEON's `float64x2_t`).
///
/// # Safety
/// Every function needs the CPU to support the vector's instruction set.
#[cfg(simd_vectors)]
trait Stream: F64x {
    /// [`block_with`].
    unsafe fn block<const MOD: bool, const SEG: usize>(
        rows: &Rows<'_>,
        s: usize,
        j0: usize,
        j1: usize,
        st: &mut SegState,
    );
    /// [`lanes_with`].
    unsafe fn lanes<const MOD: bool>(
        buf: [&[Line]; 4],
        src: [usize; 4],
        j0: usize,
        j1: usize,
        st: &mut SegState,
    );
    /// [`block_sums_with`] (called at the AVX2 and AVX-512 levels; the scalar level sums its
    /// blocks with the portable code, which the compiler vectorises for the baseline).
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    unsafe fn block_sums(b: &[f64], pivot: f64) -> (f64, f64);
    /// [`starts_on_checkpoints`].
    unsafe fn starts<const SEG: usize>(
        fr: &Frames,
        kind: Diff,
        m: usize,
        a: usize,
        st: &mut SegState,
    );
}

/// The entry points of [`Stream`] for one vector type, compiled with the target features
/// `$feat`.
#[cfg(simd_vectors)]
macro_rules! stream_entry_points {
    ($feat:literal) => {
        #[target_feature(enable = $feat)]
        unsafe fn block<const MOD: bool, const SEG: usize>(
            rows: &Rows<'_>,
            s: usize,
            j0: usize,
            j1: usize,
            st: &mut SegState,
        ) {
            // SAFETY: the instruction set is available (caller contract).
            unsafe { block_with::<Self, MOD, SEG>(rows, s, j0, j1, st) }
        }
        #[target_feature(enable = $feat)]
        unsafe fn lanes<const MOD: bool>(
            buf: [&[Line]; 4],
            src: [usize; 4],
            j0: usize,
            j1: usize,
            st: &mut SegState,
        ) {
            // SAFETY: as above.
            unsafe { lanes_with::<Self, MOD>(buf, src, j0, j1, st) }
        }
        #[target_feature(enable = $feat)]
        unsafe fn block_sums(b: &[f64], pivot: f64) -> (f64, f64) {
            // SAFETY: as above.
            unsafe { block_sums_with::<Self>(b, pivot) }
        }
        #[target_feature(enable = $feat)]
        unsafe fn starts<const SEG: usize>(
            fr: &Frames,
            kind: Diff,
            m: usize,
            a: usize,
            st: &mut SegState,
        ) {
            starts_on_checkpoints::<SEG>(fr, kind, m, a, st)
        }
    };
}

#[cfg(target_arch = "x86_64")]
impl Stream for __m512d {
    stream_entry_points!("avx512f");
}

#[cfg(target_arch = "x86_64")]
impl Stream for __m256d {
    stream_entry_points!("avx2");
}

/// SSE2, the x86-64 baseline: the scalar level's kernels on x86-64.
#[cfg(target_arch = "x86_64")]
impl Stream for std::arch::x86_64::__m128d {
    stream_entry_points!("sse2");
}

/// NEON, the aarch64 baseline: the scalar level's kernels on aarch64.
#[cfg(all(simd_vectors, target_arch = "aarch64"))]
impl Stream for std::arch::aarch64::float64x2_t {
    stream_entry_points!("neon");
}

/// The vectors (h, w, acc) of a [`SegState`], NSEG/W of each.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn load_state<V: F64x>(st: &SegState) -> (V::Seg, V::Seg, V::Seg) {
    let w = V::W;
    // SAFETY: V's instruction set is available (caller contract); each array holds NSEG =
    // W·(NSEG/W) values.
    unsafe {
        let (mut h, mut wv, mut acc) = (V::zero_seg(), V::zero_seg(), V::zero_seg());
        for g in 0..NSEG / w {
            h.as_mut()[g] = V::loadu(st.h.as_ptr().add(w * g));
            wv.as_mut()[g] = V::loadu(st.w.as_ptr().add(w * g));
            acc.as_mut()[g] = V::loadu(st.acc.as_ptr().add(w * g));
        }
        (h, wv, acc)
    }
}

/// Stores the vectors (h, w, acc) back into a [`SegState`].
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn store_state<V: F64x>(st: &mut SegState, h: &V::Seg, wv: &V::Seg, acc: &V::Seg) {
    let w = V::W;
    // SAFETY: as in [`load_state`].
    unsafe {
        for g in 0..NSEG / w {
            V::storeu(st.h.as_mut_ptr().add(w * g), h.as_ref()[g]);
            V::storeu(st.w.as_mut_ptr().add(w * g), wv.as_ref()[g]);
            V::storeu(st.acc.as_mut_ptr().add(w * g), acc.as_ref()[g]);
        }
    }
}

/// e = (y_{k−2m} − y_{k−m})·3 + (y_k − y_{k−3m}) from the four lagged vectors.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn e_of<V: F64x>(y0: V, y1: V, y2: V, y3: V, three: V) -> V {
    // SAFETY: caller contract.
    unsafe { V::add(V::mul(V::sub(y2, y1), three), V::sub(y0, y3)) }
}

/// One step of the recurrences of one vector of lanes with the increment e, as in [`seg_run`]:
/// acc ← acc + v·v (v = w for MVAR, h for OHVAR); w += h (MVAR); h += e.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn step_state<V: F64x, const MOD: bool>(h: &mut V, w: &mut V, acc: &mut V, e: V) {
    // SAFETY: caller contract.
    unsafe {
        if MOD {
            *acc = V::sq_acc(*acc, *w);
            *w = V::add(*w, *h);
        } else {
            *acc = V::sq_acc(*acc, *h);
        }
        *h = V::add(*h, e);
    }
}

/// Where a scale's recurrences over a full chunk read their samples.
enum Src<'a> {
    /// Rows of samples, transposed in registers ([`block_with`]).
    Rows(Rows<'a>),
    /// Lane-layout copies: per lag, the buffer and the line index of chunk column 0
    /// ([`lanes_with`]).
    Lanes([&'a [Line]; 4], [usize; 4]),
}

/// Halo (columns) of the lane-layout copy of a chunk: scales with 3m ≤ XH read it.
const XH: usize = 512;

/// Where the recurrences of a full chunk read their samples: for each lag j (0: y_k, 1: y_{k−m},
/// 2: y_{k−2m}, 3: y_{k−3m}) a slice and the index in it of row 0, column 0, so that row l,
/// column c is at `off + l·SEG + c`; each slice reaches 8 elements before and after the rows.
type Rows<'a> = [(&'a [f64], usize); 4];

/// Advances the 16 segments of a full chunk (its rows in `rows`) over the columns read in the
/// windows [jb − s, jb − s + W) for jb = j0, j0 + W, … < j1 (multiples of W), plus the window at
/// jb = SEG when j1 = SEG and s > 0, skipping the columns outside [0, SEG): with `s` the
/// misalignment of row 0 in elements (the same in every slice; AVX-512) the loads are 64-byte
/// aligned, with s = 0 (AVX2) the rows are read unaligned from column 0. Per vector of W
/// segments and window, the rows e = (y_{k−2m} − y_{k−m})·3 + (y_k − y_{k−3m}) are formed,
/// transposed in registers, and each lane steps its recurrence column by column in increasing
/// k: the operations of [`seg_run`] in the same order, so the values are bit-identical to the
/// portable path whatever s, W and wherever the rows are read from.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn block_with<V: F64x, const MOD: bool, const SEG: usize>(
    rows: &Rows<'_>,
    s: usize,
    j0: usize,
    j1: usize,
    st: &mut SegState,
) {
    let w = V::W;
    assert!(
        rows.iter()
            .all(|(r, off)| *off >= 8 && off + NSEG * SEG + 8 <= r.len())
            && s < w
            && j0.is_multiple_of(w)
            && j1.is_multiple_of(w)
            && j1 <= SEG
    );
    // SAFETY: V's instruction set is available (caller contract); every load reads W elements
    // from off + l·SEG + jb − s with l < NSEG, jb ≤ SEG, s < W ≤ 8: inside
    // [off − 8, off + NSEG·SEG + 8) of its slice (asserted); the state arrays hold NSEG values.
    unsafe {
        let p = rows.map(|(r, off)| r.as_ptr().add(off));
        let three = V::splat(3.0);
        let (mut h, mut wv, mut acc) = load_state::<V>(st);
        let (h, wv, acc) = (h.as_mut(), wv.as_mut(), acc.as_mut());
        // the W columns jb − s + c of rows W·g … W·g + W − 1, transposed (lane r of column c:
        // e at row W·g + r, column jb − s + c)
        macro_rules! columns {
            ($jb:expr, $g:expr) => {{
                let mut e = V::zero_rows();
                for (r, er) in e.as_mut().iter_mut().enumerate() {
                    let q = (w * $g + r) * SEG + $jb;
                    let y0 = V::loadu(p[0].add(q).sub(s));
                    let y1 = V::loadu(p[1].add(q).sub(s));
                    let y2 = V::loadu(p[2].add(q).sub(s));
                    let y3 = V::loadu(p[3].add(q).sub(s));
                    *er = e_of(y0, y1, y2, y3, three);
                }
                V::transpose(e)
            }};
        }
        // two groups of W segments at a time over the whole block: their six state vectors stay
        // in registers at every width (all groups at once spill at AVX2 and SSE2 widths), and
        // two independent chains of adds hide each other's latency; each lane's steps keep
        // their order, so the values are the same
        for g0 in (0..NSEG / w).step_by(2) {
            let mut hg = [h[g0], h[g0 + 1]];
            let mut wg = [wv[g0], wv[g0 + 1]];
            let mut ag = [acc[g0], acc[g0 + 1]];
            let mut jb = j0;
            if jb == 0 && jb < j1 {
                for q in 0..2 {
                    for &c in &columns!(0, g0 + q).as_ref()[s..] {
                        step_state::<V, MOD>(&mut hg[q], &mut wg[q], &mut ag[q], c);
                    }
                }
                jb += w;
            }
            while jb < j1 {
                // the whole window: the columns stay in registers
                for q in 0..2 {
                    for &c in columns!(jb, g0 + q).as_ref() {
                        step_state::<V, MOD>(&mut hg[q], &mut wg[q], &mut ag[q], c);
                    }
                }
                jb += w;
            }
            if j1 == SEG && s > 0 {
                for q in 0..2 {
                    for &c in &columns!(SEG, g0 + q).as_ref()[..s] {
                        step_state::<V, MOD>(&mut hg[q], &mut wg[q], &mut ag[q], c);
                    }
                }
            }
            (h[g0], h[g0 + 1]) = (hg[0], hg[1]);
            (wv[g0], wv[g0 + 1]) = (wg[0], wg[1]);
            (acc[g0], acc[g0 + 1]) = (ag[0], ag[1]);
        }
        let (mut hs, mut ws, mut accs) = (V::zero_seg(), V::zero_seg(), V::zero_seg());
        hs.as_mut().copy_from_slice(h);
        ws.as_mut().copy_from_slice(wv);
        accs.as_mut().copy_from_slice(acc);
        store_state::<V>(st, &hs, &ws, &accs);
    }
}

/// [`block_with`] from lane-layout copies ([`build_lanes_at`]): the samples of lag j of chunk
/// column c are the line pair at `src[j] + 2c` (lane r of line 2c + h: row 8h + r), so that
/// e = (y_{k−2m} − y_{k−m})·3 + (y_k − y_{k−3m}) is formed from aligned loads without
/// transposes. Over the columns [j0, j1): the operations of [`seg_run`] in the same order, so
/// the values are bit-identical to the portable path.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn lanes_with<V: F64x, const MOD: bool>(
    buf: [&[Line]; 4],
    src: [usize; 4],
    j0: usize,
    j1: usize,
    st: &mut SegState,
) {
    let w = V::W;
    assert!(j0 <= j1 && (0..4).all(|j| src[j] + 2 * j1 <= buf[j].len()));
    // SAFETY: V's instruction set is available (caller contract); the loads read the aligned
    // W-lane parts of the lines buf[j][src[j] + 2c + W·g/8] for c < j1, g < NSEG/W, inside the
    // buffers (asserted).
    unsafe {
        let p: [*const f64; 4] = std::array::from_fn(|j| buf[j].as_ptr().add(src[j]).cast());
        let three = V::splat(3.0);
        let (mut h, mut wv, mut acc) = load_state::<V>(st);
        {
            let (h, wv, acc) = (h.as_mut(), wv.as_mut(), acc.as_mut());
            // two groups of W segments at a time: their six state vectors stay in registers at
            // every width (all groups at once spill at AVX2 and SSE2 widths), and two
            // independent chains of adds hide each other's latency; each lane's steps keep
            // their order, so the values are the same
            for g0 in (0..NSEG / w).step_by(2) {
                let mut hg = [h[g0], h[g0 + 1]];
                let mut wg = [wv[g0], wv[g0 + 1]];
                let mut ag = [acc[g0], acc[g0 + 1]];
                for c in j0..j1 {
                    for q in 0..2 {
                        let o = 16 * c + w * (g0 + q);
                        let y0 = V::load(p[0].add(o));
                        let y1 = V::load(p[1].add(o));
                        let y2 = V::load(p[2].add(o));
                        let y3 = V::load(p[3].add(o));
                        let e = e_of(y0, y1, y2, y3, three);
                        step_state::<V, MOD>(&mut hg[q], &mut wg[q], &mut ag[q], e);
                    }
                }
                (h[g0], h[g0 + 1]) = (hg[0], hg[1]);
                (wv[g0], wv[g0 + 1]) = (wg[0], wg[1]);
                (acc[g0], acc[g0 + 1]) = (ag[0], ag[1]);
            }
        }
        store_state::<V>(st, &h, &wv, &acc);
    }
}

/// Runs the recurrences of one full chunk's scale over the columns [j0, j0 + BLK) with the
/// kernels of V, from where `src` says.
///
/// # Safety
/// The CPU must support V's instruction set; the chunk must be full for the scale.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn run_block<V: Stream, const SEG: usize>(
    kind: Diff,
    src: &Src<'_>,
    s: usize,
    j0: usize,
    st: &mut SegState,
) {
    // SAFETY: caller contract.
    unsafe {
        match (kind, src) {
            (Diff::Hadamard, Src::Rows(r)) => V::block::<false, SEG>(r, s, j0, j0 + BLK, st),
            (Diff::Modified, Src::Rows(r)) => V::block::<true, SEG>(r, s, j0, j0 + BLK, st),
            (Diff::Hadamard, Src::Lanes(b, o)) => V::lanes::<false>(*b, *o, j0, j0 + BLK, st),
            (Diff::Modified, Src::Lanes(b, o)) => V::lanes::<true>(*b, *o, j0, j0 + BLK, st),
        }
    }
}

/// The far walk's lane-layout copies ([`build_lanes_at`]) of the chunks its residue class
/// visited last, in contiguous slots: a far scale that is a whole number q of class steps reads
/// its lagged samples from the copies of the chunks q, 2q and 3q steps back, as aligned lane
/// vectors, instead of from the series (where rows 2^k·8 bytes apart map to the same cache
/// sets and evict each other, and would have to be transposed).
struct Ring {
    buf: Vec<Line>,
    slots: usize,
    /// The index in its class of the chunk each slot holds.
    held: Vec<usize>,
    /// Class step (samples) and the index in its class of the current chunk.
    step: usize,
    tc: usize,
    /// The vector level that makes the copies (at most [`crate::simd::level`]).
    level: SimdLevel,
}

impl Ring {
    /// A ring of `slots` slots for the walk of class step `step` (0 slots: no ring), its copies
    /// made at `level` (at most [`crate::simd::level`]).
    fn new(slots: usize, step: usize, level: SimdLevel) -> Ring {
        Ring {
            buf: vec![Line::default(); slots * 2 * SEG_FAR],
            slots,
            held: vec![usize::MAX; slots],
            step,
            tc: 0,
            level,
        }
    }

    /// Copies the full chunk at `a` (the `tc`-th of its class) into its slot, transposed.
    fn put(&mut self, y: &[f64], a: usize, tc: usize) {
        self.tc = tc;
        if self.slots == 0 || a + NSEG * SEG_FAR > y.len() {
            return;
        }
        let slot = tc % self.slots;
        let dst = &mut self.buf[2 * SEG_FAR * slot..2 * SEG_FAR * (slot + 1)];
        #[cfg(simd_vectors)]
        // SAFETY: `level` ≤ `simd::level()` (see [`Ring::new`]); the chunk is full.
        unsafe {
            build_lanes_at::<SEG_FAR>(self.level, y, a, 0, dst)
        };
        // (the portable path's rings have no slots)
        #[cfg(not(simd_vectors))]
        let _ = dst;
        self.held[slot] = tc;
    }

    /// The line index of column 0 of the chunk `back` class steps before the current one, if
    /// held.
    fn lanes(&self, back: usize) -> Option<usize> {
        let tc = self.tc.checked_sub(back)?;
        let slot = tc % self.slots.max(1);
        (self.slots > 0 && self.held[slot] == tc).then_some(2 * SEG_FAR * slot)
    }
}

/// Which code runs the full chunks: the vector kernels of a level (on x86-64 every level has
/// them: AVX-512, AVX2, and SSE2 at the scalar level; on aarch64 NEON at the scalar level, the
/// only level there), or the portable code (other architectures; and the reference of the
/// tests). The same values either way.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Path {
    Portable,
    Vector(SimdLevel),
}

impl Path {
    /// The path of `level` on this architecture.
    fn of(level: SimdLevel) -> Path {
        if cfg!(simd_vectors) {
            Path::Vector(level)
        } else {
            Path::Portable
        }
    }

    /// The level of the code outside the chunk kernels (the block sums): the vector level, or
    /// the scalar level for the portable path.
    fn level(self) -> SimdLevel {
        match self {
            Path::Portable => SimdLevel::Scalar,
            Path::Vector(l) => l,
        }
    }
}

/// The partial sums of chunk `i` (segment length SEG) for every scale of `batch`, into `out`.
/// On a vector `path` full chunks run the vector kernel of its level, all scales per column
/// block, reading the lagged rows from the `ring` where it holds them; the others (and every
/// chunk on the portable path) run [`seg_sum`] per segment. The same value either way. The
/// level must not exceed [`crate::simd::level`].
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn chunk_partials<const SEG: usize>(
    y: &[f64],
    fr: &Frames,
    kind: Diff,
    batch: &[usize],
    i: usize,
    path: Path,
    ring: Option<&Ring>,
    (states, xt): &mut (Vec<SegState>, Vec<Line>),
    out: &mut [f64],
) {
    let t = y.len();
    let a = i * NSEG * SEG;
    let k_end = kind.k_end(t);
    let (simd, level) = (path != Path::Portable, path.level());
    let full = |m: usize| simd && a >= 3 * m + 8 && a + NSEG * SEG + 8 <= t;
    // misalignment (elements) of y[a] and of every row start (SEG is a multiple of 8): the
    // AVX-512 windows start there (aligned loads); the AVX2, SSE2 and NEON rows are read unaligned
    // from a
    let mis = if level == SimdLevel::Avx512 {
        (y.as_ptr().wrapping_add(a) as usize % 64) / 8
    } else {
        0
    };
    states.clear();
    for &m in batch.iter().filter(|&&m| full(m)) {
        let mut st = SegState::default();
        #[cfg(simd_vectors)]
        if m.is_multiple_of(G) {
            // SAFETY: `full` holds only at a vector level (≤ `simd::level()`): its instructions
            // are present.
            unsafe {
                match level {
                    #[cfg(target_arch = "x86_64")]
                    SimdLevel::Avx512 => {
                        <__m512d as Stream>::starts::<SEG>(fr, kind, m, a, &mut st)
                    }
                    #[cfg(target_arch = "x86_64")]
                    SimdLevel::Avx2 => <__m256d as Stream>::starts::<SEG>(fr, kind, m, a, &mut st),
                    // the scalar level (on aarch64 the only one)
                    _ => <Base as Stream>::starts::<SEG>(fr, kind, m, a, &mut st),
                }
            };
            states.push(st);
            continue;
        }
        for l in 0..NSEG {
            (st.h[l], st.w[l]) = start(y, fr, kind, m, a + l * SEG);
        }
        states.push(st);
    }
    #[cfg(simd_vectors)]
    if !states.is_empty() {
        crate::simd::note(level);
        // where each full scale reads its samples: the lane copy of this chunk with a halo of
        // XH columns (3m ≤ XH, built once for all of them), the ring (far scales that are whole
        // class steps, chunks held), else the rows of the series
        let halo = a >= XH && batch.iter().any(|&m| full(m) && 3 * m <= XH);
        if halo {
            xt.resize(2 * (XH + SEG), Line::default());
            // SAFETY: as above (the level's instructions present); a ≥ XH, the chunk is full.
            unsafe { build_lanes_at::<SEG>(level, y, a, XH, xt) };
        }
        let xt: &[Line] = xt;
        let from_ring = |m: usize| {
            let r = ring.filter(|r| m.is_multiple_of(r.step))?;
            let q = m / r.step;
            let src = [r.lanes(0)?, r.lanes(q)?, r.lanes(2 * q)?, r.lanes(3 * q)?];
            Some(Src::Lanes([&r.buf[..]; 4], src))
        };
        let srcs: Vec<Src<'_>> = batch
            .iter()
            .filter(|&&m| full(m))
            .map(|&m| {
                if halo && 3 * m <= XH {
                    Src::Lanes([xt; 4], [0, m, 2 * m, 3 * m].map(|l| 2 * (XH - l)))
                } else {
                    from_ring(m)
                        .unwrap_or_else(|| Src::Rows(std::array::from_fn(|j| (y, a - j * m))))
                }
            })
            .collect();
        for j0 in (0..SEG).step_by(BLK) {
            for (src, st) in srcs.iter().zip(states.iter_mut()) {
                // SAFETY: as above (the level's instructions present); the chunk is full for m.
                unsafe {
                    match level {
                        #[cfg(target_arch = "x86_64")]
                        SimdLevel::Avx512 => run_block::<__m512d, SEG>(kind, src, mis, j0, st),
                        #[cfg(target_arch = "x86_64")]
                        SimdLevel::Avx2 => run_block::<__m256d, SEG>(kind, src, mis, j0, st),
                        _ => run_block::<Base, SEG>(kind, src, mis, j0, st),
                    }
                }
            }
        }
    }
    #[cfg(not(simd_vectors))]
    let _ = (ring, mis, xt);
    let mut st = states.iter();
    for (o, &m) in out.iter_mut().zip(batch) {
        *o = if full(m) {
            reduce_lanes(&st.next().expect("one state per full scale").acc)
        } else {
            let mut acc = [0.0f64; NSEG];
            for (l, al) in acc.iter_mut().enumerate() {
                let s = (a + l * SEG).max(3 * m);
                let e = (a + (l + 1) * SEG).min(k_end);
                if s < e {
                    *al = seg_sum(y, kind, m, s, e, start(y, fr, kind, m, s));
                }
            }
            reduce_lanes(&acc)
        };
    }
}

/// OHVAR ([`Diff::Hadamard`], 3m ≤ T) or MVAR ([`Diff::Modified`], 3m ≤ T + 1) of the rate
/// samples `y` at each m of `ms`, in rate unit²: Σ h_k² / (6 m² (T + 1 − 3m)) resp.
/// Σ w_k² / (2 m⁴ (T + 2 − 3m)) from [`third_diff_sums`].
pub(crate) fn variances(y: &[f64], ms: &[u64], kind: Diff) -> Result<Vec<f64>, AvarError> {
    let t = y.len();
    let sums = third_diff_sums(y, ms, kind)?;
    Ok(sums
        .into_iter()
        .zip(ms)
        .map(|(s, &m)| {
            let f = 1.0 / m as f64;
            let n = (kind.k_end(t) - 3 * m as usize) as f64;
            match kind {
                Diff::Hadamard => s * f * f / (6.0 * n),
                Diff::Modified => s * f * f / ((m * m) as f64 * 2.0 * n),
            }
        })
        .collect())
}

/// Σ over the terms of the squared third differences (h_k² for OHVAR, w_k² for MVAR, in rate
/// unit² times m² resp. m⁴) at each m of `ms` (3m ≤ T + 1), streamed from the rate samples `y`.
/// Errors on non-finite samples (naming the first) and on overflow.
pub(crate) fn third_diff_sums(y: &[f64], ms: &[u64], kind: Diff) -> Result<Vec<f64>, AvarError> {
    let path = Path::of(crate::simd::level());
    third_diff_sums_with(y, ms, kind, path, NEAR_MAX_M, CLASS_STEP)
}

/// Target near chunks per job of the near walk (8.4 M samples), and the fewest jobs: a function
/// of the series length only, so that the local frames (hence the sums) do not depend on the
/// thread count.
const JOB_CHUNKS: usize = 480;
const MIN_JOBS: usize = 8;

/// Near chunks per job for `n_chunks` chunks: jobs of equal length, about [`JOB_CHUNKS`] each but
/// at least [`MIN_JOBS`] of them.
fn job_chunks(n_chunks: usize) -> usize {
    let jobs = n_chunks.div_ceil(JOB_CHUNKS).max(MIN_JOBS);
    n_chunks.div_ceil(jobs).max(1)
}

/// The chunk partials (chunk-major, `batch.len()` per chunk) of the near scales `batch` on the
/// [`SEG_NEAR`] grid, in one pass that also sums the blocks: the chunks are cut into jobs (run in
/// parallel), each walking its chunks in order in a local frame that starts `warm` samples
/// before the job (3m ≤ warm for every near scale) and is extended block by block just before
/// a chunk runs, while its samples are in cache. The block sums of each job's own range go to
/// `sums` (for the global frame of the far scales).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn near_walk(
    y: &[f64],
    pivot: f64,
    kind: Diff,
    batch: &[usize],
    path: Path,
    warm: usize,
    sums: &mut [Entry],
) -> Vec<f64> {
    let t = y.len();
    let last = t / G;
    let schunk = NSEG * SEG_NEAR;
    let n_chunks = kind.k_end(t).div_ceil(schunk);
    let jc = job_chunks(n_chunks);
    // each job's own blocks, from its first chunk start to the next job's
    let mut dsts = Vec::new();
    let mut rest = &mut sums[..last];
    for j in 0..n_chunks.div_ceil(jc) {
        let n = (jc * schunk / G).min(rest.len());
        let (d, r) = std::mem::take(&mut rest).split_at_mut(n);
        dsts.push((j, d));
        rest = r;
    }
    let w = batch.len();
    dsts.into_par_iter()
        .map_init(Default::default, |(scratch, buf), (j, dst)| {
            let chunks = j * jc..((j + 1) * jc).min(n_chunks);
            let a0 = chunks.start * schunk;
            let g0 = a0.saturating_sub(warm) / G;
            let mut fr = Frames::local(pivot, g0, last, std::mem::take(buf));
            let mut parts = vec![0.0f64; chunks.len() * w];
            for (i, o) in chunks.zip(parts.chunks_exact_mut(w)) {
                fr.extend(y, ((i + 1) * schunk).div_ceil(G), path.level(), |g, b| {
                    if let Some(d) = g.checked_sub(a0 / G).and_then(|q| dst.get_mut(q)) {
                        d.p = b;
                    }
                });
                chunk_partials::<SEG_NEAR>(y, &fr, kind, batch, i, path, None, scratch, o);
            }
            *buf = fr.ck;
            parts
        })
        .flatten()
        .collect()
}

/// `out[s]` = the Neumaier sum, in chunk order, of the partials `part(i, s)` of chunks 0..n.
fn combine(n: usize, idx: &[usize], part: impl Fn(usize, usize) -> f64, out: &mut [f64]) {
    for (s, &o) in idx.iter().enumerate() {
        let mut acc = Neumaier::default();
        for i in 0..n {
            acc.add(part(i, s));
        }
        out[o] = acc.value();
    }
}

/// [`third_diff_sums`] with the path (its level lowered to [`crate::simd::level`] if above it),
/// the near/far threshold and the class step as parameters (tests cover every path on short
/// series with small values).
fn third_diff_sums_with(
    y: &[f64],
    ms: &[u64],
    kind: Diff,
    path: Path,
    near_max_m: usize,
    class_step: usize,
) -> Result<Vec<f64>, AvarError> {
    // never above the process's level (the vector paths' safety rests on it)
    let path = match path {
        Path::Vector(l) => Path::Vector(l.min(crate::simd::level())),
        Path::Portable => Path::Portable,
    };
    crate::simd::note(SimdLevel::Scalar);
    let simd = path != Path::Portable;
    let t = y.len();
    let k_end = kind.k_end(t);
    let pivot = pivot_of(y);
    let mut out = vec![0.0f64; ms.len()];
    let (near, far): (Vec<usize>, Vec<usize>) =
        (0..ms.len()).partition(|&s| ms[s] as usize <= near_max_m);
    // near scales, building the block sums on the way (or one pass of block sums without them)
    let mut sums = vec![Entry::default(); t / G + 1];
    let warm = (3 * near_max_m).next_multiple_of(G);
    let n_near = k_end.div_ceil(NSEG * SEG_NEAR);
    for idx in near.chunks(SCALE_BATCH) {
        let batch: Vec<usize> = idx.iter().map(|&s| ms[s] as usize).collect();
        let w = batch.len();
        let parts = near_walk(y, pivot, kind, &batch, path, warm, &mut sums);
        combine(n_near, idx, |i, s| parts[i * w + s], &mut out);
    }
    if near.is_empty() {
        block_pass(y, pivot, &mut sums);
    }
    let fr = Frames::scan(y, pivot, sums)?;
    // far scales: the chunks by residue class (chunk i in class i mod n_cls, walked in order)
    let schunk = NSEG * SEG_FAR;
    let n_chunks = k_end.div_ceil(schunk);
    let n_cls = (class_step / schunk).clamp(1, n_chunks.max(1));
    let step = n_cls * schunk;
    for idx in far.chunks(SCALE_BATCH) {
        let batch: Vec<usize> = idx.iter().map(|&s| ms[s] as usize).collect();
        let w = batch.len();
        // ring slots back to the largest lag 3q·step of a scale that is q whole steps
        let q_max = batch
            .iter()
            .filter(|&&m| m.is_multiple_of(step))
            .map(|&m| m / step)
            .max()
            .unwrap_or(0);
        let slots = if simd && q_max > 0 { 3 * q_max + 1 } else { 0 };
        let by_class: Vec<Vec<f64>> = (0..n_cls)
            .into_par_iter()
            .map_init(
                || (Default::default(), Ring::new(slots, step, path.level())),
                |(scratch, ring), r| {
                    let mut parts = vec![0.0f64; (r..n_chunks).step_by(n_cls).len() * w];
                    let walk = (r..n_chunks).step_by(n_cls).zip(parts.chunks_exact_mut(w));
                    for (tc, (i, o)) in walk.enumerate() {
                        ring.put(y, i * schunk, tc);
                        let rg = Some(&*ring);
                        chunk_partials::<SEG_FAR>(y, &fr, kind, &batch, i, path, rg, scratch, o);
                    }
                    parts
                },
            )
            .collect();
        let part = |i: usize, s: usize| by_class[i % n_cls][(i / n_cls) * w + s];
        combine(n_chunks, idx, part, &mut out);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::kernel::tests::series;

    /// Small integers from −8 to 8 (from the bits of [`series`]): the phase and the summed
    /// phase are exact integers, so the sums of the squared third differences are exact in
    /// i128 (an O(T) reference for any m).
    fn integers(n: usize) -> Vec<f64> {
        series(n, 0.0)
            .iter()
            .map(|v| ((v.to_bits() >> 11) % 17) as f64 - 8.0)
            .collect()
    }

    fn exact_sums(y: &[f64], ms: &[u64], kind: Diff) -> Vec<f64> {
        let t = y.len();
        let mut c = vec![0i128; t + 1];
        for k in 0..t {
            c[k + 1] = c[k] + y[k] as i128;
        }
        let mut p = vec![0i128; t + 2];
        for k in 0..=t {
            p[k + 1] = p[k] + c[k];
        }
        let f = match kind {
            Diff::Hadamard => &c,
            Diff::Modified => &p,
        };
        ms.iter()
            .map(|&m| {
                let m = m as usize;
                let acc: i128 = (3 * m..kind.k_end(t))
                    .map(|k| {
                        let v = f[k] - 3 * f[k - m] + 3 * f[k - 2 * m] - f[k - 3 * m];
                        v * v
                    })
                    .sum();
                acc as f64
            })
            .collect()
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    // n = 3 near chunks and a part: near and far scales, powers of two and others, m < G
    // (restarts from the samples) and m ≥ G (from the checkpoints), the largest m = ⌊T/3⌋.
    const N: usize = 3 * NSEG * SEG_NEAR + 4321;
    const MS: [u64; 14] = [
        1, 2, 3, 7, 33, 64, 100, 1000, 1024, 4099, 8192, 16_384, 18_848, 18_000,
    ];

    fn run(y: &[f64], kind: Diff, path: Path, split: bool) -> Vec<f64> {
        // split: scales above 2000 are far, walked in classes of step 2 far chunks
        let (near_max, step) = if split {
            (2000, 2 * NSEG * SEG_FAR)
        } else {
            (NEAR_MAX_M, CLASS_STEP)
        };
        third_diff_sums_with(y, &MS, kind, path, near_max, step).unwrap()
    }

    /// The portable path and the path of every level up to the process's.
    fn paths() -> Vec<Path> {
        std::iter::once(Path::Portable)
            .chain(crate::simd::levels().into_iter().map(Path::of))
            .collect()
    }

    /// Exact on integer data (where the sums are exact integers below 2^53 per term and the
    /// recurrences carry no rounding): every path, near and far.
    #[test]
    fn streamed_sums_are_exact_on_integers() {
        let y = integers(N);
        for kind in [Diff::Hadamard, Diff::Modified] {
            let want = exact_sums(&y, &MS, kind);
            for split in [false, true] {
                for path in paths() {
                    let got = run(&y, kind, path, split);
                    for ((g, w), m) in got.iter().zip(&want).zip(MS) {
                        // the terms are exact (integer increments; the restarts carry only the
                        // u² rounding of the compensated checkpoints); a segment sums at most
                        // 1088 positive squares (each exact: an integer below 2^53), each addition
                        // rounding ≤ u of the running sum:
                        // ≤ 1088·u ≈ 1.2e-13 relative, the tree and Neumaier steps add ~u
                        assert!(rel(*g, *w) < 2e-13, "{kind:?} m {m} {path:?}: {g} vs {w}");
                    }
                }
            }
        }
    }

    /// Against the plain reference functions (literal formulas on the plainly integrated phase)
    /// on floating-point data: the reference's phase carries rounding of u·|x| per point
    /// (|x| ≲ 2·10^4 here), its third differences of size ≳ 0.3·√m lose at most
    /// 8u·|x|/|h| ≈ 1e-11 relative; ours lose far less (checkpoints compensated, recurrences over
    /// one segment), so 1e-9 is a bound with margin, not a tuned value.
    #[test]
    fn streamed_sums_match_the_reference() {
        use crate::config::InputKind;
        let y = series(N, 0.0);
        for split in [false, true] {
            let path = Path::of(crate::simd::level());
            let h = run(&y, Diff::Hadamard, path, split);
            let w = run(&y, Diff::Modified, path, split);
            for (s, m) in MS.iter().enumerate() {
                let n_h = (N + 1 - 3 * *m as usize) as f64;
                let n_w = (N + 2 - 3 * *m as usize) as f64;
                let mf = *m as f64;
                let oh = super::super::hdev::hvar_reference(&y, 1.0, InputKind::Rate, *m, true);
                assert!(
                    rel(h[s] / (mf * mf * 6.0 * n_h), oh.unwrap()) < 1e-9,
                    "ohvar m {m}"
                );
                if *m <= 8192 {
                    // (the O(T·m) reference is too slow beyond)
                    let mv = super::super::mdev::mvar_reference(&y, 1.0, InputKind::Rate, *m);
                    let ours = w[s] / (mf * mf * mf * mf * 2.0 * n_w);
                    assert!(rel(ours, mv.unwrap()) < 1e-9, "mvar m {m}");
                }
            }
        }
    }

    /// The path of every SIMD level up to the process's level (SSE2 or NEON at the scalar
    /// level, AVX2, AVX-512) gives the bits of the portable path, at every
    /// misalignment of the samples within a cache line; the value for m does not depend on the other scales requested; and
    /// an offset of 10^4 standard deviations changes nothing beyond the rounding of the shifted
    /// samples themselves (u·10^4·std each: relative 1e-12 on the sums).
    #[test]
    fn streamed_sums_are_path_independent_and_offset_proof() {
        let big = series(N + 8, 0.0);
        for kind in [Diff::Hadamard, Diff::Modified] {
            for split in [false, true] {
                let base = run(&big[..N], kind, Path::Portable, split);
                for o in 0..8 {
                    let portable = run(&big[o..o + N], kind, Path::Portable, split);
                    for path in paths() {
                        let got = run(&big[o..o + N], kind, path, split);
                        for ((a, b), m) in got.iter().zip(&portable).zip(MS) {
                            assert_eq!(
                                a.to_bits(),
                                b.to_bits(),
                                "{kind:?} {path:?} offset {o} m {m}"
                            );
                        }
                        if o == 0 {
                            for (a, b) in got.iter().zip(&base) {
                                assert_eq!(a.to_bits(), b.to_bits());
                            }
                        }
                    }
                }
                let (near_max, step) = if split {
                    (2000, 2 * NSEG * SEG_FAR)
                } else {
                    (NEAR_MAX_M, CLASS_STEP)
                };
                for (s, m) in MS.iter().enumerate() {
                    let path = Path::of(crate::simd::level());
                    let one = third_diff_sums_with(&big[..N], &[*m], kind, path, near_max, step);
                    assert_eq!(one.unwrap()[0].to_bits(), base[s].to_bits(), "m {m}");
                }
            }
            let y = &big[..N];
            let mean = y.iter().sum::<f64>() / N as f64;
            let sd = (y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / N as f64).sqrt();
            let shifted: Vec<f64> = y.iter().map(|v| v + 1e4 * sd).collect();
            let a = third_diff_sums(y, &MS, kind).unwrap();
            let b = third_diff_sums(&shifted, &MS, kind).unwrap();
            for ((u, v), m) in a.iter().zip(&b).zip(MS) {
                assert!(rel(*v, *u) < 1e-9, "{kind:?} m {m}: {u} vs {v}");
            }
        }
    }

    /// The block sums (a block's contribution to c and P) of every SIMD level up to the
    /// process's level are the portable ones bit for bit, at every misalignment of the block
    /// (samples with full 53-bit mantissas, so that the weighted products round: a fused
    /// multiply-add in place of the product and the sum would change the bits).
    #[test]
    fn block_sums_are_identical_at_every_level() {
        let y = series(64 * G + 8, 0.0);
        for pivot in [0.0, 0.25] {
            for o in 0..8 {
                for b in y[o..o + 64 * G].chunks_exact(G) {
                    let want = block_sums(b, pivot);
                    for level in crate::simd::levels() {
                        let got = block_sums_fast(b, pivot, level);
                        assert_eq!(
                            (got.0.to_bits(), got.1.to_bits()),
                            (want.0.to_bits(), want.1.to_bits()),
                            "{level} offset {o} pivot {pivot}"
                        );
                    }
                }
            }
        }
    }

    /// Bit-identical for 1, 2 and 3 threads (the chunk grid and the order of the sums do not
    /// depend on the thread count).
    #[test]
    fn streamed_sums_do_not_depend_on_the_thread_count() {
        let y = series(N, 3.0);
        let on = |threads: usize, kind: Diff, split: bool| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| run(&y, kind, Path::of(crate::simd::level()), split))
        };
        for kind in [Diff::Hadamard, Diff::Modified] {
            for split in [false, true] {
                let one = on(1, kind, split);
                for threads in [2, 3] {
                    for ((a, b), m) in one.iter().zip(&on(threads, kind, split)).zip(MS) {
                        assert_eq!(a.to_bits(), b.to_bits(), "{kind:?} {threads} m {m}");
                    }
                }
            }
        }
    }

    /// The first non-finite sample is named, wherever it lies; finite samples whose sums
    /// overflow are reported as overflow.
    #[test]
    fn streamed_sums_reject_non_finite_and_overflow() {
        for (index, value) in [(0, f64::NAN), (5000, f64::INFINITY), (N - 1, f64::NAN)] {
            let mut y = series(N, 0.0);
            y[index] = value;
            match third_diff_sums(&y, &[1, 8192], Diff::Modified) {
                Err(AvarError::NonFinite { index: i, .. }) => assert_eq!(i, index),
                other => panic!("index {index}: {other:?}"),
            }
        }
        let y = vec![1.7e308; N];
        assert!(matches!(
            third_diff_sums(&y, &[2], Diff::Hadamard),
            Err(AvarError::Overflow)
        ));
    }
}
