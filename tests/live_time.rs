//! `imunoise live --time-column`: time stamps read as rows arrive with the rules of
//! `imunoise avar --time-column` (rate from the stamps, reorder window, duplicates, gaps).
//! The batch command is the second implementation: the final snapshot through a pipe must
//! equal `imunoise avar FILE --time-column t --gaps POLICY --format json` on the same file.

use std::process::Output;

mod live_common;
use live_common::{TOL, TOL_CI, assert_points_equal, bin, results_json, run_ok, run_piped};

/// The reorder window of `imunoise live` (rows).
const WINDOW: usize = imunoise::logs::timing::REORDER_WINDOW;

/// Data rows of a 100 Hz record, each `(stamp index, gx, gy)`: white noise plus a random
/// walk and an offset from a fixed xorshift sequence (stamp = 1000 s + index / 100).
fn rows(n: usize) -> Vec<(usize, f64, f64)> {
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut u = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut rw = 0.0;
    (0..n)
        .map(|i| {
            rw += 1e-3 * u();
            (i, u() + rw + 5.0, 0.1 * u() - 2.0)
        })
        .collect()
}

/// The CSV (header t,gx,gy; stamps in s with 2 decimals: exact multiples of 10 ms in ns).
fn csv(rows: &[(usize, f64, f64)]) -> String {
    let mut text = String::from("t,gx,gy\n");
    for (i, a, b) in rows {
        text += &format!("{:.2},{a},{b}\n", 1000.0 + *i as f64 / 100.0);
    }
    text
}

/// Faults: 3 duplicates (a second row with the stamp of the row before it and other values,
/// which both commands drop), 2 adjacent swaps and a row moved 40 rows later (3 reordered
/// rows: each is a row with an earlier stamp than the row read before it), and a gap of `missing` samples before stamp index `gap_at`.
fn faulty(n: usize, gap_at: usize, missing: usize) -> Vec<(usize, f64, f64)> {
    let mut r = rows(n + missing);
    r.drain(gap_at..gap_at + missing);
    r.swap(1000, 1001);
    r.swap(7000, 7001);
    let late = r.remove(3000);
    r.insert(3040, late);
    for at in [500, 12_000, 25_000] {
        let (i, a, b) = r[at - 1];
        r.insert(at, (i, a + 100.0, b - 100.0));
    }
    r
}

/// `imunoise live - ARGS --every 1e9 --json` (without --json when ARGS has --lines) with `text` written to its standard input in
/// pieces cut inside lines.
fn live(text: &str, args: &[&str]) -> Output {
    run_piped(
        bin()
            .args(["live", "-", "--every", "1e9"])
            .args(if args.contains(&"--lines") {
                &[][..]
            } else {
                &["--json"][..]
            })
            .args(args),
        text.as_bytes(),
        5_003,
    )
}

/// The final snapshot (last line of `out`'s stdout).
fn final_snapshot(out: &Output) -> serde_json::Value {
    let stdout = String::from_utf8_lossy(&out.stdout);
    let last = stdout.lines().last().expect("a final snapshot");
    let v: serde_json::Value = serde_json::from_str(last).unwrap();
    assert_eq!(v["final"], true);
    v
}

/// `snap`'s channels against `imunoise avar FILE --time-column t ARGS --format json`, to
/// TOL at every tau.
fn assert_equals_avar(snap: &serde_json::Value, file: &std::path::Path, args: &[&str]) {
    let out = run_ok(
        bin()
            .args(["avar", file.to_str().unwrap(), "--time-column", "t"])
            .args(args)
            .args(["--format", "json"]),
    );
    let batch: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for ch in 0..2 {
        let (a, b) = (&snap["channels"][ch], &batch["channels"][ch]);
        assert_eq!(a["name"], b["name"]);
        assert_eq!(a["rate_hz"], b["rate_hz"]);
        assert!(a["points"].as_array().unwrap().len() >= 8);
        let keys = [("avar", TOL), ("avar_lo", TOL_CI), ("avar_hi", TOL_CI)];
        assert_points_equal(a, b, &format!("channel {ch}"), &keys);
    }
}

