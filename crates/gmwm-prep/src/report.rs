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
