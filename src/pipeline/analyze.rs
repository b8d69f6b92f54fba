//! Analysing: everything for one recording at once. Each channel's Allan variance with CIs,
//! the data-quality findings, the best sub-model by WIC fitted by GMWM with CIs, and the
//! contamination check (classical against robust AV), with the robust fit on request. The
//! result is an [`Analysis`]: plain data, its `results.json` document, and its report folder.

use super::estimate::{ChannelCurves, check_quality, fit_curves, robust_curves};
use super::fit::{ChannelFit, DEFAULT_MODEL, FitSettings, Method, attach_quality, fit_all_robust};
use super::report::{ReportInput, RobustReport};
use crate::error::{Error, Result};
use crate::io::Table;
use crate::ui::Ui;
use avar::AllanVariance;
use avar::robust::RobustAllanVariance;
use gmwm_prep::robust::ContaminationCheck;
use processes::Unit;
use std::path::Path;

/// The full model whose sub-models `analyze` selects from by default.
pub const ANALYZE_MODEL: &str = "QN+WN+RW+BI+2*SIN+2*AR1";

/// What `analyze` does.
///
/// ```
/// use imunoise::pipeline::analyze::AnalyzeSettings;
/// let s = AnalyzeSettings::default();
/// assert!(s.select && !s.robust);
/// assert_eq!(s.record_halfwidth, 0.1);
/// assert_eq!(s.efficiency, 0.6);
/// ```
#[derive(Debug, Clone)]
pub struct AnalyzeSettings {
    /// The fit. With `select` and the default model ([`DEFAULT_MODEL`]) the candidates are
    /// the sub-models of [`ANALYZE_MODEL`].
    pub fit: FitSettings,
    /// Select the best sub-model by WIC (GMWM only); `false` fits `fit.model` as it is.
    pub select: bool,
    /// Fit the robust Allan variance too (the contamination check runs in any case).
    pub robust: bool,
    /// Gaussian efficiency of the robust AV, in [0.05, 0.99].
    pub efficiency: f64,
    /// Relative half-width of the 95 % CI on the Allan deviation at the bias-instability τ
    /// that "how long to record" aims at, in (0, 1).
    pub record_halfwidth: f64,
}

impl Default for AnalyzeSettings {
    fn default() -> Self {
        AnalyzeSettings {
            fit: FitSettings::default(),
            select: true,
            robust: false,
            efficiency: avar::robust::DEFAULT_EFFICIENCY,
            record_halfwidth: 0.1,
        }
    }
}

impl AnalyzeSettings {
    /// The fit settings `analyze` uses: selection on for GMWM (unless `select` is off), and
    /// the default model widened to [`ANALYZE_MODEL`] when selecting.
    ///
    /// ```
    /// use imunoise::pipeline::analyze::{ANALYZE_MODEL, AnalyzeSettings};
    /// use imunoise::pipeline::fit::{DEFAULT_MODEL, Method};
    /// let s = AnalyzeSettings::default().effective_fit();
    /// assert!(s.select);
    /// assert_eq!(s.model, ANALYZE_MODEL);
    /// // without selection the model is fitted as it is
    /// let s = AnalyzeSettings { select: false, ..Default::default() }.effective_fit();
    /// assert!(!s.select);
    /// assert_eq!(s.model, DEFAULT_MODEL);
    /// // selection is by WIC, a GMWM criterion: other methods do not select
    /// let mut a = AnalyzeSettings::default();
    /// a.fit.method = Method::Avlr;
    /// assert!(!a.effective_fit().select);
    /// ```
    pub fn effective_fit(&self) -> FitSettings {
        let mut s = self.fit.clone();
        s.select = self.select && s.method == Method::Gmwm;
        if s.select && s.model.replace(' ', "") == DEFAULT_MODEL {
            s.model = ANALYZE_MODEL.to_string();
        }
        s
    }

