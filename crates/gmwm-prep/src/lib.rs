//! # gmwm-prep — fitting composite noise models to the Allan variance
//!
//! Three estimators of the book's Chapter 4 family, from the least to the most reliable:
//! - [`ieee`]: the IEEE Std 952 read-off of N, B, K, Q, R from an Allan deviation curve,
//!   with automatic detection of the slope regions (REFERENCES §5);
//! - [`avlr`]: AV linear regression (book §4.4, R avar's `avlr`): each process on its own
//!   scale window by a fixed-slope log-log mean;
//! - [`gmwm`]: a GMWM-type estimator θ̂ = argmin (ν̂ − ν(θ))ᵀ Ω (ν̂ − ν(θ)) for any model of
//!   the `processes` crate (deterministic grid + NNLS starts, Levenberg–Marquardt on faer with
//!   the analytic Jacobian), with [`inference`] (delta method B V Bᵀ, J test, WIC, model
//!   selection), a reproducible parallel parametric [`bootstrap`] and serializable
//!   [`report`]s.
//!
//! Beside them: [`robust`] (the RGMWM: the GMWM on the robust AV of `avar::robust`, and a
//! check comparing the classical and robust curves) and [`multi`] (one model for several
//! recordings, with Wald and J-type tests of equality).
//!
//! The input is a plain [`AvCurve`] (cluster sizes, AV values, optional CIs/variances,
//! sampling rate), so published curves can be fitted as well as curves from the `avar` crate.
//! Parameters are per sample (as in `processes`); [`units`] gives the per-second and IEEE
//! forms (REFERENCES §5).
//!
//! ```
//! use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}};
//! let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
//! let m: Vec<u64> = (1..=18).map(|j| 1u64 << j).collect();
//! let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
//! let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(1_000_000);
//! let fit = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
//! assert!((fit.theta[0] / 1e-4 - 1.0).abs() < 1e-6);
//! # Ok::<(), gmwm_prep::FitError>(())
//! ```

pub mod adequacy;
mod avcov;
pub mod avlr;
pub mod bootstrap;
mod cov_matrix;
pub mod curve;
pub mod diagnose;
mod efficiency;
pub mod error;
pub mod gmwm;
pub mod ieee;
pub mod inference;
mod long_memory;
mod magnitude;
pub mod multi;
pub mod noise_terms;
pub mod report;
pub mod robust;
pub mod stats;
pub mod theory;
pub mod units;

pub use curve::{AvCurve, CurvePoint};
pub use error::{FitError, Result};
