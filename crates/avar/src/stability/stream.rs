//! The streamed kernel of the overlapping Hadamard (OHVAR) and modified Allan (MVAR, hence TVAR)
//! variances of rate data: no series-sized buffer, one read of the series for all near scales
//! and one for all far ones (plus one to build the checkpoints).
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
//! transposed in registers). Near scales (m ≤ [`NEAR_MAX_M`]) walk the chunks in order, all
//! scales per chunk while its samples are in cache (the lagged rows were read shortly before);
//! far scales take shorter segments ([`SEG_FAR`]) and walk the chunks by residue class of step
//! [`CLASS_STEP`], so that for m a multiple of the step the lagged rows are chunks the class
//! visited a few steps earlier (still in cache).
//!
//! Determinism: a chunk's partial sum depends only on (samples, m, chunk index), the chunk grid
//! only on m, and partials are added in chunk order with Neumaier's compensation, so results
//! are bit-identical for any thread count and whatever other scales are requested. The vector
//! and portable paths perform the same operations in the same order (acc ← fma(v, v, acc)).
//!
//! Phase (angle) input and chi-square intervals keep the buffered path of the modules.

use rayon::prelude::*;

use crate::error::AvarError;
use crate::kernel::{Neumaier, first_non_finite, pivot_of, two_sum};

/// Spacing (samples) of the checkpoints of c and P.
const G: usize = 64;
/// Segments per chunk (one vector lane each).
const NSEG: usize = 16;
/// Segment length of the near scales: a multiple of G (segment starts are checkpoints), and
/// 512 bytes more than a multiple of 4 KiB so that the 16 rows fall in different L1 sets.
const SEG_NEAR: usize = 1024 + G;
/// Segment length of the far scales: a power of two, so that the chunk width divides the class
/// step and the dyadic far lags.
const SEG_FAR: usize = 256;
/// Largest near cluster size: its lags (3m samples, 6 MiB) stay in the last-level cache.
const NEAR_MAX_M: usize = 1 << 18;
/// Class step (samples) of the far walk.
const CLASS_STEP: usize = 1 << 19;
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

/// The checkpoints of the phase c and the summed phase P (pivot-centred, origin 0) at every
/// G-th index up to T.
struct Frames {
    pivot: f64,
    ck: Vec<Entry>,
}

/// Σ (v − pivot) and Σ (v − pivot)·(G − 1 − r) over one full block of G samples (r the index in
/// the block), in eight lanes reduced by a fixed tree: the block's contribution to c and, with
/// G·c at its start, to P.
#[inline(always)]
fn block_sums(b: &[f64], pivot: f64) -> (f64, f64) {
    let mut s1 = [0.0f64; 8];
    let mut s2 = [0.0f64; 8];
    for (j, ch) in b.chunks_exact(8).enumerate() {
        for l in 0..8 {
            let v = ch[l] - pivot;
            s1[l] += v;
            s2[l] += v * (G - 1 - 8 * j - l) as f64;
        }
    }
    let tree = |s: [f64; 8]| ((s[0] + s[1]) + (s[2] + s[3])) + ((s[4] + s[5]) + (s[6] + s[7]));
    (tree(s1), tree(s2))
}

/// Veltkamp's split of `a` into a 26-bit high part and the rest (both exact).
#[inline(always)]
fn split(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a;
    let hi = c - (c - a);
    (hi, a - hi)
}

impl Frames {
    /// One parallel pass of block sums (written into the checkpoint buffer), then a sequential
    /// compensated scan in place. Errors on non-finite samples (naming the first) and overflow.
    fn build(y: &[f64]) -> Result<Frames, AvarError> {
        const PCH: usize = 1 << 16;
        let t = y.len();
        let pivot = pivot_of(y);
        let nb = t / G;
        let mut ck = vec![Entry::default(); nb + 1];
        ck[..nb]
            .par_chunks_mut(PCH / G)
            .zip(y[..nb * G].par_chunks(PCH))
            .for_each(|(out, ys)| {
                for (o, b) in out.iter_mut().zip(ys.chunks_exact(G)) {
                    (o.p.0, o.p.1) = block_sums(b, pivot);
                }
            });
        let bad = |e: &Entry| !(e.p.0.is_finite() && e.p.1.is_finite());
        if !pivot.is_finite()
            || ck[..nb].iter().any(bad)
            || y[nb * G..].iter().any(|v| !v.is_finite())
        {
            return Err(non_finite_or_overflow(y));
        }
        let (mut c, mut p) = (Neumaier::default(), Neumaier::default());
        for e in ck.iter_mut() {
            let (b1, b2) = e.p;
            *e = Entry {
                c: (c.hi, c.lo),
                p: (p.hi, p.lo),
            };
            // P_{g+1} = P_g + G·c_g + Σ of the block's local partial sums (G·c exact)
            p.add(G as f64 * c.hi);
            p.add(G as f64 * c.lo);
            p.add(b2);
            c.add(b1);
        }
        let last = ck[nb];
        if !(last.c.0.is_finite() && last.p.0.is_finite() && last.p.1.is_finite()) {
            return Err(AvarError::Overflow);
        }
        Ok(Frames { pivot, ck })
    }

