//! The `imunoise` binary on good and bad inputs: one test per error class (exit code 2
//! and a message naming file, line and column), the JSON shapes, and round trips
//! (simulate → avar, binary ↔ text).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn imunoise(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// Runs the binary and asserts that it succeeded (printing its stderr otherwise).
fn imunoise_ok(args: &[&str]) -> Output {
    let out = imunoise(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn write(dir: &Path, name: &str, content: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).expect("write");
    p
}

/// Runs `avar` on a file, expects exit code 2 and returns stderr.
fn avar_fails(path: &Path, extra: &[&str]) -> String {
    let mut args = vec!["avar", path.to_str().unwrap()];
    args.extend_from_slice(extra);
    if !extra.contains(&"--rate") {
        args.extend_from_slice(&["--rate", "100"]);
    }
    let out = imunoise(&args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(out.stdout.is_empty(), "no output on error");
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// A valid CSV of `n` rows of two columns (exact values).
fn good_csv(n: usize) -> String {
    let mut s = String::from("gyro_x_dps,acc_z_g\n");
    for i in 0..n {
        s.push_str(&format!(
            "{},{}\n",
            (i % 7) as f64 * 0.25,
            -1.0 + (i % 3) as f64 * 0.5
        ));
    }
    s
}

#[test]
fn non_numeric_cell_names_file_line_column() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = good_csv(100);
    s.push_str("0.5,abc\n");
    let p = write(dir.path(), "bad.csv", s.as_bytes());
    let err = avar_fails(&p, &[]);
    // header + 100 rows → the bad row is line 102; "abc" starts at column 5.
    assert!(err.contains(&format!("{}:102:5:", p.display())), "{err}");
    assert!(err.contains("abc"), "{err}");
}

#[test]
fn ragged_row_names_file_line_column() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = good_csv(50);
    s.push_str("1.0\n");
    s.push_str(&good_csv(10)[19..]);
    let p = write(dir.path(), "ragged.csv", s.as_bytes());
    let err = avar_fails(&p, &[]);
    assert!(err.contains(&format!("{}:52:4:", p.display())), "{err}");
    assert!(err.contains("ragged row: 1 cells"), "{err}");
}

#[test]
fn nan_and_infinity_name_file_line_column() {
    let dir = tempfile::tempdir().unwrap();
    for (bad, col) in [("nan", 6), ("inf", 6), ("1e999", 6)] {
        let mut s = good_csv(20);
        s.push_str(&format!("0.25,{bad}\n"));
        let p = write(dir.path(), "nan.csv", s.as_bytes());
        let err = avar_fails(&p, &[]);
        assert!(err.contains(&format!("{}:22:{col}:", p.display())), "{err}");
        assert!(err.contains("not a finite number"), "{err}");
    }
    // Binary input: row and channel.
    let mut bytes: Vec<u8> = (0..40).flat_map(|i| (i as f64).to_le_bytes()).collect();
    bytes[8 * 13..8 * 14].copy_from_slice(&f64::NAN.to_le_bytes());
    let p = write(dir.path(), "nan.f64", &bytes);
    let err = avar_fails(&p, &["--binary", "f64", "--channels", "2"]);
    // value 13 is row 7, channel 2
    assert!(err.contains(&format!("{}:7:2:", p.display())), "{err}");
}

#[test]
fn empty_files_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    for (name, content) in [
        ("empty.csv", &b""[..]),
        ("header_only.csv", &b"a,b\n"[..]),
        ("blank.csv", &b"\n\n  \n"[..]),
    ] {
        let p = write(dir.path(), name, content);
        let err = avar_fails(&p, &[]);
        assert!(err.contains(&p.display().to_string()), "{err}");
        assert!(err.contains("empty"), "{err}");
    }
}

#[test]
fn missing_or_nonpositive_rate_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "ok.csv", good_csv(100).as_bytes());
    let out = imunoise(&["avar", p.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--rate"));
    for rate in ["0", "-5", "nan", "inf", "fast"] {
        let err = avar_fails(&p, &["--rate", rate]);
        assert!(err.contains("--rate"), "{rate}: {err}");
    }
}

#[test]
fn too_few_samples_for_any_scale() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "short.csv", b"x\n1\n2\n3\n");
    let err = avar_fails(&p, &[]);
    assert!(err.contains(&p.display().to_string()), "{err}");
    assert!(err.contains("too few samples"), "{err}");
    // Enough for the estimator, but no dyadic scale fits (2^(j+1) < T fails for j = 1).
    let p = write(dir.path(), "four.csv", b"x\n1\n2\n3\n5\n");
    let err = avar_fails(&p, &[]);
    assert!(err.contains(&p.display().to_string()), "{err}");
}

#[test]
fn avar_json_shape_and_ci_none() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "ok.csv", good_csv(1000).as_bytes());
    let run = |ci: &str| {
        let out = imunoise_ok(&[
            "avar",
            p.to_str().unwrap(),
            "--rate",
            "50",
            "--format",
            "json",
            "--ci",
            ci,
        ]);
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let doc = run("chi2");
    let obj = doc.as_object().unwrap();
    assert_eq!(obj.keys().collect::<Vec<_>>(), ["channels"]);
    let ch = &doc["channels"][0];
    let mut keys: Vec<&String> = ch.as_object().unwrap().keys().collect();
    keys.sort();
    assert_eq!(keys, ["estimator", "n", "name", "points", "rate_hz"]);
    assert_eq!(ch["name"], "gyro_x_dps");
    assert_eq!(ch["n"], 1000);
    assert_eq!(ch["rate_hz"], 50.0);
    let pts = ch["points"].as_array().unwrap();
    // T = 1000: m = 2^j while 2^(j+1) < 1000, j = 1..=8.
    assert_eq!(pts.len(), 8);
    let p0 = pts[0].as_object().unwrap();
    let mut pk: Vec<&String> = p0.keys().collect();
    pk.sort();
    assert_eq!(
        pk,
        [
            "adev", "avar", "avar_hi", "avar_lo", "edf", "m", "n_terms", "tau"
        ]
    );
    assert_eq!(pts[0]["m"], 2);
    assert_eq!(pts[0]["tau"], 0.04);
    assert_eq!(pts[0]["n_terms"], 997);
    assert!(pts[0]["avar_lo"].as_f64().unwrap() < pts[0]["avar"].as_f64().unwrap());
    let doc = run("none");
    for p in doc["channels"][1]["points"].as_array().unwrap() {
        assert!(p["avar_lo"].is_null() && p["avar_hi"].is_null() && p["edf"].is_null());
        assert!(p["avar"].as_f64().unwrap() > 0.0);
    }
}

