//! Empirical tools on a series: autocovariance/autocorrelation by FFT and PSD estimates
//! (periodogram, Welch) in the crate's convention (two-sided, unit²/Hz, f in Hz).
//!
//! - [`autocovariance`]: γ̂(h) = (1/N) Σ_{t=1}^{N−h} (x_t − x̄)(x_{t+h} − x̄), h = 0..=H, by a
//!   real FFT zero-padded to a power of two ≥ N + H (no circular wrap-around), so it equals
//!   the direct O(N·H) sum [`autocovariance_direct`] up to rounding; O(N log N). A long series
//!   with few lags (N beyond four blocks of B ≥ H, a power of two ≥ 2048) goes by blocks
//!   instead, one transform of length 2B per block: O(N log H), small transforms that stay in
//!   cache.
//! - [`periodogram`]: P(f_k) = Δt/N |Σ_t (x_t − x̄) e^(−2πi k t/N)|², f_k = k·rate/N.
//! - [`welch`]: segments of length L with a given overlap, each demeaned, windowed (Hann by
//!   default) and normalised by Σw², P = Δt|Σ w_t x_t e^(…)|²/Σw²; the average over
//!   segments. For a process with PSD S the expectation is S convolved with the window's
//!   spectral window, ≈ S(f) for a smooth S.
//!
//! Equivalent degrees of freedom (Percival & Walden 1993, eq. 292b) for K segments shifted
//! by s samples: ν = 2K / (1 + 2 Σ_{j=1}^{K−1} (1 − j/K) ρ_j²), ρ_j = Σ_t w_t w_{t+js} / Σ w_t²
//! (≈ 1.89 K for Hann with 50 % overlap); ν/2 at f = 0 and at the Nyquist frequency. The
//! chi-square CI is [ν P̂/χ²_{1−α/2}(ν), ν P̂/χ²_{α/2}(ν)].

use crate::error::{Result, SpectralError, check_rate};
use realfft::RealFftPlanner;
use realfft::num_complex::Complex;
use statrs::distribution::{ChiSquared, ContinuousCDF};

