//! The robust Allan variance and Haar wavelet variance: spikes replaced, the stride-1 scales
//! solved in lock step, the others one difference buffer each, and the intervals of the
//! classical estimator with the EDF multiplied by the efficiency.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::biweight::Biweight;
use super::differences::{COARSE, CoarsePrefix, centred_prefix_sums_into, difference_stride};
use super::lockstep::solve_lockstep;
use super::m_scale::{RobustScale, robust_mean_square_detail};
use super::spikes::{SPIKE_THRESHOLD, SpikeReplacement, spike_scan};
use crate::config::{AvarConfig, CiMethod, Estimator, InputKind};
use crate::error::AvarError;
use crate::haar::chi2_interval;
use crate::result::AllanVariance;

/// A robust Allan variance with the classical one it was derived from.
///
/// ```
/// use avar::robust::{difference_stride, robust_allan_variance};
/// use avar::AvarConfig;
/// let x: Vec<f64> = (0..2000).map(|i| ((i * 7919) % 101) as f64 / 101.0).collect();
/// let r = robust_allan_variance(&x, 1.0, &AvarConfig::default(), 0.6).unwrap();
/// assert_eq!(r.efficiency, r.biweight.efficiency());
/// // values in [0, 1) spread evenly: no sample is 6 robust SDs off its neighbours
/// assert!(r.spikes.indices.is_empty());
/// for (k, (p, q)) in r.robust.points.iter().zip(&r.classical.points).enumerate() {
///     assert_eq!(p.m, q.m);
///     // every difference_stride(m)-th of the T − 2m + 1 differences
///     assert_eq!(r.used[k], (2000 - 2 * p.m) / difference_stride(p.m) + 1);
///     assert!(r.rejected[k] <= r.used[k]);
///     assert!(r.root_found[k]); // no contamination: the equation has a root
///     // the classical chi-square EDF times e (the variance inflated by 1/e)
///     assert_eq!(p.edf, q.edf.map(|edf| edf * r.efficiency));
/// }
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobustAllanVariance {
    /// Gaussian efficiency of the estimator.
    pub efficiency: f64,
    /// The biweight used.
    pub biweight: Biweight,
    /// The robust AV (rate unit²) with its intervals: chi-square with EDF = e·EDF of the
    /// classical interval (variance inflated by 1/e), `edf` set accordingly.
    pub robust: AllanVariance,
    /// The classical AV (book eq. 4.2) at the same scales and with the same CI family.
    pub classical: AllanVariance,
    /// Per scale: the number of the differences used that lie beyond c·σ̂ (zero weight).
    pub rejected: Vec<u64>,
    /// Per scale: the number of differences the estimating equation used (every
    /// [`difference_stride`]-th of the T − 2m + 1).
    pub used: Vec<u64>,
    /// Per scale: false where the estimating equation had no root (see [`RobustScale`]).
    pub root_found: Vec<bool>,
    /// The spikes replaced before the M-estimator (see [`replace_spikes`]).
    ///
    /// [`replace_spikes`]: super::replace_spikes
    pub spikes: SpikeReplacement,
}

/// Buffers that the robust AV lends itself and gives back (the prefix sums of a channel, the
/// differences of a scale), so that a caller estimating several channels
/// ([`robust_allan_variance_from_with`]) touches fresh memory for them once per concurrent
/// estimate instead of once per channel and scale: with 6 channels of 10⁷ samples on 2
/// threads, the prefix sums alone (80 MB per channel) are faulted in for the two or three
/// channels that run at once instead of for all six. The buffers are freed with the scratch.
///
/// ```
/// use avar::{AvarConfig, allan_variance};
/// use avar::robust::{RobustScratch, robust_allan_variance_from, robust_allan_variance_from_with};
/// let cfg = AvarConfig::default();
/// let scratch = RobustScratch::default();
/// for k in 1..4u64 {
///     let x: Vec<f64> = (0..3000).map(|i| ((i * 7919 * k as usize) % 101) as f64).collect();
///     let c = allan_variance(&x, 1.0, &cfg).unwrap();
///     let a = robust_allan_variance_from_with(&x, c.clone(), &cfg, 0.6, &scratch).unwrap();
///     assert_eq!(a, robust_allan_variance_from(&x, c, &cfg, 0.6).unwrap());
/// }
/// ```
#[derive(Debug, Default)]
pub struct RobustScratch {
    pool: std::sync::Mutex<Vec<Vec<f64>>>,
}

