//! MA2 and ARMA(p, q) (issue 28) through simulation and the GMWM:
//! - the mean of simulated Allan variances equals the theory within 3 standard errors at
//!   every scale (R = 200 paths of N = 2^14, fixed seeds);
//! - the GMWM recovers ARMA21 + WN and MA2 + RW from their theoretical curves (the exact
//!   curve's minimum is the truth).
//!
//! Paths come from `Arma::simulate` (exact, stationary start), which
//! `Model::simulate_stream` calls for MA2/ARMA components.

mod common;

use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::theory::model_avar;
use processes::{Arma, Model};

const RATE: f64 = 100.0;

#[test]
fn mean_simulated_av_matches_the_theory() {
    const N: usize = 1 << 14;
    const R: u64 = 200;
    for (k, a) in [
        Arma::new(&[], &[0.5, 0.25], 1.0).unwrap(),
        Arma::new(&[1.2728, -0.81], &[0.5], 1.0).unwrap(),
        Arma::new(&[0.9], &[-0.5, 0.3], 1.0).unwrap(),
    ]
    .into_iter()
    .enumerate()
    {
        let model = Model::from(processes::Process::from(a));
        let (ms, per_scale) = common::simulated_avs(R, RATE, |r| {
            a.simulate(N, 5000 * (k as u64 + 1) + r).unwrap()
        });
        // 3 SE: the mean of R independent AVs is close to normal at every scale
        let theory = model_avar(&model, &ms, RATE).unwrap();
        common::mean_within_3_se(&format!("{a:?}"), &ms, &per_scale, &theory);
    }
}

fn recover(truth: &str, template: &str) {
    let model: Model = truth.parse().unwrap();
    let t: Vec<f64> = model
        .processes()
        .unwrap()
        .iter()
        .flat_map(|p| p.params())
        .collect();
    let m: Vec<u64> = (0..16).map(|j| 1u64 << j).collect();
    let av = model_avar(&model, &m, RATE).unwrap();
    let curve = AvCurve::from_m(&m, &av, RATE).unwrap().with_n(1 << 20);
    let f = fit(&curve, &template.parse().unwrap(), &GmwmOptions::default()).unwrap();
    eprintln!("{truth}: theta {:?}", f.theta);
    for (i, (est, tr)) in f.theta.iter().zip(&t).enumerate() {
        // exact curve: the minimum is the truth (1e-6 relative)
        assert!(
            (est - tr).abs() <= 1e-6 * tr.abs(),
            "{truth}: param {i}: {est} vs {tr}"
        );
    }
}

#[test]
fn gmwm_recovers_arma21_wn_from_its_theoretical_curve() {
    recover(
        "ARMA21(phi1=1.6, phi2=-0.8, theta1=0.5, sigma2=1e-4) + WN(sigma2=1e-3)",
        "ARMA21 + WN",
    );
}

#[test]
fn gmwm_recovers_ma2_rw_from_its_theoretical_curve() {
    recover(
        "MA2(theta1=0.6, theta2=-0.3, sigma2=1e-3) + RW(gamma2=1e-9)",
        "MA2 + RW",
    );
}
