//! Estimating: each channel's Allan variance (or another member of the stability family, or
//! the robust AV) and the data-quality findings, with the writers of the `imunoise avar`
//! output (JSON shape, CSV, text tables, overlay plot).

use crate::error::{Error, Result};
use crate::io::Table;
use crate::ui::Ui;
use avar::stability::{Stability, Statistic};
use avar::{AllanVariance, AvarConfig, CiMethod, Estimator};
use processes::Unit;
use rayon::prelude::*;
use serde::Serialize;
use std::io::Write;

/// Maps an `avar` error of one channel to a message naming the file and channel.
///
/// ```
/// use imunoise::pipeline::estimate::avar_error;
/// let cfg = imunoise::avar::AvarConfig::default();
/// let e = imunoise::avar::allan_variance(&[], 100.0, &cfg).unwrap_err();
/// let err = avar_error("imu.csv", "gyro_x", e);
/// assert!(err.to_string().starts_with("imu.csv: channel \"gyro_x\": "));
/// assert_eq!(err.exit_code(), 2);
/// ```
pub fn avar_error(file: &str, channel: &str, e: avar::AvarError) -> Error {
    let hint = match e {
        avar::AvarError::NotRepresentable { .. } => " (--scale F multiplies every sample by F)",
        _ => "",
    };
    Error::File {
        file: file.to_string(),
        message: format!("channel {channel:?}: {e}{hint}"),
    }
}

/// One point of the JSON output (exactly the documented keys).
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let json = imunoise::pipeline::estimate::to_json(&[("gx".to_string(), av)]);
/// let p = serde_json::to_value(&json.channels[0].points[0])?;
/// let keys: Vec<&str> = p.as_object().unwrap().keys().map(String::as_str).collect();
/// // `alpha` is there only for `--statistic` curves
/// assert_eq!(keys, ["adev", "avar", "avar_hi", "avar_lo", "edf", "m", "n_terms", "tau"]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let json = imunoise::pipeline::estimate::to_json(&[("gx".to_string(), av)]);
/// let c = serde_json::to_value(&json.channels[0])?;
/// assert_eq!(c["name"], "gx");
/// assert_eq!(c["rate_hz"], 100.0);
/// assert_eq!(c["n"], 4096);
/// assert_eq!(c["estimator"], "overlapping");
/// assert!(c.get("statistic").is_none()); // only with `--statistic`
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let curves = vec![("gx".to_string(), av.clone()), ("gy".to_string(), av)];
/// let doc = serde_json::to_value(imunoise::pipeline::estimate::to_json(&curves))?;
/// assert_eq!(doc["channels"].as_array().unwrap().len(), 2);
/// assert_eq!(doc["channels"][1]["name"], "gy");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Serialize)]
pub struct AvarJson {
    /// One entry per channel, in the order of the input (or of --columns).
    pub channels: Vec<ChannelJson>,
}

/// Parses `--scales`: `dyadic` (book default), `dyadic1` (with m = 1), `octave`, `decade`,
/// `all`, `logN` (N per decade) or an explicit list `m1,m2,…` (cluster sizes in samples;
/// τ = m / rate in s). The command's `--scales` and the Python package's `scales=` both
/// go through it.
///
/// ```
/// use imunoise::pipeline::estimate::parse_scales;
/// assert_eq!(parse_scales("octave"), Ok(imunoise::avar::Scales::Octave));
/// assert_eq!(parse_scales("1,4,16"), Ok(imunoise::avar::Scales::Explicit(vec![1, 4, 16])));
/// assert!(parse_scales("fortnightly").is_err());
/// assert!(parse_scales("0,5").is_err()); // m counts samples: m ≥ 1
/// assert!(parse_scales("log0").is_err());
/// ```
pub fn parse_scales(s: &str) -> std::result::Result<avar::Scales, String> {
    use avar::Scales;
    let t = s.trim().to_ascii_lowercase();
    Ok(match t.as_str() {
        "dyadic" => Scales::Dyadic,
        "dyadic1" | "dyadic-with-one" => Scales::DyadicWithOne,
        "octave" => Scales::Octave,
        "decade" => Scales::Decade,
        "all" => Scales::All,
        _ if t.starts_with("log") => Scales::LogSpaced {
            per_decade: t[3..]
                .parse()
                .ok()
                .filter(|&n: &usize| n >= 1)
                .ok_or_else(|| format!("{s:?}: expected logN with N ≥ 1 points per decade"))?,
        },
        _ => Scales::Explicit(
            t.split(',')
                .map(|m| match m.trim().parse::<u64>() {
                    Ok(0) => Err(format!(
                        "{s:?}: cluster size m = 0 is not allowed (m counts samples, m >= 1)"
                    )),
                    Ok(m) => Ok(m),
                    Err(_) => Err(format!(
                        "{s:?}: expected dyadic, dyadic1, octave, decade, all, logN or a list of cluster sizes m1,m2,…"
                    )),
                })
                .collect::<std::result::Result<_, _>>()?,
        ),
    })
}

