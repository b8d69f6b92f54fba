//! `cargo xtask fuzz --coverage --minutes N [--target NAME[,NAME…]] [--jobs K] [--no-seeds]
//! [--no-replay] [--replay-only] [--no-line-coverage]`: coverage-guided fuzzing of the readers with cargo-fuzz
//! (libFuzzer) on the nightly toolchain.
//!
//! 1. cargo-fuzz comes from `scripts/fuzz-setup.sh` (into `target/tools`, with the nightly
//!    llvm-tools when they can be had).
//! 2. The seed corpora are written from the fixtures of `tests/logs.rs` (its ignored test
//!    `write_fuzz_seeds`) into `target/fuzz/seeds/<target>/` (`--no-seeds` keeps the seeds
//!    already there and saves building that test).
//! 3. The targets of `fuzz/` are built once (`cargo +nightly fuzz build --debug-assertions`,
//!    AddressSanitizer), then run K at a time (`--jobs`, default 1), N minutes each, one
//!    process per target (`-timeout=1 -rss_limit_mb=1024 -malloc_limit_mb=1024`): a panic, an abort, an input that
//!    takes more than 1 s or an allocation over 1 GiB is a finding, kept in
//!    `target/fuzz/artifacts/<target>/`. The corpus grows in `target/fuzz/corpus/<target>/`
//!    from run to run; each run's libFuzzer output is in `target/fuzz-logs/<target>.log`.
//!    The 1 GiB limit on a single allocation is enforced by the fuzz crate's global allocator
//!    (`fuzz/src/lib.rs`, every thread, an abort naming the size): libFuzzer's
//!    `-malloc_limit_mb` works through the sanitizer's malloc hooks, which libFuzzer installs
//!    only when leak detection is on, and the runs use `-detect_leaks=0`.
//! 4. Unless `--no-replay`, every file of the target's corpus and seeds is run again, one by
//!    one, through the same binary under the same limits (the binary given the files as
//!    arguments, in batches; after a finding the next batch starts at the file after it):
//!    what a file does is then attributed to that file alone, not to the state a long run
//!    accumulates. Any finding fails the task and is named, with the file, under the table
//!    (column "replay"; libFuzzer's output in `target/fuzz-logs/<target>-replay.log`). The
//!    replay also gives the slowest file's time. `--replay-only` skips the fuzzing runs of
//!    step 3 (the targets are still built) and only replays the corpora and seeds as they are,
//!    adding no file to them: the check of an existing corpus under new limits.
//! 5. Unless `--no-line-coverage`, `cargo fuzz coverage` replays each corpus through an
//!    instrumented build and `llvm-cov report` gives the line coverage of the reader's source
//!    file (when the llvm-tools are there; otherwise the report says so).
//!
//! The table (runs, corpus files, libFuzzer's final `cov:`/`ft:`, peak RSS, slowest unit, line
//! coverage, findings of the run and of the replay) goes to stdout and `target/fuzz-report.md`.

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
    /// libFuzzer's `stat::peak_rss_mb` of the run
    peak_rss_mb: Option<u64>,
    /// libFuzzer's `stat::slowest_unit_time_sec` of the run (whole seconds)
    slowest_s: Option<u64>,
    lines: Option<String>,
    crashes: usize,
    timeouts: usize,
    ooms: usize,
    artifacts: Vec<PathBuf>,
    replay: Option<Replay>,
}

