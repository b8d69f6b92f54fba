//! The error type of the crate.

use thiserror::Error;

/// Everything that can go wrong when estimating an Allan variance.
///
/// Library functions return this instead of panicking on bad user input.
///
/// ```
/// use avar::{allan_variance, AvarConfig, AvarError};
/// let err = allan_variance(&[], 100.0, &AvarConfig::default()).unwrap_err();
/// assert!(matches!(err, AvarError::Empty));
/// ```
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum AvarError {
    /// The input series has no samples.
    #[error("the input series is empty")]
    Empty,
    /// Fewer samples than the estimator needs.
    #[error("too few samples: got {got} rate samples, need at least {need}")]
    TooShort {
        /// Number of rate samples given (for angle input: angle samples − 1).
        got: usize,
        /// Minimum number of rate samples.
        need: usize,
    },
    /// A NaN or infinite sample.
    #[error("non-finite sample {value} at index {index}")]
    NonFinite {
        /// Zero-based index of the first offending sample.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// The sums overflowed although every sample is finite (values near f64::MAX).
    #[error("overflow while accumulating the series (samples too large in magnitude)")]
    Overflow,
    /// The Allan variance (or another statistic of the family) at a scale is beyond the range of f64 (about 1e-308 to 1e308) although
    /// every sample is finite: the samples are too large or too small in magnitude.
    #[error(
        "the estimated variance (AV, or the chosen statistic) at m = {m} is about 1e{log10:.0}, outside the range of f64 (1e-308 to 1e308): rescale the input (e.g. to SI units)"
    )]
    NotRepresentable {
        /// The cluster size (samples).
        m: u64,
        /// log10 of the AV's magnitude.
        log10: f64,
    },
    /// The sampling rate is not a finite positive number.
    #[error("invalid sampling rate {0} Hz: must be finite and > 0")]
    InvalidRate(f64),
    /// The CI level α is not in (0, 1).
    #[error("invalid alpha {0}: must satisfy 0 < alpha < 1")]
    InvalidAlpha(f64),
    /// A cluster size of zero was requested.
    #[error("cluster size m = 0 is not allowed (m counts samples, m >= 1)")]
    ZeroScale,
    /// A cluster size too large for the series (an AV needs 2m <= T).
    #[error(
        "cluster size m = {m} is too large for T = {t} rate samples (need 2m <= T, i.e. m <= {max})"
    )]
    ScaleTooLarge {
        /// The requested cluster size (samples).
        m: u64,
        /// Number of rate samples.
        t: usize,
        /// Largest admissible cluster size.
        max: u64,
    },
    /// A cluster size too large for a statistic of the stability family (see
    /// [`crate::stability::Statistic::max_m`]).
    #[error(
        "cluster size m = {m} is too large for {statistic} with T = {t} rate samples (m <= {max})"
    )]
    ScaleTooLargeFor {
        /// The statistic (`"mdev"`, …).
        statistic: &'static str,
        /// The requested cluster size (samples).
        m: u64,
        /// Number of rate samples.
        t: usize,
        /// Largest admissible cluster size.
        max: u64,
    },
    /// An unknown statistic name or a request the statistic does not support.
    #[error("{0}")]
    InvalidStatistic(String),
    /// The scale grid is malformed (e.g. a non-positive step) or yields no scale for this length.
    #[error("invalid scale grid: {0}")]
    InvalidScales(String),
    /// A robust estimator's Gaussian efficiency or tuning constant out of its range.
    #[error("invalid robust efficiency: {0}")]
    InvalidEfficiency(String),
    /// A request the online estimator ([`crate::online`]) does not support, or chunks that
    /// do not match its channels.
    #[error("online estimator: {0}")]
    Online(String),
    /// An error in one channel of a multi-channel call.
    #[error("channel {channel}: {source}")]
    Channel {
        /// Zero-based channel index.
        channel: usize,
        /// The error of that channel.
        source: Box<AvarError>,
    },
}