/// Builds the JSON document of named curves.
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let json = imunoise::pipeline::estimate::to_json(&[("gx".to_string(), av.clone())]);
/// let c = &json.channels[0];
/// assert_eq!((c.name.as_str(), c.n, c.rate_hz), ("gx", av.n, av.rate_hz));
/// // the points as they are, one for one
/// assert_eq!(c.points.len(), av.points.len());
/// for (q, p) in c.points.iter().zip(&av.points) {
///     assert_eq!((q.m, q.avar, q.avar_lo, q.edf), (p.m, p.avar, p.avar_lo, p.edf));
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
///
/// ```
/// use imunoise::avar::stability::Statistic;
/// use imunoise::pipeline::estimate::Curve;
/// use imunoise::avar::{AvarConfig, allan_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let c = Curve::from_av("gx", Statistic::Oadev, av.clone());
/// assert_eq!(c.name, "gx");
/// assert_eq!((c.estimator, c.ci), (av.estimator, av.ci));
/// assert_eq!(c.stability.statistic, Statistic::Oadev);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
    /// The curve of `statistic` (oadev or adev) from an Allan variance of channel `name`.
    ///
    /// ```
    /// use imunoise::avar::stability::Statistic;
    /// use imunoise::avar::{AvarConfig, allan_variance};
    /// use imunoise::pipeline::estimate::Curve;
    /// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
    /// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
    /// let c = Curve::from_av("gx", Statistic::Oadev, av.clone());
    /// // the same numbers under the names of the stability family
    /// assert_eq!(c.stability.n, av.n);
    /// for (q, p) in c.stability.points.iter().zip(&av.points) {
    ///     assert_eq!((q.m, q.var, q.dev, q.dev_lo), (p.m, p.avar, p.adev, p.adev_lo));
    /// }
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn from_av(name: &str, statistic: Statistic, av: AllanVariance) -> Curve {
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
                    .iter()
                    .map(avar::stability::StabilityPoint::from)
                    .collect(),
            },
        }
    }
}

/// The JSON document of `--statistic` curves (one channel entry per channel and statistic).
///
/// ```
/// use imunoise::avar::stability::Statistic;
/// use imunoise::avar::{AvarConfig, allan_variance};
/// use imunoise::pipeline::estimate::Curve;
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let curves = [Curve::from_av("gx", Statistic::Oadev, av.clone())];
/// let doc = serde_json::to_value(imunoise::pipeline::estimate::curves_json(&curves))?;
/// let c = &doc["channels"][0];
/// assert_eq!(c["statistic"], "oadev");
/// assert_eq!(c["points"].as_array().unwrap().len(), av.points.len());
/// // each point says which power law was identified there (null without one)
/// assert!(c["points"][0].get("alpha").is_some());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
///
/// ```
/// use imunoise::avar::stability::Statistic;
/// use imunoise::avar::{AvarConfig, allan_variance};
/// use imunoise::pipeline::estimate::Curve;
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let curves = [Curve::from_av("gx", Statistic::Oadev, av.clone())];
/// let mut out = Vec::new();
/// imunoise::pipeline::estimate::write_curves_csv(&mut out, &curves)?;
/// let text = String::from_utf8(out)?;
/// let lines: Vec<&str> = text.lines().collect();
/// assert!(lines[0].ends_with(",statistic,alpha"));
/// assert_eq!(lines.len(), 1 + av.points.len());
/// assert!(lines[1].starts_with("gx,2,")); // the first dyadic cluster size is m = 2
/// assert_eq!(lines[1].split(',').nth(11), Some("oadev"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
                p.edf.map_or(String::new(), |e| format!("{e}")),
                p.n_terms,
                c.stability.statistic,
                p.alpha.map_or(String::new(), |a| a.to_string())
            )?;
        }
    }
    Ok(())
}

