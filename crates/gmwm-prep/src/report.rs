//! Serializable reports of a fit, in the shape the CLI prints as JSON:
//!
//! ```json
//! {"method":"gmwm","model":"WN(sigma2=…) + RW(gamma2=…)","converged":true,
//!  "parameters":[{"process":"WN","component":0,"name":"sigma2","value":…,"se":…,"ci_lo":…,"ci_hi":…}],
//!  "ieee":{"N":{"value":…,"unit":"°/√h","ci_lo":…,"ci_hi":…}},
//!  "j_test":{"statistic":…,"dof":…,"p_value":…},"wic":…,
//!  "fitted":[{"m":…,"tau":…,"observed":…,"avar":…,"components":[…]}]}
//! ```
//!
//! Parameters are per sample (as in `processes`); `per_second` holds the continuous-time forms
//! and `ieee` the IEEE 952 equivalents of WN (N), QN (Q), RW (K) and DR (R), with their CIs
//! mapped through the same monotone conversion (REFERENCES §5).

use crate::avlr::AvlrFit;
use crate::gmwm::{Convergence, GmwmFit};
use crate::inference::{Inference, JTest};
use crate::units::{Quantity, ieee_term_of, per_second, process_ieee};
use processes::{ProcessKind, Unit};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One parameter of a fitted model.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, report::FitReport};
/// use processes::Unit;
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let r = FitReport::from_gmwm(&f, None, &Unit::DegPerSec);
/// let p = &r.parameters[1];
/// assert_eq!((p.process.as_str(), p.component, p.name.as_str()), ("RW", 1, "gamma2"));
/// assert_eq!(p.value, f.theta[1]);
/// assert!(p.se.is_none() && p.ci_lo.is_none() && p.ci_hi.is_none()); // no inference given
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterReport {
    /// Process code, e.g. `"AR1"`.
    pub process: String,
    /// Index of the component in the model.
    pub component: usize,
    /// Parameter name, e.g. `"sigma2"`.
    pub name: String,
    /// Per-sample value.
    pub value: f64,
    /// Standard error, if computed.
    pub se: Option<f64>,
    /// Lower CI bound, if computed.
    pub ci_lo: Option<f64>,
    /// Upper CI bound, if computed.
    pub ci_hi: Option<f64>,
}

/// Per-second form of one component.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, report::FitReport};
/// use processes::Unit;
/// use gmwm_prep::units::per_second;
/// use processes::ProcessKind;
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let r = FitReport::from_gmwm(&f, None, &Unit::DegPerSec);
/// let c = &r.per_second[0];
/// assert_eq!((c.process.as_str(), c.component), ("WN", 0));
/// let q = per_second(ProcessKind::WhiteNoise, &f.theta[..1], 100.0, &Unit::DegPerSec);
/// assert_eq!(c.quantities, q);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ComponentPerSecond {
    /// Process code.
    pub process: String,
    /// Index of the component.
    pub component: usize,
    /// Its per-second quantities (N, Q, K, R, T_c, σ, …).
    pub quantities: Vec<Quantity>,
}

/// An IEEE-unit value with its CI.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, report::FitReport, units::process_ieee};
/// use gmwm_prep::inference::{delta_method, fit_covariance};
/// use processes::{ProcessKind, Unit};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av = gmwm_prep::theory::model_avar(&truth, &m, 100.0)?;
/// let curve = AvCurve::from_m(&m, &av, 100.0)?.with_n(100_000);
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let inf = delta_method(&f, &fit_covariance(&f)?, 0.05)?;
/// let r = FitReport::from_gmwm(&f, Some(&inf), &Unit::DegPerSec);
/// let n = &r.ieee["N"];
/// let to_n = |s2: f64| {
///     process_ieee(ProcessKind::WhiteNoise, &[s2], 100.0, &Unit::DegPerSec)[0].value
/// };
/// assert_eq!((n.unit.as_str(), n.value), ("°/√h", to_n(f.theta[0])));
/// // the CI of σ² mapped through the increasing N = 60 √(σ² Δt)
/// assert_eq!((n.ci_lo, n.ci_hi), (Some(to_n(inf.ci[0].0)), Some(to_n(inf.ci[0].1))));
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IeeeValue {
    /// Value in `unit`.
    pub value: f64,
    /// IEEE unit, e.g. `"°/√h"`.
    pub unit: String,
    /// Lower CI bound, if computed.
    pub ci_lo: Option<f64>,
    /// Upper CI bound, if computed.
    pub ci_hi: Option<f64>,
}

