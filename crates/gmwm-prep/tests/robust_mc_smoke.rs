//! Small-R smoke version of `cargo xtask robust-mc` (the full Monte Carlo and its report are
//! in `crates/gmwm-prep/robust-mc-report.md`): WN(σ² = 1e-4) + RW(γ² = 1e-10) +
//! AR1(φ = 0.995, σ² = 1e-7) at 100 Hz, T = 2^17, R = 6, fixed seed.
//!
//! - Clean: the robust WN σ² has mean within 3 MC SE (sd/√R) of the truth.
//! - With 0.5 % additive outliers of ±20σ_WN: the classical WN σ² is biased upward by about
//!   ε·(20σ)²/σ² = 2 (×3; the outliers are white), the robust one stays within 15 % of the
//!   truth (measured at T = 10^6: −8.6 %, because the spikes are rejected only at the scales
//!   m ≤ 10 where 20σ/m exceeds c·σ_D), so its RMSE is below half the classical one.

use avar::AvarConfig;
use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::robust::fit_robust;
use processes::Model;

/// splitmix64: positions and signs of the outliers.
fn next(s: &mut u64) -> u64 {
    *s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *s;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[test]
fn robust_fit_smoke_monte_carlo() {
    let truth: Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.995, sigma2=1e-7)"
        .parse()
        .unwrap();
    let t: Model = "WN + RW + AR1".parse().unwrap();
    let opts = GmwmOptions::default();
    let (r, n) = (6, 1usize << 17);
    let mut clean = Vec::new();
    let mut cont_rob = Vec::new();
    let mut cont_cl = Vec::new();
    for k in 0..r {
        let mut x = truth
            .simulate_stream(n, 100.0, 15, k)
            .unwrap()
            .into_values();
        let f = fit_robust(&x, 100.0, &AvarConfig::default(), &t, &opts).unwrap();
        clean.push(f.fit.theta[0]);
        let mut s = 100 + k;
        let thr = (0.005 * u64::MAX as f64) as u64;
        for v in x.iter_mut() {
            if next(&mut s) < thr {
                *v += if next(&mut s) & 1 == 0 { 0.2 } else { -0.2 };
            }
        }
        let f = fit_robust(&x, 100.0, &AvarConfig::default(), &t, &opts).unwrap();
        cont_rob.push(f.fit.theta[0]);
        let av = avar::allan_variance(&x, 100.0, &AvarConfig::default()).unwrap();
        let c = fit(&AvCurve::from_avar(&av).unwrap(), &t, &opts).unwrap();
        cont_cl.push(c.theta[0]);
    }
    let rf = r as f64;
    let mean = clean.iter().sum::<f64>() / rf;
    let sd = (clean.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (rf - 1.0)).sqrt();
    assert!(
        (mean - 1e-4).abs() < 3.0 * sd / rf.sqrt(),
        "{mean} ± {}",
        sd / rf.sqrt()
    );
    let rmse = |v: &[f64]| (v.iter().map(|x| (x - 1e-4).powi(2)).sum::<f64>() / rf).sqrt();
    eprintln!("contaminated WN σ²: robust {cont_rob:?}\nclassical {cont_cl:?}");
    for v in &cont_rob {
        assert!((v / 1e-4 - 1.0).abs() < 0.15, "{v}");
    }
    for v in &cont_cl {
        assert!(*v > 2.5e-4, "{v}");
    }
    assert!(rmse(&cont_rob) < 0.5 * rmse(&cont_cl));
}
