//! Fitting: a noise model per channel (GMWM, AVLR or the IEEE 952 read-off) with CIs, per
//! sample and in IEEE units, the J test, WIC when selecting; joint fits of several
//! recordings with tests of equality; and the writers of the `imunoise fit` output.

use super::estimate::{ChannelCurves, read_curves, robust_curves};
use super::read::Input;
use crate::error::{Error, Result};
use crate::ui::Ui;
use avar::AllanVariance;
use gmwm_prep::adequacy::{Adequacy, assess};
use gmwm_prep::bootstrap::{BootstrapOptions, parametric_bootstrap_with_progress};
use gmwm_prep::gmwm::{self, CovMatrix, GmwmFit, GmwmOptions};
use gmwm_prep::inference::Inference;
use gmwm_prep::inference::{delta_method, diagonal_covariance, fit_covariance, select_by_wic};
use gmwm_prep::noise_terms::{NoiseTerms, noise_terms_of};
use gmwm_prep::report::{FitReport, IeeeValue};
use gmwm_prep::{AvCurve, FitError};
use processes::{Model, Process, ProcessKind, Unit};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;

/// Fitting methods.
///
/// ```
/// use clap::ValueEnum;
/// use imunoise::pipeline::fit::{FitSettings, Method};
/// // the names `--method` takes
/// assert_eq!(Method::from_str("avlr", false), Ok(Method::Avlr));
/// assert_eq!(Method::from_str("ieee952", false), Ok(Method::Ieee952));
/// assert_eq!(FitSettings::default().method, Method::Gmwm);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Generalized method of wavelet moments on the Allan variance (consistent).
    Gmwm,
    /// Allan-variance linear regression on automatic slope windows (R avar's avlr).
    Avlr,
    /// IEEE Std 952 read-off of N, K, Q, R (and B) on the Allan deviation.
    Ieee952,
}

/// The GMWM weighting matrix Ω (`--weighting`).
///
/// ```
/// use clap::ValueEnum;
/// use imunoise::pipeline::fit::FitWeighting;
/// assert_eq!(FitWeighting::default(), FitWeighting::Diagonal);
/// assert_eq!(FitWeighting::from_str("model-full", false), Ok(FitWeighting::ModelFull));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum FitWeighting {
    /// Ω = diag(1/Var(AV)) from the AV confidence intervals: fast (a few ms per fit).
    #[default]
    Diagonal,
    /// Ω = diag(V(θ̂))⁻¹ with V the exact covariance of the AV estimates under the fitted
    /// model, iterated.
    ModelDiagonal,
    /// Ω = V(θ̂)⁻¹, full (uses the correlation between scales), iterated: the efficient GMWM,
    /// with the smallest bias and RMSE in the Monte Carlo report, about 0.1 s per fit.
    ModelFull,
}

impl FitWeighting {
    /// The GMWM weighting this choice means.
    ///
    /// ```
    /// use imunoise::gmwm_prep::gmwm::Weighting;
    /// use imunoise::pipeline::fit::FitWeighting;
    /// assert_eq!(FitWeighting::Diagonal.weighting(), Weighting::Diagonal);
    /// assert_eq!(FitWeighting::ModelFull.weighting(), Weighting::ModelFull);
    /// ```
    pub fn weighting(self) -> gmwm::Weighting {
        match self {
            Self::Diagonal => gmwm::Weighting::Diagonal,
            Self::ModelDiagonal => gmwm::Weighting::ModelDiagonal,
            Self::ModelFull => gmwm::Weighting::ModelFull,
        }
    }
}

/// How a fit's confidence intervals were computed: the `ci_method` field of the JSON.
///
/// The delta method gives θ̂ ± z_{1−α/2}·se on each parameter's unconstrained scale with
/// Cov(θ̂) = B V Bᵀ, where V is the covariance matrix of the Allan variance estimates; the
/// variants differ in V.
///
/// ```
/// use imunoise::pipeline::fit::CiMethod;
/// assert_eq!(serde_json::to_string(&CiMethod::DeltaBootstrapCov).unwrap(), "\"delta_bootstrap_cov\"");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CiMethod {
    /// Delta method, V = the model-implied covariance of the AV estimates at θ̂.
    DeltaModelCov,
    /// Delta method, V = the sample covariance of the AV of B parametric-bootstrap replicates.
    DeltaBootstrapCov,
    /// Delta method, V = the AV estimates' own variances on the diagonal (ignores the
    /// correlation between scales: optimistic).
    DeltaDiagonal,
    /// θ̂ ± z_{1−α/2}·sd with sd from a parametric bootstrap (AVLR).
    BootstrapSd,
    /// No intervals.
    None,
}

impl CiMethod {
    /// A short phrase for table headers, e.g. "delta method, V = 40-replicate bootstrap covariance".
    ///
    /// ```
    /// use imunoise::pipeline::fit::CiMethod;
    /// assert!(CiMethod::DeltaBootstrapCov.describe(40).contains("40-replicate"));
    /// assert_eq!(CiMethod::None.describe(0), "no CIs");
    /// ```
    pub fn describe(self, bootstrap: usize) -> String {
        match self {
            CiMethod::DeltaModelCov => {
                "delta method, V = model-implied covariance of the AV at the fit".into()
            }
            CiMethod::DeltaBootstrapCov => {
                format!(
                    "delta method, V = {bootstrap}-replicate parametric-bootstrap covariance of the AV"
                )
            }
            CiMethod::DeltaDiagonal => {
                "delta method, V = diagonal AV variances (ignores scale correlation: optimistic)"
                    .into()
            }
            CiMethod::BootstrapSd => {
                format!("estimate ± z·sd of a {bootstrap}-replicate parametric bootstrap")
            }
            CiMethod::None => "no CIs".into(),
        }
    }
}

/// A GMWM fit with the moment covariance V its CIs came from: enough to recompute the
/// delta-method intervals at another level (the demo's simultaneous intervals).
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// let g = f.inference.as_ref().expect("a GMWM fit keeps its inference");
/// // V is the covariance of the AV estimates at the fitted scales
/// assert_eq!(g.v.n, g.fit.m.len());
/// assert_eq!(g.v.data.len(), g.v.n * g.v.n);
/// assert_eq!(g.fit.theta.len(), f.parameters.len());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone)]
pub struct GmwmInference {
    /// The fit.
    pub fit: GmwmFit,
    /// Covariance matrix V of the AV estimates used by the delta method.
    pub v: CovMatrix,
}

/// Delta-method intervals of one fit at one level.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// // at the fit's own level the intervals are the fit's
/// let same = f.cis_at(settings.alpha)?.expect("GMWM");
/// for (p, ci) in f.parameters.iter().zip(&same.parameters) {
///     assert_eq!((p.ci_lo, p.ci_hi), (Some(ci.0), Some(ci.1)));
/// }
/// // a higher level widens every interval
/// let wide = f.cis_at(settings.alpha / 10.0)?.expect("GMWM");
/// for (w, n) in wide.parameters.iter().zip(&same.parameters) {
///     assert!(w.0 < n.0 && n.1 < w.1);
/// }
/// assert_eq!(wide.ieee.keys().collect::<Vec<_>>(), same.ieee.keys().collect::<Vec<_>>());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone)]
pub struct LevelCis {
    /// Per-sample parameter intervals, in the order of [`ChannelFit::parameters`].
    pub parameters: Vec<(f64, f64)>,
    /// IEEE equivalents with their intervals at this level.
    pub ieee: BTreeMap<String, IeeeValue>,
}

/// Fit settings shared by `fit`, `analyze` and `demo` (and the Python `fit`).
///
/// ```
/// use imunoise::pipeline::fit::{FitSettings, Method};
/// let s = FitSettings { model: "WN+RW".into(), ..FitSettings::default() };
/// assert_eq!(s.method, Method::Gmwm);
/// assert_eq!(s.alpha, 0.05);
/// ```
#[derive(Debug, Clone)]
pub struct FitSettings {
    /// Model template (slots to estimate), e.g. "WN+RW+AR1" or "QN+WN+RW+2*AR1".
    pub model: String,
    /// Fitting method.
    pub method: Method,
    /// Select the best sub-model of `model` by WIC (GMWM only).
    pub select: bool,
    /// GMWM weighting matrix Ω.
    pub weighting: FitWeighting,
    /// Parametric bootstrap replications B for the covariance of the AV estimates behind
    /// the CIs (GMWM) or for the CIs themselves (AVLR); 0: none.
    pub bootstrap: usize,
    /// Seed of the bootstrap simulations.
    pub seed: u64,
    /// CI level: intervals cover 1 − alpha.
    pub alpha: f64,
    /// Smallest averaging time τ (s) fitted; scales below it are left out of the fit (and
    /// listed in `excluded_taus`). None: from the first scale.
    pub tau_min: Option<f64>,
    /// Largest averaging time τ (s) fitted. None: up to the last scale.
    pub tau_max: Option<f64>,
}

