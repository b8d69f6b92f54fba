//! Per-sample ↔ per-second forms of the parameters and IEEE Std 952 units (REFERENCES §5).
//!
//! With Δt = 1/rate: N² = σ²_WN Δt, K² = γ²_RW / Δt, Q = √Q² Δt, R = ω / Δt. Values are
//! first expressed in the channel's own unit u (N in u·√s, K in u/√s, Q in u·s, R in u/s, B
//! in u), then converted to the IEEE units when u is inertial: gyros (°/s or rad/s) give
//! N in °/√h, B in °/h, K in °/h/√h, Q in °, R in °/h²; accelerometers (g or m/s²) give
//! N in m/s/√h, B in m/s/h (and mg), K in m/s/h/√h, Q in m/s, R in m/s/h².

use processes::{ProcessKind, Unit};
use serde::{Deserialize, Serialize};

/// Standard gravity (m/s²).
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// A named value with its unit, e.g. `N = 0.15 °/√h`.
///
/// ```
/// let q = gmwm_prep::units::Quantity::new("N", 0.15, "°/√h");
/// assert_eq!(q.to_string(), "N = 0.15 °/√h");
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Quantity {
    /// Symbol, e.g. `"N"`.
    pub name: String,
    /// Value in `unit`.
    pub value: f64,
    /// Unit text, e.g. `"°/√h"`.
    pub unit: String,
}

impl Quantity {
    /// Builds a quantity.
    ///
    /// ```
    /// let q = gmwm_prep::units::Quantity::new("B", 3.6, "°/h");
    /// assert_eq!((q.name.as_str(), q.value, q.unit.as_str()), ("B", 3.6, "°/h"));
    /// ```
    pub fn new(name: impl Into<String>, value: f64, unit: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            value,
            unit: unit.into(),
        }
    }
}

impl std::fmt::Display for Quantity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} = {} {}", self.name, self.value, self.unit)
    }
}

/// The five IEEE 952 terms read off an Allan deviation plot.
///
/// ```
/// use gmwm_prep::units::IeeeTerm;
/// let symbols: String = IeeeTerm::ALL.iter().map(|t| t.symbol()).collect();
/// assert_eq!(symbols, "QNBKR");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum IeeeTerm {
    /// Quantization noise Q (slope −1).
    Q,
    /// Angle/velocity random walk N (slope −1/2).
    N,
    /// Bias instability B (slope 0).
    B,
    /// Rate random walk K (slope +1/2).
    K,
    /// Rate ramp R (slope +1).
    R,
}

impl IeeeTerm {
    /// All terms by increasing slope.
    pub const ALL: [IeeeTerm; 5] = [
        IeeeTerm::Q,
        IeeeTerm::N,
        IeeeTerm::B,
        IeeeTerm::K,
        IeeeTerm::R,
    ];
    /// The log-log slope of the Allan deviation in the term's region.
    ///
    /// ```
    /// use gmwm_prep::units::IeeeTerm;
    /// assert_eq!(IeeeTerm::N.slope(), -0.5); // σ(τ) = N/√τ
    /// assert!(IeeeTerm::ALL.windows(2).all(|w| w[0].slope() < w[1].slope()));
    /// ```
    pub fn slope(self) -> f64 {
        match self {
            IeeeTerm::Q => -1.0,
            IeeeTerm::N => -0.5,
            IeeeTerm::B => 0.0,
            IeeeTerm::K => 0.5,
            IeeeTerm::R => 1.0,
        }
    }
    /// Symbol as text.
    ///
    /// ```
    /// assert_eq!(gmwm_prep::units::IeeeTerm::K.symbol(), "K");
    /// ```
    pub fn symbol(self) -> &'static str {
        match self {
            IeeeTerm::Q => "Q",
            IeeeTerm::N => "N",
            IeeeTerm::B => "B",
            IeeeTerm::K => "K",
            IeeeTerm::R => "R",
        }
    }
    /// The unit of the per-second value in terms of the channel unit `u`.
    ///
    /// ```
    /// use gmwm_prep::units::IeeeTerm;
    /// use processes::Unit;
    /// assert_eq!(IeeeTerm::N.per_second_unit(&Unit::DegPerSec), "°/s·√s");
    /// assert_eq!(IeeeTerm::R.per_second_unit(&Unit::Unitless), "u/s"); // no unit: `u`
    /// ```
    pub fn per_second_unit(self, unit: &Unit) -> String {
        let u = unit.symbol();
        let u = if u.is_empty() { "u" } else { u };
        match self {
            IeeeTerm::Q => format!("{u}·s"),
            IeeeTerm::N => format!("{u}·√s"),
            IeeeTerm::B => u.to_string(),
            IeeeTerm::K => format!("{u}/√s"),
            IeeeTerm::R => format!("{u}/s"),
        }
    }
}

