//! A data-quality pass for static records, run before the Allan variance is read: spikes,
//! level shifts and a linear trend, with their times and how each one biases the AV.
//!
//! The AV of a static record is read as the sum of the AVs of latent noise processes. Three
//! disturbances that are not noise break that reading, each with a known signature at cluster
//! size m (samples) in a record of T samples:
//! - a **spike** of excess A (one sample off its neighbours by A) adds A²/(m(T − 2m + 1)) ≈
//!   A²/(mT): an AD slope of −1/2, like white noise, so it inflates N and the small-τ AV;
//! - a **level shift** of size Δ (a bump of the mount) adds about mΔ²/(3T) for m ≪ T: an AD
//!   slope of +1/2, like a rate random walk, so it inflates K (and can make a fit singular);
//! - a **linear trend** of ω per sample adds exactly ω²m²/2: an AD slope of +1, a rate ramp.
//!
//! Detection is robust and O(T):
//! - spikes: e_i = x_i − (x_{i−1} + x_{i+1})/2 against a robust scale of e (MAD, or the mean
//!   absolute deviation when quantized data make the MAD zero); a spike is a local maximum of
//!   |e| above `spike_z` scales and at least 1.5 times its neighbours (a spike leaves ±half of
//!   itself on each side, a step two equal halves);
//! - level shifts: means of `blocks` blocks, the difference D_b of the means of the w = 4 blocks
//!   after and before each boundary, robustly standardised; a local maximum above `shift_z` is a
//!   shift, located to the sample by the largest CUSUM in its neighbourhood;
//! - trend: the least-squares line, reported when it carries at least `trend_share` of the AV
//!   at each of the two longest dyadic scales (a random walk can look like this over one
//!   record: the finding says so).
//!
//! ```
//! use avar::quality::{data_quality, QualityOptions};
//! // white noise (a fixed sequence) with one level shift of 1.0 at sample 6000
//! let x: Vec<f64> = (0..10_000)
//!     .map(|i| ((i as f64 * 0.7548776662).fract() - 0.5) * 0.1 + if i >= 6000 { 1.0 } else { 0.0 })
//!     .collect();
//! let q = data_quality(&x, 100.0, &QualityOptions::default()).unwrap();
//! assert_eq!(q.level_shifts.len(), 1);
//! assert!((q.level_shifts[0].time_s - 60.0).abs() <= 0.05);
//! assert!((q.level_shifts[0].size - 1.0).abs() < 0.01);
//! assert!(q.spikes.is_empty());
//! ```

use serde::{Deserialize, Serialize};

use crate::{AllanVariance, AvarConfig, AvarError, CiMethod, Estimator, InputKind, Scales};

/// Thresholds of the data-quality pass.
///
/// ```
/// use avar::quality::{data_quality, QualityOptions};
/// let d = QualityOptions::default();
/// assert_eq!((d.spike_z, d.shift_z, d.blocks, d.trend_share), (10.0, 10.0, 256, 0.5));
/// // a ±1 square wave with one sample off its neighbours by 16 (e_i = ±2 elsewhere)
/// let mut x: Vec<f64> = (0..1000).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// x[500] += 14.0;
/// // the robust scale of e is 1.4826·MAD = 1.4826·4 ≈ 5.9: 16 is below 10 of them, above 2
/// let strict = QualityOptions { spike_z: 2.0, ..d.clone() };
/// assert!(data_quality(&x, 1.0, &d).unwrap().spikes.is_empty());
/// assert_eq!(data_quality(&x, 1.0, &strict).unwrap().spikes[0].index, 500);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QualityOptions {
    /// A spike is at least this many robust scales of e_i (default 10: under Gaussian noise a
    /// false alarm has probability about 1e-23 per sample).
    pub spike_z: f64,
    /// A level shift is at least this many robust scales of the block-mean differences
    /// (default 10).
    pub shift_z: f64,
    /// Number of blocks for the level-shift search (default 256; blocks have ≥ 16 samples).
    pub blocks: usize,
    /// A trend is reported when its share of the AV at the two longest dyadic scales is at
    /// least this (default 0.5).
    pub trend_share: f64,
}

