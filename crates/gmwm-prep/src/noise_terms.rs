//! N, K and B of a channel, always, each with its 95 % CI and where it comes from.
//!
//! These are the numbers a navigation filter needs (IEEE Std 952): N, the white-noise
//! density (angle or velocity random walk), K, the rate random walk, and B, the bias
//! instability. They are read from the fitted model's asymptotes where the model has the
//! term, and from the Allan deviation itself otherwise:
//!
//! - **N** is the slope −½ line of every short-memory component together: white noise (σ²)
//!   and each AR1, Gauss-Markov or MA1 whose correlation time is below the smallest fitted τ,
//!   as its white-noise equivalent, the long-run variance Σ_h γ(h) (AR1: σ²/(1−φ)²;
//!   GM: σ_G²(1+φ)/(1−φ) with φ = e^{−βΔt}; MA1: σ²(1+θ)²). At τ ≫ the correlation time each
//!   of them has AV(τ) → Σγ/m, so N² = Δt · Σ_c Σγ_c (units² · s). An AR1 slower than the
//!   smallest τ is a Gauss-Markov state of its own and not part of N.
//! - **K** is the slope +½ line of the random walk: K² = γ²/Δt.
//! - **B** is the flicker plateau of a bias-instability component, when the model has one.
//!
//! The 95 % CI of a model value is the delta method on the fit's covariance of θ̂, on the log
//! scale of the (positive) sum, mapped through the monotone square root.
//!
//! Beside each model value stands the IEEE 952 read-off ([`crate::ieee`]: N at τ = 1 s, K at
//! τ = 3 s, B from the minimum), with the relative CI of the AV at the scale of its region
//! nearest the read-off τ (conservative: the line through the region averages correlated
//! scales). When the two CIs do not overlap the term is flagged `disagrees`. When the model
//! lacks a term, the read-off is the value; when the curve has no region of that slope
//! either, the value is an upper bound from the whole curve (each component's AV is
//! non-negative, so N²/τ ≤ AV(τ), K²τ/3 ≤ AV(τ) and (0.6643 B)² ≤ AV(τ) at every τ).

use crate::curve::AvCurve;
use crate::error::Result;
use crate::gmwm::GmwmFit;
use crate::ieee::{bias_instability_factor, read_off};
use crate::inference::Inference;
use crate::stats::z_two_sided;
use crate::units::{IeeeTerm, ieee_quantities, ieee_term_of, per_second};
use processes::{ProcessKind, Unit};
use serde::{Deserialize, Serialize};

/// Where a term's value comes from.
///
/// ```
/// use gmwm_prep::noise_terms::TermSource;
/// assert_eq!(serde_json::to_value(TermSource::ReadOff)?, "read_off");
/// # Ok::<(), serde_json::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TermSource {
    /// The fitted model's asymptote.
    Model,
    /// The IEEE 952 read-off of the AV curve.
    ReadOff,
    /// An upper bound from the whole curve: neither the model nor the curve shows the term.
    UpperBound,
}

/// The IEEE 952 read-off of a term beside the model's value, in the same unit.
///
/// ```
/// use gmwm_prep::noise_terms::ReadOffValue;
/// let r = ReadOffValue {
///     value: 0.2, ci_lo: Some(0.18), ci_hi: Some(0.22), tau_min: 0.02, tau_max: 5.12,
/// };
/// assert!(r.ci_lo < Some(r.value) && Some(r.value) < r.ci_hi);
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReadOffValue {
    /// The read-off value.
    pub value: f64,
    /// Lower CI bound (None when the curve has no CIs or EDFs).
    pub ci_lo: Option<f64>,
    /// Upper CI bound.
    pub ci_hi: Option<f64>,
    /// Smallest τ (s) of the slope region read.
    pub tau_min: f64,
    /// Largest τ (s) of the slope region read.
    pub tau_max: f64,
}

