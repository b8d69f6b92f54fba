//! `cargo xtask avar-speed --end-to-end [--sizes 1e7,1e8,1e9] [--rows6 1e8] [--ci-max 1e9]`:
//! from file to Allan variance (issue 13), in one run on this machine.
//!
//! For each size T a raw f64 file of T samples (white noise around an offset, written in
//! blocks; the files of 10^9 samples and the six-channel file are deleted afterwards) is
//! measured by
//! * `cat FILE > /dev/null` (second of two runs: the page cache is warm, as for the command,
//!   which runs next, before the in-memory copy of the series is made);
//! * one vectorised summing pass over the samples in memory, and `avar`'s kernel in memory
//!   (dyadic scales, without and with the chi-square CI), best of 2;
//! * the release `imunoise avar FILE --binary f64 --rate 1 --format csv` end to end, without
//!   and with `--ci chi2`, best of 2 each, with the child's peak RSS (`wait4` rusage, the
//!   VmHWM of the child: mapped file pages count in it), and whether its AV values equal the
//!   in-memory kernel's bit for bit.
//!
//! Then six interleaved channels × `--rows6` rows: the command on the interleaved file (which
//! it decodes a group of channels at a time) against six single-channel kernel runs in memory,
//! without and with the chi-square CI (the latter up to `--ci-max` rows).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use avar::{AvarConfig, CiMethod, allan_variance};

/// The same white series as the speed report's `data` (seed `seed`), generated in blocks.
fn gen_block(state: &mut u64, out: &mut [f64]) {
    let mut s = *state;
    for v in out.iter_mut() {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        *v = 1e-3 + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-6;
    }
    *state = s;
}

fn seed(c: usize) -> u64 {
    0x9E37_79B9_7F4A_7C15u64 ^ ((c as u64) << 32)
}

/// Writes `n` rows of `channels` interleaved f64 (channel c from seed(c)).
fn write_file(path: &Path, n: usize, channels: usize) -> Result<(), String> {
    let f = std::fs::File::create(path).map_err(|e| e.to_string())?;
    let mut w = std::io::BufWriter::with_capacity(1 << 22, f);
    let mut st: Vec<u64> = (0..channels).map(seed).collect();
    const B: usize = 1 << 16;
    let mut cols = vec![vec![0.0f64; B]; channels];
    let mut row = Vec::with_capacity(B * channels * 8);
    let mut done = 0;
    while done < n {
        let k = B.min(n - done);
        for (c, col) in cols.iter_mut().enumerate() {
            gen_block(&mut st[c], &mut col[..k]);
        }
        row.clear();
        for r in 0..k {
            for col in &cols {
                row.extend_from_slice(&col[r].to_le_bytes());
            }
        }
        w.write_all(&row).map_err(|e| e.to_string())?;
        done += k;
    }
    w.flush().map_err(|e| e.to_string())
}

/// Channel `c` of the file in memory.
fn series(n: usize, c: usize) -> Vec<f64> {
    let mut x = vec![0.0f64; n];
    let mut st = seed(c);
    gen_block(&mut st, &mut x);
    x
}

fn best<T>(reps: usize, mut f: impl FnMut() -> Result<T, String>) -> Result<(f64, T), String> {
    let mut b = f64::INFINITY;
    let mut out = None;
    for _ in 0..reps {
        let t = Instant::now();
        let r = f()?;
        b = b.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    Ok((b, out.expect("reps >= 1")))
}

/// Where GNU time writes the peak RSS of the child (KiB).
fn rss_path() -> PathBuf {
    std::env::temp_dir().join(format!("avar-e2e-rss-{}", std::process::id()))
}

const GNU_TIME: &str = "/usr/bin/time";

/// A command running `program` under GNU time (`-f %M`), which forks its child: the
/// `ru_maxrss` that `wait4` reports for a child spawned directly from this process would
/// include this process's own high-water mark (Linux records the old memory map's peak at
/// `exec` after `vfork`, and this process holds the in-memory series). Without GNU time that
/// upper bound is what [`run_child`] reports.
fn timed(program: &Path) -> Command {
    if Path::new(GNU_TIME).exists() {
        let mut c = Command::new(GNU_TIME);
        c.arg("-f").arg("%M").arg("-o").arg(rss_path()).arg(program);
        c
    } else {
        Command::new(program)
    }
}

/// Runs `cmd` (from [`timed`]), returning (seconds, stdout, peak RSS of the child in MiB).
fn run_child(cmd: &mut Command) -> Result<(f64, Vec<u8>, f64), String> {
    run_child_to(cmd, Stdio::piped())
}

/// [`run_child`] with the child's standard output sent to `stdout` (read back only when it is
/// a pipe): `cat FILE` goes to /dev/null, as a shell's `cat FILE > /dev/null` does, so that it
/// measures reading the file and nothing else. (Collected through a pipe, the 8 GB of the
/// 10^9-sample file took 20.8 s and a buffer of that size in this process, which pushed the
/// file out of the page cache before the command ran.)
fn run_child_to(cmd: &mut Command, stdout: Stdio) -> Result<(f64, Vec<u8>, f64), String> {
    let t = Instant::now();
    let mut child = cmd
        .stdout(stdout)
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("{cmd:?}: {e}"))?;
    let mut out = Vec::new();
    if let Some(mut so) = child.stdout.take() {
        std::io::Read::read_to_end(&mut so, &mut out).map_err(|e| e.to_string())?;
    }
    let mut err = Vec::new();
    if let Some(mut se) = child.stderr.take() {
        std::io::Read::read_to_end(&mut se, &mut err).map_err(|e| e.to_string())?;
    }
    let mut status = 0i32;
    // SAFETY: an all-zero rusage is a valid value of the plain C struct.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `child.id()` is our unwaited child; `status` and `ru` are valid for writes.
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut ru) };
    let secs = t.elapsed().as_secs_f64();
    if pid < 0 || !libc::WIFEXITED(status) || libc::WEXITSTATUS(status) != 0 {
        return Err(format!("{cmd:?} failed: {}", String::from_utf8_lossy(&err)));
    }
    let kb = match std::fs::read_to_string(rss_path()) {
        Ok(s) if Path::new(GNU_TIME).exists() => {
            let _ = std::fs::remove_file(rss_path());
            s.lines()
                .filter_map(|l| l.trim().parse::<f64>().ok())
                .next_back()
                .ok_or("no peak RSS from GNU time")?
        }
        _ => ru.ru_maxrss as f64,
    };
    Ok((secs, out, kb / 1024.0))
}