impl Default for QualityOptions {
    fn default() -> Self {
        QualityOptions {
            spike_z: 10.0,
            shift_z: 10.0,
            blocks: 256,
            trend_share: 0.5,
        }
    }
}

/// One spike: a sample that stands off its two neighbours.
///
/// ```
/// use avar::quality::{data_quality, QualityOptions};
/// // a ±1 square wave at 100 Hz with 100 added to sample 500 (x_500 = 101, neighbours −1)
/// let mut x: Vec<f64> = (0..1000).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// x[500] += 100.0;
/// let opts = QualityOptions::default();
/// let q = data_quality(&x, 100.0, &opts).unwrap();
/// assert_eq!(q.spikes.len(), 1);
/// let s = &q.spikes[0];
/// assert_eq!((s.index, s.time_s), (500, 5.0));
/// assert_eq!(s.excess, 102.0); // 101 − (−1 − 1)/2
/// assert!(s.z > opts.spike_z);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spike {
    /// Zero-based sample index.
    pub index: usize,
    /// Time from the first sample (s).
    pub time_s: f64,
    /// x_i − (x_{i−1} + x_{i+1})/2 (data units).
    pub excess: f64,
    /// |excess| in robust scales.
    pub z: f64,
}

/// One level shift: the mean after differs from the mean before.
///
/// ```
/// use avar::quality::{data_quality, QualityOptions};
/// // a ±1 square wave at 64 Hz that steps up by 1.0 at sample 512 (t = 8 s): block means of
/// // 16 samples are exactly 0 before and 1 after
/// let x: Vec<f64> = (0..1024)
///     .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 } + if i >= 512 { 1.0 } else { 0.0 })
///     .collect();
/// let q = data_quality(&x, 64.0, &QualityOptions::default()).unwrap();
/// assert_eq!(q.level_shifts.len(), 1);
/// let l = &q.level_shifts[0];
/// assert_eq!((l.index, l.time_s, l.size), (512, 8.0, 1.0));
/// assert!(q.spikes.is_empty());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LevelShift {
    /// Zero-based index of the first sample after the shift.
    pub index: usize,
    /// Time of that sample from the first one (s).
    pub time_s: f64,
    /// Mean of the 4 blocks' worth of samples after minus that before (data units).
    pub size: f64,
    /// |size| in robust scales of the block-mean differences.
    pub z: f64,
}

/// A linear trend over the whole record.
///
/// ```
/// use avar::quality::{data_quality, QualityOptions};
/// // a pure ramp of 1 per sample at 10 Hz: AV(m) = m²/2 is all trend
/// let x: Vec<f64> = (0..1024).map(|i| i as f64).collect();
/// let q = data_quality(&x, 10.0, &QualityOptions::default()).unwrap();
/// let tr = q.trend.unwrap();
/// assert_eq!(tr.slope_per_s, 10.0); // 1 per sample · 10 Hz
/// assert_eq!(tr.tau_longest_s, 51.2); // m = 2^(⌊log2 1024⌋ − 1) = 512 samples
/// assert!((tr.share_longest - 1.0).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trend {
    /// Least-squares slope (data units per second).
    pub slope_per_s: f64,
    /// Share of the AV carried by ω²m²/2 at the longest dyadic scale.
    pub share_longest: f64,
    /// That scale's τ (s).
    pub tau_longest_s: f64,
}

