//! Stable32's power-law noise identification at each averaging factor (W. J. Riley, *Handbook
//! of Frequency Stability Analysis*, NIST SP 1065 §5.6; Riley & Greenhall 2004):
//!
//! * with at least [`MIN_ACF_POINTS`] analysis points at cluster size m: the lag-1
//!   autocorrelation method on the m-averaged frequencies (rate input; α = p) or the phase
//!   decimated by m (angle input; α = p + 2), differenced until δ = r1/(1 + r1) < 0.25 or
//!   d = d_max (2 for the Allan family, 3 for Hadamard), p = −round(2δ) − 2d;
//! * below that: the B1 ratio (standard variance over the non-overlapping Allan variance of
//!   the m-averaged frequencies) against its expectation B1(N, μ) (N = number of terms of the
//!   statistic) for the power laws μ = 2..−2 (boundaries at the geometric means, the
//!   arithmetic mean between μ = 2 and 1), and, where B1 cannot tell white from flicker PM
//!   (μ = −2), the ratio R(n) = MVAR/AVAR against 1/m (white PM) and
//!   3.37/(1.04 + 3 ln(π m)) (flicker PM), for every statistic;
//! * at the longest averaging times, where fewer than 2·r m-averages remain (r = the
//!   statistic's octave stop ratio, [`Statistic::octave_stop_ratio`]: ⌊T/m⌋ < 10 for ADEV and
//!   HDEV, < 8 for OADEV, MDEV, TDEV, OHDEV, < 4 for TOTDEV), no identification: the α of the
//!   previous (shorter) τ of the grid is kept (identified as above when it is the first point).
//!
//! No trend is removed (Stable32 leaves preprocessing to the user); α is clamped to −2..=2.
//!
//! Agreement with Stable32's published tables (tests/stability.rs): every row of the 22 OCXO
//! and PHASE.DAT tables, 1389 of them in the B1 region and the carried-over tail, gets
//! Stable32's α. The last two rules are not spelled out in NIST SP 1065; they are what those
//! tables show (with R(n) for the modified variances only, 1101 of the 1389 rows agree;
//! without the carried-over tail, 1089).

use rayon::prelude::*;

use super::{StabilityPoint, Statistic};
use crate::Cumulative;
use crate::config::InputKind;
use crate::kernel::compensated::Neumaier;

/// Stable32 switches from the lag-1 ACF to the B1 ratio below this many analysis points.
pub const MIN_ACF_POINTS: usize = 30;

/// Terms per block of [`acf1`]'s sums (blocks run in parallel, their sums added in order).
const ACF_BLOCK: usize = 1 << 15;

/// Σ f(i) for i in [lo, hi), in four lanes added as (l0 + l1) + (l2 + l3).
#[inline]
fn lane_sum(lo: usize, hi: usize, f: impl Fn(usize) -> f64) -> f64 {
    let mut a = [0.0f64; 4];
    let mut i = lo;
    while i + 4 <= hi {
        for (l, al) in a.iter_mut().enumerate() {
            *al += f(i + l);
        }
        i += 4;
    }
    for (l, j) in (i..hi).enumerate() {
        a[l] += f(j);
    }
    (a[0] + a[1]) + (a[2] + a[3])
}

/// Σ f(i) for i < n: blocks of [`ACF_BLOCK`] terms in parallel (lane sums), added in block
/// order, so the sum does not depend on the thread count.
fn block_sum(n: usize, f: impl Fn(usize) -> f64 + Sync) -> f64 {
    let parts: Vec<f64> = (0..n.div_ceil(ACF_BLOCK))
        .into_par_iter()
        .with_min_len(4)
        .map(|b| lane_sum(b * ACF_BLOCK, ((b + 1) * ACF_BLOCK).min(n), &f))
        .collect();
    parts.iter().sum()
}

/// Lag-1 autocorrelation as Stable32 computes it: the usual (biased) estimator times (n − 1)/n.
/// The sums run in blocks (in parallel) and lanes; one sequential read of a long series per
/// sum was the identification's critical path (OADEV with the interval at 10^8 samples, octave
/// τ: 1126 → 997 ms; at 10^7, 128 → 120 ms). The identified α of every Stable32 table is
/// unchanged.
fn acf1(z: &[f64]) -> f64 {
    acf1_of(z.len(), |i| z[i])
}

