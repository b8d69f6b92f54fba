//! Allan variance linear regression (AVLR; book §4.4, R avar's `avlr`).
//!
//! Each process is fitted on its own window of scales by a fixed-slope line in log-log space:
//! with σ(τ) the Allan deviation and τ in seconds (book eq. 4.3 and REFERENCES §5),
//!
//! | process | AD law | estimate (mean over the window) | per sample |
//! |---|---|---|---|
//! | WN | N/√τ | N = exp mean(ln σ + ½ ln τ) | σ² = N²/Δt |
//! | QN | √3 Q/τ | Q = exp mean(ln σ + ln τ)/√3 | Q² = (Q/Δt)² |
//! | RW | K √(τ/3) | K = √3 exp mean(ln σ − ½ ln τ) | γ² = K² Δt |
//! | DR | R τ/√2 | R = √2 exp mean(ln σ − ln τ) | ω = R Δt |
//!
//! The per-second values N, Q, K, R are what R avar prints. Several curves of the same
//! sensor type (e.g. the three gyro axes) can be pooled as R avar does: the window's points
//! of every curve enter the same mean ([`avlr_pooled`]). The implied curve uses the exact laws
//! above (R avar's drift decomposition divides by 2 instead of √2; we do not).
//!
//! AVLR is inconsistent for composite models (Guerrier, Molinari & Stebler 2016): every
//! process leaks into the others' windows. It is provided as the classical reference.

use crate::curve::AvCurve;
use crate::error::{FitError, Result};
use crate::units::IeeeTerm;
use processes::{Model, Process, ProcessKind, Unit};
use serde::{Deserialize, Serialize};

/// Scale windows (0-based inclusive index ranges into the curve's points) of each process;
/// `None` leaves the process out. R avar's 1-based `wn = 6:8` is `Some((5, 7))`.
///
/// ```
/// let w = gmwm_prep::avlr::AvlrWindows { wn: Some((5, 7)), ..Default::default() };
/// assert!(w.qn.is_none());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct AvlrWindows {
    /// Quantization noise window.
    pub qn: Option<(usize, usize)>,
    /// White noise window.
    pub wn: Option<(usize, usize)>,
    /// Random walk window.
    pub rw: Option<(usize, usize)>,
    /// Drift window.
    pub dr: Option<(usize, usize)>,
}

impl AvlrWindows {
    fn list(&self) -> Vec<(ProcessKind, (usize, usize))> {
        [
            (ProcessKind::WhiteNoise, self.wn),
            (ProcessKind::QuantizationNoise, self.qn),
            (ProcessKind::RandomWalk, self.rw),
            (ProcessKind::Drift, self.dr),
        ]
        .into_iter()
        .filter_map(|(k, w)| w.map(|w| (k, w)))
        .collect()
    }

    /// Windows chosen automatically from the curve's local slopes: the regions of slope
    /// −1 (QN), −½ (WN), +½ (RW) and +1 (DR) found by the IEEE read-off
    /// ([`crate::ieee::read_off`]). Processes whose region is absent are left out.
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, avlr::AvlrWindows};
    /// let m: Vec<u64> = (1..=12).map(|j| 1u64 << j).collect();
    /// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect();
    /// let w = AvlrWindows::auto(&AvCurve::from_m(&m, &av, 100.0)?)?;
    /// assert_eq!(w.wn, Some((0, 11)));
    /// assert!(w.rw.is_none());
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn auto(curve: &AvCurve) -> Result<Self> {
        let r = crate::ieee::read_off(curve, &Unit::Unitless)?;
        let tau = curve.tau();
        let idx = |t: f64| tau.iter().position(|&x| x == t).unwrap_or(0);
        let win = |term: IeeeTerm| {
            r.get(term)
                .filter(|e| e.n_points >= 2)
                .map(|e| (idx(e.tau_min), idx(e.tau_max)))
        };
        let w = Self {
            qn: win(IeeeTerm::Q),
            wn: win(IeeeTerm::N),
            rw: win(IeeeTerm::K),
            dr: win(IeeeTerm::R),
        };
        if w.list().is_empty() {
            return Err(FitError::InvalidWindow {
                process: "any",
                message: "no region of slope −1, −½, +½ or +1 found in the curve".into(),
            });
        }
        Ok(w)
    }
}

