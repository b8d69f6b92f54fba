//! Confidence intervals of the Allan variance, with their assumptions.
//!
//! Three families (select with [`crate::CiMethod`]; the third is [`crate::haar_wavelet_variance`]):
//!
//! 1. **Chi-square with equivalent degrees of freedom (default).** Assumes the AV estimate is
//!    distributed as AV·χ²_edf/edf, which holds closely for Gaussian power-law noise
//!    S_y(f) ∝ f^α. At each scale the noise exponent α is identified by the lag-1
//!    autocorrelation method of Riley & Greenhall (2004) on the non-overlapping cluster means
//!    (detrended by a least-squares line, at most 2 differencing steps, α clamped to −2..=2,
//!    the range where the AV converges; for the EDF the estimate is shifted conservatively by
//!    [`CONSERVATIVE_SE`] standard errors and interpolated between integer exponents, see
//!    [`NoiseId::alpha_edf`]), and the EDF is computed with Greenhall & Riley's
//!    general algorithm (Greenhall 2004, "Uncertainty of stability variances based on finite
//!    differences": exact basic sum for J <= 100, the published asymptotic tables beyond).
//!    Identification needs at least [`MIN_ID_CLUSTERS`] cluster means; at larger m the α of the
//!    nearest smaller scale is reused (Stable32 switches to the B1 ratio there). The interval is
//!    [edf·AV/χ²_{1−α/2}(edf), edf·AV/χ²_{α/2}(edf)] and is never negative. Non-Gaussian data,
//!    mixtures of several noise types at one scale and non-power-law processes (e.g. a
//!    Gauss-Markov near its correlation time) make it approximate.
//! 2. **Gaussian** (book Lemma 4.4, §4.3.3): AV ± z_{1−α/2}·√(σ̂²/M) where M is the number of
//!    squared differences and σ̂² a long-run variance of the series z_k = (X̄_k − X̄_{k−m})²/2,
//!    estimated by overlapping batch means (asymptotically the Bartlett/Newey-West estimator)
//!    with batch size b = ⌈10·s + M^{1/3}⌉ capped at ⌊M/2⌋, where s = 2m terms (overlapping)
//!    or 2 (non-overlapping) is the range over which z_k are correlated for white noise. Assumes
//!    the mixing and moment conditions of Lemma 4.4 (stationary increments — not met exactly
//!    by random walks at large m) and a large M/b. The lower bound can be negative (Remark
//!    4.7): it is kept in `avar_lo`, `adev_lo` is clipped to 0 and `lower_negative` is set.
//! 3. **Haar WV** with the `wv` η interval: see [`crate::haar_wavelet_variance`].

use rayon::prelude::*;
use statrs::distribution::{ContinuousCDF, Normal};

use crate::Cumulative;
use crate::config::{AvarConfig, CiMethod, Estimator};
use crate::error::AvarError;
use crate::haar::chi2_interval;
use crate::result::AvarPoint;

/// Minimum number of cluster means for the lag-1 ACF noise identification (Riley & Greenhall
/// recommend about 30).
pub const MIN_ID_CLUSTERS: usize = 30;
/// Greenhall's limit for evaluating the basic sum directly.
const J_MAX: f64 = 100.0;

/// Width, in standard errors of ρ, of the conservative shift of the exponent used for the EDF
/// (see [`NoiseId::alpha_edf`]).
pub const CONSERVATIVE_SE: f64 = 1.5;