/// Writes `--statistic` curves as aligned text tables (one per channel and statistic).
///
/// ```
/// use imunoise::avar::stability::Statistic;
/// use imunoise::avar::{AvarConfig, allan_variance};
/// use imunoise::pipeline::estimate::Curve;
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let curves = [Curve::from_av("gx", Statistic::Oadev, av.clone())];
/// let mut out = Vec::new();
/// imunoise::pipeline::estimate::write_curves_table(&mut out, &curves, 0.05)?;
/// let text = String::from_utf8(out)?;
/// assert!(text.starts_with("gx: OADEV, n = 4096, rate = 100 Hz, 95.0% chi-square CI"));
/// // a title line, a header line and one line per point
/// assert_eq!(text.lines().count(), 2 + av.points.len());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
///
/// ```
/// use imunoise::avar::AvarConfig;
/// use imunoise::avar::stability::Statistic;
/// use imunoise::pipeline::estimate::{compute, compute_statistics};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gx".into()],
///     columns: vec![x.clone().into()],
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let (cfg, ui) = (AvarConfig::default(), imunoise::Ui::quiet());
/// let stats = [Statistic::Oadev, Statistic::Mdev];
/// let curves = compute_statistics(&table, 100.0, &cfg, &stats, &ui)?;
/// assert_eq!(curves.len(), 2); // channels × statistics
/// assert_eq!(curves[1].stability.statistic, Statistic::Mdev);
/// // OADEV is the overlapping Allan variance, exactly as `compute` gives it
/// let av = &compute(&table, 100.0, &cfg, &ui)?[0].1;
/// let oadev: Vec<f64> = curves[0].stability.points.iter().map(|p| p.var).collect();
/// assert_eq!(oadev, av.points.iter().map(|p| p.avar).collect::<Vec<_>>());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn compute_statistics(
    table: &Table,
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
///
/// ```
/// use imunoise::avar::stability::Statistic;
/// use imunoise::avar::{AvarConfig, allan_variance};
/// use imunoise::pipeline::estimate::Curve;
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let curves = [Curve::from_av("gx", Statistic::Oadev, av.clone())];
/// let svg = imunoise::pipeline::estimate::plot_curves(&curves, "gyro x");
/// assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
/// // one channel: each line is labelled by its statistic alone
/// assert!(svg.contains("OADEV") && svg.contains("gyro x"));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |x| format!("{x:e}"))
}

/// Writes the curves as CSV (long format, one row per channel and scale).
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let mut out = Vec::new();
/// imunoise::pipeline::estimate::write_csv(&mut out, &[("gx".to_string(), av.clone())])?;
/// let text = String::from_utf8(out)?;
/// let mut lines = text.lines();
/// let header = "channel,m,tau,avar,adev,avar_lo,avar_hi,adev_lo,adev_hi,edf,n_terms";
/// assert_eq!(lines.next(), Some(header));
/// // every number is written in the shortest form that reads back to the same f64 (so that
/// // `imunoise fit --curve` of this file fits exactly what was estimated)
/// for (line, p) in lines.zip(&av.points) {
///     let cells: Vec<&str> = line.split(',').collect();
///     assert_eq!(cells[0], "gx");
///     assert_eq!(cells[3].parse::<f64>()?, p.avar);
///     assert_eq!(cells[9].parse::<f64>()?, p.edf.unwrap());
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
                p.edf.map_or(String::new(), |e| format!("{e}")),
                p.n_terms
            )?;
        }
    }
    Ok(())
}

