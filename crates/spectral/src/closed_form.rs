//! Closed-form theoretical Allan variance (AV) of every latent process, its analytic
//! gradient with respect to the process parameters, and the theoretical Haar wavelet
//! variance (WV) of the GMWM (`../shared/REFERENCES.md` §2–§3).
//!
//! | process | AV(m) |
//! |---|---|
//! | WN  | σ² / m |
//! | QN  | 3 Q² / m² |
//! | RW  | γ² (2m² + 1) / (6m) |
//! | DR  | ω² m² / 2 |
//! | AR1 | v² (m − 3φ − mφ² + 4φ^(m+1) − φ^(2m+1)) / (m² (1−φ)² (1−φ²)) |
//! | GM  | AR1 with φ = e^(−βΔt), v² = σ_G² (1 − e^(−2βΔt)) |
//! | MA1 | σ² (m (1+θ)² − 3θ) / m²  (book Example 4.1, rearranged) |
//! | SIN | α² sin⁴(βm/2) / (m sin(β/2))² |
//! | BI  | B² Σ_i u_i H(1/T_i, m): the GM factor of each state (T_i samples, variance u_i B², [`processes::BiasInstability`]) |
//!
//! # Numerical care
//! The AR1 numerator N(φ) = m(1−φ²) − φ(1−φ^m)(3−φ^m) has a triple root at φ = 1: for
//! φ → 1 (typical IMU models have φ = 0.995 … 0.99999, GM even closer to 1) the textbook
//! formula loses up to −3·log10((2m+1)(1−φ)) digits. Here, with L = −ln φ (= βΔt for GM,
//! exact), N is evaluated as
//! - for y = (2m+1)L ≤ 2: the Taylor series N = Σ_{k≥3} (−L)^k c_k / k!,
//!   c_k = 4(m+1)^k − (2m+1)^k − m 2^k − 3 (c_0 = c_1 = c_2 = 0 exactly), divided by L³
//!   analytically, with the ratio (L/(1−φ))³ applied afterwards;
//! - otherwise directly, with φ^m = ±exp(m ln|φ|) and 1 − φ^m by `expm1` (so φ near −1 is
//!   also accurate).
//!
//! The derivatives use the same two branches (logarithmic derivatives in L on the series
//! branch; on the direct branch the parts −2mφ − m(1−φ) of N' − N/(1+φ) are combined
//! exactly into −m(1+φ)). For even m and m(1+φ) < 1 the AR1 factor F = AV/v² is taken
//! from the reflection F(−ψ) = (2/m − (1−ψ)² F(ψ))/(1+ψ)² (from N(−ψ) = 2m(1−ψ²) − N(ψ)),
//! which keeps dAV/dφ accurate at φ → −1. Checked against double-double references to
//! ≤ 1e-15 (AV) and ≤ 5e-15 (gradient) for φ up to 1 − 1e-9 and down to −1 + 1e-7,
//! m = 1 … 2^30 (`tests/extended_reference.rs`). The MA1 form m(1+θ)² − 3θ avoids the cancellation of the book's
//! (1+θ²)m + (2m−3)θ at θ ≈ −1.

use crate::error::{Result, check_m, check_rate, check_tau_j};
use processes::{Model, Process};

/// Largest y = (2m+1)·L for which the AR1 numerator is summed as a Taylor series.
const SERIES_MAX_Y: f64 = 2.0;
/// Relative size of a Taylor term below which the series is considered converged.
const SERIES_REL_EPS: f64 = 1e-18;
/// Hard cap on the number of Taylor terms (y ≤ 2 needs about 30).
const SERIES_MAX_TERMS: usize = 120;

/// The AR1 coefficient in the forms the formulas need, each computed accurately.
#[derive(Debug, Clone, Copy)]
struct Phi {
    /// φ itself.
    phi: f64,
    /// a = 1 − φ.
    a: f64,
    /// b = 1 + φ.
    b: f64,
    /// L = −ln φ for φ > 0.
    l: Option<f64>,
}

impl Phi {
    /// From φ given as a number (AR1): 1 − φ and 1 + φ are exact in the ranges where
    /// they matter (Sterbenz), and −ln φ = −log1p(−(1 − φ)) is accurate near 1.
    fn from_phi(phi: f64) -> Self {
        let a = 1.0 - phi;
        let l = if phi > 0.0 {
            Some(if phi >= 0.5 { -(-a).ln_1p() } else { -phi.ln() })
        } else {
            None
        };
        Phi {
            phi,
            a,
            b: 1.0 + phi,
            l,
        }
    }