/// Result of the lag-1 ACF noise identification.
///
/// ```
/// use avar::ci::identify_noise;
/// // a random walk (the steps of a deterministic pseudo-random sequence): r1 ≈ 1 gives
/// // ρ ≈ 1/2, so it is differenced once into white steps (ρ ≈ 0)
/// let mut s = 1u64; let mut acc = 0.0;
/// let rw: Vec<f64> = (0..2000).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
///     acc += (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5; acc }).collect();
/// let id = identify_noise(&rw).unwrap();
/// assert_eq!((id.d, id.alpha_rg), (1, -2));
/// assert_eq!(id.alpha_raw, -2.0 * (id.rho + id.d as f64));
/// assert!(id.alpha_edf <= id.alpha_rg as f64 && id.alpha_edf >= -2.0); // the conservative side
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseId {
    /// The real exponent used for the EDF: −2(ρ + k·se_ρ + d) with k = [`CONSERVATIVE_SE`] and
    /// se_ρ = (1/√n)/(1 + r1)² for n cluster means, clamped to −2..=2 and never above
    /// `alpha_rg`. A lower α gives a smaller EDF (wider interval), so an uncertain identification
    /// (few clusters at large m) errs toward the wider interval instead of mistaking white FM
    /// for flicker PM, whose EDF is up to ten times larger. The EDF is interpolated between
    /// the neighbouring integer exponents ([`edf_greenhall_real`]), which also softens the
    /// power-law assumption for spectra between two power laws (e.g. an AR(1) near its
    /// correlation time).
    pub alpha_edf: f64,
    /// Plain Riley-Greenhall integer exponent α = −round(2ρ) − 2d of the rate PSD S_y ∝ f^α
    /// (clamped to −2..=2).
    pub alpha_rg: i32,
    /// The unrounded estimate p = −2(ρ + d).
    pub alpha_raw: f64,
    /// Number of differencing steps taken.
    pub d: u32,
    /// ρ = r1 / (1 + r1) of the final series.
    pub rho: f64,
}

impl NoiseId {
    fn decide(r1: f64, d: u32, n: usize) -> NoiseId {
        let rho = r1 / (1.0 + r1);
        let se_rho = (1.0 / (n as f64).sqrt()) / ((1.0 + r1) * (1.0 + r1));
        let alpha_raw = -2.0 * (rho + d as f64);
        let di = 2 * d as i32;
        let alpha_rg = (-(2.0 * rho).round() as i32 - di).clamp(-2, 2);
        let alpha_edf = (-2.0 * (rho + CONSERVATIVE_SE * se_rho + d as f64))
            .clamp(-2.0, 2.0)
            .min(alpha_rg as f64);
        NoiseId {
            alpha_edf,
            alpha_rg,
            alpha_raw,
            d,
            rho,
        }
    }
}

fn lag1_acf(x: &[f64]) -> f64 {
    let mu = x.iter().sum::<f64>() / x.len() as f64;
    let mut a = 0.0;
    let mut b = 0.0;
    for w in x.windows(2) {
        a += (w[0] - mu) * (w[1] - mu);
    }
    for v in x {
        b += (v - mu) * (v - mu);
    }
    a / b
}

fn detrend_linear(x: &mut [f64]) {
    let n = x.len() as f64;
    let tm = (n - 1.0) / 2.0;
    let ym = x.iter().sum::<f64>() / n;
    let mut sxy = 0.0;
    let mut sxx = 0.0;
    for (i, v) in x.iter().enumerate() {
        let dt = i as f64 - tm;
        sxy += dt * (v - ym);
        sxx += dt * dt;
    }
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    for (i, v) in x.iter_mut().enumerate() {
        *v -= ym + slope * (i as f64 - tm);
    }
}

/// Lag-1 autocorrelation noise identification (Riley & Greenhall 2004) of rate (frequency)
/// data already averaged at the cluster size of interest: the series is detrended by a
/// least-squares line, then differenced until ρ = r1/(1 + r1) < 0.25 or d = 2; α = −round(2ρ) − 2d.
/// Returns `None` for fewer than [`MIN_ID_CLUSTERS`] values or a constant series.
///
/// ```
/// use avar::ci::identify_noise;
/// // a random walk of rate (α = −2): the steps of a deterministic pseudo-random sequence
/// let mut s = 1u64; let mut acc = 0.0;
/// let rw: Vec<f64> = (0..2000).map(|_| { s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
///     acc += (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5; acc }).collect();
/// assert_eq!(identify_noise(&rw).unwrap().alpha_rg, -2);
/// let white: Vec<f64> = rw.windows(2).map(|w| w[1] - w[0]).collect();
/// assert_eq!(identify_noise(&white).unwrap().alpha_rg, 0);
/// ```
pub fn identify_noise(means: &[f64]) -> Option<NoiseId> {
    if means.len() < MIN_ID_CLUSTERS {
        return None;
    }
    let n_id = means.len();
    let mut x = means.to_vec();
    detrend_linear(&mut x);
    let mut d = 0u32;
    loop {
        let r1 = lag1_acf(&x);
        if !r1.is_finite() {
            return None;
        }
        let rho = r1 / (1.0 + r1);
        if rho < 0.25 || d >= 2 {
            return Some(NoiseId::decide(r1, d, n_id));
        }
        x = x.windows(2).map(|w| w[1] - w[0]).collect();
        d += 1;
    }
}

