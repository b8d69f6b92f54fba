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
    (0..n as i64)
        .map(|i| 1_700_000_000_000_000_000 + i * dt)
        .collect()
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
    write_mcap_with(path, topics, mcap::WriteOptions::new())
}

/// [`write_mcap`] with other writer options (compression, chunk size, indexes).
fn write_mcap_with(path: &Path, topics: &[Topic<'_>], options: mcap::WriteOptions) {
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = options.profile("ros2").create(f).unwrap();
    let mut ids = Vec::new();
    for t in topics {
        let s = w
            .add_schema(t.schema, "ros2msg", b"(definition omitted)")
            .unwrap();
        // as rosbag2 writes it: the publisher's QoS in the channel's metadata map
        let qos = BTreeMap::from([(
            "offered_qos_profiles".to_string(),
            "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n".to_string(),
        )]);
        ids.push(w.add_channel(s, t.name, "cdr", &qos).unwrap());
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
    let names: Vec<String> = imunoise::logs::IMU_NAMES
        .iter()
        .map(|s| s.to_string())
        .collect();
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

/// `analyze` on a log (`log_args`: the file and any --topic) and on the same data as CSV at
/// `rate` give the same channels in results.json (AV, fit, IEEE values, robust check), number
/// for number, and the same rate. Returns the log's results.json.
fn analyze_equals_csv(
    dir: &tempfile::TempDir,
    log_args: &[&str],
    csv: &Path,
    rate: &str,
) -> serde_json::Value {
    let (ra, rb) = (p(dir, "analyze_log"), p(dir, "analyze_csv"));
    let fit = ["--model", "WN+RW", "--no-select", "-q"];
    ok(&[&["analyze"][..], log_args, &["--out", s(&ra)], &fit[..]].concat());
    ok(&[
        &["analyze", s(csv), "--rate", rate, "--out", s(&rb)][..],
        &fit[..],
    ]
    .concat());
    let res = |d: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(d.join("results.json")).unwrap()).unwrap()
    };
    let (ja, jb) = (res(&ra), res(&rb));
    assert_eq!(
        ja["channels"], jb["channels"],
        "{log_args:?}: analyze differs from CSV"
    );
    assert_eq!(ja["rate_hz"], jb["rate_hz"]);
    ja
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
    let ja = analyze_equals_csv(&dir, &[s(&mc)], &csv, "200");
    assert_eq!(ja["timing"]["rate_source"], "stamps");
    // A ROS 2 bag folder (metadata.yaml + the storage file) reads the same.
    let bagdir = p(&dir, "bagdir");
    std::fs::create_dir(&bagdir).unwrap();
    std::fs::write(
        bagdir.join("metadata.yaml"),
        "rosbag2_bagfile_information: {}\n",
    )
    .unwrap();
    std::fs::copy(&mc, bagdir.join("bagdir_0.mcap")).unwrap();
    assert_eq!(a, ok(&["avar", s(&bagdir), "--format", "json", "-q"]));
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
    write_mcap(
        &mc,
        &[imu("/imu0", 3000, 200.0), imu("/imu1", 1000, 100.0), cam],
    );
    let out = ok(&["topics", s(&mc), "--format", "json"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let names: Vec<&str> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["name"].as_str().unwrap())
        .collect();
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
    assert!(
        err.contains("topic /cam in")
            && err.contains("has type sensor_msgs/msg/Image, not sensor_msgs/Imu"),
        "{err}"
    );
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
    write_mcap(
        &empty,
        &[Topic {
            name: "/imu0",
            schema: "sensor_msgs/msg/Imu",
            stamps: vec![],
            cols: vec![],
        }],
    );
    let err = fails(&["avar", s(&empty)]);
    assert!(
        err.contains("topic /imu0 (sensor_msgs/msg/Imu) in") && err.contains("has no messages"),
        "{err}"
    );
    // Truncated: the first 60 % of a good file.
    let good = p(&dir, "good.mcap");
    write_mcap(&good, &[imu("/imu0", 5000, 200.0)]);
    let bytes = std::fs::read(&good).unwrap();
    let trunc = p(&dir, "trunc.mcap");
    std::fs::write(&trunc, &bytes[..bytes.len() * 6 / 10]).unwrap();
    // read up to its last complete chunk with a warning; refused under --strict
    let out = imunoise(&["avar", s(&trunc), "--format", "json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("warning:") && err.contains("the file is cut off"),
        "{err}"
    );
    let err = fails(&["avar", s(&trunc), "--strict"]);
    assert!(err.contains("--strict refuses cut-off logs"), "{err}");
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
    assert!(
        err.contains("truncated or corrupt MCAP") || err.contains("not a valid sensor_msgs/Imu"),
        "{err}"
    );
    // Not MCAP at all.
    let text = p(&dir, "text.mcap");
    std::fs::write(&text, b"1,2,3\n").unwrap();
    let err = fails(&["avar", s(&text)]);
    assert!(err.contains("not an MCAP file"), "{err}");
    // A --rate that disagrees with the stamps by more than 1 %: both are printed.
    let err = fails(&["avar", s(&good), "--rate", "100"]);
    assert!(
        err.contains("--rate 100 Hz disagrees with the rate from the time stamps, 200.000000 Hz"),
        "{err}"
    );
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
    let c: Vec<Vec<f64>> = cols
        .iter()
        .map(|c| idx.iter().map(|&i| c[i]).collect())
        .collect();
    (s, c)
}

#[test]
fn gap_duplicate_and_reorder_counts_are_exact() {
    let dir = tempfile::tempdir().unwrap();
    let mc = p(&dir, "faulty.mcap");
    let (st, cols) = faulty();
    assert_eq!(st.len(), 10_005);
    write_mcap(
        &mc,
        &[Topic {
            name: "/imu0",
            schema: "sensor_msgs/msg/Imu",
            stamps: st,
            cols,
        }],
    );
    // 23 missing of 10 000 = 0.23 % > 0.1 %: refused, with the way out in the message.
    let err = fails(&["avar", s(&mc)]);
    assert!(
        err.contains("2 gaps")
            && err.contains("about 23 missing samples")
            && err.contains("--gaps longest"),
        "{err}"
    );
    let out = p(&dir, "rep");
    ok(&[
        "analyze",
        s(&mc),
        "--gaps",
        "ignore",
        "--out",
        s(&out),
        "-q",
        "--no-select",
        "--model",
        "WN+RW",
    ]);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
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
    assert!(
        html.contains("4 reordered, 5 duplicates (removed), 2 gaps (23 samples missing"),
        "report states the counts"
    );
    assert!(html.contains("--gaps ignore"));
    // Read-off marks on each AD plot and the "how long to record" line.
    let svg = std::fs::read_to_string(out.join("adev_gyro_x_rads.svg")).unwrap();
    for m in [">N = ", ">K = ", ">B = "] {
        assert!(svg.contains(m), "plot marks {m}");
    }
    assert!(html.contains("How long to record") && html.contains("±10 % needs about"));
    // --gaps longest: the longest gap-free run is samples 2000..7997 after sorting
    // (8000 − 3 = 7997 because the first gap removed 3 before it).
    let o = ok(&[
        "avar",
        s(&mc),
        "--gaps",
        "longest",
        "--format",
        "json",
        "-q",
    ]);
    let v: serde_json::Value = serde_json::from_str(&o).unwrap();
    assert_eq!(v["channels"][0]["n"], 5997);
}

// ---------------------------------------------------------------- ROS 1 bags

fn bag_field(name: &str, val: &[u8]) -> Vec<u8> {
    let mut v = ((name.len() + 1 + val.len()) as u32).to_le_bytes().to_vec();
    v.extend_from_slice(name.as_bytes());
    v.push(b'=');
    v.extend_from_slice(val);
    v
}

fn bag_record(fields: &[Vec<u8>], data: &[u8]) -> Vec<u8> {
    let h: Vec<u8> = fields.concat();
    let mut v = (h.len() as u32).to_le_bytes().to_vec();
    v.extend_from_slice(&h);
    v.extend_from_slice(&(data.len() as u32).to_le_bytes());
    v.extend_from_slice(data);
    v
}

fn bag_time(ns: i64) -> [u8; 8] {
    let mut t = [0u8; 8];
    t[..4].copy_from_slice(&((ns / 1_000_000_000) as u32).to_le_bytes());
    t[4..].copy_from_slice(&((ns % 1_000_000_000) as u32).to_le_bytes());
    t
}

fn bag_connection(id: u32, t: &Topic<'_>) -> Vec<u8> {
    let data = [
        bag_field("topic", t.name.as_bytes()),
        bag_field("type", t.schema.as_bytes()),
        bag_field("md5sum", b"6a62c6daae103f4ff57a132d6f95cec2"),
        bag_field("message_definition", b"(omitted)"),
    ]
    .concat();
    bag_record(
        &[
            bag_field("op", &[7]),
            bag_field("conn", &id.to_le_bytes()),
            bag_field("topic", t.name.as_bytes()),
        ],
        &data,
    )
}

/// Writes a ROS 1 bag (format 2.0, one uncompressed chunk, with its index), the messages
/// in recording order (position in each topic's vectors, topics interleaved).
fn write_bag(path: &Path, topics: &[Topic<'_>]) {
    write_bag_chunked(path, topics, usize::MAX, false)
}

/// A ROS 1 bag (format 2.0, uncompressed chunks of `per_chunk` messages each, the
/// connections in the first chunk and in the index), indexed as `rosbag record` writes it:
/// after each chunk its index data records, at the end the connections and one chunk info
/// record per chunk. With `miscount`, the first chunk info claims one message more on its
/// first connection than the chunk holds.
fn write_bag_chunked(path: &Path, topics: &[Topic<'_>], per_chunk: usize, miscount: bool) {
    use imunoise::logs::imu_msg::encode_ros1;
    let mut events: Vec<(usize, usize)> = Vec::new();
    for (k, t) in topics.iter().enumerate() {
        events.extend((0..t.stamps.len()).map(|i| (i, k)));
    }
    events.sort();
    let n_chunks = events.len().div_ceil(per_chunk).max(1) as u32;
    let header = |index_pos: u64| {
        bag_record(
            &[
                bag_field("op", &[3]),
                bag_field("index_pos", &index_pos.to_le_bytes()),
                bag_field("conn_count", &(topics.len() as u32).to_le_bytes()),
                bag_field("chunk_count", &n_chunks.to_le_bytes()),
            ],
            &[b' '; 64],
        )
    };
    let mut out = b"#ROSBAG V2.0\n".to_vec();
    let hdr_at = out.len();
    out.extend_from_slice(&header(0));
    // (chunk position, per connection: messages, first and last stamp)
    type Info = (u64, Vec<(u32, u32)>, i64, i64);
    let mut infos: Vec<Info> = Vec::new();
    let batches: Vec<&[(usize, usize)]> = if events.is_empty() {
        vec![&[]]
    } else {
        events.chunks(per_chunk).collect()
    };
    for (c, batch) in batches.into_iter().enumerate() {
        let mut chunk = Vec::new();
        if c == 0 {
            for (k, t) in topics.iter().enumerate() {
                chunk.extend_from_slice(&bag_connection(k as u32, t));
            }
        }
        let mut index: Vec<Vec<(i64, u32)>> = vec![Vec::new(); topics.len()];
        let (mut t0, mut t1) = (i64::MAX, i64::MIN);
        for &(i, k) in batch {
            let t = &topics[k];
            let st = t.stamps[i];
            let data = if t.schema == "sensor_msgs/Imu" {
                encode_ros1(&sample(&t.stamps, &t.cols, i), i as u32, "imu_link")
            } else {
                vec![1, 2, 3]
            };
            index[k].push((st, chunk.len() as u32));
            t0 = t0.min(st);
            t1 = t1.max(st);
            chunk.extend_from_slice(&bag_record(
                &[
                    bag_field("op", &[2]),
                    bag_field("conn", &(k as u32).to_le_bytes()),
                    bag_field("time", &bag_time(st)),
                ],
                &data,
            ));
        }
        let chunk_pos = out.len() as u64;
        out.extend_from_slice(&bag_record(
            &[
                bag_field("op", &[5]),
                bag_field("compression", b"none"),
                bag_field("size", &(chunk.len() as u32).to_le_bytes()),
            ],
            &chunk,
        ));
        let mut per = Vec::new();
        for (k, ix) in index.iter().enumerate() {
            if ix.is_empty() && !batch.is_empty() {
                continue;
            }
            let data: Vec<u8> = ix
                .iter()
                .flat_map(|&(st, off)| [bag_time(st).to_vec(), off.to_le_bytes().to_vec()].concat())
                .collect();
            out.extend_from_slice(&bag_record(
                &[
                    bag_field("op", &[4]),
                    bag_field("ver", &1u32.to_le_bytes()),
                    bag_field("conn", &(k as u32).to_le_bytes()),
                    bag_field("count", &(ix.len() as u32).to_le_bytes()),
                ],
                &data,
            ));
            per.push((k as u32, ix.len() as u32));
        }
        if t0 > t1 {
            (t0, t1) = (0, 0);
        }
        infos.push((chunk_pos, per, t0, t1));
    }
    let index_pos = out.len() as u64;
    for (k, t) in topics.iter().enumerate() {
        out.extend_from_slice(&bag_connection(k as u32, t));
    }
    for (c, (chunk_pos, per, t0, t1)) in infos.iter().enumerate() {
        let entries: Vec<u8> = per
            .iter()
            .enumerate()
            .flat_map(|(e, &(k, n))| {
                let n = n + u32::from(miscount && c == 0 && e == 0);
                [k.to_le_bytes(), n.to_le_bytes()].concat()
            })
            .collect();
        out.extend_from_slice(&bag_record(
            &[
                bag_field("op", &[6]),
                bag_field("ver", &1u32.to_le_bytes()),
                bag_field("chunk_pos", &chunk_pos.to_le_bytes()),
                bag_field("start_time", &bag_time(*t0)),
                bag_field("end_time", &bag_time(*t1)),
                bag_field("count", &(per.len() as u32).to_le_bytes()),
            ],
            &entries,
        ));
    }
    let h = header(index_pos);
    out[hdr_at..hdr_at + h.len()].copy_from_slice(&h);
    std::fs::write(path, out).unwrap();
}

/// The topics of the ROS 1 bag tests: /imu0 (12 000 `sensor_msgs/Imu` at 400 Hz, also written
/// to `csv`) and /cam (`cam` images at 10 Hz).
#[cfg(feature = "rosbag")]
fn bag_topics(csv: &Path, cam: usize) -> [Topic<'static>; 2] {
    let mut t = imu("/imu0", 12_000, 400.0);
    t.schema = "sensor_msgs/Imu";
    write_csv(csv, &t.cols);
    let cam = Topic {
        name: "/cam",
        schema: "sensor_msgs/Image",
        stamps: stamps(cam, 10.0),
        cols: vec![],
    };
    [t, cam]
}

/// A bag of many chunks (as `rosbag record` writes them) is read chunk by chunk in parallel
/// into the final columns, and equals the CSV of the same data; an index that miscounts a
/// chunk makes that read decline, and the bag is read chunk after chunk instead, with the
/// same values; a bad message is reported with the number the sequential read gives it.
#[cfg(feature = "rosbag")]
#[test]
fn ros1_bag_of_many_chunks_is_read_in_parallel() {
    use imunoise::logs::{LogReader, rosbag1::BagReader};
    let dir = tempfile::tempdir().unwrap();
    let csv = p(&dir, "run.csv");
    let topics = bag_topics(&csv, 300);
    let (good, bad) = (p(&dir, "many.bag"), p(&dir, "miscounted.bag"));
    write_bag_chunked(&good, &topics, 700, false);
    write_bag_chunked(&bad, &topics, 700, true);
    let r = BagReader::open(&good).unwrap();
    let par = r
        .read_imu_parallel("/imu0")
        .unwrap()
        .expect("the parallel read");
    assert_eq!(par.stamps_ns, topics[0].stamps);
    assert_eq!(par.columns, topics[0].cols);
    assert_eq!(r.read_imu("/imu0").unwrap(), par);
    let rb = BagReader::open(&bad).unwrap();
    assert!(rb.read_imu_parallel("/imu0").unwrap().is_none());
    assert_eq!(rb.read_imu("/imu0").unwrap(), par);
    let a = ok(&["avar", s(&good), "--format", "json", "-q"]);
    let b = ok(&["avar", s(&csv), "--rate", "400", "--format", "json", "-q"]);
    assert_eq!(a, b, "bag and CSV give the same AV JSON, byte for byte");
    // a bad message in the fifth chunk: the same message number as the sequential read
    let mut bytes = std::fs::read(&good).unwrap();
    let frame = b"imu_link";
    let hits: Vec<usize> = bytes
        .windows(frame.len())
        .enumerate()
        .filter(|(_, w)| *w == frame)
        .map(|(i, _)| i)
        .collect();
    // the frame id's u32 length sits just before it: claim far more than the message holds
    let at = hits[3000] - 4;
    bytes[at..at + 4].copy_from_slice(&1_000_000u32.to_le_bytes());
    let broken = p(&dir, "broken.bag");
    std::fs::write(&broken, &bytes).unwrap();
    let e = BagReader::open(&broken)
        .unwrap()
        .read_imu("/imu0")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("message 3001 on /imu0 is not a valid sensor_msgs/Imu"),
        "{e}"
    );
}

#[cfg(feature = "rosbag")]
#[test]
fn ros1_bag_equals_csv_and_bad_bags_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let (bag, csv) = (p(&dir, "run.bag"), p(&dir, "run.csv"));
    write_bag(&bag, &bag_topics(&csv, 20));
    let a = ok(&["avar", s(&bag), "--format", "json", "-q"]);
    let b = ok(&["avar", s(&csv), "--rate", "400", "--format", "json", "-q"]);
    assert_eq!(a, b, "bag and CSV give the same AV JSON, byte for byte");
    analyze_equals_csv(&dir, &[s(&bag)], &csv, "400");
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["topics", s(&bag), "--format", "json"])).unwrap();
    assert_eq!(v[1]["name"], "/imu0");
    assert_eq!(v[1]["msg_type"], "sensor_msgs/Imu");
    assert_eq!(v[1]["count"], 12_000);
    assert_eq!(v[1]["rate_hz"], 400.0);
    assert_eq!(v[0]["count"], 20);
    let err = fails(&["avar", s(&bag), "--topic", "/imu"]);
    assert!(err.contains(&format!("topic /imu not found; IMU topics in {}: /imu0 (sensor_msgs/Imu, 12000 messages, 400.0 Hz)", s(&bag))), "{err}");
    // Truncated (index missing), unindexed (index_pos 0), and not a bag.
    let bytes = std::fs::read(&bag).unwrap();
    let trunc = p(&dir, "trunc.bag");
    std::fs::write(&trunc, &bytes[..bytes.len() / 2]).unwrap();
    let out = imunoise(&["avar", s(&trunc), "--format", "json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && err.contains("the file is cut off"),
        "{err}"
    );
    assert!(fails(&["avar", s(&trunc), "--strict"]).contains("--strict refuses"));
    let mut unidx = bytes.clone();
    // version, header length, "op" field (4 + 4 bytes), field length, "index_pos=".
    let at = 13 + 4 + 8 + 4 + 10;
    unidx[at..at + 8].copy_from_slice(&0u64.to_le_bytes());
    let u = p(&dir, "unindexed.bag");
    std::fs::write(&u, &unidx).unwrap();
    // not closed: read by a walk over its records, the same values as through the index
    assert_eq!(
        ok(&["avar", s(&u), "--format", "json", "-q", "--strict"]),
        a
    );
    let junk = p(&dir, "junk.bag");
    std::fs::write(&junk, b"hello").unwrap();
    assert!(fails(&["topics", s(&junk)]).contains("not a ROS 1 bag"));
}

// ---------------------------------------------------------------- ROS 2 .db3

/// Writes a rosbag2 SQLite file (Humble's schema) with the messages in recording order.
#[cfg(feature = "db3")]
fn write_db3(path: &Path, topics: &[Topic<'_>]) {
    let mut c = rusqlite::Connection::open(path).unwrap();
    c.execute_batch(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
         INSERT INTO schema VALUES (3, 'humble');
         CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
           serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
           timestamp INTEGER NOT NULL, data BLOB NOT NULL);
         CREATE INDEX timestamp_idx ON messages (timestamp ASC);",
    )
    .unwrap();
    let tx = c.transaction().unwrap();
    for (k, t) in topics.iter().enumerate() {
        tx.execute(
            "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '')",
            rusqlite::params![k as i64 + 1, t.name, t.schema],
        )
        .unwrap();
    }
    let mut events: Vec<(usize, usize)> = Vec::new();
    for (k, t) in topics.iter().enumerate() {
        events.extend((0..t.stamps.len()).map(|i| (i, k)));
    }
    events.sort();
    {
        let mut st = tx
            .prepare("INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)")
            .unwrap();
        for (i, k) in events {
            let t = &topics[k];
            let data = if t.schema == "sensor_msgs/msg/Imu" {
                encode_cdr(&sample(&t.stamps, &t.cols, i), "imu_link")
            } else {
                vec![0, 1, 0, 0]
            };
            st.execute(rusqlite::params![k as i64 + 1, t.stamps[i], data])
                .unwrap();
        }
    }
    tx.commit().unwrap();
}

#[cfg(feature = "db3")]
#[test]
fn db3_equals_csv_and_bad_files_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let (db, csv) = (p(&dir, "run.db3"), p(&dir, "run.csv"));
    let t = imu("/imu/data", 10_000, 250.0);
    write_csv(&csv, &t.cols);
    write_db3(&db, &[t]);
    let a = ok(&["avar", s(&db), "--format", "json", "-q"]);
    let b = ok(&["avar", s(&csv), "--rate", "250", "--format", "json", "-q"]);
    assert_eq!(a, b, "db3 and CSV give the same AV JSON, byte for byte");
    analyze_equals_csv(&dir, &[s(&db)], &csv, "250");
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["topics", s(&db), "--format", "json"])).unwrap();
    assert_eq!(v[0]["count"], 10_000);
    assert_eq!(v[0]["rate_hz"], 250.0);
    let bytes = std::fs::read(&db).unwrap();
    let trunc = p(&dir, "trunc.db3");
    std::fs::write(&trunc, &bytes[..bytes.len() / 3]).unwrap();
    let err = fails(&["avar", s(&trunc)]);
    assert!(err.contains("corrupt"), "{err}");
    let junk = p(&dir, "junk.db3");
    std::fs::write(&junk, b"SQLite? no").unwrap();
    assert!(fails(&["avar", s(&junk)]).contains("not an SQLite"));
}

