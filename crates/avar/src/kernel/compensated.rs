//! Compensated and fixed-order summation: Neumaier's running sum, the exact two-sum, and the
//! fixed pairwise reduction of [`LANES`] accumulators that every kernel ends its lanes with (so
//! that no sum depends on the SIMD width or the thread count).

/// Number of independent accumulator lanes in the inner loops.
pub(crate) const LANES: usize = 16;

/// Neumaier's compensated accumulator.
#[derive(Clone, Copy, Default, Debug)]
pub(crate) struct Neumaier {
    pub(crate) hi: f64,
    pub(crate) lo: f64,
}

impl Neumaier {
    #[inline(always)]
    pub(crate) fn add(&mut self, x: f64) {
        let t = self.hi + x;
        if self.hi.abs() >= x.abs() {
            self.lo += (self.hi - t) + x;
        } else {
            self.lo += (x - t) + self.hi;
        }
        self.hi = t;
    }
    #[inline(always)]
    pub(crate) fn value(&self) -> f64 {
        self.hi + self.lo
    }
}

/// The fixed pairwise reduction of [`LANES`] accumulators.
#[inline(always)]
pub(crate) fn reduce_lanes(acc: &[f64; LANES]) -> f64 {
    // fixed pairwise tree
    let mut v = *acc;
    let mut w = LANES;
    while w > 1 {
        w /= 2;
        for i in 0..w {
            v[i] += v[i + w];
        }
    }
    v[0]
}

#[inline(always)]
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// Whether `f64::mul_add` is a single hardware instruction in this build: on x86 only when the
/// build enables FMA (`-C target-feature=+fma` or a `target-cpu` that has it), otherwise the
/// library's `fma`, a call per use; on the other architectures the kernels are built for
/// (aarch64, and the other 64-bit targets with a fused multiply-add in their base instruction
/// set) always.
pub(crate) const HW_FMA: bool = cfg!(any(
    not(any(target_arch = "x86", target_arch = "x86_64")),
    target_feature = "fma"
));

/// 2^e for a normal exponent e.
const fn pow2(e: i32) -> f64 {
    f64::from_bits(((1023 + e) as u64) << 52)
}

/// Veltkamp's splitting constant 2^27 + 1: `a` = hi + lo with hi and lo of 26 bits each.
const SPLIT: f64 = 134_217_729.0;

/// The smallest non-zero |d| for which [`sq_add`] is exact: the rounding error of d² is a
/// normal number (2^−450: d² ≥ 2^−900, its error ≥ 2^−1006 in magnitude or 0).
pub(crate) const SQ_ADD_MIN: f64 = pow2(-450);
/// The largest accumulator for which [`sq_add`] is exact (2^899: acc + d² cannot overflow).
/// As acc ≥ d² for every d added, an accumulator at most this after the last step also bounds
/// every |d| by 2^450.
pub(crate) const SQ_ADD_ACC_MAX: f64 = pow2(899);

