//! Robust and multi-recording fitting on real data (issue 15). Tests that read `../shared/data`
//! skip with a message when it is absent.

use avar::AvarConfig;
use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::robust::{contamination_check, fit_robust};
use processes::Model;
use std::path::PathBuf;

fn data(rel: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(rel);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("skip: {} not found", p.display());
        None
    }
}

fn read_f64(p: &PathBuf) -> Vec<f64> {
    std::fs::read(p)
        .unwrap()
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect()
}

fn inside(curve: &AvCurve, fitted: &[f64]) -> usize {
    curve
        .points
        .iter()
        .zip(fitted)
        .filter(|(p, v)| p.avar_lo.unwrap() <= **v && **v <= p.avar_hi.unwrap())
        .count()
}

/// MTi-G gyro X with outliers: classical and robust AV and fits side by side; the robust fit
/// must lie inside the robust AV CIs at >= 90 % of scales (issue 15 acceptance).
///
/// Finding: the robust curve is 27 % below the classical one at m = 2 and meets it at
/// m ≈ 256 (0.16 % of the m = 2 differences get zero weight). Its small-scale shape is not
/// that of white noise (AV(2)/AV(4) = 1.78), so WN + RW + AR1 fits it at 3 of 17 scales only
/// (J test p ≈ 1e-99); one more AR1 (WN + RW + 2·AR1, a short AR1 with φ ≈ 0.13 taking the
/// place of WN) fits it at 17 of 17 (J test p ≈ 0.7). The check flags the record as
/// contaminated at the 7 smallest scales.
#[test]
fn mtig_outliers_classical_vs_robust() {
    let Some(p) = data("mtig_outliers/cont_imu1_gyro_x.f64") else {
        return;
    };
    let x = read_f64(&p);
    assert_eq!(x.len(), 500_000);
    let rate = 100.0;
    let template: Model = "WN + RW + 2*AR1".parse().unwrap();
    let opts = GmwmOptions::default();
    let r = fit_robust(&x, rate, &AvarConfig::default(), &template, &opts).unwrap();
    let cl_curve = AvCurve::from_avar(&r.avar.classical).unwrap();
    let cl = fit(&cl_curve, &template, &opts).unwrap();
    let chk = contamination_check(&x, &r.avar, 0.01, 5).unwrap();
    eprintln!("{}", chk.message);
    for (i, s) in chk.scales.iter().enumerate() {
        eprintln!(
            "m = {:>6}  classical {:.4e} [fit {:.4e}]  robust {:.4e} [{:.4e}, {:.4e}] fit {:.4e}  z = {:.2} root {} rejected {}",
            s.m,
            s.classical,
            cl.fitted[i],
            s.robust,
            r.curve.points[i].avar_lo.unwrap(),
            r.curve.points[i].avar_hi.unwrap(),
            r.fit.fitted[i],
            s.z,
            r.avar.root_found[i],
            r.avar.rejected[i]
        );
    }
    eprintln!(
        "classical fit: {}\nrobust fit:    {}",
        cl.model, r.fit.model
    );
    // heavy-tailed noise, not isolated spikes: 5 % of the samples lie beyond 6 robust SDs of
    // their neighbours' mean, more than MAX_SPIKE_FRACTION, so none is replaced
    let sp = &r.avar.spikes;
    eprintln!(
        "beyond the spike threshold: {} (residual SD {:.4e})",
        sp.beyond, sp.residual_sd
    );
    assert!(sp.indices.is_empty());
    assert!(sp.beyond as f64 > avar::robust::MAX_SPIKE_FRACTION * x.len() as f64);
    let n_in = inside(&r.curve, &r.fit.fitted);
    eprintln!(
        "robust fit inside the robust CIs at {n_in}/{} scales",
        r.curve.len()
    );
    assert!(r.fit.convergence.converged);
    assert!(chk.contaminated);
    assert!(!chk.windows.is_empty());
    assert!(
        n_in as f64 >= 0.9 * r.curve.len() as f64,
        "{n_in}/{}",
        r.curve.len()
    );
}

