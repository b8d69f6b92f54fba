//! Config writers: the noise values of an analysis (`results.json`) in the files that
//! visual-inertial estimators read — Kalibr `imu.yaml`, OpenVINS `kalibr_imu_chain.yaml`,
//! ORB-SLAM3 settings, VINS-Fusion and Basalt.
//!
//! Conventions (every file repeats them in comments):
//! - All values are continuous-time densities in SI units (ROS REP 103): white noise
//!   N in rad/s/√Hz and m/s²/√Hz, bias random walk K in rad/s²/√Hz and m/s³/√Hz.
//!   Channels in °/s or g are converted.
//! - N, K and B are the analysis's own (`fit.noise_terms` in results.json, the values its
//!   report and console show): N from every short-memory term of the fitted model (WN and
//!   fast AR1/GM/MA1 as white-noise equivalents), K = √(γ²_RW · f), B from a bias-instability
//!   term; where the model lacks the term, the IEEE 952 read-off, else an upper bound. Each
//!   file says which. A results.json without `noise_terms` (older versions) gives
//!   N = √(σ²_WN / f) and K = √(γ²_RW · f) from the fitted WN and RW, else the read-off.
//! - A fit whose model does not describe its Allan variance (`fit.adequacy`) is named in a
//!   WARNING line at the top of every file.
//! - One value per sensor is the aggregate over its axes (`max`, `rms` or `mean`; default
//!   max), except Basalt, which takes one value per axis.
//! - Discrete equivalents at the file's rate: σ_d = N·√f (white), σ_bd = K/√f (walk).
//! - `--inflate-noise F` multiplies N, `--inflate-walk F` multiplies K (default 1).
//! - The bias instability B (σ_min / 0.6643 of the Allan deviation) and any fitted
//!   Gauss-Markov/AR1 term are listed, with a note that these estimators' models have no
//!   such term.

use crate::error::{Error, Result};
use processes::Unit;
use serde_json::Value;
use std::fmt::Write as _;

/// √(2 ln 2 / π): the flat floor of the Allan deviation per unit of bias instability.
pub const BIAS_INSTABILITY_FACTOR: f64 = 0.664_282_470_2;

/// How one value per sensor is made from its axes (`--aggregate`).
///
/// ```
/// use clap::ValueEnum;
/// use imunoise::export::{Aggregate, ExportOptions};
/// assert_eq!(ExportOptions::default().aggregate, Aggregate::Max);
/// assert_eq!(Aggregate::from_str("rms", false), Ok(Aggregate::Rms));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Aggregate {
    /// The largest axis (conservative; what Kalibr users are told to take).
    #[default]
    Max,
    /// Root mean square over the axes.
    Rms,
    /// Arithmetic mean over the axes.
    Mean,
}

impl Aggregate {
    /// Applies the aggregate to `v` (non-empty).
    ///
    /// ```
    /// use imunoise::export::Aggregate;
    /// assert_eq!(Aggregate::Max.apply(&[1.0, 3.0]), 3.0);
    /// assert_eq!(Aggregate::Mean.apply(&[1.0, 3.0]), 2.0);
    /// assert_eq!(Aggregate::Rms.apply(&[3.0, 4.0]), 12.5f64.sqrt());
    /// ```
    pub fn apply(self, v: &[f64]) -> f64 {
        let n = v.len() as f64;
        match self {
            Aggregate::Max => v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            Aggregate::Mean => v.iter().sum::<f64>() / n,
            Aggregate::Rms => (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
        }
    }

    fn name(self) -> &'static str {
        match self {
            Aggregate::Max => "max",
            Aggregate::Rms => "rms",
            Aggregate::Mean => "mean",
        }
    }
}

/// A config file format.
///
/// ```
/// use imunoise::export::Target;
/// assert_eq!(Target::parse_list("openvins")?, [Target::Openvins]);
/// assert_eq!(Target::Openvins.file_name(), "kalibr_imu_chain.yaml");
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Target {
    /// Kalibr `imu.yaml`.
    Kalibr,
    /// OpenVINS `kalibr_imu_chain.yaml` (`imu0:` block).
    Openvins,
    /// ORB-SLAM3 settings (`IMU.NoiseGyro`, …).
    Orbslam3,
    /// VINS-Fusion / VINS-Mono (`acc_n`, `gyr_n`, `acc_w`, `gyr_w`).
    Vins,
    /// Basalt calibration (per-axis `accel_noise_std`, …), JSON.
    Basalt,
}

impl Target {
    /// All targets.
    pub const ALL: [Target; 5] = [
        Target::Kalibr,
        Target::Openvins,
        Target::Orbslam3,
        Target::Vins,
        Target::Basalt,
    ];

    /// The file name written for this target.
    ///
    /// ```
    /// use imunoise::export::Target;
    /// assert_eq!(Target::Kalibr.file_name(), "imu.yaml");
    /// assert_eq!(Target::Basalt.file_name(), "basalt_imu.json");
    /// // every target has a file of its own
    /// let mut names: Vec<&str> = Target::ALL.iter().map(|t| t.file_name()).collect();
    /// names.sort();
    /// names.dedup();
    /// assert_eq!(names.len(), Target::ALL.len());
    /// ```
    pub fn file_name(self) -> &'static str {
        match self {
            Target::Kalibr => "imu.yaml",
            Target::Openvins => "kalibr_imu_chain.yaml",
            Target::Orbslam3 => "orbslam3_imu.yaml",
            Target::Vins => "vins_imu.yaml",
            Target::Basalt => "basalt_imu.json",
        }
    }

    /// Parses a comma list of targets; `all` means every one.
    ///
    /// ```
    /// use imunoise::export::Target;
    /// assert_eq!(Target::parse_list("kalibr,vins").unwrap(), [Target::Kalibr, Target::Vins]);
    /// assert_eq!(Target::parse_list("all").unwrap().len(), 5);
    /// ```
    pub fn parse_list(s: &str) -> Result<Vec<Target>> {
        let mut out = Vec::new();
        for item in s.split(',').map(|t| t.trim().to_ascii_lowercase()) {
            let t = match item.as_str() {
                "all" => {
                    out.extend(Target::ALL);
                    continue;
                }
                "kalibr" => Target::Kalibr,
                "openvins" | "ov" => Target::Openvins,
                "orbslam3" | "orb-slam3" | "orbslam" => Target::Orbslam3,
                "vins" | "vins-fusion" | "vins-mono" | "vinsfusion" => Target::Vins,
                "basalt" => Target::Basalt,
                _ => {
                    return Err(Error::Usage(format!(
                        "unknown export target {item:?}; expected kalibr, openvins, orbslam3, vins, basalt or all"
                    )));
                }
            };
            if !out.contains(&t) {
                out.push(t);
            }
        }
        Ok(out)
    }
}