/// Per channel (in order), the (avar, avar_lo, avar_hi) of each point of the command's CSV
/// output, parsed exactly (Rust's float parsing is correctly rounded, and the CSV holds the
/// shortest representation that reads back to the same f64).
type Triples = Vec<Vec<(f64, Option<f64>, Option<f64>)>>;

fn csv_points(out: &[u8]) -> Result<Triples, String> {
    let text = String::from_utf8_lossy(out);
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().ok_or("empty output")?.split(',').collect();
    let col = |name: &str| {
        head.iter()
            .position(|h| *h == name)
            .ok_or(format!("no {name}"))
    };
    let (ch, av, lo, hi) = (
        col("channel")?,
        col("avar")?,
        col("avar_lo")?,
        col("avar_hi")?,
    );
    let mut out: Triples = Vec::new();
    let mut last = String::new();
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        if cells[ch] != last {
            last = cells[ch].to_string();
            out.push(Vec::new());
        }
        let num = |c: &str| c.parse::<f64>().ok();
        out.last_mut().expect("pushed").push((
            num(cells[av]).ok_or("bad avar")?,
            num(cells[lo]),
            num(cells[hi]),
        ));
    }
    Ok(out)
}

fn triples(av: &avar::AllanVariance) -> Vec<(f64, Option<f64>, Option<f64>)> {
    av.points
        .iter()
        .map(|p| (p.avar, p.avar_lo, p.avar_hi))
        .collect()
}

fn human(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
    } else {
        format!("{:.0} MiB", bytes as f64 / (1u64 << 20) as f64)
    }
}

