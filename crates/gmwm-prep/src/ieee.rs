//! IEEE Std 952 read-off of an Allan deviation curve (REFERENCES §5).
//!
//! Regions are found automatically from the local log-log slopes s_i = Δln σ / Δln τ between
//! consecutive scales: a segment belongs to the region of slope k ∈ {−1, −½, 0, +½, +1} when
//! |s_i − k| ≤ [`SLOPE_TOLERANCE`]; for each k the longest run of such segments is used
//! (ties: the run whose mean slope is closest to k). On that run a line of fixed slope k is
//! fitted by the mean of ln σ − k ln τ (the least-squares intercept), and the term is read
//! on the line: Q = σ(√3), N = σ(1), K = σ(3), R = σ(√2). B = σ_min / √(2 ln 2 / π) with
//! σ_min the smallest σ in the flat run, or at the curve's interior minimum when there is no
//! flat run. No τ window is hard-coded.

use crate::curve::AvCurve;
use crate::error::{FitError, Result};
use crate::units::{IeeeTerm, Quantity, ieee_quantities};
use processes::Unit;
use serde::{Deserialize, Serialize};

/// Largest |local slope − k| for a segment to count in the region of slope k. Half the gap
/// between neighbouring IEEE slopes would be 0.25; 0.1 keeps the transition zones out.
pub const SLOPE_TOLERANCE: f64 = 0.1;

/// √(2 ln 2 / π) = 0.6642824702…, the flat-region factor: σ_B = 0.6643 · B.
///
/// ```
/// use std::f64::consts::{LN_2, PI};
/// let f = gmwm_prep::ieee::bias_instability_factor();
/// assert!((f * f - 2.0 * LN_2 / PI).abs() < 1e-15); // squaring the root: rounding only
/// ```
pub fn bias_instability_factor() -> f64 {
    (2.0 * std::f64::consts::LN_2 / std::f64::consts::PI).sqrt()
}

/// One IEEE term read off the curve.
///
/// ```
/// use gmwm_prep::{ieee::read_off_adev, units::IeeeTerm};
/// use processes::Unit;
/// // A pure rate random walk: σ(τ) = K √(τ/3) with K = 1e-4 °/s/√s.
/// let tau: Vec<f64> = (0..8).map(|j| 2f64.powi(j)).collect();
/// let adev: Vec<f64> = tau.iter().map(|t| 1e-4 * (t / 3.0).sqrt()).collect();
/// let r = read_off_adev(&tau, &adev, &Unit::DegPerSec)?;
/// let k = r.get(IeeeTerm::K).unwrap();
/// assert_eq!((k.n_points, k.tau_min, k.tau_max), (8, 1.0, 128.0));
/// assert_eq!((k.unit.as_str(), k.ieee[0].unit.as_str()), ("°/s/√s", "°/h/√h"));
/// assert!((k.value / 1e-4 - 1.0).abs() < 1e-13); // a mean of 8 logs: rounding only
/// assert!((k.mean_slope - 0.5).abs() < 1e-12);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IeeeEstimate {
    /// Which term.
    pub term: IeeeTerm,
    /// Its value in the channel's per-second unit (see [`IeeeTerm::per_second_unit`]).
    pub value: f64,
    /// That unit as text.
    pub unit: String,
    /// Smallest τ (s) of the region used.
    pub tau_min: f64,
    /// Largest τ (s) of the region used.
    pub tau_max: f64,
    /// Number of scales in the region.
    pub n_points: usize,
    /// Mean local slope over the region.
    pub mean_slope: f64,
    /// The value in IEEE units (empty for a unitless channel).
    pub ieee: Vec<Quantity>,
}

/// The IEEE 952 read-off: the terms whose region was found.
///
/// ```
/// use gmwm_prep::{AvCurve, ieee::read_off};
/// use processes::Unit;
/// // A pure white noise: σ(τ) = N/√τ with N = 0.01 °/s·√s.
/// let tau: Vec<f64> = (0..10).map(|j| 0.01 * 2f64.powi(j)).collect();
/// let av: Vec<f64> = tau.iter().map(|t| 1e-4 / t).collect();
/// let curve = AvCurve::from_tau(&tau, &av, 100.0)?;
/// let r = read_off(&curve, &Unit::DegPerSec)?;
/// let n = r.get(gmwm_prep::units::IeeeTerm::N).unwrap();
/// assert!((n.value - 0.01).abs() < 1e-15);
/// assert!((n.ieee[0].value - 0.6).abs() < 1e-13); // °/√h
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IeeeReadOff {
    /// Channel unit.
    pub unit: Unit,
    /// Terms found, by increasing slope.
    pub terms: Vec<IeeeEstimate>,
}

