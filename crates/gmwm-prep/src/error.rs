//! The error type of the `gmwm-prep` crate.

use thiserror::Error;

/// Everything that can go wrong when reading, fitting or bootstrapping an Allan variance curve.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FitError {
    /// An error of the `processes` layer (bad model, bad parameter, simulation).
    #[error(transparent)]
    Process(#[from] processes::ProcessError),
    /// An AV curve value (τ, m, AV, CI bound, variance) that is not finite or not positive.
    #[error("AV curve point {index}: {what} = {value} must be finite and > 0")]
    NonFinite {
        /// Zero-based index of the point in the curve.
        index: usize,
        /// Which quantity, e.g. `"avar"`.
        what: &'static str,
        /// The rejected value.
        value: f64,
    },
    /// An AV curve whose scales are not strictly increasing, or otherwise malformed.
    #[error("invalid AV curve: {0}")]
    InvalidCurve(String),
    /// Fewer usable scales than the method needs (e.g. fewer scales than parameters).
    #[error("too few scales: {needed} needed for {what}, got {got}")]
    TooFewScales {
        /// What needs them, e.g. `"a 5-parameter model"`.
        what: String,
        /// How many are needed.
        needed: usize,
        /// How many there are.
        got: usize,
    },
    /// A model that cannot be fitted by this method (e.g. not identifiable from the AV).
    #[error("model cannot be fitted: {0}")]
    Unidentifiable(String),
    /// Parameters that the fitted scales cannot determine (AᵀΩA singular at θ̂), in the
    /// user's terms: which components, over which scales, why, and what to try.
    #[error(
        "{} cannot be identified from the scales τ = {tau_lo} … {tau_hi} s: {reason}. Try selecting a sub-model by WIC (--select){}, or a longer record (more scales at long τ)",
        if components.is_empty() { "the model".to_string() } else { components.join(" and ") },
        smaller_model.as_ref().map_or(String::new(), |s| format!(", a smaller model such as \"{s}\""))
    )]
    NotIdentifiable {
        /// Codes of the components concerned (e.g. `["RW"]`), empty when none stands out.
        components: Vec<String>,
        /// Shortest averaging time of the fitted scales (s).
        tau_lo: f64,
        /// Longest averaging time of the fitted scales (s).
        tau_hi: f64,
        /// Why, in words.
        reason: String,
        /// The template without the first component concerned, when that leaves a model.
        smaller_model: Option<String>,
    },
    /// AV values too far from unit magnitude for the fit's arithmetic (samples near 1e±150).
    #[error(
        "the AV values (median {median_avar:.1e}) are too far from unit magnitude for the fit and its intervals (supported: about 1e-132 to 1e132); rescale the data (e.g. to SI units, or with --scale)"
    )]
    MagnitudeOutOfRange {
        /// The median AV of the curve.
        median_avar: f64,
    },
    /// A scale window (AVLR) that is empty or out of the curve's range.
    #[error("invalid scale window for {process}: {message}")]
    InvalidWindow {
        /// Process code.
        process: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A weighting or covariance matrix that has the wrong size or is not positive definite.
    #[error("invalid weighting/covariance matrix: {0}")]
    InvalidMatrix(String),
    /// A confidence level outside (0, 1).
    #[error("significance level alpha must lie in (0, 1), got {0}")]
    InvalidAlpha(f64),
    /// The optimizer produced a non-finite objective from every start.
    #[error("optimization failed: {0}")]
    OptimizationFailed(String),
    /// Any other invalid argument.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// An error of the empirical AV layer (`avar`), e.g. in a bootstrap replication.
    #[error(transparent)]
    Avar(#[from] avar::AvarError),
    /// An error of the theoretical AV (e.g. m = 0 or a bad rate).
    #[error(transparent)]
    Spectral(#[from] spectral::SpectralError),
}

/// Shorthand for results of this crate.
pub type Result<T, E = FitError> = std::result::Result<T, E>;