/// What the pass found, with one sentence per finding in `findings`.
///
/// ```
/// use avar::quality::{data_quality, QualityOptions};
/// // a ±1 square wave at 100 Hz with a spike of 100 every 100 samples (every second)
/// let mut x: Vec<f64> = (0..1000).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// for i in (100..1000).step_by(100) {
///     x[i] += 100.0;
/// }
/// let q = data_quality(&x, 100.0, &QualityOptions::default()).unwrap();
/// assert_eq!((q.n, q.rate_hz), (1000, 100.0));
/// assert_eq!(q.spikes.len(), 9);
/// assert_eq!(q.spike_period_s, Some(1.0));
/// assert!(q.findings[0].contains("9 spikes"));
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataQuality {
    /// Number of samples T.
    pub n: usize,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Spikes, in time order.
    pub spikes: Vec<Spike>,
    /// The spacing of the spikes when they are periodic (s): ≥ 3 spikes whose spacings agree
    /// within 2 % of their median.
    pub spike_period_s: Option<f64>,
    /// Level shifts, in time order.
    pub level_shifts: Vec<LevelShift>,
    /// A trend that dominates the longest scales.
    pub trend: Option<Trend>,
    /// Each finding in words: what, when, and how it biases the AV.
    pub findings: Vec<String>,
}

impl DataQuality {
    /// True when nothing was found.
    ///
    /// ```
    /// use avar::quality::{data_quality, QualityOptions};
    /// let opts = QualityOptions::default();
    /// // a ±1 square wave: no spike, equal block means, AV = 0 at the (even) longest scales
    /// let mut x: Vec<f64> = (0..1000).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
    /// let q = data_quality(&x, 1.0, &opts).unwrap();
    /// assert!(q.is_clean() && q.findings.is_empty());
    /// x[500] += 100.0;
    /// let q = data_quality(&x, 1.0, &opts).unwrap();
    /// assert!(!q.is_clean());
    /// assert_eq!(q.findings.len(), q.spikes.len());
    /// ```
    pub fn is_clean(&self) -> bool {
        self.findings.is_empty()
    }
}

/// Runs the data-quality pass on rate samples `x` at `rate_hz` (see the module doc).
///
/// Errors: fewer than 64 samples, non-finite samples (by index), a bad rate.
///
/// ```
/// use avar::quality::{data_quality, QualityOptions};
/// use avar::AvarError;
/// let opts = QualityOptions::default();
/// let mut x: Vec<f64> = (0..64).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// assert_eq!(data_quality(&x, 1.0, &opts).unwrap().n, 64);
/// assert_eq!(data_quality(&x[..63], 1.0, &opts), Err(AvarError::TooShort { got: 63, need: 64 }));
/// assert!(data_quality(&x, 0.0, &opts).is_err());
/// x[7] = f64::NAN;
/// assert!(matches!(data_quality(&x, 1.0, &opts), Err(AvarError::NonFinite { index: 7, .. })));
/// ```
pub fn data_quality(
    x: &[f64],
    rate_hz: f64,
    opts: &QualityOptions,
) -> Result<DataQuality, AvarError> {
    data_quality_with(x, rate_hz, opts, None)
}

