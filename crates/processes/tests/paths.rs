//! Acceptance: RW variance at t = n and the DR path match theory; QN's empirical Allan
//! variance at m = 1, 2, 4 matches 3Q²/m². Also: the conventions that moment tests over one
//! long path cannot see (stationary start of AR1/MA1/QN, X_0 = 0 of RW) and the exactness
//! of the chunked recurrences across chunk boundaries.

mod common;
use common::*;
use processes::{CHUNK_LEN, Drift, Model, Process, RandomWalk};

const RATE_HZ: f64 = 50.0;

#[test]
fn drift_path_is_omega_t_exactly() {
    for omega in [2.5e-7, -3.0, 1.0 / 3.0] {
        let model = Model::from(Drift::new(omega).unwrap());
        let n = 2 * CHUNK_LEN + 17; // three chunks, the last partial
        let x = model.simulate(n, RATE_HZ, 1).unwrap();
        for (i, &v) in x.values().iter().enumerate() {
            let t = (i + 1) as f64;
            assert_eq!(v.to_bits(), (omega * t).to_bits(), "omega {omega}, t {t}");
        }
    }
}

#[test]
fn random_walk_variance_grows_as_t_gamma2() {
    // R independent walks (streams 0..R of one seed) of n = L + 2 samples, so each crosses
    // a chunk boundary. X_t ~ N(0, t γ²) exactly, so the mean of X_t² over R walks has
    // SE = t γ² √(2/R) (the mean is known to be 0). R = 4000: 4 SE = 8.9 % of t γ².
    // This separates X_0 = 0 (Var X_1 = γ²) from an off-by-one start (2γ²) and catches a
    // lost carry at the chunk boundary (Var X_{L+1} would be γ²).
    const R: u64 = 4000;
    let gamma2 = 0.04;
    let n = CHUNK_LEN + 2;
    let rw = Process::from(RandomWalk::new(gamma2).unwrap());
    let times = [1, 2, 100, CHUNK_LEN, CHUNK_LEN + 1, n];
    let mut sum_sq = vec![0.0; times.len()];
    let mut buf = vec![0.0; n];
    for r in 0..R {
        buf.iter_mut().for_each(|v| *v = 0.0);
        rw.simulate_into(&mut buf, RATE_HZ, 77, r, 0).unwrap();
        for (s, &t) in sum_sq.iter_mut().zip(&times) {
            *s += buf[t - 1].powi(2);
        }
    }
    for (s, &t) in sum_sq.iter().zip(&times) {
        let var = t as f64 * gamma2;
        let se = var * (2.0 / R as f64).sqrt();
        assert_within(&format!("Var(X_{t})"), s / R as f64, var, se);
    }
    // The theory of the crate agrees.
    assert_eq!(
        rw.variance_at(n as u64, RATE_HZ).unwrap(),
        n as f64 * gamma2
    );
}

#[test]
fn quantization_noise_allan_variance_is_3q2_over_m2() {
    // AV(m) by book eq. 4.2 on R independent series of length T; the SE of the mean of the
    // R estimates is their sample standard deviation / √R (independent replications).
    const R: u64 = 400;
    const T: usize = 5000;
    let q2 = 2e-3;
    let model: Model = format!("QN(q2={q2})").parse().unwrap();
    for m in [1usize, 2, 4] {
        let av: Vec<f64> = (0..R)
            .map(|r| moav(model.simulate_stream(T, RATE_HZ, 5, r).unwrap().values(), m))
            .collect();
        let avg = mean(&av);
        let sd = (av.iter().map(|a| (a - avg).powi(2)).sum::<f64>() / (R - 1) as f64).sqrt();
        let theory = 3.0 * q2 / (m * m) as f64;
        assert_within(
            &format!("QN AV(m={m})"),
            avg,
            theory,
            sd / (R as f64).sqrt(),
        );
    }
}

/// The variance at t = 1 of R independent paths (streams) of a stationary model must be
/// the stationary γ(0): this is what a start at 0 (simts) or without W_0 / U_0 would break.
/// Mean of X_1² over R paths (mean 0 known): SE = √(Var(X²)/R), Var(X²) = (κ − 1) γ(0)²,
/// κ = 3 (Gaussian X_1) or 2.4 (QN: E(U−V)⁴ = 9.6 Q⁴ = 2.4 γ(0)²).
#[test]
fn stationary_processes_start_in_their_stationary_law() {
    const R: u64 = 20_000;
    for (text, kurt) in [
        ("AR1(phi=0.9, sigma2=0.19)", 3.0), // γ(0) = 1 (a start at 0 gives 0.19)
        ("AR1(phi=-0.8, sigma2=0.36)", 3.0), // γ(0) = 1
        ("GM(beta=5, sigma2=2)", 3.0),
        ("MA1(theta=0.8, sigma2=1)", 3.0), // γ(0) = 1.64 (without W_0: 1)
        ("QN(q2=1)", 2.4),                 // γ(0) = 2 (without U_0: 1)
    ] {
        let model: Model = text.parse().unwrap();
        let g0 = gamma(&model, 0, RATE_HZ);
        let mut sum_sq = [0.0; 2];
        for r in 0..R {
            let x = model.simulate_stream(2, RATE_HZ, 11, r).unwrap();
            for (s, v) in sum_sq.iter_mut().zip(x.values()) {
                *s += v * v;
            }
        }
        for (t, s) in sum_sq.iter().enumerate() {
            let se = g0 * ((kurt - 1.0) / R as f64).sqrt();
            assert_within(&format!("{text}: Var(X_{})", t + 1), s / R as f64, g0, se);
        }
    }
}

/// Residuals of the recurrence, Z_t = X_t − φ X_{t−1} (AR1) or X_t − X_{t−1} (RW), must be
/// iid N(0, v²) everywhere, in particular at the first sample of every chunk where the
/// parallel scheme joins the pieces. At the B = 63 boundaries of a 64-chunk path the mean of
/// Z²/v² has SE √(2/B) = 0.18; a lost or wrong carry makes it ≫ 1 (≈ 1 + φ²γ(0)/v² = 50 for
/// φ = 0.99). Across the whole path no |Z| may exceed 7 v (probability 1e-5 per path).
#[test]
fn recurrences_are_exact_across_chunk_boundaries() {
    let n = 64 * CHUNK_LEN;
    for (text, phi, v2) in [
        ("AR1(phi=0.99, sigma2=0.5)", 0.99, 0.5),
        ("AR1(phi=-0.5, sigma2=2)", -0.5, 2.0),
        ("RW(gamma2=0.01)", 1.0, 0.01),
    ] {
        let model: Model = text.parse().unwrap();
        let x = model.simulate(n, RATE_HZ, 21).unwrap();
        let x = x.values();
        let resid = |t: usize| x[t] - phi * x[t - 1];
        let sd = f64::sqrt(v2);
        let worst = (1..n).map(|t| resid(t).abs() / sd).fold(0.0, f64::max);
        assert!(worst < 7.0, "{text}: residual of {worst} sd");
        let boundary: Vec<f64> = (1..64).map(|k| resid(k * CHUNK_LEN).powi(2) / v2).collect();
        assert_within(
            &format!("{text}: boundary residuals"),
            mean(&boundary),
            1.0,
            (2.0 / boundary.len() as f64).sqrt(),
        );
    }
}