/// One of N, K, B with its CI and source.
///
/// ```
/// use gmwm_prep::noise_terms::{NoiseTerm, TermSource};
/// let t = NoiseTerm {
///     symbol: "N".into(), value: 0.25, unit: "°/√h".into(), per_second: 0.25 / 60.0,
///     per_second_unit: "°/s·√s".into(), ci_lo: Some(0.24),
///     ci_hi: Some(0.26), source: TermSource::Model, basis: "WN".into(), read_off: None,
///     disagrees: false,
/// };
/// assert_eq!(t.display(), "0.25 [0.24, 0.26] °/√h");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseTerm {
    /// `N`, `K` or `B`.
    pub symbol: String,
    /// Value in `unit` (an upper bound when `source` is `upper_bound`).
    pub value: f64,
    /// IEEE unit for gyros and accelerometers (°/√h, °/h/√h, °/h, m/s/√h, …), else the
    /// per-second unit of the channel.
    pub unit: String,
    /// The value in the channel's per-second unit (`per_second_unit`), for config files.
    pub per_second: f64,
    /// That unit, e.g. `rad/s·√s` for N of a gyro in rad/s (see [`IeeeTerm::per_second_unit`]).
    pub per_second_unit: String,
    /// Lower CI bound (None for a bound).
    pub ci_lo: Option<f64>,
    /// Upper CI bound (for a bound: the bound from the AV's upper CI limits).
    pub ci_hi: Option<f64>,
    /// Where the value comes from.
    pub source: TermSource,
    /// The source in words, e.g. "WN + AR1 (white-noise equivalent)" or "read-off at τ = 1 s".
    pub basis: String,
    /// The IEEE read-off beside a model value (None when the value is itself the read-off,
    /// or the curve has no region of this slope).
    pub read_off: Option<ReadOffValue>,
    /// The model's and the read-off's CIs do not overlap.
    pub disagrees: bool,
}

impl NoiseTerm {
    /// The value for people: 4 significant digits, the CI in brackets, `≤` for a bound.
    ///
    /// ```
    /// use gmwm_prep::noise_terms::{NoiseTerm, TermSource};
    /// let t = NoiseTerm {
    ///     symbol: "K".into(), value: 1.23456, unit: "°/h/√h".into(),
    ///     per_second: 1.23456 / 216_000.0, per_second_unit: "°/s/√s".into(), ci_lo: None,
    ///     ci_hi: Some(1.5), source: TermSource::UpperBound, basis: "".into(),
    ///     read_off: None, disagrees: false,
    /// };
    /// assert_eq!(t.display(), "≤ 1.235 °/h/√h");
    /// ```
    pub fn display(&self) -> String {
        let s = |x| processes::number::sig(x, 4);
        match (self.source, self.ci_lo, self.ci_hi) {
            (TermSource::UpperBound, _, _) => format!("≤ {} {}", s(self.value), self.unit),
            (_, Some(lo), Some(hi)) => {
                format!("{} [{}, {}] {}", s(self.value), s(lo), s(hi), self.unit)
            }
            _ => format!("{} {}", s(self.value), self.unit),
        }
    }
}

/// N, K and B of one channel.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, inference::{delta_method, fit_covariance}};
/// use gmwm_prep::noise_terms::{noise_terms, TermSource};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=16).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(1 << 20);
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let inf = delta_method(&f, &fit_covariance(&f)?, 0.05)?;
/// let t = noise_terms(&f, Some(&inf), &curve, &processes::Unit::DegPerSec)?;
/// // N = √(σ² Δt) = 1e-3 °/s·√s = 0.06 °/√h; K = √(γ²/Δt) = 1e-4 °/s/√s = 21.6 °/h/√h
/// assert!((t.n.value / 0.06 - 1.0).abs() < 1e-6 && t.n.source == TermSource::Model);
/// assert!((t.k.value / 21.6 - 1.0).abs() < 1e-6 && t.k.source == TermSource::Model);
/// assert_eq!(t.b.source, TermSource::ReadOff); // no bias-instability component: read off
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseTerms {
    /// White-noise density (angle / velocity random walk).
    pub n: NoiseTerm,
    /// Rate random walk.
    pub k: NoiseTerm,
    /// Bias instability.
    pub b: NoiseTerm,
}

impl NoiseTerms {
    /// The three terms in the order N, K, B.
    ///
    /// ```
    /// # use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, noise_terms::noise_terms};
    /// # let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
    /// # let m: Vec<u64> = (1..=16).map(|j| 1u64 << j).collect();
    /// # let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
    /// # let curve = AvCurve::from_m(&m, &av, 100.0)?;
    /// # let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
    /// let t = noise_terms(&f, None, &curve, &processes::Unit::DegPerSec)?;
    /// let symbols: Vec<&str> = t.all().iter().map(|x| x.symbol.as_str()).collect();
    /// assert_eq!(symbols, ["N", "K", "B"]);
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn all(&self) -> [&NoiseTerm; 3] {
        [&self.n, &self.k, &self.b]
    }
}

