//! `cargo xtask avar-speed [--sizes 1e6,1e7,1e8] [--python PATH] [--all-n 1e6] [--simd LEVEL]`:
//! the MOAV speed report of issue 4, run in one go on this machine.
//!
//! The report names the SIMD level the kernels ran at (`avar::simd::level`). `--simd
//! scalar|avx2|avx512` caps it for this run, as `IMUNOISE_SIMD` does (a cap above what the CPU
//! has leaves the CPU's level); without it `IMUNOISE_SIMD` applies. `--end-to-end` runs the
//! command in child processes: cap those with `IMUNOISE_SIMD` instead.
//!
//! For each size T the same synthetic rate series (white noise around an offset, written to
//! `target/avar-speed/`) is processed by
//! * `avar` at the book's dyadic scales (no CI; and with the default chi-square CI), with the
//!   default thread pool and with one thread;
//! * one vectorised streaming pass summing the array (the memory-bandwidth baseline);
//! * allantools `oadev(..., data_type="freq", taus="octave")` in a Python venv (created with
//!   `python3 -m venv target/venv && target/venv/bin/pip install allantools`), whose OADEV values
//!   are also compared with ours (an independent implementation);
//! * "all m" (m = 1..T/2) on `--all-n` samples by `avar` (`--all-n 0`: skipped).
//!
//! Times are the best of three runs (allantools too, in one process, up to 1e7; one call at
//! 1e8, which is slower than its later calls would be). Peak memory is the process
//! high-water mark (VmHWM), which includes the input array.
//!
//! `--end-to-end`: from file to Allan variance through the command (issue 13), see
//! [`crate::avar_e2e`].
//!
//! `--family [--sizes 1e7,1e8] [--py-max 1e7]`: the stability family instead (issue 14): at each
//! size, octave τ, no CI, OADEV and each of ADEV, MDEV, TDEV, HDEV, OHDEV, TOTDEV, alternated
//! in one run (OADEV, X, OADEV, X, … best of 3 each), the ratio X / OADEV of the same run, and
//! allantools' function of the same name on the same data up to `--py-max` samples (best of
//! three calls in one Python process, as ours; its first call, slower by 10–50 %, is shown
//! beside it) with the speed-up over the best call and the largest relative difference of the
//! deviations.

use crate::args::value;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use avar::{AvarConfig, CiMethod, Scales, allan_variance};

fn data(n: usize) -> Vec<f64> {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            1e-3 + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-6
        })
        .collect()
}

fn best_of<T>(reps: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..reps {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("reps >= 1"))
}

fn vm_hwm_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines().find(|l| l.starts_with("VmHWM")).and_then(|l| {
                l.split_whitespace()
                    .nth(1)
                    .and_then(|v| v.parse::<f64>().ok())
            })
        })
        .map(|kb| kb / 1024.0)
        .unwrap_or(f64::NAN)
}

const PY: &str = r#"
import sys, time, json, resource
import numpy as np, allantools
x = np.fromfile(sys.argv[1], dtype='<f8')
ts = []
for _ in range(int(sys.argv[3])):
    t = time.perf_counter()
    taus, devs, errs, ns = allantools.oadev(x, rate=1.0, data_type='freq', taus=sys.argv[2])
    ts.append(time.perf_counter() - t)