/// A finite factor > 0 (`--inflate-noise`, `--inflate-walk`): a number or a fraction `a/b`.
///
/// ```
/// use imunoise::export::parse_inflation;
/// assert_eq!(parse_inflation("2"), Ok(2.0));
/// assert_eq!(parse_inflation("1/2"), Ok(0.5));
/// assert!(parse_inflation("-1").is_err() && parse_inflation("0").is_err());
/// ```
pub fn parse_inflation(s: &str) -> std::result::Result<f64, String> {
    let v = crate::pipeline::read::parse_factor(s)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!(
            "the factor must be > 0 (it multiplies a noise density), got {s}"
        ))
    }
}

/// The options shared by `imunoise export` and `analyze --export`.
///
/// ```
/// use imunoise::export::{Aggregate, ExportOptions};
/// let o = ExportOptions::default();
/// assert_eq!(o.aggregate, Aggregate::Max);
/// assert_eq!((o.inflate_noise, o.inflate_walk), (1.0, 1.0));
/// assert!(o.rostopic.is_none());
/// // a VIO's usual inflation
/// let vio = ExportOptions { inflate_noise: 2.0, inflate_walk: 10.0, ..Default::default() };
/// assert_eq!(vio.aggregate, Aggregate::Max);
/// ```
#[derive(Debug, Clone, clap::Args)]
pub struct ExportOptions {
    /// How one value per sensor is made from its axes (Basalt keeps the axes).
    #[arg(long, value_enum, default_value = "max")]
    pub aggregate: Aggregate,
    /// Multiply the white-noise densities by F > 0 (e.g. 2 for a VIO; default 1).
    #[arg(long, value_name = "F", default_value = "1", value_parser = parse_inflation)]
    pub inflate_noise: f64,
    /// Multiply the random-walk densities by F > 0 (e.g. 10 for a VIO; default 1).
    #[arg(long, value_name = "F", default_value = "1", value_parser = parse_inflation)]
    pub inflate_walk: f64,
    /// The `rostopic` written into Kalibr/OpenVINS files (default: the analysed topic, else /imu0).
    #[arg(long, value_name = "TOPIC")]
    pub rostopic: Option<String>,
}

impl ExportOptions {
    /// Checks the inflation factors: finite and > 0 (a noise density or a standard deviation
    /// cannot be negative or zero).
    ///
    /// ```
    /// use imunoise::export::ExportOptions;
    /// assert!(ExportOptions::default().check().is_ok());
    /// assert!(ExportOptions { inflate_noise: -1.0, ..Default::default() }.check().is_err());
    /// assert!(ExportOptions { inflate_walk: f64::NAN, ..Default::default() }.check().is_err());
    /// ```
    pub fn check(&self) -> Result<()> {
        for (name, f) in [
            ("--inflate-noise", self.inflate_noise),
            ("--inflate-walk", self.inflate_walk),
        ] {
            if !(f.is_finite() && f > 0.0) {
                return Err(Error::Usage(format!(
                    "{name} must be a finite factor > 0, got {f}"
                )));
            }
        }
        Ok(())
    }
}

impl Default for ExportOptions {
    fn default() -> Self {
        ExportOptions {
            aggregate: Aggregate::Max,
            inflate_noise: 1.0,
            inflate_walk: 1.0,
            rostopic: None,
        }
    }
}

/// One axis: its N and K (SI, continuous, before inflation), bias instability and GM term.
///
/// ```
/// use imunoise::export::{BIAS_INSTABILITY_FACTOR, ImuNoise};
/// // one gyro axis in rad/s at 100 Hz: WN, RW and an AR1 (φ = 0.5, innovation σ² = 0.75),
/// // with its Allan deviation (minimum 0.1 at τ = 0.1 s)
/// let doc = serde_json::json!({
///     "rate_hz": 100.0,
///     "channels": [{ "name": "gyro_x", "unit": "rad/s",
///         "avar": [ { "tau": 0.01, "adev": 0.3 }, { "tau": 0.1, "adev": 0.1 },
///                   { "tau": 1.0, "adev": 0.2 } ],
///         "fit": { "model": "WN+RW+AR1", "parameters": [
///             { "process": "WN", "name": "sigma2", "value": 4e-6 },
///             { "process": "RW", "name": "gamma2", "value": 1e-10 },
///             { "process": "AR1", "name": "phi", "value": 0.5 },
///             { "process": "AR1", "name": "sigma2", "value": 0.75 } ] } }]
/// });
/// let ax = &ImuNoise::from_results(&doc, "results.json")?.gyro[0];
/// assert_eq!(ax.name, "gyro_x");
/// assert_eq!(ax.n, Some((4e-6f64 / 100.0).sqrt())); // N = √(σ²/f)
/// assert_eq!(ax.k, Some((1e-10f64 * 100.0).sqrt())); // K = √(γ²·f)
/// assert_eq!(ax.source, "fit WN+RW+AR1");
/// assert_eq!(ax.bias_instability, Some((0.1 / BIAS_INSTABILITY_FACTOR, 0.1)));
/// // the AR1 as a Gauss-Markov bias: stationary σ = √(0.75 / (1 − 0.5²)) = 1, τc = −Δt / ln φ
/// assert_eq!(ax.gauss_markov, [(1.0, -1.0 / (100.0 * 0.5f64.ln()))]);
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct AxisNoise {
    /// Channel name.
    pub name: String,
    /// White-noise density N (rad/s/√Hz or m/s²/√Hz), if estimated.
    pub n: Option<f64>,
    /// Bias random-walk density K (rad/s²/√Hz or m/s³/√Hz), if estimated.
    pub k: Option<f64>,
    /// Where N and K come from (fit or read-off).
    pub source: String,
    /// Bias instability B (rad/s or m/s²) and the τ (s) of the Allan-deviation minimum.
    pub bias_instability: Option<(f64, f64)>,
    /// Fitted Gauss-Markov terms: stationary σ (SI) and correlation time (s).
    pub gauss_markov: Vec<(f64, f64)>,
    /// The fit's verdict when it is not adequate (its reasons), from `fit.adequacy`.
    pub not_adequate: Option<String>,
}