impl RobustScratch {
    /// A buffer (empty) for `len` values: the smallest at hand that holds them, else the
    /// largest (it grows least), else a new one.
    fn take(&self, len: usize) -> Vec<f64> {
        let Ok(mut pool) = self.pool.lock() else {
            return Vec::new();
        };
        let fits = (0..pool.len())
            .filter(|&i| pool[i].capacity() >= len)
            .min_by_key(|&i| pool[i].capacity());
        let pick = fits.or_else(|| (0..pool.len()).max_by_key(|&i| pool[i].capacity()));
        pick.map(|i| pool.swap_remove(i)).unwrap_or_default()
    }

    /// Gives a buffer back.
    fn give(&self, mut v: Vec<f64>) {
        v.clear();
        if v.capacity() > 0
            && let Ok(mut pool) = self.pool.lock()
        {
            pool.push(v);
        }
    }
}

simd_dispatch! {
    /// How many x of `x` have x² ≥ `lim` (f64 lanes, exact below 2^53).
    fn count_beyond(x: &[f64], lim: f64) -> u64 => count_beyond_lanes
}

#[inline(always)]
fn count_beyond_lanes(x: &[f64], lim: f64) -> u64 {
    const L: usize = 8;
    let mut acc = [0.0f64; L];
    let chunks = x.chunks_exact(L);
    let rest = chunks.remainder();
    for ch in chunks {
        for j in 0..L {
            acc[j] += if ch[j] * ch[j] >= lim { 1.0 } else { 0.0 };
        }
    }
    acc.iter().sum::<f64>() as u64 + rest.iter().filter(|&&v| v * v >= lim).count() as u64
}

/// The robust AV needs the individual differences: rate input and the overlapping estimator.
fn check_supported(config: &AvarConfig) -> Result<(), AvarError> {
    if config.input != InputKind::Rate || config.estimator != Estimator::Overlapping {
        return Err(AvarError::InvalidScales(
            "the robust AV needs rate input and the overlapping estimator".into(),
        ));
    }
    Ok(())
}

/// Robust Allan variance of rate samples at the scales of `config` (module doc), beside the
/// classical one. `efficiency` in [`EFFICIENCY_RANGE`] ([`DEFAULT_EFFICIENCY`] = 0.6 as in
/// `gmwm`).
///
/// Errors: as [`crate::allan_variance`]; angle input or the non-overlapping estimator
/// ([`AvarError::InvalidScales`] with a message); an efficiency out of range.
///
/// ```
/// use avar::{AvarConfig, robust::robust_allan_variance};
/// // white noise (a deterministic pseudo-random sequence) with 0.5 % huge outliers
/// let mut s = 7u64;
/// let mut x: Vec<f64> = (0..20000).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
///     (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5 }).collect();
/// for i in (0..x.len()).step_by(200) { x[i] += 50.0; }
/// let r = robust_allan_variance(&x, 1.0, &AvarConfig::default(), 0.6).unwrap();
/// let (rob, cl) = (r.robust.points[0].avar, r.classical.points[0].avar);
/// // uniform(−½, ½) has variance 1/12; AV(m = 2) of white noise = σ²/2
/// assert!(cl > 5.0 * rob);
/// assert!((rob / (1.0 / 24.0) - 1.0).abs() < 0.1, "{rob}");
/// ```
///
/// [`EFFICIENCY_RANGE`]: super::EFFICIENCY_RANGE
/// [`DEFAULT_EFFICIENCY`]: super::DEFAULT_EFFICIENCY
pub fn robust_allan_variance(
    data: &[f64],
    rate_hz: f64,
    config: &AvarConfig,
    efficiency: f64,
) -> Result<RobustAllanVariance, AvarError> {
    check_supported(config)?;
    Biweight::with_efficiency(efficiency)?;
    let classical = crate::allan_variance(data, rate_hz, config)?;
    robust_allan_variance_from(data, classical, config, efficiency)
}

/// [`robust_allan_variance`] when the classical curve is at hand: `classical` must be
/// `allan_variance(data, rate_hz, config)` (rate, n and scales are checked against `data` and
/// `config`); it is kept as the result's classical curve instead of being computed again.
/// Samples beyond 2^±128 in magnitude are estimated on an exact power-of-two rescaled copy
/// (as [`crate::allan_variance`] does), so that the robust AV of 2^k·x is 4^k times that of x
/// to rounding (the Newton iterates on ln s are not scale-exact) for every representable k.
///
/// ```
/// use avar::{AvarConfig, allan_variance, robust::{robust_allan_variance, robust_allan_variance_from}};
/// let x: Vec<f64> = (0..4000).map(|i| ((i * 7919) % 101) as f64 / 101.0).collect();
/// let cfg = AvarConfig::default();
/// let classical = allan_variance(&x, 10.0, &cfg).unwrap();
/// let a = robust_allan_variance_from(&x, classical, &cfg, 0.6).unwrap();
/// assert_eq!(a, robust_allan_variance(&x, 10.0, &cfg, 0.6).unwrap());
/// ```
pub fn robust_allan_variance_from(
    data: &[f64],
    classical: AllanVariance,
    config: &AvarConfig,
    efficiency: f64,
) -> Result<RobustAllanVariance, AvarError> {
    robust_allan_variance_from_with(
        data,
        classical,
        config,
        efficiency,
        &RobustScratch::default(),
    )
}