/// The AV of a period-7 sawtooth has a closed value at m = 7: every cluster mean is the
/// same (the mean over a whole period), so AV(7) = 0 exactly up to rounding, while m = 1 on
/// a sequence 0, .25, …, 1.5 gives Σ(Δ²)/(2(T−1)) computed here independently.
#[test]
fn avar_values_from_text_and_binary_agree_with_hand_computation() {
    let dir = tempfile::tempdir().unwrap();
    let n = 700;
    let x: Vec<f64> = (0..n).map(|i| (i % 7) as f64 * 0.25).collect();
    let text: String = std::iter::once("x\n".to_string())
        .chain(x.iter().map(|v| format!("{v}\n")))
        .collect();
    let pt = write(dir.path(), "x.txt", text.as_bytes());
    let bytes: Vec<u8> = x.iter().flat_map(|v| v.to_le_bytes()).collect();
    let pb = write(dir.path(), "x.f64", &bytes);
    let get = |args: &[&str]| {
        let out = imunoise(args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let a = get(&[
        "avar",
        pt.to_str().unwrap(),
        "-r",
        "1",
        "--scales",
        "1,7",
        "-f",
        "json",
        "--ci",
        "none",
    ]);
    let b = get(&[
        "avar",
        pb.to_str().unwrap(),
        "-r",
        "1",
        "--scales",
        "1,7",
        "-f",
        "json",
        "--ci",
        "none",
        "--binary",
        "f64",
    ]);
    let expect1: f64 =
        x.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (2.0 * (n - 1) as f64);
    for doc in [&a, &b] {
        let p = &doc["channels"][0]["points"];
        assert!((p[0]["avar"].as_f64().unwrap() - expect1).abs() < 1e-12 * expect1);
        assert!(p[1]["avar"].as_f64().unwrap().abs() < 1e-20);
    }
    assert_eq!(b["channels"][0]["name"], "ch1");
    assert_eq!(a["channels"][0]["name"], "x");
}

#[test]
fn simulate_csv_and_f64_round_trip_through_avar() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("sim.csv");
    let f64p = dir.path().join("sim.f64");
    let model = "WN(sigma2=1e-4)+RW(gamma2=1e-10)";
    for p in [&csv, &f64p] {
        simulate_file(p, model, "20000", "3", &["--channels", "2"]);
    }
    let header = std::fs::read_to_string(&csv).unwrap();
    assert!(header.starts_with("ch1,ch2\n"));
    assert_eq!(header.lines().count(), 20_001);
    assert_eq!(std::fs::metadata(&f64p).unwrap().len(), 20_000 * 2 * 8);
    let get = |args: &[&str]| {
        let out = imunoise(args);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    let a = get(&["avar", csv.to_str().unwrap(), "-r", "100", "-f", "json"]);
    let b = get(&[
        "avar",
        f64p.to_str().unwrap(),
        "-r",
        "100",
        "-f",
        "json",
        "--binary",
        "f64",
        "--channels",
        "2",
    ]);
    // CSV holds shortest round-trip decimals, so both inputs are the same numbers.
    assert_eq!(a["channels"][1]["points"], b["channels"][1]["points"]);
    // Independent channels differ.
    assert_ne!(
        a["channels"][0]["points"][0]["avar"],
        a["channels"][1]["points"][0]["avar"]
    );
}

#[test]
fn theory_json_shape_and_closed_forms() {
    let out = imunoise_ok(&[
        "theory",
        "--model",
        "WN(sigma2=1e-4)+RW(gamma2=1e-10)",
        "--rate",
        "100",
        "--scales",
        "1,10",
        "--format",
        "json",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(doc["rate_hz"], 100.0);
    let pts = doc["points"].as_array().unwrap();
    assert_eq!(pts.len(), 2);
    // REFERENCES §2: WN σ²/m, RW γ²(2m²+1)/(6m); at m = 10: 1e-5 + 1e-10·201/60.
    let m10 = 1e-5 + 1e-10 * 201.0 / 60.0;
    assert!((pts[1]["avar"].as_f64().unwrap() - m10).abs() < 1e-15 * m10 * 10.0);
    assert_eq!(pts[1]["tau"], 0.1);
    let comps = doc["components"].as_array().unwrap();
    assert_eq!(comps.len(), 2);
    assert!(comps[0]["name"].as_str().unwrap().starts_with("WN"));
    assert_eq!(comps[0]["points"][1]["avar"], 1e-5);
}

#[test]
fn theory_takes_a_sinusoid_in_hz_at_the_rate() {
    // SIN(f_hz = 8) at 100 Hz is β = 2π·0.08 rad per sample; its AV (REFERENCES §11)
    // α²·sin⁴(βm/2)/(m·sin(β/2))² at m = 3 is the same through either spelling.
    let run = |model: &str| {
        let out = imunoise_ok(&[
            "theory", "--model", model, "--rate", "100", "--scales", "3", "--format", "json",
        ]);
        let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        doc["points"][0]["avar"].as_f64().unwrap()
    };
    let beta = 2.0 * std::f64::consts::PI * 0.08;
    let hz = run("SIN(alpha2=2e-4, f_hz=8)");
    let rad = run(&format!("SIN(alpha2=2e-4, beta={beta:?})"));
    let closed = 2e-4 * (beta * 1.5).sin().powi(4) / (3.0 * (beta / 2.0).sin()).powi(2);
    assert_eq!(hz, rad);
    assert!((hz - closed).abs() < 1e-12 * closed, "{hz} vs {closed}");
    // above Nyquist: a usage error naming the limit
    let out = imunoise(&[
        "theory",
        "--model",
        "SIN(alpha2=2e-4, f_hz=60)",
        "--rate",
        "100",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("Nyquist"));
}

#[test]
fn help_of_every_subcommand_has_an_example() {
    for sub in ["avar", "fit", "analyze", "simulate", "theory", "demo"] {
        let out = imunoise(&[sub, "--help"]);
        assert!(out.status.success());
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.contains("Examples:"), "{sub}: {text}");
        assert!(text.contains(&format!("imunoise {sub}")), "{sub}");
    }
}

#[test]
fn bad_model_and_unknown_column_are_user_errors() {
    let out = imunoise(&["theory", "--model", "WN(sigma2=-1)", "--rate", "1"]);
    assert_eq!(out.status.code(), Some(2));
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "ok.csv", good_csv(100).as_bytes());
    let err = avar_fails(&p, &["--columns", "nope"]);
    assert!(err.contains("nope") && err.contains("gyro_x_dps"), "{err}");
}

#[test]
fn theory_psd_is_the_white_noise_level() {
    // Two-sided PSD of WN(σ²) at rate r is σ²/r at every frequency (spectral's convention).
    let out = imunoise(&[
        "theory",
        "--model",
        "WN(sigma2=2e-4)",
        "--rate",
        "100",
        "-f",
        "json",
    ]);
    assert!(out.status.success());
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let psd = doc["psd"].as_array().unwrap();
    assert_eq!(psd.len(), 61);
    for p in psd {
        assert!((p["psd"].as_f64().unwrap() - 2e-6).abs() < 1e-18);
    }
    assert_eq!(psd.last().unwrap()["f"], 50.0);
}

/// The arguments of `imunoise fit` on the raw f64 file `p` sampled at 100 Hz, then `extra`.
fn fit_f64_args<'a>(p: &'a Path, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec!["fit", p.to_str().unwrap(), "--binary", "f64", "-r", "100"];
    args.extend_from_slice(extra);
    args
}

/// Runs `imunoise simulate` of `model` (n samples at 100 Hz, the given seed, extra flags) into
/// `path` and asserts success.
fn simulate_file(path: &Path, model: &str, n: &str, seed: &str, extra: &[&str]) {
    let mut args = vec![
        "simulate",
        "--model",
        model,
        "-n",
        n,
        "--rate",
        "100",
        "--seed",
        seed,
        "-o",
        path.to_str().unwrap(),
        "-q",
    ];
    args.extend_from_slice(extra);
    imunoise_ok(&args);
}

fn simulate_to(dir: &Path, model: &str, n: &str, unit_name: &str) -> PathBuf {
    let p = dir.join("sim.f64");
    simulate_file(&p, model, n, "11", &[]);
    let _ = unit_name;
    p
}

#[test]
fn fit_json_shape_and_white_noise_recovered() {
    let dir = tempfile::tempdir().unwrap();
    let p = simulate_to(dir.path(), "WN(sigma2=1e-4)+RW(gamma2=1e-10)", "65536", "x");
    let out = imunoise_ok(&fit_f64_args(
        &p,
        &["--unit", "deg/s", "--model", "WN+RW", "-f", "json"],
    ));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ch = &doc["channels"][0];
    let mut keys: Vec<&String> = ch.as_object().unwrap().keys().collect();
    keys.sort();
    assert_eq!(
        keys,
        [
            "adequacy",
            "ci_level",
            "ci_method",
            "converged",
            "fitted",
            "ieee",
            "j_test",
            "method",
            "model",
            "name",
            "noise_terms",
            "parameters"
        ]
    );
    assert_eq!(ch["method"], "gmwm");
    assert_eq!(ch["ci_method"], "delta_model_cov");
    assert_eq!(ch["ci_level"], 0.95);
    let pars = ch["parameters"].as_array().unwrap();
    assert_eq!(pars.len(), 2);
    assert_eq!(
        (pars[0]["process"].as_str(), pars[0]["name"].as_str()),
        (Some("WN"), Some("sigma2"))
    );
    // With T = 65536 the white-noise level dominates the first scales, whose AV has a
    // relative standard error of about √(2/T·…) < 1%: 10% is a wide margin.
    let wn = pars[0]["value"].as_f64().unwrap();
    assert!((wn / 1e-4 - 1.0).abs() < 0.1, "{wn}");
    assert!(pars[0]["ci_lo"].as_f64().unwrap() < wn && wn < pars[0]["ci_hi"].as_f64().unwrap());
    // IEEE N = √(σ²Δt) °/s·√s = 60·that °/√h ≈ 0.06.
    let n = ch["ieee"]["N"]["value"].as_f64().unwrap();
    assert!((n - 60.0 * (wn / 100.0).sqrt()).abs() < 1e-12);
    assert!(ch["j_test"]["p_value"].is_number());
    assert_eq!(ch["fitted"][0]["m"], 2);
}

#[test]
fn analyze_writes_report_plots_json_csv_yaml() {
    let dir = tempfile::tempdir().unwrap();
    let p = simulate_to(dir.path(), "WN(sigma2=1e-4)+RW(gamma2=1e-10)", "65536", "x");
    let out_dir = dir.path().join("rep");
    imunoise_ok(&[
        "analyze",
        p.to_str().unwrap(),
        "--binary",
        "f64",
        "-r",
        "100",
        "--unit",
        "deg/s",
        "--names",
        "gyro_x",
        "--model",
        "WN+RW",
        "--no-select",
        "-q",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let html = std::fs::read_to_string(out_dir.join("report.html")).unwrap();
    // the Allan deviation, the fit check, the time series and the ACF
    assert_eq!(html.matches("<svg").count(), 4);
    assert!(html.contains("Summary: the values a filter needs"));
    let res: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out_dir.join("results.json")).unwrap()).unwrap();
    assert_eq!(res["channels"][0]["name"], "gyro_x");
    assert_eq!(res["channels"][0]["fit"]["method"], "gmwm");
    assert_eq!(res["channels"][0]["fit"]["ci_method"], "delta_model_cov");
    assert!(html.contains("95% CIs by delta method, V = model-implied covariance"));
    let csv = std::fs::read_to_string(out_dir.join("avar.csv")).unwrap();
    // header + 14 dyadic scales (2^(j+1) < 65536 → j ≤ 14)
    assert_eq!(csv.lines().count(), 15);
    let yaml = std::fs::read_to_string(out_dir.join("imu.yaml")).unwrap();
    // Kalibr's gyroscope noise density is N in rad/s/√Hz = √(σ²/rate)·π/180.
    let wn = res["channels"][0]["fit"]["parameters"][0]["value"]
        .as_f64()
        .unwrap();
    let line = yaml
        .lines()
        .find(|l| l.starts_with("gyroscope_noise_density:"))
        .expect("gyro noise density");
    let v: f64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!((v / ((wn / 100.0).sqrt() * std::f64::consts::PI / 180.0) - 1.0).abs() < 1e-5);
    for stem in ["adev_gyro_x", "series_gyro_x", "acf_gyro_x"] {
        assert!(out_dir.join(format!("{stem}.svg")).exists());
        #[cfg(feature = "png")]
        {
            let png = std::fs::read(out_dir.join(format!("{stem}.png"))).unwrap();
            assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        }
    }
}

#[test]
fn fit_says_which_ci_method_it_used() {
    let dir = tempfile::tempdir().unwrap();
    let p = simulate_to(dir.path(), "WN(sigma2=1e-4)+RW(gamma2=1e-10)", "32768", "x");
    let fit = |extra: &[&str]| {
        let mut args = fit_f64_args(&p, &["--model", "WN+RW", "-q"]);
        args.extend_from_slice(extra);
        let out = imunoise_ok(&args);
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let doc: serde_json::Value =
        serde_json::from_str(&fit(&["--bootstrap", "3", "--alpha", "0.1", "-f", "json"])).unwrap();
    assert_eq!(doc["channels"][0]["ci_method"], "delta_bootstrap_cov");
    assert!((doc["channels"][0]["ci_level"].as_f64().unwrap() - 0.9).abs() < 1e-15);
    let table = fit(&["--bootstrap", "3"]);
    assert!(
        table.contains("95% CI (delta method, V = 3-replicate parametric-bootstrap"),
        "{table}"
    );
    // CSV: one row per parameter and IEEE term (N, K of the model, B read off its minimum);
    // IEEE N of a °/s channel is 60·√(σ²/rate) °/√h.
    let csv = fit(&["--unit", "deg/s", "-f", "csv"]);
    let rows: Vec<Vec<&str>> = csv.lines().map(|l| l.split(',').collect()).collect();
    assert_eq!(
        rows[0].join(","),
        "channel,process,name,value,ci_lo,ci_hi,unit,ci_method"
    );
    assert_eq!(rows.len(), 1 + 2 + 3, "{csv}");
    let cell = |r: usize, c: usize| rows[r][c].parse::<f64>().unwrap();
    let n = rows
        .iter()
        .position(|r| r[1] == "IEEE" && r[2] == "N")
        .unwrap();
    assert_eq!((rows[1][1], rows[1][2]), ("WN", "sigma2"));
    assert!((cell(n, 3) / (60.0 * (cell(1, 3) / 100.0).sqrt()) - 1.0).abs() < 1e-12);
    assert!((cell(n, 4) / (60.0 * (cell(1, 4) / 100.0).sqrt()) - 1.0).abs() < 1e-12);
    assert_eq!(rows[n][6], "°/√h");
    assert!(rows[1..].iter().all(|r| r[7] == "delta_model_cov"), "{csv}");
    // --select compares GMWM fits: with another method it is a usage error.
    let out = imunoise(&fit_f64_args(&p, &["--method", "avlr", "--select"]));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--select"));
    // The IEEE 952 read-off has no intervals, and says so.
    let doc: serde_json::Value =
        serde_json::from_str(&fit(&["--method", "ieee952", "-f", "json"])).unwrap();
    assert_eq!(doc["channels"][0]["ci_method"], "none");
    assert!(doc["channels"][0]["ci_level"].is_null());
}

/// Standard normal quantiles z_{1−α/2} for α = 0.05 and α = 0.05/24 (Python's
/// `statistics.NormalDist().inv_cdf(1 - a/2)`, an independent implementation).
const Z_975: f64 = 1.9599639845400536;
const Z_BONFERRONI_24: f64 = 3.0780880728421613;

#[test]
fn demo_reports_marginal_and_simultaneous_coverage() {
    let dir = tempfile::tempdir().unwrap();
    let out = imunoise_ok(&[
        "demo",
        "--samples",
        "65536",
        "--bootstrap",
        "4",
        "-q",
        "--out",
        dir.path().join("d").to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("Bonferroni over all K = 24 parameters"),
        "{text}"
    );
    assert!(text.contains("1 - 0.05/24 = 99.79%"), "{text}");
    // 24 parameter rows + 2 IEEE rows for gyro_x.
    assert_eq!(text.matches("gyro_x ").count(), 4 + 2, "{text}");
    assert!(dir.path().join("d/report.html").exists());
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("d/demo.json")).unwrap()).unwrap();
    assert_eq!(doc["k"], 24);
    assert_eq!(doc["simultaneous_method"], "bonferroni");
    assert!((doc["simultaneous_level"].as_f64().unwrap() - (1.0 - 0.05 / 24.0)).abs() < 1e-15);
    assert_eq!(doc["ci_method"], "delta_bootstrap_cov");
    let pair = |v: &serde_json::Value| (v[0].as_f64().unwrap(), v[1].as_f64().unwrap());
    let (mut sim_in, mut marg_in, mut n_ratio) = (0, 0, 0);
    let params = doc["parameters"].as_array().unwrap();
    assert_eq!(params.len(), 24);
    for p in params {
        let (lo, hi) = pair(&p["ci"]);
        let (slo, shi) = pair(&p["sim_ci"]);
        let (t, est) = (
            p["truth"].as_f64().unwrap(),
            p["estimate"].as_f64().unwrap(),
        );
        assert!(slo <= lo && lo <= est && est <= hi && hi <= shi, "{p}");
        // Variances get θ̂·exp(±z·se/θ̂): the log-width grows exactly by the ratio of quantiles.
        // (Not where θ̂ sits on the boundary 0 and z·se/θ̂ is capped: on 65536 samples the
        // gyros' RW can be.)
        let name = p["parameter"].as_str().unwrap();
        if (name.ends_with("sigma2") || name.ends_with("gamma2")) && lo > 0.0 && hi < 1.0 {
            let ratio = (shi / slo).ln() / (hi / lo).ln();
            assert!(
                (ratio / (Z_BONFERRONI_24 / Z_975) - 1.0).abs() < 1e-9,
                "{p}: {ratio}"
            );
            n_ratio += 1;
        }
        sim_in += usize::from(slo <= t && t <= shi);
        marg_in += usize::from(lo <= t && t <= hi);
    }
    // At least every white noise σ² (the best-determined parameters) was checked.
    assert!(n_ratio >= 6, "{n_ratio}");
    // The summary line states both counts as recomputed here.
    let summary = format!(
        "{sim_in} of 24 true parameters lie within their simultaneous 95% intervals (Bonferroni, K = 24)"
    );
    assert!(text.contains(&summary), "{summary}\n{text}");
    assert!(
        text.contains(&format!("{marg_in} of 24 within their marginal 95% CIs")),
        "{text}"
    );
    // IEEE N of a gyro in °/√h is 60·√(σ²/rate): its intervals are the images of σ²'s.
    let n = &doc["ieee"][0];
    assert_eq!(
        (n["channel"].as_str(), n["parameter"].as_str()),
        (Some("gyro_x"), Some("N"))
    );
    let (slo, shi) = pair(&params[0]["sim_ci"]);
    let (nlo, nhi) = pair(&n["sim_ci"]);
    assert!((nlo / (60.0 * (slo / 100.0).sqrt()) - 1.0).abs() < 1e-12);
    assert!((nhi / (60.0 * (shi / 100.0).sqrt()) - 1.0).abs() < 1e-12);
}

#[test]
fn demo_help_documents_the_true_parameters() {
    let out = imunoise(&["demo", "--help"]);
    let help = String::from_utf8_lossy(&out.stdout);
    for c in imunoise::cli::demo::DEMO_IMU {
        // The help line "name [unit]  model" parses to the same model as the simulated one.
        let line = help
            .lines()
            .find(|l| {
                l.trim_start()
                    .starts_with(&format!("{} [{}]", c.name, c.unit))
            })
            .unwrap_or_else(|| panic!("no help line for {}:\n{help}", c.name));
        let text = line.split_once(']').unwrap().1;
        let shown: imunoise::processes::Model = text.parse().unwrap();
        let truth: imunoise::processes::Model = c.model.parse().unwrap();
        assert_eq!(shown.to_string(), truth.to_string(), "{line}");
    }
}

/// Runs `imunoise ARGS` on a pseudo-terminal (util-linux `script`) and returns what it drew,
/// or None when `script` is not available.
fn on_terminal(args: &[&str]) -> Option<String> {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("typescript");
    let cmd = std::iter::once(env!("CARGO_BIN_EXE_imunoise"))
        .chain(args.iter().copied())
        .map(|a| format!("'{a}'"))
        .collect::<Vec<_>>()
        .join(" ");
    let out = Command::new("script")
        .args(["-qec", &format!("{cmd} > /dev/null"), log.to_str().unwrap()])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    Some(String::from_utf8_lossy(&std::fs::read(&log).ok()?).into_owned())
}

#[test]
fn progress_bars_on_a_terminal_only() {
    let dir = tempfile::tempdir().unwrap();
    let p = simulate_to(dir.path(), "WN(sigma2=1e-4)+RW(gamma2=1e-10)", "32768", "x");
    let args = fit_f64_args(&p, &["--model", "WN+RW", "--bootstrap", "3"]);
    // Not a terminal: no bar on stderr.
    let out = imunoise(&args);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("fit+bootstrap") && !err.contains("Allan var."),
        "{err}"
    );
    let Some(drawn) = on_terminal(&args) else {
        eprintln!("skipped: `script` (util-linux) cannot run a pseudo-terminal here");
        return;
    };
    // One step per channel fit plus one per bootstrap replicate: 1 channel × (1 + 3).
    assert!(drawn.contains("Allan var. ["), "{drawn}");
    assert!(
        drawn.contains("fit+bootstrap [") && drawn.contains("/4 "),
        "{drawn}"
    );
    let quiet = on_terminal(&[&args[..], &["--quiet"]].concat()).unwrap_or_default();
    assert!(
        !quiet.contains("Allan var.") && !quiet.contains("fit+bootstrap"),
        "{quiet}"
    );
}

#[test]
fn scale_accepts_fractions_of_integer_counts() {
    // i16 counts 131 and -262 scaled by 1/131 are exactly 1 and -2 (°/s): the AV at m = 1
    // of the alternating series 1, -2, 1, -2, … is 3²/2 = 4.5.
    let dir = tempfile::tempdir().unwrap();
    let bytes: Vec<u8> = (0..64)
        .flat_map(|i| if i % 2 == 0 { 131i16 } else { -262 }.to_le_bytes())
        .collect();
    let p = write(dir.path(), "counts.bin", &bytes);
    let out = imunoise_ok(&[
        "avar",
        p.to_str().unwrap(),
        "--binary",
        "i16",
        "--scale",
        "1/131",
        "-r",
        "100",
        "--scales",
        "1",
        "--ci",
        "none",
        "-f",
        "json",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!((doc["channels"][0]["points"][0]["avar"].as_f64().unwrap() - 4.5).abs() < 1e-12);
    let err = avar_fails(&p, &["--binary", "i16", "--scale", "1/0"]);
    assert!(err.contains("--scale"), "{err}");
}

/// Regression: model selection used to abort the whole `analyze` when one sub-model of the
/// default full model was not identifiable at its estimate ("AᵀΩA is singular"); with this
/// seed a 10^5-sample WN + RW record triggered it. Such candidates are now skipped and the
/// selection still returns the best identifiable model, which must contain the WN and RW the
/// record was made of.
#[test]
fn analyze_selection_skips_unidentifiable_candidates() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("wnrw.csv");
    simulate_file(&p, "WN(sigma2=1e-4)+RW(gamma2=1e-10)", "100000", "4", &[]);
    let out_dir = dir.path().join("rep");
    imunoise_ok(&[
        "analyze",
        p.to_str().unwrap(),
        "--rate",
        "100",
        "-q",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("results.json")).unwrap())
            .unwrap();
    let text = json.to_string();
    assert!(text.contains("WN(") && text.contains("RW("), "{text}");
}

/// `fit --weighting model-full` really changes Ω: on the same record the estimate differs
/// from the default diagonal weighting, and each fit's 95 % CI for the WN variance covers the
/// truth σ² = 1e-4 (for WN + RW on 65,536 samples the relative SE of σ̂² is about 0.6 %, far
/// below the 1e-9-relative difference that would mean "unchanged").
#[test]
fn fit_weighting_model_full_is_used() {
    let dir = tempfile::tempdir().unwrap();
    let p = simulate_to(dir.path(), "WN(sigma2=1e-4)+RW(gamma2=1e-10)", "65536", "x");
    let run = |w: &str| -> serde_json::Value {
        let out = imunoise_ok(&fit_f64_args(
            &p,
            &[
                "--model",
                "WN+RW",
                "--weighting",
                w,
                "--format",
                "json",
                "-q",
            ],
        ));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["channels"][0]["parameters"][0].clone()
    };
    let (d, f) = (run("diagonal"), run("model-full"));
    let (vd, vf) = (d["value"].as_f64().unwrap(), f["value"].as_f64().unwrap());
    assert!((vd / vf - 1.0).abs() > 1e-9, "{vd} vs {vf}");
    for p in [&d, &f] {
        assert!(
            p["ci_lo"].as_f64().unwrap() < 1e-4 && 1e-4 < p["ci_hi"].as_f64().unwrap(),
            "{p}"
        );
    }
}

/// The text table's header names the CI family, or says that there is none.
#[test]
fn table_header_names_the_ci_family() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "ok.csv", good_csv(1000).as_bytes());
    for (ci, want) in [
        (None, "95% chi-square CI"),
        (Some("none"), "no CI"),
        (Some("gaussian"), "95% Gaussian CI (Lemma 4.4)"),
    ] {
        let mut args = vec!["avar", p.to_str().unwrap(), "-r", "100", "-q"];
        if let Some(c) = ci {
            args.extend(["--ci", c]);
        }
        let out = imunoise_ok(&args);
        let text = String::from_utf8_lossy(&out.stdout);
        let header = text.lines().next().unwrap_or_default();
        assert!(header.ends_with(want), "{ci:?}: {header}");
    }
}