/// The noise of an IMU read from `results.json`: gyroscope and accelerometer axes.
///
/// ```
/// use imunoise::export::{ExportOptions, ImuNoise, Target};
/// // a results.json with a gyro and an accelerometer axis (per-sample values at 100 Hz)
/// let doc = serde_json::json!({
///     "source": "imu.csv",
///     "rate_hz": 100.0,
///     "channels": [
///         { "name": "gyro_x", "unit": "rad/s", "fit": { "model": "WN+RW", "parameters": [
///             { "process": "WN", "name": "sigma2", "value": 4e-6 },
///             { "process": "RW", "name": "gamma2", "value": 1e-10 } ] } },
///         { "name": "acc_x", "unit": "m/s^2", "fit": { "model": "WN", "parameters": [
///             { "process": "WN", "name": "sigma2", "value": 1e-4 } ] } }
///     ]
/// });
/// let noise = ImuNoise::from_results(&doc, "results.json")?;
/// assert_eq!((noise.source.as_str(), noise.rate_hz), ("imu.csv", 100.0));
/// assert_eq!(noise.gyro.len(), 1);
/// assert_eq!(noise.acc[0].name, "acc_x");
/// assert!(noise.topic.is_none() && noise.skipped.is_empty());
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct ImuNoise {
    /// Source of the data.
    pub source: String,
    /// Topic, for logs.
    pub topic: Option<String>,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Gyroscope axes in channel order.
    pub gyro: Vec<AxisNoise>,
    /// Accelerometer axes in channel order.
    pub acc: Vec<AxisNoise>,
    /// Channels left out (unknown unit or sensor) with the reason.
    pub skipped: Vec<String>,
}

fn get_f64(v: &Value, key: &str) -> Option<f64> {
    v.get(key).and_then(Value::as_f64)
}

