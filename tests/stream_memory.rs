//! Issue 13: `imunoise avar` on a raw f64 file of 2·10^7 samples (160 MB) without a CI holds
//! at most 64 MiB more than the same command on a tiny file (the stated constant: the
//! program, its libraries and thread stacks, measured in the same test), so the bounded
//! memory of the streamed path cannot silently regress. With the chi-square CI it holds at
//! most 128 MiB more: the checkpoints of the cumulative sum (5 MB here) and, per thread (two),
//! a 16 MiB window of the cumulative sum and the file pages of the window it reads (the
//! in-memory path held the series-sized cumulative sum beside the file: 320 MB). Peak RSS is the child's `ru_maxrss`
//! from `wait4` (VmHWM at exit; mapped file pages count in it); on Linux it also covers this
//! test process's own peak (recorded at `exec`), which stays small here: the file is written
//! in blocks, so the measured value is an upper bound.

#![cfg(target_os = "linux")]

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};

/// Writes `n` samples of white noise around an offset, in blocks of 64 Ki samples.
fn write_series(path: &Path, n: usize) {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut block = Vec::with_capacity(8 << 16);
    let mut done = 0;
    while done < n {
        block.clear();
        for _ in 0..(1 << 16).min(n - done) {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let v = 1e-3 + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-6;
            block.extend_from_slice(&v.to_le_bytes());
        }
        w.write_all(&block).unwrap();
        done += block.len() / 8;
    }
    w.flush().unwrap();
}

/// Peak RSS (MiB) of `imunoise avar FILE --binary f64 --rate 100 --ci CI` on two threads.
// the child is reaped by `wait4` below (which also gives its rusage), not by `Child::wait`
#[allow(clippy::zombie_processes)]
fn peak_rss_mib(file: &Path, ci: &str) -> f64 {
    let child = Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .arg("avar")
        .arg(file)
        .args([
            "--binary", "f64", "--rate", "100", "--ci", ci, "--format", "csv",
        ])
        .env("RAYON_NUM_THREADS", "2")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut status = 0i32;
    // SAFETY: an all-zero rusage is a valid value of the plain C struct.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `child.id()` is our unwaited child; `status` and `ru` are valid for writes.
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut ru) };
    assert!(pid > 0 && libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0);
    ru.ru_maxrss as f64 / 1024.0
}

#[test]
fn streamed_avar_memory_is_bounded() {
    let dir = tempfile::tempdir().unwrap();
    let tiny = dir.path().join("tiny.f64");
    write_series(&tiny, 4096);
    let big = dir.path().join("big.f64");
    write_series(&big, 20_000_000);
    let base = peak_rss_mib(&tiny, "none");
    let peak = peak_rss_mib(&big, "none");
    let peak_chi2 = peak_rss_mib(&big, "chi2");
    eprintln!(
        "peak RSS: {peak:.1} MiB on 2e7 samples (160 MB), {peak_chi2:.1} MiB with the chi-square \
         CI, {base:.1} MiB on 4096 samples"
    );
    assert!(base < 64.0, "the command alone takes {base:.1} MiB");
    assert!(
        peak <= base + 64.0,
        "2e7 samples: peak RSS {peak:.1} MiB > {base:.1} + 64 MiB"
    );
    assert!(
        peak_chi2 <= base + 128.0,
        "2e7 samples, chi-square CI: peak RSS {peak_chi2:.1} MiB > {base:.1} + 128 MiB"
    );
}
