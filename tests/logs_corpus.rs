//! The real logs of `../shared/data/logs/` (written by PX4's and ArduPilot's own tools) read
//! by imunoise and by the format owners' readers, pyulog and pymavlink
//! (`scripts/logs_corpus_dump.py`, in the venv `scripts/logs-corpus-venv.sh` makes under
//! `target/`): message counts equal, per topic (ULog) and per message type (DataFlash); the
//! IMU topics' stamps equal and their values equal to 1e-7 relative (the logs hold float32,
//! which both sides turn into the same f64; the differences measured, at most 2.2e-16, are
//! those of serde_json's parsing of the dumps' decimal numbers).
//!
//! Skips with a message when the data folder is absent or the venv cannot be made (no
//! network); CI makes the venv first (`.ci/run`).
#![cfg(all(feature = "ulog", feature = "dataflash"))]

use imunoise::logs::{LogFormat, open};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The dumps of the Python readers (one JSON per log), or why there are none.
fn python_dumps(data: &Path) -> Result<PathBuf, String> {
    let venv = Command::new("bash")
        .arg(root().join("scripts/logs-corpus-venv.sh"))
        .output()
        .map_err(|e| e.to_string())?;
    if !venv.status.success() {
        return Err(String::from_utf8_lossy(&venv.stderr).trim().to_string());
    }
    let out = root().join("target/logs-corpus");
    let dump = Command::new(root().join("target/pyvenv-logs/bin/python"))
        .arg(root().join("scripts/logs_corpus_dump.py"))
        .arg(data)
        .arg(&out)
        .output()
        .map_err(|e| e.to_string())?;
    assert!(
        dump.status.success(),
        "the dump failed: {}",
        String::from_utf8_lossy(&dump.stderr)
    );
    Ok(out)
}

/// Largest relative difference |a − b| / max(|a|, |b|) (0 for equal values).
fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| {
            if x == y {
                0.0
            } else {
                (x - y).abs() / x.abs().max(y.abs())
            }
        })
        .fold(0.0, f64::max)
}

#[test]
fn real_logs_equal_pyulog_and_pymavlink() {
    let data = root().join("../shared/data/logs");
    if !data.is_dir() {
        eprintln!("skipped: {} is absent", data.display());
        return;
    }
    let dumps = match python_dumps(&data) {
        Ok(d) => d,
        Err(why) => {
            eprintln!("skipped: no pyulog/pymavlink venv: {why}");
            return;
        }
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&data)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            LogFormat::from_path(p)
                .is_some_and(|f| matches!(f, LogFormat::Ulog | LogFormat::Dataflash))
        })
        .collect();
    files.sort();
    assert!(
        !files.is_empty(),
        "no ULog or DataFlash file in {}",
        data.display()
    );
    for path in files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let fmt = LogFormat::from_path(&path).unwrap();
        let json = std::fs::read_to_string(dumps.join(format!("{name}.json"))).unwrap();
        let py: serde_json::Value = serde_json::from_str(&json).unwrap();
        let r = open(&path, fmt).unwrap_or_else(|e| panic!("{name}: {e}"));
        let topics = r.topics().unwrap();
        // counts: per topic (ULog), per message type (DataFlash)
        let (ours, theirs, by): (BTreeMap<String, u64>, BTreeMap<String, u64>, &str) =
            if fmt == LogFormat::Ulog {
                let ours = topics
                    .iter()
                    .filter(|t| t.count > 0)
                    .map(|t| (t.name.clone(), t.count))
                    .collect();
                let theirs = serde_json::from_value(py["counts"].clone()).unwrap();
                (ours, theirs, "topic")
            } else {
                let mut ours = BTreeMap::new();
                for t in &topics {
                    *ours.entry(t.msg_type.clone()).or_insert(0) += t.count;
                }
                let theirs = serde_json::from_value(py["by_type"].clone()).unwrap();
                (ours, theirs, "message type")
            };
        assert_eq!(ours, theirs, "{name}: message counts per {by}");
        let total: u64 = ours.values().sum();
        // the IMU topics: stamps exact, values to 1e-7 relative
        let imu = py["imu"].as_object().unwrap();
        assert!(!imu.is_empty(), "{name}: no IMU topic in the dump");
        let mut worst = 0.0f64;
        let mut n_values = 0;
        for (topic, t) in imu {
            let s = r
                .read_imu(topic)
                .unwrap_or_else(|e| panic!("{name} {topic}: {e}"));
            let stamps: Vec<i64> = t["stamps_us"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_i64().unwrap() * 1000)
                .collect();
            assert_eq!(s.stamps_ns, stamps, "{name} {topic}: stamps");
            let cols: Vec<Vec<f64>> = serde_json::from_value(t["columns"].clone()).unwrap();
            assert_eq!(s.columns.len(), cols.len(), "{name} {topic}: channels");
            for (c, (a, b)) in s.columns.iter().zip(&cols).enumerate() {
                assert_eq!(a.len(), b.len(), "{name} {topic}: channel {c} length");
                let d = max_rel(a, b);
                assert!(
                    d <= 1e-7,
                    "{name} {topic} {}: relative difference {d:e}",
                    s.names[c]
                );
                worst = worst.max(d);
                n_values += a.len();
            }
        }
        eprintln!(
            "{name}: {total} messages in {} {by}s equal; {} IMU topics, {n_values} values, \
             largest relative difference {worst:e}; cut off: {}",
            ours.len(),
            imu.len(),
            r.truncation().map_or("no".to_string(), |t| t.to_string())
        );
    }
}