/// The default model template of `fit`.
pub const DEFAULT_MODEL: &str = "QN+WN+RW+AR1";

impl Default for FitSettings {
    fn default() -> Self {
        FitSettings {
            model: DEFAULT_MODEL.to_string(),
            method: Method::Gmwm,
            select: false,
            weighting: FitWeighting::Diagonal,
            bootstrap: 0,
            seed: 1,
            alpha: 0.05,
            tau_min: None,
            tau_max: None,
        }
    }
}

impl FitSettings {
    /// Checks the settings before any data is read, and returns the parsed model template:
    /// the template parses, `alpha` lies in (0, 1), `select` comes with GMWM only, and
    /// `bootstrap` is at most [`gmwm_prep::bootstrap::MAX_REPLICATIONS`]. A bad
    /// setting is then reported at once, not after a long file has been read.
    ///
    /// ```
    /// use imunoise::pipeline::fit::{FitSettings, Method};
    /// let s = FitSettings { model: "WN+RW".into(), ..FitSettings::default() };
    /// assert_eq!(s.check()?.to_string(), "WN + RW");
    /// let typo = FitSettings { model: "WN+FOO".into(), ..FitSettings::default() };
    /// assert!(typo.check().unwrap_err().to_string().contains("unknown process \"FOO\""));
    /// assert!(FitSettings { alpha: 1.5, ..s.clone() }.check().is_err());
    /// let avlr = FitSettings { method: Method::Avlr, select: true, ..s };
    /// assert!(avlr.check().is_err()); // selection compares GMWM fits by WIC
    /// let huge = FitSettings { bootstrap: 1 << 30, ..FitSettings::default() };
    /// assert!(huge.check().is_err());
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn check(&self) -> Result<Model> {
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return Err(Error::Usage(format!(
                "--alpha must lie in (0, 1), got {}",
                self.alpha
            )));
        }
        if self.select && self.method != Method::Gmwm {
            return Err(Error::Usage(
                "--select works with --method gmwm only (it compares GMWM fits by WIC)".into(),
            ));
        }
        for (flag, v) in [("--tau-min", self.tau_min), ("--tau-max", self.tau_max)] {
            if let Some(t) = v
                && !(t.is_finite() && t > 0.0)
            {
                return Err(Error::Usage(format!(
                    "{flag} must be a positive number of seconds, got {t}"
                )));
            }
        }
        if let (Some(a), Some(b)) = (self.tau_min, self.tau_max)
            && a >= b
        {
            return Err(Error::Usage(format!(
                "--tau-min ({a} s) must be below --tau-max ({b} s)"
            )));
        }
        let most = gmwm_prep::bootstrap::MAX_REPLICATIONS;
        if self.bootstrap > most {
            return Err(Error::Usage(format!(
                "--bootstrap: {} bootstrap replications is more than the {most} this runs \
                 (each one simulates and refits a whole record)",
                self.bootstrap
            )));
        }
        // The rate is not known before the read: a SIN's `f_hz` passes here (any frequency
        // below an unbounded Nyquist); the fit estimates every parameter anyway.
        Ok(Model::parse_at_rate(&self.model, f64::MAX)?)
    }
}

/// One GMWM fit of a template: the fit, the covariance V of the AV estimates it used, how V
/// was obtained, and the delta-method inference.
type Attempt = (GmwmFit, CovMatrix, CiMethod, Inference);

/// Level of the significance test that each component beyond the book's class (BI, SIN,
/// AR(p), ARMA, PLP, FGN) must pass to stay in a selected model (see [`drop_insignificant`]).
pub const TERM_SIGNIFICANCE: f64 = 0.01;

/// Removes, one at a time, the components beyond the book's class (BI, SIN, AR(p), ARMA, PLP,
/// FGN) that a
/// model selected by WIC does not need: a component stays when the J statistic of the model
/// without it exceeds the model's own by more than chance allows, P(χ²_k > ΔJ) <
/// [`TERM_SIGNIFICANCE`] with k its number of parameters; for a SIN, an AR(p) or an ARMA, whose
/// frequency is searched over the whole scale range, that probability is multiplied by the
/// number of scales J (Bonferroni over the frequencies the search could have picked). The
/// least significant is removed first, and the test repeated on the smaller model.
///
/// Why: the WIC charges two per parameter, but a sinusoid's frequency or a bias-instability
/// level found by search fits the noise of a long record's last scales at little cost. On a
/// simulated 3-hour 1 kHz WN + RW record the WIC picked WN + RW + BI + SIN
/// (ΔJ = 4.1 for BI, 5.3 for SIN, J = 22 scales); both go under this test, and a real
/// oscillation or flicker region moves J by hundreds (the ADIS16405 Z gyros' SIN).
fn drop_insignificant<T>(
    chosen: Attempt,
    attempt: &dyn Fn(&Model) -> std::result::Result<Attempt, T>,
) -> Attempt {
    let mut cur = chosen;
    loop {
        let Some(j_cur) = cur.3.j_test.as_ref().map(|j| j.statistic) else {
            return cur;
        };
        let kinds = cur.0.kinds.clone();
        let n_scales = cur.0.m.len() as f64;
        let mut weakest: Option<(f64, Attempt)> = None;
        for (i, k) in kinds.iter().enumerate() {
            let looks = match k {
                ProcessKind::BiasInstability(_) | ProcessKind::Plp | ProcessKind::Fgn => 1.0,
                ProcessKind::Sinusoid | ProcessKind::ArP(_) | ProcessKind::Arma(..) => n_scales,
                _ => continue,
            };
            let sub: Vec<processes::Component> = kinds
                .iter()
                .enumerate()
                .filter(|(l, _)| *l != i)
                .map(|(_, k)| processes::Component::Slot(*k))
                .collect();
            let Ok(sub) = Model::new(sub) else { continue };
            if sub.components().is_empty() {
                continue;
            }
            // a smaller model that cannot be fitted: the component stays
            let Ok(x) = attempt(&sub) else { continue };
            let Some(j_sub) = x.3.j_test.as_ref().map(|j| j.statistic) else {
                continue;
            };
            let p = (gmwm_prep::stats::chi2_sf((j_sub - j_cur).max(0.0), k.n_params() as f64)
                * looks)
                .min(1.0);
            if p >= TERM_SIGNIFICANCE && weakest.as_ref().is_none_or(|w| p > w.0) {
                weakest = Some((p, x));
            }
        }
        match weakest {
            Some((_, x)) => cur = x,
            None => return cur,
        }
    }
}

/// The note the commands print when the model template carries values: the fit estimates
/// every parameter and does not use them (nothing the user wrote is dropped silently);
/// `None` for a template of components only.
///
/// ```
/// use imunoise::pipeline::fit::template_values_note;
/// assert_eq!(template_values_note(&"WN+RW".parse()?), None);
/// let note = template_values_note(&"WN(sigma2=1e-4) + RW".parse()?).unwrap();
/// assert!(note.contains("does not use them") && note.contains("\"WN + RW\""));
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn template_values_note(template: &Model) -> Option<String> {
    template
        .components()
        .iter()
        .any(|c| c.process().is_some())
        .then(|| {
            format!(
                "note: --model {template} gives parameter values; the fit estimates every \
                 parameter and does not use them (the same fit as --model \"{}\")",
                template.template()
            )
        })
}

/// Checks a Gaussian efficiency of the robust AV and returns `Some(efficiency)` when
/// `robust`, else `None`.
///
/// ```
/// use imunoise::pipeline::fit::robust_efficiency;
/// assert_eq!(robust_efficiency(true, 0.6)?, Some(0.6));
/// assert_eq!(robust_efficiency(false, 0.6)?, None);
/// assert!(robust_efficiency(true, 1.5).is_err()); // beyond [0.05, 0.99]
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn robust_efficiency(robust: bool, efficiency: f64) -> Result<Option<f64>> {
    let (lo, hi) = avar::robust::EFFICIENCY_RANGE;
    if !(efficiency.is_finite() && (lo..=hi).contains(&efficiency)) {
        return Err(Error::Usage(format!(
            "--efficiency must lie in [{lo}, {hi}], got {efficiency}"
        )));
    }
    Ok(robust.then_some(efficiency))
}