// ---- Greenhall's EDF algorithm (Greenhall & Riley 2004, eqs. 7-13, tables 2-3), d = 2 ----

fn sw(t: f64, alpha: i32) -> f64 {
    match alpha {
        2 => -t.abs(),
        1 => {
            if t == 0.0 {
                0.0
            } else {
                t * t * t.abs().ln()
            }
        }
        0 => t.abs().powi(3),
        -1 => {
            if t == 0.0 {
                0.0
            } else {
                t.powi(4) * t.abs().ln()
            }
        }
        -2 => t.abs().powi(5),
        -3 => {
            if t == 0.0 {
                0.0
            } else {
                t.powi(6) * t.abs().ln()
            }
        }
        _ => t.abs().powi(7),
    }
}

fn sx(t: f64, f: f64, alpha: i32) -> f64 {
    if f.is_infinite() {
        return sw(t, alpha + 2);
    }
    f * f * (2.0 * sw(t, alpha) - sw(t - 1.0 / f, alpha) - sw(t + 1.0 / f, alpha))
}

fn sz(t: f64, f: f64, alpha: i32) -> f64 {
    6.0 * sx(t, f, alpha) - 4.0 * sx(t - 1.0, f, alpha) - 4.0 * sx(t + 1.0, f, alpha)
        + sx(t - 2.0, f, alpha)
        + sx(t + 2.0, f, alpha)
}

fn basic_sum(j: f64, m: f64, s: f64, f: f64, alpha: i32) -> f64 {
    let mut sum = sz(0.0, f, alpha).powi(2) + (1.0 - j / m) * sz(j / s, f, alpha).powi(2);
    let mut i = 1.0;
    while i < j {
        sum += 2.0 * (1.0 - i / m) * sz(i / s, f, alpha).powi(2);
        i += 1.0;
    }
    sum
}

/// The chi-square interval of an AV estimate `avar` with `edf` equivalent degrees of freedom
/// at level 1 − `alpha`: [edf·AV / χ²_{1−α/2}(edf), edf·AV / χ²_{α/2}(edf)] (NaN bounds for
/// edf ≤ 0), the interval of the default [`crate::CiMethod::ChiSquare`].
///
/// ```
/// // 2 EDF: χ²₂ quantiles are −2 ln(1 − p), so the bounds are closed forms
/// let (lo, hi) = avar::ci::chi_square_interval(1.0, 2.0, 0.05);
/// assert!((lo - 2.0 / (-2.0 * 0.025f64.ln())).abs() < 1e-9);
/// assert!((hi - 2.0 / (-2.0 * 0.975f64.ln())).abs() < 1e-9);
/// ```
pub fn chi_square_interval(avar: f64, edf: f64, alpha: f64) -> (f64, f64) {
    chi2_interval(avar, edf, alpha)
}