/// acc + d², correctly rounded (one rounding, the value of `d.mul_add(d, acc)`), for acc ≥ 0,
/// from plain additions and multiplications: no fused multiply-add, no call, so that the
/// portable kernel compiled without FMA keeps the bits of the FMA vector paths at a fraction
/// of the cost of the library `fma` (and the compiler can keep it in SSE2 registers).
///
/// Boldo and Melquiond's emulated FMA (IEEE Trans. Computers 57(4), 2008, proved in Coq):
/// d² = uh + ul exactly (Dekker's product with Veltkamp's split), acc + uh = th + tl exactly
/// (Dekker's fast two-sum, exact here as both terms are ≥ 0, the larger one first),
/// v = tl + ul rounded to odd (its two-sum; inexact: the sum truncated towards zero with its
/// last significand bit set), and RN(th + v) = RN(d² + acc).
///
/// Exact for 0 ≤ acc ≤ [`SQ_ADD_ACC_MAX`] and d = 0 or [`SQ_ADD_MIN`] ≤ |d| ≤ 2^450 (no
/// overflow, no underflow in the error terms); the callers check those bounds and fall
/// back to `mul_add` outside them. A NaN d or acc, or |d| ≥ 2^512, gives a NaN or a value
/// above 2^900 (so that a caller checking acc ≤ [`SQ_ADD_ACC_MAX`] afterwards falls back).
#[inline(always)]
pub(crate) fn sq_add(d: f64, acc: f64) -> f64 {
    // d² = uh + ul exactly (Dekker, Veltkamp's split of d into 26-bit halves)
    let c = SPLIT * d;
    let hi = c - (c - d);
    let lo = d - hi;
    let uh = d * d;
    let ul = ((hi * hi - uh) + (hi + hi) * lo) + lo * lo;
    // acc + uh = th + tl exactly (both ≥ 0: the fast two-sum with the larger term first)
    let th = acc + uh;
    let (big, small) = if acc > uh { (acc, uh) } else { (uh, acc) };
    let tl = small - (th - big);
    th + add_odd(tl, ul)
}

/// a + b rounded to odd: the rounded sum if it is exact, else the sum truncated towards zero
/// with its last significand bit set (the intermediate rounding of Boldo and Melquiond's
/// emulations, after which one more rounding to nearest is correct).
#[inline(always)]
fn add_odd(a: f64, b: f64) -> f64 {
    let (v, err) = two_sum(a, b);
    let vb = v.to_bits();
    // inexact: truncate (one unit less in magnitude when v was rounded away from zero, that
    // is when err has the other sign) and set the last bit; written without a branch, which
    // would be taken at random
    let inexact = (err != 0.0) as u64;
    let away = ((vb ^ err.to_bits()) >> 63) & inexact;
    f64::from_bits(vb.wrapping_sub(away) | inexact)
}

/// The smallest non-zero |q| and |p| for which [`triple_add`] is exact (2^−450: every error term
/// of its sums is then a normal number or 0).
pub(crate) const TRIPLE_ADD_MIN: f64 = pow2(-450);
/// The largest |q| and |p| for which [`triple_add`] is exact (2^450: no sum can overflow).
pub(crate) const TRIPLE_ADD_MAX: f64 = pow2(450);