fn imunoise_ok(args: &[&str]) -> std::process::Output {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn simulate(path: &std::path::Path, model: &str, n: &str, seed: &str) {
    imunoise_ok(&[
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
    ]);
}

/// `fit A B` on two simulated recordings of the same WN + RW (65,536 samples each, different
/// seeds): one joint model whose 95 % CIs are narrower than each recording's alone and still
/// cover the truth, and a Wald test with (R − 1)·p = 2 degrees of freedom. Its p-value is only
/// checked to be a probability here (its size is the Monte Carlo's job, `cargo xtask
/// robust-mc`).
#[test]
fn cli_fit_two_recordings_json() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.f64"), dir.path().join("b.f64"));
    let truth = "WN(sigma2=1e-4)+RW(gamma2=1e-10)";
    simulate(&a, truth, "65536", "1");
    simulate(&b, truth, "65536", "2");
    let out = imunoise_ok(&[
        "fit",
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        "--binary",
        "f64",
        "--channels",
        "1",
        "--rate",
        "100",
        "--model",
        "WN+RW",
        "-f",
        "json",
        "-q",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let j = &doc["joint"][0];
    assert_eq!(j["files"].as_array().unwrap().len(), 2);
    assert_eq!(j["wald"]["dof"], 2);
    let p = j["wald"]["p_value"].as_f64().unwrap();
    assert!((0.0..=1.0).contains(&p));
    // (R − 1)·J with J the common scales
    assert_eq!(
        j["moment_test"]["dof"].as_u64().unwrap() as usize,
        j["fit"]["fitted"].as_array().unwrap().len()
    );
    let width = |v: &serde_json::Value| v["ci_hi"].as_f64().unwrap() - v["ci_lo"].as_f64().unwrap();
    for (k, t) in [1e-4, 1e-10].iter().enumerate() {
        let jp = &j["fit"]["parameters"][k];
        assert!(
            jp["ci_lo"].as_f64().unwrap() < *t && *t < jp["ci_hi"].as_f64().unwrap(),
            "{jp}"
        );
        for s in j["single"].as_array().unwrap() {
            assert!(
                width(jp) < width(&s["parameters"][k]),
                "{jp} vs {}",
                s["parameters"][k]
            );
        }
    }
}

/// `fit --robust` on a record with 0.5 % spikes of 20σ: the classical WN estimate is biased
/// upward by about 0.005·20² = 2σ² (×3); the robust one is within 10 % of the truth (measured:
/// +5.9 %). It is not unbiased: a spike is rejected only where 20σ/m exceeds c·σ_D =
/// 4.4·σ·√(2/m), i.e. at m ≤ 10; at the larger scales the spikes stay in the robust AV too
/// and pull σ̂² up (its SE alone would be about 0.8 % here).
#[test]
fn cli_fit_robust_resists_spikes() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.f64");
    simulate(&p, "WN(sigma2=1e-4)+RW(gamma2=1e-10)", "65536", "3");
    let mut x = read_f64(&p);
    for i in (0..x.len()).step_by(200) {
        x[i] += 0.2; // 20σ
    }
    let bytes: Vec<u8> = x.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&p, bytes).unwrap();
    let run = |extra: &[&str]| -> f64 {
        let mut args = vec![
            "fit",
            p.to_str().unwrap(),
            "--binary",
            "f64",
            "--channels",
            "1",
            "--rate",
            "100",
            "--model",
            "WN+RW",
            "-f",
            "json",
            "-q",
        ];
        args.extend_from_slice(extra);
        let doc: serde_json::Value = serde_json::from_slice(&imunoise_ok(&args).stdout).unwrap();
        doc["channels"][0]["parameters"][0]["value"]
            .as_f64()
            .unwrap()
    };
    let (cl, rob) = (run(&[]), run(&["--robust"]));
    assert!(cl > 2.5e-4, "{cl}");
    assert!((rob / 1e-4 - 1.0).abs() < 0.1, "{rob}");
}