/// [`data_quality`] reading the AV at m = 2 and at the two longest dyadic scales from
/// `classical`, the overlapping AV of the same samples and rate (any CI, any scale set
/// holding those three; as [`crate::allan_variance`] computes it, whose value at a scale does
/// not depend on the other scales), instead of computing them; the same result, bit for bit.
/// Without such a curve (`None`, other samples, a scale missing) they are computed.
///
/// ```
/// use avar::{AvarConfig, allan_variance};
/// use avar::quality::{QualityOptions, data_quality, data_quality_with};
/// let x: Vec<f64> = (0..5000).map(|i| ((i * 7919) % 101) as f64 + 1e-3 * i as f64).collect();
/// let av = allan_variance(&x, 10.0, &AvarConfig::default()).unwrap();
/// let opts = QualityOptions::default();
/// assert_eq!(
///     data_quality_with(&x, 10.0, &opts, Some(&av)).unwrap(),
///     data_quality(&x, 10.0, &opts).unwrap()
/// );
/// ```
pub fn data_quality_with(
    x: &[f64],
    rate_hz: f64,
    opts: &QualityOptions,
    classical: Option<&AllanVariance>,
) -> Result<DataQuality, AvarError> {
    crate::validate_rate_alpha(rate_hz, 0.05)?;
    if x.len() < 64 {
        return Err(AvarError::TooShort {
            got: x.len(),
            need: 64,
        });
    }
    crate::kernel::cumsum::check_finite(x)?;
    let t = x.len();
    let spikes = find_spikes(x, rate_hz, opts.spike_z);
    let level_shifts = find_shifts(x, &spikes, rate_hz, opts);
    // AV at the first scale and the two longest dyadic ones, for the shares
    let top = (t as f64).log2().floor() as u32 - 1;
    let ms = [2u64, 1 << (top - 1), 1 << top];
    let given = classical
        .filter(|c| {
            c.n == t
                && c.rate_hz == rate_hz
                && c.input == InputKind::Rate
                && c.estimator == Estimator::Overlapping
        })
        .and_then(|c| {
            let at = |m: u64| c.points.iter().find(|p| p.m == m).map(|p| p.avar);
            Some([at(ms[0])?, at(ms[1])?, at(ms[2])?])
        });
    let [av2, av_l1, av_l] = match given {
        Some(v) => v,
        None => {
            let cfg = AvarConfig {
                scales: Scales::Explicit(ms.to_vec()),
                ci: CiMethod::None,
                ..AvarConfig::default()
            };
            let av = crate::allan_variance(x, rate_hz, &cfg)?;
            [av.points[0].avar, av.points[1].avar, av.points[2].avar]
        }
    };
    let trend = trend(
        x,
        rate_hz,
        [(1u64 << (top - 1), av_l1), (1u64 << top, av_l)],
    )
    .filter(|tr| tr.0 >= opts.trend_share && tr.1.share_longest >= opts.trend_share)
    .map(|tr| tr.1);
    let spike_period_s = period(&spikes);
    let mut findings = Vec::new();
    let tf = t as f64;
    if !spikes.is_empty() {
        let sum_a2: f64 = spikes.iter().map(|s| s.excess * s.excess).sum();
        let share = sum_a2 / (2.0 * (tf - 3.0)) / av2;
        let zmax = spikes.iter().map(|s| s.z).fold(0.0, f64::max);
        let amax = spikes.iter().map(|s| s.excess.abs()).fold(0.0, f64::max);
        findings.push(format!(
            "{} spike{} (up to {amax:.3e} off the neighbours, {zmax:.0} robust SDs){} at t = {} s: each spike of excess A adds A²/(m·T) to the AV at cluster size m (AD slope −1/2, like white noise); together they carry {} of the AV at m = 2, inflating N and the small-τ end",
            spikes.len(),
            if spikes.len() == 1 { "" } else { "s" },
            spike_period_s.map_or(String::new(), |p| format!(", periodic every {p:.4} s")),
            times(spikes.iter().map(|s| s.time_s)),
            percent(share)
        ));
    }
    for s in &level_shifts {
        findings.push(format!(
            "a level shift of {:.3e} ({:.0} robust SDs) at t = {:.3} s: it adds about m·Δ²/(3T) to the AV at cluster size m (AD slope +1/2, like a rate random walk), inflating K and the long-τ end; analyse the segments on either side, or expect RW/AR1 terms that are not noise",
            s.size, s.z, s.time_s
        ));
    }
    if let Some(tr) = &trend {
        findings.push(format!(
            "a linear trend of {:.3e} per s (least squares over the whole record) carries {:.0} % of the AV at τ = {:.4} s: it adds ω²τ²/2 (AD slope +1, a rate ramp R); if it is warm-up or temperature, detrend or fit a DR term (a random walk can look like a trend over one record)",
            tr.slope_per_s,
            100.0 * tr.share_longest.min(1.0),
            tr.tau_longest_s
        ));
    }
    Ok(DataQuality {
        n: t,
        rate_hz,
        spikes,
        spike_period_s,
        level_shifts,
        trend,
        findings,
    })
}

