//! Named tolerances of the crate's acceptance checks (statrs `prec` style): every
//! comparison in the tests uses one of these, with its justification here.

/// Closed form vs Lemma 4.2 sum (issue 3 acceptance): relative ≤ 1e-12. Both are
/// evaluated without cancellation, so the observed gap is a few ulps.
pub const SUM_REL: f64 = 1e-12;

/// Closed form vs Lemma 4.1 quadrature (issue 3 acceptance): relative ≤ 1e-8.
pub const QUADRATURE_REL: f64 = 1e-8;

/// Closed form vs an extended-precision (double-double, ~32 digits) reference: the
/// closed forms are meant to be accurate to a few ulps; 1e-13 leaves room for the
/// ~10-ulp error of the series/`expm1` evaluations.
pub const EXTENDED_REF_REL: f64 = 1e-13;

/// Analytic gradient vs central finite differences with Richardson extrapolation
/// (step h, error O(h⁴) plus roundoff ε·|f|/h): 1e-7 relative to the gradient scale.
pub const FINITE_DIFF_REL: f64 = 1e-7;

/// Analytic gradient vs the exact derivative evaluated in double-double arithmetic (a
/// high-precision reference at φ near ±1): same budget as [`EXTENDED_REF_REL`], the
/// observed gap being ≤ 5e-15.
pub const GRADIENT_EXTENDED_REL: f64 = 1e-13;

/// FFT autocovariance vs the direct O(N·H) sum (issue 3 acceptance): ≤ 1e-10 relative
/// to γ(0).
pub const FFT_ACV_REL: f64 = 1e-10;

/// Spectral ambiguity (issue 3 acceptance): max relative AV difference ≤ 1e-8 …
pub const AMBIGUITY_AV_REL: f64 = 1e-8;
/// … while the two PSDs differ by at least 10 % somewhere.
pub const AMBIGUITY_PSD_MIN_REL_DIFF: f64 = 0.10;

/// Welch PSD of a simulated AR1 inside its chi-square CI at ≥ 90 % of the frequencies.
pub const WELCH_MIN_COVERAGE: f64 = 0.90;

/// PSD formula vs the direct Fourier sum Δt Σ γ(h) e^(−2πifhΔt) (≤ 800 terms, AR1 tail
/// below 0.8^400 ≈ 1e-39): roundoff of the sum only.
pub const PSD_FOURIER_REL: f64 = 1e-12;

/// A 20-point Gauss-Legendre rule on polynomials of degree ≤ 39 (exact in exact
/// arithmetic): roundoff of 20 terms.
pub const GAUSS_LEGENDRE_REL: f64 = 1e-14;

/// Slope and intercept of log AD vs log τ fitted on a simulated WN series (2^20 samples,
/// m = 2..64): the relative SE of each AV estimate is ≤ ≈ 0.013 (m = 64, N/m = 16384), so
/// log AD errors ≤ ≈ 0.007 and the fitted slope/intercept errors ≤ ≈ 0.005; 0.05 is ≈ 10 SE.
pub const MC_LOG_AD_ABS: f64 = 0.05;

/// Number of standard errors allowed in Monte Carlo checks whose SE is computed in the
/// test (false-alarm probability < 1e-6 for a Gaussian statistic).
pub const MC_Z: f64 = 5.0;

/// Double-double arithmetic: unit roundoff 2^-104 ≈ 5e-32, a few operations.
pub const DOUBLE_DOUBLE_REL: f64 = 1e-31;