    /// Checks the settings before any data is read ([`FitSettings::check`] on
    /// [`effective_fit`](Self::effective_fit), the robust efficiency, the "how long to record"
    /// target), so that a bad option is reported at once rather than after the read; returns
    /// the model template that will be fitted.
    ///
    /// ```
    /// use imunoise::pipeline::analyze::AnalyzeSettings;
    /// assert!(AnalyzeSettings::default().check().is_ok());
    /// assert!(AnalyzeSettings { record_halfwidth: 2.0, ..Default::default() }.check().is_err());
    /// assert!(AnalyzeSettings { efficiency: 1.5, ..Default::default() }.check().is_err());
    /// let mut typo = AnalyzeSettings::default();
    /// typo.fit.model = "WN+FOO".into();
    /// assert!(typo.check().is_err());
    /// ```
    pub fn check(&self) -> Result<processes::Model> {
        let h = self.record_halfwidth;
        if !(h > 0.0 && h < 1.0) {
            return Err(Error::Usage(format!(
                "--record-halfwidth must lie in (0, 1), e.g. 0.1 for ±10 %, got {h}"
            )));
        }
        super::fit::robust_efficiency(self.robust, self.efficiency)?;
        self.effective_fit().check()
    }
}

/// The result of [`analyze`]: the data, the curves and the fits, all channels in the order of
/// the table.
///
/// ```
/// use imunoise::pipeline::{analyze, simulate};
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gyro_x_dps".into(), "gyro_y_dps".into()],
///     columns: simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 2)?
///         .into_iter()
///         .map(Into::into)
///         .collect(),
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let units = imunoise::units::channel_units(&table.names, None)?;
/// let settings = analyze::AnalyzeSettings::default();
/// let a = analyze::analyze(table, units, &settings, &imunoise::Ui::quiet())?;
/// // one curve, fit, robust curve and contamination check per channel, in table order
/// assert_eq!(a.curves.len(), 2);
/// assert_eq!(a.fits[1].name, "gyro_y_dps");
/// assert_eq!(a.robust_curves[0].0, a.curves[0].0);
/// assert_eq!(a.checks.len(), 2);
/// // the robust curves are fitted only with `robust`
/// assert!(a.robust_fits.is_none());
/// assert_eq!(a.efficiency, settings.efficiency);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug)]
pub struct Analysis {
    /// The data analysed.
    pub table: Table,
    /// Each channel's unit.
    pub units: Vec<Unit>,
    /// Each channel's Allan variance (dyadic scales, chi-square CIs).
    pub curves: ChannelCurves,
    /// Each channel's fit (its `warnings` start with the data-quality findings).
    pub fits: Vec<ChannelFit>,
    /// Each channel's robust Allan variance.
    pub robust_curves: Vec<(String, RobustAllanVariance)>,
    /// Each channel's contamination check.
    pub checks: Vec<ContaminationCheck>,
    /// The fits of the robust curves (with `robust`).
    pub robust_fits: Option<Vec<ChannelFit>>,
    /// The fit settings used (see [`AnalyzeSettings::effective_fit`]).
    pub settings: FitSettings,
    /// The robust AV's Gaussian efficiency.
    pub efficiency: f64,
    /// The target of "how long to record" (see [`AnalyzeSettings::record_halfwidth`]).
    pub record_halfwidth: f64,
}

