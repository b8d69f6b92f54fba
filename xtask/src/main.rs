//! Repository chores: `cargo xtask <task>`. Reports that are too slow for `cargo test`
//! (Monte Carlo coverage, speed comparisons with peer tools) live here.
//!
//! Each task lives in its own module; `main` only dispatches.

use std::process::ExitCode;

mod args;
mod avar_coverage;
mod avar_e2e;
mod avar_speed;
mod fuzz;
mod gmwm_report;
mod libfuzzer;
mod robust_report;
mod sim_scaling;
mod spectral_report;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let task = args.first().map(String::as_str).unwrap_or("help");
    let rest = &args[args.len().min(1)..];
    let result: Result<(), String> = match task {
        // tasks: one arm each (keep this list sorted)
        "avar-coverage" => avar_coverage::run(rest),
        "avar-speed" => avar_speed::run(rest),
        "fuzz" if rest.iter().any(|a| a == "--coverage") => libfuzzer::run(rest),
        "fuzz" => fuzz::run(rest),
        "gmwm-mc" => gmwm_report::run(rest),
        "robust-mc" => robust_report::run(rest),
        "sim-scaling" => sim_scaling::run(rest),
        "spectral-table" => spectral_report::run(rest),
        "help" | "--help" | "-h" => {
            println!("usage: cargo xtask <task> [args]\n\ntasks:");
            for (name, what) in TASKS {
                println!("  {name:<24} {what}");
            }
            Ok(())
        }
        other => Err(format!("unknown task {other:?}; run `cargo xtask help`")),
    };
    let _ = rest;
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Task names and one-line descriptions, for `cargo xtask help`.
const TASKS: &[(&str, &str)] = &[
    // ("name", "description"),
    (
        "avar-coverage",
        "Monte Carlo coverage of the avar CIs (WN, RW, AR1; all three families)",
    ),
    (
        "avar-speed",
        "MOAV speed: avar vs one pass vs allantools oadev (venv in target/venv)",
    ),
    (
        "fuzz",
        "property suites (tests/props.rs) with fresh seeds for --minutes N; cases per property; with --coverage: cargo-fuzz (libFuzzer) on each reader, --minutes N each [--target NAME] [--jobs K targets at a time] [--no-seeds] [--no-replay: skip the one-by-one replay of each corpus] [--replay-only: no fuzzing run, only that replay] [--no-line-coverage]",
    ),
    (
        "gmwm-mc",
        "Monte Carlo bias/RMSE/coverage of the GMWM vs AVLR (issue 5) and bootstrap speed",
    ),
    (
        "robust-mc",
        "Monte Carlo of the robust GMWM (clean / 0.5 % outliers) and the two-recording equality test (issue 15)",
    ),
    (
        "spectral-table",
        "spectral: closed form vs Lemma 4.2 vs Lemma 4.1 quadrature table (README)",
    ),
];