/// One scale of the fitted curve.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, report::FitReport};
/// use processes::Unit;
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let r = FitReport::from_gmwm(&f, None, &Unit::DegPerSec);
/// for (j, p) in r.fitted.iter().enumerate() {
///     assert_eq!((p.m, p.tau), (f.m[j], f.tau[j]));
///     assert_eq!((p.observed, p.avar), (f.observed[j], f.fitted[j]));
///     assert_eq!(p.components, vec![f.components[0][j], f.components[1][j]]);
/// }
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittedPoint {
    /// Cluster size (samples).
    pub m: u64,
    /// Averaging time (s).
    pub tau: f64,
    /// Observed moment (AV or WV).
    pub observed: f64,
    /// Fitted moment.
    pub avar: f64,
    /// Each component's moment, in model order.
    pub components: Vec<f64>,
}

/// A serializable fit report (see module doc).
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, report::FitReport};
/// use processes::Unit;
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
/// let r = FitReport::from_gmwm(&f, None, &Unit::DegPerSec);
/// let v = serde_json::to_value(&r)?;
/// assert_eq!((&v["method"], &v["unit"]), (&"gmwm".into(), &"deg/s".into()));
/// assert_eq!(v["parameters"][0]["name"], "sigma2");
/// assert!(v["j_test"].is_null()); // no inference given
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// `"gmwm"` or `"avlr"`.
    pub method: String,
    /// Fitted model in text form (per-sample values).
    pub model: String,
    /// Whether the optimizer converged (always true for AVLR, which is closed form).
    pub converged: bool,
    /// Optimizer details (GMWM).
    pub convergence: Option<Convergence>,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Channel unit.
    pub unit: Unit,
    /// Parameters, per sample.
    pub parameters: Vec<ParameterReport>,
    /// Per-second forms, per component.
    pub per_second: Vec<ComponentPerSecond>,
    /// IEEE equivalents keyed by symbol (N, Q, K, R).
    pub ieee: BTreeMap<String, IeeeValue>,
    /// J test (GMWM with inference).
    pub j_test: Option<JTest>,
    /// WIC (GMWM with inference).
    pub wic: Option<f64>,
    /// Fitted curve and components.
    pub fitted: Vec<FittedPoint>,
}

fn ieee_entry(
    kind: ProcessKind,
    v: f64,
    lo: Option<f64>,
    hi: Option<f64>,
    rate: f64,
    unit: &Unit,
) -> Option<(String, IeeeValue)> {
    let term = ieee_term_of(kind)?;
    let q = process_ieee(kind, &[v], rate, unit);
    let conv = |x: f64| {
        process_ieee(kind, &[x], rate, unit)
            .first()
            .map(|q| q.value)
    };
    let first = q.first()?;
    let (lo, hi) = (lo.and_then(conv), hi.and_then(conv));
    // the conversion is monotone in |θ|: order the bounds
    let (lo, hi) = match (lo, hi) {
        (Some(a), Some(b)) => (Some(a.min(b)), Some(a.max(b))),
        x => x,
    };
    Some((
        term.symbol().to_string(),
        IeeeValue {
            value: first.value,
            unit: first.unit.clone(),
            ci_lo: lo,
            ci_hi: hi,
        },
    ))
}

