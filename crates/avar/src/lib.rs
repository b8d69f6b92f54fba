//! # avar — the maximum-overlapping Allan variance
//!
//! The Allan variance (AV) of a series X_1..X_T sampled at `rate` Hz, at cluster size `m`
//! (samples) and averaging time τ = m / rate (seconds), estimated exactly as the book's
//! eq. 4.2 (maximum-overlapping AV, MOAV):
//!
//! ```text
//! AV(m) = 1 / (2 (T − 2m + 1)) · Σ_{k=2m}^{T} (X̄_k − X̄_{k−m})²,   X̄_k = mean of X_{k−m+1..k}
//! ```
//!
//! * Scales: the book's dyadic m = 2^j (default), m = 1, octave/decade/log-spaced grids, an
//!   explicit list, every m, and the real-j scales of Remark 4.1 ([`Scales`]).
//! * The non-overlapping estimator beside it ([`Estimator`]); rate or angle input ([`InputKind`]).
//! * Offset-proof: the series is centred with a pivot and its exact mean, then accumulated with
//!   compensated running offsets, so AV(X + c) = AV(X) to ~1e-12 relative even for c = 1e4·std(X).
//! * Vector kernels for AVX-512, AVX2 + FMA and portable code, chosen at run time in one place
//!   ([`simd`]); the environment variable `IMUNOISE_SIMD=scalar|avx2|avx512` caps the level.
//!   The MOAV kernels give the same bits at every level.
//! * Parallel over a fixed grid (rayon) with bit-identical results for any thread count; peak
//!   extra memory is one series-sized f64 buffer (none for angle input). Rate series of 2^22
//!   samples or more without a CI are streamed instead: no series-sized buffer, only checkpoints
//!   of the cumulative sum every 64 samples (at most about T/2 bytes); all dyadic scales of 10^8
//!   samples take about 0.2 s on two cores.
//! * Series that do not sit in memory: [`allan_variance_source`] reads a [`SampleSource`]
//!   by position (a memory-mapped file in the `imunoise` crate), tells it which ranges it may
//!   release, and reads the scattered chunks of the far scales through per-thread windows, so
//!   that without a CI a file of any length is estimated in bounded memory, bit-identically.
//! * A robust AV (Tukey biweight M-estimator of scale per scale, the RGMWM's robust WV):
//!   [`robust::robust_allan_variance`].
//! * Confidence intervals ([`CiMethod`]): chi-square with EDF (default), Gaussian from the
//!   book's Lemma 4.4, and the Haar wavelet variance with the `wv` η interval
//!   ([`haar_wavelet_variance`]).
//! * The rest of the frequency-stability family in [`stability`]: modified Allan (MDEV), time
//!   (TDEV), Hadamard (HDEV, OHDEV) and total (TOTDEV) deviations with Stable32's noise
//!   identification and EDFs, each with a plain reference function.
//!
//! ```
//! use avar::{allan_variance, AvarConfig};
//! // a deterministic ±1 square wave of period 2: AV(m) = 0 for even m
//! let x: Vec<f64> = (0..64).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
//! let av = allan_variance(&x, 100.0, &AvarConfig::default()).unwrap();
//! assert_eq!(av.points[0].m, 2);
//! assert_eq!(av.points[0].tau, 0.02);
//! assert!(av.points[0].avar.abs() < 1e-30);
//! ```

