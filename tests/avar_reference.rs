//! `imunoise avar` on the real ADIS16405 log against the book's MOAV computed in extended
//! precision (`../shared/data/adis16405/reference_moav_imu1.csv`), every column and scale,
//! to 1e-10 relative. Skips with a line when the shared data folder is absent.

use std::path::PathBuf;
use std::process::Command;

fn data_dir() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data/adis16405");
    d.exists().then_some(d)
}

#[test]
fn adis16405_json_matches_reference_moav() {
    let Some(dir) = data_dir() else {
        eprintln!("skipping: ../shared/data/adis16405 not found");
        return;
    };
    let out = Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .arg("avar")
        .arg(dir.join("adis16405_imu1.csv.gz"))
        .args(["--rate", "100", "--format", "json", "--quiet"])
        .output()
        .expect("runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
    let channels = doc["channels"].as_array().expect("channels");
    assert_eq!(channels.len(), 6);
    let reference =
        std::fs::read_to_string(dir.join("reference_moav_imu1.csv")).expect("reference");
    let mut checked = 0;
    for line in reference.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (name, m, tau, avar): (&str, u64, f64, f64) = (
            f[0],
            f[1].parse().unwrap(),
            f[2].parse().unwrap(),
            f[3].parse().unwrap(),
        );
        let ch = channels
            .iter()
            .find(|c| c["name"] == name)
            .unwrap_or_else(|| panic!("no channel {name}"));
        assert_eq!(ch["n"], 1_000_000);
        assert_eq!(ch["rate_hz"], 100.0);
        assert_eq!(ch["estimator"], "overlapping");
        let p = ch["points"]
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["m"] == m)
            .unwrap_or_else(|| panic!("{name}: no m = {m}"));
        let got = p["avar"].as_f64().unwrap();
        assert!(
            ((got - avar) / avar).abs() <= 1e-10,
            "{name} m={m}: {got} vs reference {avar}"
        );
        assert!((p["tau"].as_f64().unwrap() - tau).abs() <= 1e-12 * tau);
        checked += 1;
    }
    // 6 columns × 18 dyadic scales (m = 2 … 2^18 for T = 1e6).
    assert_eq!(checked, 6 * 18);
    for ch in channels {
        assert_eq!(ch["points"].as_array().unwrap().len(), 18);
    }
}