/// Writes the curves as aligned text tables (deviations with their CI).
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let av = allan_variance(&x, 100.0, &AvarConfig::default())?;
/// let mut out = Vec::new();
/// imunoise::pipeline::estimate::write_table(&mut out, &[("gx".to_string(), av.clone())], 0.05)?;
/// let text = String::from_utf8(out)?;
/// assert!(text.starts_with("gx: n = 4096, rate = 100 Hz"));
/// assert!(text.lines().next().unwrap().ends_with("95% chi-square CI"));
/// // a title line, a header line and one line per point
/// assert_eq!(text.lines().count(), 2 + av.points.len());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
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
///
/// ```
/// use imunoise::avar::{AvarConfig, allan_variance};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gx".into()],
///     columns: vec![x.clone().into()],
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let cfg = AvarConfig::default();
/// let ui = imunoise::Ui::quiet();
/// let curves = imunoise::pipeline::estimate::compute(&table, 100.0, &cfg, &ui)?;
/// assert_eq!(curves[0].0, "gx");
/// // each channel's curve is the one `avar` computes for it
/// assert_eq!(curves[0].1, allan_variance(&x, 100.0, &cfg)?);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn compute(
    table: &Table,
    rate_hz: f64,
    config: &AvarConfig,
    ui: &Ui,
) -> Result<Vec<(String, AllanVariance)>> {
    let cols: Vec<&[f64]> = table.columns.iter().map(|c| &c[..]).collect();
    compute_columns(&table.file, &table.names, &cols, rate_hz, config, ui)
}

/// [`compute`] on borrowed channels (the Python package passes numpy memory here without
/// copying it): each channel's Allan variance at `rate_hz` (Hz), channels in parallel, in
/// the units of the samples squared; `file` names the source in error messages.
///
/// ```
/// use imunoise::pipeline::estimate::compute_columns;
/// let x: Vec<f64> = (0..1024).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// let cfg = imunoise::avar::AvarConfig {
///     ci: imunoise::avar::CiMethod::None,
///     ..Default::default()
/// };
/// let c = compute_columns("<array>", &["x".into()], &[&x], 1.0, &cfg, &imunoise::Ui::quiet())?;
/// // ±1 alternating: every cluster mean of even size m is 0, so the AV is 0 at every m ≥ 2
/// assert!(c[0].1.points.iter().all(|p| p.avar == 0.0));
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn compute_columns(
    file: &str,
    names: &[String],
    columns: &[&[f64]],
    rate_hz: f64,
    config: &AvarConfig,
    ui: &Ui,
) -> Result<Vec<(String, AllanVariance)>> {
    let pb = ui.bar(columns.len() as u64, "Allan var.");
    let res: Vec<Result<(String, AllanVariance)>> = columns
        .par_iter()
        .zip(names)
        .map(|(col, name)| {
            let r = avar::allan_variance(col, rate_hz, config)
                .map(|av| (name.clone(), av))
                .map_err(|e| avar_error(file, name, e));
            pb.inc(1);
            r
        })
        .collect();
    pb.finish_and_clear();
    res.into_iter().collect()
}

/// Each channel's name with its Allan variance.
pub type ChannelCurves = Vec<(String, AllanVariance)>;

/// Reads the input of `fit`/`analyze`, resolves each channel's unit and computes its Allan
/// variance on the default (dyadic) scales with chi-square CIs at level 1 − `alpha`.
///
/// ```
/// use imunoise::pipeline::{estimate, read::Input};
/// use imunoise::processes::Unit;
/// let dir = tempfile::tempdir()?;
/// let p = dir.path().join("imu.csv");
/// let rows: String = (0..4096).map(|i| format!("{},{}\n", i % 7, i % 3)).collect();
/// std::fs::write(&p, format!("gyro_x_dps,acc_x_g\n{rows}"))?;
/// let ui = imunoise::Ui::quiet();
/// let input = Input { rate: Some(100.0), ..Input::new(&p) };
/// let (table, units, curves) = estimate::read_curves(&input, 0.05, &ui)?;
/// assert_eq!(table.n_rows(), 4096);
/// assert_eq!(units, [Unit::DegPerSec, Unit::G]); // from the names' suffixes
/// assert_eq!(curves, estimate::fit_curves(&table, 0.05, &ui)?);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_curves(
    input: &super::read::Input,
    alpha: f64,
    ui: &Ui,
) -> Result<(Table, Vec<Unit>, ChannelCurves)> {
    let table = input.read(ui)?;
    let units = input.units(&table)?;
    let curves = fit_curves(&table, alpha, ui)?;
    Ok((table, units, curves))
}

