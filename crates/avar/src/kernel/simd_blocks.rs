//! The SIMD block sums of the streamed MOAV kernel: on x86-64 and aarch64 the [`NSEG`] segments
//! of a chunk are vector lanes (eight per AVX-512 vector, four per AVX2 vector, two per SSE2 or
//! NEON vector at the scalar level; the level of [`crate::simd::level`]) and the chunk is walked in column blocks
//! of [`BLK`], all scales per block ([`chunk_all_with`]): the rows of x are transposed in
//! registers per scale ([`block_rows_with`]), except for the small scales (2m ≤ [`XH`]), which
//! share one transposed copy of the chunk, and the far scales that are whole steps of the
//! residue-class walk, which read the transposed copies of the chunks the walk visited (a ring
//! per thread); those run four (AVX2: two, SSE2: one) scales at a time ([`blocks_lanes_with`]).
//! Every lane performs the operations of [`seg_sum`](super::segments::seg_sum) in the same
//! order, so the results are those of the portable code ([`chunk_portable`]) bit for bit.
//! [`chunk_run`] is the entry point of the streamed walks: the vector walk on x86-64 and
//! aarch64 (cfg `simd_vectors`), the portable code per scale on other architectures.

// the vector paths' helpers (chunk-walk state, lane copies) are used only where the vector
// paths are built; other architectures build the portable path and leave them unused
#![cfg_attr(not(simd_vectors), allow(dead_code, unused_variables, unused_imports))]

use super::buffered::SCALE_BATCH;
use super::compensated::reduce_lanes;
use super::cumsum::Checkpoints;
use super::segments::{NSEG, SEG_FAR, SEG_NEAR, SegState, chunk_portable, d_start};
use super::vector::Line;
#[cfg(simd_vectors)]
use super::vector::{Base, F64x};
use crate::simd::SimdLevel;

/// Whether [`chunk_run`] walks full chunks with a vector kernel at every level (SSE2 on x86-64,
/// NEON on aarch64 at the scalar level), so that the far walk keeps a ring of lane copies;
/// other architectures run the portable code per scale.
pub(super) const VECTOR_WALK: bool = cfg!(simd_vectors);

/// Columns of a chunk that [`chunk_all_with`] runs for every scale of a batch before moving on
/// (the rows of x they read stay in L1 from one scale to the next; for dyadic scales the x_{k−2m}
/// rows of scale m are the x_{k−m'} rows of m' = 2m).
const BLK: usize = 64;
const _: () =
    assert!(SEG_NEAR.is_multiple_of(BLK) && SEG_FAR.is_multiple_of(BLK) && BLK.is_multiple_of(8));

/// How far past the chunk end [`block_rows_with`] reads with misalignment `s` (its last window).
const fn tail_reach(s: usize) -> usize {
    if s > 0 { 8 - s } else { 0 }
}

/// Halo (columns) of the transposed copy of a near chunk: scales with 2m ≤ XH read their lagged
/// samples from the copy (see `build_lanes_with` (vector)).
const XH: usize = 512;
const _: () = assert!(XH.is_multiple_of(8) && SEG_NEAR.is_multiple_of(8));

/// The vector kernels of the chunk walk, each written once ([`block_lanes_with`],
/// [`blocks_lanes_with`], [`block_rows_with`], [`chunk_all_with`]) and compiled for each vector
/// type's instruction set by `walk_entry_points!`.
///
/// # Safety
/// Every function needs the CPU to support the vector's instruction set (see [`F64x`]).
#[cfg(simd_vectors)]
pub(super) trait Walk: F64x {
    /// Scales per instruction stream of [`blocks_lanes_with`] (AVX-512: four, 32 state vectors;
    /// AVX2: two, 16 state vectors, the AVX2 register file; SSE2 and NEON: one, 16 state
    /// vectors).
    const GROUP: usize;
    /// Whether the rows of x are read aligned to cache lines ([`block_rows_with`] with the
    /// misalignment of the chunk; AVX-512), or unaligned from k = a (AVX2, SSE2, NEON).
    const ALIGN_ROWS: bool;
    /// [`block_lanes_with`].
    unsafe fn block_lanes<const N: usize>(
        buf: &[Line],
        offs: [[usize; 3]; N],
        j0: usize,
        j1: usize,
        st: &mut [SegState; N],
    );
    /// [`blocks_lanes_with`].
    unsafe fn blocks_lanes(
        buf: &[Line],
        lanes: &mut [([usize; 3], SegState)],
        j0: usize,
        j1: usize,
    );
    /// [`block_rows_with`].
    #[allow(clippy::too_many_arguments)]
    unsafe fn block_rows<const SEG: usize>(
        x: &[f64],
        m: usize,
        a: usize,
        s: usize,
        j0: usize,
        j1: usize,
        st: &mut SegState,
    );
    /// [`chunk_all_with`].
    #[allow(clippy::too_many_arguments)]
    unsafe fn chunk_all<const SEG: usize>(
        x: &[f64],
        ck: &Checkpoints,
        batch: &[u64],
        i: usize,
        next: Option<usize>,
        scratch: &mut Scratch,
        out: &mut [f64],
    );
}

