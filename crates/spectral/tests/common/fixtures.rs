// Shared fixtures of the integration tests (included with `mod`).

use processes::{Ar1, Drift, GaussMarkov, Ma1, Process, QuantizationNoise, RandomWalk, WhiteNoise};

/// Sampling rate of the fixtures (Hz).
pub const RATE: f64 = 100.0;

/// m ∈ {1, 2, 3, 4, 7, 8, 16, …, 2^20} (issue 3 acceptance grid).
pub fn m_grid() -> Vec<u64> {
    let mut v = vec![1, 2, 3, 4, 7];
    v.extend((3..=20).map(|j| 1u64 << j));
    v
}

/// Every process kind, with AR1/GM/MA1 parameters spanning the hard cases
/// (φ near ±1, β Δt from 0.1 down to 1e-7, θ = −1).
pub fn fixtures() -> Vec<(String, Process)> {
    let mut v: Vec<Process> = vec![
        WhiteNoise::new(2.5e-3).unwrap().into(),
        QuantizationNoise::new(1.3e-4).unwrap().into(),
        RandomWalk::new(1e-6).unwrap().into(),
        Drift::new(-3e-5).unwrap().into(),
    ];
    for phi in [-0.99999, -0.9, -0.3, 0.0, 0.5, 0.9, 0.995, 0.9999, 0.99999] {
        v.push(Ar1::new(phi, 1e-6).unwrap().into());
    }
    for beta in [10.0, 0.1, 1e-3, 1e-5] {
        v.push(GaussMarkov::new(beta, 4e-6).unwrap().into());
    }
    for theta in [-1.0, -0.5, 0.3, 2.0] {
        v.push(Ma1::new(theta, 1e-4).unwrap().into());
    }
    v.into_iter()
        .map(|p| (format!("{}{:?}", p.kind(), p.params()), p))
        .collect()
}