    /// From L = βΔt (GM): φ = e^(−L), 1 − φ = −expm1(−L), no rounding through φ.
    fn from_l(l: f64) -> Self {
        let phi = (-l).exp();
        Phi {
            phi,
            a: -(-l).exp_m1(),
            b: 1.0 + phi,
            l: Some(l),
        }
    }
}

/// G(L) = N(L)/L³ and G'(L) by their Taylor series (valid for (2m+1)L ≤ [`SERIES_MAX_Y`]).
fn numerator_series(m: f64, l: f64, grad: bool) -> (f64, f64) {
    // c_k L^(k-3) = 4(m+1)^3 u1^(k-3) − (2m+1)^3 u2^(k-3) − 8m u3^(k-3) − 3 L^(k-3)
    // c_k L^(k-4) = 4(m+1)^4 u1^(k-4) − (2m+1)^4 u2^(k-4) − 16m u3^(k-4) − 3 L^(k-4)
    let (m1, m2) = (m + 1.0, 2.0 * m + 1.0);
    let (u1, u2, u3) = (m1 * l, m2 * l, 2.0 * l);
    let (a3, b3) = (4.0 * m1 * m1 * m1, m2 * m2 * m2);
    let (a4, b4) = (a3 * m1, b3 * m2);
    // powers for G: index k−3; for G': index k−4.
    let (mut p1, mut p2, mut p3, mut p0) = (1.0f64, 1.0f64, 1.0f64, 1.0f64);
    let (mut q1, mut q2, mut q3, mut q0) = (1.0f64, 1.0f64, 1.0f64, 1.0f64);
    let mut fact = 6.0f64; // k! at k = 3
    let mut g = 0.0;
    let mut gp = 0.0;
    let mut sign = -1.0; // (−1)^k at k = 3
    let mut small = 0;
    for k in 3..SERIES_MAX_TERMS {
        let ck = a3 * p1 - b3 * p2 - 8.0 * m * p3 - 3.0 * p0;
        let tg = sign * ck / fact;
        g += tg;
        let mut tgp = 0.0;
        if grad && k >= 4 {
            let ck4 = a4 * q1 - b4 * q2 - 16.0 * m * q3 - 3.0 * q0;
            tgp = sign * ck4 * (k as f64 - 3.0) / fact;
            gp += tgp;
            q1 *= u1;
            q2 *= u2;
            q3 *= u3;
            q0 *= l;
        }
        p1 *= u1;
        p2 *= u2;
        p3 *= u3;
        p0 *= l;
        sign = -sign;
        fact *= (k + 1) as f64;
        if tg.abs() <= SERIES_REL_EPS * g.abs() && tgp.abs() <= SERIES_REL_EPS * gp.abs() {
            small += 1;
            if small >= 2 {
                break;
            }
        } else {
            small = 0;
        }
    }
    (g, gp)
}

/// (a − Lφ)/(L a) = 1/L − φ/a ≥ 0, without cancellation for small L.
fn q_term(p: &Phi, l: f64) -> f64 {
    if l >= 0.5 {
        return (p.a - l * p.phi) / (l * p.a);
    }
    // a − Lφ = 1 − (1+L)e^{−L} = L² Σ_{k≥2} (−1)^k (k−1) L^(k−2) / k!
    let mut s = 0.0;
    let mut pow = 1.0; // L^(k−2)
    let mut fact = 2.0;
    let mut sign = 1.0;
    for k in 2..40 {
        let t = sign * (k as f64 - 1.0) * pow / fact;
        s += t;
        if t.abs() < 1e-18 * s.abs() {
            break;
        }
        pow *= l;
        fact *= (k + 1) as f64;
        sign = -sign;
    }
    // (a − Lφ)/(L a) = s·L/a (no L² that could underflow)
    s * (l / p.a)
}

