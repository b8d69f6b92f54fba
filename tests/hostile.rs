//! Hostile input and hostile outputs, through the binary: the exit-code policy (2 for bad input
//! or arguments, 1 for failures of the machine, never a panic), magnitudes beyond f64, paths
//! that are directories, devices, pipes or full disks.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn imunoise(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts exit code `code`, no panic, and returns stderr.
fn fails_with(out: &Output, code: i32) -> String {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(code), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(err.lines().any(|l| l.starts_with("error: ")), "{err}");
    err
}

/// White noise (unit variance, a fixed LCG and Box–Muller) times `c`, as a one-column CSV whose
/// values round-trip exactly (Rust's shortest representation).
fn noise_csv(dir: &Path, name: &str, n: usize, c: f64) -> PathBuf {
    let mut s = String::from("x\n");
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut uniform = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    for _ in 0..n {
        let (u, v) = (uniform(), uniform());
        let z = (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos();
        s.push_str(&format!("{}\n", z * c));
    }
    let p = dir.join(name);
    std::fs::write(&p, s).unwrap();
    p
}

/// Issue 16, case 1: samples near 1e300 (a unit mix-up) used to print `"avar": null` at every
/// scale with exit 0. The AV (about 1e600) is not representable: exit 2, naming the channel,
/// the scale and the way out.
#[test]
fn samples_near_1e300_are_an_error_not_nulls() {
    let dir = tempfile::tempdir().unwrap();
    for (name, c) in [("huge.csv", 1e300), ("tiny.csv", 1e-300)] {
        let p = noise_csv(dir.path(), name, 2000, c);
        let out = imunoise(&["avar", p.to_str().unwrap(), "--rate", "100"]);
        let err = fails_with(&out, 2);
        assert!(out.stdout.is_empty(), "no partial output");
        assert!(err.contains("channel \"x\""), "{err}");
        assert!(err.contains("at m = 2"), "{err}");
        assert!(err.contains("outside the range of f64"), "{err}");
        assert!(err.contains("--scale"), "{err}");
    }
}

/// `imunoise avar --format csv` as rows of (m, avar, avar_lo, avar_hi, edf), parsed exactly
/// (the CSV writes the shortest representation that round-trips).
fn avar_csv(path: &Path) -> Vec<[f64; 5]> {
    let out = imunoise(&[
        "avar",
        path.to_str().unwrap(),
        "--rate",
        "100",
        "--format",
        "csv",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    parse_avar_csv(&out.stdout)
}

/// The rows of `imunoise avar --format csv` output (see [`avar_csv`]).
fn parse_avar_csv(stdout: &[u8]) -> Vec<[f64; 5]> {
    String::from_utf8_lossy(stdout)
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<f64> = l.split(',').skip(1).map(|v| v.parse().unwrap()).collect();
            // channel,m,tau,avar,adev,avar_lo,avar_hi,adev_lo,adev_hi,edf,n_terms
            [f[0], f[2], f[4], f[5], f[8]]
        })
        .collect()
}

/// Huge and tiny magnitudes that are representable give the right numbers: AV(2^k·x) =
/// 4^k·AV(x) exactly, CI bounds included, end to end through the text reader and writer.
#[test]
fn huge_and_tiny_magnitudes_give_exactly_scaled_results() {
    let dir = tempfile::tempdir().unwrap();
    let base = avar_csv(&noise_csv(dir.path(), "one.csv", 5000, 1.0));
    for k in [-500, 500] {
        let other = avar_csv(&noise_csv(dir.path(), "k.csv", 5000, 2f64.powi(k)));
        assert_eq!(base.len(), other.len());
        for (p, q) in base.iter().zip(&other) {
            assert_eq!(p[0], q[0]);
            for i in 1..4 {
                assert_eq!(
                    q[i],
                    p[i] * 2f64.powi(2 * k),
                    "k={k} column {i} at m={}",
                    p[0]
                );
            }
            // the EDF is printed rounded; it is scale-free
            assert_eq!(p[4], q[4]);
        }
    }
}

/// Issue 16, case 2: a directory as input used to exit 1 with "No such device (os error 19)".
#[test]
fn a_directory_or_a_device_as_input_is_named_in_plain_words() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    // a folder is read as a ROS 2 bag folder when it holds one .mcap or .db3 file
    let err = fails_with(&imunoise(&["avar", d, "--rate", "100"]), 2);
    assert!(
        err.contains("is a folder without a .mcap or .db3 file"),
        "{err}"
    );
    assert!(!err.contains("os error"), "{err}");
    if Path::new("/dev/null").exists() {
        let err = fails_with(&imunoise(&["avar", "/dev/null", "--rate", "100"]), 2);
        assert!(err.contains("/dev/null: is a device"), "{err}");
    }
    let err = fails_with(&imunoise(&["fit", d, "--rate", "100"]), 2);
    assert!(err.contains("is a folder"), "{err}");
    // a folder is no pipe: no note that it is read whole into memory
    assert!(!err.contains("cannot be read by position"), "{err}");
    // a missing input, text or raw binary of one or several channels, is named as missing,
    // with no note before it that it would be a pipe read into memory or temporary files
    let missing = dir.path().join("missing.csv");
    let m = missing.to_str().unwrap();
    for args in [
        vec!["avar", m, "--rate", "1"],
        vec!["analyze", m, "--rate", "1"],
        vec!["fit", m, "--rate", "1"],
        vec!["avar", m, "--rate", "1", "--binary", "f64"],
        vec![
            "avar",
            m,
            "--rate",
            "1",
            "--binary",
            "f64",
            "--channels",
            "2",
        ],
    ] {
        let err = fails_with(&imunoise(&args), 2);
        assert!(err.contains("no such file or directory"), "{args:?}: {err}");
        assert!(!err.contains("note:"), "{args:?}: {err}");
    }
}

