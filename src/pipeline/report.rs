//! The report folder of an analysis: `report.html` (self-contained), `results.json`,
//! `avar.csv`, a Kalibr-style `imu.yaml` and the plots (SVG, and PNG with the `png`
//! feature), from a [`ReportInput`]; and the pieces the report is made of (the read-off
//! marks, how long to record, the Kalibr YAML text).

use super::fit::ChannelFit;
use crate::error::{Error, Result};
use crate::plot::{AdevPlot, Series, acf_svg, adev_svg, residuals_svg, timeseries_svg};
use crate::ui::Ui;
use avar::AllanVariance;
use gmwm_prep::noise_terms::{NoiseTerm, TermSource};
use processes::number::sig;
use processes::{Sensor, Unit};
use rayon::prelude::*;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// One channel in `results.json`.
///
/// ```
/// # use imunoise::pipeline::{estimate, fit, report, simulate};
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
/// # let curves = estimate::fit_curves(&table, 0.05, &ui)?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// # let fits = fit::fit_all(&curves, &units, &settings, &ui)?;
/// # let inp = report::ReportInput {
/// #     source: &table.file,
/// #     rate_hz: 100.0,
/// #     names: &table.names,
/// #     columns: &table.columns,
/// #     units: &units,
/// #     curves: &curves,
/// #     fits: &fits,
/// #     extra_html: String::new(),
/// #     bootstrap: 0,
/// #     topic: None,
/// #     timing: None,
/// #     robust: None,
/// #     record_halfwidth: 0.1,
/// # };
/// // `inp`: the report input of a WN+RW fit to a simulated gyro channel in rad/s at 100 Hz
/// let json = report::results_json(&inp)?;
/// let ch = json["channels"][0].as_object().unwrap();
/// let keys: Vec<&str> = ch.keys().map(String::as_str).collect();
/// assert_eq!(keys, ["avar", "fit", "n", "name", "record_length", "sensor", "unit"]);
/// assert_eq!(ch["n"], 8192);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Serialize)]
pub struct ChannelResult<'a> {
    /// Channel name.
    pub name: &'a str,
    /// Unit.
    pub unit: &'a Unit,
    /// Sensor kind.
    pub sensor: Sensor,
    /// Number of samples.
    pub n: usize,
    /// Allan variance curve (same point shape as `imunoise avar`).
    pub avar: Vec<super::estimate::PointJson>,
    /// The fit (same shape as one channel of `imunoise fit --format json`).
    pub fit: &'a ChannelFit,
    /// How long to record for the report's target precision at τ_B.
    pub record_length: Option<RecordLength>,
}

/// `results.json`.
///
/// ```
/// use imunoise::pipeline::report::Results;
/// let r = Results {
///     source: "imu.csv",
///     rate_hz: 100.0,
///     topic: None,
///     timing: None,
///     channels: vec![],
/// };
/// let json = serde_json::to_value(&r)?;
/// assert_eq!(json["source"], "imu.csv");
/// // topic and timing are there for logs only
/// assert!(json.get("topic").is_none() && json.get("timing").is_none());
/// # Ok::<(), serde_json::Error>(())
/// ```
#[derive(Debug, Serialize)]
pub struct Results<'a> {
    /// Source of the data.
    pub source: &'a str,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// The topic (or log message) analysed, for logs.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub topic: Option<&'a str>,
    /// What the time stamps said (rate source, reordered, duplicates, gaps, policy), for
    /// time-stamped input.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub timing: Option<&'a crate::logs::Timing>,
    /// Channels.
    pub channels: Vec<ChannelResult<'a>>,
}

/// Everything the report is made of.
///
/// [`crate::pipeline::analyze::Analysis::report_input`] makes one; here one is made from the
/// fit of a single channel, without the robust part.
///
/// ```
/// use imunoise::pipeline::{estimate, fit, report, simulate};
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let table = imunoise::io::Table {
///     file: "gyro.csv".into(),
///     names: vec!["gyro_x_rads".into()],
///     columns: vec![simulate::simulate_channels(&model, 1 << 13, 100.0, 1, 1)?[0].clone().into()],
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let units = imunoise::units::channel_units(&table.names, None)?;
/// let ui = imunoise::Ui::quiet();
/// let curves = estimate::fit_curves(&table, 0.05, &ui)?;
/// let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// let fits = fit::fit_all(&curves, &units, &settings, &ui)?;
/// let inp = report::ReportInput {
///     source: &table.file,
///     rate_hz: 100.0,
///     names: &table.names,
///     columns: &table.columns,
///     units: &units,
///     curves: &curves,
///     fits: &fits,
///     extra_html: String::new(),
///     bootstrap: 0,
///     topic: None,
///     timing: None,
///     robust: None,
///     record_halfwidth: 0.1,
/// };
/// let json = report::results_json(&inp)?;
/// assert_eq!(json["channels"][0]["fit"]["model"], fits[0].model.as_str());
/// assert!(json["channels"][0].get("robust").is_none());
/// assert!(report::kalibr_yaml(&inp).contains("gyroscope_noise_density: "));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct ReportInput<'a> {
    /// Title / source of the data.
    pub source: &'a str,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Channel names.
    pub names: &'a [String],
    /// Channel samples.
    pub columns: &'a [crate::io::Column],
    /// Units.
    pub units: &'a [Unit],
    /// AV curves.
    pub curves: &'a [(String, AllanVariance)],
    /// Fits.
    pub fits: &'a [ChannelFit],
    /// Extra HTML inserted after the summary (e.g. the demo's truth table).
    pub extra_html: String,
    /// Bootstrap replicates behind the CIs (0: none), for their description.
    pub bootstrap: usize,
    /// The topic (or log message) analysed, for logs.
    pub topic: Option<&'a str>,
    /// What the time stamps said, for time-stamped input.
    pub timing: Option<&'a crate::logs::Timing>,
    /// The classical-vs-robust comparison (analyze's contamination check), if made.
    pub robust: Option<RobustReport<'a>>,
    /// Relative half-width of the 95 % CI on the Allan deviation at the bias-instability τ
    /// that the "how long to record" section aims at (0.1: ±10 %).
    pub record_halfwidth: f64,
}

/// The robust part of a report: each channel's robust AV, the contamination check and, when
/// the robust curve was fitted too, its fit.
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
/// let settings = analyze::AnalyzeSettings { robust: true, ..Default::default() };
/// let a = analyze::analyze(table, units, &settings, &ui)?;
/// let inp = a.report_input()?;
/// let rob = inp.robust.expect("analyze always checks for contamination");
/// assert_eq!(rob.curves[0].0, "gyro_x_rads");
/// assert_eq!(rob.checks.len(), 1);
/// assert_eq!(rob.fits.map(<[_]>::len), Some(1)); // fitted: `robust` was set
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy)]
pub struct RobustReport<'a> {
    /// Each channel's robust Allan variance.
    pub curves: &'a [(String, avar::robust::RobustAllanVariance)],
    /// Each channel's classical-vs-robust check.
    pub checks: &'a [gmwm_prep::robust::ContaminationCheck],
    /// The fits of the robust curves (with `--robust`).
    pub fits: Option<&'a [ChannelFit]>,
}