/// φ^m and 1 − φ^m, both accurate (sign-aware, `expm1` near |φ| = 1).
fn phi_pow(p: &Phi, m: u64) -> (f64, f64) {
    if p.phi == 0.0 {
        return (0.0, 1.0);
    }
    let mf = m as f64;
    // ln|φ| accurately: near +1 through L, near −1 through log1p(−(1+φ)).
    let ln_abs = match p.l {
        Some(l) => -l,
        None => {
            if p.phi <= -0.5 {
                (-p.b).ln_1p()
            } else {
                (-p.phi).ln()
            }
        }
    };
    let x = mf * ln_abs;
    let odd_negative = p.phi < 0.0 && m % 2 == 1;
    if odd_negative {
        let mag = x.exp();
        (-mag, 1.0 + mag)
    } else {
        (x.exp(), -x.exp_m1())
    }
}

/// The AR1 factor F(φ, m) = AV / v² and its derivative dF/dφ.
fn ar1_factor(p: &Phi, m: u64, grad: bool) -> (f64, f64) {
    let mf = m as f64;
    if p.phi <= -0.5 && m.is_multiple_of(2) && mf * p.b < 1.0 {
        // Even m, φ = −ψ near −1 (m(1+φ) < 1): N(−ψ) = 2m(1−ψ²) − N(ψ) gives
        // F(−ψ) = (2/m − (1−ψ)² F(ψ)) / (1+ψ)², with F(ψ) from the stable φ > 0 branches;
        // the direct formula would lose ≈ log10(1/(m(1+φ))) digits in dF/dφ there (and
        // this reflection ≈ log10(m(1+φ)) digits beyond it).
        let psi = Phi::from_phi(-p.phi);
        let (fp_, dfp) = ar1_factor(&psi, m, grad);
        let (a, b) = (psi.a, psi.b);
        let f = (2.0 / mf - a * a * fp_) / (b * b);
        // dF(−ψ)/dψ = (2aF(ψ) − a²F'(ψ))/(1+ψ)² − 2F(−ψ)/(1+ψ); d/dφ = −d/dψ
        let dpsi = (2.0 * a * fp_ - a * a * dfp) / (b * b) - 2.0 * f / b;
        return (f, -dpsi);
    }
    if let Some(l) = p.l
        && (2.0 * mf + 1.0) * l <= SERIES_MAX_Y
    {
        let (g, gp) = numerator_series(mf, l, grad);
        let r = l / p.a;
        let f = g * r * r * r / (mf * mf * p.b);
        if !grad {
            return (f, f64::NAN);
        }
        let f_l = f * (gp / g + 3.0 * q_term(p, l) + p.phi / p.b);
        return (f, -f_l / p.phi);
    }
    let (pm, e) = phi_pow(p, m);
    let phi = p.phi;
    let n = mf * p.a * p.b - phi * e * (2.0 + e);
    let d = mf * mf * p.a * p.a * p.a * p.b;
    let f = n / d;
    // F' = (N' − N/b + 3N/a)/D with N' = −2mφ − 3 + 4(m+1)φ^m − (2m+1)φ^2m; the parts
    // −2mφ − ma of N' − N/b are combined exactly into −mb (they cancel for φ → −1).
    let t1 = -mf * p.b - 3.0 + 4.0 * (mf + 1.0) * pm - (2.0 * mf + 1.0) * pm * pm
        + phi * e * (2.0 + e) / p.b;
    let fp = (t1 + 3.0 * n / p.a) / d;
    (f, fp)
}

/// The AR1 factor F(φ, m) = AV / v² (AV per unit innovation variance) and dF/dφ, for
/// φ ∈ (−1, 1) and m ≥ 1 samples: the closed form of [`allan_variance`] without validation
/// or allocation, for optimizers that evaluate it many times (NaN outside the domain).
///
/// ```
/// use processes::{Ar1, Process};
/// use spectral::{allan_variance_with_gradient, closed_form::ar1_unit_avar};
/// let (f, df) = ar1_unit_avar(0.99, 16);
/// let (av, g) = allan_variance_with_gradient(&Process::from(Ar1::new(0.99, 2.0)?), 16, 1.0)?;
/// assert_eq!((2.0 * f, 2.0 * df), (av, g[0]));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn ar1_unit_avar(phi: f64, m: u64) -> (f64, f64) {
    if !(phi > -1.0 && phi < 1.0) || m == 0 {
        return (f64::NAN, f64::NAN);
    }
    ar1_factor(&Phi::from_phi(phi), m, true)
}

