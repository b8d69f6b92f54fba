//! Sources of samples for the streamed Allan variance ([`allan_variance_source`]).
//!
//! A [`SampleSource`] is a series that the estimator reads by position and whose samples need
//! not all be resident at once: the kernel reads the samples of each near-scale job (a few
//! tens of MB) and, for the far scales, the lagged chunks of each residue class, and tells the
//! source through [`SampleSource::release`] when it is done with a range. A memory-mapped file
//! (as the `imunoise` crate provides) then drops the resident pages of that range, so that the
//! process holds a bounded window of the file instead of all of it; an in-memory slice
//! ([`SliceSource`]) ignores the hint.
//!
//! This crate does no I/O: file-backed sources live in the `imunoise` crate.
//!
//! ```
//! use avar::source::{allan_variance_source, SliceSource};
//! use avar::{allan_variance, AvarConfig, CiMethod};
//! let x: Vec<f64> = (0..5000).map(|i| ((i * 7919) % 101) as f64 * 1e-3).collect();
//! let cfg = AvarConfig { ci: CiMethod::None, ..Default::default() };
//! let a = allan_variance(&x, 100.0, &cfg).unwrap();
//! let b = allan_variance_source(&SliceSource(&x), 100.0, &cfg).unwrap();
//! assert_eq!(a, b);
//! ```

pub(crate) mod io;

use crate::config::{AvarConfig, CiMethod, Estimator, InputKind};
use crate::error::AvarError;
use crate::result::AllanVariance;
use crate::{Cumulative, check_len, finish, kernel, range, validate_rate_alpha};
pub use io::{SampleSource, SampleWindow, SliceSource};
use std::borrow::Cow;

/// Whether [`allan_variance_source`] streams a series of `t` samples with `config` (holding
/// no series-sized buffer, releasing the source's pages as it goes), rather than running the
/// in-memory estimator on the source's samples: rate input, the overlapping estimator, no
/// confidence interval or the chi-square one, and at least 2^22 samples (below that the
/// buffered kernel is faster and its buffer small). The Gaussian interval needs the whole
/// cumulative sum (8 bytes per sample).
///
/// ```
/// use avar::{AvarConfig, CiMethod};
/// use avar::source::streams;
/// let no_ci = AvarConfig { ci: CiMethod::None, ..Default::default() };
/// assert!(streams(1 << 22, &no_ci));
/// assert!(streams(1 << 22, &AvarConfig::default())); // chi-square
/// assert!(!streams(1 << 21, &no_ci));
/// let gaussian = AvarConfig { ci: CiMethod::Gaussian, ..Default::default() };
/// assert!(!streams(1 << 22, &gaussian));
/// ```
pub fn streams(t: usize, config: &AvarConfig) -> bool {
    matches!(config.input, InputKind::Rate)
        && matches!(config.estimator, Estimator::Overlapping)
        && matches!(config.ci, CiMethod::None | CiMethod::ChiSquare)
        && t >= kernel::streamed::STREAM_MIN_T
}

/// The Allan variance of the samples of `source`, bit-identical to [`crate::allan_variance`]
/// on the same samples (same rate in Hz, same configuration) for any thread count.
///
/// When [`streams`] holds, the estimate is streamed: memory beyond the source is the
/// checkpoints of the cumulative sum (16 bytes per 128 samples once the near scales are done,
/// a few MiB per thread before) and per-thread chunk buffers and windows, and the source is
/// told which ranges it may release (a memory-mapped file then keeps a bounded window
/// resident). The chi-square interval then reads the source three more times (its noise
/// identification from checkpoints of 16 bytes per 64 samples and a 16 MiB window of the
/// cumulative sum per thread, see the `ci_stream` module). Otherwise the in-memory estimator
/// runs on `source.samples()` (with the Gaussian interval it allocates the series-sized
/// cumulative sum, 8 bytes per sample). Series of extreme magnitude whose AV would leave the range of f64 are estimated
/// on a rescaled in-memory copy, as by [`crate::allan_variance`].
///
/// ```
/// use avar::source::{allan_variance_source, SliceSource};
/// use avar::{AvarConfig, CiMethod, Scales};
/// let x = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![1]), ci: CiMethod::None, ..Default::default() };
/// let av = allan_variance_source(&SliceSource(&x), 1.0, &cfg).unwrap();
/// assert_eq!(av.points[0].avar, 0.5);
/// ```
pub fn allan_variance_source<S: SampleSource + ?Sized>(
    source: &S,
    rate_hz: f64,
    config: &AvarConfig,
) -> Result<AllanVariance, AvarError> {
    let data = source.samples();
    if !streams(data.len(), config) {
        return crate::allan_variance(data, rate_hz, config);
    }
    validate_rate_alpha(rate_hz, config.alpha)?;
    let release = |lo: usize, hi: usize| source.release(lo, hi);
    let windows = || source.window();
    let io = io::Io {
        release: &release,
        windows: &windows,
    };
    let first = streamed(data, rate_hz, config, &io);
    if !range::suspicious(first.as_ref().map(|a| &a.points[..])) {
        return first;
    }
    // as allan_variance_with: magnitudes out of the ordinary go through a rescaled copy
    let Some(e) = range::rescale_exponent(data) else {
        return first;
    };
    let scaled = range::scaled_copy(data, e);
    let mut av = streamed(&scaled, rate_hz, config, &io::Io::NONE)?;
    av.mean = range::ldexp(av.mean, e);
    range::scale_back(&mut av.points, e)?;
    Ok(av)
}