/// The entry points of [`Walk`] for one vector type: each generic kernel compiled with the
/// target features `$feat` (the functions boundaries of the walk stay where they are for
/// both vector types).
#[cfg(simd_vectors)]
macro_rules! walk_entry_points {
    ($feat:literal) => {
        #[target_feature(enable = $feat)]
        unsafe fn block_lanes<const N: usize>(
            buf: &[Line],
            offs: [[usize; 3]; N],
            j0: usize,
            j1: usize,
            st: &mut [SegState; N],
        ) {
            // SAFETY: the instruction set is available (caller contract).
            unsafe { block_lanes_with::<Self, N>(buf, offs, j0, j1, st) }
        }
        #[target_feature(enable = $feat)]
        unsafe fn blocks_lanes(
            buf: &[Line],
            lanes: &mut [([usize; 3], SegState)],
            j0: usize,
            j1: usize,
        ) {
            // SAFETY: as above.
            unsafe { blocks_lanes_with::<Self>(buf, lanes, j0, j1) }
        }
        #[target_feature(enable = $feat)]
        unsafe fn block_rows<const SEG: usize>(
            x: &[f64],
            m: usize,
            a: usize,
            s: usize,
            j0: usize,
            j1: usize,
            st: &mut SegState,
        ) {
            // SAFETY: as above.
            unsafe { block_rows_with::<Self, SEG>(x, m, a, s, j0, j1, st) }
        }
        #[target_feature(enable = $feat)]
        unsafe fn chunk_all<const SEG: usize>(
            x: &[f64],
            ck: &Checkpoints,
            batch: &[u64],
            i: usize,
            next: Option<usize>,
            scratch: &mut Scratch,
            out: &mut [f64],
        ) {
            // SAFETY: as above.
            unsafe { chunk_all_with::<Self, SEG>(x, ck, batch, i, next, scratch, out) }
        }
    };
}

#[cfg(target_arch = "x86_64")]
impl Walk for std::arch::x86_64::__m512d {
    const GROUP: usize = 4;
    const ALIGN_ROWS: bool = true;
    walk_entry_points!("avx512f");
}

#[cfg(target_arch = "x86_64")]
impl Walk for std::arch::x86_64::__m256d {
    const GROUP: usize = 2;
    const ALIGN_ROWS: bool = false;
    walk_entry_points!("avx2");
}

/// SSE2, the x86-64 baseline: the walk of the scalar level on x86-64 (two lanes per vector,
/// separate multiply and add as at every level).
#[cfg(target_arch = "x86_64")]
impl Walk for std::arch::x86_64::__m128d {
    const GROUP: usize = 1;
    const ALIGN_ROWS: bool = false;
    walk_entry_points!("sse2");
}

/// NEON, the aarch64 baseline: the walk of the scalar level on aarch64 (two lanes per vector,
/// as SSE2's).
#[cfg(all(simd_vectors, target_arch = "aarch64"))]
impl Walk for std::arch::aarch64::float64x2_t {
    const GROUP: usize = 1;
    const ALIGN_ROWS: bool = false;
    walk_entry_points!("neon");
}

/// The AVX-512 and AVX2 walks (the scalar level's is [`Base`]'s).
#[cfg(target_arch = "x86_64")]
type Avx512 = std::arch::x86_64::__m512d;
#[cfg(target_arch = "x86_64")]
type Avx2 = std::arch::x86_64::__m256d;

