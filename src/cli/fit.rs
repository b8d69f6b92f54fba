//! `imunoise fit`: a noise model per channel (GMWM, AVLR or the IEEE 952 read-off) with
//! CIs, per-sample and IEEE units, J-test, and WIC when selecting.

use super::{InputArgs, Ui};
use crate::error::{Error, Result};
pub use crate::pipeline::estimate::{check_quality, read_curves, robust_curves};
pub use crate::pipeline::fit::*;
use std::io::Write;

/// Examples shown by `imunoise fit --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise fit imu.csv.gz --rate 100
  imunoise fit imu.csv.gz --rate 100 --columns gyro_x_dps --model \"WN+RW+AR1\" --bootstrap 50 --format json
  imunoise fit imu.csv.gz --rate 100 --select          # best sub-model of QN+WN+RW+AR1 by WIC
  imunoise fit imu.csv.gz --rate 100 --method avlr
  imunoise fit imu.csv.gz --rate 100 --robust          # robust AV (biweight, 60 % efficiency): outliers
  imunoise fit day1.csv.gz day2.csv.gz --rate 100 --model \"WN+RW+AR1\" --format json   # one model, two recordings
  imunoise fit --curve avar.csv --select --out report/   # a curve from `imunoise avar --format csv`, with its report
  imunoise fit --curve datasheet.txt --rate 400 --samples 5760000 --unit deg/s   # a published AD curve

--robust fits the robust Allan variance (Tukey biweight M-estimator of scale per scale at
Gaussian efficiency --efficiency, 0.6 by default, as the R package gmwm): differences beyond
about 4.4 standard deviations get no weight, so spikes and short disturbances do not inflate
the small scales. Its intervals are the chi-square ones with the EDF times the efficiency.

