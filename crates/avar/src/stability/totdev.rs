//! Total variance TOTVAR / deviation TOTDEV (NIST SP 1065 eq. 25; Stable32 "Total").
//!
//! TOTVAR(τ) = Σ_{i=1}^{N−2} (x*_{i−m} − 2x*_i + x*_{i+m})² / (2 τ² (N − 2)) over N phase points
//! extended at both ends by odd reflection, x*_{−j} = 2x_0 − x_j and
//! x*_{N−1+j} = 2x_{N−1} − x_{N−1−j}. Every τ uses N − 2 terms, which tightens the interval at
//! long τ (EDF ≈ 1.5·T/τ for white FM against ≈ 1.1·T/τ for the overlapping AV).
//!
//! Rate series of at least 2^22 samples without a chi-square interval are streamed
//! (`totvar_stream`: the interior terms from the AV's streamed kernel, the reflected ends by
//! recurrences restarted from checkpoints); shorter ones, phase input and intervals use the
//! cumulative sum (`totvar_fast`).

use super::{
    BLOCK, Stability, Statistic, check_m, fused_sums, plain_phase, split_near_far, sum_in_blocks,
    sum_in_blocks_walk, sumsq_range,
};
use crate::Cumulative;
use crate::config::InputKind;
use crate::error::AvarError;

/// The plain reference: TOTVAR at cluster size `m` (rate unit²), the reflected series built
/// explicitly. For verification.
///
/// ```
/// use avar::stability::totdev::totvar_reference;
/// use avar::InputKind;
/// // NBS14 9-point frequency set (NIST SP 1065 §12.1): TOTDEV(τ = 2) = 93.90379
/// let y = [892.0, 809.0, 823.0, 798.0, 671.0, 644.0, 883.0, 903.0, 677.0];
/// let t = totvar_reference(&y, 1.0, InputKind::Rate, 2).unwrap().sqrt();
/// assert!((t / 93.90379 - 1.0).abs() < 5e-7);
/// ```
pub fn totvar_reference(
    data: &[f64],
    rate_hz: f64,
    input: InputKind,
    m: u64,
) -> Result<f64, AvarError> {
    let x = plain_phase(data, rate_hz, input)?;
    let n = x.len();
    check_m(Statistic::Totdev, m, n - 1)?;
    let m = m as usize;
    // extended series: index k of x* sits at ext[k + n − 2]
    let mut ext = Vec::with_capacity(3 * n);
    for j in (1..=n - 2).rev() {
        ext.push(2.0 * x[0] - x[j]);
    }
    ext.extend_from_slice(&x);
    for j in 1..=n - 2 {
        ext.push(2.0 * x[n - 1] - x[n - 1 - j]);
    }
    let off = n - 2;
    let mut s = 0.0;
    for i in 1..=n - 2 {
        let v = ext[off + i - m] - 2.0 * ext[off + i] + ext[off + i + m];
        s += v * v;
    }
    let tau = m as f64 / rate_hz;
    Ok(s / (2.0 * tau * tau * (n - 2) as f64))
}

/// TOTVAR's bias factor B = TOTVAR/AVAR = 1 − a·τ/T (T = the record length, T rate samples
/// times τ0) for the identified power law α: a = 0 for white FM and the PM noises,
/// a = 1/(3 ln 2) ≈ 0.481 for flicker FM (α = −1), a = 3/4 for random-walk FM (α = −2)
/// (NIST SP 1065 §5.2.11, Howe's total variance).
///
/// ```
/// use avar::stability::totdev::bias_factor;
/// assert_eq!(bias_factor(0, 100, 1000), 1.0);
/// assert!((bias_factor(-2, 100, 1000) - (1.0 - 0.075)).abs() < 1e-15);
/// ```
pub fn bias_factor(alpha: i32, m: u64, t: usize) -> f64 {
    let a = match alpha {
        -1 => 1.0 / (3.0 * std::f64::consts::LN_2),
        a if a <= -2 => 0.75,
        _ => 0.0,
    };
    1.0 - a * m as f64 / t as f64
}