impl IeeeReadOff {
    /// The estimate of `term`, if its region was found.
    ///
    /// ```
    /// use gmwm_prep::{ieee::{bias_instability_factor, read_off_adev}, units::IeeeTerm};
    /// // A flat Allan deviation: bias instability only, B = σ / 0.6643.
    /// let r = read_off_adev(&[1.0, 2.0, 4.0], &[1e-3; 3], &processes::Unit::Unitless)?;
    /// assert_eq!(r.get(IeeeTerm::B).unwrap().value, 1e-3 / bias_instability_factor());
    /// assert!(r.get(IeeeTerm::N).is_none());
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn get(&self, term: IeeeTerm) -> Option<&IeeeEstimate> {
        self.terms.iter().find(|e| e.term == term)
    }
}

/// Reads N, B, K, Q, R off the curve's Allan deviation (see module doc). Needs ≥ 2 scales.
///
/// ```
/// use gmwm_prep::{AvCurve, ieee::{read_off, read_off_adev}};
/// use processes::Unit;
/// let m = [1u64, 2, 4, 8];
/// let av: Vec<f64> = m.iter().map(|&m| 1e-4 / m as f64).collect(); // white noise
/// let curve = AvCurve::from_m(&m, &av, 100.0)?;
/// // the same as reading the (τ, √AV) pairs
/// let adev: Vec<f64> = av.iter().map(|a| a.sqrt()).collect();
/// let r = read_off(&curve, &Unit::DegPerSec)?;
/// assert_eq!(r, read_off_adev(&curve.tau(), &adev, &Unit::DegPerSec)?);
/// // one scale shows no slope
/// assert!(read_off(&curve.slice(0..1)?, &Unit::DegPerSec).is_err());
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn read_off(curve: &AvCurve, unit: &Unit) -> Result<IeeeReadOff> {
    curve.validate()?;
    let tau = curve.tau();
    let adev: Vec<f64> = curve.points.iter().map(|p| p.adev()).collect();
    read_off_adev(&tau, &adev, unit)
}