impl ImuNoise {
    /// Reads `results.json` (as written by `imunoise analyze`).
    ///
    /// ```
    /// use imunoise::export::{ExportOptions, ImuNoise, Target};
    /// // a results.json with a gyro and an accelerometer axis (per-sample values at 100 Hz)
    /// let doc = serde_json::json!({
    ///     "source": "imu.csv",
    ///     "rate_hz": 100.0,
    ///     "channels": [
    ///         { "name": "gyro_x", "unit": "rad/s", "fit": { "model": "WN+RW", "parameters": [
    ///             { "process": "WN", "name": "sigma2", "value": 4e-6 },
    ///             { "process": "RW", "name": "gamma2", "value": 1e-10 } ] } },
    ///         { "name": "acc_x", "unit": "m/s^2", "fit": { "model": "WN", "parameters": [
    ///             { "process": "WN", "name": "sigma2", "value": 1e-4 } ] } }
    ///     ]
    /// });
    /// let noise = ImuNoise::from_results(&doc, "results.json")?;
    /// // N = √(σ²/f) and K = √(γ²·f), in SI units already
    /// assert_eq!(noise.gyro[0].n, Some((4e-6f64 / 100.0).sqrt()));
    /// assert_eq!(noise.gyro[0].k, Some((1e-10f64 * 100.0).sqrt()));
    /// // no RW and no curve to read K off: not estimated
    /// assert_eq!(noise.acc[0].k, None);
    /// // °/s is converted to rad/s; a channel of another unit is left out
    /// let doc = serde_json::json!({ "rate_hz": 100.0, "channels": [
    ///     { "name": "gx", "unit": "deg/s", "fit": { "parameters": [
    ///         { "process": "WN", "name": "sigma2", "value": 4e-6 } ] } },
    ///     { "name": "temp", "unit": "none" } ] });
    /// let noise = ImuNoise::from_results(&doc, "results.json")?;
    /// let to_rad = std::f64::consts::PI / 180.0;
    /// assert_eq!(noise.gyro[0].n, Some((4e-6f64 / 100.0).sqrt() * to_rad));
    /// assert!(noise.skipped[0].starts_with("temp: unit"));
    /// // not a results.json
    /// assert!(ImuNoise::from_results(&serde_json::json!({}), "x.json").is_err());
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn from_results(doc: &Value, file: &str) -> Result<Self> {
        let bad = |m: String| Error::File {
            file: file.to_string(),
            message: m,
        };
        let rate = get_f64(doc, "rate_hz")
            .filter(|r| *r > 0.0)
            .ok_or_else(|| bad("no rate_hz: not a results.json of imunoise analyze".into()))?;
        let chans = doc
            .get("channels")
            .and_then(Value::as_array)
            .ok_or_else(|| bad("no channels: not a results.json of imunoise analyze".into()))?;
        let mut out = ImuNoise {
            source: doc
                .get("source")
                .and_then(Value::as_str)
                .unwrap_or("?")
                .to_string(),
            topic: doc.get("topic").and_then(Value::as_str).map(String::from),
            rate_hz: rate,
            gyro: Vec::new(),
            acc: Vec::new(),
            skipped: Vec::new(),
        };
        for c in chans {
            let name = c
                .get("name")
                .and_then(Value::as_str)
                .unwrap_or("?")
                .to_string();
            let unit: Unit = match c.get("unit").and_then(Value::as_str).map(str::parse) {
                Some(Ok(u)) => u,
                _ => {
                    out.skipped.push(format!("{name}: unknown unit"));
                    continue;
                }
            };
            let to_si = match unit {
                Unit::DegPerSec => std::f64::consts::PI / 180.0,
                Unit::G => gmwm_prep::units::STANDARD_GRAVITY,
                Unit::RadPerSec | Unit::MetrePerSec2 => 1.0,
                _ => {
                    let u = match unit.symbol() {
                        "" => "none".to_string(),
                        s => format!("{s:?}"),
                    };
                    out.skipped.push(format!(
                        "{name}: unit {u} is neither an angular rate nor an acceleration (give --unit to analyze)"
                    ));
                    continue;
                }
            };
            let fit = c.get("fit").ok_or_else(|| bad(format!("{name}: no fit")))?;
            let params: Vec<(String, String, f64)> = fit
                .get("parameters")
                .and_then(Value::as_array)
                .map(|ps| {
                    ps.iter()
                        .filter_map(|p| {
                            Some((
                                p.get("process")?.as_str()?.to_string(),
                                p.get("name")?.as_str()?.to_string(),
                                p.get("value")?.as_f64()?,
                            ))
                        })
                        .collect()
                })
                .unwrap_or_default();
            let param = |proc_: &str, pname: &str| {
                params
                    .iter()
                    .find(|(p, n, _)| p == proc_ && n == pname)
                    .map(|t| t.2)
            };
            let mut n = param("WN", "sigma2").map(|s2| (s2 / rate).sqrt() * to_si);
            let mut k = param("RW", "gamma2").map(|g2| (g2 * rate).sqrt() * to_si);
            let mut source = format!(
                "fit {}",
                fit.get("model").and_then(Value::as_str).unwrap_or("?")
            );
            let points: Vec<(f64, f64)> = c
                .get("avar")
                .and_then(Value::as_array)
                .map(|ps| {
                    ps.iter()
                        .filter_map(|p| Some((get_f64(p, "tau")?, get_f64(p, "adev")?)))
                        .collect()
                })
                .unwrap_or_default();
            // N, K, B of the analysis itself (`fit.noise_terms`, the one source the report and
            // the console show); results.json files written before it had them are read as
            // before
            let terms = fit.get("noise_terms");
            let term = |sym: &str| {
                let t = terms?.get(sym)?;
                Some((
                    get_f64(t, "per_second")?,
                    t.get("source")?.as_str()?.to_string(),
                    t.get("basis")?.as_str()?.to_string(),
                ))
            };
            let mut from_terms = Vec::new();
            for (sym, slot) in [("n", &mut n), ("k", &mut k)] {
                if let Some((v, _source, basis)) = term(sym) {
                    *slot = Some(v * to_si); // the basis says when it is a bound
                    from_terms.push(format!("{} from {basis}", sym.to_uppercase()));
                }
            }
            if !from_terms.is_empty() {
                source.push_str("; ");
                source.push_str(&from_terms.join("; "));
            }
            if n.is_none() || k.is_none() {
                let (taus, adevs): (Vec<f64>, Vec<f64>) = points.iter().copied().unzip();
                if let Ok(ro) = gmwm_prep::ieee::read_off_adev(&taus, &adevs, &unit) {
                    use gmwm_prep::units::IeeeTerm;
                    if n.is_none()
                        && let Some(e) = ro.get(IeeeTerm::N)
                    {
                        n = Some(e.value * to_si);
                        source.push_str("; N from the IEEE 952 read-off (no WN in the model)");
                    }
                    if k.is_none()
                        && let Some(e) = ro.get(IeeeTerm::K)
                    {
                        k = Some(e.value * to_si);
                        source.push_str("; K from the IEEE 952 read-off (no RW in the model)");
                    }
                }
            }
            let minimum = points
                .iter()
                .copied()
                .filter(|p| p.1.is_finite())
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let bias_instability = match (term("b"), minimum) {
                (Some((b, _, _)), Some((tau, _))) => Some((b * to_si, tau)),
                (_, m) => m.map(|(tau, adev)| (adev / BIAS_INSTABILITY_FACTOR * to_si, tau)),
            };
            let not_adequate = fit
                .get("adequacy")
                .filter(|a| a.get("adequate").and_then(Value::as_bool) == Some(false))
                .map(|a| {
                    a.get("reasons")
                        .and_then(Value::as_array)
                        .and_then(|r| r.first())
                        .and_then(Value::as_str)
                        .unwrap_or("the fit is not adequate")
                        .to_string()
                });
            // AR1 (φ, innovation σ²): stationary σ² / (1 − φ²), τc = −Δt / ln φ (φ in (0, 1)).
            // GM (β in 1/s, stationary σ²): τc = 1/β.
            let of = |proc_: &str, pname: &str| -> Vec<f64> {
                params
                    .iter()
                    .filter(|p| p.0 == proc_ && p.1 == pname)
                    .map(|p| p.2)
                    .collect()
            };
            let mut gauss_markov: Vec<(f64, f64)> = of("AR1", "phi")
                .into_iter()
                .zip(of("AR1", "sigma2"))
                .filter(|(phi, _)| *phi > 0.0 && *phi < 1.0)
                .map(|(phi, s2)| {
                    (
                        (s2 / (1.0 - phi * phi)).sqrt() * to_si,
                        -1.0 / (rate * phi.ln()),
                    )
                })
                .collect();
            gauss_markov.extend(
                of("GM", "beta")
                    .into_iter()
                    .zip(of("GM", "sigma2"))
                    .map(|(beta, s2)| (s2.sqrt() * to_si, 1.0 / beta)),
            );
            let axis = AxisNoise {
                name: name.clone(),
                n,
                k,
                source,
                bias_instability,
                gauss_markov,
                not_adequate,
            };
            if unit.is_angular_rate() {
                out.gyro.push(axis);
            } else {
                out.acc.push(axis);
            }
        }
        Ok(out)
    }
}