/// The IEEE-unit equivalents of a per-second value `v` (in the channel unit, see
/// [`IeeeTerm::per_second_unit`]); empty when the unit is not inertial.
///
/// ```
/// use gmwm_prep::units::{ieee_quantities, IeeeTerm};
/// use processes::Unit;
/// // N = 0.01 °/s/√Hz = 0.6 °/√h
/// let q = ieee_quantities(IeeeTerm::N, 0.01, &Unit::DegPerSec);
/// assert!((q[0].value - 0.6).abs() < 1e-15 && q[0].unit == "°/√h");
/// ```
pub fn ieee_quantities(term: IeeeTerm, v: f64, unit: &Unit) -> Vec<Quantity> {
    let s = term.symbol();
    if unit.is_angular_rate() {
        let d = if *unit == Unit::RadPerSec {
            v.to_degrees()
        } else {
            v
        };
        match term {
            IeeeTerm::N => vec![Quantity::new(s, 60.0 * d, "°/√h")],
            IeeeTerm::B => vec![Quantity::new(s, 3600.0 * d, "°/h")],
            IeeeTerm::K => vec![Quantity::new(s, 216_000.0 * d, "°/h/√h")],
            IeeeTerm::Q => vec![Quantity::new(s, d, "°")],
            IeeeTerm::R => vec![Quantity::new(s, 3600.0 * 3600.0 * d, "°/h²")],
        }
    } else if unit.is_acceleration() {
        let a = if *unit == Unit::G {
            v * STANDARD_GRAVITY
        } else {
            v
        };
        match term {
            IeeeTerm::N => vec![Quantity::new(s, 60.0 * a, "m/s/√h")],
            IeeeTerm::B => vec![
                Quantity::new(s, 3600.0 * a, "m/s/h"),
                Quantity::new(s, 1000.0 * a / STANDARD_GRAVITY, "mg"),
            ],
            IeeeTerm::K => vec![Quantity::new(s, 216_000.0 * a, "m/s/h/√h")],
            IeeeTerm::Q => vec![Quantity::new(s, a, "m/s")],
            IeeeTerm::R => vec![Quantity::new(s, 3600.0 * 3600.0 * a, "m/s/h²")],
        }
    } else {
        Vec::new()
    }
}

/// The per-second (continuous-time) forms of a process's per-sample parameters.
///
/// WN σ² → N = √(σ²Δt); QN Q² → Q = √Q² Δt; RW γ² → K = √(γ²/Δt); DR ω → R = ω/Δt;
/// AR1 (φ, v²) → correlation time T_c = −Δt/ln φ (s, φ > 0) and stationary σ = √(v²/(1−φ²));
/// GM (β, σ_G²) → T_c = 1/β and σ_G; MA1 (θ, σ²) → θ and σ.
///
/// ```
/// use gmwm_prep::units::per_second;
/// use processes::{ProcessKind, Unit};
/// let q = per_second(ProcessKind::WhiteNoise, &[1e-4], 100.0, &Unit::DegPerSec);
/// assert!((q[0].value - 1e-3).abs() < 1e-18); // N = √(1e-4 · 0.01) °/s·√s
/// ```
pub fn per_second(kind: ProcessKind, params: &[f64], rate_hz: f64, unit: &Unit) -> Vec<Quantity> {
    let dt = 1.0 / rate_hz;
    let u = if unit.symbol().is_empty() {
        "u".to_string()
    } else {
        unit.symbol().to_string()
    };
    match kind {
        ProcessKind::WhiteNoise => vec![Quantity::new(
            "N",
            (params[0] * dt).sqrt(),
            IeeeTerm::N.per_second_unit(unit),
        )],
        ProcessKind::QuantizationNoise => vec![Quantity::new(
            "Q",
            params[0].sqrt() * dt,
            IeeeTerm::Q.per_second_unit(unit),
        )],
        ProcessKind::RandomWalk => vec![Quantity::new(
            "K",
            (params[0] / dt).sqrt(),
            IeeeTerm::K.per_second_unit(unit),
        )],
        ProcessKind::Drift => vec![Quantity::new(
            "R",
            params[0] / dt,
            IeeeTerm::R.per_second_unit(unit),
        )],
        ProcessKind::Ar1 => {
            let (phi, v2) = (params[0], params[1]);
            let mut out = Vec::new();
            if phi > 0.0 {
                out.push(Quantity::new("T_c", -dt / phi.ln(), "s"));
            }
            out.push(Quantity::new(
                "sigma",
                (v2 / ((1.0 - phi) * (1.0 + phi))).sqrt(),
                u,
            ));
            out
        }
        ProcessKind::GaussMarkov => vec![
            Quantity::new("T_c", 1.0 / params[0], "s"),
            Quantity::new("sigma", params[1].sqrt(), u),
        ],
        ProcessKind::Ma1 => vec![
            Quantity::new("theta", params[0], ""),
            Quantity::new("sigma", params[1].sqrt(), u),
        ],
        // B is rate-free: the plateau (2 ln 2/π)B² is in unit² whatever Δt
        ProcessKind::BiasInstability(_) => vec![Quantity::new("B", params[0], u)],
        ProcessKind::Sinusoid => vec![
            Quantity::new("amplitude", params[0].sqrt(), u),
            Quantity::new("f", params[1] / (2.0 * std::f64::consts::PI * dt), "Hz"),
        ],
        // AR(p): φ_k as given, the innovation σ and the stationary σ (unit)
        ProcessKind::ArP(_) => {
            let n = params.len() - 1;
            let mut out: Vec<Quantity> = params[..n]
                .iter()
                .enumerate()
                .map(|(i, &f)| Quantity::new(["phi1", "phi2", "phi3", "phi4"][i.min(3)], f, ""))
                .collect();
            out.push(Quantity::new("sigma_innov", params[n].sqrt(), u.clone()));
            if let Ok(a) = processes::ArP::new(&params[..n], params[n]) {
                out.push(Quantity::new("sigma", a.stationary_variance().sqrt(), u));
            }
            out
        }
        // MA2/ARMA: φ_k, θ_k as given, the innovation σ and the stationary σ (unit)
        ProcessKind::Arma(p, q) => {
            let (p, q) = (p as usize, q as usize);
            let names = kind.param_names();
            let mut out: Vec<Quantity> = params[..p + q]
                .iter()
                .zip(names)
                .map(|(&f, &n)| Quantity::new(n, f, ""))
                .collect();
            out.push(Quantity::new(
                "sigma_innov",
                params[p + q].sqrt(),
                u.clone(),
            ));
            if let Ok(a) = processes::Arma::new(&params[..p], &params[p..p + q], params[p + q]) {
                out.push(Quantity::new("sigma", a.stationary_variance().sqrt(), u));
            }
            out
        }
        // PLP: the innovation σ, d and the stationary σ; FGN: σ of a sample and H
        ProcessKind::Plp => {
            let mut out = vec![
                Quantity::new("sigma_innov", params[0].sqrt(), u.clone()),
                Quantity::new("d", params[1], ""),
            ];
            if let Ok(p) = processes::Plp::new(params[0], params[1]) {
                out.push(Quantity::new("sigma", p.variance().sqrt(), u));
            }
            out
        }
        ProcessKind::Fgn => vec![
            Quantity::new("sigma", params[0].sqrt(), u),
            Quantity::new("H", params[1], ""),
        ],
    }
}

