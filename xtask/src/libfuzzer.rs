//! `cargo xtask fuzz --coverage --minutes N [--target NAME[,NAME…]] [--jobs K] [--no-line-coverage]`:
//! coverage-guided fuzzing of the readers with cargo-fuzz (libFuzzer) on the nightly toolchain.
//!
//! 1. cargo-fuzz comes from `scripts/fuzz-setup.sh` (into `target/tools`, with the nightly
//!    llvm-tools when they can be had).
//! 2. The seed corpora are written from the fixtures of `tests/logs.rs` (its ignored test
//!    `write_fuzz_seeds`) into `target/fuzz/seeds/<target>/`.
//! 3. The targets of `fuzz/` are built once (`cargo +nightly fuzz build --debug-assertions`,
//!    AddressSanitizer), then run K at a time (`--jobs`, default 1), N minutes each, one
//!    process per target (`-timeout=1 -rss_limit_mb=1024 -malloc_limit_mb=1024`): a panic, an abort, an input that
//!    takes more than 1 s or an allocation over 1 GiB is a finding, kept in
//!    `target/fuzz/artifacts/<target>/`. The corpus grows in `target/fuzz/corpus/<target>/`
//!    from run to run; each run's libFuzzer output is in `target/fuzz-logs/<target>.log`.
//! 4. Unless `--no-line-coverage`, `cargo fuzz coverage` replays each corpus through an
//!    instrumented build and `llvm-cov report` gives the line coverage of the reader's source
//!    file (when the llvm-tools are there; otherwise the report says so).
//!
//! The table (runs, corpus files, libFuzzer's final `cov:`/`ft:`, line coverage, findings) goes
//! to stdout and `target/fuzz-report.md`.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use crate::args;

/// The fuzz targets (fuzz/fuzz_targets/<name>.rs) and the source file each one is about.
const TARGETS: &[(&str, &str)] = &[
    ("mcap", "src/logs/mcap.rs"),
    ("bag", "src/logs/rosbag1.rs"),
    ("db3", "src/logs/db3.rs"),
    ("ulog", "src/logs/ulog.rs"),
    ("dataflash", "src/logs/dataflash.rs"),
    ("text", "src/io.rs"),
    ("binary", "src/io.rs"),
    ("gzip", "src/io.rs"),
    ("model", "crates/processes/src/model.rs"),
];

/// libFuzzer's limits: the findings the brief counts.
const LIMITS: &[&str] = &[
    "-timeout=1",
    "-rss_limit_mb=1024",
    "-malloc_limit_mb=1024",
    "-detect_leaks=0",
    "-print_final_stats=1",
];

/// One target's run.
struct Row {
    name: String,
    minutes: f64,
    runs: u64,
    corpus: usize,
    cov: Option<u64>,
    ft: Option<u64>,
    lines: Option<String>,
    crashes: usize,
    timeouts: usize,
    ooms: usize,
    artifacts: Vec<PathBuf>,
}

