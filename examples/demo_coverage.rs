//! Monte Carlo check of the intervals `imunoise demo` prints: run the demo's whole pipeline
//! (simulate the 6-axis IMU, Allan variance, GMWM fit of WN + RW + AR1, delta-method CIs) for
//! seeds 1…S and count how often the true parameters are covered.
//!
//! Expected, if the intervals are honest: each marginal 95% CI covers its parameter in about
//! 95% of the 24·S cases (standard error about √(0.95·0.05/(24·S)) if the parameters were
//! independent, more since they are not), and all 24 simultaneous (Bonferroni) intervals
//! cover together in at least 95% of the S seeds.
//!
//! Run with `cargo run --release --example demo_coverage -- [SEEDS [BOOTSTRAP [SAMPLES]]]`
//! (defaults 20, 0 and 2^20; BOOTSTRAP > 0 uses the parametric-bootstrap covariance instead of
//! the model-implied one). Seeds 1…40 take about 1 s each with BOOTSTRAP = 0.

use imunoise::cli::{Ui, demo};
use std::collections::BTreeMap;

fn arg<T: std::str::FromStr>(i: usize, default: T) -> Result<T, String> {
    match std::env::args().nth(i) {
        Some(s) => s
            .parse()
            .map_err(|_| format!("argument {i}: {s:?} is not a number")),
        None => Ok(default),
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: u64 = arg(1, 20)?;
    let bootstrap: usize = arg(2, 0)?;
    let n: usize = arg(3, 1 << 20)?;
    let ui = Ui {
        progress: false,
        notes: false,
    };
    let (mut all_sim, mut all_marg) = (0, 0);
    let (mut cov_sim, mut cov_marg, mut total) = (0, 0, 0);
    let mut misses: BTreeMap<String, usize> = BTreeMap::new();
    let mut k = 0;
    for seed in 1..=seeds {
        let run = demo::estimate(n, seed, bootstrap, &ui)?;
        k = run.k;
        let (s, sn) = demo::count_covered(&run.params, true);
        let (m, mn) = demo::count_covered(&run.params, false);
        all_sim += usize::from(s == sn && sn == run.k);
        all_marg += usize::from(m == mn && mn == run.k);
        cov_sim += s;
        cov_marg += m;
        total += mn;
        for c in run.params.iter().filter(|c| c.covered() == Some(false)) {
            *misses.entry(c.parameter.clone()).or_default() += 1;
        }
        eprintln!("seed {seed}: simultaneous {s}/{sn}, marginal {m}/{mn}");
    }
    let total = total.max(1);
    println!(
        "{seeds} seeds, n = {n}, {}:",
        if bootstrap > 0 {
            format!("V from a {bootstrap}-replicate bootstrap")
        } else {
            "V model-implied".to_string()
        }
    );
    println!(
        "  all {k} inside the simultaneous intervals: {all_sim}/{seeds}; inside the marginal CIs: {all_marg}/{seeds}"
    );
    println!(
        "  per parameter: marginal {cov_marg}/{total} = {:.3}, simultaneous {cov_sim}/{total} = {:.3}",
        cov_marg as f64 / total as f64,
        cov_sim as f64 / total as f64
    );
    println!("  marginal misses by parameter: {misses:?}");
    Ok(())
}