/// A channel name as a file-name stem: ASCII letters, digits, `-` and `_` kept, the rest `_`.
///
/// ```
/// assert_eq!(imunoise::pipeline::report::file_safe("gyro x/°"), "gyro_x__");
/// ```
pub fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The file-name stems of the channels `names`: [`file_safe`], with a stem that an earlier
/// channel already took suffixed by the channel's number (`gyro x` and `gyro_x` would both
/// be `gyro_x`, and the second channel's plots would overwrite the first's).
///
/// ```
/// use imunoise::pipeline::report::file_stems;
/// let names = ["gyro x".to_string(), "gyro_x".to_string(), "acc".to_string()];
/// assert_eq!(file_stems(&names), ["gyro_x", "gyro_x_2", "acc"]);
/// ```
pub fn file_stems(names: &[String]) -> Vec<String> {
    let mut out: Vec<String> = Vec::with_capacity(names.len());
    for (k, name) in names.iter().enumerate() {
        let mut stem = file_safe(name);
        if out.contains(&stem) {
            stem = format!("{stem}_{}", k + 1);
            while out.contains(&stem) {
                stem.push('_');
            }
        }
        out.push(stem);
    }
    out
}

/// A number with 4 significant digits: fixed notation between 1e-3 and 1e5, else scientific.
///
/// ```
/// use imunoise::pipeline::report::num;
/// assert_eq!(num(1.5), "1.500");
/// assert_eq!(num(0.25), "0.2500");
/// assert_eq!(num(1234.5), "1234");
/// assert_eq!(num(2.0e6), "2.000e6");
/// assert_eq!(num(0.0), "0");
/// ```
pub fn num(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".to_string()
    } else if (1e-3..1e5).contains(&a) {
        let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        format!("{x:.digits$}")
    } else {
        format!("{x:.3e}")
    }
}

/// Where the Allan deviation plots go in the page: right below the summary table.
const FIRST_SCREEN_END: &str = "<!--first-screen-end-->\n";

/// One N, K or B cell of the summary: value, CI and unit, its source underneath, and a flag
/// when the model's value and the read-off disagree beyond their CIs.
fn term_cell(t: &NoiseTerm) -> String {
    let ci = match (t.source, t.ci_lo, t.ci_hi) {
        (TermSource::UpperBound, ..) => String::new(),
        (_, Some(a), Some(b)) => format!("<br><small>[{}, {}]</small>", sig(a, 4), sig(b, 4)),
        _ => String::new(),
    };
    let value = match t.source {
        TermSource::UpperBound => format!("≤ {}", sig(t.value, 4)),
        _ => sig(t.value, 4),
    };
    let from = match t.source {
        TermSource::Model => format!("model: {}", t.basis),
        TermSource::ReadOff => "IEEE read-off".to_string(),
        TermSource::UpperBound => "upper bound".to_string(),
    };
    let flag = match (&t.read_off, t.disagrees) {
        (Some(r), true) => format!(
            "<br><small class=no>read-off {} disagrees</small>",
            sig(r.value, 4)
        ),
        _ => String::new(),
    };
    format!(
        "{value} {}{ci}<br><small title=\"{}\">{}</small>{flag}",
        html_esc(&t.unit),
        html_esc(&t.basis),
        html_esc(&from)
    )
}

/// The report's first screen: per channel N, K, B with CIs and sources, the verdict on the
/// fit and the model in 4 significant digits; then [`FIRST_SCREEN_END`], where the plots go.
fn summary_table(inp: &ReportInput<'_>) -> String {
    let mut h = String::from(
        "<h2>Summary: the values a filter needs</h2><table><tr><th class=l>channel</th><th class=l>unit</th><th class=l>verdict</th><th>N (ARW/VRW)</th><th>K (RRW)</th><th>B (bias instability)</th><th class=l>fitted model (per sample)</th></tr>\n",
    );
    for (k, f) in inp.fits.iter().enumerate() {
        let verdict = match &f.adequacy {
            Some(a) if a.adequate => format!(
                "<span style=\"color:#007a3d\">adequate</span><br><small>inside the CI at {}/{}</small>",
                a.n_inside, a.n_scales
            ),
            Some(a) => format!(
                "<span class=no>not adequate</span><br><small>inside the CI at {}/{}{}</small>",
                a.n_inside,
                a.n_scales,
                {
                    // the three widest ranges, the rest counted
                    let mut r: Vec<_> = a.unexplained.iter().collect();
                    r.sort_by_key(|x| std::cmp::Reverse(x.n_scales));
                    let more = r.len().saturating_sub(3);
                    let mut t: String = r
                        .iter()
                        .take(3)
                        .map(|x| format!("<br>{}", html_esc(&x.describe())))
                        .collect();
                    if more > 0 {
                        t.push_str(&format!("<br>and {more} more (see the fit check)"));
                    }
                    t
                }
            ),
            None => "-<br><small>no CIs to check against</small>".into(),
        };
        let cells = match &f.noise_terms {
            Some(t) => t.all().map(term_cell),
            None => ["-".to_string(), "-".to_string(), "-".to_string()],
        };
        let _ = writeln!(
            h,
            "<tr><td class=l>{}</td><td class=l>{}</td><td class=l>{verdict}</td><td>{}</td><td>{}</td><td>{}</td><td class=l><small>{}</small></td></tr>",
            html_esc(&inp.names[k]),
            html_esc(inp.units[k].symbol()),
            cells[0],
            cells[1],
            cells[2],
            html_esc(&f.model_display()),
        );
    }
    h.push_str("</table>\n<p><small>N: white-noise density from every short-memory term of the model (white noise, and AR1/GM/MA1 terms faster than the smallest τ as their white-noise equivalents); K: rate random walk; B: bias instability. Each is the fitted model's value where the model has the term, else the IEEE 952 read-off of the curve, else an upper bound; brackets: 95 % CIs. A fit is adequate when its Allan variance lies inside the estimate's 95 % CI at ≥ 90 % of the scales.</small></p>\n");
    h.push_str(FIRST_SCREEN_END);
    h
}