/// A share as a percentage: "33.1 %", "< 0.1 %".
fn percent(share: f64) -> String {
    if share < 1e-3 {
        "< 0.1 %".to_string()
    } else {
        format!("{:.1} %", 100.0 * share.min(1.0))
    }
}

/// At most 8 times, then "…".
fn times(ts: impl Iterator<Item = f64>) -> String {
    let v: Vec<f64> = ts.collect();
    let mut s: Vec<String> = v.iter().take(8).map(|t| format!("{t:.3}")).collect();
    if v.len() > 8 {
        s.push(format!("… ({} more)", v.len() - 8));
    }
    s.join(", ")
}

/// A robust scale of `v`: 1.4826·MAD about the median, or 1.2533·(mean absolute deviation)
/// when that is larger (quantized data often have a MAD of zero); on at most 2^20 values taken
/// at a fixed stride.
fn robust_scale(n: usize, v: impl Fn(usize) -> f64) -> f64 {
    let stride = n.div_ceil(1 << 20).max(1);
    // the values at 0, stride, 2·stride, … only (not every value, then a subsample)
    let mut s: Vec<f64> = (0..n).step_by(stride).map(v).collect();
    if s.is_empty() {
        return 0.0;
    }
    let mid = s.len() / 2;
    let med = *s.select_nth_unstable_by(mid, f64::total_cmp).1;
    let mean_abs = s.iter().map(|x| (x - med).abs()).sum::<f64>() / s.len() as f64;
    s.iter_mut().for_each(|x| *x = (*x - med).abs());
    let mad = *s.select_nth_unstable_by(mid, f64::total_cmp).1;
    (1.4826 * mad).max(1.2533 * mean_abs)
}

fn find_spikes(x: &[f64], rate_hz: f64, z: f64) -> Vec<Spike> {
    let t = x.len();
    let e = |i: usize| x[i] - 0.5 * (x[i - 1] + x[i + 1]);
    let scale = robust_scale(t - 2, |k| e(k + 1));
    if scale.is_nan() || scale <= 0.0 {
        return Vec::new();
    }
    let mut out = Vec::new();
    let lim = z * scale;
    let mut check = |i: usize| {
        let a = e(i).abs();
        if a <= lim {
            return;
        }
        if a >= 1.5 * e(i - 1).abs().max(e(i + 1).abs()) {
            out.push(Spike {
                index: i,
                time_s: i as f64 / rate_hz,
                excess: e(i),
                z: a / scale,
            });
        }
    };
    // both neighbours' e must exist: samples 0, 1, T−2 and T−1 are not judged. Blocks of
    // 64 samples are screened first with branch-free counts in 8 lanes (vectorized); the few
    // blocks holding a candidate are then checked sample by sample, as the rest is
    const B: usize = 64;
    let mut i = 2;
    while i + B <= t - 2 {
        if beyond_in_block(&x[i - 1..i + B + 1], lim) {
            (i..i + B).for_each(&mut check);
        }
        i += B;
    }
    (i..t - 2).for_each(&mut check);
    out
}

/// Whether some |x_i − (x_{i−1} + x_{i+1})/2| > `lim` for the interior samples of `w`.
fn beyond_in_block(w: &[f64], lim: f64) -> bool {
    let mut acc = [0.0f64; 8];
    for (c, ch) in w[1..w.len() - 1].chunks(8).enumerate() {
        for (l, &v) in ch.iter().enumerate() {
            let k = 8 * c + l + 1;
            let a = (v - 0.5 * (w[k - 1] + w[k + 1])).abs();
            acc[l] += if a > lim { 1.0 } else { 0.0 };
        }
    }
    acc.iter().sum::<f64>() > 0.0
}