/// One parameter in the JSON output.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// let wn = &f.parameters[0];
/// assert_eq!((wn.process.as_str(), wn.name.as_str()), ("WN", "sigma2"));
/// // the delta-method interval, on the log scale of a variance, holds its estimate
/// assert!(wn.ci_lo.unwrap() < wn.value && wn.value < wn.ci_hi.unwrap());
/// let json = serde_json::to_value(wn)?;
/// assert_eq!(json["value"], wn.value);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct ParamJson {
    /// Process code.
    pub process: String,
    /// Parameter name.
    pub name: String,
    /// Per-sample value.
    pub value: f64,
    /// Lower CI bound.
    pub ci_lo: Option<f64>,
    /// Upper CI bound.
    pub ci_hi: Option<f64>,
}

/// The J test in the JSON output.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// let j = f.j_test.as_ref().expect("GMWM has a J test");
/// assert!((0.0..=1.0).contains(&j.p_value));
/// assert!(j.statistic >= 0.0); // a quadratic form
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct JTestJson {
    /// J statistic.
    pub statistic: f64,
    /// P-value.
    pub p_value: f64,
}

/// One fitted scale in the JSON output.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// // one fitted AV per scale of the curve
/// let m: Vec<u64> = f.fitted.iter().map(|p| p.m).collect();
/// assert_eq!(m, av.points.iter().map(|p| p.m).collect::<Vec<_>>());
/// assert!(f.fitted.iter().all(|p| p.avar > 0.0));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct FittedJson {
    /// Cluster size.
    pub m: u64,
    /// Fitted (model) Allan variance.
    pub avar: f64,
}

/// One channel's fit in the JSON output.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// assert_eq!((f.name.as_str(), f.method.as_str()), ("gyro_x", "gmwm"));
/// assert_eq!(f.ci_method, fit::CiMethod::DeltaModelCov);
/// assert_eq!(f.ci_level, Some(1.0 - settings.alpha));
/// let json = serde_json::to_value(&f)?;
/// assert_eq!(json["model"], f.model.as_str());
/// assert_eq!(json["ci_method"], "delta_model_cov");
/// // what is kept for plots and for other CI levels is not in the JSON
/// assert!(json.get("components").is_none() && json.get("inference").is_none());
/// assert_eq!(f.components.len(), 2); // one curve per component: WN, RW
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct ChannelFit {
    /// Channel name.
    pub name: String,
    /// `gmwm`, `avlr` or `ieee952`.
    pub method: String,
    /// Fitted model, per-sample values.
    pub model: String,
    /// Whether the optimizer converged.
    pub converged: bool,
    /// Parameters with CIs.
    pub parameters: Vec<ParamJson>,
    /// IEEE equivalents (N, Q, K, R, B) with CIs where available.
    pub ieee: BTreeMap<String, IeeeValue>,
    /// J test (GMWM).
    pub j_test: Option<JTestJson>,
    /// How the CIs were computed (see [`CiMethod`]).
    pub ci_method: CiMethod,
    /// Coverage level of each CI, 1 − alpha (null without CIs).
    pub ci_level: Option<f64>,
    /// WIC of the selected model (with --select).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wic: Option<f64>,
    /// What the user should know about this fit in words: components the data do not
    /// determine, data-quality findings (level shifts, trends, spikes). Empty: omitted.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub warnings: Vec<String>,
    /// N, K and B with their CIs and where each comes from: the one source of these numbers
    /// for the console, the report and the config files (None only if they could not be
    /// computed).
    pub noise_terms: Option<NoiseTerms>,
    /// The verdict on the fit: does the model describe the AV inside its CIs? (None when the
    /// curve has no CIs to check against.)
    pub adequacy: Option<Adequacy>,
    /// Averaging times τ (s) of the scales left out of the fit by `tau_min`/`tau_max`
    /// (omitted when none).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub excluded_taus: Vec<f64>,
    /// The fitted curve.
    pub fitted: Vec<FittedJson>,
    /// Each component's fitted curve (for plots; not in the JSON).
    #[serde(skip)]
    pub components: Vec<(String, Vec<f64>)>,
    /// The channel unit (not in the JSON).
    #[serde(skip)]
    pub unit: Unit,
    /// The GMWM fit and its V, to recompute intervals at other levels (not in the JSON).
    #[serde(skip)]
    pub inference: Option<GmwmInference>,
}

impl ChannelFit {
    /// The fitted model for people: parameters to 4 significant digits (the JSON keeps
    /// `model` at full precision).
    ///
    /// ```
    /// # use imunoise::avar::{AvarConfig, allan_variance};
    /// # use imunoise::pipeline::{fit, simulate};
    /// # use imunoise::processes::Unit;
    /// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
    /// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
    /// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
    /// let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
    /// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
    /// let m: imunoise::processes::Model = f.model.parse()?;
    /// assert_eq!(f.model_display(), format!("{m:.4}"));
    /// assert!(f.model_display().len() < f.model.len());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn model_display(&self) -> String {
        self.model
            .parse::<Model>()
            .map_or_else(|_| self.model.clone(), |m| format!("{m:.4}"))
    }

    /// The delta-method intervals of a GMWM fit at level 1 − `alpha` (None for other
    /// methods, which keep only the intervals they were computed with).
    ///
    /// ```no_run
    /// # fn f(fit: &imunoise::pipeline::fit::ChannelFit) -> imunoise::Result<()> {
    /// // Bonferroni: each of K = 24 intervals at level 1 − 0.05/24 covers jointly with ≥ 95%.
    /// if let Some(sim) = fit.cis_at(0.05 / 24.0)? {
    ///     println!("{:?}", sim.parameters);
    /// }
    /// # Ok(()) }
    /// ```
    pub fn cis_at(&self, alpha: f64) -> Result<Option<LevelCis>> {
        let Some(g) = &self.inference else {
            return Ok(None);
        };
        let inf = delta_method(&g.fit, &g.v, alpha).map_err(|e| fit_err(&self.name, e))?;
        let r = FitReport::from_gmwm(&g.fit, Some(&inf), &self.unit);
        Ok(Some(LevelCis {
            parameters: inf.ci,
            ieee: r.ieee,
        }))
    }
}

/// The JSON document of `imunoise fit`.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// let doc = serde_json::to_value(fit::FitJson { channels: vec![f.clone()] })?;
/// assert_eq!(doc["channels"][0]["name"], "gyro_x");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct FitJson {
    /// One entry per channel.
    pub channels: Vec<ChannelFit>,
}

fn fit_err(name: &str, e: FitError) -> Error {
    Error::Usage(format!("channel {name:?}: fit: {e}"))
}

/// How a channel fit's intervals came about (for [`from_report`]).
struct CiInfo {
    method: CiMethod,
    alpha: f64,
    inference: Option<GmwmInference>,
}

fn from_report(
    name: &str,
    r: &FitReport,
    wic: Option<f64>,
    comps: &[ProcessKind],
    ci: CiInfo,
) -> ChannelFit {
    let components = comps
        .iter()
        .enumerate()
        .map(|(c, k)| {
            (
                k.code().to_string(),
                r.fitted
                    .iter()
                    .map(|p| p.components.get(c).copied().unwrap_or(f64::NAN))
                    .collect(),
            )
        })
        .collect();
    ChannelFit {
        name: name.to_string(),
        method: r.method.clone(),
        model: r.model.clone(),
        converged: r.converged,
        parameters: r
            .parameters
            .iter()
            .map(|p| ParamJson {
                process: p.process.clone(),
                name: p.name.clone(),
                value: p.value,
                ci_lo: p.ci_lo,
                ci_hi: p.ci_hi,
            })
            .collect(),
        ieee: r.ieee.clone(),
        warnings: Vec::new(),
        noise_terms: None,
        adequacy: None,
        excluded_taus: Vec::new(),
        j_test: r.j_test.map(|j| JTestJson {
            statistic: j.statistic,
            p_value: j.p_value,
        }),
        ci_method: ci.method,
        ci_level: (ci.method != CiMethod::None).then_some(1.0 - ci.alpha),
        wic,
        fitted: r
            .fitted
            .iter()
            .map(|p| FittedJson {
                m: p.m,
                avar: p.avar,
            })
            .collect(),
        components,
        unit: r.unit.clone(),
        inference: ci.inference,
    }
}

