//! The book's eq. (4.3) for white noise: log AD(τ_j) = log σ − ½ log τ_j (τ_j in samples),
//! i.e. slope −1/2 and intercept log σ in log-log, for each of the three routes to the AV
//! (closed form, Lemma 4.2, Lemma 4.1 quadrature) and for the MOAV-free empirical route
//! (Lemma 4.2 on the FFT autocovariance of a simulated series, with a tolerance from its SE).

use processes::{Model, Process, WhiteNoise};
use spectral::tolerances::{MC_LOG_AD_ABS, QUADRATURE_REL, SUM_REL};
use spectral::{
    allan_variance, allan_variance_from_acv, empirical, lemma42_allan_variance,
    quadrature_allan_variance,
};

/// Least-squares line y = b0 + b1 x.
fn fit(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    let b1 = sxy / sxx;
    (my - b1 * mx, b1)
}

#[test]
fn white_noise_log_ad_has_slope_minus_half_and_intercept_log_sigma() {
    let sigma2: f64 = 3.7e-5;
    let p = Process::from(WhiteNoise::new(sigma2).unwrap());
    let js: Vec<u32> = (1..=20).collect();
    let logtau: Vec<f64> = js.iter().map(|&j| (2f64.powi(j as i32)).ln()).collect();
    type Route = fn(&Process, u64, f64) -> spectral::Result<f64>;
    let routes: [(&str, Route, f64); 3] = [
        ("closed form", allan_variance, SUM_REL),
        ("Lemma 4.2", lemma42_allan_variance, SUM_REL),
        ("Lemma 4.1", quadrature_allan_variance, QUADRATURE_REL),
    ];
    for (name, av, tol) in routes {
        let logad: Vec<f64> = js
            .iter()
            .map(|&j| 0.5 * av(&p, 1u64 << j, 1.0).unwrap().ln())
            .collect();
        let (b0, b1) = fit(&logtau, &logad);
        // log AD error δ = ½ relative AV error; slope/intercept inherit it.
        assert!((b1 + 0.5).abs() <= tol, "{name}: slope {b1}");
        assert!(
            (b0 - 0.5 * sigma2.ln()).abs() <= tol,
            "{name}: intercept {b0} vs {}",
            0.5 * sigma2.ln()
        );
    }
}

#[test]
fn white_noise_identity_on_a_simulated_series() {
    // 2^20 samples of WN; AV by Lemma 4.2 on the FFT autocovariance at m = 2..2^6.
    let sigma2: f64 = 2.0;
    let model = Model::from(Process::from(WhiteNoise::new(sigma2).unwrap()));
    let x = model
        .simulate(1 << 20, 1.0, 20261121)
        .unwrap()
        .into_values();
    let js: Vec<u32> = (1..=6).collect();
    let acv = empirical::autocovariance(&x, 2 << 6).unwrap();
    let logtau: Vec<f64> = js.iter().map(|&j| (2f64.powi(j as i32)).ln()).collect();
    let logad: Vec<f64> = js
        .iter()
        .map(|&j| 0.5 * allan_variance_from_acv(&acv, 1u64 << j).unwrap().ln())
        .collect();
    let (b0, b1) = fit(&logtau, &logad);
    // tolerance from the SE of the AV estimates (see MC_LOG_AD_ABS)
    assert!((b1 + 0.5).abs() <= MC_LOG_AD_ABS, "slope {b1}");
    assert!(
        (b0 - 0.5 * sigma2.ln()).abs() <= MC_LOG_AD_ABS,
        "intercept {b0}"
    );
}