/// The fit-check section: the residual panels, open when a fit is not adequate, else one line
/// with the panels folded away.
fn fit_check_section(inp: &ReportInput<'_>, panels: &str) -> String {
    if panels.is_empty() {
        return String::new();
    }
    let bad: Vec<&str> = inp
        .fits
        .iter()
        .filter(|f| f.adequacy.as_ref().is_some_and(|a| !a.adequate))
        .map(|f| f.name.as_str())
        .collect();
    let (line, open) = if bad.is_empty() {
        ("every fit is adequate".to_string(), "")
    } else {
        (
            format!("not adequate: {}", html_esc(&bad.join(", "))),
            " open",
        )
    };
    format!(
        "<h2>Fit check</h2><details{open}><summary>{line}: standardised residual ln(AV / fitted AV) per scale, in units of the estimate's log-scale SD; dashed: the 95 % CI</summary><div class=plots>\n{panels}</div></details>\n"
    )
}

fn html_esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The Kalibr `imu.yaml` text: noise density N and random walk K of gyroscopes (rad/s/√Hz,
/// rad/s²/√Hz) and accelerometers (m/s²/√Hz, m/s³/√Hz), the largest over the axes of each
/// sensor (conservative, as Kalibr takes one value per sensor). N and K are the fits'
/// [`noise_terms`](super::fit::ChannelFit::noise_terms) (the values the report shows; a
/// comment names each one not taken from a plain WN or RW), and a fit that is not adequate
/// is named in a WARNING comment.
///
/// ```
/// # use imunoise::pipeline::{estimate, fit, report, simulate};
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
/// # let curves = estimate::fit_curves(&table, 0.05, &ui)?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// # let fits = fit::fit_all(&curves, &units, &settings, &ui)?;
/// # let inp = report::ReportInput {
/// #     source: &table.file,
/// #     rate_hz: 100.0,
/// #     names: &table.names,
/// #     columns: &table.columns,
/// #     units: &units,
/// #     curves: &curves,
/// #     fits: &fits,
/// #     extra_html: String::new(),
/// #     bootstrap: 0,
/// #     topic: None,
/// #     timing: None,
/// #     robust: None,
/// #     record_halfwidth: 0.1,
/// # };
/// // `inp`: the report input of a WN+RW fit to a simulated gyro channel in rad/s at 100 Hz
/// let yaml = report::kalibr_yaml(&inp);
/// let value = |key: &str| -> f64 {
///     let line = yaml.lines().find(|l| l.starts_with(key)).expect(key);
///     line[key.len() + 2..].split_whitespace().next().unwrap().parse().unwrap()
/// };
/// // N = √(σ²/f), K = √(γ²·f) from the fitted WN and RW, written with 7 digits
/// let p = &fits[0].parameters;
/// let n = (p[0].value / 100.0).sqrt();
/// let k = (p[1].value * 100.0).sqrt();
/// assert!((value("gyroscope_noise_density") / n - 1.0).abs() < 1e-6);
/// assert!((value("gyroscope_random_walk") / k - 1.0).abs() < 1e-6);
/// assert_eq!(value("update_rate"), 100.0);
/// // no accelerometer channel
/// assert!(yaml.contains("# accelerometer_noise_density: not estimated"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn kalibr_yaml(inp: &ReportInput<'_>) -> String {
    let mut vals: [Vec<f64>; 4] = Default::default(); // gN, gK, aN, aK
    let mut fallbacks: Vec<String> = Vec::new();
    let mut terms_lines: Vec<String> = Vec::new();
    for (k, f) in inp.fits.iter().enumerate() {
        let unit = &inp.units[k];
        let to_si = match unit {
            Unit::DegPerSec => std::f64::consts::PI / 180.0,
            Unit::G => gmwm_prep::units::STANDARD_GRAVITY,
            Unit::RadPerSec | Unit::MetrePerSec2 => 1.0,
            _ => continue,
        };
        let base = if unit.is_angular_rate() { 0 } else { 2 };
        if let Some(a) = f.adequacy.as_ref().filter(|a| !a.adequate) {
            fallbacks.push(format!(
                "WARNING: {}: the fitted model does not describe its Allan variance ({}); its N and K are the best this model gives, not a validated noise model",
                inp.names[k], a.reasons[0]
            ));
        }
        // N and K of the analysis (the report's and the console's values): one source
        if let Some(t) = &f.noise_terms {
            terms_lines.push(format!(
                "{}: {}",
                inp.names[k],
                t.all()
                    .iter()
                    .map(|x| format!("{} {} ({})", x.symbol, x.display(), x.basis))
                    .collect::<Vec<_>>()
                    .join("; ")
            ));
            for (term, slot) in [(&t.n, base), (&t.k, base + 1)] {
                vals[slot].push(term.per_second * to_si);
                if term.basis != "WN" && term.basis != "RW" {
                    fallbacks.push(format!(
                        "{} {} from {}",
                        inp.names[k], term.symbol, term.basis
                    ));
                }
            }
            continue;
        }
        let (mut has_n, mut has_k) = (false, false);
        for p in &f.parameters {
            match (p.process.as_str(), p.name.as_str()) {
                ("WN", "sigma2") => {
                    vals[base].push((p.value / inp.rate_hz).sqrt() * to_si);
                    has_n = true;
                }
                ("RW", "gamma2") => {
                    vals[base + 1].push((p.value * inp.rate_hz).sqrt() * to_si);
                    has_k = true;
                }
                _ => {}
            }
        }
        // A fitted model without WN (or RW) still has a noise density (random walk) on the
        // Allan deviation: fall back to the IEEE 952 read-off, and say so.
        if !(has_n && has_k) {
            let (_, av) = &inp.curves[k];
            if let Ok(ro) = gmwm_prep::ieee::read_off_adev(&av.taus(), &av.adevs(), unit) {
                use gmwm_prep::units::IeeeTerm;
                for (has, term, slot) in
                    [(has_n, IeeeTerm::N, base), (has_k, IeeeTerm::K, base + 1)]
                {
                    if !has && let Some(e) = ro.get(term) {
                        vals[slot].push(e.value * to_si);
                        fallbacks.push(format!(
                            "{} {} from the IEEE 952 read-off (the fitted model has no {})",
                            inp.names[k],
                            term.symbol(),
                            if term == IeeeTerm::N { "WN" } else { "RW" }
                        ));
                    }
                }
            }
        }
    }
    let line = |key: &str, v: &[f64], unit: &str, what: &str| match v
        .iter()
        .copied()
        .fold(None, |m: Option<f64>, x| Some(m.map_or(x, |m| m.max(x))))
    {
        Some(x) => format!("{key}: {x:.6e}   # [{unit}] {what}\n"),
        None => {
            format!("# {key}: not estimated (no such channel or component in the fitted models)\n")
        }
    };
    let mut s = String::new();
    s.push_str("# Kalibr-style IMU noise model estimated by imunoise from the Allan variance\n");
    let _ = writeln!(s, "# source: {}", inp.source);
    s.push_str("# continuous-time values, largest over the axes of each sensor\n");
    for f in &fallbacks {
        if f.starts_with("WARNING") {
            let _ = writeln!(s, "# {f}");
        } else {
            let _ = writeln!(s, "# note: {f}");
        }
    }
    if !terms_lines.is_empty() {
        s.push_str("# per axis, as in the report (IEEE units, 95 % CIs, source):\n");
        for l in &terms_lines {
            let _ = writeln!(s, "#   {l}");
        }
    }
    s.push_str("rostopic: /imu0\n");
    let _ = writeln!(s, "update_rate: {:.6}   # [Hz]", inp.rate_hz);
    s.push_str(&line(
        "accelerometer_noise_density",
        &vals[2],
        "m/s^2/sqrt(Hz)",
        "white noise N",
    ));
    s.push_str(&line(
        "accelerometer_random_walk",
        &vals[3],
        "m/s^3/sqrt(Hz)",
        "bias random walk K",
    ));
    s.push_str(&line(
        "gyroscope_noise_density",
        &vals[0],
        "rad/s/sqrt(Hz)",
        "white noise N",
    ));
    s.push_str(&line(
        "gyroscope_random_walk",
        &vals[1],
        "rad/s^2/sqrt(Hz)",
        "bias random walk K",
    ));
    s
}

