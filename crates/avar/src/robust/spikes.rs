//! Spike replacement before the M-estimator (the module doc of [`crate::robust`], "Spikes
//! first"): isolated samples far from their neighbours replaced by the neighbours' mean plus
//! a reproducible Gaussian draw.

use serde::{Deserialize, Serialize};

use super::differences::centred_prefix_sums_into;
use crate::error::AvarError;

/// A sample is a spike when it lies farther than this many robust SDs from the mean of its
/// neighbours ([`replace_spikes`]).
pub const SPIKE_THRESHOLD: f64 = 6.0;

/// Neighbours on each side that a spike is judged against and replaced from.
pub const SPIKE_HALF_WINDOW: usize = 10;

/// Largest fraction of samples [`replace_spikes`] replaces: past it the samples beyond the
/// threshold are the tails of a heavy-tailed noise, not isolated spikes, and nothing is
/// replaced (the per-scale M-estimator alone deals with them).
pub const MAX_SPIKE_FRACTION: f64 = 0.01;

/// What [`replace_spikes`] did.
///
/// ```
/// use avar::robust::{replace_spikes, SPIKE_HALF_WINDOW};
/// use std::borrow::Cow;
/// let mut x: Vec<f64> = (0..1000).map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5).collect();
/// x[500] += 30.0;
/// let (_, r) = replace_spikes(&x, 6.0).unwrap();
/// assert_eq!(r.indices, vec![500]);
/// assert_eq!((r.threshold, r.beyond), (6.0, 1));
/// assert!(r.residual_sd > 0.0);
/// // fewer than 4w + 1 samples: not judged, nothing replaced, the data returned as they are
/// let (y, r) = replace_spikes(&x[..4 * SPIKE_HALF_WINDOW], 6.0).unwrap();
/// assert!(r.indices.is_empty() && r.residual_sd == 0.0);
/// assert!(matches!(y, Cow::Borrowed(_)));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpikeReplacement {
    /// 0-based indices of the replaced samples, increasing.
    pub indices: Vec<u64>,
    /// Robust SD (1.4826·MAD) of the residuals from the neighbours' mean (unit of the data);
    /// 0 when the series is too short or too coarsely quantized to judge (nothing replaced).
    pub residual_sd: f64,
    /// The threshold used, in residual SDs.
    pub threshold: f64,
    /// Samples beyond the threshold. More than [`MAX_SPIKE_FRACTION`] of the series: heavy
    /// tails, and then none is replaced (`indices` empty).
    pub beyond: u64,
}