/// 3q + p, correctly rounded (one rounding, the value of `q.mul_add(3.0, p)`), from plain
/// additions: 2q is exact, 2q + q = s + e exactly (two-sum), p + s = th + tl exactly, and
/// RN(th + RO(tl + e)) = RN(p + s + e) (Boldo and Melquiond's correctly rounded sum of three
/// numbers, the same paper as [`sq_add`]). Exact for q and p each 0 or of magnitude in
/// [[`TRIPLE_ADD_MIN`], [`TRIPLE_ADD_MAX`]]; the callers check those bounds and fall back to
/// `mul_add` outside them.
#[inline(always)]
pub(crate) fn triple_add(q: f64, p: f64) -> f64 {
    let (s, e) = two_sum(q + q, q);
    let (th, tl) = two_sum(p, s);
    th + add_odd(tl, e)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift64, deterministic.
    fn next(s: &mut u64) -> u64 {
        *s ^= *s << 13;
        *s ^= *s >> 7;
        *s ^= *s << 17;
        *s
    }

    /// A double with a significand of `bits` random bits (1 ≤ bits ≤ 53) times 2^e: short
    /// significands make d² exact or acc + d² fall on ties between two doubles, the cases where
    /// a double rounding would show.
    fn value(s: &mut u64, bits: u32, e: i32) -> f64 {
        let m = (next(s) >> (64 - bits)) | (1 << (bits - 1));
        m as f64 * 2f64.powi(e - bits as i32)
    }

    /// [`sq_add`] equals `mul_add` (the correctly rounded fused multiply-add of the C library or
    /// the CPU, an independent implementation) bit for bit on 4·10^6 pairs: random, short and
    /// full significands, d² from 2^−80 to 2^80 times acc, acc from 0 and subnormal to 2^999,
    /// d at and near the bounds of the exact range.
    #[test]
    fn sq_add_is_the_correctly_rounded_fma() {
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        let mut ties = 0usize;
        for i in 0..4_000_000u32 {
            let (bd, ba) = (
                1 + (next(&mut s) % 53) as u32,
                1 + (next(&mut s) % 53) as u32,
            );
            let ea = (next(&mut s) % 400) as i32 - 200;
            let ed = ea / 2 + (next(&mut s) % 80) as i32 - 40;
            let d = value(&mut s, bd, ed) * if i % 2 == 0 { 1.0 } else { -1.0 };
            let acc = match i % 16 {
                0 => 0.0,
                1 => f64::from_bits(next(&mut s) >> 12), // subnormal
                2 => value(&mut s, ba, 999),
                _ => value(&mut s, ba, ea),
            };
            let d = match i % 64 {
                0 => pow2(450),
                1 => -SQ_ADD_MIN,
                2 => SQ_ADD_MIN * (1.0 + f64::EPSILON),
                3 => 0.0,
                _ => d,
            };
            let want = d.mul_add(d, acc);
            assert_eq!(
                sq_add(d, acc).to_bits(),
                want.to_bits(),
                "d {d:e} acc {acc:e}"
            );
            // acc + RN(d²) rounded twice differs from the fused value: a hard case
            if acc + d * d != want {
                ties += 1;
            }
        }
        // the set is not too easy: double rounding would be wrong on thousands of these pairs
        assert!(
            ties > 10_000,
            "only {ties} pairs where double rounding differs"
        );
    }

    /// [`triple_add`] equals `q.mul_add(3.0, p)` bit for bit on 4·10^6 pairs: random, short and
    /// full significands (short ones put 3q + p on ties), |p| from 2^−60 to 2^60 times |q|,
    /// both signs, zeros and the bounds of the exact range.
    #[test]
    fn triple_add_is_the_correctly_rounded_fma() {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let mut hard = 0usize;
        for i in 0..4_000_000u32 {
            let (bq, bp) = (
                1 + (next(&mut s) % 53) as u32,
                1 + (next(&mut s) % 53) as u32,
            );
            let eq = (next(&mut s) % 600) as i32 - 300;
            let ep = eq + (next(&mut s) % 120) as i32 - 60;
            let sign = |k: u32| {
                if (i >> k).is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                }
            };
            let q = match i % 64 {
                0 => 0.0,
                1 => TRIPLE_ADD_MAX * sign(7),
                2 => TRIPLE_ADD_MIN * sign(7),
                _ => value(&mut s, bq, eq) * sign(7),
            };
            let p = match i % 61 {
                0 => 0.0,
                1 => TRIPLE_ADD_MAX * sign(8),
                2 => TRIPLE_ADD_MIN * sign(8),
                _ => value(&mut s, bp, ep) * sign(8),
            };
            let want = q.mul_add(3.0, p);
            assert_eq!(
                triple_add(q, p).to_bits(),
                want.to_bits(),
                "q {q:e} p {p:e}"
            );
            // RN(RN(3q) + p) differs from the fused value: a case a double rounding gets wrong
            if 3.0 * q + p != want {
                hard += 1;
            }
        }
        assert!(
            hard > 5_000,
            "only {hard} pairs where double rounding differs"
        );
    }

    /// Outside the exact range the callers must not use [`sq_add`]: where d² overflows in the
    /// split it gives a NaN instead of the fused value (which is why they check the bounds).
    #[test]
    fn sq_add_needs_its_bounds() {
        let d = 2f64.powi(1000);
        assert!(sq_add(d, 0.0).is_nan() && d.mul_add(d, 0.0).is_infinite());
    }
}