// ---------------------------------------------------------------- PX4 ULog, ArduPilot DataFlash

/// The columns rounded to f32, as these logs store them.
fn as_f32(cols: &[Vec<f64>]) -> Vec<Vec<f64>> {
    cols.iter()
        .map(|c| c.iter().map(|&v| v as f32 as f64).collect())
        .collect()
}

fn ulog_msg(ty: u8, body: &[u8]) -> Vec<u8> {
    let mut v = (body.len() as u16).to_le_bytes().to_vec();
    v.push(ty);
    v.extend_from_slice(body);
    v
}

/// Writes a ULog with `sensor_combined` (µs stamps) and a `vehicle_status` topic.
fn write_ulog(path: &Path, stamps_us: &[u64], cols: &[Vec<f64>]) {
    let mut out = b"ULog\x01\x12\x35\x01".to_vec();
    out.extend_from_slice(&0u64.to_le_bytes());
    out.extend(ulog_msg(b'B', &[0u8; 40]));
    out.extend(ulog_msg(b'F', b"sensor_combined:uint64_t timestamp;float[3] gyro_rad;uint32_t gyro_integral_dt;int32_t accelerometer_timestamp_relative;float[3] accelerometer_m_s2;uint32_t accelerometer_integral_dt;uint8_t accelerometer_clipping;uint8_t[3] _padding0;"));
    out.extend(ulog_msg(
        b'F',
        b"vehicle_status:uint64_t timestamp;uint8_t arming_state;uint8_t[7] _padding0;",
    ));
    out.extend(ulog_msg(b'A', b"\x00\x00\x00sensor_combined"));
    out.extend(ulog_msg(b'A', b"\x00\x01\x00vehicle_status"));
    for (i, &t) in stamps_us.iter().enumerate() {
        let mut d = vec![0u8, 0];
        d.extend_from_slice(&t.to_le_bytes());
        for c in &cols[..3] {
            d.extend_from_slice(&(c[i] as f32).to_le_bytes());
        }
        d.extend_from_slice(&4000u32.to_le_bytes());
        d.extend_from_slice(&0i32.to_le_bytes());
        for c in &cols[3..] {
            d.extend_from_slice(&(c[i] as f32).to_le_bytes());
        }
        d.extend_from_slice(&4000u32.to_le_bytes());
        d.extend_from_slice(&[0, 0, 0, 0]);
        out.extend(ulog_msg(b'D', &d));
        if i % 100 == 0 {
            let mut s = vec![1u8, 0];
            s.extend_from_slice(&t.to_le_bytes());
            s.extend_from_slice(&[2, 0, 0, 0, 0, 0, 0, 0]);
            out.extend(ulog_msg(b'D', &s));
        }
    }
    std::fs::write(path, out).unwrap();
}