/// Fits one channel's Allan variance curve as `settings` say. `on_replicate` is called once
/// per finished bootstrap replicate (for a progress bar; `&|| {}` for none).
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// use imunoise::pipeline::{fit, simulate};
/// use imunoise::processes::Unit;
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// let names: Vec<(&str, &str)> =
///     f.parameters.iter().map(|p| (p.process.as_str(), p.name.as_str())).collect();
/// assert_eq!(names, [("WN", "sigma2"), ("RW", "gamma2")]);
/// // 8192 samples: the white-noise variance is estimated to about 2 % (1 SD)
/// assert!((f.parameters[0].value / 1e-4 - 1.0).abs() < 0.1);
/// // each replicate of a parametric bootstrap calls back once
/// let n = std::sync::atomic::AtomicUsize::new(0);
/// let boot = fit::FitSettings { bootstrap: 5, ..settings };
/// let fb = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &boot, &|| {
///     n.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
/// })?;
/// assert_eq!(n.into_inner(), 5);
/// assert_eq!(fb.ci_method, fit::CiMethod::DeltaBootstrapCov);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_channel(
    name: &str,
    av: &AllanVariance,
    unit: &Unit,
    settings: &FitSettings,
    on_replicate: &(dyn Fn() + Sync),
) -> Result<ChannelFit> {
    fit_channel_robust(name, av, unit, settings, None, on_replicate)
}

/// [`fit_channel`] on a robust AV curve of Gaussian efficiency `robust` (None: classical):
/// the model covariance behind the CIs is inflated by 1/e. No bootstrap with a robust AV.
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// use imunoise::pipeline::{fit, simulate};
/// use imunoise::processes::Unit;
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let unit = Unit::RadPerSec;
/// // classical (None): exactly `fit_channel`
/// let a = fit::fit_channel_robust("gyro_x", &av, &unit, &settings, None, &|| {})?;
/// let b = fit::fit_channel("gyro_x", &av, &unit, &settings, &|| {})?;
/// assert_eq!(serde_json::to_value(&a)?, serde_json::to_value(&b)?);
/// // a robust curve fitted at efficiency 0.6
/// let r = imunoise::avar::robust::robust_allan_variance(&x, 100.0, &AvarConfig::default(), 0.6)?;
/// let f = fit::fit_channel_robust("gyro_x", &r.robust, &unit, &settings, Some(0.6), &|| {})?;
/// assert_eq!(f.parameters.len(), 2);
/// // the bootstrap replicates would be classical: refused
/// let boot = fit::FitSettings { bootstrap: 10, ..settings };
/// assert!(fit::fit_channel_robust("gyro_x", &r.robust, &unit, &boot, Some(0.6), &|| {}).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_channel_robust(
    name: &str,
    av: &AllanVariance,
    unit: &Unit,
    settings: &FitSettings,
    robust: Option<f64>,
    on_replicate: &(dyn Fn() + Sync),
) -> Result<ChannelFit> {
    let e = |x| fit_err(name, x);
    let (restricted, excluded_taus) = within_tau_range(name, av, settings)?;
    let av = &restricted;
    let curve = AvCurve::from_avar(av).map_err(e)?;
    let template = Model::parse_at_rate(&settings.model, av.rate_hz)?;
    if robust.is_some() && settings.bootstrap > 0 {
        return Err(Error::Usage(
            "--bootstrap cannot be combined with --robust (the bootstrap replicates would use \
             the classical AV); the robust CIs use the model covariance"
                .into(),
        ));
    }
    let mut out = fit_restricted(
        name,
        av,
        &curve,
        template,
        unit,
        settings,
        robust,
        on_replicate,
    )?;
    out.excluded_taus = excluded_taus;
    Ok(out)
}

/// The scales of `av` inside the τ range of `settings`, and the τ of those left out; fewer
/// than two scales left is an error naming the range.
fn within_tau_range(
    name: &str,
    av: &AllanVariance,
    settings: &FitSettings,
) -> Result<(AllanVariance, Vec<f64>)> {
    let (lo, hi) = (
        settings.tau_min.unwrap_or(0.0),
        settings.tau_max.unwrap_or(f64::INFINITY),
    );
    let mut kept = av.clone();
    // a relative margin so that a τ typed from a printed grid (0.64 for 64/100) matches
    let inside = |t: f64| t >= lo * (1.0 - 1e-9) && t <= hi * (1.0 + 1e-9);
    kept.points.retain(|p| inside(p.tau));
    let excluded: Vec<f64> = av
        .points
        .iter()
        .map(|p| p.tau)
        .filter(|&t| !inside(t))
        .collect();
    if kept.points.len() < 2 {
        return Err(Error::Usage(format!(
            "channel {name:?}: --tau-min/--tau-max ({} … {} s) leave {} of its {} scales (τ = {} … {} s); at least 2 are needed",
            processes::number::sig(lo, 4),
            processes::number::sig(hi, 4),
            kept.points.len(),
            av.points.len(),
            av.points.first().map_or(f64::NAN, |p| p.tau),
            av.points.last().map_or(f64::NAN, |p| p.tau),
        )));
    }
    Ok((kept, excluded))
}

/// [`fit_channel_robust`] on a curve already restricted to the τ range.
#[allow(clippy::too_many_arguments)]
fn fit_restricted(
    name: &str,
    av: &AllanVariance,
    curve: &AvCurve,
    template: Model,
    unit: &Unit,
    settings: &FitSettings,
    robust: Option<f64>,
    on_replicate: &(dyn Fn() + Sync),
) -> Result<ChannelFit> {
    let e = |x| fit_err(name, x);
    match settings.method {
        Method::Gmwm => {
            let opts = GmwmOptions {
                weighting: settings.weighting.weighting(),
                robust,
                ..GmwmOptions::default()
            };
            let v0 = diagonal_covariance(curve);
            // the fit of one template with its covariance V of the AV estimates and the
            // delta-method inference
            let attempt = |template: &Model| -> std::result::Result<_, FitError> {
                let f = gmwm::fit(curve, template, &opts)?;
                let (v, method) = if settings.bootstrap > 0 {
                    let mut b = BootstrapOptions::new(settings.bootstrap, settings.seed, av.n);
                    b.alpha = settings.alpha;
                    let boot =
                        parametric_bootstrap_with_progress(&f, template, &opts, &b, on_replicate)?;
                    (boot.av_cov, CiMethod::DeltaBootstrapCov)
                } else {
                    // The exact covariance of the AV estimates under the fitted model. It
                    // exists for every model the fit can return; should it fail, the diagonal
                    // V is used and `ci_method` says so.
                    match fit_covariance(&f) {
                        Ok(v) => (v, CiMethod::DeltaModelCov),
                        Err(_) => (v0.clone(), CiMethod::DeltaDiagonal),
                    }
                };
                let inf = delta_method(&f, &v, settings.alpha)?;
                Ok((f, v, method, inf))
            };
            let (wic, (f, v, method, inf)) = if settings.select {
                let cands = select_by_wic(curve, &template, &opts, &v0).map_err(e)?;
                // the best candidate by WIC, refitted with the fit's own weighting and every
                // start; should that refit not converge or not identify a component (the
                // search fitted it with the full model's Ω), the next one
                let mut chosen = None;
                let mut last_err = None;
                for c in &cands {
                    match attempt(&c.template.parse()?) {
                        Ok(x) => {
                            chosen = Some((Some(c.wic), x));
                            break;
                        }
                        Err(
                            err @ (FitError::OptimizationFailed(_)
                            | FitError::Unidentifiable(_)
                            | FitError::NotIdentifiable { .. }),
                        ) => last_err = Some(err),
                        Err(err) => return Err(e(err)),
                    }
                }
                match (chosen, last_err) {
                    (Some((wic, x)), _) => {
                        let before = x.0.kinds.clone();
                        let x = drop_insignificant(x, &attempt);
                        // the WIC of the smaller model, from the search that fitted it
                        let wic = if x.0.kinds == before {
                            wic
                        } else {
                            let t = Model::new(
                                x.0.kinds
                                    .iter()
                                    .map(|k| processes::Component::Slot(*k))
                                    .collect(),
                            )?
                            .to_string();
                            cands.iter().find(|c| c.template == t).map(|c| c.wic)
                        };
                        (wic, x)
                    }
                    (None, Some(err)) => return Err(e(err)),
                    (None, None) => {
                        return Err(Error::Usage(format!(
                            "channel {name:?}: no sub-model could be fitted"
                        )));
                    }
                }
            } else {
                (None, attempt(&template).map_err(e)?)
            };
            let r = FitReport::from_gmwm(&f, Some(&inf), unit);
            let kinds = f.kinds.clone();
            let theta = f.theta.clone();
            let mut warnings = undetermined(&f);
            if kinds.iter().all(|k| *k == processes::ProcessKind::Drift) {
                warnings.push(
                    "the model is a deterministic drift only: under it the AV estimates have no \
                     variance, so its CIs have zero width and there is no J test; add a random \
                     component (e.g. --model \"WN+DR\")"
                        .into(),
                );
            }
            let ci = CiInfo {
                method,
                alpha: settings.alpha,
                inference: Some(GmwmInference { fit: f, v }),
            };
            let mut out = from_report(name, &r, wic, &kinds, ci);
            out.warnings = warnings;
            Ok(with_verdict(out, curve, &kinds, &theta, Some(&inf)))
        }
        Method::Avlr => {
            let w = gmwm_prep::avlr::AvlrWindows::auto(curve).map_err(e)?;
            let mut f = gmwm_prep::avlr::avlr(curve, &w).map_err(e)?;
            let mut method = CiMethod::None;
            if settings.bootstrap > 0 {
                let mut b = BootstrapOptions::new(settings.bootstrap, settings.seed, av.n);
                b.alpha = settings.alpha;
                f = gmwm_prep::bootstrap::avlr_bootstrap(&f, &curve.m(), &b).map_err(e)?;
                (0..settings.bootstrap).for_each(|_| on_replicate());
                method = CiMethod::BootstrapSd;
            }
            let r = FitReport::from_avlr(&f, &curve.m(), unit);
            let kinds = f.model.kinds();
            let theta: Vec<f64> = r.parameters.iter().map(|p| p.value).collect();
            let ci = CiInfo {
                method,
                alpha: settings.alpha,
                inference: None,
            };
            let out = from_report(name, &r, None, &kinds, ci);
            Ok(with_verdict(out, curve, &kinds, &theta, None))
        }
        Method::Ieee952 => {
            let out = ieee952(name, av, unit)?;
            let model: Model = out.model.parse()?;
            let theta: Vec<f64> = out.parameters.iter().map(|p| p.value).collect();
            Ok(with_verdict(out, curve, &model.kinds(), &theta, None))
        }
    }
}

