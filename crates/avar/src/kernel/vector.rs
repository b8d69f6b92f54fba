//! The f64 vectors of the vector paths as one trait ([`F64x`], for AVX-512's `__m512d`, AVX2's
//! `__m256d`, SSE2's `__m128d` and NEON's `float64x2_t`), so that each vector kernel is written
//! once for every width; their in-register transposes (8 × 8, 4 × 4, 2 × 2); and the
//! lane-layout copy of a chunk ([`build_lanes_with`]): the [`NSEG`] rows of a chunk turned into
//! columns, so that the samples x_{k−λ} of all 16 segments at one column are two aligned
//! 64-byte lines.
//!
//! The vector paths are built where the cfg `simd_vectors` is set (by the crate's build script:
//! x86-64, and aarch64 with NEON); other targets build the portable code only.

// the vector paths exist on x86-64 and aarch64 only
#![cfg_attr(not(simd_vectors), allow(dead_code, unused_variables, unused_imports))]

#[cfg(all(simd_vectors, target_arch = "aarch64"))]
use std::arch::aarch64::*;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use super::segments::NSEG;

/// The 8 × 8 transpose of eight AVX-512 vectors (`[__m512d; 8]`, rows → columns): 24 shuffles.
/// Needs `std::arch::x86_64::*` in scope and AVX-512F enabled at the use site.
#[cfg(target_arch = "x86_64")]
macro_rules! transpose8x8 {
    ($v:expr) => {{
        let v = $v;
        let t0 = _mm512_unpacklo_pd(v[0], v[1]);
        let t1 = _mm512_unpackhi_pd(v[0], v[1]);
        let t2 = _mm512_unpacklo_pd(v[2], v[3]);
        let t3 = _mm512_unpackhi_pd(v[2], v[3]);
        let t4 = _mm512_unpacklo_pd(v[4], v[5]);
        let t5 = _mm512_unpackhi_pd(v[4], v[5]);
        let t6 = _mm512_unpacklo_pd(v[6], v[7]);
        let t7 = _mm512_unpackhi_pd(v[6], v[7]);
        let u0 = _mm512_shuffle_f64x2::<0x88>(t0, t2);
        let u1 = _mm512_shuffle_f64x2::<0xDD>(t0, t2);
        let u2 = _mm512_shuffle_f64x2::<0x88>(t1, t3);
        let u3 = _mm512_shuffle_f64x2::<0xDD>(t1, t3);
        let u4 = _mm512_shuffle_f64x2::<0x88>(t4, t6);
        let u5 = _mm512_shuffle_f64x2::<0xDD>(t4, t6);
        let u6 = _mm512_shuffle_f64x2::<0x88>(t5, t7);
        let u7 = _mm512_shuffle_f64x2::<0xDD>(t5, t7);
        [
            _mm512_shuffle_f64x2::<0x88>(u0, u4),
            _mm512_shuffle_f64x2::<0x88>(u2, u6),
            _mm512_shuffle_f64x2::<0x88>(u1, u5),
            _mm512_shuffle_f64x2::<0x88>(u3, u7),
            _mm512_shuffle_f64x2::<0xDD>(u0, u4),
            _mm512_shuffle_f64x2::<0xDD>(u2, u6),
            _mm512_shuffle_f64x2::<0xDD>(u1, u5),
            _mm512_shuffle_f64x2::<0xDD>(u3, u7),
        ]
    }};
}

/// The 4 × 4 transpose of four AVX2 vectors (rows → columns): lane r of column c is lane c of
/// row r. Needs `std::arch::x86_64::*` in scope and AVX enabled at the use site.
#[cfg(target_arch = "x86_64")]
macro_rules! transpose4x4 {
    ($v:expr) => {{
        let v = $v;
        let t0 = _mm256_unpacklo_pd(v[0], v[1]);
        let t1 = _mm256_unpackhi_pd(v[0], v[1]);
        let t2 = _mm256_unpacklo_pd(v[2], v[3]);
        let t3 = _mm256_unpackhi_pd(v[2], v[3]);
        [
            _mm256_permute2f128_pd::<0x20>(t0, t2),
            _mm256_permute2f128_pd::<0x20>(t1, t3),
            _mm256_permute2f128_pd::<0x31>(t0, t2),
            _mm256_permute2f128_pd::<0x31>(t1, t3),
        ]
    }};
}