/// A standard normal draw that depends on `t` only (SplitMix64 of the index, Box–Muller).
fn hashed_normal(t: u64) -> f64 {
    let mix = |mut z: u64| {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    let a = mix(t.wrapping_mul(2));
    let b = mix(t.wrapping_mul(2).wrapping_add(1));
    // u1 in (0, 1], u2 in [0, 1)
    let u1 = ((a >> 11) + 1) as f64 / (1u64 << 53) as f64;
    let u2 = (b >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Replaces isolated spikes of rate samples (module doc, "Spikes first"): a sample t is a
/// candidate when its residual r_t = x_t − x̄_t lies farther than `threshold`·σ̂_r from the
/// residuals' median, x̄_t the mean of its 2w neighbours (w = [`SPIKE_HALF_WINDOW`]) and σ̂_r =
/// 1.4826·MAD of the residuals (of an evenly spaced subsample of about [`SPIKE_MAD_SAMPLE`]
/// in longer series); it is a spike when x_t − μ_t is still that far, μ_t the mean of
/// the nearest w non-candidates on each side (n of them; the neighbours of a huge spike are
/// candidates but not spikes). A spike becomes μ_t + s·z_t: z_t a standard normal fixed by t, and
/// s² = σ̂_r²(1 − 1/n)/(1 + 1/(2w)), which gives the replaced sample a white-noise residual of
/// the clean samples' variance (σ̂_r² estimates σ²(1 + 1/(2w)) for white noise σ², and μ_t
/// carries σ²/n of it). Cost: O(T): prefix sums, two selections of at most 2^18 values, one pass.
///
/// Returns the series (a copy; `data` itself when nothing is replaced) and what was done.
/// Nothing is replaced when the series has fewer than 4w + 1 samples, when σ̂_r = 0 (more
/// than half the residuals are 0, e.g. coarse quantization), or when more than
/// [`MAX_SPIKE_FRACTION`] of the samples are beyond the threshold (heavy tails, not spikes). Errors: non-finite samples, a
/// threshold that is not finite and > 0.
///
/// ```
/// use avar::robust::replace_spikes;
/// let mut x: Vec<f64> = (0..5000).map(|i| ((i * 7919) % 101) as f64 / 101.0 - 0.5).collect();
/// x[1234] += 40.0;
/// x[4000] -= 25.0;
/// let (y, r) = replace_spikes(&x, 6.0).unwrap();
/// assert_eq!(r.indices, vec![1234, 4000]);
/// assert!(y[1234].abs() < 2.0 && y[4000].abs() < 2.0);
/// assert_eq!(y[1233], x[1233]); // the rest is untouched
/// ```
pub fn replace_spikes(
    data: &[f64],
    threshold: f64,
) -> Result<(std::borrow::Cow<'_, [f64]>, SpikeReplacement), AvarError> {
    spike_scan(data, threshold, Vec::new()).map(|s| (s.series, s.report))
}

/// Largest number of residuals the median and MAD of [`replace_spikes`] are taken from: past
/// it, an evenly spaced subsample of about this many (the MAD's relative SE is then about
/// 0.3 % at the Gaussian model, a shift of 0.02 SD in a threshold of 6).
pub const SPIKE_MAD_SAMPLE: usize = 1 << 18;

/// What [`spike_scan`] gives: the series, the report, and the centred prefix sums of `data`
/// (centred on the mean of `data`), which are those of the series when nothing was replaced.
pub(super) struct SpikeScan<'a> {
    pub(super) series: std::borrow::Cow<'a, [f64]>,
    pub(super) report: SpikeReplacement,
    /// Prefix sums of `data − mean(data)` (c[0] = 0); empty for short series.
    pub(super) prefix: Vec<f64>,
}

/// [`replace_spikes`], keeping the prefix sums it builds (see [`SpikeScan`]) in `buf`
/// (reused memory; its contents are overwritten).
pub(super) fn spike_scan(
    data: &[f64],
    threshold: f64,
    buf: Vec<f64>,
) -> Result<SpikeScan<'_>, AvarError> {
    use std::borrow::Cow;
    if !(threshold.is_finite() && threshold > 0.0) {
        return Err(AvarError::InvalidScales(format!(
            "the spike threshold must be finite and > 0, got {threshold}"
        )));
    }
    crate::kernel::cumsum::check_finite(data)?;
    let w = SPIKE_HALF_WINDOW;
    let t = data.len();
    let none = |sd: f64, beyond: usize| SpikeReplacement {
        indices: Vec::new(),
        residual_sd: sd,
        threshold,
        beyond: beyond as u64,
    };
    if t < 4 * w + 1 {
        return Ok(SpikeScan {
            series: Cow::Borrowed(data),
            report: none(0.0, 0),
            prefix: Vec::new(),
        });
    }
    // residuals from the mean of the 2w neighbours (window clipped at the ends), from prefix
    // sums of the centred series (the residual of a spike of size A moves its neighbours'
    // residuals by A/(2w) only)
    let mean = data.iter().sum::<f64>() / t as f64;
    let c = centred_prefix_sums_into(data, mean, buf);
    let resid = |i: usize| {
        let (lo, hi) = (i.saturating_sub(w), (i + w + 1).min(t));
        let own = data[i] - mean;
        let n = (hi - lo - 1) as f64;
        own - (c[hi] - c[lo] - own) / n
    };
    // median and MAD of the residuals (of an evenly spaced subsample past SPIKE_MAD_SAMPLE)
    let stride = t.div_ceil(SPIKE_MAD_SAMPLE);
    let mut abs: Vec<f64> = (0..t).step_by(stride).map(resid).collect();
    let k = abs.len() / 2;
    let med = *abs.select_nth_unstable_by(k, f64::total_cmp).1;
    abs.iter_mut().for_each(|r| *r = (*r - med).abs());
    let mad = *abs.select_nth_unstable_by(k, f64::total_cmp).1;
    drop(abs);
    let sd = 1.482_602_218_505_602 * mad;
    let done = |series, report| SpikeScan {
        series,
        report,
        prefix: Vec::new(),
    };
    if !(sd > 0.0 && sd.is_finite()) {
        let mut s = done(Cow::Borrowed(data), none(0.0, 0));
        s.prefix = c;
        return Ok(s);
    }
    let lim = threshold * sd;
    // pass 1: candidates against all their neighbours (a spike of size A moves its
    // neighbours' residuals by A/(2w), so beside a huge spike they are candidates too)
    let beyond = |i: usize| (resid(i) - med).abs() > lim;
    let mut candidates: Vec<usize> = (0..w).filter(|&i| beyond(i)).collect();
    // the interior (full windows, n = 2w) eight at a time, the operations of `resid` on each
    // (so that they vectorize; the same values)
    let nf = (2 * w) as f64;
    let mut i = w;
    while i + 8 <= t - w {
        let mut flags = [false; 8];
        for (l, f) in flags.iter_mut().enumerate() {
            let j = i + l;
            let own = data[j] - mean;
            let r = own - (c[j + w + 1] - c[j - w] - own) / nf;
            *f = (r - med).abs() > lim;
        }
        if flags.contains(&true) {
            candidates.extend((0..8).filter(|&l| flags[l]).map(|l| i + l));
        }
        i += 8;
    }
    candidates.extend((i..t).filter(|&j| beyond(j)));
    if candidates.is_empty() {
        let mut s = done(Cow::Borrowed(data), none(sd, 0));
        s.prefix = c;
        return Ok(s);
    }
    let mut is_cand = vec![false; t];
    for &i in &candidates {
        is_cand[i] = true;
    }
    // the mean of the nearest w non-candidates on each side (searching at most 8w away), and
    // how many there are
    let nearest_mean = |i: usize| -> (f64, usize) {
        let (mut sum, mut n) = (0.0, 0usize);
        let (mut taken, mut j) = (0, i);
        while taken < w && j > 0 && i - j < 8 * w {
            j -= 1;
            if !is_cand[j] {
                sum += data[j];
                n += 1;
                taken += 1;
            }
        }
        (taken, j) = (0, i);
        while taken < w && j + 1 < t && j - i < 8 * w {
            j += 1;
            if !is_cand[j] {
                sum += data[j];
                n += 1;
                taken += 1;
            }
        }
        (if n > 0 { sum / n as f64 } else { f64::NAN }, n)
    };
    // pass 2: a candidate is a spike when it is still beyond the threshold against the
    // non-candidates; a solid block with no such neighbour is left to the M-estimator
    let spikes: Vec<(usize, f64, usize)> = candidates
        .iter()
        .filter_map(|&i| {
            let (mu, n) = nearest_mean(i);
            (n > 0 && (data[i] - mu - med).abs() > lim).then_some((i, mu, n))
        })
        .collect();
    if spikes.is_empty() || spikes.len() as f64 > MAX_SPIKE_FRACTION * t as f64 {
        let mut s = done(Cow::Borrowed(data), none(sd, spikes.len()));
        s.prefix = c;
        return Ok(s);
    }
    drop(c);
    let mut y = data.to_vec();
    for &(i, mu, n) in &spikes {
        let nf = n as f64;
        let s2 = sd * sd * (1.0 - 1.0 / nf) / (1.0 + 1.0 / (2.0 * w as f64));
        y[i] = mu + s2.max(0.0).sqrt() * hashed_normal(i as u64);
    }
    Ok(done(
        Cow::Owned(y),
        SpikeReplacement {
            indices: spikes.iter().map(|s| s.0 as u64).collect(),
            residual_sd: sd,
            threshold,
            beyond: spikes.len() as u64,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::AvarConfig;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// Clean Gaussian white noise, T = 2^17: the 6-SD threshold is passed by about
    /// 2·10⁻⁹·T ≈ 3·10⁻⁴ samples in expectation (the MAD's own error moves it little), so
    /// nothing may be replaced, and the series is returned as it is.
    #[test]
    fn clean_white_noise_keeps_every_sample() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let x: Vec<f64> = (0..1 << 17)
            .map(|_| StandardNormal.sample(&mut rng))
            .collect();
        let (y, r) = replace_spikes(&x, SPIKE_THRESHOLD).unwrap();
        assert!(r.indices.is_empty(), "{:?}", r.indices);
        assert!(matches!(y, std::borrow::Cow::Borrowed(_)));
        // σ̂_r estimates σ√(1 + 1/(2w)) for white noise (the neighbours' mean has variance
        // σ²/(2w)); the MAD's relative SE at T = 2^17 is about 1.7/√T ≈ 0.5 %.
        let want = (1.0 + 1.0 / (2.0 * SPIKE_HALF_WINDOW as f64)).sqrt();
        assert!(
            (r.residual_sd / want - 1.0).abs() < 0.02,
            "{}",
            r.residual_sd
        );
    }

    /// White noise (σ = 1) plus a random walk (γ = 0.01), T = 2^18, with 0.5 % additive
    /// outliers of ±20σ at random places (isolated or adjacent): every outlier is found and
    /// nothing else, and the Allan variance of the replaced series equals that of the clean one
    /// within 1 % at every dyadic scale. Why 1 %: the replaced samples differ from the clean
    /// ones by about √2·σ each, which moves Σ D² at scale m by a zero-mean sum of about 4m·pT
    /// terms of SD ≈ 2σ²/m² against a total of ≈ 2σ²T/m: a relative SD of about
    /// √(4m·pT)/(mT) ≤ 6·10⁻⁴ here, and the estimators' own differences cancel (same series).
    #[test]
    fn spikes_are_found_and_the_av_of_the_clean_series_comes_back() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
        let n = 1usize << 18;
        let mut level = 0.0;
        let x: Vec<f64> = (0..n)
            .map(|_| {
                let z: f64 = StandardNormal.sample(&mut rng);
                let e: f64 = StandardNormal.sample(&mut rng);
                level += 0.01 * e;
                level + z
            })
            .collect();
        let mut y = x.clone();
        let mut places = std::collections::BTreeSet::new();
        let mut u = 0x1234_5678_u64;
        while places.len() < n / 200 {
            u = u
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let i = (u >> 33) as usize % n;
            places.insert(i);
            if u.is_multiple_of(7) && i + 1 < n {
                places.insert(i + 1); // some come in pairs
            }
        }
        for (k, &i) in places.iter().enumerate() {
            y[i] += if k % 2 == 0 { 20.0 } else { -20.0 };
        }
        let (z, r) = replace_spikes(&y, SPIKE_THRESHOLD).unwrap();
        let want: Vec<u64> = places.iter().map(|&i| i as u64).collect();
        assert_eq!(r.indices, want);
        let cfg = AvarConfig::default();
        let a = crate::allan_variance(&x, 1.0, &cfg).unwrap();
        let b = crate::allan_variance(&z, 1.0, &cfg).unwrap();
        let c = crate::allan_variance(&y, 1.0, &cfg).unwrap();
        for ((p, q), o) in a.points.iter().zip(&b.points).zip(&c.points) {
            assert!(
                (q.avar / p.avar - 1.0).abs() < 0.01,
                "m = {}: {} vs clean {}",
                p.m,
                q.avar,
                p.avar
            );
            // the contaminated AV is far off where WN dominates: 0.005·20² = 2σ² of extra white
            // noise would triple it; adjacent outliers of opposite sign cancel in the cluster
            // means, so somewhat less (2.5 at m = 16)
            if p.m <= 16 {
                assert!(o.avar / p.avar > 2.0, "m = {}: {}", p.m, o.avar / p.avar);
            }
        }
    }

    #[test]
    fn spikes_are_found_at_the_ends_and_at_every_block_offset() {
        // 50σ spikes at the two ends (clipped windows), just inside them and at each offset of
        // the interior's blocks of eight (17 in all, under MAX_SPIKE_FRACTION): every one is
        // found, nothing else
        let w = SPIKE_HALF_WINDOW;
        let t = 4003;
        let mut u = 11u64;
        let mut y: Vec<f64> = (0..t)
            .map(|_| {
                u = u
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (u >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let mut at = vec![0, 3, w - 1, w, w + 1, t - w - 1, t - w, t - 2, t - 1];
        at.extend((0..8).map(|k| 400 + 3 * w + k * (2 * w + 3)));
        at.sort_unstable();
        for &i in &at {
            y[i] += 50.0 * 0.29;
        }
        let (_, r) = replace_spikes(&y, SPIKE_THRESHOLD).unwrap();
        let found: Vec<usize> = r.indices.iter().map(|&i| i as usize).collect();
        assert_eq!(found, at);
    }

    #[test]
    fn spike_replacement_edge_cases() {
        // too short, constant, coarsely quantized: nothing replaced, no error
        let (y, r) = replace_spikes(&[1.0; 30], 6.0).unwrap();
        assert!(r.indices.is_empty() && y.len() == 30);
        let (_, r) = replace_spikes(&[2.0; 1000], 6.0).unwrap();
        assert!(r.indices.is_empty() && r.residual_sd == 0.0);
        // heavy tails (Student t with 1 dof, Cauchy: P(|X| > 6·1.4826·MAD) ≈ 7 %): nothing replaced
        let x: Vec<f64> = (1..20000)
            .map(|i| (std::f64::consts::PI * (i as f64 / 20000.0 - 0.5)).tan())
            .map(|v| if v.is_finite() { v } else { 0.0 })
            .collect();
        let mut y = x.clone();
        // shuffle deterministically so neighbours are unrelated
        let mut u = 7u64;
        for i in (1..y.len()).rev() {
            u = u
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            y.swap(i, (u >> 33) as usize % (i + 1));
        }
        let (z, r) = replace_spikes(&y, 6.0).unwrap();
        assert!(r.indices.is_empty() && r.beyond as f64 > MAX_SPIKE_FRACTION * y.len() as f64);
        assert!(matches!(z, std::borrow::Cow::Borrowed(_)));
        assert!(replace_spikes(&[1.0, f64::NAN, 2.0], 6.0).is_err());
        assert!(replace_spikes(&[1.0; 100], 0.0).is_err());
        assert!(replace_spikes(&[1.0; 100], f64::INFINITY).is_err());
        // the replacement draws depend on the index only
        assert_eq!(hashed_normal(12345), hashed_normal(12345));
        let m: f64 = (0..100_000).map(hashed_normal).sum::<f64>() / 1e5;
        let v: f64 = (0..100_000).map(|t| hashed_normal(t).powi(2)).sum::<f64>() / 1e5;
        // mean within 4 SE (1/√1e5), variance within 4 SE (√2/√1e5)
        assert!(
            m.abs() < 4.0 / 1e5f64.sqrt() && (v - 1.0).abs() < 4.0 * 2f64.sqrt() / 1e5f64.sqrt()
        );
    }
}