/// The IEEE term a process maps to (WN → N, QN → Q, RW → K, DR → R), if any.
///
/// ```
/// use gmwm_prep::units::{ieee_term_of, IeeeTerm};
/// use processes::ProcessKind;
/// assert_eq!(ieee_term_of(ProcessKind::RandomWalk), Some(IeeeTerm::K));
/// assert_eq!(ieee_term_of(ProcessKind::Ar1), None);
/// ```
pub fn ieee_term_of(kind: ProcessKind) -> Option<IeeeTerm> {
    match kind {
        ProcessKind::WhiteNoise => Some(IeeeTerm::N),
        ProcessKind::QuantizationNoise => Some(IeeeTerm::Q),
        ProcessKind::RandomWalk => Some(IeeeTerm::K),
        ProcessKind::Drift => Some(IeeeTerm::R),
        ProcessKind::BiasInstability(_) => Some(IeeeTerm::B),
        _ => None,
    }
}

/// The IEEE-unit equivalents of a process's per-sample parameters (WN, QN, RW, DR only).
///
/// ```
/// use gmwm_prep::units::process_ieee;
/// use processes::{ProcessKind, Unit};
/// // γ² = 1e-10 (°/s)² per sample at 100 Hz: K = 1e-4 °/s/√s = 21.6 °/h/√h.
/// let q = process_ieee(ProcessKind::RandomWalk, &[1e-10], 100.0, &Unit::DegPerSec);
/// assert!((q[0].value - 21.6).abs() < 1e-9);
/// ```
pub fn process_ieee(kind: ProcessKind, params: &[f64], rate_hz: f64, unit: &Unit) -> Vec<Quantity> {
    match ieee_term_of(kind) {
        Some(t) => {
            let v = per_second(kind, params, rate_hz, unit)[0].value;
            ieee_quantities(t, v.abs(), unit)
        }
        None => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_of_references_section_5() {
        // 1 rad/s·√s = 180/π °/√s = 60·180/π °/√h.
        let q = ieee_quantities(IeeeTerm::N, 1.0, &Unit::RadPerSec);
        assert!((q[0].value - 60.0 * 180.0 / std::f64::consts::PI).abs() < 1e-12);
        let b = ieee_quantities(IeeeTerm::B, 1e-3, &Unit::G);
        assert!((b[0].value - 3600.0 * 1e-3 * STANDARD_GRAVITY).abs() < 1e-12);
        assert!((b[1].value - 1.0).abs() < 1e-12); // 1e-3 g = 1 mg
        assert!(ieee_quantities(IeeeTerm::K, 1.0, &Unit::Unitless).is_empty());
        // QN per sample Q² = 4 at 10 Hz: Q = 2·0.1 u·s.
        let q = per_second(
            ProcessKind::QuantizationNoise,
            &[4.0],
            10.0,
            &Unit::Unitless,
        );
        assert!((q[0].value - 0.2).abs() < 1e-15);
    }
}
