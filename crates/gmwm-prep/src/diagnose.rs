//! Why the parameters of a fit cannot be identified, said in the user's terms: which component,
//! from which scales, and what to try.
//!
//! When AᵀΩA is singular at θ̂ (A = ∂ν/∂θ, Ω the weighting), some direction of the parameters
//! leaves the fitted AV unchanged over the fitted scales. Two causes cover what happens on real
//! records:
//! - a component that contributes (almost) nothing to the fitted AV at every scale: its
//!   estimate went to the boundary (e.g. a random walk fitted to a record too short to show it);
//! - two components whose AV shapes coincide over these scales (e.g. an AR1 whose correlation
//!   time is far beyond the longest τ looks like a random walk).

use crate::error::FitError;
use crate::gmwm::GmwmFit;

/// A component is negligible when its share of the fitted AV stays below this at every scale.
const NEGLIGIBLE_SHARE: f64 = 1e-3;

/// Each component's largest share of the fitted AV over the fitted scales (model order): a
/// component whose share stays below 10⁻³ at every scale is not determined by the data (its
/// estimate sits at a boundary and its CI spans many decades).
///
/// ```
/// use gmwm_prep::{AvCurve, diagnose::largest_shares, gmwm::{fit, GmwmOptions}, theory::model_avar};
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=12).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let f = fit(&curve, &"WN + RW + AR1".parse()?, &GmwmOptions::default())?;
/// let s = largest_shares(&f);
/// assert!(s[0] > 0.9 && s[1] > 0.5 && s[2] < 1e-3); // WN, RW carry the AV; AR1 nothing
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn largest_shares(fit: &GmwmFit) -> Vec<f64> {
    fit.components
        .iter()
        .map(|c| {
            c.iter()
                .zip(&fit.fitted)
                .map(|(v, f)| if *f > 0.0 { (v / f).abs() } else { 0.0 })
                .fold(0.0, f64::max)
        })
        .collect()
}

/// Codes of the components of a fit that contribute less than 10⁻³ of the fitted AV at every
/// scale, with their largest share: the data do not determine their parameters.
///
/// ```
/// use gmwm_prep::{AvCurve, gmwm::{fit, GmwmOptions}, theory::model_avar};
/// use gmwm_prep::diagnose::{largest_shares, negligible_components};
/// // no AR1 in the truth: the fitted AR1 carries nothing
/// let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse()?;
/// let m: Vec<u64> = (1..=12).map(|j| 1u64 << j).collect();
/// let curve = AvCurve::from_m(&m, &model_avar(&truth, &m, 100.0)?, 100.0)?;
/// let f = fit(&curve, &"WN + RW + AR1".parse()?, &GmwmOptions::default())?;
/// assert_eq!(negligible_components(&f), vec![("AR1", largest_shares(&f)[2])]);
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn negligible_components(fit: &GmwmFit) -> Vec<(&'static str, f64)> {
    largest_shares(fit)
        .into_iter()
        .zip(&fit.kinds)
        .filter(|(s, _)| *s < NEGLIGIBLE_SHARE)
        .map(|(s, k)| (k.code(), s))
        .collect()
}