/// [`acf1`] of the series z_i = z(i), i < len.
fn acf1_of(len: usize, z: impl Fn(usize) -> f64 + Sync) -> f64 {
    let n = len as f64;
    let mu = block_sum(len, &z) / n;
    let num = block_sum(len.saturating_sub(1), |i| (z(i) - mu) * (z(i + 1) - mu));
    let den = block_sum(len, |i| (z(i) - mu) * (z(i) - mu));
    // Stable32 scales the estimate by (n − 1)/n; without it 2 of the OCXO all-τ rows with
    // 30+ analysis points (AF = 113, 463) come out one noise type off
    num / den * (n - 1.0) / n
}

/// Lag-1 ACF exponent p = −round(2δ) − 2d of a series (differenced up to `dmax` times), or
/// `None` for a constant series.
///
/// ```
/// use avar::stability::noise_id::acf_exponent;
/// // white noise (a deterministic pseudo-random sequence): p = 0; its running sum: p = −2
/// let mut s = 1u64;
/// let white: Vec<f64> = (0..2000).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
///     (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5 }).collect();
/// assert_eq!(acf_exponent(&white, 2), Some(0));
/// let walk: Vec<f64> = white.iter().scan(0.0, |a, v| { *a += v; Some(*a) }).collect();
/// assert_eq!(acf_exponent(&walk, 2), Some(-2));
/// ```
pub fn acf_exponent(z: &[f64], dmax: u32) -> Option<i32> {
    acf_exponent_in(&mut z.to_vec(), dmax)
}

/// [`acf_exponent`] of the series z_i = z(i), i < len, read where it is (no copy) until it has
/// to be differenced, then in the buffer `buf` (the same values as from a copy).
fn acf_exponent_of(
    len: usize,
    z: impl Fn(usize) -> f64 + Sync,
    buf: &mut Vec<f64>,
    dmax: u32,
) -> Option<i32> {
    if len < 3 {
        return None;
    }
    let r1 = acf1_of(len, &z);
    if !r1.is_finite() {
        return None;
    }
    let delta = r1 / (1.0 + r1);
    if delta < 0.25 || dmax == 0 {
        return Some(-(2.0 * delta).round() as i32);
    }
    buf.clear();
    buf.extend((0..len - 1).map(|i| z(i + 1) - z(i)));
    acf_exponent_in(buf, dmax - 1).map(|p| p - 2)
}

/// [`acf_exponent`] in the buffer `z`, which it differences in place (the same values).
fn acf_exponent_in(z: &mut Vec<f64>, dmax: u32) -> Option<i32> {
    let mut d = 0u32;
    loop {
        if z.len() < 3 {
            return None;
        }
        let r1 = acf1(z);
        if !r1.is_finite() {
            return None;
        }
        let delta = r1 / (1.0 + r1);
        if delta < 0.25 || d >= dmax {
            return Some(-(2.0 * delta).round() as i32 - 2 * d as i32);
        }
        for i in 0..z.len() - 1 {
            z[i] = z[i + 1] - z[i];
        }
        z.pop();
        d += 1;
    }
}

/// Expected B1 ratio for N frequency values and AV exponent μ (AVAR ∝ τ^μ).
fn b1_expected(n: f64, mu: i32) -> f64 {
    match mu {
        2 => n * (n + 1.0) / 6.0,
        1 => n / 2.0,
        0 => n * n.ln() / (2.0 * (n - 1.0) * 2f64.ln()),
        -1 => 1.0,
        _ => (n * n - 1.0) / (1.5 * n * (n - 1.0)),
    }
}

/// The AV exponent μ (2..−2) whose expected B1 ratio is nearest to the measured `b1` for N
/// frequency values.
///
/// ```
/// use avar::stability::noise_id::b1_mu;
/// assert_eq!(b1_mu(1.0, 20), -1); // white FM: B1 = 1
/// assert_eq!(b1_mu(10.0, 20), 1); // random-walk FM: B1 = N/2
/// ```
pub fn b1_mu(b1: f64, n: usize) -> i32 {
    let n = n as f64;
    for mu in [2, 1, 0, -1] {
        let (a, b) = (b1_expected(n, mu), b1_expected(n, mu - 1));
        let bound = if mu == 2 {
            0.5 * (a + b)
        } else {
            (a * b).sqrt()
        };
        if b1 > bound {
            return mu;
        }
    }
    -2
}

