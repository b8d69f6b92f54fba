//! AR(p) (issue 28) through simulation and the GMWM:
//! - the mean of simulated Allan variances of an AR(2) with complex roots equals the theory
//!   within 3 standard errors at every scale;
//! - the GMWM recovers AR2 + WN exactly from its theoretical curve and without bias beyond
//!   2.5 Monte Carlo standard errors from R = 20 simulated records of T = 10^5.
//!
//! Fixed seeds throughout. AR(p) paths come from `ArP::simulate` (exact, stationary start),
//! which `Model::simulate_stream` calls for AR(p) components.

mod common;

use avar::{AvarConfig, allan_variance};
use common::mean_sd;
use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::theory::model_avar;
use processes::{ArP, Model};

const RATE: f64 = 100.0;

#[test]
fn mean_simulated_av_matches_the_theory() {
    const N: usize = 1 << 14;
    const R: u64 = 200;
    let a = ArP::new(&[1.6, -0.8], 1.0).unwrap();
    let model = Model::from(processes::Process::from(a));
    let (ms, per_scale) = common::simulated_avs(R, RATE, |r| a.simulate(N, 9000 + r).unwrap());
    // 3 SE: the mean of R independent AVs is close to normal at every scale
    let theory = model_avar(&model, &ms, RATE).unwrap();
    common::mean_within_3_se("", &ms, &per_scale, &theory);
}

fn truth() -> (Model, [f64; 4]) {
    let t = [1.6, -0.8, 1e-4, 1e-3];
    let m: Model = format!(
        "AR2(phi1={}, phi2={}, sigma2={}) + WN(sigma2={})",
        t[0], t[1], t[2], t[3]
    )
    .parse()
    .unwrap();
    (m, t)
}

#[test]
fn gmwm_recovers_ar2_wn_from_its_theoretical_curve() {
    let (model, t) = truth();
    let m: Vec<u64> = (0..16).map(|j| 1u64 << j).collect();
    let av = model_avar(&model, &m, RATE).unwrap();
    let curve = AvCurve::from_m(&m, &av, RATE).unwrap().with_n(1 << 20);
    let f = fit(
        &curve,
        &"AR2 + WN".parse().unwrap(),
        &GmwmOptions::default(),
    )
    .unwrap();
    eprintln!("theta {:?}", f.theta);
    for (i, (est, tr)) in f.theta.iter().zip(t).enumerate() {
        // exact curve: the minimum is the truth (1e-6 relative)
        assert!(
            (est - tr).abs() <= 1e-6 * tr.abs(),
            "param {i}: {est} vs {tr}"
        );
    }
}

#[test]
fn gmwm_recovers_ar2_wn_monte_carlo() {
    const N: usize = 100_000;
    const R: u64 = 20;
    let (model, t) = truth();
    let template: Model = "AR2 + WN".parse().unwrap();
    let mut est: Vec<[f64; 4]> = Vec::new();
    for r in 0..R {
        let x = model.simulate_stream(N, RATE, 777, r).unwrap();
        let av = allan_variance(x.values(), RATE, &AvarConfig::default()).unwrap();
        let f = fit(
            &AvCurve::from_avar(&av).unwrap(),
            &template,
            &GmwmOptions::default(),
        )
        .unwrap();
        est.push([f.theta[0], f.theta[1], f.theta[2], f.theta[3]]);
    }
    for (i, name) in ["phi1", "phi2", "sigma2", "wn sigma2"].iter().enumerate() {
        let col: Vec<f64> = est.iter().map(|e| e[i]).collect();
        let (m, sd) = mean_sd(&col);
        let se = sd / (R as f64).sqrt();
        eprintln!(
            "{name}: truth {:e}, mean {m:e}, sd {sd:e}, (mean − truth)/SE {:+.2}",
            t[i],
            (m - t[i]) / se
        );
        // unbiased within 2.5 Monte Carlo standard errors (R = 20)
        assert!(
            (m - t[i]).abs() <= 2.5 * se,
            "{name}: mean {m} vs {} (SE {se})",
            t[i]
        );
    }
}
