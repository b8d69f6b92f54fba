//! MA2/ARMA inside a model's simulation: reproducible, the total is the sum of the
//! components, the component is the one `Arma::simulate` draws (exact, stationary start),
//! the serde form round-trips, and the sample autocovariance of a long path matches the
//! exact one.

use processes::{Arma, Model};

#[test]
fn model_with_arma_simulates_as_the_sum_of_its_components() {
    let m: Model =
        "WN(sigma2=1e-3) + ARMA21(phi1=1.6, phi2=-0.8, theta1=0.4, sigma2=1e-4) + RW(gamma2=1e-9) + MA2(theta1=0.5, theta2=0.2, sigma2=1e-4)"
            .parse()
            .unwrap();
    let a = m.simulate_stream(5000, 100.0, 11, 3).unwrap();
    assert_eq!(a, m.simulate_stream(5000, 100.0, 11, 3).unwrap());
    assert_ne!(
        a.values(),
        m.simulate_stream(5000, 100.0, 11, 4).unwrap().values()
    );
    let sim = m.simulate_components_stream(5000, 100.0, 11, 3).unwrap();
    assert_eq!(sim.total, a);
    assert_eq!(sim.components.len(), 4);
    assert_eq!(
        sim.components[1].name(),
        "ARMA21(phi1=1.6, phi2=-0.8, theta1=0.4, sigma2=0.0001)"
    );
    // total = (WN + RW) + ARMA21 + MA2, in that order of addition: exact
    for i in 0..5000 {
        let c: Vec<f64> = sim.components.iter().map(|s| s.values()[i]).collect();
        assert_eq!(a.values()[i], ((c[0] + c[2]) + c[1]) + c[3], "i={i}");
    }
    let only: Model = "MA2(0.3, -0.2, 1)".parse().unwrap();
    assert_eq!(only.simulate(100, 1.0, 1).unwrap().len(), 100);
}

#[test]
fn serde_round_trip() {
    let m: Model = "MA2(theta1=0.5, theta2=-0.2, sigma2=1) + ARMA12(0.5, 0.3, 0.1, 2) + ARMA42"
        .parse()
        .unwrap();
    let json = serde_json::to_string(&m).unwrap();
    assert_eq!(serde_json::from_str::<Model>(&json).unwrap(), m);
}

#[test]
fn sample_autocovariance_matches_the_exact_one() {
    // one path of N = 2^20 per process; the sample autocovariance at lag h has standard
    // error ≈ sqrt(Σ_k γ(k)² (Bartlett) / N) ≤ sqrt(S_abs² / N) where S_abs = Σ|γ(k)|;
    // tolerance 5 such SE (a fixed seed: the check is deterministic)
    const N: usize = 1 << 20;
    for a in [
        Arma::new(&[], &[0.5, 0.25], 2.0).unwrap(),
        Arma::new(&[1.2728, -0.81], &[0.5], 1.0).unwrap(),
        Arma::new(&[-0.6], &[0.3, -0.2], 3.0).unwrap(),
    ] {
        let x = a.simulate(N, 2026).unwrap();
        let g = a.acvf(400);
        let s_abs: f64 = g[0] + 2.0 * g[1..].iter().map(|v| v.abs()).sum::<f64>();
        let se = s_abs * (2.0 / N as f64).sqrt();
        let mean = x.iter().sum::<f64>() / N as f64;
        for h in 0..6 {
            let c: f64 = (0..N - h)
                .map(|t| (x[t] - mean) * (x[t + h] - mean))
                .sum::<f64>()
                / N as f64;
            assert!(
                (c - g[h]).abs() <= 5.0 * se,
                "{a:?} h={h}: sample {c} exact {} (5 SE = {})",
                g[h],
                5.0 * se
            );
        }
        // the stationary start: X_1 has variance γ0 (mean of X_1² over 4000 seeds, 4 SE:
        // Var(X_1²) = 2γ0²)
        let r = 4000;
        let m2: f64 = (0..r)
            .map(|s| a.simulate(1, 10_000 + s as u64).unwrap()[0].powi(2))
            .sum::<f64>()
            / r as f64;
        let se0 = g[0] * (2.0 / r as f64).sqrt();
        assert!(
            (m2 - g[0]).abs() <= 4.0 * se0,
            "{a:?}: E X_1² {m2} vs {}",
            g[0]
        );
    }
}