/// A pseudo-random one-column CSV (header `y`) and its values.
fn noisy_csv(dir: &Path, n: usize) -> (PathBuf, Vec<f64>) {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut walk = 0.0;
    let y: Vec<f64> = (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let u = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            walk += 0.01 * u;
            u + walk
        })
        .collect();
    let mut text = String::from("y\n");
    for v in &y {
        text.push_str(&format!("{v:?}\n"));
    }
    (write(dir, "noisy.csv", text.as_bytes()), y)
}

#[test]
fn avar_statistic_json_has_one_entry_per_statistic_with_alpha() {
    let dir = tempfile::tempdir().unwrap();
    let (p, y) = noisy_csv(dir.path(), 4000);
    let run = |extra: &[&str]| {
        let mut args = vec!["avar", p.to_str().unwrap(), "-r", "10", "-f", "json"];
        args.extend_from_slice(extra);
        serde_json::from_slice::<serde_json::Value>(&imunoise_ok(&args).stdout).unwrap()
    };
    let default = run(&[]);
    // the default output is unchanged: no statistic field, no alpha
    assert!(default["channels"][0].get("statistic").is_none());
    assert!(default["channels"][0]["points"][0].get("alpha").is_none());
    let doc = run(&["--statistic", "oadev,mdev", "--statistic", "totdev"]);
    let ch = doc["channels"].as_array().unwrap();
    let names: Vec<&str> = ch
        .iter()
        .map(|c| c["statistic"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["oadev", "mdev", "totdev"]);
    // oadev through --statistic is the default curve, value for value
    assert_eq!(ch[0]["points"], {
        let mut pts = default["channels"][0]["points"].clone();
        for q in pts.as_array_mut().unwrap() {
            let a = ch[0]["points"]
                .as_array()
                .unwrap()
                .iter()
                .find(|r| r["m"] == q["m"])
                .unwrap()["alpha"]
                .clone();
            q.as_object_mut().unwrap().insert("alpha".into(), a);
        }
        pts
    });
    // MDEV at m = 4 against the library's plain reference (literal double sum)
    let mdev4 = ch[1]["points"]
        .as_array()
        .unwrap()
        .iter()
        .find(|q| q["m"] == 4)
        .unwrap();
    let want = imunoise::avar::stability::mdev::mvar_reference(
        &y,
        10.0,
        imunoise::avar::InputKind::Rate,
        4,
    )
    .unwrap();
    let got = mdev4["avar"].as_f64().unwrap();
    assert!((got / want - 1.0).abs() < 1e-10, "{got} vs {want}");
    assert_eq!(mdev4["n_terms"], 4000 + 2 - 3 * 4);
    for c in ch {
        for q in c["points"].as_array().unwrap() {
            let a = q["alpha"]
                .as_i64()
                .expect("alpha per point with a chi-square CI");
            assert!((-2..=2).contains(&a));
            assert!(q["avar_lo"].as_f64().unwrap() <= q["avar"].as_f64().unwrap());
        }
    }
    // without a CI, alpha is null
    let none = run(&["--statistic", "hdev", "--ci", "none"]);
    assert!(none["channels"][0]["points"][0]["alpha"].is_null());
    assert_eq!(none["channels"][0]["estimator"], "non_overlapping");
}

#[test]
fn avar_statistic_csv_table_plot_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let (p, _) = noisy_csv(dir.path(), 3000);
    let svg = dir.path().join("stab.svg");
    let out = imunoise_ok(&[
        "avar",
        p.to_str().unwrap(),
        "-r",
        "1",
        "--statistic",
        "ohdev,tdev",
        "--scales",
        "octave",
        "-f",
        "csv",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "channel,m,tau,avar,adev,avar_lo,avar_hi,adev_lo,adev_hi,edf,n_terms,statistic,alpha"
    );
    let rows: Vec<&str> = lines.collect();
    // octave grid with Stable32's stop ratio 4: m = 1..512 (3000/4 = 750) for both
    assert_eq!(rows.len(), 2 * 10);
    assert!(rows[0].contains(",ohdev,") && rows[19].contains(",tdev,"));
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.contains("OHDEV") && plot.contains("TDEV") && plot.starts_with("<svg"));
    let table = imunoise_ok(&[
        "avar",
        p.to_str().unwrap(),
        "-r",
        "1",
        "--statistic",
        "mdev",
    ]);
    let t = String::from_utf8(table.stdout).unwrap();
    assert!(t.contains("MDEV") && t.contains("alpha"), "{t}");
    let err = avar_fails(
        &p,
        &["--rate", "1", "--statistic", "mdev", "--ci", "gaussian"],
    );
    assert!(err.contains("Gaussian") && err.contains("mdev"), "{err}");
    let bad = imunoise(&[
        "avar",
        p.to_str().unwrap(),
        "-r",
        "1",
        "--statistic",
        "allan",
    ]);
    assert_eq!(bad.status.code(), Some(2));
    let help = String::from_utf8(imunoise_ok(&["avar", "--help"]).stdout).unwrap();
    for needle in [
        "linear frequency drift",
        "tighter intervals at long tau",
        "flicker phase noise",
    ] {
        assert!(help.contains(needle), "--help lacks {needle:?}");
    }
}