/// Defines `fn $name(args) -> ret` running `$body` (an `#[inline(always)]` function of the same
/// signature, written as plain lane loops) compiled for AVX-512F or AVX2 as [`simd::level`]
/// says (the CPU's level under the `IMUNOISE_SIMD` cap), else as it is. The body's operations
/// and their order are fixed by its code (no FMA contraction), so every instruction set gives
/// the same bits.
macro_rules! simd_dispatch {
    ($(#[$attr:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty => $body:ident) => {
        $(#[$attr])*
        $vis fn $name($($arg: $ty),*) -> $ret {
            let level = $crate::simd::level();
            $crate::simd::note(level);
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f")]
                fn avx512($($arg: $ty),*) -> $ret {
                    $body($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                fn avx2($($arg: $ty),*) -> $ret {
                    $body($($arg),*)
                }
                match level {
                    // SAFETY: `level()` never exceeds what the CPU has (AVX-512F).
                    $crate::simd::SimdLevel::Avx512 => return unsafe { avx512($($arg),*) },
                    // SAFETY: as above (AVX2).
                    $crate::simd::SimdLevel::Avx2 => return unsafe { avx2($($arg),*) },
                    $crate::simd::SimdLevel::Scalar => {}
                }
            }
            $body($($arg),*)
        }
    };
}

pub mod ci;
mod ci_stream;
pub mod config;
pub mod error;
mod haar;
mod kernel;
pub mod online;
pub mod quality;
mod range;
pub mod result;
pub mod robust;
pub mod simd;
pub mod source;
pub mod stability;

use std::borrow::Cow;

pub use config::{AvarConfig, CiMethod, Estimator, InputKind, Scales};
pub use error::AvarError;
pub use haar::{HaarWaveletVariance, WvPoint, haar_wavelet_variance};
pub use online::{Online, OnlineChannels};
pub use result::{AllanVariance, AvarPoint, Slope};
pub use source::{SampleSource, SliceSource, allan_variance_source};

/// Minimum number of rate samples accepted.
pub const MIN_SAMPLES: usize = 4;

/// The cumulative representation every estimator works on: `c` has T + 1 entries and the rate
/// sample X_k (k = 1..T) equals (c[k] − c[k−1])·`factor` + (a constant).
pub(crate) struct Cumulative<'a> {
    pub(crate) c: Cow<'a, [f64]>,
    pub(crate) factor: f64,
    pub(crate) mean: f64,
    /// Number of rate samples T (`c` may be empty when no CI needs it).
    pub(crate) t: usize,
}

impl Cumulative<'_> {
    /// Number of rate samples T.
    pub(crate) fn t(&self) -> usize {
        self.t
    }
}

pub(crate) fn validate_rate_alpha(rate_hz: f64, alpha: f64) -> Result<(), AvarError> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(AvarError::InvalidRate(rate_hz));
    }
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(AvarError::InvalidAlpha(alpha));
    }
    Ok(())
}

/// Errors for an empty input (`len` values) or for one holding fewer than [`MIN_SAMPLES`]
/// rate samples (`got`: `len` for rate input, `len − 1` for angle input).
pub(crate) fn check_len(len: usize, got: usize) -> Result<(), AvarError> {
    if len == 0 {
        return Err(AvarError::Empty);
    }
    if got < MIN_SAMPLES {
        return Err(AvarError::TooShort {
            got,
            need: MIN_SAMPLES,
        });
    }
    Ok(())
}

/// Validates the data and builds the cumulative representation.
pub(crate) fn cumulative<'a>(
    data: &'a [f64],
    rate_hz: f64,
    input: InputKind,
    scratch: &'a mut Vec<f64>,
) -> Result<Cumulative<'a>, AvarError> {
    match input {
        InputKind::Rate => {
            check_len(data.len(), data.len())?;
            let mean = kernel::cumsum::centred_prefix_into(data, scratch)?;
            Ok(Cumulative {
                c: Cow::Borrowed(&scratch[..]),
                factor: 1.0,
                mean,
                t: data.len(),
            })
        }
        InputKind::Angle => {
            // T + 1 angle samples hold T rate samples.
            check_len(data.len(), data.len().saturating_sub(1))?;
            kernel::cumsum::check_finite(data)?;
            let t = data.len() - 1;
            let mean = (data[t] - data[0]) * rate_hz / t as f64;
            if !mean.is_finite() {
                return Err(AvarError::Overflow);
            }
            Ok(Cumulative {
                c: Cow::Borrowed(data),
                factor: rate_hz,
                mean,
                t,
            })
        }
    }
}

