//! # imunoise — stochastic calibration of inertial sensors
//!
//! The umbrella crate: re-exports the layers and holds the `imunoise` command.
//! - [`processes`]: latent processes, composite models, simulation, time-series types.
//! - [`spectral`]: PSD, ACF and the theoretical Allan variance.
//! - [`avar`]: the maximum-overlapping Allan variance estimator and its confidence intervals.
//! - [`gmwm_prep`]: fitting composite models to the Allan variance.

pub use avar;
pub use gmwm_prep;
pub use processes;
pub use spectral;
