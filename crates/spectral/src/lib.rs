//! # spectral — PSD, ACF and the theoretical Allan variance three ways
//!
//! The theory layer of `imunoise` (book Chapter 4): power spectral densities of the latent
//! processes of [`processes`], their theoretical Allan variance (AV) by the closed forms,
//! by the book's Lemma 4.2 (ACF sum) and by its Lemma 4.1 (PSD integral), the Haar wavelet
//! variance of the GMWM with analytic gradients, the spectral ambiguity of §4.1, and
//! empirical ACF/PSD estimators.
//!
//! ## Conventions
//! - **Scales**: cluster size `m` in samples, averaging time τ = m / rate in seconds. The
//!   Haar wavelet scale `tau_j` is in samples (τ_j = 2^j; ν²_j = AV(τ_j/2)/2).
//! - **Parameters** per sample as in [`processes`] (GM: β in 1/s, σ_G² stationary).
//! - **AV** in the process's unit² (a variance, not a deviation).
//! - **PSD**: two-sided, f in Hz, unit²/Hz, S(f) = Δt Σ_h γ(h) e^(−2πifhΔt), periodic in f
//!   with period `rate` (one-sided = 2S on [0, rate/2]). With this convention Lemma 4.1,
//!   AV = 4∫_0^∞ sin⁴(πfτ)/(πfτ)² S(f) df, holds as printed — exactly, for the periodic S
//!   of a sampled process (see [`quadrature`] for why) — and the IEEE reading N²/τ of a
//!   white noise of PSD N² follows. RW has the generalized spectrum γ²Δt/(4 sin²(πfΔt))
//!   (∝ 1/f² near 0); DR's spectrum is a distribution ∝ δ''(f) (see [`mod@psd`]).
//!
//! ## The three routes (and the crate's acceptance table, `tests/three_ways.rs`)
//! | route | function | cost | notes |
//! |---|---|---|---|
//! | closed form (`REFERENCES.md` §2) | [`allan_variance`] | O(1) | stable for φ → ±1 (series in L = −ln φ), m up to 2^30 and beyond; analytic gradient [`allan_variance_gradient`] |
//! | Lemma 4.2 | [`lemma42_allan_variance`], [`allan_variance_from_acf`], [`allan_variance_from_variogram`], [`allan_variance_from_acv`] | O(m) | semivariogram form (also RW and DR, book Remark 4.5), compensated sums, double-double for AR1 with φ < 0 |
//! | Lemma 4.1 | [`quadrature_allan_variance`], [`discrete_lemma41_allan_variance`], [`lemma41_allan_variance`] | O(log m) | Gauss-Legendre panels between zeros of sin(πfτ), graded ends, asymptotic tail |
//!
//! For every process and m ∈ {1, 2, 3, 4, 7, 8, 16, …, 2^20} the closed forms agree with the
//! Lemma 4.2 sums to ≤ 1e-15 and with the quadrature to ≤ 5e-12 (acceptance: 1e-12 and 1e-8);
//! see [`tolerances`] for every bound used by the tests.
//!
//! ```
//! use processes::{WhiteNoise, RandomWalk, Ar1, Process};
//! use spectral::{allan_variance, lemma42_allan_variance, model_allan_variance, quadrature_allan_variance};
//! let model = (WhiteNoise::new(1e-4)? + RandomWalk::new(1e-9)? + Ar1::new(0.999, 1e-7)?)?;
//! let av: Vec<f64> = (1..=20)
//!     .map(|j| model_allan_variance(&model, 1 << j, 100.0))
//!     .collect::<Result<_, _>>()?;
//! assert!(av[0] < 1e-4 && av[19] > av[10]); // WN falls, then RW rises
//! // three routes, one number
//! let ar = Process::from(Ar1::new(0.99999, 1e-7)?);
//! let c = allan_variance(&ar, 1000, 100.0)?;
//! assert!((lemma42_allan_variance(&ar, 1000, 100.0)? - c).abs() <= 1e-12 * c);
//! assert!((quadrature_allan_variance(&ar, 1000, 100.0)? - c).abs() <= 1e-8 * c);
//! # Ok::<(), spectral::SpectralError>(())
//! ```
//!
//! ## Modules
//! - [`closed_form`]: AV, Haar WV and gradients, per process and per model (Corollary 4.1).
//! - [`lemma42`]: Lemma 4.2 on an ACF, a semivariogram or a sampled ACV.
//! - [`mod@psd`]: the PSD of every process and model.
//! - [`quadrature`]: Lemma 4.1 in continuous and discrete time.
//! - [`ambiguity`]: §4.1, Φ(f) = 2Φ(2f) (example `examples/spectral_ambiguity.rs`).
//! - [`empirical`]: ACV/ACF by FFT (realfft), periodogram, Welch with chi-square CIs.
//! - [`long_memory`]: AV (closed forms, Lemma 4.2) and PSD of PLP and FGN.
//! - [`tolerances`]: the named tolerances of the tests, with their justification.

pub mod ambiguity;
pub mod arma;
pub mod closed_form;
mod dd;
pub mod empirical;
pub mod error;
pub mod lemma42;
pub mod long_memory;
pub mod psd;
pub mod quadrature;
pub mod tolerances;

pub use closed_form::{
    allan_variance, allan_variance_gradient, allan_variance_with_gradient, haar_wavelet_variance,
    haar_wavelet_variance_gradient, model_allan_variance, model_allan_variance_gradient,
    model_allan_variance_with_gradient, model_haar_wavelet_variance,
    model_haar_wavelet_variance_gradient,
};
pub use error::{Result, SpectralError};
pub use lemma42::{
    allan_variance_from_acf, allan_variance_from_acv, allan_variance_from_variogram,
    lemma42_allan_variance, variogram,
};
pub use psd::{model_psd, psd};
pub use quadrature::{
    discrete_lemma41_allan_variance, lemma41_allan_variance, model_quadrature_allan_variance,
    quadrature_allan_variance,
};