impl FitReport {
    /// Report of a GMWM fit, with its inference if computed, for a channel in `unit`.
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, report::FitReport};
    /// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
    /// let m: Vec<u64> = (1..=16).map(|j| 1u64 << j).collect();
    /// let curve = AvCurve::from_m(&m, &gmwm_prep::theory::model_avar(&truth, &m, 100.0)?, 100.0)?;
    /// let f = fit(&curve, &"WN + RW".parse()?, &GmwmOptions::default())?;
    /// let r = FitReport::from_gmwm(&f, None, &processes::Unit::DegPerSec);
    /// assert_eq!(r.method, "gmwm");
    /// assert_eq!(r.parameters[1].name, "gamma2");
    /// assert!((r.ieee["K"].value - 21.6).abs() < 1e-4); // °/h/√h
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn from_gmwm(fit: &GmwmFit, inference: Option<&Inference>, unit: &Unit) -> Self {
        let mut parameters = Vec::new();
        let mut per = Vec::new();
        let mut ieee = BTreeMap::new();
        let mut at = 0;
        for (c, &k) in fit.kinds.iter().enumerate() {
            let n = k.n_params();
            for (i, name) in k.param_names().iter().enumerate() {
                let idx = at + i;
                parameters.push(ParameterReport {
                    process: k.code().to_string(),
                    component: c,
                    name: name.to_string(),
                    value: fit.theta[idx],
                    se: inference.map(|f| f.se[idx]),
                    ci_lo: inference.map(|f| f.ci[idx].0),
                    ci_hi: inference.map(|f| f.ci[idx].1),
                });
            }
            per.push(ComponentPerSecond {
                process: k.code().to_string(),
                component: c,
                quantities: per_second(k, &fit.theta[at..at + n], fit.rate_hz, unit),
            });
            if n == 1
                && let Some((key, v)) = ieee_entry(
                    k,
                    fit.theta[at],
                    inference.map(|f| f.ci[at].0),
                    inference.map(|f| f.ci[at].1),
                    fit.rate_hz,
                    unit,
                )
            {
                ieee.insert(key, v);
            }
            at += n;
        }
        let fitted = (0..fit.m.len())
            .map(|j| FittedPoint {
                m: fit.m[j],
                tau: fit.tau[j],
                observed: fit.observed[j],
                avar: fit.fitted[j],
                components: fit.components.iter().map(|c| c[j]).collect(),
            })
            .collect();
        Self {
            method: "gmwm".into(),
            model: fit.model.to_string(),
            converged: fit.convergence.converged,
            convergence: Some(fit.convergence.clone()),
            rate_hz: fit.rate_hz,
            unit: unit.clone(),
            parameters,
            per_second: per,
            ieee,
            j_test: inference.and_then(|f| f.j_test),
            wic: inference.map(|f| f.wic),
            fitted,
        }
    }

    /// Report of an AVLR fit on a curve with cluster sizes `m`.
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, avlr::{avlr, AvlrWindows}, report::FitReport};
    /// let m = [1u64, 2, 4, 8];
    /// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect();
    /// let w = AvlrWindows { wn: Some((0, 3)), ..Default::default() };
    /// let f = avlr(&AvCurve::from_m(&m, &av, 100.0)?, &w)?;
    /// let r = FitReport::from_avlr(&f, &m, &processes::Unit::DegPerSec);
    /// assert_eq!((r.method.as_str(), r.converged), ("avlr", true));
    /// let s2 = f.estimates[0].per_sample;
    /// assert_eq!(r.parameters[0].value, s2);
    /// // the implied curve is the white-noise AV σ²/m; nothing observed is carried
    /// for (p, &m) in r.fitted.iter().zip(&m) {
    ///     assert!((p.avar * m as f64 / s2 - 1.0).abs() < 1e-14 && p.observed.is_nan());
    /// }
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn from_avlr(fit: &AvlrFit, m: &[u64], unit: &Unit) -> Self {
        let mut parameters = Vec::new();
        let mut per = Vec::new();
        let mut ieee = BTreeMap::new();
        let procs = fit.model.processes().unwrap_or_default();
        for (c, e) in fit.estimates.iter().enumerate() {
            parameters.push(ParameterReport {
                process: e.process.code().to_string(),
                component: c,
                name: e.process.param_names()[0].to_string(),
                value: e.per_sample,
                se: e.sd,
                ci_lo: e.ci_lo,
                ci_hi: e.ci_hi,
            });
            per.push(ComponentPerSecond {
                process: e.process.code().to_string(),
                component: c,
                quantities: per_second(e.process, &[e.per_sample], fit.rate_hz, unit),
            });
            if let Some((k, v)) = ieee_entry(
                e.process,
                e.per_sample,
                e.ci_lo.map(|x| x.max(0.0)),
                e.ci_hi,
                fit.rate_hz,
                unit,
            ) {
                ieee.insert(k, v);
            }
        }
        let fitted = m
            .iter()
            .map(|&mj| {
                let comps: Vec<f64> = procs
                    .iter()
                    .map(|p| crate::theory::process_avar(p, mj, fit.rate_hz).unwrap_or(f64::NAN))
                    .collect();
                FittedPoint {
                    m: mj,
                    tau: mj as f64 / fit.rate_hz,
                    observed: f64::NAN,
                    avar: comps.iter().sum(),
                    components: comps,
                }
            })
            .collect();
        Self {
            method: "avlr".into(),
            model: fit.model.to_string(),
            converged: true,
            convergence: None,
            rate_hz: fit.rate_hz,
            unit: unit.clone(),
            parameters,
            per_second: per,
            ieee,
            j_test: None,
            wic: None,
            fitted,
        }
    }
}