    /// c_p as an unevaluated pair: the checkpoint below p plus the local sum of the centred
    /// samples in between (fewer than 2G; p ≤ T).
    #[inline]
    fn c_at(&self, y: &[f64], p: usize) -> (f64, f64) {
        let g = (p / G).min(self.ck.len() - 1);
        let (hi, lo) = self.ck[g].c;
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
        let g = (p / G).min(self.ck.len() - 1);
        let e = self.ck[g];
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
    if m < G {
        let h = (k - m..k)
            .map(|i| (y[i] - y[i - m]) - (y[i - m] - y[i - 2 * m]))
            .sum();
        let w = match kind {
            Diff::Hadamard => 0.0,
            Diff::Modified => (k - 2 * m..k - 1)
                .map(|i| (y[i] - y[i - m]) * (i + 2 * m + 1 - k).min(k - 1 - i) as f64)
                .sum(),
        };
        return (h, w);
    }
    let h = third_diff_at(|p| fr.c_at(y, p), m, k);
    let w = match kind {
        Diff::Hadamard => 0.0,
        Diff::Modified => third_diff_at(|p| fr.p_at(y, p), m, k),
    };
    (h, w)
}

/// Σ v_k² over the segment [s, e) of scale m from the starting values (h, w) at s, where v is
/// h (OHVAR) or w (MVAR): acc ← fma(v, v, acc); w += h (MVAR); h += e_k (for k < T).
#[inline(always)]
fn seg_run<const MOD: bool>(y: &[f64], m: usize, s: usize, e: usize, (h, w): (f64, f64)) -> f64 {
    let (mut h, mut w) = (h, w);
    let t = y.len();
    let mut acc = 0.0f64;
    for k in s..e {
        if MOD {
            acc = w.mul_add(w, acc);
            w += h;
        } else {
            acc = h.mul_add(h, acc);
        }
        if k < t {
            let p = y[k] - y[k - 3 * m];
            let q = y[k - 2 * m] - y[k - m];
            h += q.mul_add(3.0, p);
        }
    }
    acc
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "fma")]
fn seg_run_fma<const MOD: bool>(y: &[f64], m: usize, s: usize, e: usize, hw: (f64, f64)) -> f64 {
    seg_run::<MOD>(y, m, s, e, hw)
}

/// [`seg_run`] with the hardware fused multiply-add where the CPU has it (the same value).
fn seg_sum(y: &[f64], kind: Diff, m: usize, s: usize, e: usize, hw: (f64, f64)) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU supports FMA (checked above).
        return unsafe {
            match kind {
                Diff::Hadamard => seg_run_fma::<false>(y, m, s, e, hw),
                Diff::Modified => seg_run_fma::<true>(y, m, s, e, hw),
            }
        };
    }
    match kind {
        Diff::Hadamard => seg_run::<false>(y, m, s, e, hw),
        Diff::Modified => seg_run::<true>(y, m, s, e, hw),
    }
}

/// The recurrences of the NSEG segments of one chunk for one scale.
#[derive(Clone, Copy, Default)]
struct SegState {
    h: [f64; NSEG],
    w: [f64; NSEG],
    acc: [f64; NSEG],
}

/// Fixed pairwise reduction of the NSEG segment sums.
fn reduce(acc: &[f64; NSEG]) -> f64 {
    let mut v = *acc;
    let mut n = NSEG;
    while n > 1 {
        n /= 2;
        for i in 0..n {
            v[i] += v[i + n];
        }
    }
    v[0]
}