/// White (2) or flicker (1) PM from the measured R(n) = MVAR/AVAR at cluster size m.
///
/// ```
/// use avar::stability::noise_id::rn_alpha;
/// assert_eq!(rn_alpha(1.0 / 64.0, 64), 2);
/// assert_eq!(rn_alpha(0.2, 64), 1);
/// ```
pub fn rn_alpha(rn: f64, m: u64) -> i32 {
    let m = m as f64;
    let fpm = 3.37 / (1.04 + 3.0 * (std::f64::consts::PI * m).ln());
    let wpm = 1.0 / m;
    if rn > (fpm * wpm).sqrt() { 1 } else { 2 }
}

/// True when Stable32 keeps the α of the previous τ at cluster size m (fewer than 2·r
/// m-averages of the T rate samples, r = the statistic's octave stop ratio).
fn carried_over(statistic: Statistic, t: usize, m: u64) -> bool {
    (t as u64 / m) < 2 * statistic.octave_stop_ratio()
}

/// What the identification reads the m-sums of the rate samples from.
pub(crate) enum IdData<'a> {
    /// The cumulative representation (T + 1 entries): m-sums are differences of it; the phase
    /// itself for angle input.
    Cum(&'a Cumulative<'a>),
    /// The rate samples themselves, without their cumulative sum: an m-sum is the sum of its
    /// m samples less `pivot` each, or for m a multiple of 8 the sum of m/8 entries of
    /// `sums8`, the 8-sums (T/8 values: 1 byte per sample instead of the cumulative sum's 8).
    /// The values differ from the differences of a cumulative sum by rounding only, and α, a
    /// rounded function of them, agrees on every test series. Build it with [`IdData::rate`].
    Rate {
        x: &'a [f64],
        pivot: f64,
        sums8: Vec<f64>,
    },
}

/// Σ (v − pivot) over `s` in four lanes added as (l0 + l1) + (l2 + l3) (the short lengths
/// written out, with the same operations).
#[inline(always)]
fn centred_sum(s: &[f64], pivot: f64) -> f64 {
    match *s {
        [a] => return a - pivot,
        [a, b] => return (a - pivot) + (b - pivot),
        [a, b, c, d] => return ((a - pivot) + (b - pivot)) + ((c - pivot) + (d - pivot)),
        _ => {}
    }
    let mut a = [0.0f64; 4];
    let mut it = s.chunks_exact(4);
    for v in &mut it {
        for l in 0..4 {
            a[l] += v[l] - pivot;
        }
    }
    for (l, v) in it.remainder().iter().enumerate() {
        a[l] += v - pivot;
    }
    (a[0] + a[1]) + (a[2] + a[3])
}