/// [`robust_allan_variance_from`] with its buffers lent by `scratch` (the same result, bit for
/// bit): estimating several channels with one scratch, in turn or in parallel, reuses the
/// memory of the prefix sums and differences instead of touching fresh pages per channel.
/// See [`RobustScratch`] for an example.
pub fn robust_allan_variance_from_with(
    data: &[f64],
    classical: AllanVariance,
    config: &AvarConfig,
    efficiency: f64,
    scratch: &RobustScratch,
) -> Result<RobustAllanVariance, AvarError> {
    check_supported(config)?;
    if classical.n != data.len()
        || classical.input != config.input
        || classical.estimator != config.estimator
        || classical.ci != config.ci
        || classical.alpha != config.alpha
    {
        return Err(AvarError::InvalidScales(
            "the classical curve given was not computed from these data with this configuration"
                .into(),
        ));
    }
    let rate_hz = classical.rate_hz;
    let bw = Biweight::with_efficiency(efficiency)?;
    // huge or tiny samples (squares beyond the range of f64): estimated on an exact
    // power-of-two rescaled copy and scaled back, as the classical AV is (`range`)
    if let Some(e) = crate::range::rescale_exponent(data) {
        let scaled = crate::range::scaled_copy(data, e);
        let cl = crate::allan_variance(&scaled, rate_hz, config)?;
        let mut r = robust_allan_variance_from_with(&scaled, cl, config, efficiency, scratch)?;
        crate::range::scale_back(&mut r.robust.points, e)?;
        r.robust.mean = crate::range::ldexp(r.robust.mean, e);
        r.spikes.residual_sd = crate::range::ldexp(r.spikes.residual_sd, e);
        r.classical = classical;
        return Ok(r);
    }
    let scan = spike_scan(data, SPIKE_THRESHOLD, scratch.take(data.len() + 1))?;
    let spikes = scan.report;
    // the intervals' EDF and noise identification from the series the M-estimator sees
    let template = if spikes.indices.is_empty() {
        classical.clone()
    } else {
        crate::allan_variance(&scan.series, rate_hz, config)?
    };
    // centred prefix sums (the robust scale does not need the offset-proof kernel: the
    // differences are formed once, and a relative error of 1e-12 is far below its spread);
    // those of the spike scan when it replaced nothing
    let c = if spikes.indices.is_empty() && !scan.prefix.is_empty() {
        scan.prefix
    } else {
        scratch.give(scan.prefix);
        centred_prefix_sums_into(&scan.series, template.mean, scratch.take(data.len() + 1))
    };
    drop(scan.series);
    let ms: Vec<u64> = template.points.iter().map(|p| p.m).collect();
    // the stride-1 scales together (one pass over c per Newton step for all of them)
    let near: Vec<usize> = ms
        .iter()
        .filter(|&&m| difference_stride(m) == 1)
        .map(|&m| m as usize)
        .collect();
    let mut together = solve_lockstep(&c, &near, &bw).into_iter();
    let pre: Vec<Option<(RobustScale, u64)>> = ms
        .iter()
        .map(|&m| {
            if difference_stride(m) == 1 {
                together.next().flatten()
            } else {
                None
            }
        })
        .collect();
    // the others (and any the lockstep left), one difference buffer per worker, the large
    // scales read from the coarse copies of c
    let coarse = CoarsePrefix::new(
        &c,
        scratch.take(c.len().div_ceil(COARSE)),
        scratch.take(c.len().div_ceil(COARSE * COARSE)),
    );
    let est: Vec<(f64, u64, u64, bool)> = ms
        .par_iter()
        .zip(&pre)
        .map(|(&m, pre)| {
            let stride = difference_stride(m);
            let used = (c.len() as u64 - 1 - 2 * m) / stride + 1;
            if let Some((r, rej)) = pre {
                return Ok((r.s / 2.0, *rej, used, r.root));
            }
            let mut d = scratch.take((c.len() - 1 - 2 * m as usize) / stride as usize + 1);
            coarse.differences_into(&c, m as usize, stride as usize, &mut d);
            let r = robust_mean_square_detail(&d, &bw)
                .map_err(|e| AvarError::InvalidScales(format!("robust AV at m = {m}: {e}")));
            let out = r.map(|r| {
                let rej = count_beyond(&d, bw.c * bw.c * r.s);
                (r.s / 2.0, rej, d.len() as u64, r.root)
            });
            scratch.give(d);
            out
        })
        .collect::<Result<_, AvarError>>()?;
    scratch.give(c);
    scratch.give(coarse.c8);
    scratch.give(coarse.c64);
    let mut robust = template;
    let eff = bw.efficiency();
    for (p, &(av, ..)) in robust.points.iter_mut().zip(&est) {
        let ratio = if p.avar > 0.0 { av / p.avar } else { 0.0 };
        p.avar = av;
        p.adev = av.sqrt();
        match config.ci {
            CiMethod::ChiSquare => {
                if let Some(edf) = p.edf {
                    let e = edf * eff;
                    let (lo, hi) = chi2_interval(av, e, config.alpha);
                    p.edf = Some(e);
                    p.set_interval(lo, hi);
                }
            }
            CiMethod::Gaussian => {
                // half-widths scaled by the robust/classical ratio and by 1/√e
                if let (Some(lo), Some(hi)) = (p.avar_lo, p.avar_hi) {
                    let k = ratio / eff.sqrt();
                    let cl = av / ratio.max(f64::MIN_POSITIVE);
                    let (l, h) = (av - (cl - lo) * k, av + (hi - cl) * k);
                    p.set_interval(l, h);
                }
            }
            CiMethod::None => {}
        }
    }
    Ok(RobustAllanVariance {
        efficiency: eff,
        biweight: bw,
        robust,
        classical,
        rejected: est.iter().map(|e| e.1).collect(),
        used: est.iter().map(|e| e.2).collect(),
        root_found: est.iter().map(|e| e.3).collect(),
        spikes,
    })
}

