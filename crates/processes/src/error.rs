//! The error type of the `processes` crate.

use thiserror::Error;

/// Everything that can go wrong when building processes, models and time series,
/// or when simulating them.
///
/// ```
/// use processes::{Ar1, Model, ProcessError};
/// let err = Ar1::new(1.2, 1.0).unwrap_err();
/// assert!(matches!(err, ProcessError::InvalidParameter { name: "phi", .. }));
/// assert!(err.to_string().contains("(-1, 1)"));
/// assert_eq!("WN + WN".parse::<Model>().unwrap_err(), ProcessError::DuplicateComponent { kind: "WN" });
/// ```
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ProcessError {
    /// A parameter is outside its admissible range (or not finite).
    #[error("invalid parameter {name} = {value} of {process}: {requirement}")]
    InvalidParameter {
        /// Process code, e.g. `"AR1"`.
        process: &'static str,
        /// Parameter name, e.g. `"phi"`.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// What the parameter must satisfy, e.g. `"must lie in (-1, 1)"`.
        requirement: &'static str,
    },
    /// A model string could not be parsed.
    #[error("cannot parse model {input:?} at byte {position}: {message}")]
    Parse {
        /// The whole input string.
        input: String,
        /// Byte offset of the problem in `input`.
        position: usize,
        /// What was expected or found.
        message: String,
    },
    /// A model contains more than one process of a kind that may appear once only
    /// (WN, QN, RW, DR, MA1, BI): their sum would not be identifiable.
    #[error(
        "model has more than one {kind} component; at most one each of WN, QN, RW, DR, MA1 and BI is identifiable (any number of AR1/GM/SIN is allowed)"
    )]
    DuplicateComponent {
        /// Process code of the duplicated kind.
        kind: &'static str,
    },
    /// A model without components.
    #[error("a model needs at least one component")]
    EmptyModel,
    /// An operation needs numeric values but the model has slots still to be estimated.
    #[error(
        "component {index} ({kind}) of the model has no parameter values (it is a slot to be estimated)"
    )]
    UnspecifiedComponent {
        /// Zero-based component index.
        index: usize,
        /// Process code of the slot.
        kind: &'static str,
    },
    /// A sampling rate that is not finite and positive.
    #[error("sampling rate must be finite and > 0 Hz, got {0}")]
    InvalidRate(f64),
    /// A time series value that is NaN or infinite.
    #[error("time series {name:?} has a non-finite value {value} at index {index}")]
    NonFiniteValue {
        /// Name of the series.
        name: String,
        /// Zero-based index of the first bad value.
        index: usize,
        /// The bad value.
        value: f64,
    },
    /// Channels of a multi-channel record that do not have the same length.
    #[error("channel {name:?} has {len} samples but the record has {expected}")]
    LengthMismatch {
        /// Name of the offending channel.
        name: String,
        /// Its length.
        len: usize,
        /// The length of the first channel.
        expected: usize,
    },
    /// A quantity asked of a process that does not have it (e.g. the autocovariance
    /// of a non-stationary random walk).
    #[error("{what} is not defined for {process}: {why}")]
    NotDefined {
        /// What was asked, e.g. `"autocovariance"`.
        what: &'static str,
        /// Process code.
        process: &'static str,
        /// Why not.
        why: &'static str,
    },
    /// Any other invalid argument (e.g. zero samples to simulate).
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}

/// Shorthand for results of this crate.
///
/// ```
/// fn variance_of_wn(sigma2: f64) -> processes::Result<f64> {
///     processes::Process::from(processes::WhiteNoise::new(sigma2)?).variance_at(1, 1.0)
/// }
/// assert_eq!(variance_of_wn(2.0), Ok(2.0));
/// assert!(variance_of_wn(-2.0).is_err());
/// ```
pub type Result<T, E = ProcessError> = std::result::Result<T, E>;