/// A bad model, level or option of `avar`, `fit` and `analyze` is reported before the input is read
/// (on a long log, reading it took seconds before the error), and `analyze` makes no `--out`
/// folder for it. The input here does not exist: had it been read first, the error would name
/// the missing file instead.
#[test]
fn settings_are_checked_before_the_input_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.csv");
    let m = missing.to_str().unwrap();
    let out_dir = dir.path().join("report");
    let o = out_dir.to_str().unwrap();
    let cases: [(&[&str], &str); 13] = [
        (
            &["analyze", m, "--rate", "1", "--inflate-noise=-1", "-o", o],
            "must be > 0",
        ),
        (
            &["export", m, "--inflate-walk=-1/2", "-o", o],
            "must be > 0",
        ),
        (
            &["avar", m, "--rate", "1", "--scales", "0,5"],
            "m = 0 is not allowed",
        ),
        (
            &["avar", m, "--rate", "1", "--scales", "log0"],
            "N ≥ 1 points per decade",
        ),
        (
            &["fit", m, "--rate", "1", "--bootstrap", "1000000000"],
            "more than the 100000 this runs",
        ),
        (
            &["fit", m, "--rate", "1", "--model", "WN+FOO"],
            "unknown process \"FOO\"",
        ),
        (
            &["fit", m, m, "--rate", "1", "--model", "WN+FOO"],
            "unknown process \"FOO\"",
        ),
        (
            &["fit", m, "--rate", "1", "--alpha", "2"],
            "--alpha must lie in (0, 1)",
        ),
        (
            &["fit", m, "--rate", "1", "--method", "avlr", "--select"],
            "--select works with",
        ),
        (
            &["fit", m, "--rate", "1", "--robust", "--efficiency", "3"],
            "--efficiency must lie",
        ),
        (
            &["analyze", m, "--rate", "1", "--model", "WN+FOO", "-o", o],
            "unknown process",
        ),
        (
            &[
                "analyze",
                m,
                "--rate",
                "1",
                "--record-halfwidth",
                "2",
                "-o",
                o,
            ],
            "--record-halfwidth",
        ),
        (
            &["analyze", m, "--rate", "1", "--export", "foo", "-o", o],
            "unknown export target",
        ),
    ];
    for (args, want) in cases {
        let out = imunoise(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
        assert!(!err.contains("no such file"), "{args:?}: {err}");
        assert!(!out_dir.exists(), "{args:?} made --out");
    }
}

