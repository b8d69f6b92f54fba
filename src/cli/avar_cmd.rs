//! `imunoise avar`: the Allan variance of every channel of a log, with CIs.

use super::{Format, InputArgs, Ui, avar_error, parse_scales};
use crate::error::Result;
use avar::{AllanVariance, AvarConfig, CiMethod, Estimator, InputKind, Scales};
use rayon::prelude::*;
use serde::Serialize;
use std::io::Write;

/// Examples shown by `imunoise avar --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise avar imu.csv.gz --rate 100 --format json
  imunoise avar imu.csv --rate 100 --columns gyro_x,gyro_y --scales octave --ci gaussian
  imunoise avar log.f64 --binary f64 --channels 6 --rate 200 --format csv

JSON shape: {\"channels\":[{\"name\",\"rate_hz\",\"n\",\"estimator\",\"points\":[{\"m\",\"tau\",
\"avar\",\"adev\",\"avar_lo\",\"avar_hi\",\"edf\",\"n_terms\"}]}]} (CI fields null with --ci none).";

/// Arguments of `imunoise avar`.
#[derive(Debug, Clone, clap::Args)]
pub struct AvarArgs {
    /// The input file and how to read it.
    #[command(flatten)]
    pub input: InputArgs,
    /// Whether samples are rates (gyro/accelerometer output) or integrated angles/velocities.
    #[arg(long = "input", value_enum, default_value = "rate")]
    pub input_kind: InputKindArg,
    /// Cluster sizes: dyadic (book default, m = 2^j), dyadic1, octave, decade, all, logN,
    /// or a list m1,m2,…
    #[arg(long, default_value = "dyadic", value_parser = parse_scales)]
    pub scales: Scales,
    /// Estimator: the book's maximum-overlapping (eq. 4.2) or the non-overlapping one.
    #[arg(long, value_enum, default_value = "overlapping")]
    pub estimator: EstimatorArg,
    /// Confidence intervals: chi-square with equivalent degrees of freedom, Gaussian
    /// (book Lemma 4.4), or none.
    #[arg(long, value_enum, default_value = "chi2")]
    pub ci: CiArg,
    /// CI level: intervals cover 1 − alpha.
    #[arg(long, default_value_t = 0.05)]
    pub alpha: f64,
    /// Output format.
    #[arg(long, short, value_enum, default_value = "table")]
    pub format: Format,
}

/// `--input` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InputKindArg {
    /// Rate samples.
    Rate,
    /// Angle (integrated) samples.
    Angle,
}

/// `--estimator` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum EstimatorArg {
    /// Maximum-overlapping (book eq. 4.2).
    Overlapping,
    /// Non-overlapping.
    NonOverlapping,
}

/// `--ci` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CiArg {
    /// Chi-square with equivalent degrees of freedom.
    Chi2,
    /// Gaussian (may have negative lower bounds, book Remark 4.7).
    Gaussian,
    /// No interval.
    None,
}

impl AvarArgs {
    /// The `avar` configuration these flags describe.
    pub fn config(&self) -> AvarConfig {
        AvarConfig {
            scales: self.scales.clone(),
            estimator: match self.estimator {
                EstimatorArg::Overlapping => Estimator::Overlapping,
                EstimatorArg::NonOverlapping => Estimator::NonOverlapping,
            },
            input: match self.input_kind {
                InputKindArg::Rate => InputKind::Rate,
                InputKindArg::Angle => InputKind::Angle,
            },
            ci: match self.ci {
                CiArg::Chi2 => CiMethod::ChiSquare,
                CiArg::Gaussian => CiMethod::Gaussian,
                CiArg::None => CiMethod::None,
            },
            alpha: self.alpha,
        }
    }
}

/// One point of the JSON output (exactly the documented keys).
#[derive(Debug, Serialize)]
pub struct PointJson {
    /// Cluster size (samples).
    pub m: u64,
    /// Averaging time (s).
    pub tau: f64,
    /// Allan variance.
    pub avar: f64,
    /// Allan deviation.
    pub adev: f64,
    /// Lower CI bound of the AV (null without CI).
    pub avar_lo: Option<f64>,
    /// Upper CI bound of the AV (null without CI).
    pub avar_hi: Option<f64>,
    /// Equivalent degrees of freedom (null without a chi-square CI).
    pub edf: Option<f64>,
    /// Number of squared differences.
    pub n_terms: u64,
}

/// One channel of the JSON output.
#[derive(Debug, Serialize)]
pub struct ChannelJson {
    /// Channel name.
    pub name: String,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Number of (rate) samples.
    pub n: usize,
    /// `"overlapping"` or `"non_overlapping"`.
    pub estimator: Estimator,
    /// The curve.
    pub points: Vec<PointJson>,
}

/// The whole JSON document.
#[derive(Debug, Serialize)]
pub struct AvarJson {
    /// One entry per channel, in the order of the input (or of --columns).
    pub channels: Vec<ChannelJson>,
}