dt = min(ts)
print(json.dumps({"seconds": dt, "taus": list(map(float, taus)), "devs": list(map(float, devs)),
                  "ns": list(map(int, ns)), "maxrss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"#;

struct Py {
    seconds: f64,
    taus: Vec<f64>,
    devs: Vec<f64>,
    maxrss_mb: f64,
}

/// allantools' `oadev` on the samples in `file`: the best of `calls` calls in one process
/// (its first call is 10–50 % slower than the later ones).
fn run_allantools(python: &Path, file: &Path, taus: &str, calls: usize) -> Result<Py, String> {
    let out = Command::new(python)
        .arg("-c")
        .arg(PY)
        .arg(file)
        .arg(taus)
        .arg(calls.to_string())
        .output()
        .map_err(|e| format!("running {python:?}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "allantools failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).map_err(|e| format!("allantools output: {e}"))?;
    let list = |k: &str| -> Vec<f64> {
        v[k].as_array()
            .map(|a| a.iter().filter_map(|x| x.as_f64()).collect())
            .unwrap_or_default()
    };
    Ok(Py {
        seconds: v["seconds"].as_f64().unwrap_or(f64::NAN),
        taus: list("taus"),
        devs: list("devs"),
        maxrss_mb: v["maxrss_mb"].as_f64().unwrap_or(f64::NAN),
    })
}

const PY_FAMILY: &str = r#"
import sys, time, json
import numpy as np, allantools
x = np.fromfile(sys.argv[1], dtype='<f8')
f = getattr(allantools, sys.argv[2])
ts = []
for _ in range(3):
    t = time.perf_counter()
    taus, devs, errs, ns = f(x, rate=1.0, data_type='freq', taus='octave')
    ts.append(time.perf_counter() - t)
print(json.dumps({"seconds": min(ts), "first": ts[0], "taus": list(map(float, taus)), "devs": list(map(float, devs))}))
"#;

/// The `--family` report.
fn run_family(
    args: &[String],
    sizes: &[usize],
    python: &Path,
    dir: &Path,
    simd: &str,
) -> Result<(), String> {
    use avar::stability::{Statistic, stability};
    let py_max = value(args, "--py-max")
        .map(|s| s.parse::<f64>().map(|v| v as usize))
        .transpose()
        .map_err(|_| "bad --py-max")?
        .unwrap_or(10_000_000);
    let have_py = python.exists();
    let cfg = AvarConfig {
        scales: Scales::Octave,
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let load = || {
        std::fs::read_to_string("/proc/loadavg")
            .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
            .unwrap_or_else(|_| "unknown".into())
    };
    println!(
        "# stability family speed ({} threads; octave τ, no CI; best of 3, alternated with OADEV; \
         {simd}; load average at start: {})\n",
        rayon::current_num_threads(),
        load()
    );
    println!(
        "| T | statistic | scales | time | OADEV same run | ratio to OADEV | allantools (best of 3; first call) | speed-up | max rel. diff |"
    );
    println!("|---:|---|---:|---:|---:|---:|---:|---:|---:|");
    for &n in sizes {
        let x = data(n);
        let file = dir.join(format!("family_{n}.f64"));
        let use_py = have_py && n <= py_max;
        if use_py {
            let bytes: Vec<u8> = x.iter().flat_map(|v| v.to_le_bytes()).collect();
            std::fs::write(&file, bytes).map_err(|e| e.to_string())?;
        }
        for st in Statistic::ALL {
            let (mut t_o, mut t_s) = (f64::INFINITY, f64::INFINITY);
            let mut res = None;
            for _ in 0..3 {
                let t = Instant::now();
                let o = stability(&x, 1.0, Statistic::Oadev, &cfg).map_err(|e| e.to_string())?;
                t_o = t_o.min(t.elapsed().as_secs_f64());
                std::hint::black_box(o);
                let t = Instant::now();
                let r = stability(&x, 1.0, st, &cfg).map_err(|e| e.to_string())?;
                t_s = t_s.min(t.elapsed().as_secs_f64());
                res = Some(r);
            }
            let ours = res.expect("3 runs");
            let (py_s, speedup, diff) = if use_py {
                let out = Command::new(python)
                    .arg("-c")
                    .arg(PY_FAMILY)
                    .arg(&file)
                    .arg(st.name())
                    .output()
                    .map_err(|e| format!("running {python:?}: {e}"))?;
                if !out.status.success() {
                    return Err(format!(
                        "allantools {st} failed: {}",
                        String::from_utf8_lossy(&out.stderr)
                    ));
                }
                let v: serde_json::Value = serde_json::from_slice(&out.stdout)
                    .map_err(|e| format!("allantools output: {e}"))?;
                let secs = v["seconds"].as_f64().unwrap_or(f64::NAN);
                let first = v["first"].as_f64().unwrap_or(f64::NAN);
                let mut worst = 0.0f64;
                let mut matched = 0;
                let taus = v["taus"].as_array().cloned().unwrap_or_default();
                let devs = v["devs"].as_array().cloned().unwrap_or_default();
                for (tau, dev) in taus.iter().zip(&devs) {
                    let (Some(tau), Some(dev)) = (tau.as_f64(), dev.as_f64()) else {
                        continue;
                    };
                    if let Some(p) = ours.points.iter().find(|p| (p.tau - tau).abs() < 1e-9) {
                        worst = worst.max(((p.dev - dev) / dev).abs());
                        matched += 1;
                    }
                }
                (
                    format!("{secs:.3} s; {first:.3} s"),
                    format!("{:.0}×", secs / t_s),
                    format!("{worst:.1e} ({matched} τ)"),
                )
            } else {
                ("—".into(), "—".into(), "—".into())
            };
            println!(
                "| {n:.0e} | {} | {} | {:.1} ms | {:.1} ms | {:.2}× | {py_s} | {speedup} | {diff} |",
                st.name().to_uppercase(),
                ours.points.len(),
                1e3 * t_s,
                1e3 * t_o,
                t_s / t_o
            );
        }
        let _ = std::fs::remove_file(&file);
    }
    println!("\nload average at the end: {}", load());
    Ok(())
}

/// Runs the report.
/// Applies `--simd LEVEL` (before any kernel runs) and describes the level in force.
fn simd_level(args: &[String]) -> Result<String, String> {
    use avar::simd;
    if args.iter().any(|a| a == "--simd") {
        let v = value(args, "--simd").ok_or("--simd needs a value (scalar, avx2 or avx512)")?;
        let cap: simd::SimdLevel = v.parse().map_err(|e: simd::UnknownLevel| e.to_string())?;
        simd::set_cap(Some(cap)).map_err(|c| format!("the SIMD cap was already fixed: {c:?}"))?;
    }
    Ok(format!(
        "SIMD level {} (CPU: {}; cap: {})",
        simd::level(),
        simd::detected(),
        simd::cap().map_or("none".to_string(), |c| c.to_string())
    ))
}

pub fn run(args: &[String]) -> Result<(), String> {
    let simd = simd_level(args)?;
    if args.iter().any(|a| a == "--end-to-end") && args.iter().any(|a| a == "--simd") {
        return Err(
            "--simd does not reach the command's child processes of --end-to-end; \
                    set IMUNOISE_SIMD instead"
                .into(),
        );
    }
    let sizes: Vec<usize> = value(args, "--sizes")
        .unwrap_or("1e6,1e7,1e8")
        .split(',')
        .map(|s| {
            s.trim()
                .parse::<f64>()
                .map(|v| v as usize)
                .map_err(|_| format!("bad size {s}"))
        })
        .collect::<Result<_, _>>()?;
    let all_n = value(args, "--all-n")
        .map(|s| s.parse::<f64>().map(|v| v as usize))
        .transpose()
        .map_err(|_| "bad --all-n")?
        .unwrap_or(1_000_000);
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let python = value(args, "--python")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/venv/bin/python"));
    let have_py = python.exists();
    let dir = root.join("target/avar-speed");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    if args.iter().any(|a| a == "--end-to-end") {
        return crate::avar_e2e::run(args, &root);
    }
    if args.iter().any(|a| a == "--family") {
        return run_family(args, &sizes, &python, &dir, &simd);
    }
    let threads = rayon::current_num_threads();
    println!("# avar speed report ({threads} threads available; best of 3; {simd})\n");
    if !have_py {
        println!(
            "allantools: no Python venv at {python:?} (python3 -m venv target/venv && target/venv/bin/pip install allantools); skipped\n"
        );
    }
    println!(
        "| T | one pass (sum) | avar dyadic, no CI | avar dyadic, 1 thread | avar dyadic + chi² CI | avar octave, no CI | allantools oadev octave | speed-up vs allantools | dyadic / one pass | max rel. diff vs allantools | peak RSS avar / allantools |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let no_ci = AvarConfig {
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let octave = AvarConfig {
        scales: Scales::Octave,
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    for &n in &sizes {
        let x = data(n);
        let file = dir.join(format!("white_{n}.f64"));
        if have_py {
            let mut f = std::fs::File::create(&file).map_err(|e| e.to_string())?;
            let bytes: Vec<u8> = x.iter().flat_map(|v| v.to_le_bytes()).collect();
            f.write_all(&bytes).map_err(|e| e.to_string())?;
        }
        let (t_pass, _) = best_of(3, || {
            std::hint::black_box(crate::avar_e2e::one_pass(std::hint::black_box(&x)))
        });
        let (t_dy, _) = best_of(3, || {
            allan_variance(&x, 1.0, &no_ci).map(|a| a.points.len())
        });
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .map_err(|e| e.to_string())?;
        let (t_dy1, _) = best_of(3, || {
            pool.install(|| allan_variance(&x, 1.0, &no_ci).map(|a| a.points.len()))
        });
        let (t_ci, _) = best_of(3, || {
            allan_variance(&x, 1.0, &AvarConfig::default()).map(|a| a.points.len())
        });
        let (t_oct, ours) = best_of(3, || allan_variance(&x, 1.0, &octave));
        let ours = ours.map_err(|e| e.to_string())?;
        let hwm = vm_hwm_mb();
        let (py_s, diff, py_mem) = if have_py {
            // best of three as ours up to 10^7; one call (about 14 s) above
            let py = run_allantools(
                &python,
                &file,
                "octave",
                if n <= 10_000_000 { 3 } else { 1 },
            )?;
            let mut worst = 0.0f64;
            let mut matched = 0;
            for (tau, dev) in py.taus.iter().zip(&py.devs) {
                if let Some(p) = ours.points.iter().find(|p| (p.tau - tau).abs() < 1e-9) {
                    worst = worst.max(((p.adev - dev) / dev).abs());
                    matched += 1;
                }
            }
            (
                format!("{:.3} s", py.seconds),
                format!("{worst:.1e} ({matched} τ)"),
                format!("{:.0} MB", py.maxrss_mb),
            )
        } else {
            ("—".into(), "—".into(), "—".into())
        };
        let speedup = py_s
            .trim_end_matches(" s")
            .parse::<f64>()
            .map(|s| format!("{:.1}×", s / t_dy))
            .unwrap_or("—".into());
        println!(
            "| {n:.0e} | {:.1} ms | {:.1} ms | {:.1} ms | {:.1} ms | {:.1} ms | {py_s} | {speedup} | {:.1}× | {diff} | {hwm:.0} MB / {py_mem} |",
            1e3 * t_pass,
            1e3 * t_dy,
            1e3 * t_dy1,
            1e3 * t_ci,
            1e3 * t_oct,
            t_dy / t_pass,
        );
        drop(x);
        let _ = std::fs::remove_file(&file);
    }
    if all_n == 0 {
        return Ok(());
    }
    let x = data(all_n);
    let all = AvarConfig {
        scales: Scales::All,
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let t = Instant::now();
    let av = allan_variance(&x, 1.0, &all).map_err(|e| e.to_string())?;
    println!(
        "\n\"all m\" on T = {all_n:.0e}: {} scales in {:.1} s (avar, no CI)",
        av.points.len(),
        t.elapsed().as_secs_f64()
    );
    if have_py {
        let small = 100_000usize;
        let file = dir.join(format!("white_{small}.f64"));
        let bytes: Vec<u8> = data(small).iter().flat_map(|v| v.to_le_bytes()).collect();
        std::fs::write(&file, bytes).map_err(|e| e.to_string())?;
        let py = run_allantools(&python, &file, "all", 1)?;
        let xs = data(small);
        let t = Instant::now();
        let av = allan_variance(&xs, 1.0, &all).map_err(|e| e.to_string())?;
        println!(
            "\"all m\" on T = 1e5: avar {} scales in {:.2} s; allantools oadev taus=\"all\" {} τ in {:.2} s",
            av.points.len(),
            t.elapsed().as_secs_f64(),
            py.taus.len(),
            py.seconds
        );
        let _ = std::fs::remove_file(&file);
    }
    Ok(())
}