/// Spacing of ≥ 3 spikes whose spacings agree within 2 % of their median.
fn period(spikes: &[Spike]) -> Option<f64> {
    if spikes.len() < 3 {
        return None;
    }
    let mut d: Vec<f64> = spikes
        .windows(2)
        .map(|w| w[1].time_s - w[0].time_s)
        .collect();
    d.sort_by(f64::total_cmp);
    let med = d[d.len() / 2];
    (med > 0.0 && d.iter().all(|x| (x - med).abs() <= 0.02 * med)).then_some(med)
}

fn find_shifts(
    x: &[f64],
    spikes: &[Spike],
    rate_hz: f64,
    opts: &QualityOptions,
) -> Vec<LevelShift> {
    let t = x.len();
    let nb = opts.blocks.min(t / 16).max(8);
    let len = t / nb;
    // block means, spikes replaced by their neighbours' mean
    let mut mu: Vec<f64> = (0..nb)
        .map(|b| x[b * len..(b + 1) * len].iter().sum::<f64>() / len as f64)
        .collect();
    for s in spikes {
        let b = s.index / len;
        if b < nb {
            mu[b] -= s.excess / len as f64;
        }
    }
    const W: usize = 4;
    if nb < 2 * W + 2 {
        return Vec::new();
    }
    // D_b: mean of blocks b+1..=b+W minus mean of blocks b−W+1..=b, for b = W−1 .. nb−W−1
    let d: Vec<f64> = (W - 1..nb - W)
        .map(|b| {
            let after: f64 = mu[b + 1..=b + W].iter().sum();
            let before: f64 = mu[b + 1 - W..=b].iter().sum();
            (after - before) / W as f64
        })
        .collect();
    let mut sorted = d.clone();
    let mid = sorted.len() / 2;
    let med = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
    let scale = robust_scale(d.len(), |k| d[k]);
    if scale.is_nan() || scale <= 0.0 {
        return Vec::new();
    }
    let zs: Vec<f64> = d.iter().map(|v| (v - med).abs() / scale).collect();
    let mut out = Vec::new();
    for k in 0..zs.len() {
        let lo = k.saturating_sub(W);
        let hi = (k + W + 1).min(zs.len());
        let is_max = (lo..hi).all(|j| zs[j] < zs[k] || (zs[j] == zs[k] && j >= k));
        if zs[k] <= opts.shift_z || !is_max {
            continue;
        }
        let b = k + W - 1; // the boundary after block b
        // locate by the largest CUSUM over blocks b−1 ..= b+2 (the step lies in b or b+1)
        let start = b.saturating_sub(1) * len;
        let end = ((b + 3) * len).min(t);
        let seg = &x[start..end];
        let total: f64 = seg.iter().sum();
        let n = seg.len() as f64;
        let (mut acc, mut best, mut at) = (0.0, 0.0, start + 1);
        for (i, v) in seg.iter().enumerate().take(seg.len() - 1) {
            acc += v;
            let k1 = (i + 1) as f64;
            let c = (acc - k1 / n * total).abs() / (k1 * (n - k1)).sqrt();
            if c > best {
                best = c;
                at = start + i + 1;
            }
        }
        // size: the means of W blocks' worth of samples after and before the located sample
        // (spikes taken out), less the background drift per boundary (the median D)
        let mean_of = |r: std::ops::Range<usize>| {
            let n = r.len() as f64;
            let s: f64 = x[r.clone()].iter().sum::<f64>()
                - spikes
                    .iter()
                    .filter(|s| r.contains(&s.index))
                    .map(|s| s.excess)
                    .sum::<f64>();
            s / n
        };
        let span = W * len;
        let size = mean_of(at..(at + span).min(t)) - mean_of(at.saturating_sub(span)..at) - med;
        out.push(LevelShift {
            index: at,
            time_s: at as f64 / rate_hz,
            size,
            z: zs[k],
        });
    }
    out
}

