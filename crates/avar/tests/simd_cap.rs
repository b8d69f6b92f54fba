//! The SIMD cap (`IMUNOISE_SIMD`): no kernel runs a level above it.
//!
//! Every vector path of the crate records its level when it is entered
//! ([`avar::simd::highest_used`]). [`kernels_stay_at_or_below_the_level`] runs every kernel
//! family and holds that record to the process's level; [`each_cap_is_obeyed`] runs that test
//! again in a child process of this binary under each value of `IMUNOISE_SIMD` (the level is
//! read once per process, so a cap can only be tried in a fresh one).

use avar::simd::{self, SimdLevel};
use avar::stability::{Statistic, stability};
use avar::{AvarConfig, CiMethod, Scales, allan_variance};
use std::process::Command;

/// White noise on [−0.5, 0.5) plus an offset (xorshift, deterministic).
fn series(n: usize) -> Vec<f64> {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            3.0 + (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect()
}

/// Runs each kernel family once: the buffered MOAV (short series), the streamed MOAV (2^22
/// samples, rate input, no CI: the streamed kernel's near and far walks), the streamed
/// stability kernel (OHDEV, MDEV), the non-overlapping block pyramid (ADEV, HDEV) and the
/// robust AV; checks the AV at m = 1 of the long series against its definition.
fn run_every_kernel() {
    let no_ci = AvarConfig {
        ci: CiMethod::None,
        ..Default::default()
    };
    let short = series(50_000);
    allan_variance(&short, 1.0, &AvarConfig::default()).unwrap();
    let long = series(1 << 22);
    // m = 1, 2, 4, …, 2^20: near scales and far ones (2m > T/64)
    let streamed = AvarConfig {
        scales: Scales::Explicit((0..=20).map(|j| 1u64 << j).collect()),
        ci: CiMethod::None,
        ..Default::default()
    };
    let av = allan_variance(&long, 1.0, &streamed).unwrap();
    // AV(1) = Σ (x_{k+1} − x_k)² / (2 (T − 1)) by definition (a check that the kernel ran)
    let direct = long.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>()
        / (2.0 * (long.len() - 1) as f64);
    let p = &av.points[0];
    assert_eq!(p.m, 1);
    assert!(
        (p.avar - direct).abs() <= 1e-10 * direct,
        "{} {direct}",
        p.avar
    );
    let dyadic = AvarConfig {
        scales: Scales::Explicit(vec![1, 2, 64, 1024, 1 << 16]),
        ci: CiMethod::None,
        ..Default::default()
    };
    let mid = series(1 << 19);
    for s in [
        Statistic::Ohdev,
        Statistic::Mdev,
        Statistic::Adev,
        Statistic::Hdev,
    ] {
        stability(&mid, 1.0, s, &dyadic).unwrap();
    }
    avar::robust::robust_allan_variance(&short, 1.0, &no_ci, 0.95).unwrap();
}

/// The highest level any kernel ran is the process's level: never above it (the cap holds),
/// and not below it either (the record is live, and the widest path allowed is the one taken).
#[test]
fn kernels_stay_at_or_below_the_level() {
    run_every_kernel();
    let used = simd::highest_used().expect("the kernels ran");
    println!(
        "simd-cap: detected={} cap={} level={} used={}",
        simd::detected(),
        simd::cap().map_or("none", SimdLevel::name),
        simd::level(),
        used
    );
    assert!(simd::level() <= simd::detected());
    assert!(used <= simd::level(), "ran {used} above the level");
    assert_eq!(used, simd::level());
}

/// This binary's `kernels_stay_at_or_below_the_level` in a child process with `IMUNOISE_SIMD`
/// set to `value`: its report line and stderr; `None` when the binary cannot be executed
/// directly (under an emulator such as qemu-user, which does not follow the exec: the test
/// harness never started).
fn child(value: &str) -> Option<(String, String)> {
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "kernels_stay_at_or_below_the_level",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(simd::ENV_VAR, value)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    if !stdout.contains("running 1 test") {
        println!(
            "the test binary could not be re-executed ({}; {stderr})",
            out.status
        );
        return None;
    }
    assert!(
        out.status.success(),
        "IMUNOISE_SIMD={value}: child failed\n{stdout}\n{stderr}"
    );
    // (the harness may print "test … ... " before it on the same line)
    let line = stdout
        .lines()
        .find_map(|l| l.find("simd-cap: ").map(|i| l[i..].to_string()))
        .unwrap_or_else(|| panic!("no report line\n{stdout}"));
    Some((line, stderr))
}

/// Under each cap the kernels run exactly min(detected, cap) (a cap above the CPU's level does
/// not raise it; the children on this host cover every level it has); an unknown value is
/// reported and ignored.
#[test]
fn each_cap_is_obeyed() {
    let d = simd::detected();
    if child("").is_none() {
        println!("skipped: needs to run this test binary as a child process");
        return;
    }
    for cap in SimdLevel::ALL {
        let (line, _) = child(cap.name()).expect("the binary ran before");
        let want = simd::capped(d, Some(cap));
        let expect = format!("simd-cap: detected={d} cap={cap} level={want} used={want}");
        assert_eq!(line, expect);
    }
    let (line, stderr) = child("sse9").expect("the binary ran before");
    assert_eq!(
        line,
        format!("simd-cap: detected={d} cap=none level={d} used={d}")
    );
    assert!(
        stderr.contains("IMUNOISE_SIMD") && stderr.contains("sse9"),
        "{stderr}"
    );
    let (line, _) = child("").expect("the binary ran before");
    assert_eq!(
        line,
        format!("simd-cap: detected={d} cap=none level={d} used={d}")
    );
}