/// Long-run variance Σ_h γ(h) of a short-memory component with per-sample parameters `p`
/// at `rate_hz`, and its gradient in `p`, when the component's correlation time is below
/// `tau_min` seconds (None otherwise, and for components that are not short-memory).
///
/// ```
/// use gmwm_prep::noise_terms::white_noise_equivalent;
/// use processes::ProcessKind;
/// // AR1 of φ = 0.15: σ²/(1−φ)² once τ_min exceeds its correlation time −Δt/ln φ ≈ 5 ms
/// let (v, g) = white_noise_equivalent(ProcessKind::Ar1, &[0.15, 0.1], 100.0, 0.02).unwrap();
/// assert!((v - 0.1 / 0.85f64.powi(2)).abs() < 1e-15);
/// assert_eq!(g.len(), 2);
/// // a slow AR1 is a Gauss-Markov state of its own, not white noise
/// assert!(white_noise_equivalent(ProcessKind::Ar1, &[0.999, 0.1], 100.0, 0.02).is_none());
/// assert!(white_noise_equivalent(ProcessKind::RandomWalk, &[1.0], 100.0, 0.02).is_none());
/// ```
pub fn white_noise_equivalent(
    kind: ProcessKind,
    p: &[f64],
    rate_hz: f64,
    tau_min: f64,
) -> Option<(f64, Vec<f64>)> {
    let dt = 1.0 / rate_hz;
    // correlation time of an AR(1) coefficient φ: the lag where |φ|^h falls to 1/e
    let fast = |phi: f64| phi == 0.0 || -dt / phi.abs().ln() < tau_min;
    match kind {
        ProcessKind::WhiteNoise => Some((p[0], vec![1.0])),
        ProcessKind::Ar1 => {
            let (phi, s2) = (p[0], p[1]);
            let a = 1.0 - phi;
            fast(phi).then(|| (s2 / (a * a), vec![2.0 * s2 / (a * a * a), 1.0 / (a * a)]))
        }
        ProcessKind::GaussMarkov => {
            let (beta, s2) = (p[0], p[1]);
            let phi = (-beta * dt).exp();
            let a = -(-beta * dt).exp_m1(); // 1 − φ, accurate for small βΔt
            let v = s2 * (1.0 + phi) / a;
            let dv_dphi = 2.0 * s2 / (a * a);
            (1.0 / beta < tau_min).then(|| (v, vec![-dt * phi * dv_dphi, (1.0 + phi) / a]))
        }
        ProcessKind::Ma1 => {
            let (th, s2) = (p[0], p[1]);
            let b = 1.0 + th;
            Some((s2 * b * b, vec![2.0 * s2 * b, b * b]))
        }
        _ => None,
    }
}

/// Picks a component's contribution to a sum of per-sample parameters and its gradient.
type Pick<'a> = dyn Fn(ProcessKind, &[f64]) -> Option<(f64, Vec<f64>)> + 'a;

/// A model's value of a term: per-second value, per-second CI, and the source in words.
type ModelValue = (f64, Option<(f64, f64)>, String);

/// A term's value and CI in display units from its per-second value `v` (unit: the term's
/// per-second unit) and per-second CI; the conversion to IEEE units is linear.
fn display_term(
    term: IeeeTerm,
    v: f64,
    ci: Option<(f64, f64)>,
    unit: &Unit,
) -> (f64, Option<(f64, f64)>, String) {
    match ieee_quantities(term, v, unit).into_iter().next() {
        Some(q) if v != 0.0 => {
            let f = q.value / v;
            (q.value, ci.map(|(a, b)| (a * f, b * f)), q.unit)
        }
        _ => (v, ci, term.per_second_unit(unit)),
    }
}