/// For each policy the final snapshot equals the batch on a record with duplicates, rows out
/// of order within the window and a gap; the timing counts are the injected ones.
/// Refuse: a gap of 5 samples at 40000 is 0.01 % of the record and under 0.1 % of the
/// samples before it (5 ≤ 40), so both go on across it. Longest and ignore: a gap of 300
/// samples at 30000; the longest segment is the first 30000 stamps (30003 rows).
#[test]
fn each_policy_the_final_snapshot_equals_avar() {
    let dir = tempfile::tempdir().unwrap();
    for (policy, gap_at, missing) in [
        ("refuse", 40_000, 5),
        ("longest", 30_000, 300),
        ("ignore", 30_000, 300),
    ] {
        let path = dir.path().join(format!("{policy}.csv"));
        let text = csv(&faulty(50_000, gap_at, missing));
        std::fs::write(&path, &text).unwrap();
        let out = live(&text, &["--time-column", "t", "--gaps", policy]);
        assert!(
            out.status.success(),
            "{policy}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let snap = final_snapshot(&out);
        assert_equals_avar(&snap, &path, &["--gaps", policy]);
        let t = &snap["timing"];
        assert_eq!(t["messages"], 50_003, "{policy}");
        assert_eq!((&t["duplicates"], &t["reordered"]), (&3.into(), &3.into()));
        assert_eq!(
            (&t["gaps"], &t["missing_samples"]),
            (&1.into(), &missing.into())
        );
        assert!((t["rate_hz"].as_f64().unwrap() - 100.0).abs() < 1e-9);
        assert_eq!(t["rate_source"], "stamps");
        assert_eq!(t["gap_policy"], policy);
        let n = if policy == "longest" { 30_000 } else { 50_000 };
        assert_eq!((&snap["n"], &t["samples_used"]), (&n.into(), &n.into()));
        if policy == "longest" {
            assert_eq!(t["segment"], serde_json::json!([0, 30_000]));
        } else {
            assert!(t["segment"].is_null());
        }
    }
}

/// Refuse with a gap over 0.1 % of the samples before it (300 missing before the 30001st
/// sample): exit code 2 and a message naming the line after the gap, the counts and the way
/// on; the final snapshot holds the rows before the gap (the batch on the file cut there),
/// and the --out report is written with the counts.
#[test]
fn refuse_stops_at_a_gap_over_the_share_so_far() {
    let dir = tempfile::tempdir().unwrap();
    let r = faulty(50_000, 30_000, 300);
    let text = csv(&r);
    let report = dir.path().join("report");
    let out = live(
        &text,
        &["--time-column", "t", "--out", report.to_str().unwrap()],
    );
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    // the first row after the gap: stamp index 30300 is data row 30003 (3 duplicates before
    // it), line 30005 of the stream after the header
    let row = r.iter().position(|x| x.0 == 30_300).unwrap();
    assert_eq!(row, 30_003);
    assert!(
        err.contains(&format!("<stdin>:{}:1: a gap of 3.010000 s", row + 2)),
        "{err}"
    );
    assert!(err.contains("300 missing samples"), "{err}");
    assert!(err.contains("use --gaps longest or --gaps ignore"), "{err}");
    assert!(
        err.contains("(--gaps refuse: stopped after the 30000 rows before it)"),
        "{err}"
    );
    let snap = final_snapshot(&out);
    assert_eq!(snap["n"], 30_000);
    let before = dir.path().join("before.csv");
    std::fs::write(&before, csv(&r[..row])).unwrap();
    assert_equals_avar(&snap, &before, &[]);
    let results = results_json(&report);
    assert_eq!(results["timing"]["gaps"], 1);
    assert_eq!(results["timing"]["samples_used"], 30_000);
    assert_eq!(results["channels"][0]["n"], 30_000);
}

/// A row older than the window (moved 200 rows later): reported with its line number;
/// --on-error skip leaves it out and goes on (the batch on the file without it), stop ends
/// with code 2 and the final snapshot of the rows before it.
#[test]
fn a_row_older_than_the_window_is_located_and_skipped_or_stops() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = rows(20_000);
    let late = r.remove(5_000);
    r.insert(5_000 + 200, late);
    const { assert!(200 > WINDOW) };
    let text = csv(&r);
    // data row 5200 (0-based) is line 5202
    let want = "<stdin>:5202:1: time stamp 1050.000000000 s is older than 1051.";
    let skip = live(&text, &["--time-column", "t", "--on-error", "skip"]);
    assert!(
        skip.status.success(),
        "{}",
        String::from_utf8_lossy(&skip.stderr)
    );
    let err = String::from_utf8_lossy(&skip.stderr);
    assert!(err.contains(want), "{err}");
    let snap = final_snapshot(&skip);
    assert_eq!(snap["n"], 19_999);
    // the row left out leaves a gap of 1 sample (0.005 %), in the batch too
    assert_eq!(snap["timing"]["gaps"], 1);
    let without = dir.path().join("without.csv");
    let mut w = r.clone();
    w.remove(5_200);
    std::fs::write(&without, csv(&w)).unwrap();
    assert_equals_avar(&snap, &without, &[]);

    let stop = live(&text, &["--time-column", "t"]);
    assert_eq!(stop.status.code(), Some(2));
    let err = String::from_utf8_lossy(&stop.stderr);
    assert!(err.contains(want), "{err}");
    assert!(err.contains("--on-error stop"), "{err}");
    let snap = final_snapshot(&stop);
    // the 5200 rows read before it, in time order (the ones in the window included)
    assert_eq!(snap["n"], 5_200);
    let before = dir.path().join("before.csv");
    std::fs::write(&before, csv(&r[..5_200])).unwrap();
    assert_equals_avar(&snap, &before, &[]);
}