/// Attaches N, K, B ([`NoiseTerms`]) and the verdict ([`Adequacy`]) to a channel's fit of
/// `curve` by the model of component `kinds` and per-sample parameters `theta`; a fit that
/// is not adequate also gets a warning with the reasons, so every place that shows warnings
/// shows it.
fn with_verdict(
    mut out: ChannelFit,
    curve: &AvCurve,
    kinds: &[ProcessKind],
    theta: &[f64],
    inference: Option<&Inference>,
) -> ChannelFit {
    let tau_min = curve.points.first().map_or(f64::INFINITY, |p| p.tau);
    out.noise_terms = noise_terms_of(
        kinds,
        theta,
        curve.rate_hz,
        tau_min,
        inference,
        curve,
        &out.unit,
    )
    .ok();
    // one source: the IEEE map carries the same N, K, B (bounds are not values: left out)
    if let Some(t) = &out.noise_terms {
        for term in t.all() {
            if term.source == gmwm_prep::noise_terms::TermSource::UpperBound {
                out.ieee.remove(&term.symbol);
            } else {
                out.ieee.insert(
                    term.symbol.clone(),
                    IeeeValue {
                        value: term.value,
                        unit: term.unit.clone(),
                        ci_lo: term.ci_lo,
                        ci_hi: term.ci_hi,
                    },
                );
            }
        }
    }
    let fitted: Vec<f64> = out.fitted.iter().map(|p| p.avar).collect();
    out.adequacy = assess(curve, &fitted, out.j_test.as_ref().map(|j| j.p_value)).ok();
    // smallest scales below the white-noise line (a filter's mark) that the model misses: an
    // AR1 of small φ reproduces such a shape, and then there is nothing to suggest
    if let (Some(t), Some(a)) = (
        gmwm_prep::adequacy::filtered_small_scales(curve),
        out.adequacy.as_ref(),
    ) && a.scales.iter().any(|c| c.tau < t && !c.inside)
    {
        out.warnings.push(format!(
            "the smallest scales (τ < {} s) lie below the white-noise line of the scales after \
             them and the model misses them: an anti-aliasing or decimation filter may shape \
             them; try --tau-min {}",
            processes::number::sig(t, 4),
            processes::number::sig(t, 4)
        ));
    }
    if let Some(a) = out.adequacy.as_ref().filter(|a| !a.adequate) {
        out.warnings.push(format!(
            "the model does not describe the Allan variance ({}); N, K, B from it and the \
             configs made from them rest on a model the data reject",
            a.reasons[0]
        ));
    }
    out
}

/// Warnings for the components of a GMWM fit that the data do not determine.
fn undetermined(f: &gmwm_prep::gmwm::GmwmFit) -> Vec<String> {
    let (lo, hi) = (
        f.tau.first().copied().unwrap_or(f64::NAN),
        f.tau.last().copied().unwrap_or(f64::NAN),
    );
    gmwm_prep::diagnose::negligible_components(f)
        .into_iter()
        .map(|(code, share)| {
            format!(
                "{code} contributes at most {share:.1e} of the fitted AV at any scale (τ = {lo} … {hi} s): the data do not determine its parameters, whatever their CIs say; try --select or a model without {code}"
            )
        })
        .collect()
}

/// The IEEE 952 read-off as a fit: N, K, Q, R mapped to per-sample WN, RW, QN, DR
/// parameters (REFERENCES §5: σ² = N²/Δt, γ² = K²Δt, Q² = (Q/Δt)², ω = RΔt); B is reported
/// in `ieee` only (it has no per-sample counterpart). No CIs.
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// use imunoise::pipeline::{fit, simulate};
/// use imunoise::processes::Unit;
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// use imunoise::gmwm_prep::{ieee::read_off_adev, units::IeeeTerm};
/// let f = fit::ieee952("gyro_x", &av, &Unit::RadPerSec)?;
/// assert_eq!((f.method.as_str(), f.ci_method), ("ieee952", fit::CiMethod::None));
/// // WN's σ² is N²/Δt of the read-off of N
/// let ro = read_off_adev(&av.taus(), &av.adevs(), &Unit::RadPerSec)?;
/// let n = ro.get(IeeeTerm::N).expect("a −1/2 region").value;
/// let wn = f.parameters.iter().find(|p| p.process == "WN").unwrap();
/// assert_eq!(wn.value, n * n / (1.0 / av.rate_hz));
/// assert!(f.ieee.contains_key("N"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn ieee952(name: &str, av: &AllanVariance, unit: &Unit) -> Result<ChannelFit> {
    use gmwm_prep::units::IeeeTerm;
    let e = |x| fit_err(name, x);
    let ro = gmwm_prep::ieee::read_off_adev(&av.taus(), &av.adevs(), unit).map_err(e)?;
    let dt = 1.0 / av.rate_hz;
    let mut procs: Vec<Process> = Vec::new();
    let mut ieee = BTreeMap::new();
    for est in &ro.terms {
        let v = est.value;
        let p: Option<Process> = match est.term {
            IeeeTerm::Q => Some(processes::QuantizationNoise::new((v / dt).powi(2))?.into()),
            IeeeTerm::N => Some(processes::WhiteNoise::new(v * v / dt)?.into()),
            IeeeTerm::K => Some(processes::RandomWalk::new(v * v * dt)?.into()),
            IeeeTerm::R => Some(processes::Drift::new(v * dt)?.into()),
            IeeeTerm::B => None,
        };
        procs.extend(p);
        let (val, u) = est
            .ieee
            .first()
            .map_or((est.value, est.unit.clone()), |q| (q.value, q.unit.clone()));
        ieee.insert(
            est.term.symbol().to_string(),
            IeeeValue {
                value: val,
                unit: u,
                ci_lo: None,
                ci_hi: None,
            },
        );
    }
    if procs.is_empty() {
        return Err(Error::Usage(format!(
            "channel {name:?}: no IEEE 952 slope region found on the Allan deviation"
        )));
    }
    let model = Model::from_processes(procs.clone())?;
    let m: Vec<u64> = av.points.iter().map(|p| p.m).collect();
    let fitted = gmwm_prep::theory::model_avar(&model, &m, av.rate_hz).map_err(e)?;
    let mut components = Vec::new();
    for p in &procs {
        let c = gmwm_prep::theory::model_avar(&Model::from(*p), &m, av.rate_hz).map_err(e)?;
        components.push((p.kind().code().to_string(), c));
    }
    Ok(ChannelFit {
        name: name.to_string(),
        method: "ieee952".into(),
        model: model.to_string(),
        converged: true,
        parameters: procs
            .iter()
            .flat_map(|p| {
                let k = p.kind();
                k.param_names()
                    .iter()
                    .zip(p.params())
                    .map(move |(n, v)| ParamJson {
                        process: k.code().to_string(),
                        name: n.to_string(),
                        value: v,
                        ci_lo: None,
                        ci_hi: None,
                    })
                    .collect::<Vec<_>>()
            })
            .collect(),
        ieee,
        warnings: Vec::new(),
        noise_terms: None,
        adequacy: None,
        excluded_taus: Vec::new(),
        j_test: None,
        ci_method: CiMethod::None,
        ci_level: None,
        wic: None,
        fitted: m
            .iter()
            .zip(&fitted)
            .map(|(&m, &a)| FittedJson { m, avar: a })
            .collect(),
        components,
        unit: unit.clone(),
        inference: None,
    })
}

