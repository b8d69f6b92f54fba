//! Config writers end to end: `imunoise analyze --export all` and `imunoise export` on a
//! simulated 6-axis IMU (gyros in °/s, accelerometers in m/s²). Every number in every file
//! is checked against results.json (N = √(σ²_WN/f), K = √(γ²_RW·f), converted to SI,
//! aggregated over axes, inflated) to 1e-12, and the discrete equivalents by formula
//! (σ_d = N·√f, σ_bd = K/√f).

use serde_json::Value;
use std::path::Path;
use std::process::Command;

fn ok(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= 1e-12 * b.abs(),
        "{what}: {a} vs {b} (rel {})",
        (a - b).abs() / b.abs()
    );
}

/// The value after `key:` on its line (YAML), as f64.
fn yaml(text: &str, key: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with(&format!("{key}:")))
        .unwrap_or_else(|| panic!("no {key} in\n{text}"));
    let v = line.split(':').nth(1).unwrap().split('#').next().unwrap();
    v.trim().parse().unwrap_or_else(|_| panic!("{line}"))
}

/// The number after `name = ` in the comment line that starts with `prefix`.
fn comment(text: &str, prefix: &str, name: &str) -> f64 {
    let line = text
        .lines()
        .find(|l| l.trim_start_matches(['#', ' ']).starts_with(prefix))
        .unwrap_or_else(|| panic!("no {prefix} in\n{text}"));
    let at = line.find(&format!("{name} = ")).unwrap() + name.len() + 3;
    line[at..]
        .split([',', ' '])
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

/// Per-axis (N, K) in SI from results.json, gyros first.
/// (N, K) of one axis.
type Nk = (f64, f64);

fn per_axis(doc: &Value) -> (Vec<Nk>, Vec<Nk>, f64) {
    let rate = doc["rate_hz"].as_f64().unwrap();
    let (mut g, mut a) = (Vec::new(), Vec::new());
    for c in doc["channels"].as_array().unwrap() {
        let to_si = match c["unit"].as_str().unwrap() {
            "deg/s" => std::f64::consts::PI / 180.0,
            "m/s^2" => 1.0,
            u => panic!("unit {u}"),
        };
        let p = |proc_: &str, name: &str| {
            c["fit"]["parameters"]
                .as_array()
                .unwrap()
                .iter()
                .find(|p| p["process"] == proc_ && p["name"] == name)
                .unwrap()["value"]
                .as_f64()
                .unwrap()
        };
        let n = (p("WN", "sigma2") / rate).sqrt() * to_si;
        let k = (p("RW", "gamma2") * rate).sqrt() * to_si;
        if to_si == 1.0 {
            a.push((n, k))
        } else {
            g.push((n, k))
        }
    }
    (g, a, rate)
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::MIN, f64::max)
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

fn read(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap()
}

#[test]
fn five_config_files_match_results_json() {
    let dir = tempfile::tempdir().unwrap();
    let sim = |model: &str, seed: &str, name: &str| {
        let p = dir.path().join(name);
        ok(&[
            "simulate",
            "--model",
            model,
            "-n",
            "40000",
            "--rate",
            "100",
            "--seed",
            seed,
            "--channels",
            "3",
            "-o",
            p.to_str().unwrap(),
            "-q",
        ]);
        std::fs::read_to_string(p).unwrap()
    };
    let g = sim("WN(sigma2=2.5e-3)+RW(gamma2=1e-9)", "1", "g.csv");
    let a = sim("WN(sigma2=3e-5)+RW(gamma2=4e-9)", "2", "a.csv");
    let mut csv = String::from("gx_dps,gy_dps,gz_dps,ax_mps2,ay_mps2,az_mps2\n");
    for (lg, la) in g.lines().zip(a.lines()).skip(1) {
        csv.push_str(&format!("{lg},{la}\n"));
    }
    let input = dir.path().join("imu.csv");
    std::fs::write(&input, csv).unwrap();
    let out = dir.path().join("rep");
    ok(&[
        "analyze",
        input.to_str().unwrap(),
        "--rate",
        "100",
        "--out",
        out.to_str().unwrap(),
        "--model",
        "WN+RW",
        "--no-select",
        "--export",
        "all",
        "-q",
    ]);
    let doc: Value = serde_json::from_str(&read(&out, "results.json")).unwrap();
    let (g, a, f) = per_axis(&doc);
    assert_eq!((g.len(), a.len()), (3, 3));
    let gn = max(&g.iter().map(|x| x.0).collect::<Vec<_>>());
    let gk = max(&g.iter().map(|x| x.1).collect::<Vec<_>>());
    let an = max(&a.iter().map(|x| x.0).collect::<Vec<_>>());
    let ak = max(&a.iter().map(|x| x.1).collect::<Vec<_>>());
    for file in ["imu.yaml", "kalibr_imu_chain.yaml"] {
        let t = read(&out, file);
        close(yaml(&t, "gyroscope_noise_density"), gn, file);
        close(yaml(&t, "gyroscope_random_walk"), gk, file);
        close(yaml(&t, "accelerometer_noise_density"), an, file);
        close(yaml(&t, "accelerometer_random_walk"), ak, file);
        assert_eq!(yaml(&t, "update_rate"), 100.0);
        assert!(t.contains("continuous-time densities") && t.contains("aggregate over axes: max"));
    }
    assert!(read(&out, "kalibr_imu_chain.yaml").contains("imu0:\n"));
    let t = read(&out, "orbslam3_imu.yaml");
    close(yaml(&t, "IMU.NoiseGyro"), gn, "orb");
    close(yaml(&t, "IMU.NoiseAcc"), an, "orb");
    close(yaml(&t, "IMU.GyroWalk"), gk, "orb");
    close(yaml(&t, "IMU.AccWalk"), ak, "orb");
    assert!(t.contains("IMU.Frequency: 100.0"));
    // Discrete equivalents by formula.
    close(
        comment(&t, "gyroscope:", "sigma_d"),
        gn * f.sqrt(),
        "gyro sigma_d",
    );
    close(
        comment(&t, "gyroscope:", "sigma_bd"),
        gk / f.sqrt(),
        "gyro sigma_bd",
    );
    close(
        comment(&t, "accelerometer:", "sigma_d"),
        an * f.sqrt(),
        "acc sigma_d",
    );
    close(
        comment(&t, "accelerometer:", "sigma_bd"),
        ak / f.sqrt(),
        "acc sigma_bd",
    );
    let t = read(&out, "vins_imu.yaml");
    close(yaml(&t, "gyr_n"), gn, "vins");
    close(yaml(&t, "acc_n"), an, "vins");
    close(yaml(&t, "gyr_w"), gk, "vins");
    close(yaml(&t, "acc_w"), ak, "vins");
    // Basalt: per axis, no aggregate.
    let b: Value = serde_json::from_str(&read(&out, "basalt_imu.json")).unwrap();
    for k in 0..3 {
        close(
            b["gyro_noise_std"][k].as_f64().unwrap(),
            g[k].0,
            "basalt gyro n",
        );
        close(
            b["gyro_bias_std"][k].as_f64().unwrap(),
            g[k].1,
            "basalt gyro k",
        );
        close(
            b["accel_noise_std"][k].as_f64().unwrap(),
            a[k].0,
            "basalt acc n",
        );
        close(
            b["accel_bias_std"][k].as_f64().unwrap(),
            a[k].1,
            "basalt acc k",
        );
    }
    // Per-axis values are listed in the comments.
    let t = read(&out, "imu.yaml");
    close(comment(&t, "gx_dps:", "N"), g[0].0, "per-axis comment");
    // `imunoise export` with rms and inflation.
    let out2 = dir.path().join("cfg");
    ok(&[
        "export",
        out.to_str().unwrap(),
        "--to",
        "kalibr,vins",
        "--out",
        out2.to_str().unwrap(),
        "--aggregate",
        "rms",
        "--inflate-noise",
        "2",
        "--inflate-walk",
        "10",
        "-q",
    ]);
    let t = read(&out2, "vins_imu.yaml");
    close(
        yaml(&t, "gyr_n"),
        2.0 * rms(&g.iter().map(|x| x.0).collect::<Vec<_>>()),
        "rms n",
    );
    close(
        yaml(&t, "acc_w"),
        10.0 * rms(&a.iter().map(|x| x.1).collect::<Vec<_>>()),
        "rms k",
    );
    close(
        comment(&t, "accelerometer:", "sigma_bd"),
        yaml(&t, "acc_w") / f.sqrt(),
        "inflated walk",
    );
    assert!(t.contains("white noise x2, random walk x10"));
    assert!(!out2.join("basalt_imu.json").exists());
}
