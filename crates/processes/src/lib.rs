//! # processes — the latent noise processes of inertial sensors
//!
//! The bottom layer of `imunoise`: the latent processes of *An Introduction to Inertial
//! Sensors Stochastic Calibration* (Guerrier et al., §2.2) — white noise ([`WhiteNoise`]),
//! quantization noise ([`QuantizationNoise`]), drift ([`Drift`]), random walk
//! ([`RandomWalk`]), AR(1) ([`Ar1`]), Gauss-Markov ([`GaussMarkov`]), MA(1) ([`Ma1`]) and the
//! IEEE 952 bias instability ([`BiasInstability`], Gauss-Markov states over the record's band)
//! and sinusoidal term ([`Sinusoid`]) —
//! their sums ([`Model`], book Definition 2.8), their theory (mean, autocovariance,
//! stationarity), their simulation, and the time-series types ([`TimeSeries`], [`ImuRecord`]).
//!
//! ## Conventions
//! - Parameters are **per sample** (Δt = 1 / rate), except GM's β (1/s) and σ_G²
//!   (stationary variance). Time index t = 1, 2, …, T.
//! - Every constructor validates its parameters and returns [`ProcessError`] on bad input.
//! - Simulation ([`Model::simulate`], [`Model::simulate_components`],
//!   [`Model::simulate_stream`], [`Process::simulate_into`]) is parallel over fixed chunks
//!   of [`CHUNK_LEN`] samples with one xoshiro256++ stream per (seed, stream, component,
//!   chunk), so a seed gives the same bits on any number of threads; AR1/GM and MA1/QN
//!   start stationary, RW at X_0 = 0 (see [`simulate`] for the scheme).
//!
//! ```
//! use processes::{Model, WhiteNoise, RandomWalk, Ar1};
//! let model = (WhiteNoise::new(1e-4)? + RandomWalk::new(1e-9)? + Ar1::new(0.99, 1e-6)?)?;
//! assert!(!model.is_stationary()); // a random walk is not stationary
//! let parsed: Model = model.to_string().parse()?;
//! assert_eq!(parsed, model);
//! let x = model.simulate(10_000, 100.0, 42)?; // 10^4 samples at 100 Hz, seed 42
//! assert_eq!(x, model.simulate(10_000, 100.0, 42)?);
//! # Ok::<(), processes::ProcessError>(())
//! ```

pub mod ar_p;
pub mod arma;
pub mod error;
pub mod long_memory;
pub mod model;
pub mod number;
pub mod process;
pub mod series;
pub mod simulate;

pub use ar_p::{AR_MAX_ORDER, ArP};
pub use arma::{Arma, MA_MAX_ORDER};
pub use error::{ProcessError, Result};
pub use long_memory::{Fgn, Plp};
pub use model::{Component, Model};
pub use process::{
    Ar1, BI_FLAT_FROM_M, BI_FLAT_TOLERANCE, BI_MIN_CORRELATION_SAMPLES, BI_STATES_PER_DECADE,
    BiBand, BiasInstability, Drift, GaussMarkov, Ma1, Process, ProcessKind, QuantizationNoise,
    RandomWalk, Sinusoid, WhiteNoise,
};
pub use series::{ImuRecord, Sensor, TimeSeries, Unit};
pub use simulate::{CHUNK_LEN, Simulation};