/// Fits every channel (in parallel).
///
/// ```
/// use imunoise::pipeline::{estimate, fit, simulate};
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gyro_x_rads".into(), "gyro_y_rads".into()],
///     columns: simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 2)?
///         .into_iter()
///         .map(Into::into)
///         .collect(),
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let units = imunoise::units::channel_units(&table.names, None)?;
/// let ui = imunoise::Ui::quiet();
/// let curves = estimate::fit_curves(&table, 0.05, &ui)?;
/// let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let fits = fit::fit_all(&curves, &units, &settings, &ui)?;
/// assert_eq!(fits.len(), 2);
/// assert_eq!(fits[1].name, "gyro_y_rads");
/// // each is the fit of its channel alone
/// let alone = fit::fit_channel(&curves[1].0, &curves[1].1, &units[1], &settings, &|| {})?;
/// assert_eq!(serde_json::to_value(&fits[1])?, serde_json::to_value(&alone)?);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_all(
    curves: &[(String, AllanVariance)],
    units: &[Unit],
    settings: &FitSettings,
    ui: &Ui,
) -> Result<Vec<ChannelFit>> {
    fit_all_robust(curves, units, settings, None, ui)
}

/// [`fit_all`] on robust AV curves of Gaussian efficiency `robust` (None: classical).
///
/// ```
/// use imunoise::pipeline::{estimate, fit, simulate};
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gyro_x_rads".into(), "gyro_y_rads".into()],
///     columns: simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 2)?
///         .into_iter()
///         .map(Into::into)
///         .collect(),
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let units = imunoise::units::channel_units(&table.names, None)?;
/// let ui = imunoise::Ui::quiet();
/// let curves = estimate::fit_curves(&table, 0.05, &ui)?;
/// let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let a = fit::fit_all_robust(&curves, &units, &settings, None, &ui)?;
/// let b = fit::fit_all(&curves, &units, &settings, &ui)?;
/// assert_eq!(serde_json::to_value(&a)?, serde_json::to_value(&b)?);
/// // the robust curves, fitted with the covariance inflated by 1/e
/// let rc = estimate::robust_curves(&table, 100.0, 0.05, 0.6, Some(&curves))?;
/// let rc: Vec<_> = rc.into_iter().map(|(n, r)| (n, r.robust)).collect();
/// assert_eq!(fit::fit_all_robust(&rc, &units, &settings, Some(0.6), &ui)?.len(), 2);
/// // a CI level outside (0, 1) is refused
/// let bad = fit::FitSettings { alpha: 1.5, ..settings };
/// assert!(fit::fit_all_robust(&curves, &units, &bad, None, &ui).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_all_robust(
    curves: &[(String, AllanVariance)],
    units: &[Unit],
    settings: &FitSettings,
    robust: Option<f64>,
    ui: &Ui,
) -> Result<Vec<ChannelFit>> {
    use rayon::prelude::*;
    settings.check()?;
    // One step per channel fit, plus one per bootstrap replicate when bootstrapping.
    let boots = match settings.method {
        Method::Ieee952 => 0,
        _ => settings.bootstrap as u64,
    };
    let per_channel = 1 + boots;
    let msg = if boots > 0 {
        "fit+bootstrap"
    } else {
        "fitting"
    };
    let pb = ui.bar(curves.len() as u64 * per_channel, msg);
    let tick = || pb.inc(1);
    let out: Vec<Result<ChannelFit>> = curves
        .par_iter()
        .zip(units)
        .map(|((name, av), unit)| {
            let r = fit_channel_robust(name, av, unit, settings, robust, &tick);
            pb.inc(1);
            r
        })
        .collect();
    pb.finish_and_clear();
    out.into_iter().collect()
}

/// A coverage level as a percentage with at most two decimals: 0.95 → "95%",
/// 1 − 0.05/24 → "99.79%".
///
/// ```
/// use imunoise::pipeline::fit::percent;
/// assert_eq!(percent(0.95), "95%");
/// assert_eq!(percent(1.0 - 0.05 / 24.0), "99.79%");
/// ```
pub fn percent(level: f64) -> String {
    let s = format!("{:.2}", 100.0 * level);
    format!("{}%", s.trim_end_matches('0').trim_end_matches('.'))
}

fn ci(lo: Option<f64>, hi: Option<f64>) -> String {
    match (lo, hi) {
        (Some(a), Some(b)) => format!(
            "[{}, {}]",
            processes::number::sig(a, 4),
            processes::number::sig(b, 4)
        ),
        _ => "-".into(),
    }
}

/// One parameter row of the text tables: process, name, per-sample value, CI.
fn write_param_row(out: &mut impl Write, indent: &str, p: &ParamJson) -> std::io::Result<()> {
    writeln!(
        out,
        "{indent}{:<5} {:<7} {:>12}  {}",
        p.process,
        p.name,
        processes::number::sig(p.value, 4),
        ci(p.ci_lo, p.ci_hi)
    )
}

/// Writes fits as text tables.
/// `bootstrap` is the number of replicates, for the CI method's description.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// let mut out = Vec::new();
/// fit::write_table(&mut out, std::slice::from_ref(&f), 0.05, 0)?;
/// let text = String::from_utf8(out)?;
/// // the model to 4 significant digits, then the verdict and N, K, B with their sources
/// assert!(text.starts_with(&format!("gyro_x [rad/s]: gmwm fit: {}", f.model_display())));
/// assert!(text.contains("\n  verdict: ") && text.contains("\n  N = "));
/// assert!(text.contains("95% CI (delta method"));
/// assert!(text.contains("J-test: J = "));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_table(
    out: &mut impl Write,
    fits: &[ChannelFit],
    alpha: f64,
    bootstrap: usize,
) -> std::io::Result<()> {
    for (i, f) in fits.iter().enumerate() {
        if i > 0 {
            writeln!(out)?;
        }
        writeln!(
            out,
            "{} [{}]: {} fit{}: {}",
            f.name,
            if f.unit.symbol().is_empty() {
                "unitless"
            } else {
                f.unit.symbol()
            },
            f.method,
            if f.converged { "" } else { " (NOT converged)" },
            f.model_display()
        )?;
        if let Some(a) = &f.adequacy {
            writeln!(
                out,
                "  verdict: {}: {}",
                if a.adequate {
                    "adequate"
                } else {
                    "NOT ADEQUATE"
                },
                a.reasons.join("; ")
            )?;
        }
        if let Some(t) = &f.noise_terms {
            for term in t.all() {
                write_term_line(out, term)?;
            }
        }
        let ci_head = match f.ci_method {
            CiMethod::None => "no CI".to_string(),
            m => format!("{} CI ({})", percent(1.0 - alpha), m.describe(bootstrap)),
        };
        writeln!(
            out,
            "  {:<5} {:<7} {:>12}  {ci_head}",
            "proc", "param", "per sample",
        )?;
        for p in &f.parameters {
            write_param_row(out, "  ", p)?;
        }
        for (k, v) in &f.ieee {
            if f.noise_terms.is_some() && matches!(k.as_str(), "N" | "K" | "B") {
                continue; // printed above with their sources
            }
            writeln!(
                out,
                "  IEEE {k} = {} {}  {}",
                processes::number::sig(v.value, 4),
                v.unit,
                ci(v.ci_lo, v.ci_hi)
            )?;
        }
        if let Some(j) = &f.j_test {
            writeln!(
                out,
                "  J-test: J = {:.3}, p = {:.3}",
                j.statistic, j.p_value
            )?;
        }
        if let Some(w) = f.wic {
            writeln!(out, "  WIC of the selected model: {w:.4}")?;
        }
        for w in &f.warnings {
            writeln!(out, "  note: {w}")?;
        }
    }
    Ok(())
}