/// The GM factor H(L, m) = AV / σ_G² (AV per unit stationary variance) and dH/dL, for
/// L = βΔt > 0 and m ≥ 1 samples, without validation or allocation (see [`ar1_unit_avar`]).
///
/// ```
/// use processes::{GaussMarkov, Process};
/// use spectral::{allan_variance, closed_form::gm_unit_avar};
/// let (h, _) = gm_unit_avar(0.01, 64);
/// let av = allan_variance(&Process::from(GaussMarkov::new(1.0, 3.0)?), 64, 100.0)?;
/// assert_eq!(3.0 * h, av);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn gm_unit_avar(l: f64, m: u64) -> (f64, f64) {
    if !(l > 0.0 && l.is_finite()) || m == 0 {
        return (f64::NAN, f64::NAN);
    }
    gm_factor(l, m, true)
}

/// The GM factor H(L, m) = AV / σ_G² and dH/dL, L = βΔt.
fn gm_factor(l: f64, m: u64, grad: bool) -> (f64, f64) {
    let p = Phi::from_l(l);
    let mf = m as f64;
    if (2.0 * mf + 1.0) * l <= SERIES_MAX_Y {
        let (g, gp) = numerator_series(mf, l, grad);
        let r = l / p.a;
        // H = (1 − φ²) F = N / (m² a²) = G L³ / (m² a²)
        let h = g * r * r * l / (mf * mf);
        if !grad {
            return (h, f64::NAN);
        }
        let h_l = h * (gp / g + 3.0 * q_term(&p, l) + p.phi / p.a);
        return (h, h_l);
    }
    let (f, fp) = ar1_factor(&p, m, grad);
    let one_m_phi2 = p.a * p.b;
    // d/dL = −φ d/dφ; d(1 − φ²)/dL = 2φ².
    let h = one_m_phi2 * f;
    let h_l = 2.0 * p.phi * p.phi * f - p.phi * one_m_phi2 * fp;
    (h, h_l)
}

/// AV and its gradient (in the order of [`Process::params`]) after validation; with
/// `grad = false` only the AV is meaningful (the AR1/GM gradient entries are NaN).
fn av_and_gradient(process: &Process, m: u64, rate_hz: f64, grad: bool) -> Result<(f64, Vec<f64>)> {
    let rate = check_rate(rate_hz)?;
    let mf = check_m(m)? as f64;
    Ok(match *process {
        Process::WhiteNoise(p) => (p.sigma2() / mf, vec![1.0 / mf]),
        Process::QuantizationNoise(p) => {
            let k = 3.0 / (mf * mf);
            (p.q2() * k, vec![k])
        }
        Process::RandomWalk(p) => {
            let k = mf / 3.0 + 1.0 / (6.0 * mf);
            (p.gamma2() * k, vec![k])
        }
        Process::Drift(p) => {
            let w = p.omega();
            (0.5 * (w * mf) * (w * mf), vec![w * mf * mf])
        }
        Process::Ma1(p) => {
            let (t, s2) = (p.theta(), p.sigma2());
            let k = (mf * (1.0 + t) * (1.0 + t) - 3.0 * t) / (mf * mf);
            let dk = (2.0 * mf * (1.0 + t) - 3.0) / (mf * mf);
            (s2 * k, vec![s2 * dk, k])
        }
        Process::Ar1(p) => {
            let (f, fp) = ar1_factor(&Phi::from_phi(p.phi()), m, grad);
            (p.sigma2() * f, vec![p.sigma2() * fp, f])
        }
        Process::GaussMarkov(g) => {
            let dt = 1.0 / rate;
            let (h, h_l) = gm_factor(g.beta() * dt, m, grad);
            (g.sigma2() * h, vec![g.sigma2() * h_l * dt, h])
        }
        Process::BiasInstability(b) => {
            // the states are GMs with L_i = 1/T_i per sample; AV ∝ B², so ∂AV/∂B = 2 AV / B
            let (t, u) = b.band().states()?;
            let unit: f64 = t
                .iter()
                .zip(&u)
                .map(|(&t, &u)| u * gm_factor(1.0 / t, m, false).0)
                .sum();
            let b2 = b.b() * b.b();
            (b2 * unit, vec![2.0 * b.b() * unit])
        }
        Process::ArP(a) => {
            // AV ∝ σ², so ∂AV/∂σ² = AV/σ²; ∂AV/∂φ_j by central differences (step 1e-6, one
            // sided where a step would leave the stationary region)
            let av = arp_avar(&a, m);
            let mut g = Vec::with_capacity(a.order() + 1);
            if grad {
                let phi = a.phi();
                for j in 0..a.order() {
                    let h = 1e-6;
                    let at = |d: f64| {
                        let mut q = phi.to_vec();
                        q[j] += d;
                        processes::ArP::new(&q, a.sigma2())
                            .ok()
                            .map(|b| arp_avar(&b, m))
                    };
                    g.push(match (at(h), at(-h)) {
                        (Some(u), Some(d)) => (u - d) / (2.0 * h),
                        (Some(u), None) => (u - av) / h,
                        (None, Some(d)) => (av - d) / h,
                        (None, None) => f64::NAN,
                    });
                }
            } else {
                g.resize(a.order(), f64::NAN);
            }
            g.push(av / a.sigma2());
            (av, g)
        }
        Process::Arma(a) => {
            if grad {
                crate::arma::arma_avar_gradient(&a, m)
            } else {
                let av = crate::arma::arma_avar(&a, m);
                let mut g = vec![f64::NAN; a.p() + a.q()];
                g.push(av / a.sigma2());
                (av, g)
            }
        }
        Process::Sinusoid(p) => {
            // a = βm/2, c = β/2: AV = α² sin⁴a / (m² sin²c);
            // ∂/∂β = α²/m² · (2m sin³a cos a / sin²c − sin⁴a cos c / sin³c)
            let (alpha2, beta) = (p.alpha2(), p.beta());
            let (sa, ca) = (0.5 * beta * mf).sin_cos();
            let (sc, cc) = (0.5 * beta).sin_cos();
            let unit = sa.powi(4) / (mf * mf * sc * sc);
            let d_beta = alpha2 / (mf * mf)
                * (2.0 * mf * sa.powi(3) * ca / (sc * sc) - sa.powi(4) * cc / sc.powi(3));
            (alpha2 * unit, vec![unit, d_beta])
        }
        Process::Plp(p) => {
            let (av, g) = crate::long_memory::plp_avar_grad(&p, m);
            (av, g.to_vec())
        }
        Process::Fgn(f) => {
            let (av, g) = crate::long_memory::fgn_avar_grad(&f, m);
            (av, g.to_vec())
        }
    })
}