/// Runs the task.
pub fn run(rest: &[String]) -> Result<(), String> {
    let minutes: f64 = args::parsed(rest, "--minutes", 1.0)?;
    let jobs: usize = args::parsed(rest, "--jobs", 1usize)?;
    if jobs == 0 {
        return Err("--jobs must be at least 1".to_string());
    }
    let only = args::value(rest, "--target");
    let line_coverage = !rest.iter().any(|a| a == "--no-line-coverage");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .ok_or("no workspace root")?
        .to_path_buf();
    let targets: Vec<(&str, &str)> = match only {
        Some(list) => list
            .split(',')
            .map(|t| {
                TARGETS
                    .iter()
                    .find(|(n, _)| *n == t)
                    .copied()
                    .ok_or_else(|| format!("no fuzz target {t:?}; targets: {}", names()))
            })
            .collect::<Result<_, _>>()?,
        None => TARGETS.to_vec(),
    };
    let fz = root.join("target/fuzz");
    let tools = root.join("target/tools/bin");
    // 1. cargo-fuzz
    if !tools.join("cargo-fuzz").exists() {
        status(
            Command::new("bash").arg(root.join("scripts/fuzz-setup.sh")),
            "scripts/fuzz-setup.sh",
        )?;
    }
    let path = format!(
        "{}:{}",
        tools.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    // 2. seeds
    let seeds = fz.join("seeds");
    eprintln!("fuzz: writing the seed corpora into {}", seeds.display());
    status(
        Command::new(cargo())
            .current_dir(&root)
            .env("IMUNOISE_FUZZ_SEEDS", &seeds)
            .args([
                "test",
                "-p",
                "imunoise",
                "--test",
                "logs",
                "write_fuzz_seeds",
            ])
            .args(["--", "--ignored", "--exact", "fuzz::write_fuzz_seeds"]),
        "writing the seeds (tests/logs.rs write_fuzz_seeds)",
    )?;
    // 3. build and run
    let build_dir = fz.join("build");
    eprintln!("fuzz: building the targets (cargo +nightly fuzz build)");
    status(
        fuzz_cmd(&root, &path)
            .args(["build", "--debug-assertions", "--target-dir"])
            .arg(&build_dir),
        "cargo +nightly fuzz build",
    )?;
    let bin_dir = build_dir.join(host()?).join("release");
    let logs = root.join("target/fuzz-logs");
    std::fs::create_dir_all(&logs).map_err(|e| e.to_string())?;
    // `jobs` targets at a time, each one libFuzzer process (a target's figures do not depend
    // on the others, only its executions per second do)
    let mut rows = Vec::new();
    for group in targets.chunks(jobs) {
        let done: Vec<Result<Row, String>> = std::thread::scope(|s| {
            let handles: Vec<_> = group
                .iter()
                .map(|&(name, _)| {
                    let (bin, fz, logs) = (bin_dir.join(name), &fz, &logs);
                    s.spawn(move || run_target(&bin, name, minutes, fz, logs))
                })
                .collect();
            handles
                .into_iter()
                .map(|h| {
                    h.join()
                        .unwrap_or_else(|_| Err("a fuzz runner panicked".into()))
                })
                .collect()
        });
        for r in done {
            rows.push(r?);
        }
    }
    // 4. line coverage
    let mut note = String::new();
    if line_coverage {
        match llvm_cov() {
            Some(llvm_cov) => {
                for (row, &(name, file)) in rows.iter_mut().zip(&targets) {
                    row.lines = line_cov(&root, &path, &fz, &llvm_cov, name, file)
                        .map_err(|e| eprintln!("fuzz: line coverage of {name}: {e}"))
                        .ok();
                }
            }
            None => {
                note = "Line coverage: not measured: the nightly toolchain has no llvm-tools \
                        (`rustup component add llvm-tools-preview --toolchain nightly` failed); \
                        cov/ft are libFuzzer's counts of covered edges and features.\n"
                    .to_string()
            }
        }
    }
    let report = table(&rows, &note, jobs);
    print!("{report}");
    std::fs::write(root.join("target/fuzz-report.md"), &report).map_err(|e| e.to_string())?;
    let found: usize = rows.iter().map(|r| r.crashes + r.timeouts + r.ooms).sum();
    if found > 0 {
        return Err(format!(
            "{found} findings: {}",
            rows.iter()
                .flat_map(|r| &r.artifacts)
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok(())
}

fn names() -> String {
    TARGETS.iter().map(|t| t.0).collect::<Vec<_>>().join(", ")
}

fn cargo() -> String {
    std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())
}

/// `cargo +nightly fuzz` in the repository, with target/tools/bin on the path. Through rustup's
/// cargo proxy, not the stable cargo that runs the xtask (whose environment is cleared of the
/// toolchain it set).
fn fuzz_cmd(root: &Path, path: &str) -> Command {
    let mut c = Command::new("cargo");
    c.current_dir(root)
        .env("PATH", path)
        .env_remove("RUSTUP_TOOLCHAIN")
        .env_remove("CARGO")
        .env_remove("RUSTC")
        .env_remove("CARGO_TARGET_DIR")
        .args(["+nightly", "fuzz"]);
    c
}

fn status(cmd: &mut Command, what: &str) -> Result<(), String> {
    let s = cmd.status().map_err(|e| format!("{what}: {e}"))?;
    if s.success() {
        Ok(())
    } else {
        Err(format!("{what} failed ({s})"))
    }
}

/// The host triple (cargo-fuzz builds for it explicitly).
fn host() -> Result<String, String> {
    let out = Command::new("rustc")
        .args(["+nightly", "-vV"])
        .env_remove("RUSTUP_TOOLCHAIN")
        .output()
        .map_err(|e| format!("rustc: {e}"))?;
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .ok_or_else(|| "rustc -vV gives no host".to_string())
}

fn count_files(dir: &Path) -> usize {
    std::fs::read_dir(dir).map_or(0, |d| d.filter(|e| e.is_ok()).count())
}

/// Runs one target for `minutes`, one process, and reads libFuzzer's closing figures.
fn run_target(bin: &Path, name: &str, minutes: f64, fz: &Path, logs: &Path) -> Result<Row, String> {
    let corpus = fz.join("corpus").join(name);
    let seeds = fz.join("seeds").join(name);
    let artifacts = fz.join("artifacts").join(name);
    for d in [&corpus, &artifacts] {
        std::fs::create_dir_all(d).map_err(|e| e.to_string())?;
    }
    let before: Vec<PathBuf> = list(&artifacts);
    let log = logs.join(format!("{name}.log"));
    let secs = (minutes * 60.0).round().max(1.0) as u64;
    eprintln!("fuzz: {name} for {secs} s (log: {})", log.display());
    let t0 = Instant::now();
    let out = std::fs::File::create(&log).map_err(|e| e.to_string())?;
    let s = Command::new(bin)
        .arg(&corpus)
        .arg(&seeds)
        .args(LIMITS)
        .arg(format!("-max_total_time={secs}"))
        .arg(format!("-artifact_prefix={}/", artifacts.display()))
        .stdout(Stdio::null())
        .stderr(out)
        .status()
        .map_err(|e| format!("running {}: {e}", bin.display()))?;
    let ran = t0.elapsed().as_secs_f64() / 60.0;
    let text = std::fs::read_to_string(&log).map_err(|e| e.to_string())?;
    let new: Vec<PathBuf> = list(&artifacts)
        .into_iter()
        .filter(|p| !before.contains(p))
        .collect();
    let kind = |k: &str| {
        new.iter()
            .filter(|p| {
                p.file_name()
                    .is_some_and(|f| f.to_string_lossy().starts_with(k))
            })
            .count()
    };
    let (mut crashes, timeouts, ooms) = (kind("crash-"), kind("timeout-"), kind("oom-"));
    if !s.success() && crashes + timeouts + ooms == 0 {
        // an exit without an artifact (a crash in libFuzzer's own setup, say) still counts
        eprintln!(
            "fuzz: {name} exited with {s} and left no artifact; see {}",
            log.display()
        );
        crashes = 1;
    }
    // the last status line: "#123 DONE cov: 456 ft: 789 corp: ..." (or the last "pulse"/"NEW")
    let field = |line: &str, key: &str| -> Option<u64> {
        let mut it = line.split_whitespace();
        it.find(|w| *w == key)?;
        it.next()?.parse().ok()
    };
    let last = text
        .lines()
        .rev()
        .find(|l| l.starts_with('#') && l.contains(" cov: "));
    let stat = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|v| v.trim().parse::<u64>().ok())
    };
    Ok(Row {
        name: name.to_string(),
        minutes: ran,
        runs: stat("stat::number_of_executed_units:").unwrap_or(0),
        corpus: count_files(&corpus),
        cov: last.and_then(|l| field(l, "cov:")),
        ft: last.and_then(|l| field(l, "ft:")),
        lines: None,
        crashes,
        timeouts,
        ooms,
        artifacts: new,
    })
}

fn list(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir).map_or(Vec::new(), |d| {
        d.filter_map(|e| e.ok().map(|e| e.path())).collect()
    })
}