/// Runs the end-to-end report.
pub fn run(args: &[String], root: &Path) -> Result<(), String> {
    let parse = |name: &str, default: &str| -> Result<Vec<usize>, String> {
        crate::args::value(args, name)
            .unwrap_or(default)
            .split(',')
            .map(|s| {
                s.trim()
                    .parse::<f64>()
                    .map(|v| v as usize)
                    .map_err(|_| format!("bad value {s} for {name}"))
            })
            .collect()
    };
    let sizes = parse("--sizes", "1e7,1e8,1e9")?;
    let rows6 = parse("--rows6", "1e8")?[0];
    let ci_max = parse("--ci-max", "1e9")?[0];
    let dir = root.join("target/avar-e2e");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    eprintln!("building the release command …");
    let st = Command::new(env!("CARGO"))
        .current_dir(root)
        .args([
            "build",
            "--release",
            "--bin",
            "imunoise",
            "--no-default-features",
        ])
        .status()
        .map_err(|e| e.to_string())?;
    if !st.success() {
        return Err("building imunoise failed".into());
    }
    let bin: PathBuf = root.join("target/release/imunoise");
    let load = std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default();
    println!(
        "# from file to Allan variance, end to end ({} threads; dyadic scales; load average at \
         start: {load}; the machine is shared with other sessions)\n",
        rayon::current_num_threads()
    );
    println!(
        "| T | file | cat (warm) | one pass | kernel in memory | end to end | ratio | peak RSS | kernel + chi² in memory | end to end chi² | ratio chi² | peak RSS chi² | identical |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|");
    let no_ci = AvarConfig {
        ci: CiMethod::None,
        ..AvarConfig::default()
    };
    let chi2 = AvarConfig::default();
    for &n in &sizes {
        let file = dir.join(format!("w_{n}.f64"));
        eprintln!("T = {n:e}: writing {}", file.display());
        write_file(&file, n, 1)?;
        let size = std::fs::metadata(&file).map_err(|e| e.to_string())?.len();
        let cat = || {
            let null = std::fs::File::create("/dev/null").map_err(|e| e.to_string())?;
            run_child_to(timed(Path::new("cat")).arg(&file), Stdio::from(null)).map(|(s, _, _)| s)
        };
        cat()?;
        let t_cat = cat()?;
        let with_ci = n <= ci_max;
        // end to end first, while the freshly written file is in the page cache (as for the
        // smaller sizes): the in-memory copy of the series made afterwards would evict part
        // of a large file
        let e2e = |ci: &str| {
            best(2, || {
                run_child(timed(&bin).arg("avar").arg(&file).args([
                    "--binary", "f64", "--rate", "1", "--format", "csv", "--ci", ci,
                ]))
            })
        };
        let (t_e2e, (_, out, rss)) = e2e("none")?;
        let (t_e2e_ci, out_ci, rss_ci) = if with_ci {
            let (t, (_, out, rss)) = e2e("chi2")?;
            (t, Some(out), rss)
        } else {
            (f64::NAN, None, f64::NAN)
        };
        // in memory
        let x = series(n, 0);
        let (t_pass, _) = best(2, || Ok(std::hint::black_box(one_pass(&x))))?;
        let (t_kernel, mem) = best(2, || {
            allan_variance(&x, 1.0, &no_ci).map_err(|e| e.to_string())
        })?;
        let mut same = csv_points(&out)? == vec![triples(&mem)];
        let t_kernel_ci = if let Some(out_ci) = &out_ci {
            let (t, av) = best(2, || {
                allan_variance(&x, 1.0, &chi2).map_err(|e| e.to_string())
            })?;
            same &= csv_points(out_ci)? == vec![triples(&av)];
            t
        } else {
            f64::NAN
        };
        drop(x);
        let ms = |s: f64| {
            if s.is_nan() {
                "—".to_string()
            } else if s < 10.0 {
                format!("{:.0} ms", s * 1e3)
            } else {
                format!("{s:.1} s")
            }
        };
        let mib = |m: f64| {
            if m.is_nan() {
                "—".to_string()
            } else {
                format!("{m:.0} MiB")
            }
        };
        println!(
            "| {n:.0e} | {} | {} | {} | {} | {} | {:.2}× | {} | {} | {} | {} | {} | {} |",
            human(size),
            ms(t_cat),
            ms(t_pass),
            ms(t_kernel),
            ms(t_e2e),
            t_e2e / t_kernel,
            mib(rss),
            ms(t_kernel_ci),
            ms(t_e2e_ci),
            if with_ci {
                format!("{:.2}×", t_e2e_ci / t_kernel_ci)
            } else {
                "—".to_string()
            },
            mib(rss_ci),
            if same { "yes" } else { "NO" }
        );
        if n >= 1_000_000_000 {
            std::fs::remove_file(&file).map_err(|e| e.to_string())?;
        }
    }
    if rows6 > 0 {
        let file = dir.join(format!("six_{rows6}.f64"));
        eprintln!("6 channels × {rows6:e}: writing {}", file.display());
        write_file(&file, rows6, 6)?;
        let size = std::fs::metadata(&file).map_err(|e| e.to_string())?.len();
        println!(
            "\n| 6 interleaved channels × rows | CI | file | six kernel runs in memory | end to end | ratio | peak RSS | identical |"
        );
        println!("|---:|---|---:|---:|---:|---:|---:|---|");
        for (config, ci) in [(&no_ci, "none"), (&chi2, "chi2")] {
            if ci == "chi2" && rows6 > ci_max {
                continue;
            }
            let mut t_six = 0.0;
            let mut mem = Vec::new();
            for c in 0..6 {
                let x = series(rows6, c);
                let (t, av) = best(2, || {
                    allan_variance(&x, 1.0, config).map_err(|e| e.to_string())
                })?;
                t_six += t;
                mem.push(triples(&av));
            }
            let (t_e2e, (_, out, rss)) = best(2, || {
                run_child(timed(&bin).arg("avar").arg(&file).args([
                    "--binary",
                    "f64",
                    "--channels",
                    "6",
                    "--rate",
                    "1",
                    "--format",
                    "csv",
                    "--ci",
                    ci,
                ]))
            })?;
            let same = csv_points(&out)? == mem;
            println!(
                "| {rows6:.0e} | {ci} | {} | {:.2} s | {:.2} s | {:.2}× | {rss:.0} MiB | {} |",
                human(size),
                t_six,
                t_e2e,
                t_e2e / t_six,
                if same { "yes" } else { "NO" }
            );
        }
        std::fs::remove_file(&file).map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// One vectorised summing pass over `x` (16 lanes): the memory-bandwidth baseline.
pub(crate) fn one_pass(x: &[f64]) -> f64 {
    let mut acc = [0.0f64; 16];
    let mut it = x.chunks_exact(16);
    for c in &mut it {
        for l in 0..16 {
            acc[l] += c[l];
        }
    }
    acc.iter().sum::<f64>() + it.remainder().iter().sum::<f64>()
}