/// One line of N, K or B for the console: value, CI, source, and the read-off beside it.
fn write_term_line(
    out: &mut impl Write,
    t: &gmwm_prep::noise_terms::NoiseTerm,
) -> std::io::Result<()> {
    let s = |x| processes::number::sig(x, 4);
    let beside = t.read_off.as_ref().map_or(String::new(), |r| {
        let ci = match (r.ci_lo, r.ci_hi) {
            (Some(a), Some(b)) => format!(" [{}, {}]", s(a), s(b)),
            _ => String::new(),
        };
        format!(
            "; IEEE read-off {}{ci}{}",
            s(r.value),
            if t.disagrees {
                " — DISAGREES beyond the CIs"
            } else {
                ""
            }
        )
    });
    let eq = if t.source == gmwm_prep::noise_terms::TermSource::UpperBound {
        ""
    } else {
        "= "
    };
    writeln!(
        out,
        "  {} {eq}{}  ({}{beside})",
        t.symbol,
        t.display(),
        t.basis
    )
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Writes fits as CSV: a header line, then one row per parameter (per sample) and per IEEE
/// term (process `IEEE`), with empty CI cells where there is none.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// let mut out = Vec::new();
/// fit::write_csv(&mut out, std::slice::from_ref(&f))?;
/// let text = String::from_utf8(out)?;
/// let lines: Vec<&str> = text.lines().collect();
/// assert_eq!(lines[0], "channel,process,name,value,ci_lo,ci_hi,unit,ci_method");
/// assert_eq!(lines.len(), 1 + f.parameters.len() + f.ieee.len());
/// // the values read back to the same f64
/// let row: Vec<&str> = lines[1].split(',').collect();
/// assert_eq!(row[..3], ["gyro_x", "WN", "sigma2"]);
/// assert_eq!(row[3].parse::<f64>()?, f.parameters[0].value);
/// assert_eq!(row[7], "delta_model_cov");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_csv(out: &mut impl Write, fits: &[ChannelFit]) -> std::io::Result<()> {
    writeln!(out, "channel,process,name,value,ci_lo,ci_hi,unit,ci_method")?;
    let o = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:e}"));
    for f in fits {
        let method = serde_json::to_value(f.ci_method)
            .ok()
            .and_then(|v| v.as_str().map(str::to_string))
            .unwrap_or_default();
        let name = csv_field(&f.name);
        for p in &f.parameters {
            writeln!(
                out,
                "{name},{},{},{:e},{},{},per sample,{method}",
                p.process,
                p.name,
                p.value,
                o(p.ci_lo),
                o(p.ci_hi)
            )?;
        }
        for (k, v) in &f.ieee {
            writeln!(
                out,
                "{name},IEEE,{k},{:e},{},{},{},{method}",
                v.value,
                o(v.ci_lo),
                o(v.ci_hi),
                csv_field(&v.unit)
            )?;
        }
    }
    Ok(())
}

/// One channel of a joint fit of several recordings (`imunoise fit A B …`).
///
/// ```
/// # use imunoise::pipeline::{fit, read::Input, simulate};
/// # // two recordings of one gyro (the same noise, other seeds)
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let dir = tempfile::tempdir()?;
/// # let mut inputs = Vec::new();
/// # for seed in [1, 2] {
/// #     let p = dir.path().join(format!("run{seed}.csv"));
/// #     let cols = simulate::simulate_channels(&model, 1 << 13, 100.0, seed, 1)?;
/// #     simulate::write_csv(&mut std::fs::File::create(&p)?, &["gyro_x_rads".into()], &cols)?;
/// #     inputs.push(Input { rate: Some(100.0), ..Input::new(p) });
/// # }
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let joint = fit::fit_joint(&inputs, &settings, None, &imunoise::Ui::quiet())?;
/// let j = &joint[0];
/// assert_eq!(j.name, "gyro_x_rads");
/// assert_eq!(j.files.len(), 2);
/// assert_eq!(j.single.len(), 2);
/// // the joint fit and each recording's own fit have the same parameters
/// assert_eq!(j.fit.parameters.len(), j.single[1].parameters.len());
/// assert!((0.0..=1.0).contains(&j.wald.p_value));
/// assert!((0.0..=1.0).contains(&j.moment_test.p_value));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct JointChannel {
    /// Channel name.
    pub name: String,
    /// The recordings, in order.
    pub files: Vec<String>,
    /// The joint fit (same shape as one channel of a single-file fit).
    pub fit: ChannelFit,
    /// Each recording fitted alone.
    pub single: Vec<ChannelFit>,
    /// Wald test of equal parameters across recordings.
    pub wald: gmwm_prep::multi::ChiSquareTest,
    /// J-type test of equal Allan variance curves across recordings.
    pub moment_test: gmwm_prep::multi::ChiSquareTest,
}

/// The JSON document of `imunoise fit A B …`.
///
/// ```
/// # use imunoise::pipeline::{fit, read::Input, simulate};
/// # // two recordings of one gyro (the same noise, other seeds)
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let dir = tempfile::tempdir()?;
/// # let mut inputs = Vec::new();
/// # for seed in [1, 2] {
/// #     let p = dir.path().join(format!("run{seed}.csv"));
/// #     let cols = simulate::simulate_channels(&model, 1 << 13, 100.0, seed, 1)?;
/// #     simulate::write_csv(&mut std::fs::File::create(&p)?, &["gyro_x_rads".into()], &cols)?;
/// #     inputs.push(Input { rate: Some(100.0), ..Input::new(p) });
/// # }
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let joint = fit::fit_joint(&inputs, &settings, None, &imunoise::Ui::quiet())?;
/// let doc = serde_json::to_value(fit::JointJson { joint })?;
/// let j = &doc["joint"][0];
/// for key in ["name", "files", "fit", "single", "wald", "moment_test"] {
///     assert!(j.get(key).is_some(), "{key}");
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct JointJson {
    /// One entry per channel.
    pub joint: Vec<JointChannel>,
}