/// Issue 16, case 3: `analyze --out EXISTING_FILE` used to exit 1 with "File exists (os error
/// 17)" after all the work. Now exit 2 at once, naming the option.
#[test]
fn an_output_path_that_is_a_file_or_a_directory_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let data = noise_csv(dir.path(), "d.csv", 3000, 1.0);
    let file = dir.path().join("report");
    std::fs::write(&file, b"not a directory").unwrap();
    for sub in ["analyze", "demo"] {
        let mut args = vec![sub];
        if sub == "analyze" {
            args.extend([data.to_str().unwrap(), "--rate", "100"]);
        }
        args.extend(["--out", file.to_str().unwrap()]);
        let t0 = std::time::Instant::now();
        let err = fails_with(&imunoise(&args), 2);
        assert!(
            err.contains("--out") && err.contains("is an existing file, not a directory"),
            "{err}"
        );
        // refused before the work: the demo alone takes seconds
        assert!(t0.elapsed().as_secs_f64() < 60.0);
        let nested = file.join("sub");
        let mut args2 = args.clone();
        let last = args2.len() - 1;
        args2[last] = nested.to_str().unwrap();
        let err = fails_with(&imunoise(&args2), 2);
        assert!(err.contains("a part of the path is a file"), "{err}");
    }
    let err = fails_with(
        &imunoise(&[
            "simulate",
            "--model",
            "WN(sigma2=1)",
            "-n",
            "100",
            "--rate",
            "1",
            "-o",
            dir.path().to_str().unwrap(),
        ]),
        2,
    );
    assert!(
        err.contains("-o") && err.contains("is a directory"),
        "{err}"
    );
}

