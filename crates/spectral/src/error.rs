//! The error type of the `spectral` crate.

use processes::ProcessError;
use thiserror::Error;

/// Everything that can go wrong in the `spectral` crate.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpectralError {
    /// An error of the `processes` layer (invalid parameter, unspecified model slot, …).
    #[error(transparent)]
    Process(#[from] ProcessError),
    /// A cluster size `m` of zero (the Allan variance needs m ≥ 1 samples).
    #[error("cluster size m must be >= 1 sample, got {0}")]
    InvalidClusterSize(u64),
    /// A Haar wavelet scale τ_j that is not an even number ≥ 2 of samples.
    #[error("Haar wavelet scale tau_j must be an even number >= 2 of samples, got {0}")]
    InvalidScale(u64),
    /// A sampling rate that is not finite and positive.
    #[error("sampling rate must be finite and > 0 Hz, got {0}")]
    InvalidRate(f64),
    /// A frequency that is negative or not finite.
    #[error("frequency must be finite and >= 0 Hz, got {0}")]
    InvalidFrequency(f64),
    /// The PSD asked of a process whose spectrum is not a function (the drift: its
    /// generalized spectrum is a multiple of δ''(f), see the crate docs).
    #[error("the PSD of {process} is not a function: {why}")]
    NotAFunction {
        /// Process code.
        process: &'static str,
        /// Why, and what to use instead.
        why: &'static str,
    },
    /// A quantity that needs a stationary process (e.g. the autocovariance of RW or DR).
    #[error("{what} needs a stationary process, and {process} is not")]
    NotStationary {
        /// What was asked.
        what: &'static str,
        /// Process code.
        process: &'static str,
    },
    /// Input data too short for what was asked (e.g. an ACV slice shorter than 2m + 1).
    #[error("not enough data: {0}")]
    TooShort(String),
    /// A value in the input data (series, ACV, PSD values) that is NaN or infinite.
    #[error("non-finite value {value} at index {index}")]
    NonFinite {
        /// Zero-based index of the first bad value.
        index: usize,
        /// The bad value.
        value: f64,
    },
    /// A numerical integral whose value is not finite (e.g. a PSD growing like f or faster,
    /// for which the Lemma 4.1 integral diverges).
    #[error("the Lemma 4.1 integral does not converge: {0}")]
    Divergent(String),
    /// Any other invalid argument.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}

/// Shorthand for results of this crate.
pub type Result<T, E = SpectralError> = std::result::Result<T, E>;

pub(crate) fn check_rate(rate_hz: f64) -> Result<f64> {
    if rate_hz.is_finite() && rate_hz > 0.0 {
        Ok(rate_hz)
    } else {
        Err(SpectralError::InvalidRate(rate_hz))
    }
}

pub(crate) fn check_m(m: u64) -> Result<u64> {
    if m >= 1 {
        Ok(m)
    } else {
        Err(SpectralError::InvalidClusterSize(m))
    }
}

pub(crate) fn check_tau_j(tau_j: u64) -> Result<u64> {
    if tau_j >= 2 && tau_j.is_multiple_of(2) {
        Ok(tau_j / 2)
    } else {
        Err(SpectralError::InvalidScale(tau_j))
    }
}

/// Errors for a process whose theory needs data it does not carry yet: a BI with an AUTO
/// band (its states are fixed from the record's scales).
pub(crate) fn check_process(process: &processes::Process) -> Result<()> {
    if let processes::Process::BiasInstability(b) = process {
        b.band().states()?;
    }
    Ok(())
}