/// [`block_rows_with`] for N scales at once from lane-layout copies
/// (`build_lanes_with` (vector)) in `buf`: for scale q the columns
/// x_k, x_{k−m}, x_{k−2m} of chunk column j are the line pairs at column `offs[q][0] + j`,
/// `offs[q][1] + j`, `offs[q][2] + j` of `buf`. Over the columns [j0, j1): per scale and
/// column, y = (x_k − x_{k−m}) − (x_{k−m} − x_{k−2m}) from aligned loads, then
/// acc ← acc + d·d; d += y: the operations of [`seg_sum`](super::segments::seg_sum) in the
/// same order (bit-identical results). The scales only share the instruction stream: their
/// independent recurrences hide the latency of each one's chain of adds.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn block_lanes_with<V: F64x, const N: usize>(
    buf: &[Line],
    offs: [[usize; 3]; N],
    j0: usize,
    j1: usize,
    st: &mut [SegState; N],
) {
    let w = V::W;
    assert!(j0 <= j1 && NSEG == 16 && offs.iter().flatten().all(|&o| 2 * (o + j1) <= buf.len()));
    // SAFETY: V's instruction set is available (caller contract); the loads read the aligned
    // W-lane parts of the lines buf[2(o + j) + W·g/8] for j < j1, g < NSEG/W, inside `buf`
    // (asserted).
    unsafe {
        let pt = buf.as_ptr().cast::<f64>();
        let mut d = [V::zero_seg(); N];
        let mut acc = [V::zero_seg(); N];
        for q in 0..N {
            for g in 0..NSEG / w {
                d[q].as_mut()[g] = V::loadu(st[q].d.as_ptr().add(w * g));
                acc[q].as_mut()[g] = V::loadu(st[q].acc.as_ptr().add(w * g));
            }
        }
        for j in j0..j1 {
            for q in 0..N {
                let [oa, ob, oc] = offs[q];
                let (d, acc) = (d[q].as_mut(), acc[q].as_mut());
                for g in 0..NSEG / w {
                    let xa = V::load(pt.add(16 * (oa + j) + w * g));
                    let xb = V::load(pt.add(16 * (ob + j) + w * g));
                    let xc = V::load(pt.add(16 * (oc + j) + w * g));
                    let y = V::sub(V::sub(xa, xb), V::sub(xb, xc));
                    acc[g] = V::sq_acc(acc[g], d[g]);
                    d[g] = V::add(d[g], y);
                }
            }
        }
        for q in 0..N {
            for g in 0..NSEG / w {
                V::storeu(st[q].d.as_mut_ptr().add(w * g), d[q].as_ref()[g]);
                V::storeu(st[q].acc.as_mut_ptr().add(w * g), acc[q].as_ref()[g]);
            }
        }
    }
}

/// Runs [`block_lanes_with`] for the scales given by their column offsets and states,
/// [`Walk::GROUP`] at a time.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn blocks_lanes_with<V: Walk>(
    buf: &[Line],
    lanes: &mut [([usize; 3], SegState)],
    j0: usize,
    j1: usize,
) {
    macro_rules! group {
        ($n:literal, $l:expr) => {{
            let mut s: [SegState; $n] = std::array::from_fn(|q| $l[q].1);
            let o: [[usize; 3]; $n] = std::array::from_fn(|q| $l[q].0);
            // SAFETY: V's instruction set is available (caller contract).
            unsafe { V::block_lanes::<$n>(buf, o, j0, j1, &mut s) };
            for (q, sq) in s.iter().enumerate() {
                $l[q].1 = *sq;
            }
        }};
    }
    for l in lanes.chunks_mut(V::GROUP) {
        match l.len() {
            1 => group!(1, l),
            2 => group!(2, l),
            3 => group!(3, l),
            _ => group!(4, l),
        }
    }
}

