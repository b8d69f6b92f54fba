//! Fitting support for the long-memory processes PLP (ARFIMA(0, d, 0)) and FGN: the
//! unconstrained parameterisation of the optimizer and the starting value of d / H.
//!
//! - PLP: σ² = e^{η₀}, d = ½ tanh η₁ ∈ (−½, ½);
//! - FGN: σ² = e^{η₀}, H = logistic(η₁) ∈ (0, 1).
//!
//! The start of d (H) comes from the least-squares log-log slope s of the upper half of
//! the AV curve, where a long-memory component dominates: AV ∝ m^{2d−1} (PLP) and
//! m^{2H−2} (FGN), so d = (s + 1)/2 and H = (s + 2)/2, clamped to |d| ≤ 0.45 and
//! H ∈ [0.05, 0.95]. Its variance then comes from the start grid's NNLS like every other
//! component's; the optimizer refines both.

use processes::ProcessKind;

/// Largest |d| and distance of H from {0, 1} a start may take.
const D_START_MAX: f64 = 0.45;
const H_START_MIN: f64 = 0.05;

/// The memory parameter (d or H) at η and its derivative dθ/dη.
pub(crate) fn memory_theta(kind: ProcessKind, eta: f64) -> (f64, f64) {
    match kind {
        ProcessKind::Plp => {
            let t = eta.tanh();
            let d = 0.5 * t;
            if d.abs() >= 0.5 {
                return (f64::NAN, f64::NAN);
            }
            (d, 0.5 * (1.0 - t * t))
        }
        ProcessKind::Fgn => {
            let h = 1.0 / (1.0 + (-eta).exp());
            if !(h > 0.0 && h < 1.0) {
                return (f64::NAN, f64::NAN);
            }
            (h, h * (1.0 - h))
        }
        _ => (f64::NAN, f64::NAN),
    }
}

/// η of a memory parameter (inverse of [`memory_theta`], clamped inside the open range).
pub(crate) fn memory_eta(kind: ProcessKind, v: f64) -> f64 {
    match kind {
        ProcessKind::Plp => (2.0 * v).clamp(-1.0 + 1e-12, 1.0 - 1e-12).atanh(),
        ProcessKind::Fgn => {
            let h = v.clamp(1e-12, 1.0 - 1e-12);
            (h / (1.0 - h)).ln()
        }
        _ => f64::NAN,
    }
}

/// Least-squares slope of ln ν against ln m over the upper half of the scales (at least
/// the last 3, all when fewer); NaN when fewer than 2 points are positive.
pub(crate) fn upper_slope(m: &[f64], nu: &[f64]) -> f64 {
    let n = m.len();
    let from = if n >= 6 { n / 2 } else { n.saturating_sub(3) };
    let pts: Vec<(f64, f64)> = m[from..]
        .iter()
        .zip(&nu[from..])
        .filter(|(a, b)| **a > 0.0 && **b > 0.0)
        .map(|(a, b)| (a.ln(), b.ln()))
        .collect();
    if pts.len() < 2 {
        return f64::NAN;
    }
    let k = pts.len() as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / k, b + y / k));
    let (sxy, sxx) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    sxy / sxx
}

/// Start of d (PLP) or H (FGN) from [`upper_slope`] (module docs); d = 0.25 / H = 0.75 when
/// the slope is not defined.
pub(crate) fn memory_start(kind: ProcessKind, m: &[f64], nu: &[f64]) -> f64 {
    let s = upper_slope(m, nu);
    match kind {
        ProcessKind::Plp if s.is_finite() => (0.5 * (s + 1.0)).clamp(-D_START_MAX, D_START_MAX),
        ProcessKind::Plp => 0.25,
        ProcessKind::Fgn if s.is_finite() => {
            (0.5 * (s + 2.0)).clamp(H_START_MIN, 1.0 - H_START_MIN)
        }
        ProcessKind::Fgn => 0.75,
        _ => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transforms_round_trip_and_derivatives() {
        for (k, v) in [
            (ProcessKind::Plp, -0.3),
            (ProcessKind::Plp, 0.0),
            (ProcessKind::Plp, 0.49),
            (ProcessKind::Fgn, 0.2),
            (ProcessKind::Fgn, 0.5),
            (ProcessKind::Fgn, 0.97),
        ] {
            let e = memory_eta(k, v);
            let (back, dv) = memory_theta(k, e);
            // the inverse in f64: atanh/tanh and logit/logistic round trip to ~1e-15
            assert!((back - v).abs() < 1e-14, "{k:?} {v} -> {back}");
            // derivative against a central difference (step 1e-6: error O(h²) ≈ 1e-12)
            let h = 1e-6;
            let fd = (memory_theta(k, e + h).0 - memory_theta(k, e - h).0) / (2.0 * h);
            assert!((fd - dv).abs() < 1e-9, "{k:?} {dv} vs {fd}");
        }
    }

    #[test]
    fn av_gradient_used_by_the_fit_matches_central_differences() {
        // ∂AV/∂σ² and ∂AV/∂d (∂AV/∂H) of the optimizer's route vs central differences of
        // its value (step 1e-6 relative: truncation O(h²) and rounding ~1e-16/h ≈ 1e-10;
        // the PLP d-derivative is itself a central difference: 1e-6 relative)
        let mut g = [0.0; 5];
        for (k, th) in [
            (ProcessKind::Plp, [2e-4, 0.3]),
            (ProcessKind::Plp, [1.0, -0.35]),
            (ProcessKind::Fgn, [3e-5, 0.8]),
            (ProcessKind::Fgn, [1.0, 0.2]),
        ] {
            for m in [1.0, 8.0, 4096.0] {
                let v = crate::theory::kind_avar_grad(k, &th, m, 100.0, &mut g);
                assert!(v.is_finite() && v > 0.0);
                for i in 0..2 {
                    let h = 1e-6 * th[i].abs();
                    let (mut up, mut dn) = (th, th);
                    up[i] += h;
                    dn[i] -= h;
                    let mut s = [0.0; 5];
                    let fd = (crate::theory::kind_avar_grad(k, &up, m, 100.0, &mut s)
                        - crate::theory::kind_avar_grad(k, &dn, m, 100.0, &mut s))
                        / (2.0 * h);
                    assert!(
                        (g[i] - fd).abs() <= 1e-6 * fd.abs(),
                        "{k:?} {th:?} m={m} i={i}: {} vs {fd}",
                        g[i]
                    );
                }
            }
        }
    }

    #[test]
    fn start_from_the_exact_slope() {
        // pure power laws: AV = m^{2d−1} and m^{2H−2} give d and H back exactly (to rounding)
        let m: Vec<f64> = (0..16).map(|j| 2f64.powi(j)).collect();
        let nu: Vec<f64> = m.iter().map(|x| x.powf(2.0 * 0.3 - 1.0)).collect();
        assert!((memory_start(ProcessKind::Plp, &m, &nu) - 0.3).abs() < 1e-12);
        let nu: Vec<f64> = m.iter().map(|x| 3.0 * x.powf(2.0 * 0.8 - 2.0)).collect();
        assert!((memory_start(ProcessKind::Fgn, &m, &nu) - 0.8).abs() < 1e-12);
        // a rising curve is clamped
        let nu: Vec<f64> = m.clone();
        assert_eq!(memory_start(ProcessKind::Plp, &m, &nu), D_START_MAX);
    }
}
