//! `cargo xtask fuzz --minutes N [--cases C] [--seed S]`: runs the property suites of
//! `tests/props.rs` (every parser, the estimators' invariants) and the `fuzz_` properties of
//! `tests/logs.rs` (every log reader) with fresh seeds for N minutes and reports the cases tried
//! and the failures per property.
//!
//! The suite is built once in release mode; each round runs every property with C cases
//! (`IMUNOISE_FUZZ_CASES`) at seed S + round (`IMUNOISE_FUZZ_SEED`). A failing round's output
//! (with proptest's minimal failing input) is kept in `target/fuzz/failure-<seed>.txt`; the
//! report goes to stdout and `target/fuzz/report.md`.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;

use crate::args;

/// Runs the task.
pub fn run(rest: &[String]) -> Result<(), String> {
    let minutes: f64 = args::parsed(rest, "--minutes", 1.0)?;
    let cases: u64 = args::parsed(rest, "--cases", 500)?;
    let seed0: u64 = args::parsed(rest, "--seed", 1)?;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .ok_or("no workspace root")?
        .to_path_buf();
    // (test executable, name filter)
    let suites = [
        (build(&root, "props")?, None),
        (build(&root, "logs")?, Some("fuzz_")),
    ];
    let out_dir = root.join("target/fuzz");
    std::fs::create_dir_all(&out_dir).map_err(|e| e.to_string())?;
    let t0 = Instant::now();
    // property → (cases run, failed rounds)
    let mut stats: BTreeMap<String, (u64, u64)> = BTreeMap::new();
    let mut rounds = 0u64;
    let mut failures = Vec::new();
    while t0.elapsed().as_secs_f64() < minutes * 60.0 {
        let seed = seed0 + rounds;
        let (exe, filter) = &suites[rounds as usize % suites.len()];
        let mut cmd = Command::new(exe);
        cmd.env("IMUNOISE_FUZZ_CASES", cases.to_string())
            .env("IMUNOISE_FUZZ_SEED", seed.to_string())
            .args(["--test-threads", "2"]);
        if let Some(f) = filter {
            cmd.arg(f);
        }
        let out = cmd
            .output()
            .map_err(|e| format!("running {}: {e}", exe.display()))?;
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        let mut seen = 0;
        for line in text.lines() {
            let Some(rest) = line.strip_prefix("test ") else {
                continue;
            };
            let Some((name, verdict)) = rest.split_once(" ... ") else {
                continue;
            };
            seen += 1;
            let e = stats.entry(name.to_string()).or_default();
            e.0 += cases;
            if verdict.trim() != "ok" {
                e.1 += 1;
            }
        }
        if seen == 0 {
            return Err(format!(
                "the suite printed no test lines:\n{text}\n{}",
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        if !out.status.success() {
            let f = out_dir.join(format!("failure-{seed}.txt"));
            let all = format!("{text}\n{}", String::from_utf8_lossy(&out.stderr));
            std::fs::write(&f, all).map_err(|e| e.to_string())?;
            failures.push(f);
        }
        rounds += 1;
        eprintln!(
            "round {rounds} (seed {seed}) done at {:.0} s",
            t0.elapsed().as_secs_f64()
        );
    }
    let mut report = format!(
        "# cargo xtask fuzz: {rounds} rounds (alternating tests/props.rs and the fuzz_ properties of tests/logs.rs) of {cases} cases per property in {:.1} min (seeds {seed0}..{})\n\n| property | cases | failed rounds |\n|---|---|---|\n",
        t0.elapsed().as_secs_f64() / 60.0,
        seed0 + rounds
    );
    let (mut total, mut failed) = (0, 0);
    for (name, (n, f)) in &stats {
        report.push_str(&format!("| {name} | {n} | {f} |\n"));
        total += n;
        failed += f;
    }
    report.push_str(&format!(
        "\nTotal: {total} cases, {failed} failed rounds.\n"
    ));
    for f in &failures {
        report.push_str(&format!("Failure output: {}\n", f.display()));
    }
    print!("{report}");
    std::fs::write(out_dir.join("report.md"), &report).map_err(|e| e.to_string())?;
    if failed > 0 {
        return Err(format!("{failed} failed rounds"));
    }
    Ok(())
}

/// Builds the test target `target` in release mode and returns its executable.
fn build(root: &PathBuf, target: &str) -> Result<PathBuf, String> {
    let out = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(root)
        .args([
            "test",
            "--release",
            "-p",
            "imunoise",
            "--test",
            target,
            "--no-run",
            "--message-format=json",
        ])
        .output()
        .map_err(|e| format!("cargo: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "building tests/{target}.rs failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["target"]["name"] == target)
        .find_map(|v| v["executable"].as_str().map(PathBuf::from))
        .ok_or_else(|| format!("no executable for tests/{target}.rs in cargo's output"))
}