#[cfg(feature = "ulog")]
#[test]
fn ulog_equals_csv_and_bad_files_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let (ul, csv) = (p(&dir, "px4.ulg"), p(&dir, "px4.csv"));
    let n = 8000;
    let cols = as_f32(&simulated(n, 250.0));
    let st: Vec<u64> = (0..n as u64).map(|i| 5_000_000 + 4000 * i).collect();
    write_csv(&csv, &cols);
    write_ulog(&ul, &st, &cols);
    let a = ok(&["avar", s(&ul), "--format", "json", "-q"]);
    let b = ok(&["avar", s(&csv), "--rate", "250", "--format", "json", "-q"]);
    assert_eq!(a, b, "ULog and CSV give the same AV JSON, byte for byte");
    analyze_equals_csv(&dir, &[s(&ul)], &csv, "250");
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["topics", s(&ul), "--format", "json"])).unwrap();
    assert_eq!(v[0]["name"], "sensor_combined");
    assert_eq!(v[0]["count"], 8000);
    assert_eq!(v[0]["rate_hz"], 250.0);
    assert_eq!(v[1]["name"], "vehicle_status");
    assert_eq!(v[1]["count"], 80);
    let err = fails(&["avar", s(&ul), "--topic", "vehicle_status"]);
    assert!(
        err.contains("has type vehicle_status, not sensor_msgs/Imu"),
        "{err}"
    );
    let bytes = std::fs::read(&ul).unwrap();
    let trunc = p(&dir, "trunc.ulg");
    std::fs::write(&trunc, &bytes[..bytes.len() - 7]).unwrap();
    assert!(fails(&["avar", s(&trunc), "--strict"]).contains("the file is cut off"));
    let out = imunoise(&["topics", s(&trunc)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && err.contains("the 46 bytes from byte"),
        "{err}"
    );
    let junk = p(&dir, "junk.ulg");
    std::fs::write(&junk, b"not a ulog file at all").unwrap();
    assert!(fails(&["avar", s(&junk)]).contains("not a PX4 ULog"));
}

fn df_fmt(ty: u8, len: u8, name: &str, format: &str, labels: &str) -> Vec<u8> {
    let pad = |s: &str, n: usize| {
        let mut v = s.as_bytes().to_vec();
        v.resize(n, 0);
        v
    };
    let mut v = vec![0xA3, 0x95, 0x80, ty, len];
    v.extend(pad(name, 4));
    v.extend(pad(format, 16));
    v.extend(pad(labels, 64));
    v
}