/// The streamed estimate, releasing as it goes: the sums of the streamed kernel, then (for
/// the chi-square interval) the noise identification from checkpoints and windows of the
/// cumulative sum ([`crate::ci_stream`]), the same values as the in-memory path's.
pub(crate) fn streamed(
    data: &[f64],
    rate_hz: f64,
    config: &AvarConfig,
    io: &io::Io<'_>,
) -> Result<AllanVariance, AvarError> {
    check_len(data.len(), data.len())?;
    let t = data.len();
    let ms = config.scales.cluster_sizes(t)?;
    let (sums, mean) = kernel::streamed::overlapping_sums_stream_io(data, &ms, io)?;
    let cum = Cumulative {
        c: Cow::Borrowed(&[]),
        factor: 1.0,
        mean,
        t,
    };
    let bare = AvarConfig {
        ci: CiMethod::None,
        ..config.clone()
    };
    let mut av = finish(cum, rate_hz, &bare, &ms, &sums)?;
    if config.ci == CiMethod::ChiSquare {
        let ids = crate::ci_stream::identify_streamed(data, &ms, io.release)?;
        crate::ci::apply_chi_square(&ids, t, config, &mut av.points);
        av.ci = config.ci;
    }
    Ok(av)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Scales;
    use std::sync::Mutex;

    /// A slice source that records the released ranges.
    struct Recording<'a> {
        x: &'a [f64],
        released: Mutex<Vec<(usize, usize)>>,
    }

    impl SampleSource for Recording<'_> {
        fn samples(&self) -> &[f64] {
            self.x
        }
        fn release(&self, lo: usize, hi: usize) {
            self.released.lock().unwrap().push((lo, hi));
        }
    }

    fn series(n: usize) -> Vec<f64> {
        crate::kernel::tests::series(n, 2.5)
    }

    /// The streamed source path gives exactly the in-memory result (both thread counts), and
    /// it releases every sample it read: the released ranges cover [0, T).
    #[test]
    fn source_matches_in_memory_and_releases_everything() {
        let n = (1 << 22) + 54_321;
        let x = series(n);
        let cfg = AvarConfig {
            ci: CiMethod::None,
            scales: Scales::Dyadic,
            ..Default::default()
        };
        let mem = crate::allan_variance(&x, 200.0, &cfg).unwrap();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let src = Recording {
                x: &x,
                released: Mutex::new(Vec::new()),
            };
            let av = pool
                .install(|| allan_variance_source(&src, 200.0, &cfg))
                .unwrap();
            assert_eq!(av, mem, "threads {threads}");
            let mut r = src.released.into_inner().unwrap();
            r.sort_unstable();
            let mut covered = 0;
            for (lo, hi) in r {
                assert!(lo <= covered, "gap before {lo}");
                covered = covered.max(hi);
            }
            assert!(covered >= n);
        }
    }

    /// A window that holds NaN wherever it was not filled since the last clear: any read
    /// the far walk does not announce poisons the sums.
    struct Poisoned<'a> {
        x: &'a [f64],
        buf: Vec<f64>,
        filled: Vec<(usize, usize)>,
    }

    impl SampleWindow for Poisoned<'_> {
        fn fill(&mut self, lo: usize, hi: usize) {
            let hi = hi.min(self.x.len());
            if lo < hi {
                self.buf[lo..hi].copy_from_slice(&self.x[lo..hi]);
                self.filled.push((lo, hi));
            }
        }
        fn view(&self) -> &[f64] {
            &self.buf
        }
        fn clear(&mut self) {
            for (lo, hi) in self.filled.drain(..) {
                self.buf[lo..hi].fill(f64::NAN);
            }
        }
    }

    struct WindowedSource<'a>(&'a [f64]);

    impl SampleSource for WindowedSource<'_> {
        fn samples(&self) -> &[f64] {
            self.0
        }
        fn window(&self) -> Option<Box<dyn SampleWindow + '_>> {
            Some(Box::new(Poisoned {
                x: self.0,
                buf: vec![f64::NAN; self.0.len()],
                filled: Vec::new(),
            }))
        }
    }

    /// The far walk through (poisoned) windows: every sample it reads was filled, and the
    /// result is the in-memory one bit for bit, for dyadic and odd far scales and both thread
    /// counts.
    #[test]
    fn windows_are_filled_where_read() {
        let n = (1 << 23) + 4321;
        let x = series(n);
        for scales in [
            Scales::Dyadic,
            Scales::Explicit(vec![5, 600_001, 1 << 20, 1_500_000, 3 << 20, 4_000_000]),
        ] {
            let cfg = AvarConfig {
                ci: CiMethod::None,
                scales,
                ..Default::default()
            };
            let mem = crate::allan_variance(&x, 1.0, &cfg).unwrap();
            for threads in [1, 2] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let av = pool
                    .install(|| allan_variance_source(&WindowedSource(&x), 1.0, &cfg))
                    .unwrap();
                assert_eq!(av, mem, "threads {threads}");
            }
        }
    }

    /// Scales with both near and far members, and a CI (the in-memory fallback): identical.
    #[test]
    fn explicit_scales_and_ci_match() {
        let n = (1 << 22) + 7;
        let x = series(n);
        for ci in [CiMethod::None, CiMethod::ChiSquare] {
            let cfg = AvarConfig {
                ci,
                scales: Scales::Explicit(vec![1, 3, 1000, 70_000, 600_001, 1 << 20, 2_000_000]),
                ..Default::default()
            };
            let mem = crate::allan_variance(&x, 1.0, &cfg).unwrap();
            let src = allan_variance_source(&SliceSource(&x), 1.0, &cfg).unwrap();
            assert_eq!(src, mem);
        }
    }
}