fn adis_gyro(name: &str, col: usize) -> Option<Vec<f64>> {
    use std::io::{BufRead, BufReader};
    let p = data(&format!("adis16405/{name}"))?;
    let rd = BufReader::new(flate2::read::GzDecoder::new(
        std::fs::File::open(&p).unwrap(),
    ));
    Some(
        rd.lines()
            .skip(1)
            .map(|l| l.unwrap().split(',').nth(col).unwrap().parse().unwrap())
            .collect(),
    )
}

/// Two recordings of the same sensor type (ADIS16405 imu1 and imu2, gyro X and Y, the model
/// RW + 2·AR1 that WIC selects on them): the joint 95 % CIs are narrower than each
/// recording's alone for every parameter, and the equality tests are reported (measured:
/// gyro X Wald W = 19.5 on 5 dof, p = 0.0015; gyro Y W = 11.0, p = 0.052).
#[test]
fn adis16405_two_recordings_joint_fit() {
    use gmwm_prep::multi::fit_joint;
    let template: Model = "RW + 2*AR1".parse().unwrap();
    for (col, axis) in [(0, "x"), (1, "y")] {
        let (Some(a), Some(b)) = (
            adis_gyro("adis16405_imu1.csv.gz", col),
            adis_gyro("adis16405_imu2.csv.gz", col),
        ) else {
            return;
        };
        let curves: Vec<AvCurve> = [a, b]
            .iter()
            .map(|x| {
                AvCurve::from_avar(&avar::allan_variance(x, 100.0, &AvarConfig::default()).unwrap())
                    .unwrap()
            })
            .collect();
        let j = fit_joint(&curves, &template, &GmwmOptions::default(), 0.05).unwrap();
        eprintln!(
            "gyro {axis}: joint {}\n  Wald W = {:.3}, dof {}, p = {:.4}; moments J = {:.3}, dof {}, p = {:.4}",
            j.fit.model,
            j.wald.statistic,
            j.wald.dof,
            j.wald.p_value,
            j.moments.statistic,
            j.moments.dof,
            j.moments.p_value
        );
        assert_eq!(j.wald.dof, 5);
        assert!(j.wald.statistic.is_finite() && (0.0..=1.0).contains(&j.wald.p_value));
        for k in 0..template.n_params() {
            let w = |c: (f64, f64)| (c.1 / c.0).ln();
            let wj = w(j.inference.ci[k]);
            for s in &j.single {
                let ws = w(s.inference.ci[k]);
                eprintln!("  param {k}: joint log-width {wj:.4}, alone {ws:.4}");
                assert!(wj < ws, "gyro {axis} param {k}: {wj} vs {ws}");
            }
        }
    }
}

