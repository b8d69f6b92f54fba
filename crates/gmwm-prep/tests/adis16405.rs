//! Real data (issue 5 acceptance): QN + WN + RW + AR1 on the ADIS16405 imu1 gyro X
//! (`../shared/data/adis16405/adis16405_imu1.csv.gz`, 100 Hz, °/s). The fit must converge and
//! the J test and the WIC are reported (V = the model covariance of the AV at θ̂,
//! [`gmwm_prep::inference::fit_covariance`]).
//!
//! Finding: with avar's chi-square 95 % CIs that model puts its fitted AV inside the CIs at
//! only 13 of 18 scales: the curve has both a short correlation (AV(2)/AV(4) = 1.78 < 2, which
//! only a positively correlated component reproduces — the AR1 goes there, φ ≈ 0.14) and a
//! bump at τ ≈ 20–330 s that RW cannot produce. This is not an optimizer or weighting problem:
//! the diagonal, model-diagonal and model-full weightings and 32 starts all give 12–13 of 18,
//! and *no* parameter value of QN + WN + RW + AR1 reaches the 17 of 18 scales that ≥ 90 %
//! needs — `cargo run --release -p imunoise-gmwm-prep --example adis_feasibility` minimizes
//! the convex distance to the CIs over the variances for every φ of a grid and every choice
//! of the one scale left out: the smallest distance is > 0 (it is 0 for the 13 scales of the
//! fit, the check of the method). The J test rejects the model. One more AR1
//! (QN + WN + RW + 2*AR1) puts the fitted AV inside at 17 of 18 scales; the ≥ 90 % criterion
//! is asserted for that model.

use flate2::read::GzDecoder;
use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::inference::{delta_method, fit_covariance};
use gmwm_prep::report::FitReport;
use processes::{Model, Unit};
use std::io::{BufRead, BufReader};
use std::path::PathBuf;

/// Acceptance: share of scales whose AV CI contains the fitted AV.
const MIN_INSIDE_SHARE: f64 = 0.90;

fn inside_share(curve: &AvCurve, fitted: &[f64]) -> (usize, f64) {
    let inside = curve
        .points
        .iter()
        .zip(fitted)
        .filter(|(p, v)| p.avar_lo.unwrap() <= **v && **v <= p.avar_hi.unwrap())
        .count();
    (inside, inside as f64 / curve.len() as f64)
}

#[test]
fn adis16405_gyro_x_qn_wn_rw_ar1() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/adis16405/adis16405_imu1.csv.gz");
    if !path.is_file() {
        eprintln!("skipped: {} not found", path.display());
        return;
    }
    let rd = BufReader::new(GzDecoder::new(std::fs::File::open(&path).unwrap()));
    let x: Vec<f64> = rd
        .lines()
        .skip(1)
        .map(|l| l.unwrap().split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(x.len(), 1_000_000);
    let rate = 100.0;
    let av = avar::allan_variance(&x, rate, &avar::AvarConfig::default()).unwrap();
    let curve = AvCurve::from_avar(&av).unwrap();
    let template: Model = "QN + WN + RW + AR1".parse().unwrap();
    let opts = GmwmOptions::default();
    let f = fit(&curve, &template, &opts).unwrap();
    assert!(f.convergence.converged, "{:?}", f.convergence);
    let inside = curve
        .points
        .iter()
        .zip(&f.fitted)
        .filter(|(p, v)| p.avar_lo.unwrap() <= **v && **v <= p.avar_hi.unwrap())
        .count();
    for (p, v) in curve.points.iter().zip(&f.fitted) {
        eprintln!(
            "m = {:>6}  AV = {:.4e}  CI [{:.4e}, {:.4e}]  fitted {:.4e}{}",
            p.m,
            p.avar,
            p.avar_lo.unwrap(),
            p.avar_hi.unwrap(),
            v,
            if p.avar_lo.unwrap() <= *v && *v <= p.avar_hi.unwrap() {
                ""
            } else {
                "  outside"
            }
        );
    }
    let share = inside as f64 / curve.len() as f64;
    let inf = delta_method(&f, &fit_covariance(&f).unwrap(), 0.05).unwrap();
    let report = FitReport::from_gmwm(&f, Some(&inf), &Unit::DegPerSec);
    eprintln!("{}", serde_json::to_string_pretty(&report).unwrap());
    eprintln!(
        "fitted AV inside the 95 % AV CI at {inside}/{} scales; J = {:?}; WIC = {}",
        curve.len(),
        inf.j_test,
        inf.wic
    );
    let j = inf.j_test.unwrap();
    assert!(j.statistic.is_finite() && (0.0..=1.0).contains(&j.p_value));
    // the finding: the J test rejects QN + WN + RW + AR1 at 1 % (measured p ≈ 3e-4)
    assert!(j.p_value < 0.01, "J test no longer rejects: {j:?}");
    assert!(inf.wic.is_finite());
    assert!(
        share < MIN_INSIDE_SHARE,
        "finding above changed: {inside} inside"
    );
    // one more AR1
    let rich: Model = "QN + WN + RW + 2*AR1".parse().unwrap();
    let f2 = fit(&curve, &rich, &opts).unwrap();
    assert!(f2.convergence.converged, "{:?}", f2.convergence);
    let (inside2, share2) = inside_share(&curve, &f2.fitted);
    let inf2 = delta_method(&f2, &fit_covariance(&f2).unwrap(), 0.05).unwrap();
    eprintln!(
        "{}: inside at {inside2}/{} scales; J = {:?}; WIC = {}",
        f2.model,
        curve.len(),
        inf2.j_test,
        inf2.wic
    );
    assert!(
        share2 >= MIN_INSIDE_SHARE,
        "only {inside2}/{} scales inside",
        curve.len()
    );
}