/// The point of `curve` inside [lo, hi] (s) nearest `tau` on a log scale.
fn nearest_in(curve: &AvCurve, lo: f64, hi: f64, tau: f64) -> Option<&crate::CurvePoint> {
    curve
        .points
        .iter()
        .filter(|p| p.tau >= lo * (1.0 - 1e-12) && p.tau <= hi * (1.0 + 1e-12))
        .min_by(|a, b| {
            let d = |p: &crate::CurvePoint| (p.tau / tau).ln().abs();
            d(a).total_cmp(&d(b))
        })
}

/// Relative CI of the Allan deviation at a point: (√(lo/ν̂), √(hi/ν̂)), from its CI or EDF.
fn relative_adev_ci(p: &crate::CurvePoint, alpha: f64) -> Option<(f64, f64)> {
    match (p.avar_lo, p.avar_hi, p.edf) {
        (Some(lo), Some(hi), _) if p.avar > 0.0 => {
            Some(((lo / p.avar).sqrt(), (hi / p.avar).sqrt()))
        }
        (_, _, Some(edf)) if edf > 0.0 => {
            let s = 0.5 * (2.0 / edf).sqrt() * z_two_sided(alpha);
            Some(((-s).exp(), s.exp()))
        }
        _ => None,
    }
}

/// N, K and B of a GMWM fit to `curve` (see the module doc). `inference` gives the CIs of
/// the model values; without it they have none.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, noise_terms::{noise_terms, TermSource}};
/// // QN + RW: no short-memory component, so N is read off, or bounded
/// let truth: processes::Model = "QN(q2=1e-4) + RW(gamma2=1e-8)".parse()?;
/// let m: Vec<u64> = (0..=14).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?;
/// let f = fit(&curve, &"QN + RW".parse()?, &GmwmOptions::default())?;
/// let t = noise_terms(&f, None, &curve, &processes::Unit::RadPerSec)?;
/// assert_ne!(t.n.source, TermSource::Model);
/// assert_eq!(t.k.source, TermSource::Model);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn noise_terms(
    fit: &GmwmFit,
    inference: Option<&Inference>,
    curve: &AvCurve,
    unit: &Unit,
) -> Result<NoiseTerms> {
    let tau_min = fit.tau.first().copied().unwrap_or(f64::INFINITY);
    noise_terms_of(
        &fit.kinds,
        &fit.theta,
        fit.rate_hz,
        tau_min,
        inference,
        curve,
        unit,
    )
}