/// Theoretical Allan variance of one process at cluster size `m` ≥ 1 (samples), in the
/// process's unit², by the closed forms of `REFERENCES.md` §2 (see the module docs for
/// the numerically stable evaluation). `rate_hz` (Hz) is used by GM (φ = e^(−β/rate));
/// the averaging time is τ = m / rate seconds.
///
/// ```
/// use processes::{Ar1, Process, WhiteNoise};
/// use spectral::allan_variance;
/// let wn = Process::from(WhiteNoise::new(2.0)?);
/// assert_eq!(allan_variance(&wn, 4, 100.0)?, 0.5);
/// // AR1 at m = 1: γ(0) − γ(1) = v²/(1+φ), even with φ extremely close to 1.
/// let ar = Process::from(Ar1::new(0.999_999, 1.0)?);
/// let av = allan_variance(&ar, 1, 1.0)?;
/// assert!((av - 1.0 / 1.999_999).abs() < 1e-15);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn allan_variance(process: &Process, m: u64, rate_hz: f64) -> Result<f64> {
    Ok(av_and_gradient(process, m, rate_hz, false)?.0)
}

/// Gradient ∂AV/∂θ of [`allan_variance`] with respect to each parameter, in the order of
/// [`Process::params`] (per-sample parameters; GM: β in 1/s and σ_G²). Analytic.
///
/// ```
/// use processes::{Process, RandomWalk};
/// use spectral::allan_variance_gradient;
/// let rw = Process::from(RandomWalk::new(1e-9)?);
/// // AV = γ²(2m²+1)/(6m) is linear in γ².
/// assert_eq!(allan_variance_gradient(&rw, 1, 1.0)?, vec![0.5]);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn allan_variance_gradient(process: &Process, m: u64, rate_hz: f64) -> Result<Vec<f64>> {
    Ok(av_and_gradient(process, m, rate_hz, true)?.1)
}

/// Allan variance and its gradient together (one evaluation of the shared terms).
///
/// ```
/// use processes::{Ar1, Process};
/// use spectral::{allan_variance, allan_variance_with_gradient};
/// let ar = Process::from(Ar1::new(0.99, 1e-6)?);
/// let (av, grad) = allan_variance_with_gradient(&ar, 16, 100.0)?;
/// assert_eq!(av, allan_variance(&ar, 16, 100.0)?);
/// assert_eq!(grad.len(), 2);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn allan_variance_with_gradient(
    process: &Process,
    m: u64,
    rate_hz: f64,
) -> Result<(f64, Vec<f64>)> {
    av_and_gradient(process, m, rate_hz, true)
}

