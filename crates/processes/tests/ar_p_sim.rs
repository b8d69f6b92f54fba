//! AR(p) inside a model's simulation: reproducible, the total is the sum of the components,
//! and the AR component is the one `ArP::simulate` draws (exact, stationary start).

use processes::Model;

#[test]
fn model_with_ar2_simulates_as_the_sum_of_its_components() {
    let m: Model = "WN(sigma2=1e-3) + AR2(phi1=1.6, phi2=-0.8, sigma2=1e-4) + RW(gamma2=1e-9)"
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
    assert_eq!(sim.components.len(), 3);
    assert_eq!(
        sim.components[1].name(),
        "AR2(phi1=1.6, phi2=-0.8, sigma2=0.0001)"
    );
    // total = (WN + RW) + AR2, in that order of addition: exact
    for i in 0..5000 {
        let c: Vec<f64> = sim.components.iter().map(|s| s.values()[i]).collect();
        assert_eq!(a.values()[i], (c[0] + c[2]) + c[1], "i={i}");
    }
    // an AR-only model works too
    let only: Model = "AR3(0.2, -0.1, 0.4, 1)".parse().unwrap();
    assert_eq!(only.simulate(100, 1.0, 1).unwrap().len(), 100);
}
