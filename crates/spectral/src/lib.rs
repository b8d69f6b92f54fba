//! # spectral — PSD, ACF and the theoretical Allan variance three ways
//!
//! The theory layer of `imunoise` (book Chapter 4): the theoretical Allan variance (AV)
//! and Haar wavelet variance of every latent process of [`processes`], with analytic
//! gradients for the GMWM.
//!
//! ## Conventions
//! - Cluster size `m` in samples, averaging time τ = m / rate in seconds; parameters per
//!   sample as in [`processes`] (GM: β in 1/s, σ_G² the stationary variance).
//! - AV in the process's unit² (variance, not deviation).
//!
//! ```
//! use processes::{WhiteNoise, RandomWalk, Ar1};
//! use spectral::model_allan_variance;
//! let model = (WhiteNoise::new(1e-4)? + RandomWalk::new(1e-9)? + Ar1::new(0.999, 1e-7)?)?;
//! let av: Vec<f64> = (1..=20)
//!     .map(|j| model_allan_variance(&model, 1 << j, 100.0))
//!     .collect::<Result<_, _>>()?;
//! assert!(av[0] < 1e-4 && av[19] > av[10]); // WN falls, then RW rises
//! # Ok::<(), spectral::SpectralError>(())
//! ```

pub mod ambiguity;
pub mod closed_form;
mod dd;
pub mod empirical;
pub mod error;
pub mod lemma42;
pub mod psd;
pub mod quadrature;
pub mod tolerances;

pub use closed_form::{
    allan_variance, allan_variance_gradient, allan_variance_with_gradient, haar_wavelet_variance,
    haar_wavelet_variance_gradient, model_allan_variance, model_allan_variance_gradient,
    model_haar_wavelet_variance, model_haar_wavelet_variance_gradient,
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