/// Advances the NSEG segment recurrences of a full chunk [a, a + NSEG·SEG) of scale m over the
/// columns of every segment (k = a + l·SEG + j) read in the windows j ∈ [jb − s, jb − s + W) for
/// jb = j0, j0 + W, … < j1 (plus the window at jb = SEG when j1 = SEG and s > 0), skipping
/// columns outside [0, SEG): with `s` the misalignment of x[a] in elements (AVX-512, m a
/// multiple of 8) every load is then 64-byte aligned; with s = 0 the rows are read unaligned
/// from k = a. W segments per vector (one lane each), straight from `x`: for every window the
/// three input rows of each segment are loaded, y is formed row-wise exactly as in
/// [`seg_sum`](super::segments::seg_sum), the W × W block is transposed in registers, and each
/// lane then performs acc ← acc + d·d; d += y_k in increasing k: the operations of
/// [`seg_sum`](super::segments::seg_sum) in the same order, so the results are bit-identical to
/// the portable path whatever s and however the columns are split into blocks.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn block_rows_with<V: F64x, const SEG: usize>(
    x: &[f64],
    m: usize,
    a: usize,
    s: usize,
    j0: usize,
    j1: usize,
    st: &mut SegState,
) {
    let w = V::W;
    assert!(
        a >= 2 * m + s
            && a + (NSEG * SEG) + tail_reach(s) <= x.len()
            && s < w
            && j0.is_multiple_of(w)
            && j1.is_multiple_of(w)
            && j1 <= SEG
    );
    // SAFETY: V's instruction set is available (caller contract). Every load reads x[k],
    // x[k − m] and x[k − 2m] for k in [a − s, a + NSEG·SEG + tail_reach(s)), inside `x` by the
    // assertion above; the state arrays hold NSEG = W·(NSEG/W) values.
    unsafe {
        let px = x.as_ptr();
        let mut dv = V::zero_seg();
        let mut av = V::zero_seg();
        let (dv, av) = (dv.as_mut(), av.as_mut());
        for g in 0..NSEG / w {
            dv[g] = V::loadu(st.d.as_ptr().add(w * g));
            av[g] = V::loadu(st.acc.as_ptr().add(w * g));
        }
        // the W columns jb − s + c (c = 0..W) of rows W·g..W·g + W, transposed: lane r of
        // column c is y at k = a + (W·g + r)·SEG + jb − s + c
        macro_rules! window {
            ($jb:expr, $g:expr) => {{
                let mut y = V::zero_rows();
                for (r, yr) in y.as_mut().iter_mut().enumerate() {
                    let k = a + (w * $g + r) * SEG + $jb - s;
                    let xa = V::loadu(px.add(k));
                    let xb = V::loadu(px.add(k - m));
                    let xc = V::loadu(px.add(k - 2 * m));
                    *yr = V::sub(V::sub(xa, xb), V::sub(xb, xc));
                }
                V::transpose(y)
            }};
        }
        let mut jb = j0;
        while jb < j1 {
            let lo = if jb == 0 { s } else { 0 };
            for g in 0..NSEG / w {
                let cols = window!(jb, g);
                if lo == 0 {
                    for &c in cols.as_ref() {
                        av[g] = V::sq_acc(av[g], dv[g]);
                        dv[g] = V::add(dv[g], c);
                    }
                } else {
                    for &c in &cols.as_ref()[lo..] {
                        av[g] = V::sq_acc(av[g], dv[g]);
                        dv[g] = V::add(dv[g], c);
                    }
                }
            }
            jb += w;
        }
        if j1 == SEG && s > 0 {
            for g in 0..NSEG / w {
                let cols = window!(SEG, g);
                for &c in &cols.as_ref()[..s] {
                    av[g] = V::sq_acc(av[g], dv[g]);
                    dv[g] = V::add(dv[g], c);
                }
            }
        }
        for g in 0..NSEG / w {
            V::storeu(st.d.as_mut_ptr().add(w * g), dv[g]);
            V::storeu(st.acc.as_mut_ptr().add(w * g), av[g]);
        }
    }
}

