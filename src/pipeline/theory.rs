//! Theory: the Allan variance of a model and of each of its components at given cluster
//! sizes, with the model's PSD (what `imunoise theory` and the Python `theory` produce).

use crate::error::{Error, Result};
use processes::Model;
use serde::Serialize;

/// One theoretical point.
///
/// ```
/// let model: imunoise::processes::Model = "WN(sigma2=2)".parse()?;
/// let t = imunoise::pipeline::theory::curves(&model, 100.0, &[4])?;
/// let p = &t.points[0];
/// // white noise: AV = σ²/m
/// assert_eq!((p.m, p.tau, p.avar), (4, 0.04, 0.5));
/// assert_eq!(p.adev, 0.5f64.sqrt());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct TheoryPoint {
    /// Cluster size (samples).
    pub m: u64,
    /// Averaging time (s).
    pub tau: f64,
    /// Theoretical Allan variance.
    pub avar: f64,
    /// Theoretical Allan deviation.
    pub adev: f64,
}

/// One component's curve.
///
/// ```
/// let model: imunoise::processes::Model = "WN(sigma2=2) + RW(gamma2=1e-6)".parse()?;
/// let t = imunoise::pipeline::theory::curves(&model, 100.0, &[1, 10, 100])?;
/// assert_eq!(t.components.len(), 2);
/// assert!(t.components[0].name.starts_with("WN") && t.components[1].name.starts_with("RW"));
/// // independent components: the model's AV is the sum of theirs
/// for (i, p) in t.points.iter().enumerate() {
///     let sum: f64 = t.components.iter().map(|c| c.points[i].avar).sum();
///     assert!((p.avar - sum).abs() <= 1e-12 * p.avar);
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct ComponentCurve {
    /// The component's text form, e.g. `"WN(sigma2=0.0001)"`.
    pub name: String,
    /// Its curve.
    pub points: Vec<TheoryPoint>,
}

/// The JSON document of `imunoise theory`.
///
/// ```
/// let model: imunoise::processes::Model = "WN(sigma2=2)".parse()?;
/// let t = imunoise::pipeline::theory::curves(&model, 100.0, &[1, 2, 4, 8])?;
/// let json = serde_json::to_value(&t)?;
/// assert_eq!(json["rate_hz"], 100.0);
/// assert_eq!(json["model"], model.to_string());
/// assert_eq!(json["points"].as_array().unwrap().len(), 4);
/// assert_eq!(json["psd"].as_array().unwrap().len(), t.psd.len());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct TheoryJson {
    /// The model's text form.
    pub model: String,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// The whole model's curve.
    pub points: Vec<TheoryPoint>,
    /// Each component's curve, in model order.
    pub components: Vec<ComponentCurve>,
    /// Two-sided PSD of the model (unit²/Hz, f in Hz; `spectral`'s convention) at
    /// log-spaced frequencies from rate/(2·m_max) to rate/2. Empty when the model has a
    /// drift, whose spectrum is not a function.
    pub psd: Vec<PsdPoint>,
}

/// One PSD point.
///
/// ```
/// let model: imunoise::processes::Model = "WN(sigma2=2)".parse()?;
/// let psd = imunoise::pipeline::theory::psd_curve(&model, 100.0, 0.1, 5);
/// // white noise is flat at σ²Δt
/// assert!(psd.iter().all(|p| (p.psd - 2.0 / 100.0).abs() < 1e-15));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Debug, Clone, Serialize)]
pub struct PsdPoint {
    /// Frequency (Hz).
    pub f: f64,
    /// Two-sided PSD (unit²/Hz).
    pub psd: f64,
}

/// The model's two-sided PSD at `k` log-spaced frequencies in [f0, rate/2].
///
/// ```
/// use imunoise::pipeline::theory::psd_curve;
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let psd = psd_curve(&model, 100.0, 0.01, 31);
/// assert_eq!(psd.len(), 31);
/// assert_eq!(psd[0].f, 0.01);
/// assert!((psd[30].f - 50.0).abs() < 1e-9); // the Nyquist frequency
/// // the random walk's 1/f² part: the PSD falls with f
/// assert!(psd.windows(2).all(|w| w[1].psd < w[0].psd));
/// // a drift has no PSD function: empty
/// let dr: imunoise::processes::Model = "DR(omega=1e-3)".parse()?;
/// assert!(psd_curve(&dr, 100.0, 0.01, 31).is_empty());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn psd_curve(model: &Model, rate_hz: f64, f0: f64, k: usize) -> Vec<PsdPoint> {
    let f1 = rate_hz / 2.0;
    let f0 = f0.min(f1 / 10.0);
    let mut out = Vec::with_capacity(k);
    for i in 0..k {
        let f = f0 * (f1 / f0).powf(i as f64 / (k - 1) as f64);
        match spectral::model_psd(model, f, rate_hz) {
            Ok(p) => out.push(PsdPoint { f, psd: p }),
            Err(_) => return Vec::new(),
        }
    }
    out
}

/// Theoretical curves of `model` at cluster sizes `ms` (closed forms of the `spectral` layer).
///
/// ```
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let t = imunoise::pipeline::theory::curves(&model, 100.0, &[1, 2, 4, 8, 16])?;
/// assert_eq!(t.points.iter().map(|p| p.m).collect::<Vec<_>>(), [1, 2, 4, 8, 16]);
/// // the WN component: σ²/m
/// let wn = &t.components[0];
/// assert!(wn.points.iter().all(|p| (p.avar - 1e-4 / p.m as f64).abs() <= 1e-18));
/// // the PSD reaches down to rate / (2 m_max)
/// assert!((t.psd[0].f - 100.0 / 32.0).abs() < 1e-12);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn curves(model: &Model, rate_hz: f64, ms: &[u64]) -> Result<TheoryJson> {
    let procs = model.processes()?;
    let point = |m: u64, avar: f64| TheoryPoint {
        m,
        tau: m as f64 / rate_hz,
        avar,
        adev: avar.sqrt(),
    };
    let spec = |e: spectral::SpectralError| Error::Usage(format!("theory: {e}"));
    let mut components = Vec::new();
    for p in &procs {
        let pts = ms
            .iter()
            .map(|&m| spectral::allan_variance(p, m, rate_hz).map(|a| point(m, a)))
            .collect::<std::result::Result<Vec<_>, _>>()
            .map_err(spec)?;
        components.push(ComponentCurve {
            name: Model::from(*p).to_string(),
            points: pts,
        });
    }
    let points = ms
        .iter()
        .map(|&m| spectral::model_allan_variance(model, m, rate_hz).map(|a| point(m, a)))
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(spec)?;
    let m_max = ms.iter().copied().max().unwrap_or(1) as f64;
    Ok(TheoryJson {
        model: model.to_string(),
        rate_hz,
        points,
        components,
        psd: psd_curve(model, rate_hz, rate_hz / (2.0 * m_max), 61),
    })
}