/// Samples per channel: of the first column, or, for curves without their samples, of the
/// record behind the first curve.
fn samples_per_channel(inp: &ReportInput<'_>) -> usize {
    inp.columns
        .first()
        .map_or_else(|| inp.curves.first().map_or(0, |c| c.1.n), |c| c.len())
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    crate::output::write_file(path, bytes)
}

/// Writes an SVG and (with the `png` feature) its PNG rendering.
fn write_plot(dir: &Path, stem: &str, svg: &str) -> Result<()> {
    write_file(&dir.join(format!("{stem}.svg")), svg.as_bytes())?;
    #[cfg(feature = "png")]
    {
        let png =
            crate::plot::svg_to_png(svg, 1.5).map_err(|e| Error::Usage(format!("{stem}: {e}")))?;
        write_file(&dir.join(format!("{stem}.png")), &png)?;
    }
    Ok(())
}

/// The read-off points of a channel: N at τ = 1 s (σ(1) on the −1/2 line), K at τ = 3 s
/// (σ(3) on the +1/2 line), from the fitted WN and RW (else the IEEE 952 read-off), and B at
/// the minimum of the Allan deviation (B = σ_min / 0.6643).
///
/// ```
/// # use imunoise::pipeline::{estimate, fit, report, simulate};
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
/// # let curves = estimate::fit_curves(&table, 0.05, &ui)?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// # let fits = fit::fit_all(&curves, &units, &settings, &ui)?;
/// # let inp = report::ReportInput {
/// #     source: &table.file,
/// #     rate_hz: 100.0,
/// #     names: &table.names,
/// #     columns: &table.columns,
/// #     units: &units,
/// #     curves: &curves,
/// #     fits: &fits,
/// #     extra_html: String::new(),
/// #     bootstrap: 0,
/// #     topic: None,
/// #     timing: None,
/// #     robust: None,
/// #     record_halfwidth: 0.1,
/// # };
/// // `inp`: the report input of a WN+RW fit to a simulated gyro channel in rad/s at 100 Hz
/// let (av, f) = (&curves[0].1, &fits[0]);
/// let marks = report::read_off_marks(av, f, &units[0], 100.0);
/// let labels: Vec<&str> = marks.iter().map(|m| &m.label[..1]).collect();
/// assert_eq!(labels, ["N", "K", "B"]);
/// // N on the −1/2 line at τ = 1 s: √(σ²/f) from the fitted WN
/// assert_eq!((marks[0].tau, marks[0].sigma), (1.0, (f.parameters[0].value / 100.0).sqrt()));
/// // B at the minimum of the Allan deviation
/// let min = av.points.iter().map(|p| p.adev).fold(f64::INFINITY, f64::min);
/// assert_eq!(marks[2].sigma, min);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_off_marks(
    av: &AllanVariance,
    f: &ChannelFit,
    unit: &Unit,
    rate_hz: f64,
) -> Vec<crate::plot::Mark> {
    use crate::plot::Mark;
    let param = |p: &str, n: &str| {
        f.parameters
            .iter()
            .find(|x| x.process == p && x.name == n)
            .map(|x| x.value)
    };
    let ro = gmwm_prep::ieee::read_off_adev(&av.taus(), &av.adevs(), unit).ok();
    let from_ro =
        |t: gmwm_prep::units::IeeeTerm| ro.as_ref().and_then(|r| r.get(t)).map(|e| e.value);
    let n = param("WN", "sigma2")
        .map(|s2| (s2 / rate_hz).sqrt())
        .or_else(|| from_ro(gmwm_prep::units::IeeeTerm::N));
    let k = param("RW", "gamma2")
        .map(|g2| (g2 * rate_hz).sqrt())
        .or_else(|| from_ro(gmwm_prep::units::IeeeTerm::K));
    let mut marks = Vec::new();
    if let Some(n) = n {
        marks.push(Mark {
            label: format!("N = {}", num(n)),
            tau: 1.0,
            sigma: n,
        });
    }
    if let Some(k) = k {
        marks.push(Mark {
            label: format!("K = {}", num(k)),
            tau: 3.0,
            sigma: k,
        });
    }
    if let Some(p) = av
        .points
        .iter()
        .filter(|p| p.adev > 0.0)
        .min_by(|a, b| a.adev.total_cmp(&b.adev))
    {
        marks.push(Mark {
            label: format!(
                "B = {}",
                num(p.adev / crate::export::BIAS_INSTABILITY_FACTOR)
            ),
            tau: p.tau,
            sigma: p.adev,
        });
    }
    marks
}

/// How long to record for a chosen precision of the Allan deviation at the bias-instability
/// τ (see [`record_length`]).
///
/// ```
/// use imunoise::avar::{allan_variance, AvarConfig};
/// use imunoise::pipeline::report::record_length;
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let r = record_length(&av, x.len(), 100.0, 0.1).expect("a minimum with an EDF");
/// assert_eq!(r.hours_now, 4096.0 / 100.0 / 3600.0);
/// assert_eq!(r.halfwidth_target, 0.1);
/// // τ_B is a τ of the curve
/// assert!(av.points.iter().any(|p| p.tau == r.tau_b));
/// // the length needed scales with (now / target)²
/// let ratio = (r.halfwidth_now / r.halfwidth_target).powi(2);
/// assert!((r.hours_needed / r.hours_now / ratio - 1.0).abs() < 1e-6);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RecordLength {
    /// τ_B (s): where the Allan deviation has its minimum.
    pub tau_b: f64,
    /// Relative half-width of the 95 % CI on the Allan deviation at τ_B now, ≈ 1.96/√(2ν).
    pub halfwidth_now: f64,
    /// The relative half-width aimed at.
    pub halfwidth_target: f64,
    /// Length of this record (h).
    pub hours_now: f64,
    /// Record length (h) that gives `halfwidth_target`.
    pub hours_needed: f64,
}

