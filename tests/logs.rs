//! Log readers end to end: fixtures written here from simulated data (with the `mcap`
//! crate for MCAP), read back by the `imunoise` binary and compared with the same data as
//! CSV, bit for bit; exact gap/duplicate/reorder counts on injected faults; and one exit-2
//! test per bad-input class (wrong topic, several IMU topics, no IMU topic, wrong message
//! type, empty topic, truncated file, corrupt file, rate disagreeing with the stamps).
#![cfg(feature = "mcap")]

use imunoise::logs::imu_msg::{ImuSample, encode_cdr};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn imunoise(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_imunoise"))
        .args(args)
        .output()
        .expect("the binary runs")
}

fn ok(args: &[&str]) -> String {
    let out = imunoise(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs, expects exit code 2, returns stderr.
fn fails(args: &[&str]) -> String {
    let out = imunoise(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// Six channels of WN + RW (gyro in rad/s, acc in m/s² around g), known parameters,
/// fixed seed.
fn simulated(n: usize, rate: f64) -> Vec<Vec<f64>> {
    let gyro: imunoise::processes::Model = "WN(sigma2=1e-6)+RW(gamma2=1e-12)".parse().unwrap();
    let acc: imunoise::processes::Model = "WN(sigma2=4e-4)+RW(gamma2=1e-9)".parse().unwrap();
    let mut c = imunoise::cli::simulate::simulate_channels(&gyro, n, rate, 11, 3).unwrap();
    let mut a = imunoise::cli::simulate::simulate_channels(&acc, n, rate, 12, 3).unwrap();
    a[2].iter_mut().for_each(|v| *v += 9.80665);
    c.append(&mut a);
    c
}

/// Stamps at `rate` from 1.7e9 s.
fn stamps(n: usize, rate: f64) -> Vec<i64> {
    let dt = (1e9 / rate).round() as i64;
    (0..n as i64).map(|i| 1_700_000_000_000_000_000 + i * dt).collect()
}

struct Topic<'a> {
    name: &'a str,
    schema: &'a str,
    stamps: Vec<i64>,
    cols: Vec<Vec<f64>>,
}

fn sample(stamps: &[i64], cols: &[Vec<f64>], i: usize) -> ImuSample {
    ImuSample {
        stamp_ns: stamps[i],
        gyro: [cols[0][i], cols[1][i], cols[2][i]],
        acc: [cols[3][i], cols[4][i], cols[5][i]],
    }
}

/// Writes an MCAP file (zstd chunks) with the topics interleaved in stamp order.
fn write_mcap(path: &Path, topics: &[Topic<'_>]) {
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .create(f)
        .unwrap();
    let mut ids = Vec::new();
    for t in topics {
        let s = w.add_schema(t.schema, "ros2msg", b"(definition omitted)").unwrap();
        ids.push(w.add_channel(s, t.name, "cdr", &BTreeMap::new()).unwrap());
    }
    let mut events: Vec<(i64, usize, usize)> = Vec::new();
    for (k, t) in topics.iter().enumerate() {
        for (i, &s) in t.stamps.iter().enumerate() {
            events.push((s, k, i));
        }
    }
    // Recording order = position in the topic's vectors (so injected reordering survives).
    events.sort_by_key(|&(_, k, i)| (i, k));
    for (seq, &(s, k, i)) in events.iter().enumerate() {
        let t = &topics[k];
        let data = if t.schema == "sensor_msgs/msg/Imu" {
            encode_cdr(&sample(&t.stamps, &t.cols, i), "imu_link")
        } else {
            vec![0, 1, 0, 0, 1, 2, 3, 4]
        };
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: ids[k],
                sequence: seq as u32,
                log_time: s as u64,
                publish_time: s as u64,
            },
            &data,
        )
        .unwrap();
    }
    w.finish().unwrap();
}

fn write_csv(path: &Path, cols: &[Vec<f64>]) {
    let names: Vec<String> = imunoise::logs::IMU_NAMES.iter().map(|s| s.to_string()).collect();
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    imunoise::cli::simulate::write_csv(&mut f, &names, cols).unwrap();
}

fn imu<'a>(name: &'a str, n: usize, rate: f64) -> Topic<'a> {
    Topic {
        name,
        schema: "sensor_msgs/msg/Imu",
        stamps: stamps(n, rate),
        cols: simulated(n, rate),
    }
}

