//! A robust Allan variance (and Haar wavelet variance): an M-estimator of scale with Tukey's
//! biweight, per scale, as in the robust wavelet variance of Guerrier, Molinari and
//! Victoria-Feser (the RGMWM; R packages `gmwm`/`wv`, option `robust = TRUE`).
//!
//! At cluster size m the overlapping AV is half the mean square of the K = T − 2m + 1 differences
//! D_k = X̄_k − X̄_{k−m} (book eq. 4.2), and the Haar WV at τ = 2m is a quarter of it. The
//! classical mean square is replaced by the solution s = σ̂² of
//!
//! ```text
//! (1/K) Σ_k χ_c(D_k² / s) = a(c),    χ_c(u) = u (1 − u/c²)⁴ for u ≤ c², 0 beyond,
//! a(c) = E χ_c(Z²),  Z ~ N(0, 1),
//! ```
//!
//! (χ_c(z²) = ψ_c(z)² for the biweight ψ_c(z) = z(1 − z²/c²)²), so that σ̂² is consistent for
//! E D² = 2·AV(m) when D is Gaussian, and a difference beyond c·σ̂ gets no weight at all.
//! The robust AV is σ̂²/2 (the robust WV σ̂²/4).
//!
//! **Efficiency.** With θ = σ², a one-term expansion gives σ̂² − σ² ≈ 2σ² ((1/K) Σ χ_c(Z_k²) − a)/M_c,
//! M_c = E[(Z² − 1) χ_c(Z²)] (= E[Z χ_c'(Z)] by Stein's identity). For independent Gaussian
//! differences its variance is 4σ⁴ Var χ_c(Z²) / (K M_c²) against 2σ⁴/K for the mean square,
//! so the Gaussian efficiency is e(c) = M_c² / (2 Var χ_c(Z²)); c is chosen so that e(c) equals
//! the requested efficiency (0.6 by default: c = 4.400; [`Biweight::with_efficiency`]). The
//! moments are exact sums of truncated normal moments ([`Biweight::efficiency`]); a quadrature
//! ([`Biweight::efficiency_quadrature`]) checks them.
//!
//! **Variance and CIs.** The differences D_k are correlated (overlap, and the noise itself).
//! Expanding χ_c(Z²) − a = Σ_{k even ≥ 2} h_k He_k(Z)/k! in Hermite polynomials,
//! Cov(χ(Z_s²), χ(Z_t²)) = Σ h_k² ρ_{st}^k / k!: the k = 2 term (h₂ = M_c) reproduces the
//! classical estimator's covariance exactly, the others add at most the same sum again with
//! ρ^k ≤ ρ², so that Var(robust) / Var(classical) lies between 1 (strongly correlated
//! differences, large m) and 1/e(c) (independent differences). The intervals and the GMWM
//! weights here use the upper bound 1/e(c) at every scale (as `gmwm` does): the chi-square
//! interval of the classical estimator with its EDF multiplied by e(c). This is conservative
//! at large m (intervals too wide by at most 1/√e ≈ 1.29 in log-width at e = 0.6).
//!
//! **Spikes first.** An isolated outlier of size A changes a difference at cluster size m by
//! A/m while the differences spread as σ√(2/m) (white noise σ): past m ≈ (A/(cσ))²/2 it is no
//! longer beyond c·σ̂, and at m = 16 already 2·16·p of the differences carry one of a fraction
//! p of outliers. A per-scale M-estimator alone therefore cleans the small scales only and
//! leaves the large ones contaminated, a shape no noise model has. So [`robust_allan_variance`]
//! first replaces isolated spikes ([`replace_spikes`]): a sample farther than
//! [`SPIKE_THRESHOLD`] robust SDs from the mean of its 2·[`SPIKE_HALF_WINDOW`] neighbours is
//! replaced by the mean of its nearest unflagged neighbours plus a Gaussian draw (a fixed
//! hash of its index, so results are reproducible) whose variance restores the white-noise
//! share the neighbours' mean lacks: the replaced series has, to O(p/w), the clean series'
//! Allan variance at every scale, so that the per-scale estimator then only has to deal with
//! what is left (bursts, moderate outliers). On Gaussian data the threshold is passed by
//! about 2·10⁻⁹ of the samples: clean records are left as they are. When more than
//! [`MAX_SPIKE_FRACTION`] of the samples pass it, the noise itself is heavy-tailed (the MTi-G
//! gyro in `shared/data/mtig_outliers`: 5 % beyond 6 robust SDs, 21 % beyond 3) and nothing
//! is replaced.
//!
//! **Stride.** Overlapping differences m apart or less share samples, and at cluster size m
//! neighbouring ones are nearly equal: at m ≥ 2·[`STRIDE_DIVISOR`] the estimating equation
//! runs over every s-th difference, s = ⌊m/16⌋ ([`difference_stride`]), which costs 2T + T/16 ·
//! (a few) passes over all scales instead of one pass of T per scale (≈ 4.5× less on 22 dyadic
//! scales). Measured (R = 300 series of 2^17 samples, WN and WN + RW, m = 16 … 1024): the
//! strided estimate's variance is within 0.99–1.02 of the all-differences one (MC SE about
//! 0.02), and their difference has at most 0.9 % of that variance (s = m/8: 2.3–3.4 %, with
//! variance ratios up to 1.07; s = m/4: 10–13 %); the unit test
//! `stride_costs_no_precision` repeats a smaller version of this.
//!
//! Only rate input and the overlapping estimator are supported (the M-estimator needs the
//! individual differences). The stride-1 scales (m < 2·[`STRIDE_DIVISOR`]) are solved together,
//! each pass over the prefix sums forming their differences on the fly and serving every
//! scale's Newton step (`solve_lockstep`), so that the few small scales cost a handful of passes
//! in all instead of a buffer and five passes each. Memory: the T + 1 centred prefix sums and one
//! buffer of at most T/2 strided differences per worker thread, reused across the larger scales.

// One file per concept; an arrow points from a file to one that names it (no file names one
// after it):
//   biweight (Tukey's χ_c, its Gaussian constants) ← m_scale (the M-estimate of a mean square,
//   Newton on ln s) ← lockstep (the stride-1 scales solved together) ← estimators (the robust
//   AV and WV);
//   differences (centred prefix sums, strided differences) ← spikes (replacement before the
//   estimate), excess (the windows driving classical − robust) and estimators.
mod biweight;
mod differences;
mod estimators;
mod excess;
mod lockstep;
mod m_scale;
mod spikes;

pub use biweight::{Biweight, DEFAULT_EFFICIENCY, EFFICIENCY_RANGE};
pub use differences::{STRIDE_DIVISOR, difference_stride};
pub use estimators::{
    RobustAllanVariance, RobustScratch, robust_allan_variance, robust_allan_variance_from,
    robust_allan_variance_from_with, robust_haar_wavelet_variance,
};
pub use excess::{ExcessWindow, excess_windows, excess_windows_at};
pub use m_scale::{RobustScale, robust_mean_square, robust_mean_square_detail};
pub use spikes::{
    MAX_SPIKE_FRACTION, SPIKE_HALF_WINDOW, SPIKE_MAD_SAMPLE, SPIKE_THRESHOLD, SpikeReplacement,
    replace_spikes,
};