/// Writes a DataFlash log with two IMU instances (the second at half the values) and BARO.
fn write_dataflash(path: &Path, stamps_us: &[u64], cols: &[Vec<f64>]) {
    let mut out = df_fmt(0x80, 89, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns");
    out.extend(df_fmt(
        0x40,
        36,
        "IMU",
        "QBffffff",
        "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ",
    ));
    out.extend(df_fmt(0x41, 16, "BARO", "QBf", "TimeUS,I,Alt"));
    for (i, &t) in stamps_us.iter().enumerate() {
        for inst in 0..2u8 {
            out.extend_from_slice(&[0xA3, 0x95, 0x40]);
            out.extend_from_slice(&t.to_le_bytes());
            out.push(inst);
            for c in cols {
                let v = if inst == 0 { c[i] } else { c[i] / 2.0 };
                out.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        if i % 40 == 0 {
            out.extend_from_slice(&[0xA3, 0x95, 0x41]);
            out.extend_from_slice(&t.to_le_bytes());
            out.push(0);
            out.extend_from_slice(&12.5f32.to_le_bytes());
        }
    }
    std::fs::write(path, out).unwrap();
}

#[cfg(feature = "dataflash")]
#[test]
fn dataflash_equals_csv_and_bad_files_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let (df, csv) = (p(&dir, "ap.bin"), p(&dir, "ap.csv"));
    let n = 8000;
    let cols = as_f32(&simulated(n, 400.0));
    let st: Vec<u64> = (0..n as u64).map(|i| 1_000_000 + 2500 * i).collect();
    write_csv(&csv, &cols);
    write_dataflash(&df, &st, &cols);
    // Two IMU instances: --topic is required.
    let err = fails(&["avar", s(&df)]);
    assert!(err.contains("has 2 IMU topics; choose one or more with --topic: IMU[0] (IMU, 8000 messages, 400.0 Hz), IMU[1] (IMU, 8000 messages, 400.0 Hz)"), "{err}");
    let a = ok(&[
        "avar",
        s(&df),
        "--topic",
        "IMU[0]",
        "--format",
        "json",
        "-q",
    ]);
    let b = ok(&["avar", s(&csv), "--rate", "400", "--format", "json", "-q"]);
    assert_eq!(
        a, b,
        "DataFlash and CSV give the same AV JSON, byte for byte"
    );
    analyze_equals_csv(&dir, &[s(&df), "--topic", "IMU[0]"], &csv, "400");
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["topics", s(&df), "--format", "json"])).unwrap();
    assert_eq!(v[0]["name"], "BARO");
    assert_eq!(v[0]["count"], 200);
    // analyze with two topics: one report folder each.
    let out = p(&dir, "rep");
    ok(&[
        "analyze",
        s(&df),
        "--topic",
        "IMU[0]",
        "--topic",
        "IMU[1]",
        "--out",
        s(&out),
        "-q",
        "--no-select",
        "--model",
        "WN+RW",
    ]);
    for t in ["IMU_0_", "IMU_1_"] {
        let r: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join(t).join("results.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(r["rate_hz"], 400.0);
    }
    let bytes = std::fs::read(&df).unwrap();
    let trunc = p(&dir, "trunc.bin");
    std::fs::write(&trunc, &bytes[..bytes.len() - 5]).unwrap();
    assert!(fails(&["avar", s(&trunc), "--topic", "IMU[0]", "--strict"]).contains("cut off"));
    let out = imunoise(&["topics", s(&trunc)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success() && err.contains("the 31 bytes from byte"),
        "{err}"
    );
    let mut bad = bytes.clone();
    let at = 89 * 3 + 2 * 36 + 16; // the header of the second time step's first IMU message
    bad[at] = 0;
    let corrupt = p(&dir, "corrupt.bin");
    std::fs::write(&corrupt, &bad).unwrap();
    let err = fails(&["avar", s(&corrupt), "--topic", "IMU[0]"]);
    assert!(err.contains("expected a message header (A3 95)"), "{err}");
}

#[test]
fn csv_time_column_gives_the_rate_and_the_order() {
    let dir = tempfile::tempdir().unwrap();
    let cols = simulated(6000, 100.0);
    let st = stamps(6000, 100.0);
    // Time in seconds since start, with 3 rows swapped in recording order and one gap.
    let mut rows: Vec<usize> = (0..6000).collect();
    rows.swap(10, 11);
    rows.swap(20, 21);
    rows.swap(30, 31);
    let mut s1 = String::from("t,gyro_x_rads,acc_x_mps2\n");
    for &i in &rows {
        let t = (st[i] - st[0]) as f64 * 1e-9;
        s1.push_str(&format!("{t:?},{:?},{:?}\n", cols[0][i], cols[3][i]));
    }
    let timed = p(&dir, "timed.csv");
    std::fs::write(&timed, &s1).unwrap();
    let mut s2 = String::from("gyro_x_rads,acc_x_mps2\n");
    for (g, a) in cols[0].iter().zip(&cols[3]) {
        s2.push_str(&format!("{g:?},{a:?}\n"));
    }
    let plain = p(&dir, "plain.csv");
    std::fs::write(&plain, &s2).unwrap();
    let a = ok(&[
        "avar",
        s(&timed),
        "--time-column",
        "t",
        "--format",
        "json",
        "-q",
    ]);
    let b = ok(&["avar", s(&plain), "--rate", "100", "--format", "json", "-q"]);
    assert_eq!(a, b, "sorted by stamp, rate from the time column");
    // The same with --columns and the time column given by index, in milliseconds.
    let mut s3 = String::from("t_ms,gyro_x_rads,acc_x_mps2\n");
    for &i in &rows {
        s3.push_str(&format!(
            "{},{:?},{:?}\n",
            (st[i] - st[0]) / 1_000_000,
            cols[0][i],
            cols[3][i]
        ));
    }
    let ms = p(&dir, "ms.csv");
    std::fs::write(&ms, &s3).unwrap();
    let c = ok(&[
        "avar",
        s(&ms),
        "--time-column",
        "1",
        "--time-unit",
        "ms",
        "--columns",
        "gyro_x_rads,acc_x_mps2",
        "--format",
        "json",
        "-q",
    ]);
    assert_eq!(a, c);
    let err = fails(&[
        "avar",
        s(&ms),
        "--time-column",
        "1",
        "--time-unit",
        "ms",
        "--rate",
        "50",
    ]);
    assert!(err.contains("--rate 50 Hz disagrees"), "{err}");
}

/// Property tests of every log reader (run by `cargo xtask fuzz` too, filter `fuzz_`): a valid
/// fixture of each format with random byte flips and a random truncation, or arbitrary bytes
/// behind the format's magic, never makes a reader panic; listing the topics and reading each
/// one either works (finite values, one stamp per sample) or gives a user error (exit code 2).
#[cfg(all(
    feature = "rosbag",
    feature = "db3",
    feature = "ulog",
    feature = "dataflash"
))]
mod fuzz {
    use super::*;
    use imunoise::logs::{LogFormat, open};
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngSeed};
    use std::sync::OnceLock;

    fn config() -> Config {
        let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<u64>().ok());
        Config {
            cases: env("IMUNOISE_FUZZ_CASES").map_or(64, |c| c as u32),
            rng_seed: RngSeed::Fixed(env("IMUNOISE_FUZZ_SEED").unwrap_or(0x106_2026)),
            failure_persistence: None,
            ..Config::default()
        }
    }

    const FORMATS: [(LogFormat, &str); 5] = [
        (LogFormat::Mcap, "mcap"),
        (LogFormat::Bag, "bag"),
        (LogFormat::Db3, "db3"),
        (LogFormat::Ulog, "ulg"),
        (LogFormat::Dataflash, "bin"),
    ];

    /// One valid fixture per format (200 samples at 100 Hz), written once.
    fn fixtures() -> &'static Vec<Vec<u8>> {
        static F: OnceLock<Vec<Vec<u8>>> = OnceLock::new();
        F.get_or_init(|| {
            let dir = tempfile::tempdir().unwrap();
            let n = 200;
            let cols = simulated(n, 100.0);
            let us: Vec<u64> = (0..n as u64).map(|i| 1_000_000 + i * 10_000).collect();
            FORMATS
                .iter()
                .map(|(f, ext)| {
                    let path = dir.path().join(format!("f.{ext}"));
                    match f {
                        LogFormat::Mcap => write_mcap(&path, &[imu("/imu0", n, 100.0)]),
                        LogFormat::Bag => write_bag(&path, &[imu("/imu0", n, 100.0)]),
                        LogFormat::Db3 => write_db3(&path, &[imu("/imu0", n, 100.0)]),
                        LogFormat::Ulog => write_ulog(&path, &us, &cols),
                        LogFormat::Dataflash => write_dataflash(&path, &us, &cols),
                    }
                    std::fs::read(&path).unwrap()
                })
                .collect()
        })
    }

    /// 300 samples at 100 Hz: an MCAP file in uncompressed chunks of about 4 kB with message
    /// indexes, and a ROS 1 bag in chunks of 25 messages with its index.
    fn indexed_logs() -> &'static (Vec<u8>, Vec<u8>) {
        static F: OnceLock<(Vec<u8>, Vec<u8>)> = OnceLock::new();
        F.get_or_init(|| {
            let dir = tempfile::tempdir().unwrap();
            let (mc, bag) = (dir.path().join("i.mcap"), dir.path().join("i.bag"));
            let opts = mcap::WriteOptions::new()
                .compression(None)
                .chunk_size(Some(4000));
            write_mcap_with(&mc, &[imu("/imu0", 300, 100.0)], opts);
            let mut t = imu("/imu0", 300, 100.0);
            t.schema = "sensor_msgs/Imu";
            write_bag_chunked(&bag, &[t], 25, false);
            for (path, format) in [(&mc, LogFormat::Mcap), (&bag, LogFormat::Bag)] {
                let s = open(path, format).unwrap().read_imu("/imu0").unwrap();
                assert_eq!(s.stamps_ns.len(), 300);
            }
            (std::fs::read(&mc).unwrap(), std::fs::read(&bag).unwrap())
        })
    }

    /// Opens `bytes` as `format` and reads every topic; panics only on a broken property.
    fn read_all(format: LogFormat, ext: &str, bytes: &[u8]) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(format!("x.{ext}"));
        std::fs::write(&path, bytes).unwrap();
        let user = |e: imunoise::Error| assert_eq!(e.exit_code(), 2, "{format:?}: {e}");
        let r = match open(&path, format) {
            Ok(r) => r,
            Err(e) => return user(e),
        };
        let topics = match r.topics() {
            Ok(t) => t,
            Err(e) => return user(e),
        };
        for t in topics {
            match r.read_imu(&t.name) {
                Ok(s) => {
                    assert_eq!(s.stamps_ns.len(), s.columns[0].len());
                    assert!(s.columns.iter().all(|c| c.iter().all(|v| v.is_finite())));
                }
                Err(e) => user(e),
            }
        }
    }

    /// The seed corpora of the coverage-guided fuzz targets (fuzz/, `cargo xtask fuzz
    /// --coverage`), written into `$IMUNOISE_FUZZ_SEEDS/<target>/` from this file's fixtures:
    /// the fixture of each log format (and the chunked, indexed MCAP and bag, the DataFlash
    /// batch sampler log), small text, raw, gzip files and model strings. Every log seed is
    /// read back first (each IMU topic gives samples), so a seed is a valid file. Run by the xtask (ignored otherwise).
    #[test]
    #[ignore = "writes the fuzz seeds; run by cargo xtask fuzz --coverage"]
    fn write_fuzz_seeds() {
        use std::io::Write;
        let Ok(root) = std::env::var("IMUNOISE_FUZZ_SEEDS") else {
            eprintln!("IMUNOISE_FUZZ_SEEDS is not set: no seeds written");
            return;
        };
        let root = PathBuf::from(root);
        let put = |target: &str, name: &str, bytes: &[u8]| {
            let d = root.join(target);
            std::fs::create_dir_all(&d).unwrap();
            std::fs::write(d.join(name), bytes).unwrap();
        };
        let dir = tempfile::tempdir().unwrap();
        let isb = dir.path().join("isb.bin");
        write_isb(&isb, 3, 2, 400.0, &[]);
        // the bag of `fixtures()` holds CDR messages under a ROS 2 type name (a bad bag for the
        // properties); the seed is a valid ROS 1 bag of the same samples, and that one besides
        let ros1 = dir.path().join("ros1.bag");
        let mut t = imu("/imu0", 200, 100.0);
        t.schema = "sensor_msgs/Imu";
        write_bag(&ros1, &[t]);
        put("bag", "ros2-typed.bag", &fixtures()[1]);
        let mut logs: Vec<(LogFormat, &str, Vec<u8>)> = FORMATS
            .iter()
            .zip(fixtures())
            .map(|(&(f, ext), b)| (f, ext, b.clone()))
            .collect();
        logs[1].2 = std::fs::read(&ros1).unwrap();
        logs.push((LogFormat::Mcap, "mcap", indexed_logs().0.clone()));
        logs.push((LogFormat::Bag, "bag", indexed_logs().1.clone()));
        logs.push((LogFormat::Dataflash, "bin", std::fs::read(&isb).unwrap()));
        for (k, (format, ext, bytes)) in logs.iter().enumerate() {
            let path = dir.path().join(format!("check{k}.{ext}"));
            std::fs::write(&path, bytes).unwrap();
            let r = open(&path, *format).unwrap();
            let imu: Vec<_> = r
                .topics()
                .unwrap()
                .into_iter()
                .filter(|t| t.is_imu)
                .collect();
            assert!(!imu.is_empty(), "{format:?} seed {k} has no IMU topic");
            for t in imu {
                let n = r.read_imu(&t.name).unwrap().stamps_ns.len();
                assert!(n >= 2, "{format:?} seed {k}, {}: {n} samples", t.name);
            }
            let target = match format {
                LogFormat::Mcap => "mcap",
                LogFormat::Bag => "bag",
                LogFormat::Db3 => "db3",
                LogFormat::Ulog => "ulog",
                LogFormat::Dataflash => "dataflash",
            };
            put(target, &format!("seed{k}.{ext}"), bytes);
        }
        // text: the simulated IMU as CSV with a header, with a time column, as TSV and
        // whitespace-separated without a header
        let cols = simulated(40, 100.0);
        let csv = dir.path().join("s.csv");
        write_csv(&csv, &cols);
        let csv = std::fs::read(&csv).unwrap();
        put("text", "imu.csv", &csv);
        let mut timed = String::from("time,gx,gy\n");
        let mut ws = String::new();
        let rows = cols[0]
            .iter()
            .zip(&cols[1])
            .zip(&cols[3])
            .zip(&cols[4])
            .zip(&cols[5]);
        for (i, ((((g0, g1), a0), a1), a2)) in rows.enumerate() {
            let t = 1.7e9 + 0.01 * i as f64 + if i == 20 { 0.05 } else { 0.0 };
            timed += &format!("{t:.3},{g0},{g1:e}\n");
            ws += &format!("{a0} {a1}\t{a2}\n");
        }
        put("text", "time.csv", timed.as_bytes());
        put("text", "ws.txt", ws.as_bytes());
        put(
            "text",
            "tsv.tsv",
            b"# comment\ngx\tgy\n1\t2\n3\t-4.5e-3\nnan\t1\n",
        );
        // raw: the first byte picks the type and channels (fuzz/fuzz_targets/binary.rs)
        let f64s: Vec<u8> = cols[0].iter().flat_map(|v| v.to_le_bytes()).collect();
        let i16s: Vec<u8> = (0..120i16)
            .flat_map(|v| (v * 97 - 4000).to_le_bytes())
            .collect();
        put("binary", "f64x1", &[&[0u8][..], &f64s].concat());
        put("binary", "f64x2", &[&[4u8][..], &f64s].concat());
        put("binary", "i16x3", &[&[2u8 | (2 << 2)][..], &i16s].concat());
        put("binary", "f32x1", &[&[1u8][..], &i16s].concat());
        // gzip: the CSV and the f64 samples compressed, and two members in one file
        let gz = |bytes: &[u8]| {
            let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
            e.write_all(bytes).unwrap();
            e.finish().unwrap()
        };
        put("gzip", "imu.csv.gz", &gz(&csv));
        put("gzip", "f64.gz", &gz(&f64s));
        put(
            "gzip",
            "two.gz",
            &[gz(b"gx\n1\n2\n"), gz(b"3\n4\n")].concat(),
        );
        for (k, m) in [
            "WN",
            "WN + RW + AR1",
            "WN(sigma2=1e-6)+RW(gamma2=1e-12)",
            "QN(q2=2e-7) + WN + 2*AR1 + DR(omega=1e-9)",
            "AR1(phi=0.999962, sigma2=2e-8) + BI + RW",
            "AR2 + AR3(phi1=0.5, phi2=-0.2, phi3=0.1, sigma2=1e-4)",
            "WN + BI(B=1e-4, 0.01..100)",
        ]
        .iter()
        .enumerate()
        {
            put("model", &format!("m{k}"), m.as_bytes());
        }
    }

    proptest! {
        #![proptest_config(config())]

        #[test]
        fn fuzz_log_readers_corrupted_fixtures(
            which in 0usize..5,
            flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..6),
            cut in any::<prop::sample::Index>(),
        ) {
            let (format, ext) = FORMATS[which];
            let mut b = fixtures()[which].clone();
            for (i, x) in &flips {
                let at = i.index(b.len());
                b[at] ^= x | 1;
            }
            let keep = b.len() / 2 + cut.index(b.len() / 2 + 1);
            b.truncate(keep);
            read_all(format, ext, &b);
        }

        /// An MCAP file of uncompressed 4 kB chunks with its summary intact, and a ROS 1 bag of
        /// 25-message chunks with its index (flips only, no cut), so that the chunks are read
        /// one by one, in parallel, through the indexes (for the MCAP file with no walk over a
        /// chunk's records first).
        #[test]
        fn fuzz_indexed_chunks_flipped(
            bag in any::<bool>(),
            flips in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        ) {
            let (format, ext, fixture) = if bag {
                (LogFormat::Bag, "bag", &indexed_logs().1)
            } else {
                (LogFormat::Mcap, "mcap", &indexed_logs().0)
            };
            let mut b = fixture.clone();
            for (i, x) in &flips {
                let at = i.index(b.len());
                b[at] ^= x | 1;
            }
            read_all(format, ext, &b);
        }

        #[test]
        fn fuzz_log_readers_arbitrary_bytes_after_the_magic(
            which in 0usize..5,
            tail in prop::collection::vec(any::<u8>(), 0..400),
        ) {
            let (format, ext) = FORMATS[which];
            let magic: &[u8] = match format {
                LogFormat::Mcap => b"\x89MCAP0\r\n",
                LogFormat::Bag => b"#ROSBAG V2.0\n",
                LogFormat::Db3 => b"SQLite format 3\0",
                LogFormat::Ulog => b"ULog\x01\x12\x35\x01",
                LogFormat::Dataflash => b"\xa3\x95\x80",
            };
            let mut b = magic.to_vec();
            b.extend_from_slice(&tail);
            read_all(format, ext, &b);
        }
    }
}