/// --rate within 1 % of the stamps' 100 Hz is used; 2 % away is the batch's error (exit 2,
/// both rates named); neither --rate nor --time-column is a usage error (exit 2).
#[test]
fn rate_checked_against_the_stamps() {
    let text = csv(&rows(3_000));
    let ok = live(&text, &["--time-column", "t", "--rate", "100.9"]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let snap = final_snapshot(&ok);
    assert_eq!(snap["channels"][0]["rate_hz"], 100.9);
    assert_eq!(snap["timing"]["rate_source"], "--rate");
    let from_stamps = snap["timing"]["rate_from_stamps_hz"].as_f64().unwrap();
    assert!((from_stamps - 100.0).abs() < 1e-9);

    let bad = live(&text, &["--time-column", "t", "--rate", "102"]);
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("--rate 102 Hz disagrees with the rate from the time stamps, 100.000000 Hz"),
        "{err}"
    );
    assert!(bad.stdout.is_empty());

    let none = live(&text, &[]);
    assert_eq!(none.status.code(), Some(2));
    let err = String::from_utf8_lossy(&none.stderr);
    assert!(err.contains("--rate"), "{err}");

    // --lines: a line of the counts before the channels' lines
    let lines = live(&text, &["--time-column", "t", "--lines"]);
    let stdout = String::from_utf8_lossy(&lines.stdout);
    assert!(
        stdout.starts_with(
            "final t=30.0s n=3000 stamps: 3000 messages, rate 100.000000 Hz (stamps; stamps say \
             100.000000 Hz), 0 reordered, 0 duplicates (removed), 0 gaps"
        ),
        "{stdout}"
    );

    // binary rows have no time column (as for `imunoise avar`)
    let binary = live("", &["--time-column", "1", "--binary", "f64"]);
    assert_eq!(binary.status.code(), Some(2));
    let err = String::from_utf8_lossy(&binary.stderr);
    assert!(err.contains("--time-column is for text input"), "{err}");

    // stamps in ms, headerless, the stamp column by index: the same rate
    let ms: String = rows(3_000)
        .iter()
        .map(|(i, a, b)| format!("{a} {} {b}\n", 10 * i))
        .collect();
    let out = live(&ms, &["--time-column", "2", "--time-unit", "ms"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let snap = final_snapshot(&out);
    assert!((snap["channels"][0]["rate_hz"].as_f64().unwrap() - 100.0).abs() < 1e-9);
    assert_eq!(snap["channels"][1]["name"], "col3");
}

/// --gaps longest with --out: the report equals `imunoise analyze --time-column t --gaps
/// longest` on the same file (channels and the timing in results.json).
#[test]
fn longest_out_report_equals_analyze() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imu.csv");
    std::fs::write(&path, csv(&faulty(30_000, 10_000, 50))).unwrap();
    let (live_dir, batch_dir) = (dir.path().join("live"), dir.path().join("batch"));
    let file = path.to_str().unwrap();
    let common = ["--time-column", "t", "--gaps", "longest", "--out"];
    run_ok(
        bin()
            .args(["live", file, "--every", "100", "--json"])
            .args(common)
            .arg(&live_dir),
    );
    run_ok(bin().args(["analyze", file]).args(common).arg(&batch_dir));
    let (a, b) = (results_json(&live_dir), results_json(&batch_dir));
    assert_eq!(a["timing"], b["timing"]);
    assert_eq!(a["timing"]["segment"], serde_json::json!([10_000, 30_000]));
    assert_eq!(a["channels"], b["channels"]);
}

/// --gaps longest as the stream goes: each snapshot reports the longest gap-free segment so
/// far (the first 2000 samples until the segment after the gap, of 3000, outgrows it), with
/// its bounds in `timing.segment`; the snapshots fall due every 500 samples read (the one
/// at 5000 falls due in `finish`, whose final snapshot stands for it).
#[test]
fn longest_snapshots_follow_the_longest_segment_so_far() {
    use imunoise::logs::GapPolicy;
    use imunoise::pipeline::live::{Event, Live, LiveSettings, TimeStamps};
    use imunoise::pipeline::read::TimeUnit;
    let mut r = rows(5_100);
    r.drain(2_000..2_100);
    let time = TimeStamps {
        column: "t".into(),
        unit: TimeUnit::S,
        gaps: GapPolicy::Longest,
        rate_hz: None,
    };
    let settings = LiveSettings {
        time: Some(time),
        every_s: 5.0,
        ..LiveSettings::default()
    };
    let mut live = Live::new(settings, "imu.csv").unwrap();
    let mut seen = Vec::new();
    for piece in csv(&r).as_bytes().chunks(999) {
        for e in live.feed(piece).unwrap() {
            if let Event::Snapshot(s) = e {
                let seg = s.timing.unwrap().segment;
                seen.push((s.n, seg.map(|[a, b]| (a, b))));
            }
        }
    }
    let last = live.finish().unwrap();
    let first = Some((0, 2_000));
    assert_eq!(
        seen,
        [
            (500, None),
            (1_000, None),
            (1_500, None),
            (2_000, None),
            (2_000, first),
            (2_000, first),
            (2_000, first),
            (2_000, first),
            (2_500, Some((2_000, 4_500))),
        ]
    );
    assert_eq!(
        (last.n, last.timing.unwrap().segment),
        (3_000, Some([2_000, 5_000]))
    );
}

/// A malformed line with stamps: --on-error stop keeps every row read before it, the rows
/// still held in the reorder window included (the batch on the rows before the line).
#[test]
fn a_malformed_line_keeps_the_rows_held_for_their_order() {
    let dir = tempfile::tempdir().unwrap();
    let mut r = rows(3_000);
    r.swap(1_990, 1_991);
    let mut text = csv(&r);
    // data row 2000 is line 2002: its gx cell spoilt
    let at = text.match_indices('\n').nth(2_000).unwrap().0 + 1;
    let comma = at + text[at..].find(',').unwrap();
    text.insert(comma + 1, 'x');
    let out = live(&text, &["--time-column", "t"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("<stdin>:2002:"), "{err}");
    let snap = final_snapshot(&out);
    assert_eq!(snap["n"], 2_000);
    assert_eq!(snap["timing"]["reordered"], 1);
    let before = dir.path().join("before.csv");
    std::fs::write(&before, csv(&r[..2_000])).unwrap();
    assert_equals_avar(&snap, &before, &[]);
}

/// `--time-column SEC+NSEC`: the stamps of a ROS message header as `ros2 topic echo --csv`
/// prints them (no header line; whole seconds, nanoseconds and the frame id before the
/// values). `avar` and `live` give the result of the same record with one column of stamps in
/// ns (the same stamps: the second implementation), across second boundaries, with the
/// faults and a gap of [`faulty`].
#[test]
fn ros_header_stamps_as_seconds_plus_nanoseconds() {
    let dir = tempfile::tempdir().unwrap();
    let r = faulty(30_000, 20_000, 300);
    let base = 1_732_723_200u64;
    let (mut ros, mut ns) = (String::new(), String::from("t,gx,gy\n"));
    for (i, a, b) in &r {
        let stamp = 10_000_000 * *i as u64 + 990_000_000; // the first second boundary at row 1
        ros += &format!(
            "{},{},imu_link,{a},{b}\n",
            base + stamp / 1_000_000_000,
            stamp % 1_000_000_000
        );
        // (the epoch left out: ns since 1970 exceed 2^53 and would not parse exactly as f64)
        ns += &format!("{stamp},{a},{b}\n");
    }
    let (ros_path, ns_path) = (dir.path().join("ros.csv"), dir.path().join("ns.csv"));
    std::fs::write(&ros_path, &ros).unwrap();
    std::fs::write(&ns_path, &ns).unwrap();
    let avar = |path: &std::path::Path, args: &[&str]| -> serde_json::Value {
        let out = run_ok(
            bin()
                .args(["avar", path.to_str().unwrap(), "--gaps", "ignore"])
                .args(args)
                .args(["--format", "json"]),
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let want = avar(&ns_path, &["--time-column", "t", "--time-unit", "ns"]);
    let got = avar(&ros_path, &["--time-column", "1+2", "--columns", "4,5"]);
    let out = live(
        &ros,
        &[
            "--time-column",
            "1+2",
            "--columns",
            "4-5",
            "--gaps",
            "ignore",
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let snap = final_snapshot(&out);
    assert_eq!(snap["timing"]["missing_samples"], 300);
    assert_eq!(snap["timing"]["duplicates"], 3);
    for ch in 0..2 {
        let w = &want["channels"][ch];
        assert_eq!(w["n"], 30_000);
        for (what, c) in [
            ("avar", &got["channels"][ch]),
            ("live", &snap["channels"][ch]),
        ] {
            assert_eq!(c["rate_hz"], w["rate_hz"], "{what}");
            assert_points_equal(c, w, &format!("{what} ch {ch}"), &[("avar", TOL)]);
        }
    }
    // the same column twice is a usage error
    let out = bin()
        .args(["avar", ros_path.to_str().unwrap(), "--time-column", "1+1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("the same"));
}