/// The 2 × 2 transpose of two SSE2 vectors (rows → columns).
#[cfg(target_arch = "x86_64")]
macro_rules! transpose2x2 {
    ($v:expr) => {{
        let v = $v;
        [_mm_unpacklo_pd(v[0], v[1]), _mm_unpackhi_pd(v[0], v[1])]
    }};
}

/// The 2 × 2 transpose of two NEON vectors (rows → columns).
#[cfg(all(simd_vectors, target_arch = "aarch64"))]
macro_rules! transpose2x2_neon {
    ($v:expr) => {{
        let v = $v;
        [vzip1q_f64(v[0], v[1]), vzip2q_f64(v[0], v[1])]
    }};
}

/// The vector of the scalar level: the two-lane f64 vector of the architecture's baseline,
/// SSE2's `__m128d` on x86-64, NEON's `float64x2_t` on aarch64 (every CPU of the target has it,
/// so no run-time check guards it).
#[cfg(target_arch = "x86_64")]
pub(crate) type Base = __m128d;
/// The vector of the scalar level: the two-lane f64 vector of the architecture's baseline,
/// SSE2's `__m128d` on x86-64, NEON's `float64x2_t` on aarch64 (every CPU of the target has it,
/// so no run-time check guards it).
#[cfg(all(simd_vectors, target_arch = "aarch64"))]
pub(crate) type Base = float64x2_t;

/// Eight f64 on one cache line (the element of the transposed copy).
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
pub(crate) struct Line([f64; 8]);

/// A vector of [`F64x::W`] f64 lanes and the operations the vector kernels use on it. Each
/// operation is one instruction of the vector's instruction set, with one rounding per
/// operation and no fused multiply-add (as the portable code, which Rust compiles without
/// contraction), so a kernel written once over this trait performs, lane by lane, the same
/// operations in the same order at every width.
///
/// # Safety
/// Every function needs the CPU to support the vector's instruction set (AVX-512F for
/// `__m512d`, AVX2 for `__m256d`, SSE2, which every x86-64 CPU has, for `__m128d`, NEON for
/// `float64x2_t`); the pointer functions also need their addresses to be valid for W f64
/// (aligned to the vector's size for `load` and `store`).
#[cfg(simd_vectors)]
pub(crate) trait F64x: Copy {
    /// f64 lanes per vector.
    const W: usize;
    /// W vectors (the rows, or columns, of one transpose).
    type Rows: Copy + AsRef<[Self]> + AsMut<[Self]>;
    /// NSEG / W vectors (the state of the NSEG segments of a chunk, one lane each).
    type Seg: Copy + AsRef<[Self]> + AsMut<[Self]>;
    unsafe fn zero_rows() -> Self::Rows;
    unsafe fn zero_seg() -> Self::Seg;
    unsafe fn load(p: *const f64) -> Self;
    unsafe fn loadu(p: *const f64) -> Self;
    unsafe fn store(p: *mut f64, v: Self);
    unsafe fn storeu(p: *mut f64, v: Self);
    unsafe fn add(a: Self, b: Self) -> Self;
    unsafe fn sub(a: Self, b: Self) -> Self;
    unsafe fn mul(a: Self, b: Self) -> Self;
    /// acc + d·d, rounded twice (the product, then the sum), as the portable code's
    /// `acc + d * d`.
    #[inline(always)]
    unsafe fn sq_acc(acc: Self, d: Self) -> Self {
        unsafe { Self::add(acc, Self::mul(d, d)) }
    }
    /// Every lane v.
    unsafe fn splat(v: f64) -> Self;
    /// Rows → columns: lane r of column c is lane c of row r.
    unsafe fn transpose(rows: Self::Rows) -> Self::Rows;
    /// [`build_lanes_with`] compiled for the vector's instruction set.
    unsafe fn build_lanes<const SEG: usize>(x: &[f64], a: usize, halo: usize, dst: &mut [Line]);
}