/// How long to record for a relative 95 % CI half-width `h` on the Allan deviation at the
/// bias-instability τ (the minimum): the chi-square EDF ν there gives a half-width of about
/// 1.96/√(2ν); ν grows in proportion to the record length when T ≫ m, so the length needed
/// is T·ν_needed/ν with ν_needed = 1.96²/(2h²). `None` without a minimum with an EDF.
///
/// ```
/// use imunoise::avar::{allan_variance, AvarConfig};
/// use imunoise::pipeline::report::record_length;
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default()).unwrap();
/// let r = record_length(&av, x.len(), 100.0, 0.1).unwrap();
/// // halving the half-width needs four times the record
/// let r2 = record_length(&av, x.len(), 100.0, 0.05).unwrap();
/// assert!((r2.hours_needed / r.hours_needed - 4.0).abs() < 1e-12);
/// ```
pub fn record_length(av: &AllanVariance, n: usize, rate_hz: f64, h: f64) -> Option<RecordLength> {
    let p = av
        .points
        .iter()
        .filter(|p| p.adev > 0.0)
        .min_by(|a, b| a.adev.total_cmp(&b.adev))?;
    let edf = p.edf.filter(|e| *e > 0.0)?;
    let z = 1.959_963_984_540_054;
    let hours_now = n as f64 / rate_hz / 3600.0;
    let need = z * z / (2.0 * h * h);
    Some(RecordLength {
        tau_b: p.tau,
        halfwidth_now: z / (2.0 * edf).sqrt(),
        halfwidth_target: h,
        hours_now,
        hours_needed: hours_now * need / edf,
    })
}

/// Writes the whole report into `dir`.
///
/// ```
/// # use imunoise::pipeline::{estimate, fit, report, simulate};
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
/// # let curves = estimate::fit_curves(&table, 0.05, &ui)?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// # let fits = fit::fit_all(&curves, &units, &settings, &ui)?;
/// # let inp = report::ReportInput {
/// #     source: &table.file,
/// #     rate_hz: 100.0,
/// #     names: &table.names,
/// #     columns: &table.columns,
/// #     units: &units,
/// #     curves: &curves,
/// #     fits: &fits,
/// #     extra_html: String::new(),
/// #     bootstrap: 0,
/// #     topic: None,
/// #     timing: None,
/// #     robust: None,
/// #     record_halfwidth: 0.1,
/// # };
/// // `inp`: the report input of a WN+RW fit to a simulated gyro channel in rad/s at 100 Hz
/// let dir = tempfile::tempdir()?;
/// report::write_report(dir.path(), &inp, &ui)?;
/// for f in ["report.html", "results.json", "avar.csv", "imu.yaml"] {
///     assert!(dir.path().join(f).is_file(), "{f}");
/// }
/// // three plots per channel, named after it
/// for stem in ["adev", "series", "acf"] {
///     assert!(dir.path().join(format!("{stem}_gyro_x_rads.svg")).is_file());
/// }
/// assert_eq!(std::fs::read_to_string(dir.path().join("imu.yaml"))?, report::kalibr_yaml(&inp));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_report(dir: &Path, inp: &ReportInput<'_>, ui: &Ui) -> Result<()> {
    crate::output::create_dir(dir, "--out")?;
    let pb = ui.spinner("report and plots");
    // avar.csv
    let mut csv = Vec::new();
    super::estimate::write_csv(&mut csv, inp.curves).map_err(|e| Error::write("avar.csv", e))?;
    write_file(&dir.join("avar.csv"), &csv)?;
    write_file(
        &dir.join("results.json"),
        serde_json::to_string_pretty(&results_json(inp)?)?.as_bytes(),
    )?;
    write_file(&dir.join("imu.yaml"), kalibr_yaml(inp).as_bytes())?;
    write_html(dir, inp)?;
    pb.finish_and_clear();
    Ok(())
}

/// The `results.json` document of a report: source, rate, topic and timing, and per channel its
/// unit, sensor, sample count, Allan variance curve, fit and (with a robust part) the robust
/// entry. This is what the Python `analyze` returns as a dict.
///
/// ```
/// # use imunoise::pipeline::{estimate, fit, report, simulate};
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
/// # let curves = estimate::fit_curves(&table, 0.05, &ui)?;
/// # let settings = fit::FitSettings { model: "WN+RW".into(), ..Default::default() };
/// # let fits = fit::fit_all(&curves, &units, &settings, &ui)?;
/// # let inp = report::ReportInput {
/// #     source: &table.file,
/// #     rate_hz: 100.0,
/// #     names: &table.names,
/// #     columns: &table.columns,
/// #     units: &units,
/// #     curves: &curves,
/// #     fits: &fits,
/// #     extra_html: String::new(),
/// #     bootstrap: 0,
/// #     topic: None,
/// #     timing: None,
/// #     robust: None,
/// #     record_halfwidth: 0.1,
/// # };
/// // `inp`: the report input of a WN+RW fit to a simulated gyro channel in rad/s at 100 Hz
/// let json = report::results_json(&inp)?;
/// assert_eq!(json["source"], "gyro.csv");
/// assert_eq!(json["rate_hz"], 100.0);
/// let ch = &json["channels"][0];
/// assert_eq!(ch["name"], "gyro_x_rads");
/// assert_eq!(ch["sensor"], "Gyroscope");
/// // the fit and the curve as `imunoise fit` and `imunoise avar` write them
/// assert_eq!(ch["fit"], serde_json::to_value(&fits[0])?);
/// let avar = serde_json::to_value(&estimate::to_json(&curves).channels[0].points)?;
/// assert_eq!(ch["avar"], avar);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn results_json(inp: &ReportInput<'_>) -> Result<serde_json::Value> {
    let json = super::estimate::to_json(inp.curves);
    let results = Results {
        source: inp.source,
        rate_hz: inp.rate_hz,
        topic: inp.topic,
        timing: inp.timing,
        channels: json
            .channels
            .into_iter()
            .enumerate()
            .map(|(k, c)| ChannelResult {
                name: &inp.names[k],
                unit: &inp.units[k],
                sensor: crate::units::sensor_of(&inp.names[k], &inp.units[k]),
                n: c.n,
                avar: c.points,
                fit: &inp.fits[k],
                record_length: record_length(
                    &inp.curves[k].1,
                    c.n,
                    inp.rate_hz,
                    inp.record_halfwidth,
                ),
            })
            .collect(),
    };
    let mut doc = serde_json::to_value(&results)?;
    let Some(rob) = &inp.robust else {
        return Ok(doc);
    };
    let rjson = super::estimate::to_json(
        &rob.curves
            .iter()
            .map(|(n, r)| (n.clone(), r.robust.clone()))
            .collect::<Vec<_>>(),
    );
    if let Some(chs) = doc["channels"].as_array_mut() {
        for (k, (ch, pts)) in chs.iter_mut().zip(rjson.channels).enumerate() {
            let (_, r) = &rob.curves[k];
            let entry = RobustResult {
                efficiency: r.efficiency,
                check: &rob.checks[k],
                avar: pts.points,
                no_root_m: r
                    .robust
                    .points
                    .iter()
                    .zip(&r.root_found)
                    .filter(|(_, ok)| !**ok)
                    .map(|(p, _)| p.m)
                    .collect(),
                spikes_replaced: r.spikes.indices.len() as u64,
                spike_times_s: spike_times(r, inp.rate_hz),
                fit: rob.fits.map(|f| &f[k]),
            };
            ch["robust"] = serde_json::to_value(&entry)?;
        }
    }
    Ok(doc)
}