/// The error for a fit whose AᵀΩA is singular, naming the components and the scales.
pub(crate) fn unidentifiable(fit: &GmwmFit) -> FitError {
    let codes: Vec<&str> = fit.kinds.iter().map(|k| k.code()).collect();
    let (tau_lo, tau_hi) = (
        fit.tau.first().copied().unwrap_or(f64::NAN),
        fit.tau.last().copied().unwrap_or(f64::NAN),
    );
    let shares = largest_shares(fit);
    let negligible: Vec<usize> = (0..codes.len())
        .filter(|&c| shares[c] < NEGLIGIBLE_SHARE)
        .collect();
    let (culprits, reason) = if !negligible.is_empty() {
        let names: Vec<String> = negligible
            .iter()
            .map(|&c| format!("{} (at most {:.2e} of the AV)", codes[c], shares[c]))
            .collect();
        let one = negligible.len() == 1;
        (
            negligible.clone(),
            format!(
                "at the fitted values {} {} almost nothing at any of these scales, so the data say nothing about {}",
                names.join(", "),
                if one { "contributes" } else { "contribute" },
                if one { "it" } else { "them" }
            ),
        )
    } else if let Some((a, b, cos)) = most_collinear(fit) {
        (
            vec![a, b],
            format!(
                "over these scales the AV shapes of {} and {} are nearly the same (their weighted gradients have |cos| = {cos:.6}), so the data cannot tell them apart",
                codes[a], codes[b]
            ),
        )
    } else {
        (
            Vec::new(),
            "the weighted gradients of the AV with respect to the parameters are linearly dependent"
                .to_string(),
        )
    };
    let smaller: Vec<&str> = codes
        .iter()
        .enumerate()
        .filter(|(c, _)| culprits.first().is_none_or(|&d| d != *c))
        .map(|(_, s)| *s)
        .collect();
    let what: Vec<&str> = culprits.iter().map(|&c| codes[c]).collect();
    FitError::NotIdentifiable {
        components: what.iter().map(|s| s.to_string()).collect(),
        tau_lo,
        tau_hi,
        reason,
        smaller_model: (smaller.len() < codes.len() && !smaller.is_empty())
            .then(|| smaller.join(" + ")),
    }
}

/// The pair of components whose whitened gradient columns are most nearly parallel, with the
/// |cosine| of their angle (over every pair of parameters of different components).
fn most_collinear(fit: &GmwmFit) -> Option<(usize, usize, f64)> {
    let a = fit.jacobian();
    let w = fit.whitening.to_mat();
    let u = &w * &a; // J×p whitened columns
    let p = u.ncols();
    let owner: Vec<usize> = fit
        .kinds
        .iter()
        .enumerate()
        .flat_map(|(c, k)| std::iter::repeat_n(c, k.n_params()))
        .collect();
    let norm = |k: usize| {
        (0..u.nrows())
            .map(|i| u[(i, k)] * u[(i, k)])
            .sum::<f64>()
            .sqrt()
    };
    let mut best: Option<(usize, usize, f64)> = None;
    for k in 0..p {
        for l in k + 1..p {
            if owner[k] == owner[l] {
                continue;
            }
            let (nk, nl) = (norm(k), norm(l));
            if nk == 0.0 || nl == 0.0 {
                continue;
            }
            let dot: f64 = (0..u.nrows()).map(|i| u[(i, k)] * u[(i, l)]).sum();
            let cos = (dot / (nk * nl)).abs();
            if best.is_none_or(|b| cos > b.2) {
                best = Some((owner[k], owner[l], cos));
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use crate::gmwm::{GmwmOptions, fit};
    use crate::{AvCurve, FitError};

    /// White noise + random walk, fitted with WN + RW + AR1: the AR1 goes to the boundary;
    /// the message names AR1, the scales, and WN + RW as the smaller model.
    #[test]
    fn a_component_that_contributes_nothing_is_named() {
        let truth: processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse().unwrap();
        let m: Vec<u64> = (1..=12).map(|j| 1u64 << j).collect();
        let av = crate::theory::model_avar(&truth, &m, 100.0).unwrap();
        let curve = AvCurve::from_m(&m, &av, 100.0).unwrap().with_n(100_000);
        let f = fit(
            &curve,
            &"WN + RW + AR1".parse().unwrap(),
            &GmwmOptions::default(),
        )
        .unwrap();
        // the column scaling of the delta method keeps AᵀΩA invertible here (the AR1 CI spans
        // hundreds of decades instead); the diagnosis of a fit is the same either way
        let e = super::unidentifiable(&f);
        match &e {
            FitError::NotIdentifiable {
                components,
                tau_lo,
                tau_hi,
                smaller_model,
                ..
            } => {
                assert_eq!(components, &["AR1".to_string()]);
                assert_eq!((*tau_lo, *tau_hi), (0.02, 40.96));
                assert_eq!(smaller_model.as_deref(), Some("WN + RW"));
            }
            other => panic!("{other:?}"),
        }
        let msg = e.to_string();
        assert!(
            msg.contains("AR1 cannot be identified from the scales τ = 0.02 … 40.96 s"),
            "{msg}"
        );
        assert!(msg.contains("select"), "{msg}");
        assert!(msg.contains("longer record"), "{msg}");
    }
}