fn check_series(x: &[f64], min_len: usize) -> Result<()> {
    if x.len() < min_len {
        return Err(SpectralError::TooShort(format!(
            "need at least {min_len} samples, got {}",
            x.len()
        )));
    }
    if let Some((index, &value)) = x.iter().enumerate().find(|(_, v)| !v.is_finite()) {
        return Err(SpectralError::NonFinite { index, value });
    }
    Ok(())
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

fn fft_error(e: impl std::fmt::Display) -> SpectralError {
    SpectralError::InvalidArgument(format!("FFT failed: {e}"))
}

/// Sample autocovariance γ̂(0..=max_lag) (unit², lags in samples) of a series: mean
/// removed, divided by N (the biased, positive semi-definite estimator), by FFT.
/// Needs `max_lag < x.len()`.
///
/// ```
/// use spectral::empirical::{autocovariance, autocovariance_direct};
/// let x: Vec<f64> = (0..500).map(|t| ((t * t) % 17) as f64).collect();
/// let (a, b) = (autocovariance(&x, 40)?, autocovariance_direct(&x, 40)?);
/// for (u, v) in a.iter().zip(&b) {
///     assert!((u - v).abs() <= 1e-12 * b[0]);
/// }
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn autocovariance(x: &[f64], max_lag: usize) -> Result<Vec<f64>> {
    check_series(x, max_lag + 1)?;
    let n = x.len();
    let xm = mean(x);
    let block = max_lag.max(1).next_power_of_two().max(1 << 11);
    if n > 4 * block {
        return autocovariance_blocked(x, xm, max_lag, block);
    }
    let len = (n + max_lag).next_power_of_two().max(2);
    let mut planner = RealFftPlanner::<f64>::new();
    let r2c = planner.plan_fft_forward(len);
    let c2r = planner.plan_fft_inverse(len);
    let mut buf = r2c.make_input_vec();
    for (b, &v) in buf.iter_mut().zip(x) {
        *b = v - xm;
    }
    let mut spec = r2c.make_output_vec();
    r2c.process(&mut buf, &mut spec).map_err(fft_error)?;
    for z in spec.iter_mut() {
        *z = Complex::new(z.norm_sqr(), 0.0);
    }
    let mut out = c2r.make_output_vec();
    c2r.process(&mut spec, &mut out).map_err(fft_error)?;
    let scale = 1.0 / (len as f64 * n as f64);
    Ok(out[..=max_lag].iter().map(|v| v * scale).collect())
}

/// [`autocovariance`] of a long series with few lags (N > 4·`b`, `b` ≥ H a power of two): the
/// series is cut into blocks a_j of B = `b` samples, and Σ_t d_t d_{t+h} = Σ_j Σ_{t∈a_j} d_t
/// d_{t+h} is the lag-h cross-correlation of each block with the pair (a_j, a_{j+1}). With
/// transforms of length 2B the pair fills the whole buffer and the block alone its first
/// half, so no lag 0..=H ≤ B wraps around; and the pair's transform is A_j + (−1)^k A_{j+1}
/// (a shift by half the length), so each block is transformed once: the cross-spectra
/// conj(A_j)·(A_j + (−1)^k A_{j+1}) are summed and one inverse FFT gives all lags. O(N log B)
/// instead of O(N log N), with small FFTs that stay in cache (no series-sized buffer).
fn autocovariance_blocked(x: &[f64], xm: f64, max_lag: usize, b: usize) -> Result<Vec<f64>> {
    let n = x.len();
    let len = 2 * b;
    let mut planner = RealFftPlanner::<f64>::new();
    let r2c = planner.plan_fft_forward(len);
    let c2r = planner.plan_fft_inverse(len);
    let mut buf = r2c.make_input_vec();
    let mut scratch = r2c.make_scratch_vec();
    // the spectrum of block j, zero-padded to 2B
    let mut spectrum = |j: usize, out: &mut [Complex<f64>]| -> Result<()> {
        buf.fill(0.0);
        let (lo, hi) = (j * b, ((j + 1) * b).min(n));
        for (o, &v) in buf.iter_mut().zip(&x[lo..hi]) {
            *o = v - xm;
        }
        r2c.process_with_scratch(&mut buf, out, &mut scratch)
            .map_err(fft_error)
    };
    let mut cur = r2c.make_output_vec();
    let mut next = r2c.make_output_vec();
    let mut acc = vec![Complex::new(0.0, 0.0); cur.len()];
    let blocks = n.div_ceil(b);
    spectrum(0, &mut cur)?;
    for j in 0..blocks {
        if j + 1 < blocks {
            spectrum(j + 1, &mut next)?;
        } else {
            next.fill(Complex::new(0.0, 0.0));
        }
        // (−1)^k: even and odd bins in pairs, then the last bin (k = B, even)
        let pairs = acc
            .chunks_exact_mut(2)
            .zip(cur.chunks_exact(2))
            .zip(next.chunks_exact(2));
        for ((s, a), e) in pairs {
            s[0] += a[0].conj() * (a[0] + e[0]);
            s[1] += a[1].conj() * (a[1] - e[1]);
        }
        acc[b] += cur[b].conj() * (cur[b] + next[b]);
        std::mem::swap(&mut cur, &mut next);
    }
    // the inverse of a real correlation's spectrum: the imaginary parts at 0 and len/2 are
    // rounding only
    acc[0].im = 0.0;
    if let Some(last) = acc.last_mut() {
        last.im = 0.0;
    }
    let mut out = c2r.make_output_vec();
    c2r.process(&mut acc, &mut out).map_err(fft_error)?;
    let scale = 1.0 / (len as f64 * n as f64);
    Ok(out[..=max_lag].iter().map(|v| v * scale).collect())
}

/// The direct O(N·H) sum of the same estimator as [`autocovariance`] (the control).
///
/// ```
/// use spectral::empirical::autocovariance_direct;
/// let g = autocovariance_direct(&[1.0, -1.0, 1.0, -1.0], 1)?;
/// assert_eq!(g, vec![1.0, -0.75]);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn autocovariance_direct(x: &[f64], max_lag: usize) -> Result<Vec<f64>> {
    check_series(x, max_lag + 1)?;
    let n = x.len();
    let xm = mean(x);
    let d: Vec<f64> = x.iter().map(|v| v - xm).collect();
    Ok((0..=max_lag)
        .map(|h| {
            d[..n - h]
                .iter()
                .zip(&d[h..])
                .map(|(a, b)| a * b)
                .sum::<f64>()
                / n as f64
        })
        .collect())
}