/// A number in the shortest form that reads back to the same f64, always with a decimal
/// point (OpenCV's YAML reader takes `1e-05` for a string).
///
/// ```
/// assert_eq!(imunoise::export::num(1e-5), "1.0e-5");
/// assert_eq!(imunoise::export::num(7.25e-4), "7.25e-4");
/// ```
pub fn num(x: f64) -> String {
    let s = format!("{x:e}");
    match s.find('e') {
        Some(i) if !s[..i].contains('.') => format!("{}.0{}", &s[..i], &s[i..]),
        _ => s,
    }
}

/// A rate with a decimal point (ORB-SLAM3 wants a real).
fn rate_str(r: f64) -> String {
    let s = format!("{r}");
    if s.contains('.') { s } else { format!("{s}.0") }
}

/// The four aggregated numbers (after inflation): gyro N, gyro K, acc N, acc K.
///
/// ```
/// # use imunoise::export::{ExportOptions, ImuNoise, Target};
/// # // a results.json with a gyro and an accelerometer axis (per-sample values at 100 Hz)
/// # let doc = serde_json::json!({
/// #     "source": "imu.csv",
/// #     "rate_hz": 100.0,
/// #     "channels": [
/// #         { "name": "gyro_x", "unit": "rad/s", "fit": { "model": "WN+RW", "parameters": [
/// #             { "process": "WN", "name": "sigma2", "value": 4e-6 },
/// #             { "process": "RW", "name": "gamma2", "value": 1e-10 } ] } },
/// #         { "name": "acc_x", "unit": "m/s^2", "fit": { "model": "WN", "parameters": [
/// #             { "process": "WN", "name": "sigma2", "value": 1e-4 } ] } }
/// #     ]
/// # });
/// // `noise`: at 100 Hz, a gyro axis with WN σ² = 4e-6 and RW γ² = 1e-10, an accelerometer
/// // axis with WN σ² = 1e-4
/// let noise = ImuNoise::from_results(&doc, "results.json")?;
/// let a = noise.aggregate(&ExportOptions::default());
/// assert_eq!(a.gyro_n, noise.gyro[0].n);
/// assert_eq!(a.acc_n, noise.acc[0].n);
/// assert_eq!(a.acc_k, None); // no accelerometer random walk
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aggregated {
    /// Gyroscope white-noise density (rad/s/√Hz).
    pub gyro_n: Option<f64>,
    /// Gyroscope random-walk density (rad/s²/√Hz).
    pub gyro_k: Option<f64>,
    /// Accelerometer white-noise density (m/s²/√Hz).
    pub acc_n: Option<f64>,
    /// Accelerometer random-walk density (m/s³/√Hz).
    pub acc_k: Option<f64>,
}

impl ImuNoise {
    /// Aggregates each sensor's axes and applies the inflation factors.
    ///
    /// ```
    /// use imunoise::export::{Aggregate, ExportOptions, ImuNoise};
    /// // two gyro axes with N = √(σ²/f) = 1e-3 and 2e-3 (σ² = 1e-4 and 4e-4 at 100 Hz)
    /// let doc = serde_json::json!({ "rate_hz": 100.0, "channels": [
    ///     { "name": "gx", "unit": "rad/s", "fit": { "parameters": [
    ///         { "process": "WN", "name": "sigma2", "value": 1e-4 } ] } },
    ///     { "name": "gy", "unit": "rad/s", "fit": { "parameters": [
    ///         { "process": "WN", "name": "sigma2", "value": 4e-4 } ] } } ] });
    /// let noise = ImuNoise::from_results(&doc, "results.json")?;
    /// let (n1, n2) = (noise.gyro[0].n.unwrap(), noise.gyro[1].n.unwrap());
    /// let max = noise.aggregate(&ExportOptions::default());
    /// assert_eq!(max.gyro_n, Some(n2));
    /// let o = ExportOptions {
    ///     aggregate: Aggregate::Mean,
    ///     inflate_noise: 2.0,
    ///     ..Default::default()
    /// };
    /// assert_eq!(noise.aggregate(&o).gyro_n, Some((n1 + n2) / 2.0 * 2.0));
    /// assert_eq!(max.acc_n, None); // no accelerometer
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn aggregate(&self, o: &ExportOptions) -> Aggregated {
        let agg = |axes: &[AxisNoise], f: fn(&AxisNoise) -> Option<f64>, infl: f64| {
            let v: Vec<f64> = axes.iter().filter_map(f).collect();
            (!v.is_empty()).then(|| o.aggregate.apply(&v) * infl)
        };
        Aggregated {
            gyro_n: agg(&self.gyro, |a| a.n, o.inflate_noise),
            gyro_k: agg(&self.gyro, |a| a.k, o.inflate_walk),
            acc_n: agg(&self.acc, |a| a.n, o.inflate_noise),
            acc_k: agg(&self.acc, |a| a.k, o.inflate_walk),
        }
    }