/// The least-squares slope and its shares of the AV at two scales `(m, AV̂(m))`: returns the
/// share at the first and the trend with the share at the second.
fn trend(x: &[f64], rate_hz: f64, at: [(u64, f64); 2]) -> Option<(f64, Trend)> {
    let n = x.len() as f64;
    let ibar = (n - 1.0) / 2.0;
    let xbar = x.iter().sum::<f64>() / n;
    let sxy: f64 = x
        .iter()
        .enumerate()
        .map(|(i, v)| (i as f64 - ibar) * (v - xbar))
        .sum();
    let sxx = n * (n * n - 1.0) / 12.0;
    let omega = sxy / sxx; // per sample
    let share = |(m, av): (u64, f64)| {
        if av > 0.0 {
            omega * omega * (m as f64).powi(2) / 2.0 / av
        } else {
            0.0
        }
    };
    Some((
        share(at[0]),
        Trend {
            slope_per_s: omega * rate_hz,
            share_longest: share(at[1]),
            tau_longest_s: at[1].0 as f64 / rate_hz,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    fn wn(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..n).map(|_| StandardNormal.sample(&mut rng)).collect()
    }

    /// The block-screened spike search finds what a plain loop over every sample finds:
    /// spikes at the first and last judged samples, on both sides of block boundaries, two in
    /// one block, and in the tail after the last whole block.
    #[test]
    fn screened_spike_search_equals_the_plain_loop() {
        let n = 10_000 + 37;
        let mut x = wn(n, 9);
        // blocks start at 2, 66, 130, …: 64 and 67 straddle a boundary, 200 and 205 share one
        for &i in &[2usize, 64, 67, 129, 200, 205, 5000, n - 40, n - 3] {
            x[i] += if i % 2 == 0 { 25.0 } else { -30.0 };
        }
        let got = find_spikes(&x, 50.0, 10.0);
        let e = |i: usize| x[i] - 0.5 * (x[i - 1] + x[i + 1]);
        let scale = robust_scale(n - 2, |k| e(k + 1));
        let want: Vec<usize> = (2..n - 2)
            .filter(|&i| {
                let a = e(i).abs();
                a > 10.0 * scale && a >= 1.5 * e(i - 1).abs().max(e(i + 1).abs())
            })
            .collect();
        assert_eq!(got.iter().map(|s| s.index).collect::<Vec<_>>(), want);
        assert!(
            want.contains(&2) && want.contains(&(n - 3)) && want.len() >= 8,
            "{want:?}"
        );
    }

    /// The AV read from a dyadic chi-square curve gives the same result, bit for bit, as the
    /// AV the pass computes at its three scales, in memory and (from 2^22 samples) with the
    /// streamed kernel; a spike and a trend make the findings depend on those AV values.
    #[test]
    fn a_given_classical_curve_gives_the_same_result() {
        for n in [50_000usize, (1 << 22) + 12_345] {
            let mut x = wn(n, 3);
            for (i, v) in x.iter_mut().enumerate() {
                *v += 2e-5 * i as f64;
            }
            x[n / 3] += 40.0;
            let av = crate::allan_variance(&x, 100.0, &AvarConfig::default()).unwrap();
            let opts = QualityOptions::default();
            let own = data_quality(&x, 100.0, &opts).unwrap();
            assert!(
                own.trend.is_some() && own.spikes.len() == 1,
                "{:?}",
                own.findings
            );
            assert_eq!(data_quality_with(&x, 100.0, &opts, Some(&av)).unwrap(), own);
            // the curve is read: a doctored AV at the longest scale changes the trend's share
            let mut doctored = av.clone();
            doctored.points.last_mut().unwrap().avar *= 4.0;
            assert_ne!(
                data_quality_with(&x, 100.0, &opts, Some(&doctored)).unwrap(),
                own
            );
            // a curve of other samples is not used
            let other = crate::allan_variance(&x[..n - 1], 100.0, &AvarConfig::default()).unwrap();
            assert_eq!(
                data_quality_with(&x, 100.0, &opts, Some(&other)).unwrap(),
                own
            );
        }
    }

    #[test]
    fn clean_white_noise_and_random_walk_have_no_findings() {
        for seed in 0..5 {
            let x = wn(200_000, seed);
            let q = data_quality(&x, 100.0, &QualityOptions::default()).unwrap();
            assert!(q.is_clean(), "seed {seed}: {:?}", q.findings);
            // white noise + a random walk whose AV dominates the long scales
            let mut acc = 0.0;
            let y: Vec<f64> = wn(200_000, 100 + seed)
                .iter()
                .zip(&x)
                .map(|(w, v)| {
                    acc += 1e-3 * w;
                    v + acc
                })
                .collect();
            let q = data_quality(&y, 100.0, &QualityOptions::default()).unwrap();
            assert!(
                q.spikes.is_empty() && q.level_shifts.is_empty(),
                "{:?}",
                q.findings
            );
        }
    }

    #[test]
    fn periodic_spikes_are_found_with_their_period() {
        let mut x = wn(200_000, 7);
        for i in (2500..200_000).step_by(5000) {
            x[i] += 50.0;
        }
        let q = data_quality(&x, 100.0, &QualityOptions::default()).unwrap();
        assert_eq!(q.spikes.len(), 40);
        assert_eq!(q.spikes[0].index, 2500);
        assert!((q.spike_period_s.unwrap() - 50.0).abs() < 1e-9);
        assert!(q.findings[0].contains("40 spikes") && q.findings[0].contains("periodic every 50"));
        // the predicted share A²/(2(T−3)) / AV(2) at m = 2, against the AV without the spikes
        assert!(
            q.level_shifts.is_empty() && q.trend.is_none(),
            "{:?}",
            q.findings
        );
    }

    #[test]
    fn a_level_shift_is_located_to_the_sample_and_sized() {
        let mut x = wn(200_000, 8);
        for v in &mut x[123_457..] {
            *v += 4.0;
        }
        let q = data_quality(&x, 100.0, &QualityOptions::default()).unwrap();
        assert!(q.spikes.is_empty(), "{:?}", q.findings);
        assert_eq!(q.level_shifts.len(), 1, "{:?}", q.findings);
        let s = &q.level_shifts[0];
        // a step of 4 SDs is located within a few samples; the size within 4 block SEs
        assert!((s.index as i64 - 123_457).abs() <= 3, "{}", s.index);
        assert!(
            (s.size - 4.0).abs() < 4.0 * (2.0 / (4.0 * 781.0_f64)).sqrt(),
            "{}",
            s.size
        );
    }

    #[test]
    fn a_dominant_trend_is_reported() {
        let x: Vec<f64> = wn(100_000, 9)
            .iter()
            .enumerate()
            .map(|(i, v)| v + 1e-4 * i as f64)
            .collect();
        let q = data_quality(&x, 100.0, &QualityOptions::default()).unwrap();
        let tr = q.trend.as_ref().expect("trend");
        // slope 1e-4 per sample = 1e-2 per s; its LS standard error is 1/sqrt(T³/12) per sample
        let se = (12.0 / 1e15_f64).sqrt() * 100.0;
        assert!(
            (tr.slope_per_s - 1e-2).abs() < 5.0 * se,
            "{}",
            tr.slope_per_s
        );
        assert!(q.level_shifts.is_empty(), "{:?}", q.findings);
    }

    #[test]
    fn quantized_data_do_not_raise_false_spikes() {
        // white noise rounded to a step of 2 SDs: most e_i are 0, the MAD is 0
        let x: Vec<f64> = wn(100_000, 10)
            .iter()
            .map(|v| (v / 2.0).round() * 2.0)
            .collect();
        let q = data_quality(&x, 100.0, &QualityOptions::default()).unwrap();
        assert!(q.is_clean(), "{:?}", q.findings);
    }
}