/// Sample autocorrelation ρ̂(h) = γ̂(h)/γ̂(0), h = 0..=max_lag (by FFT).
///
/// ```
/// use spectral::empirical::autocorrelation;
/// let r = autocorrelation(&[1.0, 2.0, 3.0, 4.0], 2)?;
/// assert_eq!(r[0], 1.0);
/// assert!(r[1] > 0.0);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn autocorrelation(x: &[f64], max_lag: usize) -> Result<Vec<f64>> {
    let g = autocovariance(x, max_lag)?;
    if g[0] == 0.0 {
        return Err(SpectralError::InvalidArgument(
            "the series is constant: its autocorrelation is undefined".into(),
        ));
    }
    let g0 = g[0];
    Ok(g.into_iter().map(|v| v / g0).collect())
}

/// Data taper of the Welch estimator.
///
/// ```
/// use spectral::empirical::{periodogram, welch, WelchConfig, Window};
/// let x: Vec<f64> = (0..200).map(|t| ((t * 7919) % 101) as f64).collect();
/// // one untapered segment of the whole series is the periodogram
/// let one = WelchConfig { segment_len: x.len(), overlap: 0, window: Window::Rectangular };
/// assert_eq!(welch(&x, 5.0, &one)?, periodogram(&x, 5.0)?);
/// assert_eq!(WelchConfig::default().window, Window::Hann);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Window {
    /// w_t = 1.
    Rectangular,
    /// Hann, periodic form w_t = sin²(π t / L), t = 0..L−1 (the default).
    #[default]
    Hann,
}

impl Window {
    fn weights(self, len: usize) -> Vec<f64> {
        match self {
            Window::Rectangular => vec![1.0; len],
            Window::Hann => (0..len)
                .map(|t| (std::f64::consts::PI * t as f64 / len as f64).sin().powi(2))
                .collect(),
        }
    }
}

/// Settings of [`welch`]: segment length L (samples, ≥ 2), overlap (samples, < L) and
/// window. The default is L = 4096, 50 % overlap, Hann.
///
/// ```
/// use spectral::empirical::{welch, WelchConfig, Window};
/// let d = WelchConfig::default();
/// assert_eq!((d.segment_len, d.overlap, d.window), (4096, 2048, Window::Hann));
/// let x: Vec<f64> = (0..1000).map(|t| ((t * 7919) % 101) as f64).collect();
/// let cfg = WelchConfig { segment_len: 200, overlap: 100, ..d };
/// let est = welch(&x, 50.0, &cfg)?;
/// assert_eq!(est.segments, 9); // (N − L)/(L − overlap) + 1
/// assert_eq!(est.frequencies_hz.len(), 101); // L/2 + 1
/// assert_eq!(est.frequencies_hz[1], 0.25); // rate/L
/// # Ok::<(), spectral::SpectralError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WelchConfig {
    /// Segment length L in samples.
    pub segment_len: usize,
    /// Overlap between consecutive segments in samples (< L).
    pub overlap: usize,
    /// Data taper.
    pub window: Window,
}

impl Default for WelchConfig {
    fn default() -> Self {
        WelchConfig {
            segment_len: 4096,
            overlap: 2048,
            window: Window::Hann,
        }
    }
}