/// Equivalent degrees of freedom of the (overlapping or non-overlapping) Allan variance for
/// power-law noise S_y ∝ f^α, by Greenhall's general algorithm (Greenhall & Riley 2004) with
/// d = 2 (second differences of phase), F = m (unmodified variance), stride S = m (overlapping)
/// or 1. `n_phase` is the number of phase samples (rate samples + 1), `m` the cluster size.
/// `alpha` is clamped to −2..=2. Always > 0 for admissible input.
///
/// ```
/// use avar::ci::edf_greenhall;
/// // white FM, N = 1001 phase points, m = 10: NIST SP 1065 Table 5 gives
/// // (3(N−1)/(2m) − 2(N−2)/N)·4m²/(4m² + 5) = 146.2 (an older empirical fit); Greenhall's
/// // exact sum gives 135.1
/// let simple = (3.0 * 1000.0 / 20.0 - 2.0 * 999.0 / 1001.0) * 400.0 / 405.0;
/// let edf = edf_greenhall(0, 10, 1001, true);
/// assert!((edf / simple - 1.0).abs() < 0.1, "{edf} vs {simple}");
/// // at m = 1 the overlapping and non-overlapping estimators coincide
/// assert_eq!(edf_greenhall(0, 1, 1001, true), edf_greenhall(0, 1, 1001, false));
/// ```
pub fn edf_greenhall(alpha: i32, m: u64, n_phase: u64, overlapping: bool) -> f64 {
    let alpha = alpha.clamp(-2, 2);
    let d = 2.0;
    let mf = m as f64;
    let n = n_phase as f64;
    let f = mf;
    let s = if overlapping { mf } else { 1.0 };
    let l = mf / f + mf * d;
    let big_m = 1.0 + (s * (n - l) / mf).floor();
    if big_m < 1.0 {
        return f64::NAN;
    }
    let j = big_m.min((d + 1.0) * s);
    let r = big_m / s;
    let inv = if alpha <= 0 {
        // case 2, unmodified variances, alpha <= 0
        if j <= J_MAX {
            let mp = if mf * (d + 1.0) <= J_MAX {
                mf
            } else {
                f64::INFINITY
            };
            basic_sum(j, big_m, s, mp, alpha) / (sz(0.0, mp, alpha).powi(2) * big_m)
        } else if r > d + 1.0 {
            let (a0, a1) = match alpha {
                0 => (2.0 / 3.0, 1.0 / 3.0),
                -1 => (0.852, 0.375),
                _ => (1.079, 0.368),
            };
            (a0 - a1 / r) / r
        } else {
            let mp = J_MAX / r;
            basic_sum(J_MAX, J_MAX, mp, f64::INFINITY, alpha)
                / (sz(0.0, f64::INFINITY, alpha).powi(2) * J_MAX)
        }
    } else if alpha == 1 {
        // case 3, unmodified variances, alpha = 1 (flicker PM)
        if j <= J_MAX {
            basic_sum(j, big_m, s, mf, 1) / (sz(0.0, mf, 1).powi(2) * big_m)
        } else if r > d + 1.0 {
            let (a0, a1) = (790.0, 410.0);
            let (b0, b1) = (15.23, 12.0);
            (a0 - a1 / r) / ((b0 + b1 * mf.ln()).powi(2) * r)
        } else {
            let mp = J_MAX / r;
            let (b0, b1) = (15.23, 12.0);
            basic_sum(J_MAX, J_MAX, mp, mp, 1) / ((b0 + b1 * mf.ln()).powi(2) * J_MAX)
        }
    } else {
        // case 4, alpha = 2 (white PM): a0 = C(4d,2d)/C(2d,d)^2 = 70/36, a1 = d/2
        let a0 = 70.0 / 36.0;
        let a1 = d / 2.0;
        if r.ceil() <= d {
            // too few terms for the asymptotic form: fall back to the direct sum
            basic_sum(j, big_m, s, mf, 2) / (sz(0.0, mf, 2).powi(2) * big_m)
        } else {
            (a0 - a1 / r) / big_m
        }
    };
    1.0 / inv
}

/// [`edf_greenhall`] at a real exponent: log-linear interpolation between the neighbouring
/// integer exponents (α clamped to −2..=2).
///
/// ```
/// use avar::ci::{edf_greenhall, edf_greenhall_real};
/// assert_eq!(edf_greenhall_real(-1.0, 64, 10_001, true), edf_greenhall(-1, 64, 10_001, true));
/// let mid = edf_greenhall_real(-0.5, 64, 10_001, true);
/// let geo = (edf_greenhall(-1, 64, 10_001, true) * edf_greenhall(0, 64, 10_001, true)).sqrt();
/// assert!((mid / geo - 1.0).abs() < 1e-12);
/// ```
pub fn edf_greenhall_real(alpha: f64, m: u64, n_phase: u64, overlapping: bool) -> f64 {
    let a = if alpha.is_nan() {
        0.0
    } else {
        alpha.clamp(-2.0, 2.0)
    };
    let lo = a.floor();
    let w = a - lo;
    let e_lo = edf_greenhall(lo as i32, m, n_phase, overlapping);
    if w == 0.0 {
        return e_lo;
    }
    let e_hi = edf_greenhall(lo as i32 + 1, m, n_phase, overlapping);
    (e_lo.ln() * (1.0 - w) + e_hi.ln() * w).exp()
}

