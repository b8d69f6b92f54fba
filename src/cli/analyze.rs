//! `imunoise analyze`: everything for a log — AV with CIs, model selection and fit, IEEE
//! noise table, plots (SVG and PNG), `report.html`, `results.json`, `avar.csv` and a
//! Kalibr-style `imu.yaml`.

use super::fit::FitFlags;
use super::{InputArgs, Ui};
use crate::error::{Error, Result};
pub use crate::pipeline::analyze::{ANALYZE_MODEL, Analysis, AnalyzeSettings, analyze};
pub use crate::pipeline::report::{
    ChannelResult, RecordLength, ReportInput, Results, RobustReport, RobustResult, file_safe,
    kalibr_yaml, num, read_off_marks, record_length, results_json, write_report,
};
use std::path::PathBuf;

/// Examples shown by `imunoise analyze --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise analyze imu.csv.gz --rate 100 --out report/
  imunoise analyze log.f64 --binary f64 --channels 6 --rate 200 --unit deg/s,deg/s,deg/s,g,g,g --bootstrap 40

  imunoise analyze mtig.f64 --binary f64 --channels 1 --rate 100 --robust --out report/

Writes into DIR: report.html (self-contained), results.json, avar.csv, imu.yaml (Kalibr:
continuous-time noise density and random walk, SI units), adev_<channel>.svg/.png,
series_<channel>.svg/.png and acf_<channel>.svg/.png.

Model selection: with the default --model the candidates are the sub-models of
QN+WN+RW+BI+2*SIN+2*AR1, ranked by WIC: BI is the IEEE 952 bias instability (flicker, a flat
AV; Gauss-Markov states over the record's scales), SIN a random-phase sinusoid (an oscillation
from vibration or filtering: a bump in the AV), and two AR1s because real MEMS gyros often show
a short correlation and a slow bias drift at once. The class is searched by backward
elimination (from the full model, drop the component whose removal lowers the WIC most, while
it does).

Contamination check (always): the robust Allan variance (Tukey biweight, --efficiency) is
compared with the classical one at every scale; when the classical one is larger beyond the
Gaussian sampling noise (one-sided, 1 % level, Bonferroni over the scales) the report says the
data look contaminated and names the time windows that drive the difference. With --robust the
robust curve is fitted too, and the report shows both curves and both fits
(adev_robust_<channel>.svg); results.json gets a \"robust\" entry per channel.";

/// Arguments of `imunoise analyze`.
#[derive(Debug, Clone, clap::Args)]
pub struct AnalyzeArgs {
    /// The input file and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// Fit settings (by default: the best sub-model of QN+WN+RW+AR1 by WIC).
    #[command(flatten)]
    pub fit: FitFlags,
    /// Fit exactly --model instead of selecting its best sub-model by WIC (selecting is the
    /// default here, so --select changes nothing).
    #[arg(long)]
    pub no_select: bool,
    /// Output directory (created if needed).
    #[arg(long, short, default_value = "imunoise-report")]
    pub out: PathBuf,
    /// Robust fitting (the contamination check runs in any case, at --efficiency).
    #[command(flatten)]
    pub robust: super::fit::RobustArgs,
    /// Also write estimators' config files into the output directory: a comma list of
    /// kalibr, openvins, orbslam3, vins, basalt, or all (see `imunoise export --help`;
    /// kalibr replaces the plain imu.yaml with the commented one).
    #[arg(long, value_name = "LIST")]
    pub export: Option<String>,
    /// "How long to record": the relative half-width of the 95 % CI on the Allan deviation at
    /// the bias-instability τ (its minimum) to aim at, e.g. 0.05 for ±5 %. The report and
    /// results.json (`record_length`) give the record length in hours that reaches it.
    #[arg(long, value_name = "H", default_value_t = 0.1)]
    pub record_halfwidth: f64,
    /// Aggregation and inflation for --export.
    #[command(flatten)]
    pub export_options: crate::export::ExportOptions,
}

/// Runs `imunoise analyze`.
pub fn run(args: &AnalyzeArgs, ui: &Ui) -> Result<()> {
    // a bad model or option fails before the file is read, and before --out is made
    let settings = AnalyzeSettings {
        fit: args.fit.settings(),
        select: !args.no_select,
        robust: args.robust.robust,
        efficiency: args.robust.efficiency,
        record_halfwidth: args.record_halfwidth,
    };
    let template = settings.check()?;
    if let Some(note) = crate::pipeline::fit::template_values_note(&template) {
        ui.note(note);
    }
    let targets = args
        .export
        .as_deref()
        .map(crate::export::Target::parse_list)
        .transpose()?;
    // a bad --out fails before the work, not after it
    crate::output::create_dir(&args.out, "--out")?;
    // Several topics (given, or a flight log's high-rate topics): one report per topic, in
    // a folder named after it.
    let topics = match args.input.topic.len() {
        0 => args.input.spec().preferred_topics(ui)?,
        _ => args.input.topic.clone(),
    };
    if topics.len() > 1 {
        for topic in &topics {
            let mut one = args.clone();
            one.input.topic = vec![topic.clone()];
            one.out = args.out.join(file_safe(topic.trim_start_matches('/')));
            run(&one, ui)?;
        }
        return Ok(());
    }
    let spec = args.input.spec();
    let table = spec.read(ui)?;
    let units = spec.units(&table)?;
    let a = analyze(table, units, &settings, ui)?;
    a.write_report(&args.out, ui)?;
    if let Some(targets) = &targets {
        let noise = super::export::load(&args.out.join("results.json"))?;
        crate::export::write_all(&noise, targets, &args.export_options, &args.out)?;
    }
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let fit = &a.settings;
    super::fit::write_table(&mut out, &a.fits, fit.alpha, fit.bootstrap)
        .and_then(|_| {
            use std::io::Write;
            for (n, c) in a.table.names.iter().zip(&a.checks) {
                writeln!(out, "{n}: {}", c.message)?;
            }
            if let Some(rf) = &a.robust_fits {
                writeln!(out, "\nrobust fits (efficiency {}):", a.efficiency)?;
                super::fit::write_table(&mut out, rf, fit.alpha, 0)?;
            }
            writeln!(
                out,
                "\nreport written to {}",
                args.out.join("report.html").display()
            )?;
            out.flush()
        })
        .map_err(|e| Error::write("<stdout>", e))
}