/// Implements [`F64x`] for one vector type from its width, target features and instructions.
#[cfg(simd_vectors)]
macro_rules! f64x_impl {
    ($v:ident, $w:literal, $feat:literal, $zero:ident, $load:ident, $loadu:ident, $store:ident,
     $storeu:ident, $add:ident, $sub:ident, $mul:ident, $splat:ident,
     $transpose:ident) => {
        impl F64x for $v {
            const W: usize = $w;
            type Rows = [$v; $w];
            type Seg = [$v; NSEG / $w];
            #[inline(always)]
            unsafe fn zero_rows() -> Self::Rows {
                unsafe { [$zero(); $w] }
            }
            #[inline(always)]
            unsafe fn zero_seg() -> Self::Seg {
                unsafe { [$zero(); NSEG / $w] }
            }
            #[inline(always)]
            unsafe fn load(p: *const f64) -> Self {
                unsafe { $load(p) }
            }
            #[inline(always)]
            unsafe fn loadu(p: *const f64) -> Self {
                unsafe { $loadu(p) }
            }
            #[inline(always)]
            unsafe fn store(p: *mut f64, v: Self) {
                unsafe { $store(p, v) }
            }
            #[inline(always)]
            unsafe fn storeu(p: *mut f64, v: Self) {
                unsafe { $storeu(p, v) }
            }
            #[inline(always)]
            unsafe fn add(a: Self, b: Self) -> Self {
                unsafe { $add(a, b) }
            }
            #[inline(always)]
            unsafe fn sub(a: Self, b: Self) -> Self {
                unsafe { $sub(a, b) }
            }
            #[inline(always)]
            unsafe fn mul(a: Self, b: Self) -> Self {
                unsafe { $mul(a, b) }
            }
            #[inline(always)]
            unsafe fn splat(v: f64) -> Self {
                unsafe { $splat(v) }
            }
            #[inline(always)]
            unsafe fn transpose(rows: Self::Rows) -> Self::Rows {
                unsafe { $transpose!(rows) }
            }
            #[target_feature(enable = $feat)]
            unsafe fn build_lanes<const SEG: usize>(
                x: &[f64],
                a: usize,
                halo: usize,
                dst: &mut [Line],
            ) {
                // SAFETY: the instruction set is available (caller contract).
                unsafe { build_lanes_with::<Self, SEG>(x, a, halo, dst) }
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
f64x_impl!(
    __m512d,
    8,
    "avx512f",
    _mm512_setzero_pd,
    _mm512_load_pd,
    _mm512_loadu_pd,
    _mm512_store_pd,
    _mm512_storeu_pd,
    _mm512_add_pd,
    _mm512_sub_pd,
    _mm512_mul_pd,
    _mm512_set1_pd,
    transpose8x8
);

#[cfg(target_arch = "x86_64")]
f64x_impl!(
    __m256d,
    4,
    "avx2",
    _mm256_setzero_pd,
    _mm256_load_pd,
    _mm256_loadu_pd,
    _mm256_store_pd,
    _mm256_storeu_pd,
    _mm256_add_pd,
    _mm256_sub_pd,
    _mm256_mul_pd,
    _mm256_set1_pd,
    transpose4x4
);

#[cfg(target_arch = "x86_64")]
f64x_impl!(
    __m128d,
    2,
    "sse2",
    _mm_setzero_pd,
    _mm_load_pd,
    _mm_loadu_pd,
    _mm_store_pd,
    _mm_storeu_pd,
    _mm_add_pd,
    _mm_sub_pd,
    _mm_mul_pd,
    _mm_set1_pd,
    transpose2x2
);

/// Every lane 0 (the NEON counterpart of `_mm_setzero_pd`).
#[cfg(all(simd_vectors, target_arch = "aarch64"))]
#[inline(always)]
unsafe fn neon_zero() -> float64x2_t {
    // SAFETY: NEON is part of the target's baseline (cfg `simd_vectors` on aarch64).
    unsafe { vdupq_n_f64(0.0) }
}

// NEON has one load and one store for aligned and unaligned addresses; its add, subtract and
// multiply round once each, as SSE2's (no fusion).
#[cfg(all(simd_vectors, target_arch = "aarch64"))]
f64x_impl!(
    float64x2_t,
    2,
    "neon",
    neon_zero,
    vld1q_f64,
    vld1q_f64,
    vst1q_f64,
    vst1q_f64,
    vaddq_f64,
    vsubq_f64,
    vmulq_f64,
    vdupq_n_f64,
    transpose2x2_neon
);

/// Transposed copy of the NSEG rows of the full chunk [a, a + NSEG·SEG) with a halo of `halo`
/// columns, written to `dst` (2·(halo + SEG) lines): `dst[2c + h]` holds, in lane r,
/// x[a + (8h + r)·SEG − halo + c] for c ∈ [0, halo + SEG), so that for any column j of the chunk
/// and any lag λ ≤ halo the samples x_{k−λ} of the 16 segments are two aligned vectors (no
/// transposes left in the lane kernels of `simd_blocks`). Rows are read W at a time and
/// transposed in registers; the copy is the same at every width. Needs a ≥ halo.
///
/// # Safety
/// The CPU must support V's instruction set.
#[cfg(simd_vectors)]
#[inline(always)]
unsafe fn build_lanes_with<V: F64x, const SEG: usize>(
    x: &[f64],
    a: usize,
    halo: usize,
    dst: &mut [Line],
) {
    let cols = halo + SEG;
    assert!(
        a >= halo
            && a + NSEG * SEG <= x.len()
            && NSEG == 16
            && halo.is_multiple_of(8)
            && dst.len() >= 2 * cols
    );
    // SAFETY: V's instruction set is available (caller contract); the loads read
    // x[a − halo + (W·q + r)·SEG + c] for c < cols, r < W, q < NSEG/W, inside
    // [a − halo, a + NSEG·SEG) (asserted); the stores write the W-lane parts of the aligned
    // lines dst[2c + W·q/8] for c < cols (length asserted).
    unsafe {
        let px = x.as_ptr().add(a - halo);
        let pt = dst.as_mut_ptr().cast::<f64>();
        for q in 0..NSEG / V::W {
            let mut c0 = 0;
            while c0 < cols {
                let mut v = V::zero_rows();
                for (r, vr) in v.as_mut().iter_mut().enumerate() {
                    *vr = V::loadu(px.add((V::W * q + r) * SEG + c0));
                }
                let col = V::transpose(v);
                for (cc, cv) in col.as_ref().iter().enumerate() {
                    let line = 2 * (c0 + cc) + V::W * q / 8;
                    V::store(pt.add(8 * line + (V::W * q) % 8), *cv);
                }
                c0 += V::W;
            }
        }
    }
}

/// The lane-layout copy ([`build_lanes_with`]) at `level` (AVX-512, AVX2, or the [`Base`]
/// vector at the scalar level; the same copy at every level), for the stability family's
/// streamed kernel.
///
/// # Safety
/// `level` must be a vector level the CPU supports (at most [`crate::simd::level`]).
#[cfg(simd_vectors)]
#[inline(always)]
pub(crate) unsafe fn build_lanes_at<const SEG: usize>(
    level: crate::simd::SimdLevel,
    x: &[f64],
    a: usize,
    halo: usize,
    dst: &mut [Line],
) {
    // SAFETY: caller contract.
    unsafe {
        match level {
            #[cfg(target_arch = "x86_64")]
            crate::simd::SimdLevel::Avx512 => {
                <__m512d as F64x>::build_lanes::<SEG>(x, a, halo, dst)
            }
            #[cfg(target_arch = "x86_64")]
            crate::simd::SimdLevel::Avx2 => <__m256d as F64x>::build_lanes::<SEG>(x, a, halo, dst),
            // the scalar level (on aarch64 the only level: the others are never detected)
            _ => <Base as F64x>::build_lanes::<SEG>(x, a, halo, dst),
        }
    }
}
