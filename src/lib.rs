//! # imunoise — stochastic calibration of inertial sensors
//!
//! The umbrella crate: re-exports the layers and holds the `imunoise` command.
//! - [`processes`]: latent processes, composite models, simulation, time-series types.
//! - [`spectral`]: PSD, ACF and the theoretical Allan variance.
//! - [`avar`]: the maximum-overlapping Allan variance estimator and its confidence intervals.
//! - [`gmwm_prep`]: fitting composite models to the Allan variance.
//!
//! The command's own layers live here too: [`io`] reads IMU logs (text, gzip, binary)
//! and [`error`] locates every input problem by file, line and column.

pub use avar;
pub use gmwm_prep;
pub use processes;
pub use spectral;

pub mod cli;
pub mod error;
pub mod io;
pub mod plot;
pub mod units;

pub use error::{Error, Result};