/// The curves `fit` and `analyze` fit: each channel's Allan variance on the default (dyadic)
/// scales with chi-square CIs at level 1 − `alpha`, at the table's rate.
///
/// ```
/// use imunoise::avar::{AvarConfig, CiMethod, Scales};
/// use imunoise::pipeline::estimate::{compute, fit_curves};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gx".into()],
///     columns: vec![x.clone().into()],
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let ui = imunoise::Ui::quiet();
/// let curves = fit_curves(&table, 0.1, &ui)?;
/// let av = &curves[0].1;
/// assert_eq!((av.ci, av.alpha), (CiMethod::ChiSquare, 0.1));
/// assert!(av.points.iter().all(|p| p.avar_lo.is_some()));
/// // that is `compute` at the table's rate with the default configuration at level 0.9
/// let cfg = AvarConfig { scales: Scales::Dyadic, alpha: 0.1, ..Default::default() };
/// assert_eq!(curves, compute(&table, 100.0, &cfg, &ui)?);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn fit_curves(table: &Table, alpha: f64, ui: &Ui) -> Result<ChannelCurves> {
    let cfg = AvarConfig {
        alpha,
        ..AvarConfig::default()
    };
    compute(table, table.rate()?, &cfg, ui)
}

/// The data-quality pass ([`avar::quality`]) of every channel of `table` at `rate` Hz: one list
/// of findings per channel (spikes, level shifts, a dominant trend, each with its times and how
/// it biases the AV), printed as notes before any fitting. Channels shorter than 64 samples are
/// not examined. `classical`: the channels' classical curves from [`fit_curves`], whose AV at
/// the pass's three scales is read instead of computed again (the same findings).
///
/// ```
/// use imunoise::pipeline::estimate::{check_quality, fit_curves};
/// // a fixed noise-like sequence with a level shift of 1.0 at sample 6000 (t = 60 s), and a
/// // channel too short to be examined
/// let x: Vec<f64> = (0..10_000)
///     .map(|i| ((i as f64 * 0.7548776662).fract() - 0.5) * 0.1)
///     .enumerate()
///     .map(|(i, v)| if i >= 6000 { v + 1.0 } else { v })
///     .collect();
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gx".into(), "short".into()],
///     columns: vec![x.into(), vec![0.0; 10_000].into()],
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let ui = imunoise::Ui::quiet();
/// let q = check_quality(&table, 100.0, None, &ui)?;
/// assert!(q[0].iter().any(|f| f.starts_with("data quality: a level shift")));
/// // the classical curves, when given, are read instead of recomputed: the same findings
/// let curves = fit_curves(&table, 0.05, &ui)?;
/// assert_eq!(check_quality(&table, 100.0, Some(&curves), &ui)?, q);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn check_quality(
    table: &Table,
    rate: f64,
    classical: Option<&ChannelCurves>,
    ui: &Ui,
) -> Result<Vec<Vec<String>>> {
    let out = table
        .names
        .par_iter()
        .zip(&table.columns)
        .enumerate()
        .map(|(k, (name, x))| {
            if x.len() < 64 {
                return Ok(Vec::new());
            }
            let given = classical.and_then(|c| c.get(k)).map(|c| &c.1);
            let q = avar::quality::data_quality_with(x, rate, &Default::default(), given)
                .map_err(|e| avar_error(&table.file, name, e))?;
            Ok(q.findings
                .iter()
                .map(|f| format!("data quality: {f}"))
                .collect())
        })
        .collect::<Result<Vec<Vec<String>>>>()?;
    for (name, f) in table.names.iter().zip(&out) {
        for w in f {
            ui.note(format!("note: channel {name:?}: {w}"));
        }
    }
    Ok(out)
}