    /// The comment block every file starts with (`prefix` is `# ` for YAML).
    fn comments(&self, o: &ExportOptions, target: Target, prefix: &str) -> String {
        let f = self.rate_hz;
        let a = self.aggregate(o);
        let mut s = String::new();
        let mut line = |t: String| {
            let _ = writeln!(s, "{prefix}{t}");
        };
        line(format!(
            "IMU noise for {} written by imunoise {} from {}{}",
            match target {
                Target::Kalibr => "Kalibr (imu.yaml)",
                Target::Openvins => "OpenVINS (kalibr_imu_chain.yaml)",
                Target::Orbslam3 => "ORB-SLAM3 (settings file; paste the IMU.* keys)",
                Target::Vins => "VINS-Fusion / VINS-Mono (paste into the config)",
                Target::Basalt => "Basalt (calibration: accel/gyro noise and bias std)",
            },
            env!("CARGO_PKG_VERSION"),
            self.source,
            self.topic
                .as_deref()
                .map_or(String::new(), |t| format!(", topic {t}"))
        ));
        line("time convention: continuous-time densities (white noise N, bias random walk K), as in Kalibr's IMU noise model".into());
        line("units (SI, ROS REP 103): gyroscope N rad/s/sqrt(Hz), K rad/s^2/sqrt(Hz); accelerometer N m/s^2/sqrt(Hz), K m/s^3/sqrt(Hz)".into());
        line(format!("rate: {} Hz", rate_str(f)));
        for ax in self.gyro.iter().chain(&self.acc) {
            if let Some(why) = &ax.not_adequate {
                line(format!(
                    "WARNING: {}: the fitted model does not describe its Allan variance ({why}); its N and K below are the best this model gives, not a validated noise model",
                    ax.name
                ));
            }
        }
        line("per-axis values (before inflation):".into());
        for ax in self.gyro.iter().chain(&self.acc) {
            line(format!(
                "  {}: N = {}, K = {}  ({})",
                ax.name,
                ax.n.map_or("-".into(), num),
                ax.k.map_or("-".into(), num),
                ax.source
            ));
        }
        for sk in &self.skipped {
            line(format!("  left out: {sk}"));
        }
        if target == Target::Basalt {
            line(
                "aggregate: none (Basalt takes one value per axis, in channel order x, y, z)"
                    .into(),
            );
        } else {
            line(format!(
                "aggregate over axes: {} (--aggregate max|rms|mean)",
                o.aggregate.name()
            ));
        }
        line(format!(
            "inflation: white noise x{}, random walk x{} (--inflate-noise, --inflate-walk); the values below include it",
            o.inflate_noise, o.inflate_walk
        ));
        line(format!(
            "discrete equivalents at {} Hz (white sigma_d = N*sqrt(f), walk sigma_bd = K/sqrt(f)), after inflation:",
            rate_str(f)
        ));
        let sf = f.sqrt();
        for (what, n, k) in [
            ("gyroscope", a.gyro_n, a.gyro_k),
            ("accelerometer", a.acc_n, a.acc_k),
        ] {
            line(format!(
                "  {what}: sigma_d = {}, sigma_bd = {}",
                n.map_or("-".into(), |n| num(n * sf)),
                k.map_or("-".into(), |k| num(k / sf))
            ));
        }
        line("not representable in this estimator's model (it has white noise and a random-walk bias only):".into());
        let units = self
            .gyro
            .iter()
            .map(|a| (a, "rad/s"))
            .chain(self.acc.iter().map(|a| (a, "m/s^2")));
        for (ax, unit) in units {
            if let Some((b, tau)) = ax.bias_instability {
                line(format!(
                    "  {}: bias instability B = {} {unit} (Allan deviation minimum / 0.6643, at tau = {tau} s)",
                    ax.name,
                    num(b),
                ));
            }
            for (sig, tc) in &ax.gauss_markov {
                line(format!(
                    "  {}: Gauss-Markov bias sigma = {} {unit}, correlation time = {} s",
                    ax.name,
                    num(*sig),
                    num(*tc)
                ));
            }
        }
        match target {
            Target::Orbslam3 => line("ORB-SLAM3 multiplies the noises by sqrt(IMU.Frequency) and divides the walks by it: IMU.Frequency must be the true rate".into()),
            Target::Vins => line("VINS's comments call these \"standard deviation\"; whether continuous or discrete is disputed (VINS-Mono #102, #125, #167, #327). These are the continuous-time densities, as Kalibr's; the discrete ones are above".into()),
            Target::Basalt => line("Basalt: converters copy Kalibr's continuous-time values one to one; not verified in Basalt's source".into()),
            _ => {}
        }
        s
    }