/// The one-by-one replay of a target's corpus and seeds.
struct Replay {
    files: usize,
    /// (file, what libFuzzer or the allocator said)
    findings: Vec<(PathBuf, String)>,
    /// the slowest file and its time in ms
    slowest: Option<(PathBuf, u64)>,
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
    let replay_only = rest.iter().any(|a| a == "--replay-only");
    let replay = !rest.iter().any(|a| a == "--no-replay");
    if replay_only && !replay {
        return Err("--replay-only and --no-replay exclude each other".to_string());
    }
    let write_seeds = !rest.iter().any(|a| a == "--no-seeds");
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
    if write_seeds {
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
    } else {
        eprintln!(
            "fuzz: --no-seeds: using the seed corpora in {}",
            seeds.display()
        );
    }
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
    if replay_only {
        rows = replay_rows(&bin_dir, &targets, &fz, &logs)?;
    }
    for group in targets.chunks(jobs).filter(|_| !replay_only) {
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
    // 4. one-by-one replay (done above with --replay-only)
    if replay && !replay_only {
        for row in &mut rows {
            let r = replay_target(&bin_dir.join(&row.name), &row.name, &fz, &logs)?;
            row.replay = Some(r);
        }
    }
    // 5. line coverage
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
    if replay_only {
        note.push_str(
            "--replay-only: no fuzzing run (minutes, runs, cov, ft, peak RSS, slowest unit, \
             crashes, timeouts and OOMs of the run are empty); only the replay of the corpus \
             and seeds as they were.\n",
        );
    }
    let report = table(&rows, &note, jobs);
    print!("{report}");
    std::fs::write(root.join("target/fuzz-report.md"), &report).map_err(|e| e.to_string())?;
    let found: usize = rows
        .iter()
        .map(|r| {
            r.crashes + r.timeouts + r.ooms + r.replay.as_ref().map_or(0, |p| p.findings.len())
        })
        .sum();
    if found > 0 {
        return Err(format!(
            "{found} findings: {}",
            rows.iter()
                .flat_map(|r| {
                    r.artifacts.iter().cloned().chain(
                        r.replay
                            .iter()
                            .flat_map(|p| p.findings.iter().map(|f| f.0.clone())),
                    )
                })
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
    for d in [&corpus, &seeds, &artifacts] {
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
        peak_rss_mb: stat("stat::peak_rss_mb:"),
        slowest_s: stat("stat::slowest_unit_time_sec:"),
        lines: None,
        crashes,
        timeouts,
        ooms,
        artifacts: new,
        replay: None,
    })
}

/// `--replay-only`: for each target, a row with no fuzzing run and the one-by-one replay of
/// its corpus and seeds (`bin_dir/<target>` the fuzz binary), the corpus counted as it is.
fn replay_rows(
    bin_dir: &Path,
    targets: &[(&str, &str)],
    fz: &Path,
    logs: &Path,
) -> Result<Vec<Row>, String> {
    targets
        .iter()
        .map(|&(name, _)| {
            let replay = replay_target(&bin_dir.join(name), name, fz, logs)?;
            Ok(Row {
                name: name.to_string(),
                minutes: 0.0,
                runs: 0,
                corpus: count_files(&fz.join("corpus").join(name)),
                cov: None,
                ft: None,
                peak_rss_mb: None,
                slowest_s: None,
                lines: None,
                crashes: 0,
                timeouts: 0,
                ooms: 0,
                artifacts: Vec::new(),
                replay: Some(replay),
            })
        })
        .collect()
}

/// Files per replay process (the command line stays short; one process per file would cost
/// a start-up each).
const REPLAY_BATCH: usize = 200;

/// Runs every file of the target's corpus and seeds once, one by one, through `bin` under
/// [`LIMITS`]: libFuzzer, given files rather than folders, runs each in turn and prints
/// "Running: F" before and "Executed F in N ms" after it. A process that stops early stopped
/// on the first file it did not finish: that file is a finding, and the replay goes on from
/// the next one.
fn replay_target(bin: &Path, name: &str, fz: &Path, logs: &Path) -> Result<Replay, String> {
    let mut files: Vec<PathBuf> = ["corpus", "seeds"]
        .iter()
        .flat_map(|d| list(&fz.join(d).join(name)))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    let log = logs.join(format!("{name}-replay.log"));
    eprintln!(
        "fuzz: replaying the {} files of {name}'s corpus and seeds one by one (log: {})",
        files.len(),
        log.display()
    );
    let mut all_out = String::new();
    let mut r = Replay {
        files: files.len(),
        findings: Vec::new(),
        slowest: None,
    };
    let mut at = 0;
    while at < files.len() {
        let batch = &files[at..(at + REPLAY_BATCH).min(files.len())];
        let out = Command::new(bin)
            .args(batch)
            .args(LIMITS)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .output()
            .map_err(|e| format!("running {}: {e}", bin.display()))?;
        let text = String::from_utf8_lossy(&out.stderr);
        all_out.push_str(&text);
        let mut done = 0;
        for line in text.lines() {
            let Some((_, ms)) = line
                .strip_prefix("Executed ")
                .and_then(|l| l.rsplit_once(" in "))
            else {
                continue;
            };
            let ms: u64 = ms.trim_end_matches(" ms").parse().unwrap_or(0);
            if let Some(f) = batch.get(done)
                && r.slowest.as_ref().is_none_or(|s| ms > s.1)
            {
                r.slowest = Some((f.clone(), ms));
            }
            done += 1;
        }
        if out.status.success() && done >= batch.len() {
            at += batch.len();
            continue;
        }
        // the file it stopped on (or, if it stopped after the last one, that one)
        let i = done.min(batch.len() - 1);
        let what = text
            .lines()
            .find(|l| {
                l.starts_with("imunoise-fuzz:")
                    || l.contains("ERROR: libFuzzer")
                    || l.contains("ERROR: AddressSanitizer")
                    || l.contains("panicked at")
            })
            .map_or_else(|| format!("exit {}", out.status), |l| l.trim().to_string());
        eprintln!("fuzz: replay of {name}: {}: {what}", batch[i].display());
        r.findings.push((batch[i].clone(), what));
        at += i + 1;
    }
    std::fs::write(&log, all_out).map_err(|e| e.to_string())?;
    Ok(r)
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
    let (lines, missed) = report_lines(&text)?;
    Ok(format!(
        "{}/{} ({:.1} %) of {file}",
        lines - missed,
        lines,
        100.0 * (lines - missed) as f64 / lines.max(1) as f64
    ))
}

/// The lines and the missed lines of the TOTAL row of an `llvm-cov report`. The header's
/// column names contain single spaces ("Missed Regions") and are separated by two or more,
/// so the header is split at runs of spaces of two or more; the TOTAL row holds one word
/// per column.
fn report_lines(text: &str) -> Result<(u64, u64), String> {
    let header: Vec<&str> = text
        .lines()
        .find(|l| l.starts_with("Filename"))
        .ok_or("llvm-cov report has no header")?
        .split("  ")
        .map(str::trim)
        .filter(|w| !w.is_empty())
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
    let num = |i: usize, what: &str| -> Result<u64, String> {
        total
            .get(i)
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("bad {what} in the TOTAL row"))
    };
    Ok((num(at, "Lines")?, num(at + 1, "Missed Lines")?))
}

fn table(rows: &[Row], note: &str, jobs: usize) -> String {
    let mut s = format!(
        "# cargo xtask fuzz --coverage (cargo-fuzz, libFuzzer, -timeout=1 -rss_limit_mb=1024 -malloc_limit_mb=1024, single allocations capped at 1 GiB on every thread, one process per target, {jobs} at a time)\n\n\
         | target | minutes | runs | corpus (files) | cov | ft | peak RSS (MB) | slowest unit (s) | line coverage | crashes | timeouts | OOMs | replay |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let opt = |v: Option<u64>| v.map_or("?".to_string(), |v| v.to_string());
    for r in rows {
        let replay = r.replay.as_ref().map_or("-".to_string(), |p| {
            format!(
                "{} files, {} findings, slowest {} ms",
                p.files,
                p.findings.len(),
                p.slowest.as_ref().map_or(0, |s| s.1)
            )
        });
        s.push_str(&format!(
            "| {} | {:.1} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.name,
            r.minutes,
            r.runs,
            r.corpus,
            opt(r.cov),
            opt(r.ft),
            opt(r.peak_rss_mb),
            opt(r.slowest_s),
            r.lines.as_deref().unwrap_or("-"),
            r.crashes,
            r.timeouts,
            r.ooms,
            replay
        ));
    }
    s.push('\n');
    s.push_str(note);
    for r in rows {
        for a in &r.artifacts {
            s.push_str(&format!("Finding of {}: {}\n", r.name, a.display()));
        }
        if let Some(p) = &r.replay {
            for (f, what) in &p.findings {
                s.push_str(&format!(
                    "Replay finding of {}: {}: {what}\n",
                    r.name,
                    f.display()
                ));
            }
            if let Some((f, ms)) = &p.slowest {
                s.push_str(&format!(
                    "Slowest file of {}'s replay: {} ({ms} ms)\n",
                    r.name,
                    f.display()
                ));
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The TOTAL row of `llvm-cov report` as the nightly toolchain's llvm-cov prints it
    /// (two-word column names), here the db3 target's corpus of 2026-11-28: 102 lines, 14
    /// missed.
    #[test]
    fn report_lines_reads_the_total_row_under_two_word_column_names() {
        let text = "\
Filename                       Regions    Missed Regions     Cover   Functions  Missed Functions  Executed       Lines      Missed Lines     Cover    Branches   Missed Branches     Cover
-----------------------------------------------------------------------------------------
/work/main/src/logs/db3.rs         199                33    83.42%          21                 8    61.90%         102                14    86.27%           0                 0         -
-----------------------------------------------------------------------------------------
TOTAL                              199                33    83.42%          21                 8    61.90%         102                14    86.27%           0                 0         -
";
        assert_eq!(report_lines(text), Ok((102, 14)));
        assert!(report_lines("TOTAL 1 2\n").is_err());
    }

    /// The replay against a stand-in for a fuzz binary: a script that prints libFuzzer's
    /// "Running: F" and "Executed F in N ms" lines for each file argument (N = the file's size
    /// in bytes) and dies, as libFuzzer does on a crash, on a file whose name contains "bad".
    /// 450 files (more than two batches), bad ones at the start, across a batch boundary and
    /// last: each must be named once, every other file run, and the slowest be the largest.
    /// Writes the stand-in fuzz binary described at
    /// [`replay_names_each_failing_file_and_goes_on_after_it`] to `bin`.
    fn fake_fuzzer(bin: &Path) {
        std::fs::write(
            bin,
            "#!/bin/sh\nfor f in \"$@\"; do\n  case \"$f\" in -*) continue;; esac\n  \
             echo \"Running: $f\" >&2\n  case \"$f\" in *bad*) \
             echo '==1== ERROR: libFuzzer: deadly signal' >&2; exit 1;; esac\n  \
             echo \"Executed $f in $(wc -c < \"$f\") ms\" >&2\ndone\n",
        )
        .unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(bin, std::fs::Permissions::from_mode(0o755)).unwrap();
    }

    /// `--replay-only` on two targets with the same stand-in: each row holds only its own
    /// target's replay (corpus + seeds: 30 + 2 and 12 + 1 files, one bad file in the second
    /// one's seeds, the largest file of each the slowest), no run figures, and the corpora are
    /// left as they were.
    #[test]
    fn replay_only_replays_each_target_and_adds_nothing() {
        let root = std::env::temp_dir().join(format!("xtask-replay-only-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let (fz, logs, bins) = (root.join("fz"), root.join("logs"), root.join("bin"));
        for d in [&logs, &bins] {
            std::fs::create_dir_all(d).unwrap();
        }
        for (t, n_corpus, largest) in [("a", 30, 17), ("b", 12, 3)] {
            let (corpus, seeds) = (fz.join("corpus").join(t), fz.join("seeds").join(t));
            std::fs::create_dir_all(&corpus).unwrap();
            std::fs::create_dir_all(&seeds).unwrap();
            for i in 0..n_corpus {
                let size = if i == largest { 500 } else { 1 + i % 5 };
                std::fs::write(corpus.join(format!("c{i:02}")), vec![1u8; size]).unwrap();
            }
            std::fs::write(seeds.join("s0"), b"x").unwrap();
            let last = if t == "b" { "s1-bad" } else { "s1" };
            std::fs::write(seeds.join(last), b"y").unwrap();
            fake_fuzzer(&bins.join(t));
        }
        let rows = replay_rows(&bins, &[("a", "x.rs"), ("b", "y.rs")], &fz, &logs).unwrap();
        assert_eq!(rows.len(), 2);
        for (row, (t, corpus, files, findings, slowest)) in rows
            .iter()
            .zip([("a", 30, 32, 0, "c17"), ("b", 12, 14, 1, "c03")])
        {
            assert_eq!(row.name, t);
            assert_eq!((row.runs, row.cov, row.ft), (0, None, None));
            assert_eq!(row.corpus, corpus);
            assert_eq!(count_files(&fz.join("corpus").join(t)), corpus);
            let p = row.replay.as_ref().unwrap();
            assert_eq!(p.files, files);
            assert_eq!(p.findings.len(), findings);
            let (f, ms) = p.slowest.as_ref().unwrap();
            assert_eq!(
                (f.file_name().unwrap().to_str().unwrap(), *ms),
                (slowest, 500)
            );
        }
        assert!(
            rows[1].replay.as_ref().unwrap().findings[0]
                .0
                .ends_with("seeds/b/s1-bad")
        );
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn replay_names_each_failing_file_and_goes_on_after_it() {
        let root = std::env::temp_dir().join(format!("xtask-replay-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let (fz, logs) = (root.join("fz"), root.join("logs"));
        let corpus = fz.join("corpus/t");
        std::fs::create_dir_all(&corpus).unwrap();
        std::fs::create_dir_all(&logs).unwrap();
        let bad = [5, 199, 200, 449];
        for i in 0..450 {
            let name = if bad.contains(&i) {
                format!("f{i:03}-bad")
            } else {
                format!("f{i:03}")
            };
            let size = if i == 300 { 999 } else { 1 + i % 7 };
            std::fs::write(corpus.join(name), vec![0u8; size]).unwrap();
        }
        let bin = root.join("fake-fuzzer");
        fake_fuzzer(&bin);
        let r = replay_target(&bin, "t", &fz, &logs).unwrap();
        assert_eq!(r.files, 450);
        let named: Vec<String> = r
            .findings
            .iter()
            .map(|(f, what)| {
                assert_eq!(what, "==1== ERROR: libFuzzer: deadly signal");
                f.file_name().unwrap().to_string_lossy().into_owned()
            })
            .collect();
        assert_eq!(named, ["f005-bad", "f199-bad", "f200-bad", "f449-bad"]);
        let (slowest, ms) = r.slowest.unwrap();
        assert_eq!(slowest.file_name().unwrap(), "f300");
        assert_eq!(ms, 999);
        // every good file ran exactly once
        let log = std::fs::read_to_string(logs.join("t-replay.log")).unwrap();
        assert_eq!(log.matches("Executed ").count(), 450 - bad.len());
        std::fs::remove_dir_all(&root).unwrap();
    }
}