/// Allan variance of one series at the configured scales.
///
/// * `data`: rate samples (or angle samples, see [`InputKind`]), any finite values; a
///   memory-mapped slice works as is (the function only reads it).
/// * `rate_hz`: sampling rate (Hz, finite, > 0); τ = m / rate_hz.
/// * `config`: scales, estimator, input kind, CI family and level.
///
/// Memory: rate series of at least 2^22 samples with the overlapping estimator and no CI or
/// the chi-square CI allocate no series-sized buffer (checkpoints of the cumulative sum, 16
/// bytes per 64 samples, and per-thread windows); otherwise the cumulative sum takes 8 bytes
/// per sample.
///
/// Errors: empty input, fewer than [`MIN_SAMPLES`] rate samples, a NaN/inf sample (with its
/// index), a bad rate or alpha, scales that do not fit (2m > T), an empty grid.
///
/// ```
/// use avar::{allan_variance, AvarConfig, CiMethod, Scales};
/// let x = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![1, 2]), ci: CiMethod::None, ..Default::default() };
/// let av = allan_variance(&x, 1.0, &cfg).unwrap();
/// assert_eq!(av.points[0].avar, 0.5); // (±1)² / 2
/// assert_eq!(av.points[1].avar, 0.0); // pairs average to 1/2 everywhere
/// assert_eq!(av.points[1].n_terms, 5); // T − 2m + 1
/// ```
pub fn allan_variance(
    data: &[f64],
    rate_hz: f64,
    config: &AvarConfig,
) -> Result<AllanVariance, AvarError> {
    allan_variance_with(data, rate_hz, config, &mut Vec::new())
}

/// [`allan_variance`] with a caller-provided buffer for the cumulative sums (reused across calls).
///
/// Samples of huge or tiny magnitude are estimated on an exact power-of-two rescaled copy (see
/// the `range` module): the result is the same as the unscaled estimate would be in exact
/// range, and an AV beyond the range of f64 is an error instead of an infinity or a zero.
fn allan_variance_with(
    data: &[f64],
    rate_hz: f64,
    config: &AvarConfig,
    scratch: &mut Vec<f64>,
) -> Result<AllanVariance, AvarError> {
    validate_rate_alpha(rate_hz, config.alpha)?;
    let first = estimate(data, rate_hz, config, scratch);
    if !range::suspicious(first.as_ref().map(|a| &a.points[..])) {
        return first;
    }
    let Some(e) = range::rescale_exponent(data) else {
        // magnitudes are ordinary: the values are what they are (e.g. AV = 0 of a square wave)
        return first;
    };
    let scaled = range::scaled_copy(data, e);
    let mut av = estimate(&scaled, rate_hz, config, scratch)?;
    av.mean = range::ldexp(av.mean, e);
    range::scale_back(&mut av.points, e)?;
    Ok(av)
}

/// The estimate itself, on data of ordinary magnitude.
fn estimate(
    data: &[f64],
    rate_hz: f64,
    config: &AvarConfig,
    scratch: &mut Vec<f64>,
) -> Result<AllanVariance, AvarError> {
    if matches!(config.input, InputKind::Rate)
        && matches!(config.estimator, Estimator::Overlapping)
        && data.len() >= kernel::streamed::STREAM_MIN_T
    {
        if matches!(config.ci, CiMethod::None | CiMethod::ChiSquare) {
            // no series-sized buffer: the streamed kernel, and the chi-square interval's
            // noise identification from checkpoints and windows of the cumulative sum
            return source::streamed(data, rate_hz, config, &source::io::Io::NONE);
        }
        // the Gaussian interval needs the cumulative sum; the AV itself comes from the
        // streamed kernel, as without a CI (faster at this length, and more precise at small
        // m: no rounding of a long cumulative sum enters the differences)
        let cum = cumulative(data, rate_hz, config.input, scratch)?;
        let ms = config.scales.cluster_sizes(data.len())?;
        let (sums, mean) = kernel::streamed::overlapping_sums_stream(data, &ms)?;
        return finish(Cumulative { mean, ..cum }, rate_hz, config, &ms, &sums);
    }
    let cum = cumulative(data, rate_hz, config.input, scratch)?;
    let t = cum.t();
    let ms = config.scales.cluster_sizes(t)?;
    let sums = match config.estimator {
        Estimator::Overlapping => kernel::buffered::overlapping_sums(&cum.c, &ms),
        Estimator::NonOverlapping => kernel::buffered::nonoverlapping_sums(&cum.c, &ms),
    };
    finish(cum, rate_hz, config, &ms, &sums)
}

