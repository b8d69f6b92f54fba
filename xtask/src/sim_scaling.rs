//! `cargo xtask sim-scaling [--n N] [--runs R]`: thread scaling of the simulation (issue 2).
//!
//! Times `Model::simulate` (which allocates a fresh output buffer) and
//! `Process::simulate_into` (into a reused, already touched buffer) for WN and for the
//! composite WN + RW + AR1 + QN, on rayon pools of 1 and 2 threads. It reports the best of R runs,
//! because timing noise on a shared VM only ever adds time. Default n = 10^8 (800 MB per buffer).

use crate::args::parsed;
use processes::{Model, Process};
use std::time::Instant;

/// Best-of-`runs` wall time in seconds of `f`.
fn best_of(runs: usize, mut f: impl FnMut()) -> f64 {
    (0..runs)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Runs the report.
pub fn run(args: &[String]) -> Result<(), String> {
    let n = parsed(args, "--n", 100_000_000usize)?;
    let runs = parsed(args, "--runs", 5usize)?.max(1);
    let rate = 100.0;
    let cases = [
        ("WN", "WN(sigma2=1)"),
        (
            "WN+RW+AR1+QN",
            "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.995, sigma2=1e-7) + QN(q2=1e-6)",
        ),
    ];
    println!("| case | n | what | 1 thread | 2 threads | speed-up |");
    println!("|---|---|---|---|---|---|");
    for (name, text) in cases {
        let model: Model = text.parse().map_err(|e| format!("{e}"))?;
        let procs: Vec<Process> = model.processes().map_err(|e| format!("{e}"))?;
        let mut fresh = [0.0; 2];
        let mut reused = [0.0; 2];
        let mut buf = vec![0.0; n];
        for (slot, threads) in [1usize, 2].into_iter().enumerate() {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .map_err(|e| e.to_string())?;
            let mut err = None;
            fresh[slot] = best_of(runs, || {
                if let Err(e) = pool.install(|| model.simulate(n, rate, 1)) {
                    err = Some(e.to_string());
                }
            });
            reused[slot] = best_of(runs, || {
                buf.iter_mut().for_each(|x| *x = 0.0);
                for (c, p) in procs.iter().enumerate() {
                    if let Err(e) = pool.install(|| p.simulate_into(&mut buf, rate, 1, 0, c)) {
                        err = Some(e.to_string());
                    }
                }
            });
            if let Some(e) = err {
                return Err(e);
            }
        }
        for (what, t) in [
            ("simulate (fresh buffer)", fresh),
            ("simulate_into (reused buffer, incl. re-zeroing)", reused),
        ] {
            println!(
                "| {name} | {n} | {what} | {:.1} ms | {:.1} ms | {:.2}× |",
                t[0] * 1e3,
                t[1] * 1e3,
                t[0] / t[1]
            );
        }
    }
    Ok(())
}