/// Writes the plots and `report.html`.
fn write_html(dir: &Path, inp: &ReportInput<'_>) -> Result<()> {
    let mut html = String::new();
    let _ = write!(
        html,
        r#"<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>imunoise report: {src}</title>
<style>body{{font-family:"DejaVu Sans",Verdana,Arial,sans-serif;margin:24px;max-width:1600px;color:#222}}
table{{border-collapse:collapse;margin:8px 0 18px}}td,th{{border:1px solid #ccc;padding:3px 8px;text-align:right;font-size:13px}}
th{{background:#f0f0f0}}td.l,th.l{{text-align:left}}.plots{{display:flex;flex-wrap:wrap;gap:8px}}.plots svg{{border:1px solid #ddd;max-width:100%;height:auto}}
h2{{border-bottom:2px solid #0072B2;padding-bottom:4px;margin-top:32px}}.no{{color:#C00000;font-weight:bold}}</style></head><body>
<h1>imunoise report</h1><p>Source: <code>{src}</code>, {rate} Hz, {n} samples per channel ({h:.2} h). Allan variance: book eq. 4.2 (maximum overlap), dyadic scales, 95% chi-square CIs. Fit: {method}.</p>
"#,
        src = html_esc(inp.source),
        rate = inp.rate_hz,
        n = samples_per_channel(inp),
        h = samples_per_channel(inp) as f64 / inp.rate_hz / 3600.0,
        method = inp.fits.first().map_or("-".to_string(), |f| {
            let ci = match f.ci_method {
                super::fit::CiMethod::None => "no CIs".to_string(),
                m => format!(
                    "{} CIs by {}",
                    super::fit::percent(f.ci_level.unwrap_or(0.95)),
                    m.describe(inp.bootstrap)
                ),
            };
            format!("{}, {}", f.method, html_esc(&ci))
        })
    );
    // The first screen: per channel the values a filter needs, the verdict, then the plots.
    html.push_str(&summary_table(inp));
    // What the user should know before trusting the numbers: data quality, undetermined terms.
    let remarks: Vec<String> = inp
        .fits
        .iter()
        .flat_map(|f| {
            f.warnings
                .iter()
                .map(move |w| format!("<li><b>{}</b>: {}</li>", html_esc(&f.name), html_esc(w)))
        })
        .collect();
    if !remarks.is_empty() {
        html.push_str("<h2>Remarks</h2><ul>\n");
        html.push_str(&remarks.join("\n"));
        html.push_str("</ul>\n");
    }
    // How long to record.
    let h = inp.record_halfwidth;
    let _ = writeln!(
        html,
        "<h2>How long to record</h2><p>For a ±{} % (95 %) interval on the Allan deviation at the bias-instability τ (its minimum); the EDF there grows in proportion to the record length.</p><ul>",
        100.0 * h
    );
    for (k, (name, av)) in inp.curves.iter().enumerate() {
        let n = inp.columns.get(k).map_or(av.n, |c| c.len());
        if let Some(r) = record_length(av, n, inp.rate_hz, h) {
            let _ = writeln!(
                html,
                "<li>{}: τ<sub>B</sub> = {} s, now ±{:.1} % with {:.2} h; ±{} % needs about {:.2} h.</li>",
                html_esc(name),
                num(r.tau_b),
                r.halfwidth_now * 100.0,
                r.hours_now,
                100.0 * h,
                r.hours_needed
            );
        }
    }
    html.push_str("</ul>\n");
    if let Some(t) = inp.timing {
        let _ = writeln!(
            html,
            "<h2>Time stamps</h2><p>{}{}</p>",
            inp.topic.map_or(String::new(), |t| format!(
                "Topic <code>{}</code>: ",
                html_esc(t)
            )),
            html_esc(&t.summary())
        );
    }
    if let Some(rob) = &inp.robust {
        html.push_str(&robust_section(dir, inp, rob)?);
    }
    html.push_str(&inp.extra_html);
    // Parameter table.
    let level = inp
        .fits
        .iter()
        .find_map(|f| f.ci_level)
        .map_or("no".to_string(), super::fit::percent);
    let _ = writeln!(
        html,
        "<h2>Parameters (per sample, {level} CI)</h2><table><tr><th class=l>channel</th><th class=l>process</th><th class=l>parameter</th><th>value</th><th>CI low</th><th>CI high</th></tr>"
    );
    for (k, f) in inp.fits.iter().enumerate() {
        for p in &f.parameters {
            let o = |v: Option<f64>| v.map_or("-".to_string(), |x| sig(x, 4));
            let _ = writeln!(
                html,
                "<tr><td class=l>{}</td><td class=l>{}</td><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                html_esc(&inp.names[k]),
                p.process,
                p.name,
                sig(p.value, 4),
                o(p.ci_lo),
                o(p.ci_hi)
            );
        }
    }
    html.push_str("</table>\n");
    let mut series_html = String::from("<h2>Time series</h2><div class=plots>\n");
    let mut acf_html = String::from("<h2>Autocorrelation</h2><div class=plots>\n");
    // the channels' plots in parallel (each renders three SVGs and PNGs), appended in order
    let stems = file_stems(inp.names);
    let parts = inp
        .names
        .par_iter()
        .enumerate()
        .map(|(k, name)| -> Result<[String; 4]> {
            let stem = &stems[k];
            let (_, av) = &inp.curves[k];
            let f = &inp.fits[k];
            let tau_of = |m: u64| m as f64 / inp.rate_hz;
            let plot = AdevPlot {
                title: format!("{name}: Allan deviation"),
                unit: inp.units[k].symbol().to_string(),
                observed: observed(av),
                fitted: Some(Series {
                    label: format!("fitted model ({})", f.method),
                    points: f
                        .fitted
                        .iter()
                        .map(|p| (tau_of(p.m), p.avar.max(0.0).sqrt()))
                        .collect(),
                }),
                components: f
                    .components
                    .iter()
                    .map(|(code, v)| Series {
                        label: code.clone(),
                        // the components' scales are the fit's (all of them, or those in
                        // --tau-min/--tau-max)
                        points: f
                            .fitted
                            .iter()
                            .zip(v)
                            .map(|(p, &a)| (tau_of(p.m), a.max(0.0).sqrt()))
                            .collect(),
                    })
                    .collect(),
                marks: read_off_marks(av, f, &inp.units[k], inp.rate_hz),
                excluded: f.excluded_taus.clone(),
            };
            let svg = adev_svg(&plot, &format!("ad{k}"));
            write_plot(dir, &format!("adev_{stem}"), &svg)?;
            let check = match &f.adequacy {
                Some(adq) => {
                    let z_crit = gmwm_prep::stats::z_two_sided(1.0 - adq.ci_level);
                    let taus: Vec<f64> = adq.scales.iter().map(|c| c.tau).collect();
                    let zs: Vec<f64> = adq.scales.iter().map(|c| c.z).collect();
                    let r = residuals_svg(
                        &format!("{name}: fit check"),
                        &taus,
                        &zs,
                        z_crit,
                        &format!("rz{k}"),
                    );
                    write_plot(dir, &format!("fitcheck_{stem}"), &r)?;
                    r
                }
                None => String::new(),
            };
            // a curve without its samples (`fit --curve --out`): no time series, no ACF
            let Some(x) = inp.columns.get(k) else {
                return Ok([svg, String::new(), String::new(), check]);
            };
            let ts = timeseries_svg(
                &format!("{name}: time series"),
                inp.units[k].symbol(),
                x,
                inp.rate_hz,
                &format!("ts{k}"),
            );
            write_plot(dir, &format!("series_{stem}"), &ts)?;
            let lags = (x.len() / 4)
                .clamp(2, (inp.rate_hz * 30.0) as usize + 1)
                .min(4000);
            let acf = spectral::empirical::autocorrelation(x, lags - 1)
                .map_err(|e| Error::Usage(format!("{name}: ACF: {e}")))?;
            let a = acf_svg(
                &format!("{name}: sample ACF"),
                &acf,
                x.len(),
                inp.rate_hz,
                &format!("acf{k}"),
            );
            write_plot(dir, &format!("acf_{stem}"), &a)?;
            Ok([svg, ts, a, check])
        })
        .collect::<Result<Vec<_>>>()?;
    let mut ad_html = String::from("<h2>Allan deviation</h2><div class=plots>\n");
    let mut check_html = String::new();
    for [ad, ts, acf, check] in parts {
        ad_html.push_str(&ad);
        series_html.push_str(&ts);
        acf_html.push_str(&acf);
        check_html.push_str(&check);
    }
    ad_html.push_str("</div>\n");
    ad_html.push_str(&fit_check_section(inp, &check_html));
    let at = html.find(FIRST_SCREEN_END).unwrap_or(html.len());
    html.replace_range(
        at..at + FIRST_SCREEN_END.len().min(html.len() - at),
        &ad_html,
    );
    if !inp.columns.is_empty() {
        html.push_str(&series_html);
        html.push_str("</div>\n");
        html.push_str(&acf_html);
        html.push_str("</div>\n");
    }
    html.push_str("<p><small>Made by imunoise. Dotted grey lines: IEEE 952 slope guides (−1 quantization, −1/2 white noise, +1/2 rate random walk, +1 ramp). Shaded band: 95% CI of the estimated Allan deviation.</small></p></body></html>\n");
    write_file(&dir.join("report.html"), html.as_bytes())
}

/// One channel's robust entry in `results.json` (with `--robust` or when contaminated).
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
/// let settings = analyze::AnalyzeSettings { robust: true, ..Default::default() };
/// let a = analyze::analyze(table, units, &settings, &ui)?;
/// let json = a.results_json()?;
/// let rob = &json["channels"][0]["robust"];
/// let r = &a.robust_curves[0].1;
/// assert_eq!(rob["efficiency"], r.efficiency);
/// assert_eq!(rob["spikes_replaced"], r.spikes.indices.len());
/// assert_eq!(rob["avar"].as_array().unwrap().len(), r.robust.points.len());
/// assert_eq!(rob["fit"]["model"], a.robust_fits.as_ref().unwrap()[0].model.as_str());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Serialize)]
pub struct RobustResult<'a> {
    /// Gaussian efficiency of the robust AV.
    pub efficiency: f64,
    /// The classical-vs-robust comparison.
    pub check: &'a gmwm_prep::robust::ContaminationCheck,
    /// The robust AV (τ, AV, CI).
    pub avar: Vec<super::estimate::PointJson>,
    /// Scales where the robust estimating equation had no root (fallback used).
    pub no_root_m: Vec<u64>,
    /// Isolated spikes replaced before the robust AV ([`avar::robust::replace_spikes`]).
    pub spikes_replaced: u64,
    /// Times (s from the first sample) of the first 20 replaced spikes.
    pub spike_times_s: Vec<f64>,
    /// The fit of the robust curve (with --robust).
    pub fit: Option<&'a ChannelFit>,
}

/// An Allan deviation curve as plot points: (τ, AD, AD low, AD high), NaN without a CI.
fn observed(av: &AllanVariance) -> Vec<(f64, f64, f64, f64)> {
    let nan = f64::NAN;
    av.points
        .iter()
        .map(|p| {
            (
                p.tau,
                p.adev,
                p.adev_lo.unwrap_or(nan),
                p.adev_hi.unwrap_or(nan),
            )
        })
        .collect()
}

/// The times (s) of the first 20 spikes replaced before a robust AV.
fn spike_times(r: &avar::robust::RobustAllanVariance, rate_hz: f64) -> Vec<f64> {
    r.spikes
        .indices
        .iter()
        .take(20)
        .map(|&i| i as f64 / rate_hz)
        .collect()
}

fn adev_series(label: &str, rate: f64, fitted: &[super::fit::FittedJson]) -> Series {
    Series {
        label: label.to_string(),
        points: fitted
            .iter()
            .map(|p| (p.m as f64 / rate, p.avar.max(0.0).sqrt()))
            .collect(),
    }
}

fn fmt_ci(lo: Option<f64>, hi: Option<f64>) -> String {
    match (lo, hi) {
        (Some(a), Some(b)) => format!("[{}, {}]", sig(a, 4), sig(b, 4)),
        _ => "-".into(),
    }
}

/// The "classical vs robust" section of the report, writing the robust plots.
fn robust_section(dir: &Path, inp: &ReportInput<'_>, rob: &RobustReport<'_>) -> Result<String> {
    let (names, units, rate) = (inp.names, inp.units, inp.rate_hz);
    let (robust, checks, classical_fits, robust_fits) =
        (rob.curves, rob.checks, inp.fits, rob.fits);
    let mut h = String::from("<h2>Classical vs robust Allan variance (contamination check)</h2>\n");
    let _ = writeln!(
        h,
        "<p>Robust AV: Tukey biweight M-estimator of scale per scale at Gaussian efficiency {} (c = {:.3}); its CIs are the chi-square ones with EDF × efficiency. A scale is flagged when z = (classical − robust)/sd exceeds the one-sided 1 % threshold with Bonferroni over the scales (sd from the classical EDF and the 1/e variance bound: conservative).</p>",
        sig(robust.first().map_or(0.0, |r| r.1.efficiency), 4),
        robust.first().map_or(0.0, |r| r.1.biweight.c),
    );
    let stems = file_stems(names);
    for (k, name) in names.iter().enumerate() {
        let (_, r) = &robust[k];
        let chk = &checks[k];
        let cls = if chk.contaminated { " class=no" } else { "" };
        let _ = writeln!(
            h,
            "<h3>{}</h3><p{cls}>{}</p>",
            html_esc(name),
            html_esc(&chk.message)
        );
        let sp = &r.spikes;
        if !sp.indices.is_empty() {
            let times: Vec<String> = spike_times(r, rate)
                .iter()
                .map(|t| format!("{t:.3}"))
                .collect();
            let _ = writeln!(
                h,
                "<p>{} isolated spikes (more than {} robust SDs from their neighbours) were replaced before the robust AV, at t = {}{} s.</p>",
                sp.indices.len(),
                sp.threshold,
                times.join(", "),
                if sp.indices.len() > times.len() {
                    ", …"
                } else {
                    ""
                }
            );
        } else if sp.beyond > 0 {
            let _ = writeln!(
                h,
                "<p>{} samples lie more than {} robust SDs from their neighbours: more than {} % of the record, so the noise is heavy-tailed rather than spiky, and none was replaced.</p>",
                sp.beyond,
                sp.threshold,
                100.0 * avar::robust::MAX_SPIKE_FRACTION
            );
        }
        if !chk.windows.is_empty() {
            h.push_str("<table><tr><th>window start (s)</th><th>end (s)</th><th>share of the excess</th><th>largest |D|/σ̂</th></tr>\n");
            for w in &chk.windows {
                let _ = writeln!(
                    h,
                    "<tr><td>{:.2}</td><td>{:.2}</td><td>{:.1} %</td><td>{:.1}</td></tr>",
                    w.start_s,
                    w.end_s,
                    100.0 * w.share,
                    w.max_z
                );
            }
            h.push_str("</table>\n");
        }
        // the per-scale table folded away: open where the check found something
        let flagged = chk.scales.iter().filter(|s| s.z > chk.threshold).count();
        let _ = writeln!(
            h,
            "<details{}><summary>per-scale comparison: {} scales, {flagged} flagged</summary>",
            if chk.contaminated { " open" } else { "" },
            chk.scales.len()
        );
        h.push_str("<table><tr><th>m</th><th>τ (s)</th><th>classical AV</th><th>robust AV</th><th>robust CI</th><th>ratio</th><th>z</th><th>rejected</th></tr>\n");
        for (i, s) in chk.scales.iter().enumerate() {
            let p = &r.robust.points[i];
            let flag = if s.z > chk.threshold { " class=no" } else { "" };
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.3}</td><td{flag}>{:.2}</td><td>{}</td></tr>",
                s.m,
                num(s.tau),
                num(s.classical),
                num(s.robust),
                fmt_ci(p.avar_lo, p.avar_hi),
                s.ratio,
                s.z,
                r.rejected[i]
            );
        }
        h.push_str("</table></details>\n");
        if let Some(rf) = robust_fits {
            let (c, q) = (&classical_fits[k], &rf[k]);
            let _ = writeln!(
                h,
                "<table><tr><th class=l></th><th class=l>classical fit</th><th class=l>robust fit</th></tr><tr><td class=l>model</td><td class=l><small>{}</small></td><td class=l><small>{}</small></td></tr>",
                html_esc(&c.model),
                html_esc(&q.model)
            );
            let rows = c.parameters.len().max(q.parameters.len());
            for i in 0..rows {
                let cell = |f: &ChannelFit| {
                    f.parameters.get(i).map_or("".to_string(), |p| {
                        format!(
                            "{} {} = {} {}",
                            p.process,
                            p.name,
                            sig(p.value, 4),
                            fmt_ci(p.ci_lo, p.ci_hi)
                        )
                    })
                };
                let _ = writeln!(
                    h,
                    "<tr><td></td><td class=l>{}</td><td class=l>{}</td></tr>",
                    cell(c),
                    cell(q)
                );
            }
            let jp = |f: &ChannelFit| {
                f.j_test
                    .as_ref()
                    .map_or("-".into(), |j| format!("{:.3}", j.p_value))
            };
            let _ = writeln!(
                h,
                "<tr><td class=l>J-test p</td><td class=l>{}</td><td class=l>{}</td></tr></table>",
                jp(c),
                jp(q)
            );
        }
        if robust_fits.is_none() {
            continue;
        }
        let mut components = vec![Series {
            label: "classical AD".into(),
            points: r.classical.points.iter().map(|p| (p.tau, p.adev)).collect(),
        }];
        components.push(adev_series(
            "classical fit",
            rate,
            &classical_fits[k].fitted,
        ));
        let plot = AdevPlot {
            title: format!("{name}: robust (band) vs classical Allan deviation"),
            unit: units[k].symbol().to_string(),
            observed: observed(&r.robust),
            fitted: robust_fits.map(|rf| adev_series("robust fit", rate, &rf[k].fitted)),
            components,
            marks: Vec::new(),
            excluded: Vec::new(),
        };
        let svg = adev_svg(&plot, &format!("rob{k}"));
        write_plot(dir, &format!("adev_robust_{}", stems[k]), &svg)?;
        h.push_str("<div class=plots>");
        h.push_str(&svg);
        h.push_str("</div>\n");
    }
    Ok(h)
}
