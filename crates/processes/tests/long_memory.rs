//! PLP (ARFIMA(0, d, 0)) and FGN (issue 28): validation, the model-string syntax, the exact
//! ACF, and the circulant-embedding simulation (reproducible; nonnegative embedding at the
//! edges of the parameter ranges; sample autocovariances within Monte Carlo error of the
//! exact ones; the total of a model is the sum of its components).

use processes::{Fgn, Model, Plp, Process, ProcessKind};

#[test]
fn validation_and_model_strings() {
    assert!(Plp::new(1.0, 0.5).is_err() && Plp::new(1.0, -0.5).is_err());
    assert!(Plp::new(0.0, 0.1).is_err() && Plp::new(f64::NAN, 0.1).is_err());
    assert!(Fgn::new(1.0, 0.0).is_err() && Fgn::new(1.0, 1.0).is_err());
    assert!(Fgn::new(-1.0, 0.5).is_err());
    let m: Model = "PLP(sigma2=1e-4, d=0.3) + FGN(sigma2=2, H=0.8) + WN(sigma2=1)"
        .parse()
        .unwrap();
    assert_eq!(
        m.kinds(),
        vec![ProcessKind::Plp, ProcessKind::Fgn, ProcessKind::WhiteNoise]
    );
    let back: Model = m.to_string().parse().unwrap();
    assert_eq!(back.to_string(), m.to_string());
    let params: Vec<f64> = m
        .processes()
        .unwrap()
        .iter()
        .flat_map(|p| p.params())
        .collect();
    assert_eq!(params, vec![1e-4, 0.3, 2.0, 0.8, 1.0]);
    // a value out of range is a parse error, naming the parameter
    let e = "PLP(sigma2=1, d=0.7)".parse::<Model>().unwrap_err();
    assert!(e.to_string().contains('d'), "{e}");
    assert!("FGN(sigma2=1, H=1.5)".parse::<Model>().is_err());
    // template slots
    assert_eq!("PLP + WN".parse::<Model>().unwrap().n_params(), 3);
}

#[test]
fn exact_acf() {
    // recursion vs the Gamma-ratio closed form, and ρ(h) ~ Γ(1−d)/Γ(d) h^{2d−1}
    for d in [-0.4, -0.1, 0.2, 0.45] {
        let p = Plp::new(1.0, d).unwrap();
        let r = p.acf(20_001);
        for h in [1u64, 2, 7, 100, 20_000] {
            let c = p.autocorrelation(h);
            // recursion error ≤ 2hε ≈ 4.4e-12 at h = 2·10^4
            assert!((c - r[h as usize]).abs() <= 1e-11 * c.abs(), "d={d} h={h}");
        }
    }
    let p = Plp::new(3.0, 0.0).unwrap();
    assert_eq!(p.variance(), 3.0);
    assert!((1..50).all(|h| p.autocovariance(h) == 0.0));
    // FGN: the binomial series at h ≥ 2 vs the direct second difference (accurate at
    // small h, where it has no cancellation)
    for hh in [0.1, 0.3, 0.7, 0.95] {
        let f = Fgn::new(2.0, hh).unwrap();
        let a = 2.0 * hh;
        for h in 2u64..12 {
            let x = h as f64;
            let direct = (x + 1.0).powf(a) - 2.0 * x.powf(a) + (x - 1.0).powf(a);
            assert!(
                (f.autocovariance(h) - direct).abs() <= 1e-12,
                "H={hh} h={h}"
            );
        }
        // Σ_{|h|<n} γ(h) = Var(sum of n) = σ² n^{2H} (fBm), n = 64
        let n = 64u64;
        let s: f64 = n as f64 * f.autocovariance(0)
            + 2.0
                * (1..n)
                    .map(|h| (n - h) as f64 * f.autocovariance(h))
                    .sum::<f64>();
        let want = 2.0 * (n as f64).powf(a);
        assert!((s - want).abs() <= 1e-12 * want, "H={hh}: {s} vs {want}");
    }
}

