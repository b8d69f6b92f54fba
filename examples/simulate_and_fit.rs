//! Library use of the whole stack without the command: simulate a gyro with known noise,
//! estimate its Allan variance with CIs, fit a GMWM model and print true against estimated.
//!
//! Run with `cargo run --release --example simulate_and_fit`.

use imunoise::avar::{AvarConfig, allan_variance};
use imunoise::gmwm_prep::AvCurve;
use imunoise::gmwm_prep::gmwm::{GmwmOptions, fit};
use imunoise::gmwm_prep::inference::{delta_method, fit_covariance};
use imunoise::processes::Model;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let rate = 100.0;
    let truth: Model =
        "WN(sigma2=2.5e-3) + RW(gamma2=8e-12) + AR1(phi=0.999, sigma2=8e-9)".parse()?;
    let x = truth.simulate(1 << 20, rate, 42)?;
    let av = allan_variance(x.values(), rate, &AvarConfig::default())?;
    let curve = AvCurve::from_avar(&av)?;
    let f = fit(&curve, &truth.template(), &GmwmOptions::default())?;
    // V = the exact covariance of the AV estimates under the fitted model: it accounts for the
    // correlation between scales (the diagonal one would not, and gives too-narrow CIs).
    let inf = delta_method(&f, &fit_covariance(&f)?, 0.05)?;
    let true_params: Vec<f64> = truth.processes()?.iter().flat_map(|p| p.params()).collect();
    println!("{:>12} {:>12} {:>28}", "true", "estimate", "95% CI");
    for (i, t) in true_params.iter().enumerate() {
        println!(
            "{t:>12.4e} {:>12.4e}   [{:.4e}, {:.4e}]",
            f.theta[i], inf.ci[i].0, inf.ci[i].1
        );
    }
    Ok(())
}