/// Chunk partials of chunk `i` for every scale of `batch` (each as [`chunk_portable`] would
/// return it, bit for bit), with the vector kernels of V: the chunk is walked in column blocks
/// of [`BLK`], all scales per block; the small scales read the halo copy of the chunk, the far
/// scales that are whole class steps the lane ring, the others transpose their rows in
/// registers. Scales whose chunk is not full go through [`chunk_portable`]. `next`, when given,
/// is the start of the chunk the caller runs next: its samples are prefetched towards L2 one
/// slice per column block, so that the requests are spread over the chunk's work (the far
/// grid's residue-class walk jumps FAR_M samples from chunk to chunk, out of reach of the
/// hardware prefetchers; on the far scales 2^21..2^25 of 10^8 samples, timed alternately with
/// and without: 104–108 ms → 94–97 ms including the checkpoint pass).
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn chunk_all_with<V: Walk, const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    batch: &[u64],
    i: usize,
    next: Option<usize>,
    scratch: &mut Scratch,
    out: &mut [f64],
) {
    let t = x.len();
    let a = i * (NSEG * SEG);
    // misalignment (elements) of x[a] and of every row start (SEG is a multiple of 8); the
    // AVX2 rows are read unaligned from k = a
    let mis = (x.as_ptr().wrapping_add(a) as usize % 64) / 8;
    let shift = |m: usize| {
        if V::ALIGN_ROWS && m.is_multiple_of(8) {
            mis
        } else {
            0
        }
    };
    let full = |m: usize| a >= 2 * m + shift(m) && a + (NSEG * SEG) + tail_reach(shift(m)) <= t;
    let chunk_full = a + NSEG * SEG <= t;
    // far walk: the lane-layout copy of this chunk goes to its ring slot (every full chunk of
    // the class, for the later chunks that lag back to it)
    let ring = match scratch.ring_pos {
        Some((tc, step)) if chunk_full && scratch.ring_slots > 0 => {
            let slot = tc % scratch.ring_slots;
            let dst = &mut scratch.ring[2 * SEG * slot..2 * SEG * (slot + 1)];
            // SAFETY: the vector level is available (caller contract); the chunk is full.
            unsafe { V::build_lanes::<SEG>(x, a, 0, dst) };
            Some((tc, step))
        }
        _ => None,
    };
    // scales with 2m ≤ XH read the halo copy of the chunk, built once for all of them; far
    // scales that are whole class steps (m = q·step) read the ring; the others transpose in
    // registers
    let halo_ok = a >= XH && chunk_full;
    let slots = scratch.ring_slots;
    let halo_offs = |m: usize| (halo_ok && 2 * m <= XH).then(|| [XH, XH - m, XH - 2 * m]);
    let ring_offs = |m: usize| {
        let (tc, step) = ring?;
        let q = m / step;
        (m.is_multiple_of(step) && 2 * q <= tc && 2 * q < slots)
            .then(|| [tc, tc - q, tc - 2 * q].map(|v| (v % slots) * SEG))
    };
    let Scratch {
        states,
        regs,
        xt,
        halo,
        ring_lanes,
        ring: ring_buf,
        ..
    } = scratch;
    states.clear();
    regs.clear();
    halo.clear();
    ring_lanes.clear();
    for m in batch.iter().map(|&m| m as usize).filter(|&m| full(m)) {
        let mut d = [0.0f64; NSEG];
        for (l, dl) in d.iter_mut().enumerate() {
            *dl = d_start(x, ck, m, a + l * SEG);
        }
        let st = SegState {
            d,
            acc: [0.0f64; NSEG],
        };
        let at = if let Some(offs) = halo_offs(m) {
            halo.push((offs, st));
            StateAt::Halo(halo.len() - 1)
        } else if let Some(offs) = ring_offs(m) {
            ring_lanes.push((offs, st));
            StateAt::Ring(ring_lanes.len() - 1)
        } else {
            regs.push((m, st));
            StateAt::Regs(regs.len() - 1)
        };
        states.push(at);
    }
    if !halo.is_empty() {
        if xt.len() < 2 * (XH + SEG) {
            xt.resize(2 * (XH + SEG), Line::default());
        }
        // SAFETY: the vector level is available (caller contract); a ≥ XH, the chunk is full.
        unsafe { V::build_lanes::<SEG>(x, a, XH, xt) };
    }
    // the samples of `next`, in one slice per column block (a hint only: no effect on values)
    let per_blk = NSEG * BLK;
    // (x86-64 only: Rust has no stable prefetch for aarch64)
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (next, per_blk);
    for j0 in (0..SEG).step_by(BLK) {
        #[cfg(target_arch = "x86_64")]
        if let Some(nx) = next {
            use std::arch::x86_64::{_MM_HINT_T1, _mm_prefetch};
            let lo = nx + (j0 / BLK) * per_blk;
            let mut p = lo;
            while p < (lo + per_blk).min(t) {
                // SAFETY: a hint that never faults; `wrapping_add` keeps the address defined
                // past the end
                unsafe { _mm_prefetch::<_MM_HINT_T1>(x.as_ptr().wrapping_add(p).cast()) };
                p += 8;
            }
        }
        // SAFETY: V's instruction set is available (caller contract); the halo copy was built
        // above.
        unsafe { V::blocks_lanes(xt, halo, j0, j0 + BLK) };
        // SAFETY: as above; this chunk's copy was built above, and the lagged ones when the
        // walk visited their chunks (2q ≤ t, 2q < slots).
        unsafe { V::blocks_lanes(ring_buf, ring_lanes, j0, j0 + BLK) };
        for (m, st) in regs.iter_mut() {
            // SAFETY: as above; the chunk is full for m (with its shift).
            unsafe { V::block_rows::<SEG>(x, *m, a, shift(*m), j0, j0 + BLK, st) };
        }
    }
    let mut done = states.iter();
    for (o, &m) in out.iter_mut().zip(batch) {
        let m = m as usize;
        *o = if full(m) {
            let st = match done.next().expect("one state per full scale") {
                StateAt::Regs(k) => &regs[*k].1,
                StateAt::Halo(k) => &halo[*k].1,
                StateAt::Ring(k) => &ring_lanes[*k].1,
            };
            reduce_lanes(&st.acc)
        } else {
            chunk_portable::<SEG>(x, ck, m, i)
        };
    }
}

