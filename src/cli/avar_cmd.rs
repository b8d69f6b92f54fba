//! `imunoise avar`: the Allan variance of every channel of a log, with CIs.

use super::{Format, InputArgs, Ui, parse_scales};
use crate::error::Result;
pub use crate::pipeline::estimate::{
    AvarJson, ChannelJson, Curve, PointJson, compute, compute_statistics, curves_json, plot_curves,
    to_json, write_csv, write_curves_csv, write_curves_table, write_table,
};
use avar::stability::Statistic;
use avar::{AvarConfig, CiMethod, Estimator, InputKind, Scales};
use std::io::Write;

/// Examples shown by `imunoise avar --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise avar imu.csv.gz --rate 100 --format json
  imunoise avar imu.csv --rate 100 --columns gyro_x,gyro_y --scales octave --ci gaussian
  imunoise avar log.f64 --binary f64 --channels 6 --rate 200 --format csv
  imunoise avar clock.txt --rate 1 --statistic oadev,mdev,ohdev,totdev --scales octave --plot s.svg
  imunoise avar phase.txt --rate 1 --input angle --statistic tdev --alpha 0.317 --format json

Which statistic (--statistic, several allowed):
  oadev   overlapping Allan deviation (the book's eq. 4.2), the default
  adev    non-overlapping Allan deviation
  mdev    modified Allan deviation: averages the phase over tau first; tells white from
          flicker phase noise apart (MDEV falls as tau^-3/2 vs tau^-1), where ADEV cannot
  tdev    time deviation tau*MDEV/sqrt(3), in phase (angle) units: the time error of a clock
  hdev    Hadamard deviation (third differences): insensitive to a linear frequency drift
          (IMU warm-up, rate ramp) and convergent for random-walk FM; ohdev overlaps it
  ohdev   overlapping Hadamard deviation: the drift-free choice with the most terms
  totdev  total deviation (reflected ends): tighter intervals at long tau, up to T/2
For mdev/tdev/hdev/ohdev/totdev the chi-square interval follows Stable32: noise type from the
lag-1 autocorrelation (B1 ratio and R(n) below 30 points), Greenhall's EDF (TOTDEV: SP 1065);
--alpha 0.317 gives Stable32's 0.683 confidence factor. --ci gaussian is for the AV only.
Memory: their values are streamed from rate samples (mdev/tdev/ohdev, and totdev from 4194304
samples on); their chi-square interval sums the samples in eights once (1 byte per sample)
for its noise identification; --ci none skips it.

JSON shape: {\"channels\":[{\"name\",\"rate_hz\",\"n\",\"estimator\",\"points\":[{\"m\",\"tau\",
\"avar\",\"adev\",\"avar_lo\",\"avar_hi\",\"edf\",\"n_terms\"}]}]} (CI fields null with --ci none).
With --statistic each channel entry also has \"statistic\" (one entry per channel and
statistic) and each point \"alpha\" (the identified power-law exponent, null without a
chi-square CI); avar/adev then hold that statistic's variance/deviation.";

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
    /// Statistics to compute (comma list or repeated; default oadev): oadev, adev, mdev,
    /// tdev, hdev, ohdev, totdev. See "Which statistic" below. With this flag --estimator is
    /// not used (oadev is overlapping, adev non-overlapping).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub statistic: Option<Vec<StatisticArg>>,
    /// Write a log-log plot of the deviations (all statistics overlaid, CI bands) to this
    /// file: .svg, or .png (with the default png feature).
    #[arg(long, value_name = "FILE")]
    pub plot: Option<std::path::PathBuf>,
    /// Output format.
    #[arg(long, short, value_enum, default_value = "table")]
    pub format: Format,
}

/// `--statistic` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StatisticArg {
    /// Overlapping Allan deviation (book eq. 4.2).
    Oadev,
    /// Non-overlapping Allan deviation.
    Adev,
    /// Modified Allan deviation: separates white from flicker phase noise.
    Mdev,
    /// Time deviation (phase units).
    Tdev,
    /// Hadamard deviation: insensitive to linear frequency drift.
    Hdev,
    /// Overlapping Hadamard deviation.
    Ohdev,
    /// Total deviation: tighter intervals at long tau.
    Totdev,
}

impl From<StatisticArg> for Statistic {
    fn from(s: StatisticArg) -> Statistic {
        match s {
            StatisticArg::Oadev => Statistic::Oadev,
            StatisticArg::Adev => Statistic::Adev,
            StatisticArg::Mdev => Statistic::Mdev,
            StatisticArg::Tdev => Statistic::Tdev,
            StatisticArg::Hdev => Statistic::Hdev,
            StatisticArg::Ohdev => Statistic::Ohdev,
            StatisticArg::Totdev => Statistic::Totdev,
        }
    }
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

fn write_plot(path: &std::path::Path, svg: &str) -> Result<()> {
    let is_png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    let bytes = if is_png {
        #[cfg(feature = "png")]
        {
            crate::plot::svg_to_png(svg, 1.5).map_err(|m| crate::Error::File {
                file: path.display().to_string(),
                message: m,
            })?
        }
        #[cfg(not(feature = "png"))]
        {
            return Err(crate::Error::Usage(
                "--plot FILE.png needs the png feature; write an .svg instead".into(),
            ));
        }
    } else {
        svg.as_bytes().to_vec()
    };
    std::fs::write(path, bytes).map_err(|e| crate::Error::io(path.display().to_string(), e))
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
    let Some(list) = &args.statistic else {
        // raw binary is used in place (or decoded by groups of channels), never read into a
        // table; other inputs are read into one
        let (file, curves) = crate::pipeline::estimate::avar_file(&args.input.spec(), &config, ui)?;
        return write_av_curves(args, &config, &curves, &file);
    };
    let table = args.input.read(ui)?;
    let mut stats: Vec<Statistic> = Vec::new();
    for &s in list {
        let s = Statistic::from(s);
        if !stats.contains(&s) {
            stats.push(s);
        }
    }
    let curves = compute_statistics(&table, table.rate()?, &config, &stats, ui)?;
    if let Some(path) = &args.plot {
        write_plot(path, &plot_curves(&curves, &table.file))?;
    }
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let res = match args.format {
        Format::Json => {
            serde_json::to_writer(&mut out, &curves_json(&curves))?;
            writeln!(out)
        }
        Format::Csv => write_curves_csv(&mut out, &curves),
        Format::Table => write_curves_table(&mut out, &curves, args.alpha),
    };
    res.and_then(|_| out.flush())
        .map_err(|e| crate::Error::write("<stdout>", e))
}

/// Writes the AV curves of `imunoise avar` (and the plot) as the flags say.
fn write_av_curves(
    args: &AvarArgs,
    config: &AvarConfig,
    curves: &[(String, avar::AllanVariance)],
    file: &str,
) -> Result<()> {
    if let Some(path) = &args.plot {
        let st = match config.estimator {
            Estimator::Overlapping => Statistic::Oadev,
            Estimator::NonOverlapping => Statistic::Adev,
        };
        let c: Vec<Curve> = curves
            .iter()
            .map(|(name, av)| Curve::from_av(name, st, av.clone()))
            .collect();
        write_plot(path, &plot_curves(&c, file))?;
    }
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let res = match args.format {
        Format::Json => {
            serde_json::to_writer(&mut out, &to_json(curves))?;
            writeln!(out)
        }
        Format::Csv => write_csv(&mut out, curves),
        Format::Table => write_table(&mut out, curves, args.alpha),
    };
    res.and_then(|_| out.flush())
        .map_err(|e| crate::Error::write("<stdout>", e))
}