/// Advances the 16 segments of the full chunk at `a` (3m ≤ a, a + NSEG·SEG ≤ T) over the
/// columns [j0, j1) (multiples of 8): per group of eight segments and eight columns, the rows
/// e = fma(y_{k−2m} − y_{k−m}, 3, y_k − y_{k−3m}) are formed, transposed in registers, and
/// each lane steps its recurrence column by column: the operations of [`seg_run`] in the same
/// order, so the values are bit-identical to the portable path.
///
/// # Safety
/// The CPU must support AVX-512F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn block_avx512<const MOD: bool, const SEG: usize>(
    y: &[f64],
    m: usize,
    a: usize,
    j0: usize,
    j1: usize,
    st: &mut SegState,
) {
    use crate::kernel::transpose8x8;
    use std::arch::x86_64::*;
    assert!(
        a >= 3 * m
            && a + NSEG * SEG <= y.len()
            && j0.is_multiple_of(8)
            && j1.is_multiple_of(8)
            && j1 <= SEG
    );
    // SAFETY: AVX-512F is available (caller contract); every load reads y[k − λ] for
    // k ∈ [a, a + NSEG·SEG) and λ ∈ {0, m, 2m, 3m}, inside `y` (asserted); the state arrays
    // hold NSEG = 16 values.
    unsafe {
        let py = y.as_ptr();
        let three = _mm512_set1_pd(3.0);
        let mut h = [_mm512_setzero_pd(); 2];
        let mut w = [_mm512_setzero_pd(); 2];
        let mut acc = [_mm512_setzero_pd(); 2];
        for g in 0..2 {
            h[g] = _mm512_loadu_pd(st.h.as_ptr().add(8 * g));
            w[g] = _mm512_loadu_pd(st.w.as_ptr().add(8 * g));
            acc[g] = _mm512_loadu_pd(st.acc.as_ptr().add(8 * g));
        }
        let mut jb = j0;
        while jb < j1 {
            for g in 0..2 {
                let mut e = [_mm512_setzero_pd(); 8];
                for (r, er) in e.iter_mut().enumerate() {
                    let k = a + (8 * g + r) * SEG + jb;
                    let y0 = _mm512_loadu_pd(py.add(k));
                    let y1 = _mm512_loadu_pd(py.add(k - m));
                    let y2 = _mm512_loadu_pd(py.add(k - 2 * m));
                    let y3 = _mm512_loadu_pd(py.add(k - 3 * m));
                    *er = _mm512_fmadd_pd(_mm512_sub_pd(y2, y1), three, _mm512_sub_pd(y0, y3));
                }
                for c in transpose8x8!(e) {
                    if MOD {
                        acc[g] = _mm512_fmadd_pd(w[g], w[g], acc[g]);
                        w[g] = _mm512_add_pd(w[g], h[g]);
                    } else {
                        acc[g] = _mm512_fmadd_pd(h[g], h[g], acc[g]);
                    }
                    h[g] = _mm512_add_pd(h[g], c);
                }
            }
            jb += 8;
        }
        for g in 0..2 {
            _mm512_storeu_pd(st.h.as_mut_ptr().add(8 * g), h[g]);
            _mm512_storeu_pd(st.w.as_mut_ptr().add(8 * g), w[g]);
            _mm512_storeu_pd(st.acc.as_mut_ptr().add(8 * g), acc[g]);
        }
    }
}

/// Whether the AVX-512 chunk kernel can run.
fn have_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The partial sums of chunk `i` (segment length SEG) for every scale of `batch`, into `out`.
/// Full chunks run the vector kernel when `simd`, all scales per column block; the others (and
/// every chunk without `simd`) run [`seg_sum`] per segment. The same value either way.
#[allow(clippy::too_many_arguments)]
fn chunk_partials<const SEG: usize>(
    y: &[f64],
    fr: &Frames,
    kind: Diff,
    batch: &[usize],
    i: usize,
    simd: bool,
    states: &mut Vec<SegState>,
    out: &mut [f64],
) {
    let t = y.len();
    let a = i * NSEG * SEG;
    let k_end = kind.k_end(t);
    let full = |m: usize| simd && a >= 3 * m && a + NSEG * SEG <= t;
    states.clear();
    for &m in batch.iter().filter(|&&m| full(m)) {
        let mut st = SegState::default();
        for l in 0..NSEG {
            (st.h[l], st.w[l]) = start(y, fr, kind, m, a + l * SEG);
        }
        states.push(st);
    }
    #[cfg(target_arch = "x86_64")]
    if !states.is_empty() {
        for j0 in (0..SEG).step_by(BLK) {
            let mut st = states.iter_mut();
            for &m in batch.iter().filter(|&&m| full(m)) {
                let s = st.next().expect("one state per full scale");
                // SAFETY: `simd` is set only when AVX-512F is present; the chunk is full for m.
                unsafe {
                    match kind {
                        Diff::Hadamard => block_avx512::<false, SEG>(y, m, a, j0, j0 + BLK, s),
                        Diff::Modified => block_avx512::<true, SEG>(y, m, a, j0, j0 + BLK, s),
                    }
                }
            }
        }
    }
    let mut st = states.iter();
    for (o, &m) in out.iter_mut().zip(batch) {
        *o = if full(m) {
            reduce(&st.next().expect("one state per full scale").acc)
        } else {
            let mut acc = [0.0f64; NSEG];
            for (l, al) in acc.iter_mut().enumerate() {
                let s = (a + l * SEG).max(3 * m);
                let e = (a + (l + 1) * SEG).min(k_end);
                if s < e {
                    *al = seg_sum(y, kind, m, s, e, start(y, fr, kind, m, s));
                }
            }
            reduce(&acc)
        };
    }
}