/// Each channel's robust AV (beside the classical one), on the default dyadic scales with
/// chi-square CIs at level 1 − `alpha` and EDF × efficiency. `classical`: the channels'
/// classical curves from [`fit_curves`] with the same `alpha`, reused instead of recomputed.
///
/// ```
/// use imunoise::pipeline::estimate::{fit_curves, robust_curves};
/// let x: Vec<f64> = (0..4096).map(|i| ((i * 7919) % 1000) as f64 / 1000.0).collect();
/// let table = imunoise::io::Table {
///     file: "<array>".into(),
///     names: vec!["gx".into()],
///     columns: vec![x.clone().into()],
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// let curves = fit_curves(&table, 0.05, &imunoise::Ui::quiet())?;
/// let r = robust_curves(&table, 100.0, 0.05, 0.6, Some(&curves))?;
/// assert_eq!(r[0].0, "gx");
/// assert!((r[0].1.efficiency - 0.6).abs() < 1e-9); // the biweight's c is solved for it
/// // beside the robust curve, the classical one it was given
/// assert_eq!(r[0].1.classical, curves[0].1);
/// assert_eq!(r[0].1.robust.points.len(), curves[0].1.points.len());
/// // computed afresh when not given: the same result
/// assert_eq!(robust_curves(&table, 100.0, 0.05, 0.6, None)?, r);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn robust_curves(
    table: &Table,
    rate: f64,
    alpha: f64,
    efficiency: f64,
    classical: Option<&ChannelCurves>,
) -> Result<Vec<(String, avar::robust::RobustAllanVariance)>> {
    let cfg = AvarConfig {
        alpha,
        ..AvarConfig::default()
    };
    // channels in parallel: each has serial parts (prefix sums, spike replacement) and a few
    // dominant scales; their buffers are lent by one scratch (fresh pages once per concurrent
    // channel, not per channel)
    let scratch = avar::robust::RobustScratch::default();
    table
        .names
        .par_iter()
        .zip(&table.columns)
        .enumerate()
        .map(|(k, (n, x))| {
            match classical {
                Some(c) => avar::robust::robust_allan_variance_from_with(
                    x,
                    c[k].1.clone(),
                    &cfg,
                    efficiency,
                    &scratch,
                ),
                None => avar::robust::robust_allan_variance(x, rate, &cfg, efficiency),
            }
            .map(|r| (n.clone(), r))
            .map_err(|e| Error::Usage(format!("channel {n:?}: robust AV: {e}")))
        })
        .collect()
}

/// Each channel's Allan variance of the file `input` names, as `imunoise avar` computes it:
/// raw binary through [`avar_streamed`] (used in place or decoded by groups of channels, never
/// read into a table), every other input (text, gzip, logs, standard input) read by
/// [`super::read::Input::read`] and estimated by [`compute`]. Returns the name the file goes
/// by in messages (`<stdin>` for `-`) and the curves, in the units of the samples squared.
///
/// ```
/// use imunoise::pipeline::{estimate::avar_file, read::Input};
/// use avar::{AvarConfig, CiMethod};
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("x.csv");
/// let rows: String = (0..4096).map(|i| format!("{},{}\n", i % 7, i % 3)).collect();
/// std::fs::write(&p, format!("gx,gy\n{rows}")).unwrap();
/// let cfg = AvarConfig { ci: CiMethod::None, ..Default::default() };
/// let input = Input { rate: Some(100.0), ..Input::new(&p) };
/// let (_, curves) = avar_file(&input, &cfg, &imunoise::Ui::quiet()).unwrap();
/// assert_eq!(curves.len(), 2);
/// assert_eq!(curves[1].0, "gy");
/// ```
pub fn avar_file(
    input: &super::read::Input,
    config: &AvarConfig,
    ui: &Ui,
) -> Result<(String, ChannelCurves)> {
    if can_stream(input) {
        let curves = avar_streamed(input, config, ui)?;
        return Ok((input.file.display().to_string(), curves));
    }
    if streams_text(input) {
        let curves = avar_text_streamed(input, config, crate::source::TEXT_WINDOW, ui)?;
        return Ok((input.file.display().to_string(), curves));
    }
    let table = input.read(ui)?;
    let curves = compute(&table, table.rate()?, config, ui)?;
    Ok((table.file, curves))
}