/// [`noise_terms`] of any fitted model: its component `kinds`, per-sample parameters `theta`
/// (in model order), the sampling rate, the smallest fitted τ (s), and the inference on
/// `theta` if there is one (AVLR fits have none: no CIs on the model values).
///
/// ```
/// use gmwm_prep::{AvCurve, noise_terms::{noise_terms_of, TermSource}};
/// use processes::ProcessKind;
/// let m: Vec<u64> = (0..=12).map(|j| 1u64 << j).collect();
/// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect();
/// let curve = AvCurve::from_m(&m, &av, 100.0)?;
/// let t = noise_terms_of(&[ProcessKind::WhiteNoise], &[1e-4], 100.0, 0.01, None, &curve,
///     &processes::Unit::RadPerSec)?;
/// assert_eq!(t.n.source, TermSource::Model);
/// assert_eq!(t.n.unit, "°/√h"); // N = √(σ²Δt) rad/s·√s, in degrees per root hour
/// let want = (1e-4f64 * 0.01).sqrt() * 180.0 / std::f64::consts::PI * 60.0;
/// assert!((t.n.value / want - 1.0).abs() < 1e-12);
/// assert_eq!(t.k.source, TermSource::UpperBound); // no +½ region in white noise
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn noise_terms_of(
    kinds: &[ProcessKind],
    theta: &[f64],
    rate_hz: f64,
    tau_min: f64,
    inference: Option<&Inference>,
    curve: &AvCurve,
    unit: &Unit,
) -> Result<NoiseTerms> {
    let n_params: usize = kinds.iter().map(|k| k.n_params()).sum();
    if n_params != theta.len() || !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(crate::error::FitError::InvalidArgument(format!(
            "noise terms: {} parameters for a model of {n_params}, rate {rate_hz} Hz",
            theta.len()
        )));
    }
    let rate = rate_hz;
    let dt = 1.0 / rate;
    let alpha = inference.map_or(0.05, |i| i.alpha);
    let z = z_two_sided(alpha);
    let ro = read_off(curve, unit).ok();
    let p = theta.len();

    // Σ_c f_c(θ_c) with its gradient over all of θ, for the components `pick` takes
    let sum_of = |pick: &Pick<'_>| {
        let mut v = 0.0;
        let mut g = vec![0.0; p];
        let mut codes = Vec::new();
        let mut at = 0;
        for &k in kinds {
            let n = k.n_params();
            if let Some((vc, gc)) = pick(k, &theta[at..at + n]) {
                v += vc;
                g[at..at + n].copy_from_slice(&gc);
                codes.push(k.code());
            }
            at += n;
        }
        (!codes.is_empty()).then_some((v, g, codes))
    };
    // log-scale delta-method CI of a positive sum
    let ci_of = |v: f64, g: &[f64]| {
        inference.and_then(|inf| {
            let mut var = 0.0;
            for i in 0..p {
                for j in 0..p {
                    var += g[i] * inf.cov_theta.get(i, j) * g[j];
                }
            }
            (v > 0.0 && var.is_finite()).then(|| {
                let r = z * var.max(0.0).sqrt() / v;
                (v * (-r).exp(), v * r.exp())
            })
        })
    };

    // the read-off of a term, with the relative CI of its nearest scale
    let read = |term: IeeeTerm, tau_at: f64| -> Option<ReadOffValue> {
        let e = ro.as_ref()?.get(term)?;
        let at = match term {
            IeeeTerm::B => {
                // the scale of the smallest σ in the region
                let pts = curve.points.iter().filter(|q| {
                    q.tau >= e.tau_min * (1.0 - 1e-12) && q.tau <= e.tau_max * (1.0 + 1e-12)
                });
                pts.min_by(|a, b| a.avar.total_cmp(&b.avar))?
            }
            _ => nearest_in(curve, e.tau_min, e.tau_max, tau_at)?,
        };
        let rel = relative_adev_ci(at, curve.alpha);
        let ci = rel.map(|(rl, rh)| (e.value * rl, e.value * rh));
        let (v, ci, _) = display_term(term, e.value, ci, unit);
        Some(ReadOffValue {
            value: v,
            ci_lo: ci.map(|c| c.0),
            ci_hi: ci.map(|c| c.1),
            tau_min: e.tau_min,
            tau_max: e.tau_max,
        })
    };

    // an upper bound from every scale: value from ν̂, ci_hi from the AV's upper CI limits
    let bound = |term: IeeeTerm, of: &dyn Fn(f64, f64) -> f64| -> (f64, Option<f64>) {
        let v = curve
            .points
            .iter()
            .map(|q| of(q.avar, q.tau))
            .fold(f64::INFINITY, f64::min);
        let hi = curve
            .points
            .iter()
            .filter_map(|q| q.avar_hi.map(|h| of(h, q.tau)))
            .fold(f64::INFINITY, f64::min);
        let (v, ci, _) = display_term(term, v, Some((v, hi)), unit);
        (v, ci.map(|c| c.1).filter(|h| h.is_finite()))
    };

    let assemble = |term: IeeeTerm,
                    model: Option<ModelValue>,
                    tau_at: f64,
                    read_words: String,
                    bound_of: &dyn Fn(f64, f64) -> f64,
                    bound_words: &str| {
        let read_off = read(term, tau_at);
        match model {
            Some((v_ps, ci_ps, words)) => {
                let (value, ci, unit_s) = display_term(term, v_ps, ci_ps, unit);
                let per_second = v_ps;
                let disagrees = match (ci, &read_off) {
                    (Some((lo, hi)), Some(r)) => match (r.ci_lo, r.ci_hi) {
                        (Some(rlo), Some(rhi)) => hi < rlo || rhi < lo,
                        _ => false,
                    },
                    _ => false,
                };
                NoiseTerm {
                    symbol: term.symbol().into(),
                    value,
                    unit: unit_s,
                    per_second,
                    per_second_unit: term.per_second_unit(unit),
                    ci_lo: ci.map(|c| c.0),
                    ci_hi: ci.map(|c| c.1),
                    source: TermSource::Model,
                    basis: words,
                    read_off,
                    disagrees,
                }
            }
            None => match read_off {
                Some(r) => NoiseTerm {
                    symbol: term.symbol().into(),
                    value: r.value,
                    unit: display_term(term, 1.0, None, unit).2,
                    per_second: r.value / display_term(term, 1.0, None, unit).0,
                    per_second_unit: term.per_second_unit(unit),
                    ci_lo: r.ci_lo,
                    ci_hi: r.ci_hi,
                    source: TermSource::ReadOff,
                    basis: read_words,
                    read_off: None,
                    disagrees: false,
                },
                None => {
                    let (v, hi) = bound(term, bound_of);
                    NoiseTerm {
                        symbol: term.symbol().into(),
                        value: v,
                        unit: display_term(term, 1.0, None, unit).2,
                        per_second: v / display_term(term, 1.0, None, unit).0,
                        per_second_unit: term.per_second_unit(unit),
                        ci_lo: None,
                        ci_hi: hi,
                        source: TermSource::UpperBound,
                        basis: bound_words.into(),
                        read_off: None,
                        disagrees: false,
                    }
                }
            },
        }
    };

    // N: every short-memory component through its white-noise equivalent
    let n_model =
        sum_of(&|k, th| white_noise_equivalent(k, th, rate, tau_min)).map(|(v, g, codes)| {
            let words = if codes.iter().all(|c| *c == "WN") {
                codes.join(" + ")
            } else {
                format!("{} (white-noise equivalent)", codes.join(" + "))
            };
            let ci = ci_of(v, &g).map(|(lo, hi)| ((lo * dt).sqrt(), (hi * dt).sqrt()));
            ((v * dt).sqrt(), ci, words)
        });
    // K: the random walk
    let k_model = sum_of(&|k, th| (k == ProcessKind::RandomWalk).then(|| (th[0], vec![1.0]))).map(
        |(v, g, codes)| {
            let ci = ci_of(v, &g).map(|(lo, hi)| ((lo / dt).sqrt(), (hi / dt).sqrt()));
            ((v / dt).sqrt(), ci, codes.join(" + "))
        },
    );
    // B: a bias-instability component (a one-parameter process the units map to B)
    let b_model = {
        let mut at = 0;
        let mut found = None;
        for &k in kinds {
            let n = k.n_params();
            if n == 1 && ieee_term_of(k) == Some(IeeeTerm::B) {
                let per_s = |x: f64| per_second(k, &[x], rate, unit).first().map(|q| q.value);
                if let Some(v) = per_s(theta[at]) {
                    let ci = inference.and_then(|i| {
                        let (a, b) = i.ci[at];
                        Some((per_s(a)?, per_s(b)?))
                    });
                    found = Some((v, ci, k.code().to_string()));
                }
            }
            at += n;
        }
        found
    };

    let f = bias_instability_factor();
    Ok(NoiseTerms {
        n: assemble(
            IeeeTerm::N,
            n_model,
            1.0,
            "IEEE read-off at τ = 1 s (the model has no white-noise term)".into(),
            &|av, tau| (av * tau).sqrt(),
            "upper bound: neither the model nor the curve has a white-noise (slope −½) part",
        ),
        k: assemble(
            IeeeTerm::K,
            k_model,
            3.0,
            "IEEE read-off at τ = 3 s (the model has no random walk)".into(),
            &|av, tau| (3.0 * av / tau).sqrt(),
            "upper bound: neither the model nor the curve has a random-walk (slope +½) part",
        ),
        b: assemble(
            IeeeTerm::B,
            b_model,
            f64::NAN,
            "IEEE read-off at the Allan deviation's minimum".into(),
            &|av, _| av.sqrt() / f,
            "upper bound: the curve has no flat part or minimum",
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::theory::model_avar;

    /// The white-noise equivalent is the large-m limit of m·AV(m) (a second route: the
    /// theoretical AV of `theory`, i.e. the spectral crate's closed forms). At m = 2^40 the
    /// AR1 correction 3φ/(m(1−φ²)) is below 1e-11 for φ ≤ e^{−0.2} (the GM here), so 1e-10
    /// holds.
    #[test]
    fn white_noise_equivalents_are_the_large_m_limit_of_the_av() {
        let m = 1u64 << 40;
        for (model, kind, p) in [
            ("WN(sigma2=2.5e-3)", ProcessKind::WhiteNoise, vec![2.5e-3]),
            (
                "AR1(phi=0.15, sigma2=0.12)",
                ProcessKind::Ar1,
                vec![0.15, 0.12],
            ),
            ("AR1(phi=-0.4, sigma2=3)", ProcessKind::Ar1, vec![-0.4, 3.0]),
            (
                "MA1(theta=0.3, sigma2=0.5)",
                ProcessKind::Ma1,
                vec![0.3, 0.5],
            ),
            (
                "GM(beta=20, sigma2=1e-3)",
                ProcessKind::GaussMarkov,
                vec![20.0, 1e-3],
            ),
        ] {
            let model: processes::Model = model.parse().unwrap();
            let av = model_avar(&model, &[m], 100.0).unwrap()[0];
            let (v, _) = white_noise_equivalent(kind, &p, 100.0, 1.0).unwrap();
            assert!(
                (m as f64 * av / v - 1.0).abs() < 1e-10,
                "{model}: {} vs {v}",
                m as f64 * av
            );
        }
    }

    /// The gradients against central differences (step 1e-6 relative; the functions are
    /// smooth rational ones, so the difference is exact to ~1e-9).
    #[test]
    fn gradients_match_central_differences() {
        for (kind, p) in [
            (ProcessKind::Ar1, vec![0.3, 0.2]),
            (ProcessKind::GaussMarkov, vec![30.0, 2.0]),
            (ProcessKind::Ma1, vec![-0.2, 0.7]),
        ] {
            let (_, g) = white_noise_equivalent(kind, &p, 100.0, 1.0).unwrap();
            for i in 0..p.len() {
                let h = 1e-6 * p[i].abs();
                let mut a = p.clone();
                let mut b = p.clone();
                a[i] += h;
                b[i] -= h;
                let fa = white_noise_equivalent(kind, &a, 100.0, 1.0).unwrap().0;
                let fb = white_noise_equivalent(kind, &b, 100.0, 1.0).unwrap().0;
                let d = (fa - fb) / (2.0 * h);
                assert!(
                    (g[i] / d - 1.0).abs() < 1e-6,
                    "{kind:?} {i}: {} vs {d}",
                    g[i]
                );
            }
        }
    }

    /// N, K from the model equal their closed forms N = √(Δt Σγ), K = √(γ²/Δt) for a model of
    /// WN + AR1 (small φ) + RW; B is read off at the minimum of the curve, and an AR1 slower
    /// than the smallest τ is left out of N.
    #[test]
    fn model_terms_equal_their_closed_forms() {
        let rate = 100.0;
        let dt = 1.0 / rate;
        let m: Vec<u64> = (1..=18).map(|j| 1u64 << j).collect();
        let truth: processes::Model =
            "WN(sigma2=1e-4) + AR1(phi=0.13, sigma2=2e-4) + RW(gamma2=1e-11)"
                .parse()
                .unwrap();
        let av = model_avar(&truth, &m, rate).unwrap();
        let curve = AvCurve::from_m(&m, &av, rate).unwrap();
        let kinds = [
            ProcessKind::WhiteNoise,
            ProcessKind::Ar1,
            ProcessKind::RandomWalk,
        ];
        let theta = [1e-4, 0.13, 2e-4, 1e-11];
        let t = noise_terms_of(&kinds, &theta, rate, 0.02, None, &curve, &Unit::RadPerSec).unwrap();
        let deg = 180.0 / std::f64::consts::PI;
        let n = (dt * (1e-4 + 2e-4 / 0.87f64.powi(2))).sqrt() * deg * 60.0;
        let k = (1e-11 / dt).sqrt() * deg * 216_000.0;
        assert!((t.n.value / n - 1.0).abs() < 1e-10 && t.n.basis.contains("equivalent"));
        assert!((t.k.value / k - 1.0).abs() < 1e-10);
        // the per-second forms, in rad/s·√s and rad/s/√s
        let n_ps = (dt * (1e-4 + 2e-4 / 0.87f64.powi(2))).sqrt();
        assert!((t.n.per_second / n_ps - 1.0).abs() < 1e-12 && t.n.per_second_unit == "rad/s·√s");
        assert!((t.k.per_second / (1e-11 / dt).sqrt() - 1.0).abs() < 1e-12);
        assert_eq!(t.b.source, TermSource::ReadOff);
        // B = σ_min / 0.6643 at the smallest ADEV of the curve
        let smin = av.iter().cloned().fold(f64::INFINITY, f64::min).sqrt();
        let b = smin / bias_instability_factor() * deg * 3600.0;
        assert!((t.b.value / b - 1.0).abs() < 1e-10, "{} vs {b}", t.b.value);
        // a slow AR1 (correlation time 10 s > 0.02 s) is not white noise
        let slow = [1e-4, (-0.1f64 * dt).exp(), 2e-4, 1e-11];
        let t = noise_terms_of(&kinds, &slow, rate, 0.02, None, &curve, &Unit::RadPerSec).unwrap();
        let n = (dt * 1e-4).sqrt() * deg * 60.0;
        assert!((t.n.value / n - 1.0).abs() < 1e-12 && t.n.basis == "WN");
    }

    /// B of a bias-instability component is its parameter: rad/s to °/h exactly; N and K
    /// beside it are those of the WN and RW only (BI's Gauss-Markov states are not white
    /// noise at any fitted scale).
    #[test]
    fn bias_instability_gives_b_from_the_model() {
        let rate = 100.0;
        let dt = 1.0 / rate;
        let m: Vec<u64> = (1..=16).map(|j| 1u64 << j).collect();
        let band = processes::BiBand::new(2, 1 << 16).unwrap();
        let bi = ProcessKind::BiasInstability(band);
        let truth = processes::Model::from_processes(vec![
            processes::WhiteNoise::new(1e-4).unwrap().into(),
            processes::BiasInstability::new(2e-5, band).unwrap().into(),
            processes::RandomWalk::new(1e-13).unwrap().into(),
        ])
        .unwrap();
        let av = model_avar(&truth, &m, rate).unwrap();
        let curve = AvCurve::from_m(&m, &av, rate).unwrap();
        let kinds = [ProcessKind::WhiteNoise, bi, ProcessKind::RandomWalk];
        let theta = [1e-4, 2e-5, 1e-13];
        let t = noise_terms_of(&kinds, &theta, rate, 0.02, None, &curve, &Unit::RadPerSec).unwrap();
        let deg = 180.0 / std::f64::consts::PI;
        assert_eq!((t.b.source, t.b.basis.as_str()), (TermSource::Model, "BI"));
        assert!((t.b.value / (2e-5 * deg * 3600.0) - 1.0).abs() < 1e-12);
        assert!((t.b.per_second / 2e-5 - 1.0).abs() < 1e-12);
        assert!((t.n.per_second / (1e-4 * dt).sqrt() - 1.0).abs() < 1e-12 && t.n.basis == "WN");
        assert!((t.k.per_second / (1e-13 / dt).sqrt() - 1.0).abs() < 1e-12);
    }

    /// Without any term of a slope in the model or the curve, the value is the bound
    /// min_τ √(τ·AV(τ)) (for N), and it is ≥ the true N of a model that adds to it.
    #[test]
    fn bounds_hold_for_absent_terms() {
        let m: Vec<u64> = (0..=10).map(|j| 1u64 << j).collect();
        // a pure random walk: no −½ region
        let av: Vec<f64> = m.iter().map(|&m| 1e-8 * m as f64 / 3.0).collect();
        let curve = AvCurve::from_m(&m, &av, 1.0).unwrap();
        let t = noise_terms_of(&[], &[], 1.0, 1.0, None, &curve, &Unit::Unitless).unwrap();
        assert_eq!(t.n.source, TermSource::UpperBound);
        // at m = 1: √(1 · 1e-8/3)
        assert!((t.n.value / (1e-8f64 / 3.0).sqrt() - 1.0).abs() < 1e-12);
        assert_eq!(t.n.unit, "u·√s");
        assert_eq!(t.k.source, TermSource::ReadOff);
        assert!((t.k.value / 1e-4 - 1.0).abs() < 1e-10);
    }

    #[test]
    fn mismatched_parameters_are_an_error() {
        let curve = AvCurve::from_m(&[1, 2], &[1.0, 0.5], 1.0).unwrap();
        let e = noise_terms_of(
            &[ProcessKind::Ar1],
            &[0.5],
            1.0,
            1.0,
            None,
            &curve,
            &Unit::G,
        );
        assert!(e.is_err());
    }
}