/// `analyze --robust` on a WN + RW record with a burst of spikes at t = 300–301 s: the check
/// flags contamination and names a window containing the burst; the report has the robust
/// plot and both fits; results.json has the robust entry.
#[test]
fn cli_analyze_robust_names_the_window() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.f64");
    simulate(&p, "WN(sigma2=1e-4)+RW(gamma2=1e-10)", "65536", "4");
    let mut x = read_f64(&p);
    for i in (30_000..30_100).step_by(5) {
        x[i] += 0.3; // 30σ
    }
    let bytes: Vec<u8> = x.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&p, bytes).unwrap();
    let out_dir = dir.path().join("rep");
    imunoise_ok(&[
        "analyze",
        p.to_str().unwrap(),
        "--binary",
        "f64",
        "--channels",
        "1",
        "--rate",
        "100",
        "--model",
        "WN+RW",
        "--no-select",
        "--robust",
        "-q",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let res: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out_dir.join("results.json")).unwrap()).unwrap();
    let rob = &res["channels"][0]["robust"];
    assert_eq!(rob["check"]["contaminated"], true, "{rob}");
    let w = &rob["check"]["windows"][0];
    let (a, b) = (w["start_s"].as_f64().unwrap(), w["end_s"].as_f64().unwrap());
    assert!(a <= 300.5 && 300.5 <= b, "{w}");
    assert_eq!(rob["fit"]["method"], "gmwm");
    // the 20 spikes of 30σ (every 5th sample from 30000: isolated, 4 clean samples between)
    // are replaced before the robust AV, and named
    assert_eq!(rob["spikes_replaced"], 20, "{rob}");
    let times: Vec<f64> = rob["spike_times_s"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_f64().unwrap())
        .collect();
    let want: Vec<f64> = (30_000..30_100)
        .step_by(5)
        .map(|i| i as f64 / 100.0)
        .collect();
    assert_eq!(times, want);
    let html = std::fs::read_to_string(out_dir.join("report.html")).unwrap();
    assert!(html.contains(
        "20 isolated spikes (more than 6 robust SDs from their neighbours) were replaced"
    ));
    assert!(html.contains("Classical vs robust"));
    assert!(html.contains("robust fit"));
    assert!(out_dir.join("adev_robust_ch1.svg").exists());
}

/// A deterministic uniform stream (64-bit LCG, top 53 bits) for the synthetic records below.
fn uniforms(n: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        })
        .collect()
}

/// What the contamination check says when no part of the record drives the excess: white
/// Laplace noise (kurtosis 6: heavier-tailed than Gaussian in every sample) is flagged, and
/// the message says what the data are, not where; the same Gaussian-free record with a burst
/// of large values in one second names that window instead.
#[test]
fn contamination_spread_through_the_record_is_described_not_located() {
    let n = 1 << 17;
    let rate = 100.0;
    // Laplace by the inverse CDF: x = −sgn(u − ½)·ln(1 − 2|u − ½|)
    let laplace: Vec<f64> = uniforms(n, 7)
        .into_iter()
        .map(|u| {
            let d = u - 0.5;
            -d.signum() * (1.0 - 2.0 * d.abs()).ln()
        })
        .collect();
    let cfg = AvarConfig::default();
    let rob = avar::robust::robust_allan_variance(&laplace, rate, &cfg, 0.6).unwrap();
    let chk = contamination_check(&laplace, &rob, 0.01, 5).unwrap();
    eprintln!("{}", chk.message);
    assert!(chk.contaminated, "{}", chk.message);
    let largest = chk.windows.iter().map(|w| w.share).fold(0.0, f64::max);
    assert!(largest < gmwm_prep::robust::SPREAD_SHARE, "{largest}");
    assert!(
        chk.message
            .contains("heavier-tailed than Gaussian throughout"),
        "{}",
        chk.message
    );
    assert!(!chk.message.contains("windows driving it"));

    // Gaussian noise (Box–Muller) with 100 samples of ±20 σ in the second 600–601 s
    let u = uniforms(n + 1, 11);
    let mut x: Vec<f64> = (0..n)
        .map(|i| (-2.0 * u[i].ln()).sqrt() * (2.0 * std::f64::consts::PI * u[i + 1]).cos())
        .collect();
    for (k, v) in x[60_000..60_100].iter_mut().enumerate() {
        *v += if k % 2 == 0 { 20.0 } else { -20.0 };
    }
    let rob = avar::robust::robust_allan_variance(&x, rate, &cfg, 0.6).unwrap();
    let chk = contamination_check(&x, &rob, 0.01, 5).unwrap();
    eprintln!("{}", chk.message);
    assert!(chk.contaminated, "{}", chk.message);
    assert!(
        chk.message.contains("windows driving it"),
        "{}",
        chk.message
    );
    let w = &chk.windows[0];
    assert!(w.start_s <= 600.0 && 601.0 <= w.end_s + 1.0, "{w:?}");
}