/// Where the segment state of a scale lives during the vector chunk walk ([`chunk_all_with`]).
enum StateAt {
    /// At this index of the scales transposing in registers ([`Scratch::regs`]).
    Regs(usize),
    /// At this index of the scales reading the halo copy ([`Scratch::halo`]).
    Halo(usize),
    /// At this index of the scales reading the ring ([`Scratch::ring_lanes`]).
    Ring(usize),
}

/// Per-thread scratch of the chunk kernels (reused from chunk to chunk).
pub(super) struct Scratch {
    /// Where the segment state of each full scale of the vector chunk walk lives, in batch order.
    states: Vec<StateAt>,
    /// Scales (and states) that transpose their rows in registers ([`block_rows_with`]).
    regs: Vec<(usize, SegState)>,
    /// The halo copy of the chunk (`build_lanes_with` (vector)).
    xt: Vec<Line>,
    /// Column offsets and states of the scales that read `xt`, and of those that read `ring`.
    halo: Vec<([usize; 3], SegState)>,
    ring_lanes: Vec<([usize; 3], SegState)>,
    /// Far walk: lane copies of the chunks of the current residue class, chunk t of the class in
    /// slot t mod `ring_slots` (0: no ring).
    ring: Vec<Line>,
    ring_slots: usize,
    /// Far walk: (index t of the current chunk in its class, class step in samples).
    pub(super) ring_pos: Option<(usize, usize)>,
}

impl Scratch {
    pub(super) fn new<const SEG: usize>() -> Scratch {
        Scratch {
            states: Vec::with_capacity(SCALE_BATCH),
            regs: Vec::with_capacity(SCALE_BATCH),
            xt: Vec::new(),
            halo: Vec::new(),
            ring_lanes: Vec::new(),
            ring: Vec::new(),
            ring_slots: 0,
            ring_pos: None,
        }
    }

    /// A ring of `slots` lane copies of SEG-grid chunks (see `stream_group` (streamed)).
    pub(super) fn with_ring<const SEG: usize>(slots: usize) -> Scratch {
        let mut s = Scratch::new::<SEG>();
        s.ring = vec![Line::default(); 2 * SEG * slots];
        s.ring_slots = slots;
        s
    }
}