impl<'a> IdData<'a> {
    /// The view of rate samples `x`: centred on [`crate::kernel::cumsum::pivot_of`], with their 8-sums
    /// (one parallel pass).
    pub(crate) fn rate(x: &'a [f64]) -> IdData<'a> {
        let pivot = crate::kernel::cumsum::pivot_of(x);
        let mut sums8 = vec![0.0f64; x.len() / 8];
        sums8
            .par_chunks_mut(1 << 12)
            .enumerate()
            .for_each(|(b, out)| {
                let x = &x[(b << 12) * 8..];
                for (i, o) in out.iter_mut().enumerate() {
                    *o = centred_sum(&x[8 * i..8 * i + 8], pivot);
                }
            });
        IdData::Rate { x, pivot, sums8 }
    }

    /// Number of rate samples T.
    pub(crate) fn t(&self) -> usize {
        match self {
            IdData::Cum(c) => c.c.len() - 1,
            IdData::Rate { x, .. } => x.len(),
        }
    }

    /// The i-th m-sum of the (centred) rate samples: Σ_{j<m} x_{im+j}.
    #[inline]
    fn msum(&self, m: usize, i: usize) -> f64 {
        match self {
            IdData::Cum(c) => c.c[(i + 1) * m] - c.c[i * m],
            IdData::Rate { sums8, .. } if m.is_multiple_of(8) => {
                centred_sum(&sums8[i * (m / 8)..(i + 1) * (m / 8)], 0.0)
            }
            IdData::Rate { x, pivot, .. } => centred_sum(&x[i * m..(i + 1) * m], *pivot),
        }
    }
}

/// The identified α at every point of a curve (parallel over points, then the long-τ tail
/// takes the α of the point before it, in the order of `points`).
pub(crate) fn identify_all(
    data: &IdData<'_>,
    statistic: Statistic,
    input: InputKind,
    points: &[StabilityPoint],
) -> Vec<i32> {
    let phase_input = input == InputKind::Angle;
    let t = data.t();
    // one buffer per worker for the decimated series, differenced in place (a fresh one per
    // point, and a copy per differencing, was mostly page faults: ADEV with the interval at
    // 10^7 samples, octave τ, 124–137 → 92 ms)
    let own: Vec<Option<i32>> = points
        .par_iter()
        .enumerate()
        .map_init(Vec::new, |z, (i, p)| {
            (i == 0 || !carried_over(statistic, t, p.m))
                .then(|| identify_one(data, statistic, p.m as usize, p.n_terms, phase_input, z))
        })
        .collect();
    let mut out = Vec::with_capacity(points.len());
    for a in own {
        let prev = out.last().copied();
        out.push(a.or(prev).unwrap_or(0));
    }
    out
}

/// The α at cluster size m, with `z` as the buffer of the decimated series.
fn identify_one(
    data: &IdData<'_>,
    statistic: Statistic,
    m: usize,
    n_terms: u64,
    phase_input: bool,
    z: &mut Vec<f64>,
) -> i32 {
    let t = data.t();
    let k = t / m;
    let dmax = statistic.diff_order();
    z.clear();
    let acf = if phase_input {
        let IdData::Cum(cum) = data else {
            unreachable!("phase input is read as its cumulative representation")
        };
        // phase decimated by m: x_0, x_m, …
        z.extend(cum.c.iter().step_by(m));
        (z.len() >= MIN_ACF_POINTS)
            .then(|| acf_exponent_in(z, dmax).map(|p| p + 2))
            .flatten()
    } else if k < MIN_ACF_POINTS {
        None
    } else {
        match data {
            IdData::Cum(cum) => {
                let c = &cum.c;
                // two reads, but at a stride of m
                acf_of_msums(k, m, |i| c[(i + 1) * m] - c[i * m], z, dmax)
            }
            IdData::Rate { sums8, .. } if m.is_multiple_of(8) => {
                let q = m / 8;
                acf_of_msums(
                    k,
                    q,
                    |i| centred_sum(&sums8[i * q..(i + 1) * q], 0.0),
                    z,
                    dmax,
                )
            }
            IdData::Rate { x, pivot, .. } => acf_of_msums(
                k,
                m,
                |i| centred_sum(&x[i * m..(i + 1) * m], *pivot),
                z,
                dmax,
            ),
        }
    };
    let alpha = match acf {
        Some(a) => a,
        None => b1_alpha(data, m, n_terms),
    };
    alpha.clamp(-2, 2)
}

/// The lag-1 ACF exponent of the k m-sums z(i) (rate input), each made of `reads` values of
/// the source. With fewer than 8 reads they are read where they are until the series has to
/// be differenced: a copy (k values) would cost a series-sized buffer per thread and a write,
/// and most series are decided before any differencing (MDEV with the interval at 10^8
/// samples: 1191 → 834 ms, peak memory 2.87 → 1.78 GB; at 10^7, 120 → 87 ms). More: a copy
/// (the three sums would each read the source at a stride).
fn acf_of_msums(
    k: usize,
    reads: usize,
    z_of: impl Fn(usize) -> f64 + Sync,
    z: &mut Vec<f64>,
    dmax: u32,
) -> Option<i32> {
    if reads < 8 {
        acf_exponent_of(k, z_of, z, dmax)
    } else {
        z.extend((0..k).map(z_of));
        acf_exponent_in(z, dmax)
    }
}

/// B1 (and R(n)) identification at cluster size m.
fn b1_alpha(data: &IdData<'_>, m: usize, n_terms: u64) -> i32 {
    let t = data.t();
    let k = t / m;
    if k < 2 {
        return 0;
    }
    let y: Vec<f64> = (0..k).map(|i| data.msum(m, i)).collect();
    let mean = y.iter().sum::<f64>() / k as f64;
    let svar = y.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (k - 1) as f64;
    let avar = y.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2 * (k - 1)) as f64;
    if avar.is_nan() || avar <= 0.0 {
        return 0;
    }
    // N of the expected ratio: the number of terms of the statistic (the choice that agrees
    // best with Stable32's tables; with N = ⌊T/m⌋ fewer rows agree)
    let mu = b1_mu(svar / avar, n_terms as usize);
    if mu == -2 {
        if 3 * m > t + 1 {
            // MVAR undefined at this m (only TOTDEV reaches beyond T/3, where its α is carried
            // over in any grid with a shorter τ): B1 alone, white PM
            return 2;
        }
        // R(n) = MVAR/AVAR (overlapping AV), both from the same cumulative sums, for every
        // statistic (as Stable32's tables show: with R(n) for MVAR/TVAR only, the OADEV, ADEV,
        // HDEV and OHDEV rows of PHASE.DAT's white/flicker PM region come out α = 2, not 1)
        let n_mod = t + 2 - 3 * m;
        let (mv, av) = match data {
            IdData::Cum(cum) => rn_sums_cum(&cum.c, m),
            IdData::Rate { x, pivot, .. } => rn_sums_rate(x, *pivot, m),
        };
        let mvar = mv / (m * m) as f64 / n_mod as f64;
        let oavar = av / (t + 1 - 2 * m) as f64;
        return rn_alpha(mvar / oavar, m as u64);
    }
    // μ = −α − 1 for α ≤ 0 (μ = 2 would be α = −3, clamped)
    -mu - 1
}

