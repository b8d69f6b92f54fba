//! Theory: the Allan variance of a model and of each of its components at given cluster
//! sizes, with the model's PSD (what `imunoise theory` and the Python `theory` produce).

use crate::error::{Error, Result};
use processes::Model;
use serde::Serialize;

/// One theoretical point.
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
#[derive(Debug, Clone, Serialize)]
pub struct ComponentCurve {
    /// The component's text form, e.g. `"WN(sigma2=0.0001)"`.
    pub name: String,
    /// Its curve.
    pub points: Vec<TheoryPoint>,
}

/// The JSON document of `imunoise theory`.
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
#[derive(Debug, Clone, Serialize)]
pub struct PsdPoint {
    /// Frequency (Hz).
    pub f: f64,
    /// Two-sided PSD (unit²/Hz).
    pub psd: f64,
}

/// The model's two-sided PSD at `k` log-spaced frequencies in [f0, rate/2].
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