/// Fills the CI fields of `points` according to `config.ci`.
pub(crate) fn apply(
    cum: &Cumulative<'_>,
    config: &AvarConfig,
    points: &mut [AvarPoint],
) -> Result<(), AvarError> {
    match config.ci {
        CiMethod::None => Ok(()),
        CiMethod::ChiSquare => {
            chi_square(cum, config, points);
            Ok(())
        }
        CiMethod::Gaussian => {
            gaussian(cum, config, points);
            Ok(())
        }
    }
}

/// The non-overlapping cluster means of one scale, read from cumulative sums at the cluster
/// boundaries: y_i = (c(i + 1) − c(i))·`inv`, where c(i) = `c[i·step − k0]` is the cumulative
/// sum at sample i·m. The whole cumulative sum gives step = m, k0 = 0; a stored copy of the
/// boundary values step = 1; a window of the cumulative sum starting at sample k0 step = m.
/// Every view of the same values gives the same y_i, bit for bit.
#[derive(Clone, Copy)]
pub(crate) struct ClusterMeans<'a> {
    pub(crate) c: &'a [f64],
    pub(crate) step: usize,
    pub(crate) k0: usize,
    pub(crate) inv: f64,
}

impl ClusterMeans<'_> {
    /// y_lo, y_{lo+1}, … into `out` (strided reads of the cumulative sums).
    #[inline]
    fn gather(&self, lo: usize, out: &mut [f64]) {
        let mut it = self.c[lo * self.step - self.k0..].iter().step_by(self.step);
        let mut prev = it.next().copied().unwrap_or(0.0);
        for (v, &next) in out.iter_mut().zip(it) {
            *v = (next - prev) * self.inv;
            prev = next;
        }
    }
}

/// Cluster means per block of the identification (blocks are summed in parallel, their
/// parts added in block order: the grid depends only on the number of means).
pub(crate) const ID_BLOCK: usize = 1 << 14;
/// Values per sub-block gathered into a stack buffer, then summed with 8 lanes.
const ID_SUB: usize = 512;

/// Sum of the 8 lanes in a fixed order.
#[inline]
fn red8(v: [f64; 8]) -> f64 {
    ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]))
}

/// Block `b` of the least-squares line through (i, y_i), i < n: (Σ y_i, Σ (i − tm)·y_i).
pub(crate) fn fit_block(y: &ClusterMeans<'_>, b: usize, n: usize) -> (f64, f64) {
    let tm = (n as f64 - 1.0) / 2.0;
    let (mut sy, mut sty) = ([0.0f64; 8], [0.0f64; 8]);
    let mut buf = [0.0f64; ID_SUB];
    let end = ((b + 1) * ID_BLOCK).min(n);
    let mut sb = b * ID_BLOCK;
    while sb < end {
        let ns = (end - sb).min(ID_SUB);
        y.gather(sb, &mut buf[..ns]);
        // i − tm, exact (half-integers far below 2^53)
        let t0 = sb as f64 - tm;
        let mut it = buf[..ns].chunks_exact(8);
        let mut k0 = 0u32;
        for ch in &mut it {
            for l in 0..8 {
                sy[l] += ch[l];
                sty[l] += (t0 + (k0 + l as u32) as f64) * ch[l];
            }
            k0 += 8;
        }
        for (l, &v) in it.remainder().iter().enumerate() {
            sy[l] += v;
            sty[l] += (t0 + (k0 + l as u32) as f64) * v;
        }
        sb += ns;
    }
    (red8(sy), red8(sty))
}