/// A fixture, its last message spans (start, end, stamp in ns, whether of `topic`), the number of `topic` messages before them, and whether a cut at a message boundary still
/// leaves an unfinished record (a chunk: MCAP, bags).
#[cfg(all(feature = "rosbag", feature = "ulog", feature = "dataflash"))]
struct CutFixture {
    format: imunoise::logs::LogFormat,
    ext: &'static str,
    topic: &'static str,
    bytes: Vec<u8>,
    /// The last four messages of the file: start, end, stamp (ns), whether of `topic`.
    spans: Vec<(usize, usize, i64, bool)>,
    /// Messages of `topic` before the first span.
    before: usize,
    in_chunk: bool,
}

#[cfg(all(feature = "rosbag", feature = "ulog", feature = "dataflash"))]
fn find(hay: &[u8], needle: &[u8]) -> usize {
    hay.windows(needle.len())
        .position(|w| w == needle)
        .expect("the record is in the file")
}

/// One fixture per reader, written by this file's writers; the spans of the last four
/// messages are found from the bytes each writer writes for them (not from the readers).
#[cfg(all(feature = "rosbag", feature = "ulog", feature = "dataflash"))]
fn cut_fixtures() -> Vec<CutFixture> {
    use imunoise::logs::LogFormat;
    use imunoise::logs::imu_msg::encode_ros1;
    let dir = tempfile::tempdir().unwrap();
    let mut out = Vec::new();
    // ULog: 250 sensor_combined (53-byte messages), vehicle_status at 0, 100, 200
    let n = 250;
    let cols = as_f32(&simulated(n, 250.0));
    let us: Vec<u64> = (0..n as u64).map(|i| 1_000_000 + 4000 * i).collect();
    let path = p(&dir, "c.ulg");
    write_ulog(&path, &us, &cols);
    let bytes = std::fs::read(&path).unwrap();
    let len = bytes.len();
    let spans = (0..4)
        .map(|k| {
            let end = len - 53 * (3 - k);
            (end - 53, end, us[n - 4 + k] as i64 * 1000, true)
        })
        .collect();
    out.push(CutFixture {
        format: LogFormat::Ulog,
        ext: "ulg",
        topic: "sensor_combined",
        bytes,
        spans,
        before: n - 4,
        in_chunk: false,
    });
    // DataFlash: per step IMU[0] and IMU[1] (36 bytes each), BARO every 40 steps (16 bytes)
    let n = 250;
    let cols = as_f32(&simulated(n, 400.0));
    let us: Vec<u64> = (0..n as u64).map(|i| 1_000_000 + 2500 * i).collect();
    let path = p(&dir, "c.bin");
    write_dataflash(&path, &us, &cols);
    let bytes = std::fs::read(&path).unwrap();
    let len = bytes.len();
    // the last four messages: IMU[0], IMU[1] of steps n-2 and n-1 (read topic IMU[1])
    let spans = (0..4)
        .map(|k| {
            let end = len - 36 * (3 - k);
            (end - 36, end, us[n - 2 + k / 2] as i64 * 1000, k % 2 == 1)
        })
        .collect();
    out.push(CutFixture {
        format: LogFormat::Dataflash,
        ext: "bin",
        topic: "IMU[1]",
        bytes,
        spans,
        before: n - 2,
        in_chunk: false,
    });
    // ROS 1 bag: 60 messages on /imu0 in one uncompressed chunk, indexed
    let mut t = imu("/imu0", 60, 100.0);
    t.schema = "sensor_msgs/Imu";
    let path = p(&dir, "c.bag");
    write_bag(&path, std::slice::from_ref(&t));
    let bytes = std::fs::read(&path).unwrap();
    let spans = (56..60)
        .map(|i| {
            let rec = bag_record(
                &[
                    bag_field("op", &[2]),
                    bag_field("conn", &0u32.to_le_bytes()),
                    bag_field("time", &bag_time(t.stamps[i])),
                ],
                &encode_ros1(&sample(&t.stamps, &t.cols, i), i as u32, "imu_link"),
            );
            let at = find(&bytes, &rec);
            (at, at + rec.len(), t.stamps[i], true)
        })
        .collect();
    out.push(CutFixture {
        format: LogFormat::Bag,
        ext: "bag",
        topic: "/imu0",
        bytes,
        spans,
        before: 56,
        in_chunk: true,
    });
    // MCAP: 60 messages on /imu0 in uncompressed chunks of about 4 kB
    let t = imu("/imu0", 60, 100.0);
    let path = p(&dir, "c.mcap");
    let opts = mcap::WriteOptions::new()
        .compression(None)
        .chunk_size(Some(4000));
    write_mcap_with(&path, std::slice::from_ref(&t), opts);
    let bytes = std::fs::read(&path).unwrap();
    let spans = (56..60)
        .map(|i| {
            // a message record: opcode, u64 length, channel, sequence, log and publish time
            let data = encode_cdr(&sample(&t.stamps, &t.cols, i), "imu_link");
            let tail = [
                &(t.stamps[i] as u64).to_le_bytes()[..],
                &(t.stamps[i] as u64).to_le_bytes(),
                &data,
            ]
            .concat();
            let at = find(&bytes, &tail) - 15;
            assert_eq!(bytes[at], 0x05);
            (at, at + 15 + tail.len(), t.stamps[i], true)
        })
        .collect();
    out.push(CutFixture {
        format: LogFormat::Mcap,
        ext: "mcap",
        topic: "/imu0",
        bytes,
        spans,
        before: 56,
        in_chunk: true,
    });
    out
}