/// Chunk partials of chunk `i` on the grid of segment length SEG for every scale of `batch`,
/// written to `out` (the AVX-512, AVX2 or SSE2 chunk walk on x86-64, else [`chunk_portable`] per
/// scale). `next`: see
/// [`chunk_all_with`].
#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) fn chunk_run<const SEG: usize>(
    x: &[f64],
    ck: &Checkpoints,
    batch: &[u64],
    i: usize,
    simd: SimdLevel,
    scratch: &mut Scratch,
    next: Option<usize>,
    out: &mut [f64],
) {
    #[cfg(simd_vectors)]
    {
        crate::simd::note(simd);
        match simd {
            // SAFETY: `simd` is at most `simd::level()` (the callers pass it or, in tests, a
            // lower level): AVX-512F present.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx512 => unsafe {
                Avx512::chunk_all::<SEG>(x, ck, batch, i, next, scratch, out)
            },
            // SAFETY: as above: AVX2 present.
            #[cfg(target_arch = "x86_64")]
            SimdLevel::Avx2 => unsafe {
                Avx2::chunk_all::<SEG>(x, ck, batch, i, next, scratch, out)
            },
            // SAFETY: the scalar level's vectors are the target's baseline (SSE2 on x86-64,
            // NEON on aarch64): every CPU of the target has them. (On aarch64 no other level
            // is ever detected.)
            _ => unsafe { Base::chunk_all::<SEG>(x, ck, batch, i, next, scratch, out) },
        }
    }
    #[cfg(not(simd_vectors))]
    {
        let _ = (next, scratch);
        for (o, &m) in out.iter_mut().zip(batch) {
            *o = chunk_portable::<SEG>(x, ck, m as usize, i);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::cumsum::checkpoints;
    use crate::kernel::segments::{SEG_FAR, SEG_NEAR};
    use crate::kernel::tests::series;

    /// The chunk partials of every vector path equal the portable ones bit for bit, on both
    /// grids, for near and far scales, whole and partial chunks.
    #[test]
    fn vector_chunk_walks_match_the_portable_path() {
        let n = 3 * NSEG * SEG_NEAR + 12_345;
        let ms: Vec<u64> = vec![
            1, 2, 3, 7, 8, 64, 1000, 1024, 5000, 8192, 16_384, 20_000, 30_000,
        ];
        check_paths::<SEG_NEAR>(n, &ms);
        check_paths::<SEG_FAR>(n, &ms);
    }

    /// On the chunk grid of segment length SEG: every chunk partial is bit-identical between the
    /// portable code and [`chunk_run`] at every level up to the process's (SSE2 or NEON at the
    /// scalar level, AVX2, AVX-512), and between those chunk walks (all scales
    /// per column block, aligned windows, transposed copy for small scales) and the portable
    /// code at every misalignment of the data within a cache line.
    fn check_paths<const SEG: usize>(n: usize, ms: &[u64]) {
        let x = series(n, 0.0);
        let ck = checkpoints(&x).unwrap();
        let n_chunks = (n + 1).div_ceil(NSEG * SEG);
        let best = crate::simd::level();
        let paths = crate::simd::levels();
        for &m in ms {
            for i in 0..n_chunks {
                let p = chunk_portable::<SEG>(&x, &ck, m as usize, i);
                for &simd in &paths {
                    let mut q = [0.0];
                    let mut scratch = Scratch::new::<SEG>();
                    chunk_run::<SEG>(&x, &ck, &[m], i, simd, &mut scratch, None, &mut q);
                    assert_eq!(
                        p.to_bits(),
                        q[0].to_bits(),
                        "SEG {SEG} m {m} chunk {i} {simd:?}"
                    );
                }
            }
        }
        #[cfg(simd_vectors)]
        for walk in paths.iter().copied().filter(|w| *w <= best) {
            let big = series(n + 8, 0.0);
            for o in 0..8 {
                let xo = &big[o..o + n];
                let cko = checkpoints(xo).unwrap();
                // all scales, and the first 1 and 3 (groups of every size in the xt walk)
                for (i, ms) in (0..n_chunks).flat_map(|i| [(i, ms), (i, &ms[..1]), (i, &ms[..3])]) {
                    // (prefetching the following chunk, past the end for the last one)
                    let nx = Some((i + 1) * NSEG * SEG);
                    let mut q = vec![0.0; ms.len()];
                    let mut scratch = Scratch::new::<SEG>();
                    let sc = &mut scratch;
                    // SAFETY: `walk` ≤ `level()`: the CPU has its instructions.
                    unsafe {
                        match walk {
                            #[cfg(target_arch = "x86_64")]
                            SimdLevel::Avx512 => {
                                Avx512::chunk_all::<SEG>(xo, &cko, ms, i, nx, sc, &mut q)
                            }
                            #[cfg(target_arch = "x86_64")]
                            SimdLevel::Avx2 => {
                                Avx2::chunk_all::<SEG>(xo, &cko, ms, i, nx, sc, &mut q)
                            }
                            _ => Base::chunk_all::<SEG>(xo, &cko, ms, i, nx, sc, &mut q),
                        }
                    };
                    for (&m, qm) in ms.iter().zip(&q) {
                        let p = chunk_portable::<SEG>(xo, &cko, m as usize, i);
                        assert_eq!(
                            p.to_bits(),
                            qm.to_bits(),
                            "SEG {SEG} {walk} offset {o} m {m} chunk {i}"
                        );
                    }
                }
            }
        }
    }
}