/// The residuals r_i = y_i − (ȳ + slope·(i − tm)) of the line through the n cluster means,
/// and the means μ_d of their d-th differences (d = 0, 1, 2; from the end points, since the
/// residuals have mean 0).
#[derive(Clone, Copy, Debug)]
pub(crate) struct IdLine {
    n: usize,
    ym: f64,
    slope: f64,
    mu: [f64; 3],
}

impl IdLine {
    /// The line from the fit blocks' parts (in block order) and y_0, y_1, y_{n−2}, y_{n−1}.
    pub(crate) fn new(n: usize, parts: &[(f64, f64)], ends: [f64; 4]) -> IdLine {
        let nf = n as f64;
        let tm = (nf - 1.0) / 2.0;
        let sy: f64 = parts.iter().map(|p| p.0).sum();
        let sty: f64 = parts.iter().map(|p| p.1).sum();
        let ym = sy / nf;
        let sxx = nf * (nf * nf - 1.0) / 12.0;
        let slope = if sxx > 0.0 { sty / sxx } else { 0.0 };
        let r = |i: usize, y: f64| y - (ym + slope * (i as f64 - tm));
        let (r0, r1, rn2, rn1) = (
            r(0, ends[0]),
            r(1, ends[1]),
            r(n - 2, ends[2]),
            r(n - 1, ends[3]),
        );
        let mu = [
            0.0,
            (rn1 - r0) / (n - 1) as f64,
            ((rn1 - rn2) - (r1 - r0)) / (n - 2) as f64,
        ];
        IdLine { n, ym, slope, mu }
    }

    /// Number of d-th differences of the residuals, and the number of blocks they take.
    pub(crate) fn blocks(&self, d: usize) -> usize {
        (self.n - d).div_ceil(ID_BLOCK)
    }
}

/// Block `b` of level d: (Σ x_i x_{i+1}, Σ x_i²) of x = (d-th difference of the residuals) − μ_d,
/// in one tight loop with the last d + 1 residuals carried along.
pub(crate) fn level_block(y: &ClusterMeans<'_>, line: &IdLine, d: usize, b: usize) -> (f64, f64) {
    let len = line.n - d;
    let tm = (line.n as f64 - 1.0) / 2.0;
    let (ym, slope, mu_d) = (line.ym, line.slope, line.mu[d]);
    let lo = b * ID_BLOCK;
    let end = ((b + 1) * ID_BLOCK).min(len);
    // sub-blocks of ID_SUB values of x^(d) − μ_d (plus the one after, for the lag product),
    // formed in a small buffer, then summed with 8 lanes
    let mut rb = [0.0f64; ID_SUB + 3];
    let mut xb = [0.0f64; ID_SUB + 1];
    let (mut lag, mut sq) = ([0.0f64; 8], [0.0f64; 8]);
    let mut sb = lo;
    while sb < end {
        let se = (sb + ID_SUB).min(end);
        // x_i for i in [sb, xe): one past the sub-block when it exists
        let xe = (se + 1).min(len);
        let nx = xe - sb;
        y.gather(sb, &mut rb[..nx + d]);
        let t0 = sb as f64 - tm;
        for (k, v) in rb[..nx + d].iter_mut().enumerate() {
            *v -= ym + slope * (t0 + (k as u32) as f64);
        }
        for (k, v) in xb[..nx].iter_mut().enumerate() {
            let x = match d {
                0 => rb[k],
                1 => rb[k + 1] - rb[k],
                _ => (rb[k + 2] - rb[k + 1]) - (rb[k + 1] - rb[k]),
            };
            *v = x - mu_d;
        }
        let ns = se - sb;
        // squares of x_sb .. x_{se−1}; products x_i x_{i+1} for i + 1 < xe
        let np = nx - 1;
        let mut it = xb[..ns].chunks_exact(8);
        for ch in &mut it {
            for l in 0..8 {
                sq[l] += ch[l] * ch[l];
            }
        }
        for (l, v) in it.remainder().iter().enumerate() {
            sq[l] += v * v;
        }
        let (a, bb) = (&xb[..np], &xb[1..np + 1]);
        let mut ia = a.chunks_exact(8);
        let mut ib = bb.chunks_exact(8);
        for (ca, cb) in (&mut ia).zip(&mut ib) {
            for l in 0..8 {
                lag[l] += ca[l] * cb[l];
            }
        }
        for (l, (va, vb)) in ia.remainder().iter().zip(ib.remainder()).enumerate() {
            lag[l] += va * vb;
        }
        sb = se;
    }
    (red8(lag), red8(sq))
}