/// The sums of R(n) at cluster size m (3m ≤ T + 1) from the cumulative sums c: Σ w_j² over the
/// T + 2 − 3m sums w_j of m consecutive second differences d(i) = c[i+2m] − 2c[i+m] + c[i],
/// and Σ d(i)² over the T + 1 − 2m of them.
fn rn_sums_cum(c: &[f64], m: usize) -> (f64, f64) {
    let t = c.len() - 1;
    let mut mv = Neumaier::default();
    let mut av = Neumaier::default();
    let d = |i: usize| (c[i + 2 * m] - c[i + m]) - (c[i + m] - c[i]);
    let mut w: f64 = (0..m).map(d).sum();
    let n_mod = t + 2 - 3 * m;
    for j in 0..n_mod {
        mv.add(w * w);
        if j + 1 < n_mod {
            w += d(j + m) - d(j);
        }
    }
    for i in 0..=t - 2 * m {
        let v = d(i);
        av.add(v * v);
    }
    (mv.value(), av.value())
}

/// [`rn_sums_cum`] from the rate samples x (centred by `pivot`), without their cumulative sum:
/// d(0) summed directly, then d(i + 1) = d(i) + (x_{i+2m} − x_{i+m}) − (x_{i+m} − x_i), in two
/// streams (at j and j + m) for the sums w_j. (Only the long-τ B1 region, k < 30 clusters,
/// asks for it.)
fn rn_sums_rate(x: &[f64], pivot: f64, m: usize) -> (f64, f64) {
    let t = x.len();
    let y = |i: usize| (x[i + 2 * m] - x[i + m]) - (x[i + m] - x[i]);
    let d0 = x[m..2 * m].iter().map(|v| v - pivot).sum::<f64>()
        - x[..m].iter().map(|v| v - pivot).sum::<f64>();
    let mut av = Neumaier::default();
    let (mut d, mut w, mut d_m) = (d0, 0.0f64, None);
    for i in 0..=t - 2 * m {
        if i < m {
            w += d;
        }
        if i == m {
            d_m = Some(d);
        }
        av.add(d * d);
        if i < t - 2 * m {
            d += y(i);
        }
    }
    let mut mv = Neumaier::default();
    let n_mod = t + 2 - 3 * m;
    let (mut da, mut db) = (d0, d_m.unwrap_or(f64::NAN));
    for j in 0..n_mod {
        mv.add(w * w);
        if j + 1 < n_mod {
            w += db - da;
            if j + 2 < n_mod {
                da += y(j);
                db += y(j + m);
            }
        }
    }
    (mv.value(), av.value())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White noise (xorshift), its running sum and the running sum of that: the lag-1 ACF
    /// decides at d = 0, 1 and 2 differences.
    fn series() -> [Vec<f64>; 3] {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        let white: Vec<f64> = (0..5000)
            .map(|_| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let run = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .scan(0.0, |a, x| {
                    *a += x;
                    Some(*a)
                })
                .collect()
        };
        let walk = run(&white);
        let walk2 = run(&walk);
        [white, walk, walk2]
    }

    #[test]
    fn reading_in_place_equals_the_copy() {
        // the exponent of a series read through a function (differenced into a buffer when
        // needed) is that of the copied series, for every differencing depth
        let mut buf = Vec::new();
        for (k, z) in series().iter().enumerate() {
            for dmax in 0..=3 {
                let copy = acf_exponent(z, dmax);
                let read = acf_exponent_of(z.len(), |i| z[i], &mut buf, dmax);
                assert_eq!(copy, read, "series {k}, dmax {dmax}");
            }
            // the three series need 0, 1 and 2 differences
            assert_eq!(acf_exponent(z, 3), Some(-2 * k as i32), "series {k}");
        }
        assert_eq!(acf_exponent_of(2, |i| i as f64, &mut buf, 2), None);
    }

    /// The test series plus white PM read as rate (differenced white noise: the R(n) branch),
    /// each with an offset of 10^3 (the samples' pivot centres them).
    fn rate_series() -> Vec<Vec<f64>> {
        let [white, walk, walk2] = series();
        let wpm: Vec<f64> = white.windows(2).map(|w| w[1] - w[0]).collect();
        [white, walk, walk2, wpm]
            .into_iter()
            .map(|z| z.iter().map(|v| v + 1e3).collect())
            .collect()
    }

    #[test]
    fn r_n_sums_from_the_samples_equal_those_of_the_cumulative_sum() {
        for (k, x) in rate_series().iter().enumerate() {
            let mut c = Vec::new();
            crate::kernel::cumsum::centred_prefix_into(x, &mut c).unwrap();
            let t = x.len();
            // down to the last m with 3m ≤ T + 1 (a single sum w_0)
            for m in [1, 2, 7, 64, t / 5, (t + 1) / 3] {
                let (mv_c, av_c) = rn_sums_cum(&c, m);
                let (mv_x, av_x) = rn_sums_rate(x, crate::kernel::cumsum::pivot_of(x), m);
                // two roundings of the same sums (recurrences over ≤ 5000 steps of O(1)
                // values against sums of O(m) values): far below the R(n) boundaries
                for (a, b) in [(mv_c, mv_x), (av_c, av_x)] {
                    assert!(
                        (a - b).abs() <= 1e-9 * a.abs(),
                        "series {k}, m {m}: {a} vs {b}"
                    );
                }
            }
        }
    }

    #[test]
    fn identification_from_the_samples_equals_that_of_the_cumulative_sum() {
        // every point of every statistic (octave τ and the tail past T/30, where B1 and R(n)
        // decide): the α of the m-sums summed from the samples equals that of the differences
        // of the cumulative sum
        for (k, x) in rate_series().iter().enumerate() {
            let mut c = Vec::new();
            let mean = crate::kernel::cumsum::centred_prefix_into(x, &mut c).unwrap();
            let t = x.len();
            let cum = Cumulative {
                c: std::borrow::Cow::Borrowed(&c[..]),
                factor: 1.0,
                mean,
                t,
            };
            let samples = IdData::rate(x);
            for st in Statistic::ALL {
                let ms: Vec<u64> = (0..)
                    .map(|j| 1u64 << j)
                    .take_while(|&m| m as usize * 3 <= t + 1)
                    .chain([(t as u64 + 1) / 3, t as u64 / 40])
                    .chain((t as u64 / 29..=t as u64 / 8).step_by(7))
                    .collect::<std::collections::BTreeSet<u64>>()
                    .into_iter()
                    .collect();
                let points: Vec<StabilityPoint> = ms
                    .iter()
                    .map(|&m| StabilityPoint {
                        m,
                        tau: m as f64,
                        var: 1.0,
                        dev: 1.0,
                        var_lo: None,
                        var_hi: None,
                        dev_lo: None,
                        dev_hi: None,
                        edf: None,
                        n_terms: st.n_terms(t, m),
                        alpha: None,
                    })
                    .collect();
                let a = identify_all(&IdData::Cum(&cum), st, InputKind::Rate, &points);
                let b = identify_all(&samples, st, InputKind::Rate, &points);
                assert_eq!(a, b, "series {k}, {st}");
            }
        }
        // and the white PM series does reach the R(n) branch (B1 says μ = −2) in that tail
        let wpm = &rate_series()[3];
        let t = wpm.len();
        let reached = (t / 29..=t / 8).step_by(7).any(|m| {
            let data = IdData::rate(wpm);
            let y: Vec<f64> = (0..t / m).map(|i| data.msum(m, i)).collect();
            let k = y.len() as f64;
            let mean = y.iter().sum::<f64>() / k;
            let svar = y.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (k - 1.0);
            let avar = y.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (k - 1.0));
            b1_mu(svar / avar, Statistic::Oadev.n_terms(t, m as u64) as usize) == -2
        });
        assert!(
            reached,
            "no white-PM point in the B1 region came out μ = −2"
        );
    }
}