Several files: the same channels are read from each (same columns and rate), one model is
fitted to all recordings (their Allan variances pooled with the inverse of their covariance
matrices, CIs from the pooled covariance), each recording is also fitted alone, and two tests
of equality are reported per channel: \"wald\" (equal parameters, χ² with (R−1)·p degrees of
freedom, on the log scale of the CIs) and \"moment_test\" (equal Allan variance curves, χ² with
(R−1)·J degrees of freedom). JSON: {\"joint\":[{\"name\",\"files\",\"fit\":{…as one channel…},
\"single\":[…],\"wald\":{\"statistic\",\"dof\",\"p_value\"},\"moment_test\":{…}}]}.

Parameters are per sample (Δt = 1/rate), in the parameterization of the model string and in
the channel's unit u: WN sigma2 [u²], RW gamma2 [u² per sample], QN q2 [u²], DR omega
[u per sample], AR1 phi [-] and sigma2 [u²]. The IEEE 952 equivalents are in the usual units
(N in °/√h or m/s/√h, K in °/h/√h or m/s/h/√h, …) when --unit or the column names give u.

CIs (level 1 − alpha, each on its own): GMWM uses the delta method with the covariance V of
the Allan variance estimates implied by the fitted model, or with --bootstrap B its
parametric-bootstrap estimate; AVLR needs --bootstrap; the IEEE 952 read-off has none.
\"ci_method\" says which was used: delta_model_cov, delta_bootstrap_cov, delta_diagonal,
bootstrap_sd or none.

JSON shape: {\"channels\":[{\"name\",\"method\",\"model\",\"converged\",\"parameters\":[{\"process\",
\"name\",\"value\",\"ci_lo\",\"ci_hi\"}],\"ieee\":{\"N\":{\"value\",\"unit\",\"ci_lo\",\"ci_hi\"},…},
\"noise_terms\":{\"n\",\"k\",\"b\":{\"value\",\"unit\",\"ci_lo\",\"ci_hi\",\"source\",\"basis\",
\"read_off\",\"disagrees\",\"per_second\",\"per_second_unit\"}},\"adequacy\":{\"adequate\",
\"inside_fraction\",\"n_scales\",\"n_inside\",\"unexplained\":[{\"tau_lo\",\"tau_hi\",\"n_scales\",
\"model_above\"}],\"reasons\",\"scales\":[{\"tau\",\"z\",\"inside\"}]},
\"j_test\":{\"statistic\",\"p_value\"},\"ci_method\",\"ci_level\",\"fitted\":[{\"m\",\"avar\"}]}]}
(plus \"wic\" with --select, \"excluded_taus\" with --tau-min/--tau-max).
N, K, B (\"noise_terms\"): from the fitted model where it has the term (N: white noise and
every AR1/GM/MA1 faster than the smallest τ, as white-noise equivalents; K: the random walk),
else the IEEE 952 read-off (N at τ = 1 s, K at 3 s, B at the minimum), else an upper bound;
\"source\" says which. The verdict (\"adequacy\"): a fit is adequate when its Allan variance
lies inside the estimate's CI at ≥ 90 % of the fitted scales; the τ ranges it does not
explain are listed. CSV: one row per parameter and IEEE term:
channel,process,name,value,ci_lo,ci_hi,unit,ci_method (process \"IEEE\" for N, K, …).";

/// The fit flags shared by `fit` and `analyze` (the library's [`FitSettings`]).
#[derive(Debug, Clone, clap::Args)]
pub struct FitFlags {
    /// Model template (slots to estimate), e.g. "WN+RW+AR1" or "QN+WN+RW+2*AR1".
    #[arg(long, short, default_value = "QN+WN+RW+AR1")]
    pub model: String,
    /// Fitting method.
    #[arg(long, value_enum, default_value = "gmwm")]
    pub method: Method,
    /// Select the best sub-model of --model by WIC (GMWM only).
    #[arg(long)]
    pub select: bool,
    /// GMWM weighting matrix Ω: `diagonal` (default, fastest), `model-diagonal`, or
    /// `model-full` (Ω from the exact covariance of the AV estimates under the fitted model,
    /// iterated; less bias and RMSE for composite models, ~0.1 s per fit). With --select the
    /// sub-models share the full model's Ω.
    #[arg(long, value_enum, default_value = "diagonal")]
    pub weighting: FitWeighting,
    /// Parametric bootstrap replications B for the covariance V of the AV estimates behind
    /// the CIs (GMWM), or for the CIs themselves (AVLR). 0: GMWM uses the exact covariance
    /// of the AV estimates implied by the fitted model (no simulation), AVLR gives no CIs.
    #[arg(long, default_value_t = 0, value_name = "B")]
    pub bootstrap: usize,
    /// Seed of the bootstrap simulations.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// CI level: intervals cover 1 − alpha.
    #[arg(long, default_value_t = 0.05)]
    pub alpha: f64,
    /// Fit only the scales with τ ≥ SECONDS, e.g. to leave out the smallest scales when an
    /// anti-aliasing or decimation filter shapes them (the AV falls below the white-noise
    /// line there). The excluded scales are listed in the JSON (`excluded_taus`) and drawn
    /// grey in the report's plot.
    #[arg(long, value_name = "SECONDS")]
    pub tau_min: Option<f64>,
    /// Fit only the scales with τ ≤ SECONDS (e.g. to leave out the few, noisy largest ones).
    #[arg(long, value_name = "SECONDS")]
    pub tau_max: Option<f64>,
}

impl FitFlags {
    /// The library settings these flags describe.
    pub fn settings(&self) -> FitSettings {
        FitSettings {
            model: self.model.clone(),
            method: self.method,
            select: self.select,
            weighting: self.weighting,
            bootstrap: self.bootstrap,
            seed: self.seed,
            alpha: self.alpha,
            tau_min: self.tau_min,
            tau_max: self.tau_max,
        }
    }
}

/// The robust options of `fit` and `analyze`.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct RobustArgs {
    /// Fit the robust Allan variance (Tukey biweight M-estimator of scale per scale) instead
    /// of the classical one: resistant to outliers and short disturbances.
    #[arg(long)]
    pub robust: bool,
    /// Gaussian efficiency of the robust estimator, in [0.05, 0.99] (lower: more resistant).
    #[arg(long, default_value_t = avar::robust::DEFAULT_EFFICIENCY, value_name = "E")]
    pub efficiency: f64,
}

impl RobustArgs {
    /// `Some(efficiency)` with --robust (checked), else `None`.
    pub fn efficiency(&self) -> Result<Option<f64>> {
        robust_efficiency(self.robust, self.efficiency)
    }
}

/// Arguments of `imunoise fit`.
#[derive(Debug, Clone, clap::Args)]
pub struct FitArgs {
    /// The input file and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// More recordings of the same sensor (same columns, rate and format): one model is
    /// fitted to all of them, with tests of equality.
    #[arg(value_name = "MORE_FILES")]
    pub more: Vec<std::path::PathBuf>,
    /// Fit settings.
    #[command(flatten)]
    pub fit: FitFlags,
    /// Robust fitting.
    #[command(flatten)]
    pub robust: RobustArgs,
    /// The input is an Allan variance curve, not samples: a text file of τ and AV or AD
    /// columns, as `imunoise avar --format csv`, allan_variance_ros or imu_utils write them or
    /// as copied from a datasheet (long layout: tau, avar|adev, optional channel, m,
    /// avar_lo/avar_hi or adev_lo/adev_hi, edf, n_terms; wide layout: τ first, then one
    /// column per channel, deviations unless the name contains "var"). The rate comes from
    /// --rate or the m column; the CIs from the file's CI or EDF columns, else from the record
    /// length (--samples, or the n_terms column) by the EDF of the noise the curve's slope
    /// shows. Units from --unit or the channel names, as for samples.
    #[arg(long)]
    pub curve: bool,
    /// With --curve: the record length T behind the curve, in samples.
    #[arg(long, value_name = "N", requires = "curve")]
    pub samples: Option<u64>,
    /// With --curve: also write the report folder there (report.html with the summary, the
    /// AD plots and the fit check, results.json, avar.csv, imu.yaml), as `analyze` does for
    /// samples (without the time series and ACF plots, which need the samples).
    #[arg(long, value_name = "DIR", requires = "curve")]
    pub out: Option<std::path::PathBuf>,
    /// Output format: table, json or csv.
    #[arg(long, short, value_enum, default_value = "table")]
    pub format: super::Format,
}

/// Runs `imunoise fit`.
pub fn run(args: &FitArgs, ui: &Ui) -> Result<()> {
    // a bad model or level fails before the file is read
    let template = args.fit.settings().check()?;
    if let Some(note) = crate::pipeline::fit::template_values_note(&template) {
        ui.note(note);
    }
    args.robust.efficiency()?;
    if !args.more.is_empty() {
        let mut inputs = vec![args.input.spec()];
        inputs.extend(args.more.iter().map(|f| {
            let mut i = args.input.spec();
            i.file = f.clone();
            i
        }));
        let joint = fit_joint(&inputs, &args.fit.settings(), args.robust.efficiency()?, ui)?;
        let stdout = std::io::stdout();
        let mut out = std::io::BufWriter::new(stdout.lock());
        let r = match args.format {
            super::Format::Json => serde_json::to_writer(&mut out, &JointJson { joint })
                .map_err(std::io::Error::other)
                .and_then(|_| writeln!(out)),
            super::Format::Csv => {
                let all: Vec<ChannelFit> = joint.into_iter().map(|j| j.fit).collect();
                write_csv(&mut out, &all)
            }
            super::Format::Table => write_joint_table(&mut out, &joint, args.fit.alpha),
        };
        return r
            .and_then(|_| out.flush())
            .map_err(|e| Error::write("<stdout>", e));
    }
    let robust = args.robust.efficiency()?;
    let settings = args.fit.settings();
    let fits = if args.curve {
        if robust.is_some() || !args.more.is_empty() {
            return Err(Error::Usage(
                "--curve fits one curve file as it is: without --robust (which needs the \
                 samples) and without more files"
                    .into(),
            ));
        }
        let opts = crate::pipeline::curve::CurveOptions {
            rate_hz: args.input.rate,
            samples: args.samples,
            alpha: settings.alpha,
        };
        let curves = crate::pipeline::curve::read_curve_file(&args.input.file, &opts)?;
        let names: Vec<String> = curves.iter().map(|(n, _)| n.clone()).collect();
        let units = crate::units::channel_units(&names, args.input.unit.as_deref())?;
        let fits = fit_all(&curves, &units, &settings, ui)?;
        if let Some(dir) = &args.out {
            let source = args.input.file.display().to_string();
            let inp = crate::pipeline::report::ReportInput {
                source: &source,
                rate_hz: curves.first().map_or(f64::NAN, |c| c.1.rate_hz),
                names: &names,
                columns: &[],
                units: &units,
                curves: &curves,
                fits: &fits,
                extra_html: String::new(),
                bootstrap: settings.bootstrap,
                topic: None,
                timing: None,
                robust: None,
                record_halfwidth: 0.1,
            };
            crate::pipeline::report::write_report(dir, &inp, ui)?;
            ui.note(format!(
                "report written to {}",
                dir.join("report.html").display()
            ));
        }
        fits
    } else {
        let spec = args.input.spec();
        let table = spec.read(ui)?;
        let units = spec.units(&table)?;
        fit_table(&table, &units, &settings, robust, ui)?
    };
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let r = match args.format {
        super::Format::Json => serde_json::to_writer(&mut out, &FitJson { channels: fits })
            .map_err(std::io::Error::other)
            .and_then(|_| writeln!(out)),
        super::Format::Csv => write_csv(&mut out, &fits),
        super::Format::Table => write_table(&mut out, &fits, args.fit.alpha, args.fit.bootstrap),
    };
    r.and_then(|_| out.flush())
        .map_err(|e| Error::write("<stdout>", e))
}