/// Σ over the terms of the squared third differences (h_k² for OHVAR, w_k² for MVAR, in rate
/// unit² times m² resp. m⁴) at each m of `ms` (3m ≤ T + 1), streamed from the rate samples `y`.
/// Errors on non-finite samples (naming the first) and on overflow.
pub(crate) fn third_diff_sums(y: &[f64], ms: &[u64], kind: Diff) -> Result<Vec<f64>, AvarError> {
    third_diff_sums_with(y, ms, kind, have_avx512(), NEAR_MAX_M, CLASS_STEP)
}

/// [`third_diff_sums`] with the vector kernel, the near/far threshold and the class step as
/// parameters (tests cover every path on short series with small values).
fn third_diff_sums_with(
    y: &[f64],
    ms: &[u64],
    kind: Diff,
    simd: bool,
    near_max_m: usize,
    class_step: usize,
) -> Result<Vec<f64>, AvarError> {
    let fr = Frames::build(y)?;
    let t = y.len();
    let k_end = kind.k_end(t);
    let mut out = vec![0.0f64; ms.len()];
    let (near, far): (Vec<usize>, Vec<usize>) =
        (0..ms.len()).partition(|&s| ms[s] as usize <= near_max_m);
    // near scales: the chunks in order (each thread takes contiguous runs of them)
    let schunk = NSEG * SEG_NEAR;
    let n_chunks = k_end.div_ceil(schunk);
    for idx in near.chunks(SCALE_BATCH) {
        let batch: Vec<usize> = idx.iter().map(|&s| ms[s] as usize).collect();
        let w = batch.len();
        let parts: Vec<Vec<f64>> = (0..n_chunks)
            .into_par_iter()
            .map_init(Vec::new, |states, i| {
                let mut o = vec![0.0f64; w];
                chunk_partials::<SEG_NEAR>(y, &fr, kind, &batch, i, simd, states, &mut o);
                o
            })
            .collect();
        for (s, &o) in idx.iter().enumerate() {
            let mut acc = Neumaier::default();
            for p in &parts {
                acc.add(p[s]);
            }
            out[o] = acc.value();
        }
    }
    // far scales: the chunks by residue class (chunk i in class i mod n_cls, walked in order)
    let schunk = NSEG * SEG_FAR;
    let n_chunks = k_end.div_ceil(schunk);
    let n_cls = (class_step / schunk).clamp(1, n_chunks.max(1));
    for idx in far.chunks(SCALE_BATCH) {
        let batch: Vec<usize> = idx.iter().map(|&s| ms[s] as usize).collect();
        let w = batch.len();
        let by_class: Vec<Vec<f64>> = (0..n_cls)
            .into_par_iter()
            .map_init(Vec::new, |states, r| {
                let mut parts = vec![0.0f64; (r..n_chunks).step_by(n_cls).len() * w];
                for (i, o) in (r..n_chunks).step_by(n_cls).zip(parts.chunks_exact_mut(w)) {
                    chunk_partials::<SEG_FAR>(y, &fr, kind, &batch, i, simd, states, o);
                }
                parts
            })
            .collect();
        for (s, &o) in idx.iter().enumerate() {
            let mut acc = Neumaier::default();
            for i in 0..n_chunks {
                acc.add(by_class[i % n_cls][(i / n_cls) * w + s]);
            }
            out[o] = acc.value();
        }
    }
    Ok(out)
}