/// Whether `imunoise avar` parses `input` in windows ([`avar_text_streamed`]): a regular,
/// uncompressed text file longer than a quarter of the available memory (reading it into a
/// table takes about its size in memory, mapped, and 8 bytes per value beside it), not a
/// log, without a time column or topics.
fn streams_text(input: &super::read::Input) -> bool {
    input.binary.is_none()
        && input.log_format().is_none()
        && input.time_column.is_none()
        && input.topic.is_empty()
        && input.channels.is_none()
        && crate::source::unseekable(&input.file).is_none()
        && std::fs::metadata(&input.file)
            .is_ok_and(|m| m.len() as usize > crate::source::memory_budget())
}

/// Each channel's Allan variance of a regular, uncompressed text file (CSV, TSV or
/// whitespace-separated) without holding it in memory: the text is parsed in windows of
/// `window` bytes into one compact f64 temporary file per column
/// ([`crate::source::decode_text`]), and each is estimated by
/// [`avar::allan_variance_source`]. Bit-identical to [`compute`] on the table
/// [`super::read::Input::read`] returns (the same values, names, selection, scale and
/// errors). `rate` is required. `imunoise avar` takes this path for text files longer than a
/// quarter of the available memory.
///
/// ```
/// use imunoise::pipeline::{estimate::avar_text_streamed, read::Input};
/// use avar::{AvarConfig, CiMethod};
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("x.csv");
/// let rows: String = (0..4096).map(|i| format!("{},{}\n", i % 7, i % 3)).collect();
/// std::fs::write(&p, format!("gx,gy\n{rows}")).unwrap();
/// let input = Input { rate: Some(100.0), columns: Some("gy".into()), ..Input::new(&p) };
/// let cfg = AvarConfig { ci: CiMethod::None, ..Default::default() };
/// let curves = avar_text_streamed(&input, &cfg, 1000, &imunoise::Ui::quiet()).unwrap();
/// assert_eq!(curves[0].0, "gy");
/// assert_eq!(curves[0].1.n, 4096);
/// ```
pub fn avar_text_streamed(
    input: &super::read::Input,
    config: &AvarConfig,
    window: usize,
    ui: &Ui,
) -> Result<ChannelCurves> {
    let file = input.file.display().to_string();
    if input.binary.is_some() || input.time_column.is_some() || !input.topic.is_empty() {
        return Err(Error::Usage(format!(
            "{file}: only text without --binary, --time-column or --topic is parsed in windows"
        )));
    }
    if input.channels.is_some() {
        return Err(Error::Usage(
            "--channels is for binary input; text input has its columns".to_string(),
        ));
    }
    let rate_hz = input.rate.ok_or_else(|| crate::io::rate_required(&file))?;
    let select = input
        .columns
        .as_deref()
        .map(crate::io::parse_columns)
        .transpose()?;
    let size = std::fs::metadata(&input.file).map_or(0, |m| m.len());
    ui.note(format!(
        "note: {file} ({:.0} MB of text) is parsed in windows of {} MiB into temporary files \
         in {} (8 bytes per value of disk space, deleted at the end), not into memory",
        size as f64 / 1e6,
        window >> 20,
        std::env::temp_dir().display()
    ));
    let pb = ui.spinner(format!("parsing {file}"));
    let (names, sources) =
        crate::source::decode_text(&input.file, &file, select.as_deref(), input.scale, window)?;
    pb.finish_and_clear();
    let names = input.renamed(names)?;
    let pb = ui.bar(names.len() as u64, "Allan var.");
    let mut out = Vec::with_capacity(names.len());
    let refs: Vec<&dyn avar::SampleSource> = sources.iter().map(|s| s as _).collect();
    estimate_sources(&refs, &names, rate_hz, config, &file, &pb, &mut out)?;
    pb.finish_and_clear();
    Ok(out)
}

/// The Allan variance of each source (named by `names`, in order) appended to `out`, a step
/// of `pb` each: the estimation step of both streamed paths.
fn estimate_sources(
    sources: &[&dyn avar::SampleSource],
    names: &[String],
    rate_hz: f64,
    config: &AvarConfig,
    file: &str,
    pb: &indicatif::ProgressBar,
    out: &mut ChannelCurves,
) -> Result<()> {
    for (src, name) in sources.iter().zip(names) {
        let av = avar::allan_variance_source(*src, rate_hz, config)
            .map_err(|e| avar_error(file, name, e))?;
        out.push((name.clone(), av));
        pb.inc(1);
    }
    Ok(())
}