/// Builds the JSON document of named curves.
pub fn to_json(curves: &[(String, AllanVariance)]) -> AvarJson {
    AvarJson {
        channels: curves
            .iter()
            .map(|(name, av)| ChannelJson {
                name: name.clone(),
                rate_hz: av.rate_hz,
                n: av.n,
                estimator: av.estimator,
                points: av
                    .points
                    .iter()
                    .map(|p| PointJson {
                        m: p.m,
                        tau: p.tau,
                        avar: p.avar,
                        adev: p.adev,
                        avar_lo: p.avar_lo,
                        avar_hi: p.avar_hi,
                        edf: p.edf,
                        n_terms: p.n_terms,
                    })
                    .collect(),
            })
            .collect(),
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |x| format!("{x:e}"))
}

/// Writes the curves as CSV (long format, one row per channel and scale).
pub fn write_csv(out: &mut impl Write, curves: &[(String, AllanVariance)]) -> std::io::Result<()> {
    writeln!(
        out,
        "channel,m,tau,avar,adev,avar_lo,avar_hi,adev_lo,adev_hi,edf,n_terms"
    )?;
    for (name, av) in curves {
        for p in &av.points {
            writeln!(
                out,
                "{name},{},{},{:e},{:e},{},{},{},{},{},{}",
                p.m,
                p.tau,
                p.avar,
                p.adev,
                opt(p.avar_lo),
                opt(p.avar_hi),
                opt(p.adev_lo),
                opt(p.adev_hi),
                p.edf.map_or(String::new(), |e| format!("{e:.3}")),
                p.n_terms
            )?;
        }
    }
    Ok(())
}

/// Writes the curves as aligned text tables (deviations with their CI).
pub fn write_table(
    out: &mut impl Write,
    curves: &[(String, AllanVariance)],
    alpha: f64,
) -> std::io::Result<()> {
    for (i, (name, av)) in curves.iter().enumerate() {
        if i > 0 {
            writeln!(out)?;
        }
        let level = 100.0 * (1.0 - alpha);
        let ci = match av.ci {
            CiMethod::ChiSquare => format!("{level:.0}% chi-square CI"),
            CiMethod::Gaussian => format!("{level:.0}% Gaussian CI (Lemma 4.4)"),
            CiMethod::None => "no CI".to_string(),
        };
        writeln!(
            out,
            "{name}: n = {}, rate = {} Hz, {:?} estimator, {ci}",
            av.n, av.rate_hz, av.estimator,
        )?;
        writeln!(
            out,
            "{:>10} {:>12} {:>12} {:>12} {:>12} {:>9} {:>10}",
            "m", "tau [s]", "adev", "adev_lo", "adev_hi", "edf", "n_terms"
        )?;
        let f = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.5e}"));
        for p in &av.points {
            writeln!(
                out,
                "{:>10} {:>12} {:>12.5e} {:>12} {:>12} {:>9} {:>10}",
                p.m,
                format!("{:.4}", p.tau),
                p.adev,
                f(p.adev_lo),
                f(p.adev_hi),
                p.edf.map_or("-".to_string(), |e| format!("{e:.1}")),
                p.n_terms
            )?;
        }
    }
    Ok(())
}

/// Computes the Allan variance of every channel of `table` (in parallel).
pub fn compute(
    table: &crate::io::Table,
    rate_hz: f64,
    config: &AvarConfig,
    ui: &Ui,
) -> Result<Vec<(String, AllanVariance)>> {
    let pb = ui.bar(table.columns.len() as u64, "Allan var.");
    let res: Vec<Result<(String, AllanVariance)>> = table
        .columns
        .par_iter()
        .zip(&table.names)
        .map(|(col, name)| {
            let r = avar::allan_variance(col, rate_hz, config)
                .map(|av| (name.clone(), av))
                .map_err(|e| avar_error(&table.file, name, e));
            pb.inc(1);
            r
        })
        .collect();
    pb.finish_and_clear();
    res.into_iter().collect()
}

/// Runs `imunoise avar`.
pub fn run(args: &AvarArgs, ui: &Ui) -> Result<()> {
    let config = args.config();
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return Err(crate::Error::Usage(format!(
            "--alpha must lie in (0, 1), got {}",
            args.alpha
        )));
    }
    let table = args.input.read(ui)?;
    let curves = compute(&table, table.rate()?, &config, ui)?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let res = match args.format {
        Format::Json => {
            serde_json::to_writer(&mut out, &to_json(&curves))?;
            writeln!(out)
        }
        Format::Csv => write_csv(&mut out, &curves),
        Format::Table => write_table(&mut out, &curves, args.alpha),
    };
    res.and_then(|_| out.flush())
        .map_err(|e| crate::Error::io("<stdout>", e))
}