    /// The text of one config file.
    ///
    /// ```
    /// # use imunoise::export::{ExportOptions, ImuNoise, Target};
    /// # // a results.json with a gyro and an accelerometer axis (per-sample values at 100 Hz)
    /// # let doc = serde_json::json!({
    /// #     "source": "imu.csv",
    /// #     "rate_hz": 100.0,
    /// #     "channels": [
    /// #         { "name": "gyro_x", "unit": "rad/s", "fit": { "model": "WN+RW", "parameters": [
    /// #             { "process": "WN", "name": "sigma2", "value": 4e-6 },
    /// #             { "process": "RW", "name": "gamma2", "value": 1e-10 } ] } },
    /// #         { "name": "acc_x", "unit": "m/s^2", "fit": { "model": "WN", "parameters": [
    /// #             { "process": "WN", "name": "sigma2", "value": 1e-4 } ] } }
    /// #     ]
    /// # });
    /// // `noise`: at 100 Hz, a gyro axis with WN σ² = 4e-6 and RW γ² = 1e-10, an accelerometer
    /// // axis with WN σ² = 1e-4
    /// let noise = ImuNoise::from_results(&doc, "results.json")?;
    /// use imunoise::export::num;
    /// let o = ExportOptions::default();
    /// let (n, k) = (noise.gyro[0].n.unwrap(), noise.gyro[0].k.unwrap());
    /// let kalibr = noise.render(Target::Kalibr, &o);
    /// assert!(kalibr.contains(&format!("gyroscope_noise_density: {}", num(n))));
    /// assert!(kalibr.contains(&format!("gyroscope_random_walk: {}", num(k))));
    /// assert!(kalibr.contains("rostopic: /imu0\nupdate_rate: 100.0"));
    /// assert!(kalibr.contains("# accelerometer_random_walk: not estimated"));
    /// let vins = noise.render(Target::Vins, &ExportOptions { inflate_noise: 2.0, ..o.clone() });
    /// assert!(vins.contains(&format!("gyr_n: {}", num(2.0 * n))));
    /// // Basalt's file is JSON, one value per axis of three
    /// let basalt: serde_json::Value =
    ///     serde_json::from_str(&noise.render(Target::Basalt, &o)).unwrap();
    /// assert_eq!(basalt["imu_update_rate"], 100.0);
    /// assert!(basalt["gyro_noise_std"].is_null()); // one gyro axis, not three
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn render(&self, target: Target, o: &ExportOptions) -> String {
        let a = self.aggregate(o);
        let topic = o
            .rostopic
            .clone()
            .or_else(|| self.topic.clone())
            .unwrap_or_else(|| "/imu0".to_string());
        let kv = |key: &str, v: Option<f64>, indent: &str, unit: &str| match v {
            Some(x) => format!("{indent}{key}: {}   # [{unit}]\n", num(x)),
            None => format!("{indent}# {key}: not estimated (no such channel or term)\n"),
        };
        let f = rate_str(self.rate_hz);
        match target {
            Target::Kalibr => {
                let mut s = self.comments(o, target, "# ");
                let _ = writeln!(s, "rostopic: {topic}");
                let _ = writeln!(s, "update_rate: {f}   # [Hz]");
                s += &kv("accelerometer_noise_density", a.acc_n, "", "m/s^2/sqrt(Hz)");
                s += &kv("accelerometer_random_walk", a.acc_k, "", "m/s^3/sqrt(Hz)");
                s += &kv("gyroscope_noise_density", a.gyro_n, "", "rad/s/sqrt(Hz)");
                s += &kv("gyroscope_random_walk", a.gyro_k, "", "rad/s^2/sqrt(Hz)");
                s
            }
            Target::Openvins => {
                let mut s = String::from("%YAML:1.0\n");
                s += &self.comments(o, target, "# ");
                s += "# intrinsics (Tw, Ta, Tg, R_IMUtoGYRO, R_IMUtoACC) are not estimated by imunoise: identity/zero = none\n";
                s += "imu0:\n  T_i_b:\n";
                for r in 0..4 {
                    let row: Vec<&str> =
                        (0..4).map(|c| if r == c { "1.0" } else { "0.0" }).collect();
                    let _ = writeln!(s, "    - [{}]", row.join(", "));
                }
                s += &kv(
                    "accelerometer_noise_density",
                    a.acc_n,
                    "  ",
                    "m/s^2/sqrt(Hz)",
                );
                s += &kv("accelerometer_random_walk", a.acc_k, "  ", "m/s^3/sqrt(Hz)");
                s += &kv("gyroscope_noise_density", a.gyro_n, "  ", "rad/s/sqrt(Hz)");
                s += &kv("gyroscope_random_walk", a.gyro_k, "  ", "rad/s^2/sqrt(Hz)");
                let _ = writeln!(s, "  rostopic: {topic}");
                s += "  time_offset: 0.0\n";
                let _ = writeln!(s, "  update_rate: {f}");
                s += "  model: \"kalibr\"\n";
                let id = "    - [1.0, 0.0, 0.0]\n    - [0.0, 1.0, 0.0]\n    - [0.0, 0.0, 1.0]\n";
                for key in ["Tw", "R_IMUtoGYRO", "Ta", "R_IMUtoACC"] {
                    let _ = write!(s, "  {key}:\n{id}");
                }
                s += "  Tg:\n    - [0.0, 0.0, 0.0]\n    - [0.0, 0.0, 0.0]\n    - [0.0, 0.0, 0.0]\n";
                s
            }
            Target::Orbslam3 => {
                let mut s = String::from("%YAML:1.0\n");
                s += &self.comments(o, target, "# ");
                s += &kv("IMU.NoiseGyro", a.gyro_n, "", "rad/s/sqrt(Hz)");
                s += &kv("IMU.NoiseAcc", a.acc_n, "", "m/s^2/sqrt(Hz)");
                s += &kv("IMU.GyroWalk", a.gyro_k, "", "rad/s^2/sqrt(Hz)");
                s += &kv("IMU.AccWalk", a.acc_k, "", "m/s^3/sqrt(Hz)");
                let _ = writeln!(s, "IMU.Frequency: {f}   # [Hz]");
                s
            }
            Target::Vins => {
                let mut s = String::from("%YAML:1.0\n");
                s += &self.comments(o, target, "# ");
                s += &kv("acc_n", a.acc_n, "", "m/s^2/sqrt(Hz)");
                s += &kv("gyr_n", a.gyro_n, "", "rad/s/sqrt(Hz)");
                s += &kv("acc_w", a.acc_k, "", "m/s^3/sqrt(Hz)");
                s += &kv("gyr_w", a.gyro_k, "", "rad/s^2/sqrt(Hz)");
                s += "g_norm: 9.80665   # [m/s^2] standard gravity: replace with the local value\n";
                s
            }
            Target::Basalt => {
                // JSON has no comments: they go into a list of strings.
                let mut notes: Vec<String> = self
                    .comments(o, target, "")
                    .lines()
                    .map(String::from)
                    .collect();
                for (what, v) in [("gyroscope", &self.gyro), ("accelerometer", &self.acc)] {
                    if v.len() != 3 || v.iter().any(|a| a.n.is_none() || a.k.is_none()) {
                        notes.push(format!(
                            "{what}: Basalt needs N and K on 3 axes; {} axes with both found, so its values are null",
                            v.iter().filter(|a| a.n.is_some() && a.k.is_some()).count()
                        ));
                    }
                }
                let axes =
                    |v: &[AxisNoise], f: fn(&AxisNoise) -> Option<f64>, infl: f64| -> Value {
                        let xs: Vec<Option<f64>> = v.iter().map(f).collect();
                        if xs.len() == 3 && xs.iter().all(Option::is_some) {
                            Value::from(
                                xs.iter()
                                    .map(|x| x.unwrap_or(0.0) * infl)
                                    .collect::<Vec<_>>(),
                            )
                        } else {
                            Value::Null
                        }
                    };
                let doc = serde_json::json!({
                    "imunoise_notes": notes,
                    "accel_noise_std": axes(&self.acc, |a| a.n, o.inflate_noise),
                    "gyro_noise_std": axes(&self.gyro, |a| a.n, o.inflate_noise),
                    "accel_bias_std": axes(&self.acc, |a| a.k, o.inflate_walk),
                    "gyro_bias_std": axes(&self.gyro, |a| a.k, o.inflate_walk),
                    "imu_update_rate": self.rate_hz,
                });
                serde_json::to_string_pretty(&doc).unwrap_or_default() + "\n"
            }
        }
    }
}