/// Analyses every channel of `table` (at its rate) with `units` as [`AnalyzeSettings`] say.
///
/// ```
/// use imunoise::pipeline::{analyze, simulate};
/// use imunoise::processes::Unit;
/// // a gyro in °/s and an accelerometer in g, white noise and a random walk each, at 100 Hz
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gyro_x_dps".into(), "acc_x_g".into()],
///     columns: simulate::simulate_channels(&model, 1 << 13, 100.0, 7, 2)?
///         .into_iter()
///         .map(Into::into)
///         .collect(),
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let units = imunoise::units::channel_units(&table.names, None)?;
/// let ui = imunoise::Ui::quiet();
/// let settings = analyze::AnalyzeSettings { robust: true, ..Default::default() };
/// let a = analyze::analyze(table.clone(), units.clone(), &settings, &ui)?;
/// assert_eq!(a.units, [Unit::DegPerSec, Unit::G]);
/// assert_eq!(a.fits.len(), 2);
/// assert_eq!(a.robust_fits.as_ref().map(Vec::len), Some(2));
/// // the sub-models are selected from ANALYZE_MODEL
/// assert_eq!(a.settings.model, analyze::ANALYZE_MODEL);
/// assert!(a.fits.iter().all(|f| f.wic.is_some()));
/// // a target half-width outside (0, 1) is a usage error
/// let bad = analyze::AnalyzeSettings { record_halfwidth: 1.5, ..Default::default() };
/// let e = analyze::analyze(table, units, &bad, &ui).unwrap_err();
/// assert_eq!(e.exit_code(), 2);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn analyze(
    table: Table,
    units: Vec<Unit>,
    settings: &AnalyzeSettings,
    ui: &Ui,
) -> Result<Analysis> {
    settings.check()?;
    let rate = table.rate()?;
    let h = settings.record_halfwidth;
    let fit = settings.effective_fit();
    let robust = super::fit::robust_efficiency(settings.robust, settings.efficiency)?;
    let curves = fit_curves(&table, fit.alpha, ui)?;
    let quality = check_quality(&table, rate, Some(&curves), ui)?;
    let mut fits = fit_all_robust(&curves, &units, &fit, None, ui)?;
    attach_quality(&mut fits, quality);
    // the contamination check, always
    let pb = ui.spinner("robust Allan variance");
    let rcurves = robust_curves(&table, rate, fit.alpha, settings.efficiency, Some(&curves))?;
    let checks = rcurves
        .iter()
        .zip(&table.columns)
        .map(|((n, r), x)| {
            gmwm_prep::robust::contamination_check(x, r, 0.01, 5)
                .map_err(|e| Error::Usage(format!("channel {n:?}: contamination check: {e}")))
        })
        .collect::<Result<Vec<_>>>()?;
    pb.finish_and_clear();
    let robust_fits = match robust {
        Some(e) => {
            let rc: Vec<(String, AllanVariance)> = rcurves
                .iter()
                .map(|(n, r)| (n.clone(), r.robust.clone()))
                .collect();
            Some(fit_all_robust(&rc, &units, &fit, Some(e), ui)?)
        }
        None => None,
    };
    Ok(Analysis {
        table,
        units,
        curves,
        fits,
        robust_curves: rcurves,
        checks,
        robust_fits,
        settings: fit,
        efficiency: settings.efficiency,
        record_halfwidth: h,
    })
}