fn p(dir: &tempfile::TempDir, name: &str) -> PathBuf {
    dir.path().join(name)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn mcap_equals_csv_bit_for_bit_and_rate_from_stamps() {
    let dir = tempfile::tempdir().unwrap();
    let (mc, csv) = (p(&dir, "run.mcap"), p(&dir, "run.csv"));
    let t = imu("/imu0", 20_000, 200.0);
    write_csv(&csv, &t.cols);
    write_mcap(&mc, &[t]);
    let a = ok(&["avar", s(&mc), "--format", "json", "-q"]);
    let b = ok(&["avar", s(&csv), "--rate", "200", "--format", "json", "-q"]);
    assert_eq!(a, b, "MCAP and CSV give the same AV JSON, byte for byte");
    let v: serde_json::Value = serde_json::from_str(&a).unwrap();
    assert_eq!(v["channels"][0]["rate_hz"], 200.0);
    assert_eq!(v["channels"][0]["n"], 20_000);
    // A --rate within 1 % is accepted.
    let c = ok(&["avar", s(&mc), "--rate", "200", "--format", "json", "-q"]);
    assert_eq!(a, c);
}

#[test]
fn topics_lists_types_counts_and_rates() {
    let dir = tempfile::tempdir().unwrap();
    let mc = p(&dir, "two.mcap");
    let cam = Topic {
        name: "/cam",
        schema: "sensor_msgs/msg/Image",
        stamps: stamps(30, 10.0),
        cols: vec![],
    };
    write_mcap(&mc, &[imu("/imu0", 3000, 200.0), imu("/imu1", 1000, 100.0), cam]);
    let out = ok(&["topics", s(&mc), "--format", "json"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let names: Vec<&str> = v.as_array().unwrap().iter().map(|t| t["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["/cam", "/imu0", "/imu1"]);
    assert_eq!(v[1]["count"], 3000);
    assert_eq!(v[1]["rate_hz"], 200.0);
    assert_eq!(v[2]["rate_hz"], 100.0);
    assert_eq!(v[0]["is_imu"], false);
    let table = ok(&["topics", s(&mc)]);
    assert!(table.contains("* /imu0"), "{table}");
    // Several IMU topics and no --topic: exit 2 listing them.
    let err = fails(&["avar", s(&mc)]);
    assert!(
        err.contains(&format!("{} has 2 IMU topics; choose one or more with --topic: /imu0 (sensor_msgs/msg/Imu, 3000 messages, 200.0 Hz), /imu1 (sensor_msgs/msg/Imu, 1000 messages, 100.0 Hz)", s(&mc))),
        "{err}"
    );
    // A wrong topic: the message.
    let err = fails(&["avar", s(&mc), "--topic", "/imu"]);
    assert!(
        err.contains(&format!("topic /imu not found; IMU topics in {}: /imu0 (sensor_msgs/msg/Imu, 3000 messages, 200.0 Hz), /imu1", s(&mc))),
        "{err}"
    );
    // A topic of another type.
    let err = fails(&["avar", s(&mc), "--topic", "/cam"]);
    assert!(err.contains("topic /cam in") && err.contains("has type sensor_msgs/msg/Image, not sensor_msgs/Imu"), "{err}");
    // Selecting works; two topics for analyze give one report each (checked in
    // analyze_reports_timing_and_one_section_per_topic).
    let one = ok(&["avar", s(&mc), "--topic", "/imu1", "--format", "json", "-q"]);
    let v: serde_json::Value = serde_json::from_str(&one).unwrap();
    assert_eq!(v["channels"][0]["rate_hz"], 100.0);
    assert_eq!(v["channels"][0]["n"], 1000);
}

#[test]
fn no_imu_topic_empty_topic_truncated_and_corrupt_files_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let mc = p(&dir, "cam.mcap");
    let cam = Topic {
        name: "/cam",
        schema: "sensor_msgs/msg/Image",
        stamps: stamps(30, 10.0),
        cols: vec![],
    };
    write_mcap(&mc, &[cam]);
    let err = fails(&["avar", s(&mc)]);
    assert!(err.contains(&format!("no IMU topic (sensor_msgs/Imu) in {}; its topics: /cam (sensor_msgs/msg/Image, 30 messages)", s(&mc))), "{err}");
    // An IMU topic without messages.
    let empty = p(&dir, "empty.mcap");
    write_mcap(&empty, &[Topic { name: "/imu0", schema: "sensor_msgs/msg/Imu", stamps: vec![], cols: vec![] }]);
    let err = fails(&["avar", s(&empty)]);
    assert!(err.contains("topic /imu0 (sensor_msgs/msg/Imu) in") && err.contains("has no messages"), "{err}");
    // Truncated: the first 60 % of a good file.
    let good = p(&dir, "good.mcap");
    write_mcap(&good, &[imu("/imu0", 5000, 200.0)]);
    let bytes = std::fs::read(&good).unwrap();
    let trunc = p(&dir, "trunc.mcap");
    std::fs::write(&trunc, &bytes[..bytes.len() * 6 / 10]).unwrap();
    let err = fails(&["avar", s(&trunc)]);
    assert!(err.contains("truncated or corrupt MCAP"), "{err}");
    // Corrupt: 4 KiB flipped a third into the file (inside the first zstd chunk, which
    // is written before its message index).
    let mut bad = bytes.clone();
    let mid = bad.len() / 3;
    for b in &mut bad[mid..mid + 4096] {
        *b ^= 0x5a;
    }
    let corrupt = p(&dir, "corrupt.mcap");
    std::fs::write(&corrupt, &bad).unwrap();
    let err = fails(&["avar", s(&corrupt)]);
    assert!(err.contains("truncated or corrupt MCAP") || err.contains("not a valid sensor_msgs/Imu"), "{err}");
    // Not MCAP at all.
    let text = p(&dir, "text.mcap");
    std::fs::write(&text, b"1,2,3\n").unwrap();
    let err = fails(&["avar", s(&text)]);
    assert!(err.contains("not an MCAP file"), "{err}");
    // A --rate that disagrees with the stamps by more than 1 %: both are printed.
    let err = fails(&["avar", s(&good), "--rate", "100"]);
    assert!(err.contains("--rate 100 Hz disagrees with the rate from the time stamps, 200.000000 Hz"), "{err}");
    // Text without stamps still needs --rate.
    let csv = p(&dir, "x.csv");
    std::fs::write(&csv, "a\n1\n2\n3\n4\n5\n6\n7\n8\n").unwrap();
    let err = fails(&["avar", s(&csv)]);
    assert!(err.contains("--rate is required"), "{err}");
}

/// 10 000 samples at 100 Hz with injected faults: 4 messages recorded out of order, 5
/// duplicated stamps and 2 gaps missing 3 and 20 samples.
fn faulty() -> (Vec<i64>, Vec<Vec<f64>>) {
    let n = 10_023;
    let st = stamps(n, 100.0);
    let cols = simulated(n, 100.0);
    let mut idx: Vec<usize> = (0..n).collect();
    idx.drain(8000..8020); // gap of 20 missing
    idx.drain(2000..2003); // gap of 3 missing
    for d in [100, 101, 102, 103, 104] {
        idx.insert(d * 10, idx[d * 10]); // duplicates
    }
    for at in [500, 600, 700, 900] {
        idx.swap(at, at + 1); // one message recorded before its predecessor
    }
    let s: Vec<i64> = idx.iter().map(|&i| st[i]).collect();
    let c: Vec<Vec<f64>> = cols.iter().map(|c| idx.iter().map(|&i| c[i]).collect()).collect();
    (s, c)
}

#[test]
fn gap_duplicate_and_reorder_counts_are_exact() {
    let dir = tempfile::tempdir().unwrap();
    let mc = p(&dir, "faulty.mcap");
    let (st, cols) = faulty();
    assert_eq!(st.len(), 10_005);
    write_mcap(&mc, &[Topic { name: "/imu0", schema: "sensor_msgs/msg/Imu", stamps: st, cols }]);
    // 23 missing of 10 000 = 0.23 % > 0.1 %: refused, with the way out in the message.
    let err = fails(&["avar", s(&mc)]);
    assert!(err.contains("2 gaps") && err.contains("about 23 missing samples") && err.contains("--gaps longest"), "{err}");
    let out = p(&dir, "rep");
    ok(&["analyze", s(&mc), "--gaps", "ignore", "--out", s(&out), "-q", "--no-select", "--model", "WN+RW"]);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let t = &v["timing"];
    assert_eq!(t["messages"], 10_005);
    assert_eq!(t["reordered"], 4);
    assert_eq!(t["duplicates"], 5);
    assert_eq!(t["gaps"], 2);
    assert_eq!(t["missing_samples"], 23);
    assert_eq!(t["samples_used"], 10_000);
    assert_eq!(t["rate_hz"], 100.0);
    assert_eq!(t["gap_policy"], "ignore");
    assert_eq!(v["topic"], "/imu0");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("4 reordered, 5 duplicates (removed), 2 gaps (23 samples missing"), "report states the counts");
    assert!(html.contains("--gaps ignore"));
    // --gaps longest: the longest gap-free run is samples 2000..7997 after sorting
    // (8000 − 3 = 7997 because the first gap removed 3 before it).
    let o = ok(&["avar", s(&mc), "--gaps", "longest", "--format", "json", "-q"]);
    let v: serde_json::Value = serde_json::from_str(&o).unwrap();
    assert_eq!(v["channels"][0]["n"], 5997);
}
