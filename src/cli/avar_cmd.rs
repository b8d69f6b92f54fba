//! `imunoise avar`: the Allan variance of every channel of a log, with CIs.

use super::{Format, InputArgs, Ui, avar_error, parse_scales};
use crate::error::Result;
use avar::stability::{Stability, Statistic};
use avar::{AllanVariance, AvarConfig, CiMethod, Estimator, InputKind, Scales};
use rayon::prelude::*;
use serde::Serialize;
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
    /// Identified power-law exponent α (S_y ∝ f^α) with `--statistic` (null without a
    /// chi-square CI); absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha: Option<Option<i32>>,
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
    /// The statistic (`"oadev"`, `"mdev"`, …), with `--statistic` only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub statistic: Option<Statistic>,
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
                        alpha: None,
                    })
                    .collect(),
                statistic: None,
            })
            .collect(),
    }
}

/// One channel's curve of one statistic (the `--statistic` output).
#[derive(Debug, Clone)]
pub struct Curve {
    /// Channel name.
    pub name: String,
    /// Estimator (overlapping or not) of the statistic.
    pub estimator: Estimator,
    /// CI family.
    pub ci: CiMethod,
    /// The curve.
    pub stability: Stability,
}

impl Curve {
    fn from_av(name: &str, statistic: Statistic, av: AllanVariance) -> Curve {
        Curve {
            name: name.to_string(),
            estimator: av.estimator,
            ci: av.ci,
            stability: Stability {
                statistic,
                rate_hz: av.rate_hz,
                n: av.n,
                input: av.input,
                ci: av.ci,
                alpha: av.alpha,
                points: av
                    .points
                    .into_iter()
                    .map(|p| avar::stability::StabilityPoint {
                        m: p.m,
                        tau: p.tau,
                        var: p.avar,
                        dev: p.adev,
                        var_lo: p.avar_lo,
                        var_hi: p.avar_hi,
                        dev_lo: p.adev_lo,
                        dev_hi: p.adev_hi,
                        edf: p.edf,
                        n_terms: p.n_terms,
                        alpha: p.noise_alpha,
                    })
                    .collect(),
            },
        }
    }
}

/// The JSON document of `--statistic` curves (one channel entry per channel and statistic).
pub fn curves_json(curves: &[Curve]) -> AvarJson {
    AvarJson {
        channels: curves
            .iter()
            .map(|c| ChannelJson {
                name: c.name.clone(),
                rate_hz: c.stability.rate_hz,
                n: c.stability.n,
                estimator: c.estimator,
                statistic: Some(c.stability.statistic),
                points: c
                    .stability
                    .points
                    .iter()
                    .map(|p| PointJson {
                        m: p.m,
                        tau: p.tau,
                        avar: p.var,
                        adev: p.dev,
                        avar_lo: p.var_lo,
                        avar_hi: p.var_hi,
                        edf: p.edf,
                        n_terms: p.n_terms,
                        alpha: Some(p.alpha),
                    })
                    .collect(),
            })
            .collect(),
    }
}

/// Writes `--statistic` curves as CSV: today's columns, then `statistic` and `alpha`.
pub fn write_curves_csv(out: &mut impl Write, curves: &[Curve]) -> std::io::Result<()> {
    writeln!(
        out,
        "channel,m,tau,avar,adev,avar_lo,avar_hi,adev_lo,adev_hi,edf,n_terms,statistic,alpha"
    )?;
    for c in curves {
        for p in &c.stability.points {
            writeln!(
                out,
                "{},{},{},{:e},{:e},{},{},{},{},{},{},{},{}",
                c.name,
                p.m,
                p.tau,
                p.var,
                p.dev,
                opt(p.var_lo),
                opt(p.var_hi),
                opt(p.dev_lo),
                opt(p.dev_hi),
                p.edf.map_or(String::new(), |e| format!("{e:.3}")),
                p.n_terms,
                c.stability.statistic,
                p.alpha.map_or(String::new(), |a| a.to_string())
            )?;
        }
    }
    Ok(())
}