/// A full disk is a failure of the machine: exit 1, "no space left on the device", for a file
/// output and for standard output (Linux's /dev/full fails every write with ENOSPC).
#[test]
fn a_full_disk_is_exit_1_in_plain_words() {
    if !Path::new("/dev/full").exists() {
        eprintln!("skip: /dev/full is absent on this system");
        return;
    }
    let err = fails_with(
        &imunoise(&[
            "simulate",
            "--model",
            "WN(sigma2=1)",
            "-n",
            "100000",
            "--rate",
            "1",
            "-o",
            "/dev/full",
        ]),
        1,
    );
    assert!(
        err.contains("cannot write /dev/full: no space left on the device"),
        "{err}"
    );
    let dir = tempfile::tempdir().unwrap();
    let data = noise_csv(dir.path(), "d.csv", 3000, 1.0);
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .args(["avar", data.to_str().unwrap(), "--rate", "100"])
        .stdout(Stdio::from(full))
        .output()
        .unwrap();
    let err = fails_with(&out, 1);
    assert!(
        err.contains("cannot write <stdout>: no space left"),
        "{err}"
    );
}

/// Standard input (`-`) and a FIFO are read (into memory) and give the same result as the file.
#[test]
fn standard_input_and_fifos_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let data = noise_csv(dir.path(), "d.csv", 3000, 1.0);
    let expect = avar_csv(&data);
    let mut child = Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .args(["avar", "-", "--rate", "100", "--format", "csv"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let bytes = std::fs::read(&data).unwrap();
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().unwrap();
        stdin.write_all(&bytes).unwrap();
    }
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    assert_eq!(parse_avar_csv(&out.stdout), expect);
    #[cfg(unix)]
    {
        let fifo = dir.path().join("fifo");
        let ok = Command::new("mkfifo").arg(&fifo).status();
        if ok.is_ok_and(|s| s.success()) {
            let f2 = fifo.clone();
            let writer = std::thread::spawn(move || std::fs::write(f2, bytes).unwrap());
            let got = avar_csv(&fifo);
            writer.join().unwrap();
            assert_eq!(got, expect);
        }
    }
}

/// The policy is stated in `--help`.
#[test]
fn help_states_the_exit_code_policy() {
    let out = imunoise(&["--help"]);
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("Exit codes: 0 success; 2 bad input"), "{s}");
}

/// A one-column CSV `gyro_x_dps` at 100 Hz: white noise of SD 0.05 °/s plus `extra(i)`.
fn gyro_csv(dir: &Path, name: &str, n: usize, extra: impl Fn(usize) -> f64) -> PathBuf {
    let p = noise_csv(dir, "base.csv", n, 0.05);
    let text = std::fs::read_to_string(&p).unwrap();
    let mut s = String::from("gyro_x_dps\n");
    for (i, l) in text.lines().skip(1).enumerate() {
        let v: f64 = l.parse().unwrap();
        s.push_str(&format!("{}\n", v + extra(i)));
    }
    let q = dir.join(name);
    std::fs::write(&q, s).unwrap();
    q
}