/// A CSV of 4000 samples of WN(σ² = 1e-4) + RW(γ² = 1e-8) at 100 Hz (seed 3), made by the
/// command itself, in `dir`.
fn simulated_wn_rw(dir: &Path) -> PathBuf {
    let data = dir.join("sim.csv");
    imunoise_ok(&[
        "simulate",
        "--model",
        "WN(sigma2=1e-4)+RW(gamma2=1e-8)",
        "-n",
        "4000",
        "--rate",
        "100",
        "--seed",
        "3",
        "-o",
        data.to_str().unwrap(),
    ]);
    data
}

/// Values written into `--model` are not used by the fit (every parameter is estimated); the
/// command says so instead of dropping them silently, and the fit is the one of the bare
/// template.
#[test]
fn values_in_the_model_template_are_named_as_unused() {
    let dir = tempfile::tempdir().unwrap();
    let data = simulated_wn_rw(dir.path());
    let d = data.to_str().unwrap();
    let with = imunoise_ok(&["fit", d, "--rate", "100", "--model", "WN(sigma2=5)+RW"]);
    let bare = imunoise_ok(&["fit", d, "--rate", "100", "--model", "WN+RW"]);
    let note = String::from_utf8_lossy(&with.stderr);
    assert!(note.contains("does not use them"), "{note}");
    assert!(note.contains("--model \"WN + RW\""), "{note}");
    assert!(!String::from_utf8_lossy(&bare.stderr).contains("does not use them"));
    assert_eq!(with.stdout, bare.stdout);
}