/// Writes `--statistic` curves as aligned text tables (one per channel and statistic).
pub fn write_curves_table(
    out: &mut impl Write,
    curves: &[Curve],
    alpha: f64,
) -> std::io::Result<()> {
    for (i, c) in curves.iter().enumerate() {
        if i > 0 {
            writeln!(out)?;
        }
        let level = 100.0 * (1.0 - alpha);
        let ci = match c.ci {
            CiMethod::ChiSquare => format!("{level:.1}% chi-square CI"),
            CiMethod::Gaussian => format!("{level:.1}% Gaussian CI (Lemma 4.4)"),
            CiMethod::None => "no CI".to_string(),
        };
        let s = &c.stability;
        writeln!(
            out,
            "{}: {}, n = {}, rate = {} Hz, {ci}",
            c.name,
            s.statistic.name().to_uppercase(),
            s.n,
            s.rate_hz,
        )?;
        writeln!(
            out,
            "{:>10} {:>12} {:>12} {:>12} {:>12} {:>9} {:>10} {:>5}",
            "m", "tau [s]", "dev", "dev_lo", "dev_hi", "edf", "n_terms", "alpha"
        )?;
        let f = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.5e}"));
        for p in &s.points {
            writeln!(
                out,
                "{:>10} {:>12} {:>12.5e} {:>12} {:>12} {:>9} {:>10} {:>5}",
                p.m,
                format!("{:.4}", p.tau),
                p.dev,
                f(p.dev_lo),
                f(p.dev_hi),
                p.edf.map_or("-".to_string(), |e| format!("{e:.1}")),
                p.n_terms,
                p.alpha.map_or("-".to_string(), |a| a.to_string())
            )?;
        }
    }
    Ok(())
}

/// Computes every requested statistic of every channel of `table` (channels in parallel).
/// `oadev` (overlapping) and `adev` (non-overlapping) are the AV with the configured CI exactly
/// as in the default output (`config.estimator` is not used: the statistic names it); the other
/// statistics come from [`avar::stability::stability`].
pub fn compute_statistics(
    table: &crate::io::Table,
    rate_hz: f64,
    config: &AvarConfig,
    statistics: &[Statistic],
    ui: &Ui,
) -> Result<Vec<Curve>> {
    let pb = ui.bar((table.columns.len() * statistics.len()) as u64, "stability");
    let res: Vec<Result<Vec<Curve>>> = table
        .columns
        .par_iter()
        .zip(&table.names)
        .map(|(col, name)| {
            statistics
                .iter()
                .map(|&st| {
                    let r = match st {
                        Statistic::Oadev | Statistic::Adev => {
                            let cfg = AvarConfig {
                                estimator: if st == Statistic::Adev {
                                    Estimator::NonOverlapping
                                } else {
                                    Estimator::Overlapping
                                },
                                ..config.clone()
                            };
                            avar::allan_variance(col, rate_hz, &cfg)
                                .map(|av| Curve::from_av(name, st, av))
                        }
                        _ => avar::stability::stability(col, rate_hz, st, config).map(|s| Curve {
                            name: name.clone(),
                            estimator: if st.overlapping() {
                                Estimator::Overlapping
                            } else {
                                Estimator::NonOverlapping
                            },
                            ci: config.ci,
                            stability: s,
                        }),
                    };
                    pb.inc(1);
                    r.map_err(|e| avar_error(&table.file, &format!("{name} ({st})"), e))
                })
                .collect()
        })
        .collect();
    pb.finish_and_clear();
    let mut out = Vec::new();
    for r in res {
        out.extend(r?);
    }
    Ok(out)
}

/// The overlay plot of curves: one line (with its CI band) per channel and statistic.
pub fn plot_curves(curves: &[Curve], title: &str) -> String {
    let series: Vec<crate::plot::StabilitySeries> = curves
        .iter()
        .map(|c| crate::plot::StabilitySeries {
            label: if curves.iter().all(|d| d.name == c.name) {
                c.stability.statistic.name().to_uppercase()
            } else {
                format!("{} {}", c.name, c.stability.statistic.name().to_uppercase())
            },
            points: c
                .stability
                .points
                .iter()
                .map(|p| {
                    (
                        p.tau,
                        p.dev,
                        p.dev_lo.unwrap_or(f64::NAN),
                        p.dev_hi.unwrap_or(f64::NAN),
                    )
                })
                .collect(),
        })
        .collect();
    crate::plot::stability_svg(title, &series, "stab")
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
    if let Some(list) = &args.statistic {
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
        return res
            .and_then(|_| out.flush())
            .map_err(|e| crate::Error::write("<stdout>", e));
    }
    let curves = compute(&table, table.rate()?, &config, ui)?;
    if let Some(path) = &args.plot {
        let st = match config.estimator {
            Estimator::Overlapping => Statistic::Oadev,
            Estimator::NonOverlapping => Statistic::Adev,
        };
        let c: Vec<Curve> = curves
            .iter()
            .map(|(name, av)| Curve::from_av(name, st, av.clone()))
            .collect();
        write_plot(path, &plot_curves(&c, &table.file))?;
    }
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
        .map_err(|e| crate::Error::write("<stdout>", e))
}