/// Theoretical AV of a fully specified model: the sum of its components' AVs (book
/// Corollary 4.1). Errors if the model has slots without values.
///
/// ```
/// use processes::{WhiteNoise, RandomWalk, Model};
/// use spectral::model_allan_variance;
/// let model = (WhiteNoise::new(1.0)? + RandomWalk::new(6.0)?)?;
/// // 1/m + 6(2m²+1)/(6m) at m = 1: 1 + 3.
/// assert_eq!(model_allan_variance(&model, 1, 1.0)?, 4.0);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn model_allan_variance(model: &Model, m: u64, rate_hz: f64) -> Result<f64> {
    let mut s = 0.0;
    for p in model.processes()? {
        s += allan_variance(&p, m, rate_hz)?;
    }
    Ok(s)
}

/// Gradient of [`model_allan_variance`] with respect to the model's flat parameter vector
/// (component order, each in the order of [`Process::params`], as [`Model::with_params`]).
///
/// ```
/// use processes::{WhiteNoise, QuantizationNoise};
/// use spectral::model_allan_variance_gradient;
/// let model = (QuantizationNoise::new(1.0)? + WhiteNoise::new(1.0)?)?;
/// assert_eq!(model_allan_variance_gradient(&model, 2, 1.0)?, vec![0.75, 0.5]);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn model_allan_variance_gradient(model: &Model, m: u64, rate_hz: f64) -> Result<Vec<f64>> {
    let mut g = Vec::with_capacity(model.n_params());
    for p in model.processes()? {
        g.extend(allan_variance_gradient(&p, m, rate_hz)?);
    }
    Ok(g)
}

/// [`model_allan_variance`] and [`model_allan_variance_gradient`] in one pass.
///
/// ```
/// use processes::{WhiteNoise, RandomWalk};
/// use spectral::{model_allan_variance, model_allan_variance_with_gradient};
/// let model = (WhiteNoise::new(1e-4)? + RandomWalk::new(1e-9)?)?;
/// let (av, grad) = model_allan_variance_with_gradient(&model, 32, 100.0)?;
/// assert_eq!(av, model_allan_variance(&model, 32, 100.0)?);
/// assert_eq!(grad, vec![1.0 / 32.0, (2.0 * 1024.0 + 1.0) / (6.0 * 32.0)]);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn model_allan_variance_with_gradient(
    model: &Model,
    m: u64,
    rate_hz: f64,
) -> Result<(f64, Vec<f64>)> {
    let mut s = 0.0;
    let mut g = Vec::with_capacity(model.n_params());
    for p in model.processes()? {
        let (v, d) = av_and_gradient(&p, m, rate_hz, true)?;
        s += v;
        g.extend(d);
    }
    Ok((s, g))
}

/// Theoretical Haar wavelet variance ν²(τ_j) of one process at the level scale `tau_j`
/// (samples; τ_j = 2^j for the MODWT level j, any even τ_j ≥ 2 accepted):
/// ν²_j = AV(m = τ_j/2) / 2 (`REFERENCES.md` §3). Unit²; `rate_hz` for GM.
///
/// ```
/// use processes::{Process, QuantizationNoise};
/// use spectral::haar_wavelet_variance;
/// let qn = Process::from(QuantizationNoise::new(1.0)?);
/// assert_eq!(haar_wavelet_variance(&qn, 4, 1.0)?, 6.0 / 16.0); // 6Q²/τ²
/// assert!(haar_wavelet_variance(&qn, 3, 1.0).is_err());       // odd scale
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn haar_wavelet_variance(process: &Process, tau_j: u64, rate_hz: f64) -> Result<f64> {
    let m = check_tau_j(tau_j)?;
    Ok(0.5 * allan_variance(process, m, rate_hz)?)
}