/// What the parts of level d (in block order) say: `Ok(id)` the identification (`None`: the
/// lag-1 ACF is not finite), `Err(())` difference once more.
pub(crate) fn decide_level(
    parts: &[(f64, f64)],
    d: usize,
    n: usize,
) -> Result<Option<NoiseId>, ()> {
    let num: f64 = parts.iter().map(|p| p.0).sum();
    let den: f64 = parts.iter().map(|p| p.1).sum();
    let r1 = num / den;
    if !r1.is_finite() {
        return Ok(None);
    }
    let rho = r1 / (1.0 + r1);
    if rho < 0.25 || d >= 2 {
        return Ok(Some(NoiseId::decide(r1, d as u32, n)));
    }
    Err(())
}

/// Lag-1 ACF noise identification ([`identify_noise`]'s method) on the n cluster means of
/// `y`, computed block by block in parallel (no buffer of the means): identical in exact
/// arithmetic to [`identify_noise`] on the materialised means. `None` for fewer than
/// [`MIN_ID_CLUSTERS`] means or a constant series.
pub(crate) fn identify_cluster_means(y: &ClusterMeans<'_>, n: usize) -> Option<NoiseId> {
    if n < MIN_ID_CLUSTERS {
        return None;
    }
    let fit: Vec<(f64, f64)> = (0..n.div_ceil(ID_BLOCK))
        .into_par_iter()
        .map(|b| fit_block(y, b, n))
        .collect();
    let at = |i: usize| {
        let mut v = [0.0];
        y.gather(i, &mut v);
        v[0]
    };
    let line = IdLine::new(n, &fit, [at(0), at(1), at(n - 2), at(n - 1)]);
    // level by level (most scales stop at d = 0)
    for d in 0..=2usize {
        let parts: Vec<(f64, f64)> = (0..line.blocks(d))
            .into_par_iter()
            .map(|b| level_block(y, &line, d, b))
            .collect();
        if let Ok(id) = decide_level(&parts, d, n) {
            return id;
        }
    }
    None
}

/// [`identify_cluster_means`] at cluster size m from the whole cumulative sum.
pub(crate) fn identify_from_cumulative(cum: &Cumulative<'_>, m: usize) -> Option<NoiseId> {
    let c: &[f64] = &cum.c;
    let n = (c.len() - 1) / m;
    let y = ClusterMeans {
        c,
        step: m,
        k0: 0,
        inv: cum.factor / m as f64,
    };
    identify_cluster_means(&y, n)
}

fn chi_square(cum: &Cumulative<'_>, config: &AvarConfig, points: &mut [AvarPoint]) {
    let ids: Vec<Option<NoiseId>> = points
        .par_iter()
        .map(|p| identify_from_cumulative(cum, p.m as usize))
        .collect();
    apply_chi_square(&ids, cum.t(), config, points);
}

/// The chi-square intervals from the identification at each point (`None`: too few clusters,
/// or a constant series) for T rate samples.
pub(crate) fn apply_chi_square(
    ids: &[Option<NoiseId>],
    t: usize,
    config: &AvarConfig,
    points: &mut [AvarPoint],
) {
    let mut last: Option<(f64, i32)> = None;
    let first_known = ids
        .iter()
        .flatten()
        .next()
        .map(|i| (i.alpha_edf, i.alpha_rg));
    let n_phase = t as u64 + 1;
    for (p, id) in points.iter_mut().zip(ids) {
        let (alpha, alpha_rg) = match id {
            Some(id) => (id.alpha_edf, id.alpha_rg),
            // too few clusters: reuse the nearest smaller identified scale (white FM if none)
            None => last.or(first_known).unwrap_or((0.0, 0)),
        };
        last = Some((alpha, alpha_rg));
        let edf = edf_greenhall_real(
            alpha,
            p.m,
            n_phase,
            config.estimator == Estimator::Overlapping,
        );
        p.noise_alpha = Some(alpha_rg);
        if edf.is_finite() && edf > 0.0 {
            p.edf = Some(edf);
            let (lo, hi) = chi2_interval(p.avar, edf, config.alpha);
            p.set_interval(lo, hi);
        }
    }
}