/// A PSD estimate: two-sided density values (unit²/Hz) at frequencies 0 … rate/2 (Hz),
/// with the equivalent degrees of freedom of the interior bins.
///
/// ```
/// use spectral::empirical::periodogram;
/// let x: Vec<f64> = (0..16).map(|t| ((t * 7) % 5) as f64).collect();
/// let p = periodogram(&x, 4.0)?;
/// assert_eq!(p.segments, 1);
/// assert_eq!(p.edf, 2.0); // one segment: ν = 2
/// // f_k = k·rate/N for k = 0..=N/2: 0, 0.25, …, 2 Hz
/// let f: Vec<f64> = (0..=8).map(|k| k as f64 * 0.25).collect();
/// assert_eq!(p.frequencies_hz, f);
/// assert_eq!(p.psd.len(), f.len());
/// assert!(p.psd[0].abs() < 1e-12); // the mean is removed
/// # Ok::<(), spectral::SpectralError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct PsdEstimate {
    /// Frequencies f_k = k·rate/L, k = 0..=L/2, in Hz.
    pub frequencies_hz: Vec<f64>,
    /// Two-sided PSD estimate at each frequency, unit²/Hz (double it for one-sided).
    pub psd: Vec<f64>,
    /// Equivalent degrees of freedom at 0 < f < rate/2 (half of it at 0 and Nyquist).
    pub edf: f64,
    /// Number of segments averaged (1 for the periodogram).
    pub segments: usize,
    /// Whether the segment length is even (then the last bin is the Nyquist frequency).
    even_length: bool,
}

impl PsdEstimate {
    /// EDF of bin `k`: ν, or ν/2 at f = 0 and (for even L) at the Nyquist frequency.
    ///
    /// ```
    /// use spectral::empirical::periodogram;
    /// let x = [1.0, 3.0, -2.0, 0.5, 4.0, -1.0, 2.0, 0.0];
    /// // N = 8: bins 0..=4, bin 4 is the Nyquist frequency
    /// let p = periodogram(&x, 1.0)?;
    /// assert_eq!((p.edf_at(0), p.edf_at(2), p.edf_at(4)), (1.0, 2.0, 1.0));
    /// // N = 7: bins 0..=3, the last (3/7 Hz) lies below the Nyquist frequency
    /// let q = periodogram(&x[..7], 1.0)?;
    /// assert_eq!((q.edf_at(0), q.edf_at(3)), (1.0, 2.0));
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn edf_at(&self, k: usize) -> f64 {
        let last = self.psd.len() - 1;
        if k == 0 || (k == last && self.even_length) {
            0.5 * self.edf
        } else {
            self.edf
        }
    }

    /// Chi-square confidence intervals (lower, upper) at level `level` ∈ (0, 1) for every
    /// bin: [ν P̂/χ²_{1−α/2}(ν), ν P̂/χ²_{α/2}(ν)], α = 1 − level.
    ///
    /// ```
    /// use spectral::empirical::{welch, WelchConfig};
    /// let x: Vec<f64> = (0..20_000).map(|t| ((t * 7919) % 101) as f64 - 50.0).collect();
    /// let est = welch(&x, 10.0, &WelchConfig { segment_len: 256, overlap: 128, ..Default::default() })?;
    /// let ci = est.confidence_intervals(0.95)?;
    /// assert!(ci.iter().zip(&est.psd).all(|((lo, hi), p)| lo <= p && p <= hi));
    /// # Ok::<(), spectral::SpectralError>(())
    /// ```
    pub fn confidence_intervals(&self, level: f64) -> Result<Vec<(f64, f64)>> {
        if !(level > 0.0 && level < 1.0) {
            return Err(SpectralError::InvalidArgument(format!(
                "confidence level must lie in (0, 1), got {level}"
            )));
        }
        let alpha = 1.0 - level;
        let bounds = |nu: f64| -> Result<(f64, f64)> {
            let chi = ChiSquared::new(nu).map_err(|e| {
                SpectralError::InvalidArgument(format!("chi-square with {nu} dof: {e}"))
            })?;
            Ok((
                chi.inverse_cdf(1.0 - alpha / 2.0),
                chi.inverse_cdf(alpha / 2.0),
            ))
        };
        let (q_hi, q_lo) = bounds(self.edf)?;
        let (h_hi, h_lo) = bounds(0.5 * self.edf)?;
        Ok(self
            .psd
            .iter()
            .enumerate()
            .map(|(k, &p)| {
                let nu = self.edf_at(k);
                let (a, b) = if nu == self.edf {
                    (q_hi, q_lo)
                } else {
                    (h_hi, h_lo)
                };
                (nu * p / a, nu * p / b)
            })
            .collect())
    }
}