/// One AVLR estimate.
///
/// ```
/// use gmwm_prep::{AvCurve, avlr::{avlr, AvlrWindows}, units::IeeeTerm};
/// // Continuous-time law of a random walk, AV = K² τ / 3, with K = 1e-4 at 100 Hz.
/// let m: Vec<u64> = (1..=6).map(|j| 1u64 << j).collect();
/// let av: Vec<f64> = m.iter().map(|&m| 1e-8 * (m as f64 / 100.0) / 3.0).collect();
/// let w = AvlrWindows { rw: Some((1, 4)), ..Default::default() };
/// let e = avlr(&AvCurve::from_m(&m, &av, 100.0)?, &w)?.estimates[0].clone();
/// assert_eq!((e.term, e.window, e.tau_range), (IeeeTerm::K, (1, 4), (0.04, 0.32)));
/// assert!((e.value / 1e-4 - 1.0).abs() < 1e-13); // a mean of 4 logs: rounding only
/// assert_eq!(e.per_sample, e.value * e.value * 0.01); // γ² = K² Δt
/// assert!(e.sd.is_none() && e.ci_lo.is_none()); // no bootstrap
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AvlrEstimate {
    /// The process.
    pub process: ProcessKind,
    /// The per-second value printed by R avar: N, Q, K or R (channel unit × s^k).
    pub value: f64,
    /// Its IEEE symbol.
    pub term: IeeeTerm,
    /// The per-sample parameter of `processes`: σ², Q², γ² or ω.
    pub per_sample: f64,
    /// Window used (0-based inclusive scale indices).
    pub window: (usize, usize),
    /// τ range of the window (s).
    pub tau_range: (f64, f64),
    /// Parametric bootstrap standard deviation of `per_sample`, if computed.
    pub sd: Option<f64>,
    /// Lower CI bound of `per_sample` (θ̂ − z_{1−α/2} sd), if computed.
    pub ci_lo: Option<f64>,
    /// Upper CI bound of `per_sample`, if computed.
    pub ci_hi: Option<f64>,
}

/// The AVLR fit.
///
/// ```
/// use gmwm_prep::{AvCurve, avlr::{avlr, AvlrWindows}};
/// // White noise σ² = 1e-4 per sample at 100 Hz: AV(m) = σ²/m.
/// let m = [1u64, 2, 4, 8];
/// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect();
/// let w = AvlrWindows { wn: Some((0, 3)), ..Default::default() };
/// let f = avlr(&AvCurve::from_m(&m, &av, 100.0)?, &w)?;
/// assert_eq!((f.rate_hz, f.windows), (100.0, w));
/// // the model holds the per-sample estimates
/// assert_eq!(f.model.processes()?[0].params(), vec![f.estimates[0].per_sample]);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AvlrFit {
    /// Estimates in the order WN, QN, RW, DR (those with a window).
    pub estimates: Vec<AvlrEstimate>,
    /// The fitted model with per-sample parameters.
    pub model: Model,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Windows used.
    pub windows: AvlrWindows,
}

impl AvlrFit {
    /// The estimate of a process kind, if fitted.
    ///
    /// ```
    /// use gmwm_prep::{AvCurve, avlr::{avlr, AvlrWindows}};
    /// use processes::ProcessKind;
    /// let m = [1u64, 2, 4, 8];
    /// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect();
    /// let w = AvlrWindows { wn: Some((0, 3)), ..Default::default() };
    /// let f = avlr(&AvCurve::from_m(&m, &av, 100.0)?, &w)?;
    /// assert_eq!(f.get(ProcessKind::WhiteNoise), Some(&f.estimates[0]));
    /// assert!(f.get(ProcessKind::RandomWalk).is_none()); // no RW window
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn get(&self, kind: ProcessKind) -> Option<&AvlrEstimate> {
        self.estimates.iter().find(|e| e.process == kind)
    }
}

/// AVLR on one curve (see module doc).
///
/// ```
/// use gmwm_prep::{AvCurve, avlr::{avlr, AvlrWindows}};
/// use processes::ProcessKind;
/// let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
/// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect();
/// let f = avlr(&AvCurve::from_m(&m, &av, 100.0)?, &AvlrWindows { wn: Some((0, 9)), ..Default::default() })?;
/// let wn = f.get(ProcessKind::WhiteNoise).unwrap();
/// assert!((wn.per_sample / 1e-4 - 1.0).abs() < 1e-13);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn avlr(curve: &AvCurve, windows: &AvlrWindows) -> Result<AvlrFit> {
    avlr_pooled(std::slice::from_ref(curve), windows)
}