/// Writes the files of `targets` into `dir`; returns their paths.
///
/// ```
/// # use imunoise::export::{ExportOptions, ImuNoise, Target};
/// # // a results.json with a gyro and an accelerometer axis (per-sample values at 100 Hz)
/// # let doc = serde_json::json!({
/// #     "source": "imu.csv",
/// #     "rate_hz": 100.0,
/// #     "channels": [
/// #         { "name": "gyro_x", "unit": "rad/s", "fit": { "model": "WN+RW", "parameters": [
/// #             { "process": "WN", "name": "sigma2", "value": 4e-6 },
/// #             { "process": "RW", "name": "gamma2", "value": 1e-10 } ] } },
/// #         { "name": "acc_x", "unit": "m/s^2", "fit": { "model": "WN", "parameters": [
/// #             { "process": "WN", "name": "sigma2", "value": 1e-4 } ] } }
/// #     ]
/// # });
/// // `noise`: at 100 Hz, a gyro axis with WN σ² = 4e-6 and RW γ² = 1e-10, an accelerometer
/// // axis with WN σ² = 1e-4
/// let noise = ImuNoise::from_results(&doc, "results.json")?;
/// let dir = tempfile::tempdir().unwrap();
/// let o = ExportOptions::default();
/// let targets = [Target::Kalibr, Target::Vins];
/// let paths = imunoise::export::write_all(&noise, &targets, &o, dir.path())?;
/// assert_eq!(paths, [dir.path().join("imu.yaml"), dir.path().join("vins_imu.yaml")]);
/// assert_eq!(std::fs::read_to_string(&paths[1]).unwrap(), noise.render(Target::Vins, &o));
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn write_all(
    noise: &ImuNoise,
    targets: &[Target],
    o: &ExportOptions,
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>> {
    o.check()?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir.display().to_string(), e))?;
    targets
        .iter()
        .map(|&t| {
            let p = dir.join(t.file_name());
            std::fs::write(&p, noise.render(t, o))
                .map_err(|e| Error::io(p.display().to_string(), e))?;
            Ok(p)
        })
        .collect()
}

/// Reads a results.json (or DIR/results.json) into an [`ImuNoise`].
///
/// ```
/// use imunoise::export::{ExportOptions, ImuNoise, Target};
/// // a results.json with a gyro and an accelerometer axis (per-sample values at 100 Hz)
/// let doc = serde_json::json!({
///     "source": "imu.csv",
///     "rate_hz": 100.0,
///     "channels": [
///         { "name": "gyro_x", "unit": "rad/s", "fit": { "model": "WN+RW", "parameters": [
///             { "process": "WN", "name": "sigma2", "value": 4e-6 },
///             { "process": "RW", "name": "gamma2", "value": 1e-10 } ] } },
///         { "name": "acc_x", "unit": "m/s^2", "fit": { "model": "WN", "parameters": [
///             { "process": "WN", "name": "sigma2", "value": 1e-4 } ] } }
///     ]
/// });
/// let dir = tempfile::tempdir().unwrap();
/// std::fs::write(dir.path().join("results.json"), doc.to_string()).unwrap();
/// // the folder of a report, or the file itself
/// let noise = imunoise::export::load(dir.path())?;
/// assert_eq!(noise, imunoise::export::load(&dir.path().join("results.json"))?);
/// assert_eq!(noise, ImuNoise::from_results(&doc, "results.json")?);
/// assert!(imunoise::export::load(&dir.path().join("missing.json")).is_err());
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn load(path: &std::path::Path) -> Result<ImuNoise> {
    let p = if path.is_dir() {
        path.join("results.json")
    } else {
        path.to_path_buf()
    };
    let file = p.display().to_string();
    let text = std::fs::read_to_string(&p).map_err(|e| Error::io(&file, e))?;
    let doc: serde_json::Value = serde_json::from_str(&text).map_err(|e| Error::File {
        file: file.clone(),
        message: format!("not JSON: {e}"),
    })?;
    ImuNoise::from_results(&doc, &file)
}
