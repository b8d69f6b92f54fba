//! Book Example 2.4: the composite process "2*AR1 + WN",
//! X_t = Y_t + W_t + Q_t with Y, W two AR1 processes and Q a white noise, all independent;
//! only X_t is observed.
//!
//! Simulates the three components and their sum with `simulate_components` and prints, for
//! each, the sample mean, variance and lag-1 autocorrelation next to their theoretical
//! values.
//!
//! Run: `cargo run -p imunoise-processes --example book_example_2_4`

use processes::{Ar1, Model, ProcessError, TimeSeries, WhiteNoise};

const N: usize = 100_000;
const RATE_HZ: f64 = 100.0;
const SEED: u64 = 2024;

fn sample_stats(x: &[f64]) -> (f64, f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
    let c1 = x
        .windows(2)
        .map(|w| (w[0] - mean) * (w[1] - mean))
        .sum::<f64>()
        / n;
    (mean, var, c1 / var)
}

fn report(label: &str, series: &TimeSeries, theory: &Model) -> Result<(), ProcessError> {
    let (mean, var, rho1) = sample_stats(series.values());
    // The total is named by the whole model (printed above); show "sum" instead.
    let name = if series.name() == theory.to_string() && theory.len() > 1 {
        "sum"
    } else {
        series.name()
    };
    println!(
        "{label:<4} {name:<28} mean {mean:>8.4} (0)   var {var:>7.4} ({:>7.4})   rho(1) {rho1:>7.4} ({:>7.4})",
        theory.autocovariance(0, RATE_HZ)?,
        theory.autocorrelation(1, RATE_HZ)?,
    );
    Ok(())
}

fn main() -> Result<(), ProcessError> {
    // Y: AR1(φ1 = 0.99, v1² = 0.01), W: AR1(φ2 = 0.6, v2² = 0.1), Q: WN(σ² = 1).
    let y = Ar1::new(0.99, 0.01)?;
    let w = Ar1::new(0.6, 0.1)?;
    let q = WhiteNoise::new(1.0)?;
    let model = ((y + w)? + q)?;
    println!("model: {model}   (n = {N}, {RATE_HZ} Hz, seed {SEED})");
    println!("sample values, theory in parentheses:");

    let sim = model.simulate_components(N, RATE_HZ, SEED)?;
    for ((label, series), part) in ["Y_t", "W_t", "Q_t"].into_iter().zip(&sim.components).zip([
        Model::from(y),
        Model::from(w),
        Model::from(q),
    ]) {
        report(label, series, &part)?;
    }
    report("X_t", &sim.total, &model)?;

    println!("first samples:");
    println!("   t        Y_t        W_t        Q_t        X_t");
    for t in 0..5 {
        let v: Vec<f64> = sim.components.iter().map(|c| c.values()[t]).collect();
        println!(
            "{:>4} {:>10.4} {:>10.4} {:>10.4} {:>10.4}",
            t + 1,
            v[0],
            v[1],
            v[2],
            sim.total.values()[t]
        );
    }
    Ok(())
}