/// Periodogram of a series sampled at `rate_hz`: mean removed, two-sided density
/// (unit²/Hz) at f_k = k·rate/N, k = 0..=N/2 (ν = 2 per interior bin).
///
/// ```
/// use spectral::empirical::periodogram;
/// // Parseval: Σ over the full two-sided band, times Δf, is the sample variance.
/// let x = [1.0, 3.0, -2.0, 0.5, 4.0, -1.0, 2.0, 0.0];
/// let p = periodogram(&x, 2.0)?;
/// let df = 2.0 / 8.0;
/// let total: f64 = (0..p.psd.len()).map(|k| if k == 0 || k == 4 { p.psd[k] } else { 2.0 * p.psd[k] }).sum::<f64>() * df;
/// let m = x.iter().sum::<f64>() / 8.0;
/// let var = x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / 8.0;
/// assert!((total - var).abs() < 1e-12);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn periodogram(x: &[f64], rate_hz: f64) -> Result<PsdEstimate> {
    let rate = check_rate(rate_hz)?;
    check_series(x, 2)?;
    segment_average(x, rate, x.len(), 0, Window::Rectangular)
}

/// Welch PSD estimate of a series sampled at `rate_hz` (see the module docs), two-sided
/// (unit²/Hz) at f_k = k·rate/L, k = 0..=L/2.
///
/// ```
/// use spectral::empirical::{welch, WelchConfig};
/// let x: Vec<f64> = (0..10_000).map(|t| if t % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// let est = welch(&x, 100.0, &WelchConfig { segment_len: 64, overlap: 32, ..Default::default() })?;
/// // all the power sits at the Nyquist frequency, 50 Hz
/// let kmax = (0..est.psd.len()).max_by(|&a, &b| est.psd[a].total_cmp(&est.psd[b])).unwrap();
/// assert_eq!(est.frequencies_hz[kmax], 50.0);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn welch(x: &[f64], rate_hz: f64, config: &WelchConfig) -> Result<PsdEstimate> {
    let rate = check_rate(rate_hz)?;
    let l = config.segment_len;
    if l < 2 || config.overlap >= l {
        return Err(SpectralError::InvalidArgument(format!(
            "Welch needs segment_len >= 2 and overlap < segment_len, got {} and {}",
            l, config.overlap
        )));
    }
    check_series(x, l)?;
    segment_average(x, rate, l, config.overlap, config.window)
}

fn segment_average(
    x: &[f64],
    rate: f64,
    l: usize,
    overlap: usize,
    window: Window,
) -> Result<PsdEstimate> {
    let step = l - overlap;
    let k_segments = (x.len() - l) / step + 1;
    let w = window.weights(l);
    let w2: f64 = w.iter().map(|v| v * v).sum();
    let mut planner = RealFftPlanner::<f64>::new();
    let r2c = planner.plan_fft_forward(l);
    let mut buf = r2c.make_input_vec();
    let mut spec = r2c.make_output_vec();
    let mut acc = vec![0.0; spec.len()];
    for s in 0..k_segments {
        let seg = &x[s * step..s * step + l];
        let m = mean(seg);
        for ((b, &v), &wt) in buf.iter_mut().zip(seg).zip(&w) {
            *b = (v - m) * wt;
        }
        r2c.process(&mut buf, &mut spec).map_err(fft_error)?;
        for (a, z) in acc.iter_mut().zip(&spec) {
            *a += z.norm_sqr();
        }
    }
    let norm = 1.0 / (rate * w2 * k_segments as f64);
    let psd: Vec<f64> = acc.iter().map(|a| a * norm).collect();
    let frequencies_hz = (0..psd.len()).map(|k| k as f64 * rate / l as f64).collect();
    // Percival & Walden eq. 292b
    let mut denom = 1.0;
    for j in 1..k_segments {
        let shift = j * step;
        if shift >= l {
            break;
        }
        let rho: f64 = w[..l - shift]
            .iter()
            .zip(&w[shift..])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / w2;
        denom += 2.0 * (1.0 - j as f64 / k_segments as f64) * rho * rho;
    }
    Ok(PsdEstimate {
        frequencies_hz,
        psd,
        edf: 2.0 * k_segments as f64 / denom,
        segments: k_segments,
        even_length: l.is_multiple_of(2),
    })
}