/// llvm-cov of the nightly toolchain (from its llvm-tools component), if it is installed.
fn llvm_cov() -> Option<PathBuf> {
    let out = Command::new("rustc")
        .args(["+nightly", "--print", "sysroot"])
        .env_remove("RUSTUP_TOOLCHAIN")
        .output()
        .ok()?;
    let sysroot = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    let p = sysroot
        .join("lib/rustlib")
        .join(host().ok()?)
        .join("bin/llvm-cov");
    p.exists().then_some(p)
}

/// `cargo fuzz coverage` over the target's corpus, then the line coverage of `file` as
/// "covered/lines (percent)".
fn line_cov(
    root: &Path,
    path: &str,
    fz: &Path,
    llvm_cov: &Path,
    name: &str,
    file: &str,
) -> Result<String, String> {
    let cov_dir = fz.join("cov-build");
    eprintln!("fuzz: line coverage of {name} (cargo fuzz coverage)");
    status(
        fuzz_cmd(root, path)
            .args(["coverage", name, "--target-dir"])
            .arg(&cov_dir)
            .arg(fz.join("corpus").join(name))
            .arg(fz.join("seeds").join(name))
            .stdout(Stdio::null())
            .stderr(Stdio::null()),
        "cargo fuzz coverage",
    )?;
    let triple = host()?;
    // cargo-fuzz 0.13 puts the instrumented binary at <dir>/<triple>/release/<name>
    let bin = [
        cov_dir.join(&triple).join("release").join(name),
        cov_dir
            .join(&triple)
            .join("coverage")
            .join(&triple)
            .join("release")
            .join(name),
    ]
    .into_iter()
    .find(|p| p.exists())
    .ok_or_else(|| {
        format!(
            "no instrumented binary for {name} under {}",
            cov_dir.display()
        )
    })?;
    let profdata = root
        .join("fuzz/coverage")
        .join(name)
        .join("coverage.profdata");
    let out = Command::new(llvm_cov)
        .arg("report")
        .arg(&bin)
        .arg(format!("-instr-profile={}", profdata.display()))
        .arg(root.join(file))
        .output()
        .map_err(|e| format!("llvm-cov: {e}"))?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        return Err(format!(
            "llvm-cov report: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    // columns: Filename Regions Missed Cover Functions Missed Executed Lines Missed Cover ...
    let header: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("Filename"))
        .ok_or("llvm-cov report has no header")?
        .split_whitespace()
        .collect();
    let at = header
        .iter()
        .position(|w| *w == "Lines")
        .ok_or("no Lines column")?;
    let total: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("TOTAL"))
        .ok_or("llvm-cov report has no TOTAL")?
        .split_whitespace()
        .collect();
    let lines: u64 = total[at].parse().map_err(|_| "bad Lines")?;
    let missed: u64 = total[at + 1].parse().map_err(|_| "bad Missed Lines")?;
    Ok(format!(
        "{}/{} ({:.1} %) of {file}",
        lines - missed,
        lines,
        100.0 * (lines - missed) as f64 / lines.max(1) as f64
    ))
}

fn table(rows: &[Row], note: &str, jobs: usize) -> String {
    let mut s = format!(
        "# cargo xtask fuzz --coverage (cargo-fuzz, libFuzzer, -timeout=1 -rss_limit_mb=1024 -malloc_limit_mb=1024, one process per target, {jobs} at a time)\n\n\
         | target | minutes | runs | corpus (files) | cov | ft | line coverage | crashes | timeouts | OOMs |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    let opt = |v: Option<u64>| v.map_or("?".to_string(), |v| v.to_string());
    for r in rows {
        s.push_str(&format!(
            "| {} | {:.1} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.name,
            r.minutes,
            r.runs,
            r.corpus,
            opt(r.cov),
            opt(r.ft),
            r.lines.as_deref().unwrap_or("-"),
            r.crashes,
            r.timeouts,
            r.ooms
        ));
    }
    s.push('\n');
    s.push_str(note);
    for r in rows {
        for a in &r.artifacts {
            s.push_str(&format!("Finding of {}: {}\n", r.name, a.display()));
        }
    }
    s
}