#[test]
fn embedding_is_nonnegative_at_the_edges() {
    // Davies–Harte needs every eigenvalue of the circulant ≥ 0: true for these processes
    // (an error would be returned otherwise); checked at the ends of the ranges and sizes
    for n in [1usize, 2, 3, 1000, 1 << 16] {
        for d in [-0.49, -0.25, 0.0, 0.25, 0.49] {
            let x = Plp::new(1.0, d).unwrap().simulate(n, 5).unwrap();
            assert_eq!(x.len(), n);
            assert!(x.iter().all(|v| v.is_finite()));
        }
        for h in [0.01, 0.25, 0.5, 0.75, 0.99] {
            let x = Fgn::new(1.0, h).unwrap().simulate(n, 5).unwrap();
            assert_eq!(x.len(), n);
        }
    }
    assert!(Plp::new(1.0, 0.1).unwrap().simulate(0, 1).is_err());
}

fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1.0);
    (m, v.sqrt())
}

#[test]
fn sample_autocovariance_matches_the_exact_one() {
    // R = 200 paths of n = 4096 through Model::simulate_stream (stream r, seed 2028);
    // γ̂(h) = Σ x_t x_{t+h}/(n − h) is unbiased (known zero mean), so the mean over the
    // replicates is within 3 Monte Carlo SE of γ(h) (normal to good approximation with
    // R = 200 independent replicates; 3 SE: two-sided 0.27 % per check)
    const N: usize = 4096;
    const R: u64 = 200;
    let lags = [0usize, 1, 2, 10, 100];
    let cases: [(Process, &str); 3] = [
        (Plp::new(1.0, 0.3).unwrap().into(), "PLP(d=0.3)"),
        (Plp::new(1.0, -0.3).unwrap().into(), "PLP(d=-0.3)"),
        (Fgn::new(1.0, 0.85).unwrap().into(), "FGN(H=0.85)"),
    ];
    for (p, name) in cases {
        let model = Model::from(p);
        let mut est = vec![Vec::new(); lags.len()];
        for r in 0..R {
            let x = model
                .simulate_stream(N, 1.0, 2028, r)
                .unwrap()
                .into_values();
            for (k, &h) in lags.iter().enumerate() {
                let s: f64 = (0..N - h).map(|t| x[t] * x[t + h]).sum();
                est[k].push(s / (N - h) as f64);
            }
        }
        for (k, &h) in lags.iter().enumerate() {
            let want = p.autocovariance(h as u64, 1.0).unwrap();
            let (m, sd) = mean_sd(&est[k]);
            let z = (m - want) / (sd / (R as f64).sqrt());
            eprintln!("{name} h={h}: mean {m:.5} exact {want:.5} z {z:+.2}");
            assert!(z.abs() <= 3.0, "{name} h={h}: z = {z}");
        }
    }
}

#[test]
fn model_total_is_the_sum_of_components() {
    let m: Model = "WN(sigma2=1) + PLP(sigma2=0.5, d=0.2) + FGN(sigma2=0.3, H=0.7)"
        .parse()
        .unwrap();
    let a = m.simulate_stream(3000, 10.0, 4, 1).unwrap();
    assert_eq!(a, m.simulate_stream(3000, 10.0, 4, 1).unwrap());
    assert_ne!(
        a.values(),
        m.simulate_stream(3000, 10.0, 4, 2).unwrap().values()
    );
    let sim = m.simulate_components_stream(3000, 10.0, 4, 1).unwrap();
    assert_eq!(sim.total, a);
    // WN through the chunked engine first, then PLP and FGN added in model order
    for i in 0..3000 {
        let c: Vec<f64> = sim.components.iter().map(|s| s.values()[i]).collect();
        assert_eq!(a.values()[i], (c[0] + c[1]) + c[2], "i={i}");
    }
}