/// Robust Haar wavelet variance at levels 1..=J (τ_j = 2^j samples): ν̂²_j = robust AV(m =
/// 2^(j−1)) / 2 (module doc), with the `wv` η interval of [`crate::haar_wavelet_variance`]
/// computed with η·e (the variance inflated by 1/e). `levels`: as in
/// [`crate::haar_wavelet_variance`].
///
/// ```
/// use avar::{haar_wavelet_variance, robust::robust_haar_wavelet_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 97) as f64).collect();
/// let r = robust_haar_wavelet_variance(&x, 1.0, Some(5), 0.05, 0.6).unwrap();
/// let c = haar_wavelet_variance(&x, 1.0, Some(5), 0.05).unwrap();
/// assert_eq!(r.points.len(), 5);
/// assert!((r.points[0].eta / c.points[0].eta - 0.6).abs() < 1e-12);
/// ```
pub fn robust_haar_wavelet_variance(
    data: &[f64],
    rate_hz: f64,
    levels: Option<u32>,
    alpha: f64,
    efficiency: f64,
) -> Result<crate::HaarWaveletVariance, AvarError> {
    let mut wv = crate::haar_wavelet_variance(data, rate_hz, levels, alpha)?;
    let cfg = AvarConfig {
        scales: crate::Scales::Explicit(wv.points.iter().map(|p| p.scale / 2).collect()),
        ci: CiMethod::None,
        alpha,
        ..AvarConfig::default()
    };
    let r = robust_allan_variance(data, rate_hz, &cfg, efficiency)?;
    for (w, p) in wv.points.iter_mut().zip(&r.robust.points) {
        w.wv = p.avar / 2.0;
        w.eta *= r.efficiency;
        let (lo, hi) = chi2_interval(w.wv, w.eta, alpha);
        w.wv_lo = lo;
        w.wv_hi = hi;
    }
    Ok(wv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robust::excess_windows;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// Samples near 1e±154 and beyond used to overflow (or underflow) the squared differences
    /// (and `fit --robust` looped forever on an infinite mean square): now the robust AV of
    /// 2^k·x is 4^k times that of x to 1e-13 (the Newton iterates on ln s round differently),
    /// its intervals too, and the classical curve is the one given.
    #[test]
    fn huge_and_tiny_samples_are_rescaled() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(41);
        let x: Vec<f64> = (0..20_000)
            .map(|i| {
                let z: f64 = StandardNormal.sample(&mut rng);
                z + if i % 997 == 0 { 30.0 } else { 0.0 }
            })
            .collect();
        let cfg = AvarConfig::default();
        let base = robust_allan_variance(&x, 10.0, &cfg, 0.6).unwrap();
        assert!(!base.spikes.indices.is_empty());
        for k in [511, -500, 200] {
            let y: Vec<f64> = x.iter().map(|v| crate::range::ldexp(*v, k)).collect();
            let r = robust_allan_variance(&y, 10.0, &cfg, 0.6).unwrap();
            assert_eq!(r.spikes.indices, base.spikes.indices);
            for (p, q) in r.robust.points.iter().zip(&base.robust.points) {
                let back = |v: f64| crate::range::ldexp(v, -2 * k);
                assert!(
                    (back(p.avar) / q.avar - 1.0).abs() < 1e-13,
                    "k = {k}, m = {}: {:e}",
                    p.m,
                    back(p.avar) / q.avar - 1.0
                );
                let (lo, hi) = (p.avar_lo.unwrap(), p.avar_hi.unwrap());
                assert!((back(lo) / q.avar_lo.unwrap() - 1.0).abs() < 1e-13);
                assert!((back(hi) / q.avar_hi.unwrap() - 1.0).abs() < 1e-13);
            }
            for (p, q) in r.classical.points.iter().zip(&base.classical.points) {
                assert_eq!(crate::range::ldexp(p.avar, -2 * k), q.avar);
            }
        }
    }

    #[test]
    fn robust_av_is_consistent_for_white_noise() {
        let cfg = AvarConfig {
            scales: crate::Scales::Explicit(vec![1, 4, 64]),
            ..AvarConfig::default()
        };
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let r = 100;
        let mut sums = [[0.0; 2]; 3];
        for _ in 0..r {
            let x: Vec<f64> = (0..1 << 16)
                .map(|_| StandardNormal.sample(&mut rng))
                .collect();
            let ra = robust_allan_variance(&x, 1.0, &cfg, 0.6).unwrap();
            for (i, p) in ra.robust.points.iter().enumerate() {
                let v = p.avar * p.m as f64; // → σ² = 1
                sums[i][0] += v;
                sums[i][1] += v * v;
            }
        }
        for (i, s) in sums.iter().enumerate() {
            let mean = s[0] / r as f64;
            let var = (s[1] / r as f64 - mean * mean) * r as f64 / (r - 1) as f64;
            let se = (var / r as f64).sqrt();
            assert!((mean - 1.0).abs() < 3.0 * se, "scale {i}: {mean} ± {se}");
        }
    }

    #[test]
    fn robust_av_errors_and_intervals() {
        let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 97) as f64).collect();
        let ang = AvarConfig {
            input: InputKind::Angle,
            ..AvarConfig::default()
        };
        assert!(robust_allan_variance(&x, 1.0, &ang, 0.6).is_err());
        assert!(robust_allan_variance(&x, 1.0, &AvarConfig::default(), 1.5).is_err());
        let r = robust_allan_variance(&x, 1.0, &AvarConfig::default(), 0.6).unwrap();
        for (p, q) in r.robust.points.iter().zip(&r.classical.points) {
            let (lo, hi) = (p.avar_lo.unwrap(), p.avar_hi.unwrap());
            assert!(lo < p.avar && p.avar < hi);
            // relative width wider than the classical one (EDF × 0.6)
            assert!(hi / lo > q.avar_hi.unwrap() / q.avar_lo.unwrap());
            assert!((p.edf.unwrap() / q.edf.unwrap() - r.efficiency).abs() < 1e-12);
        }
        let b = Biweight::with_efficiency(0.6).unwrap();
        assert!(excess_windows(&x, 1.0, 1, &b, 0, 3).is_err());
        // 70 % zeros and 30 % ±1: (1/n) Σ χ(d²/s) ≤ 0.3·max χ = 0.3·c²/5·(4/5)⁴ < a(c), so
        // the equation has no root; the fallback maximizes its left side: u = 1/s = c²/5
        let d: Vec<f64> = (0..1000)
            .map(|i| match i % 10 {
                0..=6 => 0.0,
                7 | 9 => 1.0,
                _ => -1.0,
            })
            .collect();
        let r = robust_mean_square_detail(&d, &b).unwrap();
        assert!(!r.root);
        assert!((r.s / (5.0 / (b.c * b.c)) - 1.0).abs() < 1e-6, "{}", r.s);
        assert!(excess_windows(&x, 1.0, 5000, &b, 10, 3).is_err());
    }
}