/// The bias-corrected TOTDEV curve as Stable32 reports it when it identifies the noise: at
/// every point TOTVAR and its bounds are divided by [`bias_factor`] of the identified α (the
/// EDF is unchanged). `curve` must be a TOTDEV curve computed with a chi-square interval
/// (the correction needs the identified α at each point).
///
/// ```
/// use avar::stability::{stability, totdev::bias_corrected, Statistic};
/// use avar::{AvarConfig, Scales};
/// // a random walk in frequency (α = −2): TOTVAR underestimates the AV by 3/4·τ/T
/// let mut s = 7u64;
/// let mut acc = 0.0;
/// let y: Vec<f64> = (0..4000).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
///     acc += (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5; acc }).collect();
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![100]), ..Default::default() };
/// let raw = stability(&y, 1.0, Statistic::Totdev, &cfg).unwrap();
/// let fixed = bias_corrected(&raw).unwrap();
/// let p = &raw.points[0];
/// assert_eq!(p.alpha, Some(-2));
/// assert!((fixed.points[0].var * (1.0 - 0.75 * 100.0 / 4000.0) / p.var - 1.0).abs() < 1e-12);
/// ```
pub fn bias_corrected(curve: &Stability) -> Result<Stability, AvarError> {
    if curve.statistic != Statistic::Totdev {
        return Err(AvarError::InvalidStatistic(format!(
            "the total-variance bias correction applies to totdev, not to {}",
            curve.statistic
        )));
    }
    let mut out = curve.clone();
    for p in &mut out.points {
        let Some(alpha) = p.alpha else {
            return Err(AvarError::InvalidStatistic(
                "the total-variance bias correction needs the identified noise (compute the \
                 curve with the chi-square interval)"
                    .into(),
            ));
        };
        let b = bias_factor(alpha, p.m, curve.n);
        let r = b.sqrt();
        p.var /= b;
        p.dev /= r;
        for v in [&mut p.var_lo, &mut p.var_hi].into_iter().flatten() {
            *v /= b;
        }
        for v in [&mut p.dev_lo, &mut p.dev_hi].into_iter().flatten() {
            *v /= r;
        }
    }
    Ok(out)
}

/// TOTVAR at each m without materialising the reflection: the terms whose lagged points fall
/// outside the record read the reflected values on the fly; the middle runs branch-free.
pub(crate) fn totvar_fast(cum: &Cumulative<'_>, ms: &[u64]) -> Vec<f64> {
    let c: &[f64] = &cum.c;
    let n_terms = c.len() - 2;
    let finish = |m: usize, s: f64| {
        let f = cum.factor / m as f64;
        s * f * f / (2.0 * n_terms as f64)
    };
    split_near_far(
        ms,
        |near| {
            fused_sums(near, |_| n_terms, |m, lo, hi| totvar_block(c, m, lo, hi))
                .into_iter()
                .zip(near)
                .map(|(s, &m)| finish(m, s))
                .collect()
        },
        |m| {
            let block = |lo, hi| totvar_block(c, m, lo, hi);
            let s = if m >= BLOCK && m.is_multiple_of(BLOCK) {
                sum_in_blocks_walk(n_terms, BLOCK, m / BLOCK, block)
            } else {
                sum_in_blocks(n_terms, BLOCK, block)
            };
            finish(m, s)
        },
    )
}

/// The plain sum of the TOTVAR terms lo..hi (term k is i = k + 1, i = 1..=N−2).
fn totvar_block(c: &[f64], m: usize, lo: usize, hi: usize) -> f64 {
    let last = c.len() - 1;
    let xs = |k: isize| -> f64 {
        if k < 0 {
            2.0 * c[0] - c[(-k) as usize]
        } else if k as usize > last {
            2.0 * c[last] - c[2 * last - k as usize]
        } else {
            c[k as usize]
        }
    };
    let edge = |i: usize| {
        let i = i as isize;
        let mi = m as isize;
        let a = xs(i + mi) - xs(i);
        let b = xs(i) - xs(i - mi);
        a - b
    };
    let (lo, hi) = (lo + 1, hi + 1);
    // middle: m <= i <= last − m
    let a = lo.max(m).min(hi);
    let b = (last + 1).saturating_sub(m).max(a).min(hi);
    sumsq_range(lo, a, edge) + mid_sumsq(c, m, a, b) + sumsq_range(b, hi, edge)
}

