//! # imunoise — stochastic calibration of inertial sensors
//!
//! The umbrella crate: re-exports the layers and holds the `imunoise` command.
//! - [`processes`]: latent processes, composite models, simulation, time-series types.
//! - [`spectral`]: PSD, ACF and the theoretical Allan variance.
//! - [`avar`]: the maximum-overlapping Allan variance estimator and its confidence intervals.
//! - [`gmwm_prep`]: fitting composite models to the Allan variance.
//!
//! [`pipeline`] is the path from a file to results in plain structs (read, estimate, fit,
//! analyze, report): the `imunoise` command and the Python package are two faces of it.
//! The command's own layers live here too: [`io`] reads IMU logs (text, gzip, binary),
//! [`error`] locates every input problem by file, line and column, [`units`] maps
//! `--unit` and channel names to units, [`plot`] draws the SVG/PNG figures and [`cli`]
//! holds the subcommands (`avar`, `fit`, `analyze`, `export`, `topics`, `simulate`, `theory`,
//! `demo`). [`logs`] reads the logs IMUs are recorded in (ROS 2 MCAP, …) and checks their
//! time stamps; [`export`] writes the noise values into the estimators' config files.

pub use avar;
pub use gmwm_prep;
pub use processes;
pub use spectral;

pub mod cli;
pub mod error;
pub mod export;
pub mod io;
pub mod logs;
mod mapped;
pub mod output;
pub mod pipeline;
pub mod plot;
pub mod source;
pub mod ui;
pub mod units;

pub use error::{Error, Result};
pub use ui::Ui;