impl Analysis {
    /// Everything the report is made of.
    ///
    /// ```
    /// # use imunoise::pipeline::{analyze, simulate};
    /// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
    /// # let table = imunoise::io::Table {
    /// #     file: "gyro.csv".into(),
    /// #     names: vec!["gyro_x_rads".into()],
    /// #     columns: vec![simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?[0].clone().into()],
    /// #     rate_hz: Some(100.0),
    /// #     timing: None,
    /// #     topic: None,
    /// # };
    /// # let units = imunoise::units::channel_units(&table.names, None)?;
    /// # let ui = imunoise::Ui::quiet();
    /// // `a`: the analysis of one simulated gyro channel in rad/s at 100 Hz
    /// let a = analyze::analyze(table, units, &analyze::AnalyzeSettings::default(), &ui)?;
    /// let inp = a.report_input()?;
    /// assert_eq!(inp.source, "gyro.csv");
    /// assert_eq!(inp.rate_hz, 100.0);
    /// assert_eq!(inp.fits.len(), a.fits.len());
    /// // the contamination check is always part of it
    /// assert_eq!(inp.robust.map(|r| r.checks.len()), Some(1));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn report_input(&self) -> Result<ReportInput<'_>> {
        Ok(ReportInput {
            source: &self.table.file,
            rate_hz: self.table.rate()?,
            names: &self.table.names,
            columns: &self.table.columns,
            units: &self.units,
            curves: &self.curves,
            fits: &self.fits,
            extra_html: String::new(),
            bootstrap: self.settings.bootstrap,
            topic: self.table.topic.as_deref(),
            timing: self.table.timing.as_ref(),
            robust: Some(RobustReport {
                curves: &self.robust_curves,
                checks: &self.checks,
                fits: self.robust_fits.as_deref(),
            }),
            record_halfwidth: self.record_halfwidth,
        })
    }

    /// The `results.json` document (see [`super::report::results_json`]).
    ///
    /// ```
    /// # use imunoise::pipeline::{analyze, simulate};
    /// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
    /// # let table = imunoise::io::Table {
    /// #     file: "gyro.csv".into(),
    /// #     names: vec!["gyro_x_rads".into()],
    /// #     columns: vec![simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?[0].clone().into()],
    /// #     rate_hz: Some(100.0),
    /// #     timing: None,
    /// #     topic: None,
    /// # };
    /// # let units = imunoise::units::channel_units(&table.names, None)?;
    /// # let ui = imunoise::Ui::quiet();
    /// // `a`: the analysis of one simulated gyro channel in rad/s at 100 Hz
    /// let a = analyze::analyze(table, units, &analyze::AnalyzeSettings::default(), &ui)?;
    /// let json = a.results_json()?;
    /// assert_eq!(json["source"], "gyro.csv");
    /// assert_eq!(json["rate_hz"], 100.0);
    /// let ch = &json["channels"][0];
    /// assert_eq!(ch["name"], "gyro_x_rads");
    /// assert_eq!(ch["unit"], "rad/s");
    /// assert_eq!(ch["fit"]["model"], a.fits[0].model.as_str());
    /// assert_eq!(ch["avar"].as_array().unwrap().len(), a.curves[0].1.points.len());
    /// assert!(ch["robust"]["check"].is_object());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn results_json(&self) -> Result<serde_json::Value> {
        super::report::results_json(&self.report_input()?)
    }

    /// Writes the report folder into `dir` (created if needed).
    ///
    /// ```
    /// # use imunoise::pipeline::{analyze, simulate};
    /// # let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
    /// # let table = imunoise::io::Table {
    /// #     file: "gyro.csv".into(),
    /// #     names: vec!["gyro_x_rads".into()],
    /// #     columns: vec![simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?[0].clone().into()],
    /// #     rate_hz: Some(100.0),
    /// #     timing: None,
    /// #     topic: None,
    /// # };
    /// # let units = imunoise::units::channel_units(&table.names, None)?;
    /// # let ui = imunoise::Ui::quiet();
    /// // `a`: the analysis of one simulated gyro channel in rad/s at 100 Hz
    /// let a = analyze::analyze(table, units, &analyze::AnalyzeSettings::default(), &ui)?;
    /// let dir = tempfile::tempdir()?;
    /// let out = dir.path().join("report");
    /// a.write_report(&out, &ui)?;
    /// for f in ["report.html", "results.json", "avar.csv", "imu.yaml", "adev_gyro_x_rads.svg"] {
    ///     assert!(out.join(f).is_file(), "{f}");
    /// }
    /// let json: serde_json::Value =
    ///     serde_json::from_str(&std::fs::read_to_string(out.join("results.json"))?)?;
    /// assert_eq!(json["channels"][0]["fit"]["model"], a.fits[0].model.as_str());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn write_report(&self, dir: &Path, ui: &Ui) -> Result<()> {
        super::report::write_report(dir, &self.report_input()?, ui)
    }
}