/// Same as [`read_off`] from raw (τ in s, σ) pairs, τ strictly increasing.
///
/// ```
/// use gmwm_prep::{ieee::read_off_adev, units::IeeeTerm};
/// use processes::Unit;
/// // Pure quantization noise, σ(τ) = √3 Q / τ with Q = 2e-4 u·s.
/// let tau = [0.1, 0.2, 0.4, 0.8];
/// let adev: Vec<f64> = tau.iter().map(|t| 3f64.sqrt() * 2e-4 / t).collect();
/// let r = read_off_adev(&tau, &adev, &Unit::Unitless)?;
/// let q = r.get(IeeeTerm::Q).unwrap();
/// assert!((q.value / 2e-4 - 1.0).abs() < 1e-13); // a mean of 4 logs: rounding only
/// assert!(q.ieee.is_empty()); // no IEEE unit for a unitless channel
/// assert!(read_off_adev(&[2.0, 1.0], &[1.0, 1.0], &Unit::Unitless).is_err()); // τ decreasing
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn read_off_adev(tau: &[f64], adev: &[f64], unit: &Unit) -> Result<IeeeReadOff> {
    if tau.len() != adev.len() {
        return Err(FitError::InvalidCurve(format!(
            "{} taus but {} deviations",
            tau.len(),
            adev.len()
        )));
    }
    if tau.len() < 2 {
        return Err(FitError::TooFewScales {
            what: "slope detection".into(),
            needed: 2,
            got: tau.len(),
        });
    }
    for (i, (&t, &a)) in tau.iter().zip(adev).enumerate() {
        for (what, v) in [("tau", t), ("adev", a)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(FitError::NonFinite {
                    index: i,
                    what,
                    value: v,
                });
            }
        }
        if i > 0 && t <= tau[i - 1] {
            return Err(FitError::InvalidCurve("tau must increase strictly".into()));
        }
    }
    let lt: Vec<f64> = tau.iter().map(|t| t.ln()).collect();
    let la: Vec<f64> = adev.iter().map(|a| a.ln()).collect();
    let slopes: Vec<f64> = (0..tau.len() - 1)
        .map(|i| (la[i + 1] - la[i]) / (lt[i + 1] - lt[i]))
        .collect();
    let mut terms = Vec::new();
    for term in IeeeTerm::ALL {
        let k = term.slope();
        // Longest run of segments within tolerance; ties → closest mean slope.
        let mut best: Option<(usize, usize, f64)> = None; // (first seg, last seg, mean dev)
        let mut i = 0;
        while i < slopes.len() {
            if (slopes[i] - k).abs() <= SLOPE_TOLERANCE {
                let start = i;
                while i + 1 < slopes.len() && (slopes[i + 1] - k).abs() <= SLOPE_TOLERANCE {
                    i += 1;
                }
                let dev = slopes[start..=i].iter().map(|s| (s - k).abs()).sum::<f64>()
                    / (i - start + 1) as f64;
                let better = match best {
                    None => true,
                    Some((a, b, d)) => {
                        let (len, blen) = (i - start, b - a);
                        len > blen || (len == blen && dev < d)
                    }
                };
                if better {
                    best = Some((start, i, dev));
                }
            }
            i += 1;
        }
        let (lo, hi) = match (best, term) {
            (Some((a, b, _)), _) => (a, b + 1), // points a..=b+1
            (None, IeeeTerm::B) => {
                // No flat run: use the interior minimum of σ, if any.
                let (imin, _) = adev
                    .iter()
                    .enumerate()
                    .fold(
                        (0, f64::INFINITY),
                        |acc, (i, &a)| if a < acc.1 { (i, a) } else { acc },
                    );
                if imin == 0 || imin == adev.len() - 1 {
                    continue;
                }
                (imin, imin)
            }
            (None, _) => continue,
        };
        let pts = lo..=hi;
        let n_points = hi - lo + 1;
        let mean_slope = if hi > lo {
            (la[hi] - la[lo]) / (lt[hi] - lt[lo])
        } else {
            0.0
        };
        let value = match term {
            IeeeTerm::B => {
                adev[pts.clone()]
                    .iter()
                    .cloned()
                    .fold(f64::INFINITY, f64::min)
                    / bias_instability_factor()
            }
            _ => {
                let c =
                    (pts.clone().map(|i| la[i] - k * lt[i]).sum::<f64>() / n_points as f64).exp();
                let tau_read = match term {
                    IeeeTerm::Q => 3f64.sqrt(),
                    IeeeTerm::N => 1.0,
                    IeeeTerm::K => 3.0,
                    IeeeTerm::R => 2f64.sqrt(),
                    IeeeTerm::B => unreachable!(),
                };
                // σ(τ_read) on the line, times the factor that turns σ into the term:
                // Q = σ(√3), N = σ(1), K = σ(3), R = σ(√2).
                c * tau_read.powf(k)
            }
        };
        terms.push(IeeeEstimate {
            term,
            value,
            unit: term.per_second_unit(unit),
            tau_min: tau[lo],
            tau_max: tau[hi],
            n_points,
            mean_slope,
            ieee: ieee_quantities(term, value, unit),
        });
    }
    Ok(IeeeReadOff {
        unit: unit.clone(),
        terms,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bias_instability_factor_is_0_6643() {
        assert!((bias_instability_factor() - 0.664_282_470_2).abs() < 1e-10);
    }

    #[test]
    fn pure_power_laws_give_the_terms_exactly() {
        // σ²(τ) of REFERENCES §5 with known Q, N, K, R; one pure law at a time must be
        // read back to rounding (1e-13 relative: a mean of ~10 logs).
        const EXACT_REL_TOL: f64 = 1e-13;
        let tau: Vec<f64> = (0..12).map(|j| 0.01 * 2f64.powi(j)).collect();
        let cases = [
            (
                IeeeTerm::Q,
                2e-4,
                (|v: f64, t: f64| 3.0 * v * v / (t * t)) as fn(f64, f64) -> f64,
            ),
            (IeeeTerm::N, 3e-3, |v: f64, t: f64| v * v / t),
            (IeeeTerm::K, 5e-5, |v: f64, t: f64| v * v * t / 3.0),
            (IeeeTerm::R, 7e-6, |v: f64, t: f64| v * v * t * t / 2.0),
        ];
        for (term, v, av) in cases {
            let adev: Vec<f64> = tau.iter().map(|&t| av(v, t).sqrt()).collect();
            let r = read_off_adev(&tau, &adev, &Unit::Unitless).unwrap();
            let e = r.get(term).unwrap();
            assert!(
                (e.value / v - 1.0).abs() < EXACT_REL_TOL,
                "{term:?}: {} vs {v}",
                e.value
            );
            assert_eq!(e.n_points, tau.len());
            assert_eq!(r.terms.len(), 1, "{term:?}: only its own region");
        }
    }

    #[test]
    fn bias_instability_from_a_flat_curve() {
        let tau: Vec<f64> = (0..6).map(|j| 2f64.powi(j)).collect();
        let b = 1e-3;
        let adev = vec![bias_instability_factor() * b; 6];
        let r = read_off_adev(&tau, &adev, &Unit::DegPerSec).unwrap();
        let e = r.get(IeeeTerm::B).unwrap();
        assert!((e.value / b - 1.0).abs() < 1e-14);
        assert!((e.ieee[0].value - 3.6).abs() < 1e-12); // °/h
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(read_off_adev(&[1.0], &[1.0], &Unit::Unitless).is_err());
        assert!(read_off_adev(&[1.0, 2.0], &[1.0, f64::NAN], &Unit::Unitless).is_err());
        assert!(read_off_adev(&[2.0, 1.0], &[1.0, 1.0], &Unit::Unitless).is_err());
    }
}