/// Turns the sums of squared second differences into AV points, then applies the CI.
fn finish(
    cum: Cumulative<'_>,
    rate_hz: f64,
    config: &AvarConfig,
    ms: &[u64],
    sums: &[f64],
) -> Result<AllanVariance, AvarError> {
    let t = cum.t();
    let mut points: Vec<AvarPoint> = ms
        .iter()
        .zip(sums)
        .map(|(&m, &s)| {
            let n_terms = n_terms(t, m, config.estimator);
            let scale = cum.factor / m as f64;
            let avar = s * scale * scale / (2.0 * n_terms as f64);
            AvarPoint::bare(m, rate_hz, avar, n_terms)
        })
        .collect();
    ci::apply(&cum, config, &mut points)?;
    Ok(AllanVariance {
        rate_hz,
        n: t,
        estimator: config.estimator,
        input: config.input,
        ci: config.ci,
        alpha: config.alpha,
        mean: cum.mean,
        points,
    })
}

/// Number of squared differences at cluster size m for T rate samples.
pub(crate) fn n_terms(t: usize, m: u64, est: Estimator) -> u64 {
    match est {
        Estimator::Overlapping => t as u64 - 2 * m + 1,
        Estimator::NonOverlapping => t as u64 / m - 1,
    }
}

/// Allan variances of several channels (e.g. the six axes of an IMU) in one call, all at the same
/// rate and configuration. Channels may differ in length. Errors name the channel. Channels are
/// processed one after the other (each in parallel) and share one buffer for the cumulative sums,
/// so at most one series-sized buffer is allocated (and its pages are faulted in only once).
///
/// ```
/// use avar::{allan_variance_channels, AvarConfig};
/// let a: Vec<f64> = (0..100).map(|i| (i % 3) as f64).collect();
/// let b: Vec<f64> = (0..50).map(|i| (i % 5) as f64).collect();
/// let out = allan_variance_channels(&[&a, &b], 10.0, &AvarConfig::default()).unwrap();
/// assert_eq!(out.len(), 2);
/// assert_eq!(out[1].n, 50);
/// ```
pub fn allan_variance_channels(
    channels: &[&[f64]],
    rate_hz: f64,
    config: &AvarConfig,
) -> Result<Vec<AllanVariance>, AvarError> {
    let mut scratch = Vec::new();
    channels
        .iter()
        .enumerate()
        .map(|(i, ch)| {
            allan_variance_with(ch, rate_hz, config, &mut scratch).map_err(|e| AvarError::Channel {
                channel: i,
                source: Box::new(e),
            })
        })
        .collect()
}

/// The control implementation: eq. 4.2 evaluated literally for rate samples, each cluster mean
/// X̄_k summed from scratch (O(T·m) work, O(1) extra memory). Slow; for verification only.
///
/// Returns the MOAV at cluster size `m` (samples) in rate unit².
///
/// ```
/// use avar::{allan_variance, moav_reference, AvarConfig, CiMethod, Scales};
/// let x: Vec<f64> = (0..200).map(|i| ((i * 37) % 11) as f64 - 5.0).collect();
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![7]), ci: CiMethod::None, ..Default::default() };
/// let fast = allan_variance(&x, 1.0, &cfg).unwrap().points[0].avar;
/// let slow = moav_reference(&x, 7).unwrap();
/// assert!((fast - slow).abs() <= 1e-12 * slow);
/// ```
pub fn moav_reference(data: &[f64], m: u64) -> Result<f64, AvarError> {
    check_len(data.len(), data.len())?;
    kernel::cumsum::check_finite(data)?;
    let t = data.len();
    if m == 0 {
        return Err(AvarError::ZeroScale);
    }
    if 2 * m > t as u64 {
        return Err(AvarError::ScaleTooLarge {
            m,
            t,
            max: (t / 2) as u64,
        });
    }
    let m = m as usize;
    // 1-based k = 2m..T  ->  window of X̄_k is data[k-m .. k] (0-based)
    let mean = |k: usize| data[k - m..k].iter().sum::<f64>() / m as f64;
    let mut s = 0.0;
    for k in 2 * m..=t {
        let d = mean(k) - mean(k - m);
        s += d * d;
    }
    Ok(s / (2.0 * (t - 2 * m + 1) as f64))
}