/// Issue 16, case 4a: a level shift (a bump of the mount) used to end in "AᵀΩA is singular at
/// θ̂: the parameters are not identifiable from these scales". Now the data-quality pass names
/// the shift and its time before fitting, and the fit failure names the component, the scales
/// and what to try.
#[test]
fn a_level_shift_is_named_and_the_fit_failure_says_what_to_try() {
    let dir = tempfile::tempdir().unwrap();
    let p = gyro_csv(dir.path(), "shift.csv", 200_000, |i| {
        if i >= 120_000 { 0.2 } else { 0.0 }
    });
    let out = imunoise(&["fit", p.to_str().unwrap(), "--rate", "100"]);
    let err = stderr(&out);
    assert!(
        err.contains("at t = 1200.000 s") && err.contains("like a rate random walk"),
        "{err}"
    );
    // the size: 0.2 within 5 standard errors of a difference of two means of 4 blocks of
    // 781 samples of SD 0.05 (√(2·0.05²/3124) = 0.0013)
    let size: f64 = err
        .split("a level shift of ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|s| s.parse().ok())
        .expect("the size is printed");
    assert!((size - 0.2).abs() < 5.0 * 0.0013, "{size}");
    // with this (fixed) noise the default QN + WN + RW + AR1 fit is singular
    let err = fails_with(&out, 2);
    assert!(!err.contains("singular"), "{err}");
    assert!(
        err.contains("cannot be identified from the scales τ = 0.02 … 655.36 s"),
        "{err}"
    );
    assert!(
        err.contains("--select")
            && err.contains("a smaller model such as")
            && err.contains("longer record"),
        "{err}"
    );
}

/// Issue 16, case 4b: periodic 50σ spikes used to be fitted with full confidence and no remark.
/// Now `fit` lists them (count, period, times, share of the AV) in its JSON warnings, and the
/// report of `analyze` has a Remarks section.
#[test]
fn periodic_spikes_are_remarked_in_fit_and_report() {
    let dir = tempfile::tempdir().unwrap();
    let p = gyro_csv(dir.path(), "spikes.csv", 200_000, |i| {
        if i % 5000 == 2500 { 2.5 } else { 0.0 }
    });
    let out = imunoise(&[
        "fit",
        p.to_str().unwrap(),
        "--rate",
        "100",
        "--model",
        "WN",
        "--format",
        "json",
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let w = v["channels"][0]["warnings"][0].as_str().unwrap();
    assert!(
        w.contains("40 spikes")
            && w.contains("periodic every 50.0000 s")
            && w.contains("t = 25.000, 75.000"),
        "{w}"
    );
    let rep = dir.path().join("rep");
    let out = imunoise(&[
        "analyze",
        p.to_str().unwrap(),
        "--rate",
        "100",
        "--out",
        rep.to_str().unwrap(),
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    assert!(
        html.contains("<h2>Remarks</h2>") && html.contains("40 spikes"),
        "no remark"
    );
    let json = std::fs::read_to_string(rep.join("results.json")).unwrap();
    assert!(json.contains("periodic every 50.0000 s"));
}

/// Samples near 1e150 (AV near 1e300) are estimated exactly, but a fit of such a curve is
/// refused with a message about the magnitude (it used to blame the model as "not identifiable").
#[test]
fn a_fit_far_from_unit_magnitude_names_the_magnitude() {
    let dir = tempfile::tempdir().unwrap();
    let p = noise_csv(dir.path(), "huge.csv", 5000, 2f64.powi(500));
    let out = imunoise(&["fit", p.to_str().unwrap(), "--rate", "100", "-q"]);
    let err = fails_with(&out, 2);
    assert!(err.contains("too far from unit magnitude"), "{err}");
    assert!(err.contains("--scale"), "{err}");
    // the same data at unit scale fit
    let q = noise_csv(dir.path(), "unit.csv", 5000, 1.0);
    let out = imunoise(&[
        "fit",
        q.to_str().unwrap(),
        "--rate",
        "100",
        "--model",
        "WN",
        "-q",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
}

/// `fit --robust` on samples near 1e154 used to loop forever (the robust AV's squared
/// differences overflowed to an infinite mean square). Now the robust AV is computed on an exact
/// power-of-two rescaled copy, and the fit is refused for its magnitude as the classical one is.
#[test]
fn a_robust_fit_of_huge_samples_ends_with_the_magnitude_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = noise_csv(dir.path(), "huge.csv", 5000, 1e154);
    let out = imunoise(&[
        "fit",
        p.to_str().unwrap(),
        "--rate",
        "100",
        "--robust",
        "--model",
        "WN",
        "-q",
    ]);
    let err = fails_with(&out, 2);
    assert!(err.contains("too far from unit magnitude"), "{err}");
}

/// A bootstrap of a billion replicates used to abort on a failed allocation; now it is refused.
#[test]
fn an_absurd_bootstrap_count_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = noise_csv(dir.path(), "d.csv", 3000, 1.0);
    let out = imunoise(&[
        "fit",
        p.to_str().unwrap(),
        "--rate",
        "100",
        "--model",
        "WN",
        "--bootstrap",
        "1000000000",
        "-q",
    ]);
    let err = fails_with(&out, 2);
    assert!(err.contains("more than the 100000 this runs"), "{err}");
}