/// Gradient of [`haar_wavelet_variance`] in the order of [`Process::params`].
///
/// ```
/// use processes::{Process, WhiteNoise};
/// use spectral::haar_wavelet_variance_gradient;
/// let wn = Process::from(WhiteNoise::new(3.0)?);
/// assert_eq!(haar_wavelet_variance_gradient(&wn, 8, 1.0)?, vec![1.0 / 8.0]); // σ²/τ
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn haar_wavelet_variance_gradient(
    process: &Process,
    tau_j: u64,
    rate_hz: f64,
) -> Result<Vec<f64>> {
    let m = check_tau_j(tau_j)?;
    let mut g = allan_variance_gradient(process, m, rate_hz)?;
    g.iter_mut().for_each(|x| *x *= 0.5);
    Ok(g)
}

/// Haar wavelet variance of a fully specified model (sum over its components).
///
/// ```
/// use processes::{WhiteNoise, RandomWalk};
/// use spectral::model_haar_wavelet_variance;
/// let model = (WhiteNoise::new(2.0)? + RandomWalk::new(12.0)?)?;
/// // σ²/τ + γ²(τ²+2)/(12τ) at τ = 2: 1 + 3.
/// assert_eq!(model_haar_wavelet_variance(&model, 2, 1.0)?, 4.0);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn model_haar_wavelet_variance(model: &Model, tau_j: u64, rate_hz: f64) -> Result<f64> {
    let m = check_tau_j(tau_j)?;
    Ok(0.5 * model_allan_variance(model, m, rate_hz)?)
}

/// Gradient of [`model_haar_wavelet_variance`] with respect to the model's flat parameter
/// vector (same order as [`Model::with_params`]).
///
/// ```
/// use processes::{WhiteNoise, Drift};
/// use spectral::model_haar_wavelet_variance_gradient;
/// let model = (WhiteNoise::new(2.0)? + Drift::new(1.0)?)?;
/// // ∂/∂σ² of σ²/τ, ∂/∂ω of ω²τ²/16, at τ = 4.
/// assert_eq!(model_haar_wavelet_variance_gradient(&model, 4, 1.0)?, vec![0.25, 2.0]);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn model_haar_wavelet_variance_gradient(
    model: &Model,
    tau_j: u64,
    rate_hz: f64,
) -> Result<Vec<f64>> {
    let m = check_tau_j(tau_j)?;
    let mut g = model_allan_variance_gradient(model, m, rate_hz)?;
    g.iter_mut().for_each(|x| *x *= 0.5);
    Ok(g)
}

/// Theoretical AV of an AR(p) at cluster size `m` (unit², samples), by Lemma 4.2 regrouped
/// by lag, AV = γ(0)/m² · [m(1 − ρ_m) + Σ_{k<m} (2m − 3k) ρ_k − Σ_{m<k<2m} (2m − k) ρ_k],
/// with ρ_k from the AR recursion and the sum stopped once the last p values of ρ are below
/// 1e-20 (the ACF decays geometrically, so the rest is below f64 resolution of the sum).
/// O(min(m, decay length)): cheap for every m once the ACF has died out.
///
/// ```
/// use processes::{Ar1, ArP};
/// use spectral::closed_form::{ar1_unit_avar, arp_avar};
/// // φ_2 = 0 is the AR(1) of the same φ and σ²
/// let (a, f) = (arp_avar(&ArP::new(&[0.7, 0.0], 2.0)?, 10), ar1_unit_avar(0.7, 10).0);
/// assert!((a - 2.0 * f).abs() < 1e-12 * a);
/// # Ok::<(), processes::ProcessError>(())
/// ```
pub fn arp_avar(a: &processes::ArP, m: u64) -> f64 {
    let p = a.order();
    let phi = a.phi();
    let mut rho = a.acf(p + 1); // ρ_0 … ρ_p
    let mf = m as f64;
    let mut b = crate::lemma42::KahanSum::default();
    b.add(mf);
    let w = |k: u64| -> f64 {
        if k < m {
            2.0 * mf - 3.0 * k as f64
        } else if k == m {
            -mf
        } else {
            -(2.0 * mf - k as f64)
        }
    };
    let mut k = 1u64;
    while k < 2 * m {
        let i = k as usize;
        if i >= rho.len() {
            let v: f64 = (0..p).map(|j| phi[j] * rho[i - 1 - j]).sum();
            rho.push(v);
        }
        b.add_product(w(k), rho[i]);
        if i >= p && rho[i + 1 - p..=i].iter().all(|x| x.abs() < 1e-20) {
            break;
        }
        k += 1;
    }
    a.stationary_variance() * b.value() / (mf * mf)
}