/// AVLR pooling several curves of the same rate and scales (R avar's `avlr` on an
/// `imu_avar`: every window's points of every curve enter one mean).
///
/// ```
/// use gmwm_prep::{AvCurve, avlr::{avlr_pooled, AvlrWindows}};
/// let m = [1u64, 2, 4, 8];
/// let wn = |s2: f64| AvCurve::from_m(&m, &m.map(|m| s2 / m as f64), 100.0);
/// let w = AvlrWindows { wn: Some((0, 3)), ..Default::default() };
/// // the log-log mean pools the σ² geometrically: √(4e-4 · 2.5e-5) = 1e-4
/// let f = avlr_pooled(&[wn(4e-4)?, wn(2.5e-5)?], &w)?;
/// assert!((f.estimates[0].per_sample / 1e-4 - 1.0).abs() < 1e-13); // rounding only
/// // the curves must share their scales
/// let other = AvCurve::from_m(&[1, 2, 4, 16], &[1.0; 4], 100.0)?;
/// assert!(avlr_pooled(&[wn(1e-4)?, other], &w).is_err());
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn avlr_pooled(curves: &[AvCurve], windows: &AvlrWindows) -> Result<AvlrFit> {
    let first = curves
        .first()
        .ok_or_else(|| FitError::InvalidArgument("no curve to fit".into()))?;
    for c in curves {
        c.validate()?;
        if c.rate_hz != first.rate_hz || c.m() != first.m() {
            return Err(FitError::InvalidCurve(
                "pooled curves must share the rate and the scales".into(),
            ));
        }
    }
    let list = windows.list();
    if list.is_empty() {
        return Err(FitError::InvalidWindow {
            process: "any",
            message: "no window given".into(),
        });
    }
    let dt = 1.0 / first.rate_hz;
    let tau = first.tau();
    let mut estimates = Vec::new();
    let mut procs = Vec::new();
    for (kind, (a, b)) in list {
        if a > b || b >= first.len() {
            return Err(FitError::InvalidWindow {
                process: kind.code(),
                message: format!("({a}, {b}) is not inside 0..{}", first.len()),
            });
        }
        let k = match kind {
            ProcessKind::QuantizationNoise => -1.0,
            ProcessKind::WhiteNoise => -0.5,
            ProcessKind::RandomWalk => 0.5,
            _ => 1.0,
        };
        let mut acc = 0.0;
        let mut cnt = 0usize;
        for c in curves {
            for p in &c.points[a..=b] {
                acc += 0.5 * p.avar.ln() - k * p.tau.ln();
                cnt += 1;
            }
        }
        let line = (acc / cnt as f64).exp(); // σ(τ) = line · τ^k
        let (term, value, per_sample) = match kind {
            ProcessKind::WhiteNoise => (IeeeTerm::N, line, line * line / dt),
            ProcessKind::QuantizationNoise => {
                let q = line / 3f64.sqrt();
                (IeeeTerm::Q, q, (q / dt) * (q / dt))
            }
            ProcessKind::RandomWalk => {
                let kk = 3f64.sqrt() * line;
                (IeeeTerm::K, kk, kk * kk * dt)
            }
            _ => {
                let r = 2f64.sqrt() * line;
                (IeeeTerm::R, r, r * dt)
            }
        };
        procs.push(Process::from_params(kind, &[per_sample])?);
        estimates.push(AvlrEstimate {
            process: kind,
            value,
            term,
            per_sample,
            window: (a, b),
            tau_range: (tau[a], tau[b]),
            sd: None,
            ci_lo: None,
            ci_hi: None,
        });
    }
    Ok(AvlrFit {
        estimates,
        model: Model::from_processes(procs)?,
        rate_hz: first.rate_hz,
        windows: *windows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_windows_are_errors() {
        let m: Vec<u64> = (1..=5).map(|j| 1u64 << j).collect();
        let c = AvCurve::from_m(&m, &[1.0, 0.5, 0.25, 0.125, 0.0625], 1.0).unwrap();
        let w = AvlrWindows {
            wn: Some((3, 9)),
            ..Default::default()
        };
        assert!(matches!(avlr(&c, &w), Err(FitError::InvalidWindow { .. })));
        assert!(avlr(&c, &AvlrWindows::default()).is_err());
    }
}
