//! The Haar wavelet variance (WV) estimator of the R package `wv`, via the MOAV identity.

use serde::{Deserialize, Serialize};
use statrs::distribution::{ChiSquared, ContinuousCDF};

use crate::config::{AvarConfig, CiMethod, Scales};
use crate::error::AvarError;

/// The Haar WV at one MODWT level.
///
/// ```
/// use avar::haar_wavelet_variance;
/// let x: Vec<f64> = (0..100).map(|i| ((i * 7) % 17) as f64).collect();
/// let wv = haar_wavelet_variance(&x, 4.0, Some(3), 0.05).unwrap();
/// for p in &wv.points {
///     assert_eq!(p.scale, 1 << p.j); // τ_j = 2^j samples
///     assert_eq!(p.tau, p.scale as f64 / 4.0); // s at 4 Hz
///     assert_eq!(p.n_coeffs, 100 - p.scale + 1); // M_j = T − 2^j + 1
///     assert_eq!(p.eta, (p.n_coeffs as f64 / p.scale as f64).max(1.0));
///     assert!(p.wv_lo < p.wv && p.wv < p.wv_hi);
/// }
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WvPoint {
    /// MODWT level j >= 1.
    pub j: u32,
    /// Wavelet scale τ_j = 2^j (samples).
    pub scale: u64,
    /// Wavelet scale in seconds (τ_j / rate).
    pub tau: f64,
    /// Haar wavelet variance ν̂²_j (rate unit²) = MOAV(m = 2^(j−1)) / 2.
    pub wv: f64,
    /// Lower bound of the chi-square η interval.
    pub wv_lo: f64,
    /// Upper bound of the chi-square η interval.
    pub wv_hi: f64,
    /// η = max(M_j / 2^j, 1), the degrees of freedom of the interval.
    pub eta: f64,
    /// Number of MODWT coefficients kept, M_j = T − 2^j + 1.
    pub n_coeffs: u64,
}

/// Haar wavelet variances at levels 1..=J.
///
/// ```
/// use avar::haar_wavelet_variance;
/// let x: Vec<f64> = (0..300).map(|i| ((i * 7) % 17) as f64).collect();
/// let wv = haar_wavelet_variance(&x, 50.0, Some(4), 0.1).unwrap();
/// assert_eq!((wv.rate_hz, wv.n, wv.alpha), (50.0, 300, 0.1));
/// let levels: Vec<u32> = wv.points.iter().map(|p| p.j).collect();
/// assert_eq!(levels, vec![1, 2, 3, 4]);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HaarWaveletVariance {
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Number of samples T.
    pub n: usize,
    /// Nominal non-coverage of the intervals.
    pub alpha: f64,
    /// One entry per level, ascending.
    pub points: Vec<WvPoint>,
}

/// Haar wavelet variance of rate samples, as the R package `wv` computes it (REFERENCES §3):
/// Haar MODWT with periodic boundary, the first 2^j − 1 coefficients of level j dropped
/// (M_j = T − 2^j + 1 kept), ν̂²_j = Σ W²/M_j. This equals MOAV(m = 2^(j−1)) / 2 exactly and is
/// computed that way. CI: with η = max(M_j / 2^j, 1),
/// [η ν̂² / χ²_{1−α/2}(η), η ν̂² / χ²_{α/2}(η)] — it assumes ν̂² ~ ν² χ²_η / η (Percival 1995,
/// "η3" approximation), which is rough for strongly correlated noise.
///
/// `levels`: J (the levels are 1..=J; needs 2^J <= T); `None` gives J = ⌊log2 T⌋ − 1.
///
/// ```
/// use avar::{allan_variance, haar_wavelet_variance, AvarConfig, CiMethod, Scales};
/// let x: Vec<f64> = (0..500).map(|i| ((i * 7) % 17) as f64).collect();
/// let wv = haar_wavelet_variance(&x, 1.0, None, 0.05).unwrap();
/// assert_eq!(wv.points.len(), 7); // ⌊log2 500⌋ − 1
/// let cfg = AvarConfig { scales: Scales::Explicit(vec![4]), ci: CiMethod::None, ..Default::default() };
/// let av = allan_variance(&x, 1.0, &cfg).unwrap().points[0].avar;
/// assert_eq!(wv.points[2].wv, av / 2.0); // level 3 ↔ m = 4
/// ```
pub fn haar_wavelet_variance(
    data: &[f64],
    rate_hz: f64,
    levels: Option<u32>,
    alpha: f64,
) -> Result<HaarWaveletVariance, AvarError> {
    crate::validate_rate_alpha(rate_hz, alpha)?;
    let t = data.len();
    crate::check_len(t, t)?;
    let jmax = match levels {
        Some(0) => return Err(AvarError::InvalidScales("levels must be >= 1".into())),
        Some(j) => {
            if j >= 63 || (1u64 << j) > t as u64 {
                return Err(AvarError::ScaleTooLarge {
                    m: if j >= 63 { u64::MAX } else { 1u64 << (j - 1) },
                    t,
                    max: (t / 2) as u64,
                });
            }
            j
        }
        None => (t as f64).log2().floor() as u32 - 1,
    };
    let ms: Vec<u64> = (1..=jmax).map(|j| 1u64 << (j - 1)).collect();
    let cfg = AvarConfig {
        scales: Scales::Explicit(ms),
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let av = crate::allan_variance(data, rate_hz, &cfg)?;
    let points = av
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let j = i as u32 + 1;
            let scale = 1u64 << j;
            let wv = p.avar / 2.0;
            let eta = (p.n_terms as f64 / scale as f64).max(1.0);
            let (wv_lo, wv_hi) = chi2_interval(wv, eta, alpha);
            WvPoint {
                j,
                scale,
                tau: scale as f64 / rate_hz,
                wv,
                wv_lo,
                wv_hi,
                eta,
                n_coeffs: p.n_terms,
            }
        })
        .collect();
    Ok(HaarWaveletVariance {
        rate_hz,
        n: t,
        alpha,
        points,
    })
}

/// [edf·v / χ²_{1−α/2}(edf), edf·v / χ²_{α/2}(edf)] (edf > 0).
pub(crate) fn chi2_interval(v: f64, edf: f64, alpha: f64) -> (f64, f64) {
    match ChiSquared::new(edf) {
        Ok(d) => {
            let hi_q = d.inverse_cdf(1.0 - alpha / 2.0);
            let lo_q = d.inverse_cdf(alpha / 2.0);
            (edf * v / hi_q, edf * v / lo_q)
        }
        Err(_) => (f64::NAN, f64::NAN),
    }
}