/// Σ_{i=lo}^{hi−1} ((c_{i+m} − c_i) − (c_i − c_{i−m}))² for m ≤ lo, hi + m ≤ len(c), from three
/// contiguous slices in four lanes.
fn mid_sumsq(c: &[f64], m: usize, lo: usize, hi: usize) -> f64 {
    let k = hi - lo;
    if k == 0 {
        return 0.0;
    }
    let x0 = &c[lo - m..lo - m + k];
    let x1 = &c[lo..lo + k];
    let x2 = &c[lo + m..lo + m + k];
    let mut acc = [0.0f64; 4];
    let term = |p: f64, q: f64, r: f64| {
        let v = (r - q) - (q - p);
        v * v
    };
    let (c0, c1, c2) = (x0.chunks_exact(4), x1.chunks_exact(4), x2.chunks_exact(4));
    let tail = (c0.remainder(), c1.remainder(), c2.remainder());
    for ((p, q), r) in c0.zip(c1).zip(c2) {
        for l in 0..4 {
            acc[l] += term(p[l], q[l], r[l]);
        }
    }
    for ((p, q), r) in tail.0.iter().zip(tail.1).zip(tail.2) {
        acc[0] += term(*p, *q, *r);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Length of the segments of reflected terms that restart from exact values (checkpoints).
const EDGE_SEG: usize = 4096;

/// TOTVAR of rate samples `y` at each m (2m ≤ T), streamed without a series-sized cumulative
/// sum: the interior terms (m ≤ i ≤ T − m, ordinary second differences) are the overlapping
/// AV's sums from its streamed kernel; the 2(m − 1) terms at the reflected ends are carried by
/// their own recurrences in i over segments of [`EDGE_SEG`] terms, each started from phase
/// values rebuilt exactly from the checkpoints of the centred cumulative sum: those the AV's
/// far walk built (no more read of the series; before, a read of its own cost 2.4 ms at 10^7
/// samples, 10 %), or, when no scale was far, its own. Rate unit². Deterministic for any
/// thread count (fixed segment grid, segment sums added in order with Neumaier's
/// compensation).
pub(crate) fn totvar_stream(y: &[f64], ms: &[u64]) -> Result<Vec<f64>, AvarError> {
    use rayon::prelude::*;
    let t = y.len();
    // the phase from the far walk's checkpoints where it had far scales, else from its own
    let (interior, ck) = crate::kernel::streamed::overlapping_sums_stream_checkpoints(y, ms)?;
    let ck = match ck {
        Some(ck) => ck,
        None => crate::kernel::cumsum::checkpoints(y)?,
    };
    let x = |p: usize| ck.at(y, p);
    // every (scale, end, segment) of the reflected terms, in a fixed order
    let jobs: Vec<(usize, bool, usize, usize)> = ms
        .iter()
        .enumerate()
        .flat_map(|(s, &m)| {
            let m = m as usize;
            let left = (1..m)
                .step_by(EDGE_SEG)
                .map(move |a| (s, true, a, (a + EDGE_SEG).min(m)));
            let right = (t + 1 - m..t)
                .step_by(EDGE_SEG)
                .map(move |a| (s, false, a, (a + EDGE_SEG).min(t)));
            left.chain(right)
        })
        .collect();
    let segs: Vec<EdgeSeg> = jobs
        .par_iter()
        .map(|&(s, left, a, b)| {
            let m = ms[s] as usize;
            // d_i = x*_{i+m} − 2x*_i + x*_{i−m} with x*_{−j} = 2x_0 − x_j (x_0 = 0 here) on the
            // left and x*_{T+j} = 2x_T − x_{T−j} on the right; d_{i+1} − d_i from the samples:
            // (y_{i+m} − 2y_i) + y_{m−i−1} on the left, (y_{i−m} − 2y_i) + y_{2T−i−m−1} on the
            // right
            if left {
                EdgeSeg {
                    d0: signed_sum(&[(1.0, x(a + m)), (-2.0, x(a)), (-1.0, x(m - a))]),
                    near: a + m,
                    cur: a,
                    far: m - a - 1,
                    len: b - a,
                }
            } else {
                let xt = x(t);
                EdgeSeg {
                    d0: signed_sum(&[
                        (2.0, xt),
                        (-1.0, x(2 * t - a - m)),
                        (-2.0, x(a)),
                        (1.0, x(a - m)),
                    ]),
                    near: a - m,
                    cur: a,
                    far: 2 * t - a - m - 1,
                    len: b - a,
                }
            }
        })
        .collect();
    // four segments at a time where they are as long (their chains of additions interleaved)
    let sums: Vec<f64> = segs
        .par_chunks(LANES_EDGE)
        .flat_map_iter(|g| {
            let out: Vec<f64> = match <&[EdgeSeg; LANES_EDGE]>::try_from(g) {
                Ok(g) if g.iter().all(|e| e.len == g[0].len && e.len >= 2) => {
                    edge_sums(std::array::from_fn::<_, LANES_EDGE, _>(|q| &g[q]), y).to_vec()
                }
                _ => g.iter().map(|e| edge_sums([e], y)[0]).collect(),
            };
            out
        })
        .collect();
    let mut out = interior;
    for (o, s) in out.iter_mut().zip(0..) {
        let mut acc = crate::kernel::compensated::Neumaier::default();
        acc.add(*o);
        for (job, v) in jobs.iter().zip(&sums) {
            if job.0 == s {
                acc.add(*v);
            }
        }
        let m = ms[s] as f64;
        let f = 1.0 / m;
        *o = acc.value() * f * f / (2.0 * (t - 1) as f64);
    }
    Ok(out)
}

/// Segments whose recurrences [`edge_sums`] interleaves (see there for why four).
const LANES_EDGE: usize = 4;

/// One segment of reflected TOTVAR terms: d at its first term, and where the three samples of
/// the step j (0 ≤ j < len − 1) are: `near + j`, `cur + j` and `far − j`.
struct EdgeSeg {
    d0: f64,
    near: usize,
    cur: usize,
    far: usize,
    len: usize,
}

/// Σ d_j² over each of N segments of the same length: acc += d·d, then (but for the last
/// term) d += (y_near − 2y_cur) + y_far, the operations of one segment in its order whatever
/// N (so the sums do not depend on the grouping). The N chains are independent: interleaved,
/// their latencies overlap (four at a time; at 10^7 samples, octave τ, TOTDEV took 27.7–29.0
/// ms with one, 26.7–27.4 with four, 27–30 with eight).
#[inline]
fn edge_sums<const N: usize>(seg: [&EdgeSeg; N], y: &[f64]) -> [f64; N] {
    let len = seg[0].len;
    assert!(seg.iter().all(|e| e.len == len));
    let steps = len.saturating_sub(1);
    let near: [&[f64]; N] = seg.map(|e| &y[e.near..e.near + steps]);
    let cur: [&[f64]; N] = seg.map(|e| &y[e.cur..e.cur + steps]);
    // far − j for j < steps, stored reversed: index steps − 1 − j
    let far: [&[f64]; N] = seg.map(|e| &y[e.far + 1 - steps..e.far + 1]);
    let mut d = seg.map(|e| e.d0);
    let mut acc = [0.0f64; N];
    for j in 0..steps {
        for q in 0..N {
            acc[q] += d[q] * d[q];
            d[q] += (near[q][j] - 2.0 * cur[q][j]) + far[q][steps - 1 - j];
        }
    }
    if len > 0 {
        for q in 0..N {
            acc[q] += d[q] * d[q];
        }
    }
    acc
}

/// Σ c_j·v_j of unevaluated pairs v_j = (hi, lo) with coefficients ±1, ±2 (exact scalings): the
/// high parts added exactly (two-sums), the low parts and the errors added plainly.
fn signed_sum(terms: &[(f64, (f64, f64))]) -> f64 {
    let mut hi = 0.0;
    let mut lo = 0.0;
    for &(c, (h, l)) in terms {
        let (s, e) = crate::kernel::compensated::two_sum(hi, c * h);
        hi = s;
        lo += e + c * l;
    }
    hi + lo
}