/// Fits one model to each channel of several recordings of one sensor (GMWM only; no
/// selection, no bootstrap): the inputs are read alike (same channels), their Allan variances
/// (robust ones with `robust = Some(efficiency)`) pooled with their covariances.
///
/// ```
/// use imunoise::pipeline::{fit, read::Input, simulate};
/// // two recordings of one gyro (the same noise, other seeds)
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let dir = tempfile::tempdir()?;
/// let mut inputs = Vec::new();
/// for seed in [1, 2] {
///     let p = dir.path().join(format!("run{seed}.csv"));
///     let cols = simulate::simulate_channels(&model, 1 << 13, 100.0, seed, 1)?;
///     simulate::write_csv(&mut std::fs::File::create(&p)?, &["gyro_x_rads".into()], &cols)?;
///     inputs.push(Input { rate: Some(100.0), ..Input::new(p) });
/// }
/// let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let joint = fit::fit_joint(&inputs, &settings, None, &imunoise::Ui::quiet())?;
/// assert_eq!(joint.len(), 1); // one entry per channel
/// let files: Vec<String> = inputs.iter().map(|i| i.file.display().to_string()).collect();
/// assert_eq!(joint[0].files, files);
/// // selection, bootstrap and the other methods are refused
/// let sel = fit::FitSettings { select: true, ..settings };
/// assert!(fit::fit_joint(&inputs, &sel, None, &imunoise::Ui::quiet()).is_err());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_joint(
    inputs: &[Input],
    settings: &FitSettings,
    robust: Option<f64>,
    ui: &Ui,
) -> Result<Vec<JointChannel>> {
    if settings.method != Method::Gmwm || settings.select || settings.bootstrap > 0 {
        return Err(Error::Usage(
            "several files: the joint fit works with --method gmwm, without --select and \
             without --bootstrap"
                .into(),
        ));
    }
    // the model and the level are checked before any recording is read
    let template = settings.check()?;
    let Some(first) = inputs.first() else {
        return Err(Error::Usage(
            "a joint fit needs at least one recording".into(),
        ));
    };
    let mut per_file: Vec<(Vec<String>, Vec<Unit>, ChannelCurves)> = Vec::new();
    for input in inputs {
        let (table, units, mut curves) = read_curves(input, settings.alpha, ui)?;
        if let Some(e) = robust {
            let r = robust_curves(&table, table.rate()?, settings.alpha, e, Some(&curves))?;
            curves = r.into_iter().map(|(n, r)| (n, r.robust)).collect();
        }
        if let Some((names0, _, _)) = per_file.first()
            && *names0 != table.names
        {
            return Err(Error::Usage(format!(
                "{}: channels {:?} differ from those of {} ({:?})",
                input.file.display(),
                table.names,
                first.file.display(),
                names0
            )));
        }
        per_file.push((table.names.clone(), units, curves));
    }
    let opts = GmwmOptions {
        weighting: settings.weighting.weighting(),
        robust,
        ..GmwmOptions::default()
    };
    let (names, units, _) = &per_file[0];
    let mut out = Vec::new();
    for (k, name) in names.iter().enumerate() {
        let e = |x| fit_err(name, x);
        let cs: Vec<AvCurve> = per_file
            .iter()
            .map(|(_, _, c)| AvCurve::from_avar(&c[k].1))
            .collect::<std::result::Result<_, _>>()
            .map_err(e)?;
        let j = gmwm_prep::multi::fit_joint(&cs, &template, &opts, settings.alpha).map_err(e)?;
        let mk = |f: &GmwmFit, inf: &gmwm_prep::inference::Inference, v: CovMatrix| {
            let r = FitReport::from_gmwm(f, Some(inf), &units[k]);
            let ci = CiInfo {
                method: CiMethod::DeltaModelCov,
                alpha: settings.alpha,
                inference: Some(GmwmInference { fit: f.clone(), v }),
            };
            from_report(name, &r, None, &f.kinds, ci)
        };
        let joint = mk(&j.fit, &j.inference, j.pooled_cov.clone());
        let single = j
            .single
            .iter()
            .map(|s| {
                let v = fit_covariance(&s.fit).map_err(e)?;
                Ok(mk(&s.fit, &s.inference, v))
            })
            .collect::<Result<Vec<_>>>()?;
        out.push(JointChannel {
            name: name.clone(),
            files: inputs
                .iter()
                .map(|i| i.file.display().to_string())
                .collect(),
            fit: joint,
            single,
            wald: j.wald,
            moment_test: j.moments,
        });
    }
    Ok(out)
}

/// Prepends each channel's data-quality findings to its fit's warnings.
///
/// ```
/// # use imunoise::avar::{AvarConfig, allan_variance};
/// # use imunoise::pipeline::{fit, simulate};
/// # use imunoise::processes::Unit;
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let x = simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?.remove(0);
/// # let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// // `f`: a GMWM fit of WN+RW to a simulated gyro channel in rad/s
/// let f = fit::fit_channel("gyro_x", &av, &Unit::RadPerSec, &settings, &|| {})?;
/// let mut fits = vec![f];
/// let before = fits[0].warnings.clone();
/// fit::attach_quality(&mut fits, vec![vec!["data quality: a spike".to_string()]]);
/// assert_eq!(fits[0].warnings[0], "data quality: a spike");
/// assert_eq!(fits[0].warnings[1..], before[..]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn attach_quality(fits: &mut [ChannelFit], quality: Vec<Vec<String>>) {
    for (f, mut q) in fits.iter_mut().zip(quality) {
        q.append(&mut f.warnings);
        f.warnings = q;
    }
}

/// Writes joint fits as text tables.
///
/// ```
/// # use imunoise::pipeline::{fit, read::Input, simulate};
/// # // two recordings of one gyro (the same noise, other seeds)
/// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// # let dir = tempfile::tempdir()?;
/// # let mut inputs = Vec::new();
/// # for seed in [1, 2] {
/// #     let p = dir.path().join(format!("run{seed}.csv"));
/// #     let cols = simulate::simulate_channels(&model, 1 << 13, 100.0, seed, 1)?;
/// #     simulate::write_csv(&mut std::fs::File::create(&p)?, &["gyro_x_rads".into()], &cols)?;
/// #     inputs.push(Input { rate: Some(100.0), ..Input::new(p) });
/// # }
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let joint = fit::fit_joint(&inputs, &settings, None, &imunoise::Ui::quiet())?;
/// let mut out = Vec::new();
/// fit::write_joint_table(&mut out, &joint, 0.05)?;
/// let text = String::from_utf8(out)?;
/// assert!(text.starts_with("gyro_x_rads: one model for 2 recordings"));
/// assert!(text.contains("equal parameters (Wald)") && text.contains("equal AV curves (J-type)"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_joint_table(
    out: &mut impl Write,
    joint: &[JointChannel],
    alpha: f64,
) -> std::io::Result<()> {
    for j in joint {
        writeln!(
            out,
            "{}: one model for {} recordings",
            j.name,
            j.files.len()
        )?;
        write_table(out, std::slice::from_ref(&j.fit), alpha, 0)?;
        for (f, s) in j.files.iter().zip(&j.single) {
            writeln!(out, "  alone, {f}:")?;
            for p in &s.parameters {
                write_param_row(out, "    ", p)?;
            }
        }
        writeln!(
            out,
            "  equal parameters (Wald): W = {:.3}, dof = {}, p = {:.4}",
            j.wald.statistic, j.wald.dof, j.wald.p_value
        )?;
        writeln!(
            out,
            "  equal AV curves (J-type): J = {:.3}, dof = {}, p = {:.4}\n",
            j.moment_test.statistic, j.moment_test.dof, j.moment_test.p_value
        )?;
    }
    Ok(())
}

/// The whole of `imunoise fit` for one recording: each channel's Allan variance on the
/// dyadic scales with chi-square CIs (or its robust AV with `robust` = the Gaussian
/// efficiency), the data-quality findings, and the fit as `settings` say, channels in the
/// order of `table`. The `fit` command and the Python package's `imunoise.fit` both call it.
///
/// ```
/// use imunoise::pipeline::{fit, simulate};
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4)".parse()?;
/// let cols = simulate::simulate_channels(&model, 1 << 14, 100.0, 1, 1)?;
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gyro_x_dps".into()],
///     columns: cols.into_iter().map(Into::into).collect(),
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let units = imunoise::units::channel_units(&table.names, None)?;
/// let settings = fit::FitSettings { model: "WN".into(), ..Default::default() };
/// let fits = fit::fit_table(&table, &units, &settings, None, &imunoise::Ui::quiet())?;
/// let wn = fits[0].parameters[0].value; // per-sample variance in (°/s)²
/// assert!((wn / 1e-4 - 1.0).abs() < 0.05);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_table(
    table: &crate::io::Table,
    units: &[Unit],
    settings: &FitSettings,
    robust: Option<f64>,
    ui: &Ui,
) -> Result<Vec<ChannelFit>> {
    let rate = table.rate()?;
    let mut curves = super::estimate::fit_curves(table, settings.alpha, ui)?;
    let quality = super::estimate::check_quality(table, rate, Some(&curves), ui)?;
    if let Some(e) = robust {
        let r = robust_curves(table, rate, settings.alpha, e, Some(&curves))?;
        curves = r.into_iter().map(|(n, r)| (n, r.robust)).collect();
    }
    let mut fits = fit_all_robust(&curves, units, settings, robust, ui)?;
    attach_quality(&mut fits, quality);
    Ok(fits)
}
