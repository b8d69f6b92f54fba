//! PLP (ARFIMA(0, d, 0)) and FGN (issue 28) through simulation and the GMWM:
//! - the mean of simulated Allan variances (MOAV, unbiased for a stationary process) equals
//!   the theory within 3 standard errors at every scale (R = 200, T = 2^14, fixed seeds);
//! - the GMWM recovers PLP + WN and FGN + WN from their exact theoretical curves, starting
//!   d / H from the curve's log-log slope.

mod common;

use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::theory::model_avar;
use processes::Model;

const RATE: f64 = 100.0;

#[test]
fn mean_simulated_av_matches_the_theory() {
    const N: usize = 1 << 14;
    const R: u64 = 200;
    for spec in [
        "PLP(sigma2=1, d=0.3)",
        "PLP(sigma2=1, d=-0.3)",
        "FGN(sigma2=1, H=0.8)",
    ] {
        let model: Model = spec.parse().unwrap();
        let (ms, per_scale) = common::simulated_avs(R, RATE, |r| {
            model
                .simulate_stream(N, RATE, 31, r)
                .unwrap()
                .values()
                .to_vec()
        });
        // 3 SE: the mean of R independent AVs is close to normal at every scale
        let theory = model_avar(&model, &ms, RATE).unwrap();
        common::mean_within_3_se(spec, &ms, &per_scale, &theory);
    }
}

fn recovers(truth: &str, template: &str, t: &[f64]) {
    let model: Model = truth.parse().unwrap();
    let m: Vec<u64> = (0..18).map(|j| 1u64 << j).collect();
    let av = model_avar(&model, &m, RATE).unwrap();
    let curve = AvCurve::from_m(&m, &av, RATE).unwrap().with_n(1 << 20);
    let f = fit(&curve, &template.parse().unwrap(), &GmwmOptions::default()).unwrap();
    eprintln!("{truth}: theta {:?}", f.theta);
    for (i, (est, tr)) in f.theta.iter().zip(t).enumerate() {
        // exact curve: the minimum is the truth (1e-6 relative)
        assert!(
            (est - tr).abs() <= 1e-6 * tr.abs(),
            "{truth} param {i}: {est} vs {tr}"
        );
    }
}

#[test]
fn gmwm_recovers_plp_wn_from_its_theoretical_curve() {
    recovers(
        "PLP(sigma2=1e-4, d=0.3) + WN(sigma2=1e-4)",
        "PLP + WN",
        &[1e-4, 0.3, 1e-4],
    );
    recovers(
        "PLP(sigma2=2e-6, d=-0.25) + RW(gamma2=1e-12)",
        "PLP + RW",
        &[2e-6, -0.25, 1e-12],
    );
}

#[test]
fn gmwm_recovers_fgn_wn_from_its_theoretical_curve() {
    recovers(
        "FGN(sigma2=1e-4, H=0.85) + WN(sigma2=1e-3)",
        "FGN + WN",
        &[1e-4, 0.85, 1e-3],
    );
}