/// A drift alone is deterministic: under it the AV estimates have no variance, so the J
/// statistic is undefined. It used to be printed as "J = NaN, p = 1.000" (a NaN statistic
/// read as a perfect fit); now there is no J test, and a note says why the CIs have zero width.
#[test]
fn a_drift_only_model_has_no_j_test_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let data = simulated_wn_rw(dir.path());
    let d = data.to_str().unwrap();
    let out = imunoise_ok(&[
        "fit", d, "--rate", "100", "--model", "DR", "--format", "json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let c = &v["channels"][0];
    assert!(c["j_test"].is_null(), "{c}");
    let w = c["warnings"].to_string();
    assert!(w.contains("deterministic drift only"), "{w}");
    let table = imunoise_ok(&["fit", d, "--rate", "100", "--model", "DR"]);
    let text = String::from_utf8_lossy(&table.stdout);
    assert!(!text.contains("J-test"), "{text}");
    // with a random component the J test is there, with a finite statistic
    let out = imunoise_ok(&[
        "fit", d, "--rate", "100", "--model", "WN+DR", "--format", "json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let j = &v["channels"][0]["j_test"];
    assert!(j["statistic"].as_f64().is_some_and(f64::is_finite), "{j}");
    assert!(
        j["p_value"]
            .as_f64()
            .is_some_and(|p| (0.0..=1.0).contains(&p)),
        "{j}"
    );
}

/// `imunoise analyze DATA --rate 100 -o OUT`, which must succeed.
fn analyze_at_100_hz(data: &Path, out: &Path) {
    imunoise_ok(&[
        "analyze",
        data.to_str().unwrap(),
        "--rate",
        "100",
        "-o",
        out.to_str().unwrap(),
    ]);
}

/// A CSV `name` in `dir` of two integer columns (3000 rows) under `header`.
fn two_columns(dir: &Path, name: &str, header: &str) -> PathBuf {
    let rows: String = (0..3000)
        .map(|i| format!("{},{}\n", (i * 7) % 11, (i * 5) % 13))
        .collect();
    write(dir, name, format!("{header}\n{rows}").as_bytes())
}

/// Two channels of the same name (a header `gyro_x,gyro_x`, or `--names a,a`) used to write
/// one set of plots over the other in `analyze`'s folder; now the read refuses them, naming
/// both channels, and `--names` resolves it.
#[test]
fn equal_channel_names_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = two_columns(dir.path(), "dup.csv", "gyro_x,gyro_x");
    let d = data.to_str().unwrap();
    let out_dir = dir.path().join("report");
    let o = out_dir.to_str().unwrap();
    for args in [
        vec!["avar", d, "--rate", "100"],
        vec!["analyze", d, "--rate", "100", "-o", o],
        vec!["avar", d, "--rate", "100", "--names", "a,a"],
    ] {
        let out = imunoise(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("channels 1 and 2 are both named"),
            "{args:?}: {err}"
        );
    }
    imunoise_ok(&["avar", d, "--rate", "100", "--names", "gx,gy"]);
}

/// Channel names that differ but map to the same file name (`gyro x` and `gyro_x` both give
/// `gyro_x`) get plot files of their own: the second is numbered.
#[test]
fn names_that_share_a_file_name_get_their_own_plots() {
    let dir = tempfile::tempdir().unwrap();
    let data = two_columns(dir.path(), "two.csv", "gyro x,gyro_x");
    let out_dir = dir.path().join("report");
    analyze_at_100_hz(&data, &out_dir);
    for f in [
        "adev_gyro_x.svg",
        "adev_gyro_x_2.svg",
        "series_gyro_x_2.svg",
        "acf_gyro_x_2.svg",
    ] {
        assert!(out_dir.join(f).is_file(), "{f}");
    }
    // and the two plots are of the two channels
    let a = std::fs::read_to_string(out_dir.join("adev_gyro_x.svg")).unwrap();
    let b = std::fs::read_to_string(out_dir.join("adev_gyro_x_2.svg")).unwrap();
    assert!(a.contains("gyro x:") && b.contains("gyro_x:"));
}

/// `export` of a results.json with no angular-rate or acceleration channel used to write five
/// config files of "not estimated" and exit 0; now it says there is nothing to export.
#[test]
fn export_of_no_imu_channel_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rows: String = (0..3000).map(|i| format!("{}\n", (i * 7) % 11)).collect();
    let data = write(dir.path(), "x.csv", format!("x\n{rows}").as_bytes());
    let report = dir.path().join("report");
    analyze_at_100_hz(&data, &report);
    let out_dir = dir.path().join("config");
    let out = imunoise(&[
        "export",
        report.to_str().unwrap(),
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("nothing to export") && err.contains("x: unit none"),
        "{err}"
    );
    assert!(!out_dir.exists());
}