/// Cut-off property: each reader, on its fixture cut at every byte of its last three
/// messages (and at their ends), reads exactly the complete prefix of the full read (stamps
/// and values), reports where the file is cut (offset, bytes dropped, stamp of the last
/// complete message), and refuses the file under strict. A cut at the end of a message is no
/// cut for ULog and DataFlash (nothing tells it from a complete file); inside an unfinished
/// chunk (MCAP, bags) it is reported with no bytes dropped.
#[cfg(all(feature = "rosbag", feature = "ulog", feature = "dataflash"))]
#[test]
fn cut_off_fixtures_give_the_complete_prefix_and_the_warning() {
    use imunoise::logs::{Truncation, open, open_checked};
    let dir = tempfile::tempdir().unwrap();
    let quiet = imunoise::Ui::quiet();
    for fx in cut_fixtures() {
        let full_path = dir.path().join(format!("full.{}", fx.ext));
        std::fs::write(&full_path, &fx.bytes).unwrap();
        let full = open(&full_path, fx.format).unwrap();
        assert_eq!(full.truncation(), None, "{:?}", fx.format);
        let all = full.read_imu(fx.topic).unwrap();
        let n_all = fx.before + fx.spans.iter().filter(|sp| sp.3).count();
        assert_eq!(all.stamps_ns.len(), n_all, "{:?}", fx.format);
        let path = dir.path().join(format!("cut.{}", fx.ext));
        // every byte of the last three messages, and their ends
        let cuts: std::collections::BTreeSet<usize> =
            fx.spans[1..].iter().flat_map(|sp| sp.0..=sp.1).collect();
        for cut in cuts {
            std::fs::write(&path, &fx.bytes[..cut]).unwrap();
            let r = open(&path, fx.format).unwrap();
            let s = r.read_imu(fx.topic).unwrap();
            // complete messages of the topic: those before the spans, and whole spans
            let whole = fx.spans.iter().filter(|sp| sp.3 && sp.1 <= cut).count();
            let k = fx.before + whole;
            let what = format!("{:?} cut at {cut}", fx.format);
            assert_eq!(s.stamps_ns, all.stamps_ns[..k], "{what}");
            for (c, a) in s.columns.iter().zip(&all.columns) {
                assert_eq!(c[..], a[..k], "{what}");
            }
            let inside = fx.spans.iter().find(|sp| sp.0 < cut && cut < sp.1);
            let last_stamp = fx.spans.iter().rev().find(|sp| sp.1 <= cut).map(|sp| sp.2);
            let want = match inside {
                Some(sp) => Some(Truncation {
                    offset: sp.0 as u64,
                    dropped_bytes: (cut - sp.0) as u64,
                    last_stamp_ns: last_stamp,
                }),
                None if fx.in_chunk && cut < fx.bytes.len() => Some(Truncation {
                    offset: cut as u64,
                    dropped_bytes: 0,
                    last_stamp_ns: last_stamp,
                }),
                None => None,
            };
            assert_eq!(r.truncation(), want, "{what}");
            let strict = open_checked(&path, fx.format, true, &quiet);
            match want {
                Some(t) => {
                    let e = strict.err().expect("strict refuses a cut-off file");
                    assert_eq!(e.exit_code(), 2);
                    assert!(e.to_string().contains(&t.to_string()), "{what}: {e}");
                }
                None => assert!(strict.is_ok(), "{what}"),
            }
        }
    }
}