/// Whether [`avar_streamed`] can read `input`: raw binary (`--binary`), not a log, without a
/// time column or topics. `imunoise avar` streams exactly these inputs.
///
/// ```
/// use imunoise::io::BinaryType;
/// use imunoise::pipeline::{estimate::can_stream, read::Input};
/// let bin = Input { binary: Some(BinaryType::F64), ..Input::new("w.f64") };
/// assert!(can_stream(&bin));
/// assert!(!can_stream(&Input::new("imu.csv")));
/// ```
pub fn can_stream(input: &super::read::Input) -> bool {
    input.binary.is_some()
        && input.log_format.is_none()
        && input.time_column.is_none()
        && input.topic.is_empty()
}

/// Each channel's Allan variance of a raw binary file (see [`can_stream`]) without reading it
/// into memory: the file is used in place through a memory map (one channel of f64, no scale),
/// or decoded a group of channels at a time into reused buffers (a regular file; see
/// [`crate::source::for_channel_groups`]), or once into compact temporary files (gzip, pipes,
/// channels too long for memory; see [`crate::source`]), and each channel is
/// estimated by [`avar::allan_variance_source`], which streams (no series-sized buffer, a
/// bounded window of the file resident) when no CI is asked for. Bit-identical to [`compute`]
/// on the table [`super::read::Input::read`] returns. Channels are named `ch1`, `ch2`, … (or
/// by `names`), selected by `columns`; `rate` is required.
///
/// ```
/// use imunoise::io::BinaryType;
/// use imunoise::pipeline::{estimate::avar_streamed, read::Input};
/// use avar::{AvarConfig, CiMethod};
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("w.f64");
/// let bytes: Vec<u8> = (0..4096).flat_map(|i| ((i % 7) as f64).to_le_bytes()).collect();
/// std::fs::write(&p, bytes).unwrap();
/// let input = Input { binary: Some(BinaryType::F64), rate: Some(100.0), ..Input::new(&p) };
/// let cfg = AvarConfig { ci: CiMethod::None, ..Default::default() };
/// let curves = avar_streamed(&input, &cfg, &imunoise::Ui::quiet()).unwrap();
/// assert_eq!(curves[0].0, "ch1");
/// assert_eq!(curves[0].1.n, 4096);
/// ```
pub fn avar_streamed(
    input: &super::read::Input,
    config: &AvarConfig,
    ui: &Ui,
) -> Result<ChannelCurves> {
    let file = input.file.display().to_string();
    let Some(kind) = input.binary.filter(|_| can_stream(input)) else {
        return Err(Error::Usage(format!(
            "{file}: only raw binary input (--binary) without --time-column or --topic is streamed"
        )));
    };
    let channels = input.channels.unwrap_or(1);
    let layout = crate::source::BinaryLayout {
        scale: input.scale,
        ..crate::source::BinaryLayout::new(kind, channels)
    };
    let all: Vec<String> = (1..=channels).map(|c| format!("ch{c}")).collect();
    let idx: Vec<usize> = match &input.columns {
        Some(list) => crate::io::resolve_columns(&crate::io::parse_columns(list)?, &all)?,
        None => (0..channels).collect(),
    };
    let names = input.renamed(idx.iter().map(|&i| all[i].clone()).collect())?;
    let rate_hz = input.rate.ok_or_else(|| crate::io::rate_required(&file))?;
    if let Some(why) = crate::source::unseekable(&input.file) {
        ui.note(format!(
            "note: {} cannot be read by position: it is decoded once, in one pass, into \
             temporary files in {} (8 bytes per sample and channel of disk space, deleted at \
             the end); the memory stays bounded",
            crate::source::unseekable_subject(&input.file, why),
            std::env::temp_dir().display()
        ));
    }
    let pb = ui.bar(names.len() as u64, "Allan var.");
    let mut out = Vec::with_capacity(names.len());
    crate::source::for_channel_groups(&input.file, &file, &layout, &idx, |first, group| {
        estimate_sources(
            group,
            &names[first..],
            rate_hz,
            config,
            &file,
            &pb,
            &mut out,
        )
    })?;
    pb.finish_and_clear();
    Ok(out)
}