/// Batch size of the overlapping-batch-means long-run variance for M terms correlated over `s` lags.
pub(crate) fn obm_batch(m_terms: usize, s: usize) -> usize {
    let b = (10.0 * s as f64 + (m_terms as f64).cbrt()).ceil() as usize;
    b.min(m_terms / 2).max(1)
}

fn gaussian(cum: &Cumulative<'_>, config: &AvarConfig, points: &mut [AvarPoint]) {
    let z = Normal::standard().inverse_cdf(1.0 - config.alpha / 2.0);
    let c = &cum.c;
    let overlapping = config.estimator == Estimator::Overlapping;
    points.par_iter_mut().for_each(|p| {
        let m = p.m as usize;
        let scale = cum.factor / m as f64;
        let stride = if overlapping { 1 } else { m };
        let n_terms = p.n_terms as usize;
        if n_terms < 4 {
            return;
        }
        let b = obm_batch(n_terms, if overlapping { 2 * m } else { 2 });
        // stream z_k = d_k^2 / 2 (AV units); window sums of b consecutive z from a ring of prefixes
        let mut ring = vec![0.0f64; b + 1];
        let mut pref = 0.0f64;
        let mean = p.avar;
        let mut ss = 0.0f64;
        let mut i = 0usize;
        let mut k = 2 * m;
        while k < c.len() {
            let d = ((c[k] - c[k - m]) - (c[k - m] - c[k - 2 * m])) * scale;
            pref += 0.5 * d * d;
            i += 1;
            ring[i % (b + 1)] = pref;
            if i >= b {
                let w = (pref - ring[(i - b) % (b + 1)]) / b as f64;
                ss += (w - mean) * (w - mean);
            }
            k += stride;
        }
        // ss = Σ (W_j − z̄)² over the M − b + 1 batch means W_j
        let mm = n_terms as f64;
        let bb = b as f64;
        let lrv = mm * bb / ((mm - bb) * (mm - bb + 1.0)) * ss;
        let se = (lrv / mm).sqrt();
        p.set_interval(p.avar - z * se, p.avar + z * se);
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::borrow::Cow;

    /// The streaming identification equals the materialised one (same ρ up to rounding).
    #[test]
    fn streaming_noise_id_matches_materialised() {
        let mut s = 7u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let white: Vec<f64> = (0..100_000).map(|_| next()).collect();
        let mut acc = 0.0;
        let walk: Vec<f64> = white
            .iter()
            .map(|v| {
                acc += v;
                acc + 3.0 * next()
            })
            .collect();
        for x in [&white, &walk] {
            let mut c = vec![0.0];
            for v in x.iter() {
                c.push(c.last().unwrap() + v);
            }
            let t = c.len() - 1;
            let cum = Cumulative {
                c: Cow::Owned(c),
                factor: 1.0,
                mean: 0.0,
                t,
            };
            for m in [1usize, 2, 16, 100, 1000, 3000] {
                let means: Vec<f64> = x
                    .chunks_exact(m)
                    .map(|ch| ch.iter().sum::<f64>() / m as f64)
                    .collect();
                let a = identify_noise(&means).unwrap();
                let b = identify_from_cumulative(&cum, m).unwrap();
                assert_eq!((a.alpha_rg, a.d), (b.alpha_rg, b.d), "m={m}");
                assert!(
                    (a.rho - b.rho).abs() < 1e-9,
                    "m={m}: {} vs {}",
                    a.rho,
                    b.rho
                );
            }
            assert!(identify_from_cumulative(&cum, 100_000 / 29).is_none());
        }
    }
}