/// A ULog written from message definitions: the header, the flag bits (with `appended` as
/// the appended-data offset, patched in by [`UlogWriter::append_here`]), then messages.
struct UlogWriter {
    out: Vec<u8>,
}

impl UlogWriter {
    fn new() -> Self {
        let mut out = b"ULog\x01\x12\x35\x01".to_vec();
        out.extend_from_slice(&0u64.to_le_bytes());
        out.extend(ulog_msg(b'B', &[0u8; 40]));
        UlogWriter { out }
    }
    fn msg(&mut self, ty: u8, body: &[u8]) {
        self.out.extend(ulog_msg(ty, body));
    }
    fn add(&mut self, multi: u8, id: u16, name: &str) {
        let mut b = vec![multi];
        b.extend_from_slice(&id.to_le_bytes());
        b.extend_from_slice(name.as_bytes());
        self.msg(b'A', &b);
    }
    fn data(&mut self, id: u16, payload: &[u8]) {
        self.msg(b'D', &[&id.to_le_bytes()[..], payload].concat());
    }
    /// Marks the data from here on as appended (flag bits: DATA_APPENDED, first offset).
    fn append_here(&mut self) {
        let at = self.out.len() as u64;
        // the flag bits' body starts at 16 + 3: compat[8], incompat[8], offsets[3]
        self.out[19 + 8] = 1;
        self.out[19 + 16..19 + 24].copy_from_slice(&at.to_le_bytes());
    }
}

/// ULog per the specification, in a fixture written from the definitions: a nested type
/// before the fields read (offsets after it), three instances of `sensor_gyro` (`--instance`),
/// messages with and without their trailing `_padding` bytes, appended data, and
/// `sensor_gyro_fifo` (PX4 `msg/SensorGyroFifo.msg`): each sample a row, the last at
/// `timestamp_sample` and the others `dt` µs before it, values × `scale`.
#[cfg(feature = "ulog")]
#[test]
fn ulog_nested_instances_padding_appended_and_fifo() {
    use imunoise::logs::{LogFormat, open};
    let dir = tempfile::tempdir().unwrap();
    let mut w = UlogWriter::new();
    w.msg(b'F', b"esc_report:uint32_t rpm;float[2] v;");
    w.msg(b'F', b"sensor_gyro:uint64_t timestamp;esc_report[2] esc;uint64_t timestamp_sample;uint32_t device_id;float x;float y;float z;float temperature;uint8_t[4] _padding0;");
    w.msg(b'F', b"sensor_gyro_fifo:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;bool is_external;float dt;float scale;uint8_t samples;int16_t[32] x;int16_t[32] y;int16_t[32] z;uint8_t[2] _padding0;");
    for k in 0..3u8 {
        w.add(k, k as u16, "sensor_gyro");
    }
    w.add(0, 7, "sensor_gyro_fifo");
    // sensor_gyro instance k, message i: x = k + i/8, stamp 1 s + 4 ms i (+ 100 µs k)
    let gyro = |w: &mut UlogWriter, k: u16, i: u64| {
        let mut d = (1_000_000 + 4000 * i + 100 * k as u64 + 7)
            .to_le_bytes()
            .to_vec();
        d.extend((0..2).flat_map(|e| {
            [
                (e as u32).to_le_bytes(),
                1.5f32.to_le_bytes(),
                2.5f32.to_le_bytes(),
            ]
            .concat()
        }));
        d.extend_from_slice(&(1_000_000 + 4000 * i + 100 * k as u64).to_le_bytes());
        d.extend_from_slice(&42u32.to_le_bytes());
        for v in [k as f32 + i as f32 / 8.0, -0.25, 0.125, 40.0] {
            d.extend_from_slice(&v.to_le_bytes());
        }
        if i % 2 == 1 {
            d.extend_from_slice(&[0; 4]); // the padding, written for odd messages only
        }
        w.data(k, &d);
    };
    for i in 0..100 {
        for k in 0..3 {
            gyro(&mut w, k, i);
        }
    }
    // FIFO: 10 messages of 32 samples at 2 kHz (dt 500 µs), the 5th with 20 valid samples
    let fifo_n = |m: u64| if m == 4 { 20 } else { 32 };
    let count = |m: u64, i: u64, a: u64| ((m * 37 + i * 5 + a * 11) % 2000) as i16 - 1000;
    let scale = 1.0f32 / 4096.0;
    for m in 0..10u64 {
        let mut d = (2_000_000 + 16_000 * m).to_le_bytes().to_vec();
        d.extend_from_slice(&(2_000_000 + 16_000 * m - 10).to_le_bytes()); // timestamp_sample
        d.extend_from_slice(&7u32.to_le_bytes());
        d.push(0);
        d.extend_from_slice(&500f32.to_le_bytes());
        d.extend_from_slice(&scale.to_le_bytes());
        d.push(fifo_n(m) as u8);
        for a in 0..3 {
            for i in 0..32 {
                d.extend_from_slice(&count(m, i, a).to_le_bytes());
            }
        }
        w.data(7, &d); // without the padding
    }
    // appended data: 20 more messages of instance 1
    w.append_here();
    for i in 100..120 {
        gyro(&mut w, 1, i);
    }
    let path = p(&dir, "spec.ulg");
    std::fs::write(&path, &w.out).unwrap();

    let r = open(&path, LogFormat::Ulog).unwrap();
    let counts: Vec<(String, u64, bool)> = r
        .topics()
        .unwrap()
        .into_iter()
        .map(|t| (t.name, t.count, t.is_imu))
        .collect();
    let want = [
        ("sensor_gyro", 100),
        ("sensor_gyro[1]", 120),
        ("sensor_gyro[2]", 100),
        ("sensor_gyro_fifo", 10),
    ];
    assert_eq!(counts, want.map(|(n, c)| (n.to_string(), c, true)).to_vec());
    for (k, topic) in ["sensor_gyro", "sensor_gyro[1]", "sensor_gyro[2]"]
        .iter()
        .enumerate()
    {
        let s = r.read_imu(topic).unwrap();
        let n = if k == 1 { 120 } else { 100 };
        let st: Vec<i64> = (0..n)
            .map(|i| (1_000_000 + 4000 * i + 100 * k as i64) * 1000)
            .collect();
        assert_eq!(s.stamps_ns, st, "{topic}: timestamp_sample, not timestamp");
        assert_eq!(s.names, ["gyro_x_rads", "gyro_y_rads", "gyro_z_rads"]);
        let x: Vec<f64> = (0..n).map(|i| (k as f32 + i as f32 / 8.0) as f64).collect();
        assert_eq!(s.columns[0], x, "{topic}");
        assert!(s.columns[1].iter().all(|&v| v == -0.25));
        assert!(s.columns[2].iter().all(|&v| v == 0.125));
    }
    let f = r.read_imu("sensor_gyro_fifo").unwrap();
    let (mut st, mut xs) = (Vec::new(), vec![Vec::new(); 3]);
    for m in 0..10u64 {
        let n = fifo_n(m);
        let last_ns = (2_000_000 + 16_000 * m as i64 - 10) * 1000;
        for i in 0..n {
            st.push(last_ns - (n - 1 - i) as i64 * 500_000);
            for (a, x) in xs.iter_mut().enumerate() {
                x.push(count(m, i, a as u64) as f64 * scale as f64);
            }
        }
    }
    assert_eq!(f.stamps_ns.len(), 9 * 32 + 20);
    assert_eq!(f.stamps_ns, st);
    assert_eq!(f.columns, xs);
    // the same through the command: --topic and --instance
    let a = ok(&[
        "avar",
        s(&path),
        "--topic",
        "sensor_gyro",
        "--instance",
        "2",
        "--format",
        "json",
        "-q",
    ]);
    let b = ok(&[
        "avar",
        s(&path),
        "--topic",
        "sensor_gyro[2]",
        "--format",
        "json",
        "-q",
    ]);
    assert_eq!(a, b);
    let err = fails(&[
        "avar",
        s(&path),
        "--topic",
        "sensor_gyro",
        "--instance",
        "3",
    ]);
    assert!(
        err.contains("its instances of sensor_gyro: sensor_gyro, sensor_gyro[1], sensor_gyro[2]"),
        "{err}"
    );
}

/// A DataFlash log with the batch sampler (ArduPilot `libraries/AP_InertialSensor/
/// LogStructure.h`: `ISBH` "QHBBHHQf" TimeUS,N,type,instance,mul,smp_cnt,SampleUS,smp_rate;
/// `ISBD` "QHHaaa" TimeUS,N,seqno,x,y,z) and a low-rate IMU: batches of `per` ISBD messages
/// (32 samples each) at `rate`, gyro (type 1) and accelerometer (type 0) of instance 0 in turn,
/// `skip` = (batch, seqno) of ISBD messages not written. Sample j of batch b, axis a: count
/// `isb_count(b, j, a)`.
fn write_isb(path: &Path, batches: u16, per: u16, rate: f32, skip: &[(u16, u16)]) {
    let mut out = df_fmt(0x80, 89, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns");
    out.extend(df_fmt(
        0x40,
        36,
        "IMU",
        "QBffffff",
        "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ",
    ));
    out.extend(df_fmt(
        0x50,
        31,
        "ISBH",
        "QHBBHHQf",
        "TimeUS,N,type,instance,mul,smp_cnt,SampleUS,smp_rate",
    ));
    out.extend(df_fmt(0x51, 207, "ISBD", "QHHaaa", "TimeUS,N,seqno,x,y,z"));
    for b in 0..batches {
        let t0 = isb_start_us(b, per, rate);
        let ty = if b % 2 == 0 { 1u8 } else { 0 };
        out.extend_from_slice(&[0xA3, 0x95, 0x50]);
        out.extend_from_slice(&(t0 + 500).to_le_bytes());
        out.extend_from_slice(&b.to_le_bytes());
        out.extend_from_slice(&[ty, 0]);
        out.extend_from_slice(&isb_mul(ty).to_le_bytes());
        out.extend_from_slice(&(32 * per).to_le_bytes());
        out.extend_from_slice(&t0.to_le_bytes());
        out.extend_from_slice(&rate.to_le_bytes());
        for k in 0..per {
            // a low-rate IMU message now and then
            out.extend_from_slice(&[0xA3, 0x95, 0x40]);
            out.extend_from_slice(&(t0 + 1000 * k as u64).to_le_bytes());
            out.push(0);
            out.extend([0u8; 24]);
            if skip.contains(&(b, k)) {
                continue;
            }
            out.extend_from_slice(&[0xA3, 0x95, 0x51]);
            out.extend_from_slice(&(t0 + 1000 * k as u64 + 700).to_le_bytes());
            out.extend_from_slice(&b.to_le_bytes());
            out.extend_from_slice(&k.to_le_bytes());
            for a in 0..3 {
                for i in 0..32 {
                    out.extend_from_slice(&isb_count(b, 32 * k + i, a).to_le_bytes());
                }
            }
        }
    }
    std::fs::write(path, out).unwrap();
}

fn isb_start_us(b: u16, per: u16, rate: f32) -> u64 {
    // batches 10 s apart, well after the previous one ends
    let _ = (per, rate);
    5_000_000 + 10_000_000 * b as u64
}

fn isb_mul(ty: u8) -> u16 {
    if ty == 1 { 1000 } else { 200 }
}

fn isb_count(b: u16, j: u16, a: u16) -> i16 {
    ((b as i32 * 101 + j as i32 * 7 + a as i32 * 13) % 3000 - 1500) as i16
}

/// ArduPilot's batch sampler in a fixture written from its message definitions: each ISBD
/// sample a row, stamped `SampleUS + (32 seqno + i) / smp_rate`, valued `x[i] / mul`, a
/// missing ISBD message a gap of 32 samples; `topics` lists `ISB_gyro[0]` and `ISB_acc[0]` at
/// the sample rate; `analyze` without `--topic` reads them (a note says so) rather than IMU.
#[cfg(feature = "dataflash")]
#[test]
fn dataflash_batch_sampler_samples_stamps_and_preference() {
    use imunoise::logs::{LogFormat, open};
    let dir = tempfile::tempdir().unwrap();
    let path = p(&dir, "isb.bin");
    let (per, rate) = (40u16, 2000f32);
    write_isb(&path, 3, per, rate, &[(2, 5)]);
    let r = open(&path, LogFormat::Dataflash).unwrap();
    let topics: Vec<(String, String, u64, bool)> = r
        .topics()
        .unwrap()
        .into_iter()
        .map(|t| (t.name, t.msg_type, t.count, t.is_imu))
        .collect();
    let t = |n: &str, ty: &str, c, imu| (n.to_string(), ty.to_string(), c, imu);
    assert_eq!(
        topics,
        [
            t("IMU[0]", "IMU", 3 * per as u64, true),
            t("ISBH", "ISBH", 3, false),
            t("ISB_acc[0]", "ISBD", per as u64, true),
            t("ISB_gyro[0]", "ISBD", 2 * per as u64 - 1, true),
        ]
    );
    for (topic, batches, ty) in [
        ("ISB_gyro[0]", &[0u16, 2][..], 1u8),
        ("ISB_acc[0]", &[1], 0),
    ] {
        let s = r.read_imu(topic).unwrap();
        let (mut st, mut cols) = (Vec::new(), vec![Vec::new(); 3]);
        for &b in batches {
            for j in 0..32 * per {
                if b == 2 && j / 32 == 5 {
                    continue; // the ISBD not written
                }
                let dt = (j as f64 * 1e9 / rate as f64).round() as i64;
                st.push(isb_start_us(b, per, rate) as i64 * 1000 + dt);
                for (a, c) in cols.iter_mut().enumerate() {
                    c.push(isb_count(b, j, a as u16) as f64 / isb_mul(ty) as f64);
                }
            }
        }
        assert_eq!(s.stamps_ns, st, "{topic}");
        assert_eq!(s.columns, cols, "{topic}");
    }
    let v: serde_json::Value =
        serde_json::from_str(&ok(&["topics", s(&path), "--format", "json"])).unwrap();
    assert_eq!(v[3]["name"], "ISB_gyro[0]");
    assert_eq!(v[3]["rate_hz"], 2000.0);
    // analyze prefers the batch topics; the gyro's missing message is a gap
    let out = imunoise(&[
        "analyze",
        s(&path),
        "--gaps",
        "longest",
        "--model",
        "WN",
        "--no-select",
        "--out",
        s(&p(&dir, "rep")),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("reading the high-rate IMU topics ISB_gyro[0], ISB_acc[0]"),
        "{err}"
    );
    assert!(
        err.contains("ISB_gyro[0]: 2528 messages") && err.contains("gaps"),
        "{err}"
    );
}

/// A simulated WN + RW gyro at 2 kHz written through PX4's `sensor_gyro_fifo` (int16 counts
/// × `scale`, 32 samples a message): `analyze` of the log equals `analyze` of the same
/// quantized samples as CSV, and the fitted parameters are within 4 standard errors of the
/// simulated values (fixed seed; the quantization noise, scale²/12 = 2.3e-11 (rad/s)², is 4·10⁻⁵ of the
/// white noise's variance).
#[cfg(feature = "ulog")]
#[test]
fn fifo_gyro_at_2khz_recovers_wn_and_rw() {
    let dir = tempfile::tempdir().unwrap();
    let (n, rate) = (1usize << 19, 2000.0);
    let model: imunoise::processes::Model = "WN(sigma2=1e-6)+RW(gamma2=1e-12)".parse().unwrap();
    let sim = imunoise::cli::simulate::simulate_channels(&model, n, rate, 21, 3).unwrap();
    let scale = 1.0f32 / 65536.0;
    let counts: Vec<Vec<i16>> = sim
        .iter()
        .map(|c| {
            c.iter()
                .map(|&v| (v / scale as f64).round() as i16)
                .collect()
        })
        .collect();
    let mut w = UlogWriter::new();
    w.msg(b'F', b"sensor_gyro_fifo:uint64_t timestamp;uint64_t timestamp_sample;uint32_t device_id;bool is_external;float dt;float scale;uint8_t samples;int16_t[32] x;int16_t[32] y;int16_t[32] z;uint8_t[2] _padding0;");
    w.add(0, 0, "sensor_gyro_fifo");
    for m in 0..n / 32 {
        let last_us = 1_000_000 + 500 * (32 * m as u64 + 31);
        let mut d = (last_us + 50).to_le_bytes().to_vec();
        d.extend_from_slice(&last_us.to_le_bytes());
        d.extend_from_slice(&1u32.to_le_bytes());
        d.push(0);
        d.extend_from_slice(&500f32.to_le_bytes());
        d.extend_from_slice(&scale.to_le_bytes());
        d.push(32);
        for c in &counts {
            for v in &c[32 * m..32 * m + 32] {
                d.extend_from_slice(&v.to_le_bytes());
            }
        }
        d.extend_from_slice(&[0, 0]);
        w.data(0, &d);
    }
    let path = p(&dir, "fifo.ulg");
    std::fs::write(&path, &w.out).unwrap();
    let csv = p(&dir, "fifo.csv");
    let names: Vec<String> = ["gyro_x_rads", "gyro_y_rads", "gyro_z_rads"]
        .map(String::from)
        .to_vec();
    let cols: Vec<Vec<f64>> = counts
        .iter()
        .map(|c| c.iter().map(|&v| v as f64 * scale as f64).collect())
        .collect();
    let mut f = std::io::BufWriter::new(std::fs::File::create(&csv).unwrap());
    imunoise::cli::simulate::write_csv(&mut f, &names, &cols).unwrap();
    drop(f);
    let res = analyze_equals_csv(&dir, &[s(&path)], &csv, "2000");
    assert_eq!(res["rate_hz"], 2000.0);
    for ch in res["channels"].as_array().unwrap() {
        for prm in ch["fit"]["parameters"].as_array().unwrap() {
            let truth = if prm["process"] == "WN" { 1e-6 } else { 1e-12 };
            let (lo, hi) = (
                prm["ci_lo"].as_f64().unwrap(),
                prm["ci_hi"].as_f64().unwrap(),
            );
            // within 4 standard errors of the simulated value (the standard error from the
            // fit's 95 % interval, half-width / 1.96): a chance of 6e-5 per parameter to fail
            let se = (hi - lo) / 2.0 / 1.96;
            let v = prm["value"].as_f64().unwrap();
            assert!((v - truth).abs() <= 4.0 * se, "{}: {prm}", ch["name"]);
        }
    }
}
