//! `imunoise live` end to end: through a pipe and through a growing file, its final snapshot
//! against `imunoise avar` on the same rows, and a malformed line mid-stream.

use std::io::Write;
use std::process::Stdio;
use std::time::Duration;

mod live_common;
use live_common::{TOL, TOL_CI, assert_points_equal, bin, rel, results_json, run_ok, run_piped};

/// A two-channel CSV (header gx,gy) of `n` rows of white noise plus a random walk and an
/// offset, from a fixed xorshift sequence; `bad` puts a malformed cell on that data row (0-based).
fn csv(n: usize, bad: Option<usize>) -> String {
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut u = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut text = String::from("gx,gy\n");
    let mut rw = 0.0;
    for i in 0..n {
        rw += 1e-3 * u();
        let (a, b) = (u() + rw + 5.0, 0.1 * u() - 2.0);
        if bad == Some(i) {
            text += &format!("{a},x{b}\n");
        } else {
            text += &format!("{a},{b}\n");
        }
    }
    text
}

/// The last line of `stdout` (the final snapshot) against `imunoise avar FILE --format json`.
fn assert_final_equals_avar(stdout: &str, file: &std::path::Path, rows: usize) {
    let last = stdout.lines().last().expect("a final snapshot");
    let live: serde_json::Value = serde_json::from_str(last).unwrap();
    assert_eq!(live["final"], true);
    assert_eq!(live["n"], rows);
    let out = bin()
        .args([
            "avar",
            file.to_str().unwrap(),
            "--rate",
            "100",
            "--format",
            "json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let batch: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for ch in 0..2 {
        let (a, b) = (&live["channels"][ch], &batch["channels"][ch]);
        assert_eq!(a["name"], b["name"]);
        for (p, q) in a["points"]
            .as_array()
            .unwrap()
            .iter()
            .zip(b["points"].as_array().unwrap())
        {
            assert_eq!(p["n_terms"], q["n_terms"]);
        }
        let keys = [
            ("avar", TOL),
            ("avar_lo", TOL_CI),
            ("avar_hi", TOL_CI),
            ("edf", TOL_CI),
        ];
        assert_points_equal(a, b, &format!("channel {ch}"), &keys);
    }
}

#[test]
fn through_a_pipe_the_final_snapshot_equals_avar() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imu.csv");
    let text = csv(50_000, None);
    std::fs::write(&path, &text).unwrap();
    // pieces of odd sizes, cut inside lines
    let out = run_piped(
        bin().args(["live", "-", "--rate", "100", "--every", "100", "--json"]),
        text.as_bytes(),
        7_777,
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    // a snapshot every 100 s of input (10^4 rows) and the final one
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 6, "{stdout}");
    for (i, l) in lines[..5].iter().enumerate() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert_eq!(v["n"], 10_000 * (i + 1));
        assert_eq!(v["final"], false);
        // N is read off at 1 s with a CI around it
        let n = &v["channels"][0]["n_term"];
        assert!(n["ci_lo"].as_f64().unwrap() < n["value"].as_f64().unwrap());
    }
    assert_final_equals_avar(&stdout, &path, 50_000);
}

#[test]
fn through_a_growing_file_the_final_snapshot_equals_avar() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("growing.csv");
    let text = csv(30_000, None);
    std::fs::write(&path, "").unwrap();
    let child = bin()
        .args([
            "live",
            path.to_str().unwrap(),
            "--follow",
            "--idle",
            "1.5",
            "--rate",
            "100",
            "--every",
            "60",
            "--json",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .unwrap();
        for piece in text.as_bytes().chunks(100_003) {
            f.write_all(piece).unwrap();
            f.flush().unwrap();
            std::thread::sleep(Duration::from_millis(150));
        }
    }
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(stdout.lines().count(), 5 + 1, "{stdout}");
    assert_final_equals_avar(&stdout, &path, 30_000);
}

#[test]
fn a_malformed_line_is_reported_and_stops_or_is_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let text = csv(20_000, Some(12_345));
    let run = |policy: &str| {
        run_piped(
            bin()
                .args(["live", "-", "--rate", "100", "--every", "50", "--json"])
                .args(["--on-error", policy]),
            text.as_bytes(),
            4_096,
        )
    };
    // data row 12345 (0-based) is line 12347 of the stream (after the header); the bad cell
    // is the second one, after the first number and the comma
    let bad_line = text.lines().nth(12_346).unwrap();
    let column = bad_line.find(",x").unwrap() + 2;
    let want = format!("<stdin>:12347:{column}: not a number");

    let stop = run("stop");
    assert_eq!(stop.status.code(), Some(2));
    let err = String::from_utf8_lossy(&stop.stderr);
    assert!(err.contains(&want), "{err}");
    let stdout = String::from_utf8(stop.stdout).unwrap();
    // nothing accumulated is lost: the final snapshot holds the 12345 rows before the line
    let path = dir.path().join("before.csv");
    let before: String = text
        .lines()
        .take(1 + 12_345)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(&path, before).unwrap();
    assert_final_equals_avar(&stdout, &path, 12_345);

    let skip = run("skip");
    assert!(skip.status.success());
    let err = String::from_utf8_lossy(&skip.stderr);
    assert!(err.contains(&want), "{err}");
    let stdout = String::from_utf8(skip.stdout).unwrap();
    let path = dir.path().join("without.csv");
    let without: String = text
        .lines()
        .enumerate()
        .filter(|&(i, _)| i != 12_346)
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    std::fs::write(&path, without).unwrap();
    assert_final_equals_avar(&stdout, &path, 19_999);
}

/// A headerless stream with a text column (as `ros2 topic echo … --csv` writes: stamp, frame
/// id, values), read through `--columns` by index: the text column is never parsed, and the
/// columns are named col1, col2, … as `imunoise avar` names them.
#[test]
fn headerless_rows_with_a_text_column_and_selected_columns() {
    use imunoise::pipeline::live::{Live, LiveSettings};
    let text = csv(4_000, None);
    let rows: String = text
        .lines()
        .skip(1)
        .enumerate()
        .map(|(i, l)| format!("{i},imu_link,{l}\n"))
        .collect();
    let settings = LiveSettings {
        rate_hz: 100.0,
        columns: Some("3-4".into()),
        every_s: 1e9,
        ..LiveSettings::default()
    };
    let mut live = Live::new(settings, "ros.csv").unwrap();
    for piece in rows.as_bytes().chunks(1000) {
        assert!(live.feed(piece).unwrap().is_empty());
    }
    let fin = live.finish().unwrap();
    assert_eq!(fin.n, 4_000);
    assert_eq!(fin.channels[0].name, "col3");
    // the same values as the file with a header, fed in one piece: the same AV (up to the
    // order of the sums, which follows the pieces)
    let mut plain = Live::new(
        LiveSettings {
            rate_hz: 100.0,
            every_s: 1e9,
            ..LiveSettings::default()
        },
        "imu.csv",
    )
    .unwrap();
    plain.feed(text.as_bytes()).unwrap();
    let want = plain.finish().unwrap();
    for (a, b) in fin.channels.iter().zip(&want.channels) {
        for (p, q) in a.points.iter().zip(&b.points) {
            assert!(rel(p.avar, q.avar) <= TOL, "m={}", p.m);
        }
    }
}

/// `--until K=20%`: the stream stops at the first snapshot where K's interval on every channel
/// has a relative half-width of at most 20 %, and nothing after it is read.
#[test]
fn until_stops_at_the_first_snapshot_reaching_the_precision() {
    use imunoise::pipeline::live::{Event, Live, LiveSettings};
    // white noise plus a random walk dominant beyond a few seconds (a clear +1/2 region)
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut u = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut rw = 0.0;
    let mut text = String::from("gx\n");
    for _ in 0..400_000 {
        rw += 3e-3 * u();
        text += &format!("{}\n", u() + rw);
    }
    let settings = LiveSettings {
        rate_hz: 100.0,
        every_s: 100.0,
        until: vec!["K=20%".parse().unwrap()],
        ..LiveSettings::default()
    };
    let mut live = Live::new(settings, "rw.csv").unwrap();
    let mut snaps = Vec::new();
    for piece in text.as_bytes().chunks(50_000) {
        for e in live.feed(piece).unwrap() {
            if let Event::Snapshot(s) = e {
                snaps.push(s);
            }
        }
    }
    assert!(live.reached());
    let last = snaps.last().unwrap();
    assert!(last.reached);
    for s in &snaps[..snaps.len() - 1] {
        assert!(!s.reached);
        let h = s.progress[0].rel_halfwidth;
        assert!(h.is_none_or(|h| h > 0.2), "t={} h={h:?}", s.t_s);
        // the time-left estimate exists whenever the half-width does
        assert_eq!(h.is_some(), s.progress[0].time_left_s.is_some());
    }
    let k = last.channels[0].k_term.as_ref().unwrap();
    let h = (k.ci_hi.unwrap() - k.ci_lo.unwrap()) / (2.0 * k.value);
    assert!(h <= 0.2, "{h}");
    assert_eq!(last.progress[0].rel_halfwidth, Some(h));
    // stopped well before the end of the data: the final snapshot is the one that reached it
    let fin = live.finish().unwrap();
    assert_eq!(fin.n, last.n);
    assert!(fin.n < 400_000);
}

/// `--out DIR`: at the end of the input the report folder of `imunoise analyze` on all the
/// rows read, the same results.json (both run the same batch pipeline on the same values).
#[test]
fn out_writes_the_analyze_report_at_the_end() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("imu.csv");
    std::fs::write(&path, csv(30_000, None)).unwrap();
    let (live_dir, batch_dir) = (dir.path().join("live"), dir.path().join("batch"));
    let file = path.to_str().unwrap();
    let out = bin()
        .args([
            "live", file, "--rate", "100", "--every", "100", "--json", "--out",
        ])
        .arg(&live_dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    run_ok(
        bin()
            .args(["analyze", file, "--rate", "100", "--out"])
            .arg(&batch_dir),
    );
    let (a, b) = (results_json(&live_dir), results_json(&batch_dir));
    assert_eq!(a["channels"].as_array().unwrap().len(), 2);
    assert_eq!(a["channels"], b["channels"]);
    assert!(live_dir.join("report.html").is_file());
}

/// Ctrl-C (SIGINT) ends a stream that is still open like its end: the final snapshot of the
/// rows read is printed and the exit code is 0.
#[cfg(unix)]
#[test]
fn an_interrupt_ends_an_open_stream_with_the_final_snapshot() {
    use std::io::Read;
    let text = csv(20_000, None);
    let mut child = bin()
        .args(["live", "-", "--rate", "100", "--every", "1000", "--json"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // the stream stays open: stdin is kept until after the child has exited
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(text.as_bytes()).unwrap();
    stdin.flush().unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        stdout.read_to_string(&mut s).unwrap();
        s
    });
    std::thread::sleep(Duration::from_millis(1500));
    // SAFETY: signals our own child process by its id
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let status = child.wait().unwrap();
    drop(stdin);
    assert!(status.success(), "{status:?}");
    let out = reader.join().unwrap();
    let last: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
    assert_eq!(last["final"], true);
    assert_eq!(last["n"], 20_000);
}

/// Standard output not a terminal and no --json: JSON lines all the same (for other programs);
/// --lines: one text line per channel and snapshot.
#[test]
fn a_pipe_gets_json_lines_and_lines_gets_text() {
    let text = csv(20_000, None);
    let run = |extra: &[&str]| {
        let out = run_piped(
            bin()
                .args(["live", "-", "--rate", "100", "--every", "100"])
                .args(extra),
            text.as_bytes(),
            text.len(),
        );
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8(out.stdout).unwrap()
    };
    // 2 snapshots (at 100 s and 200 s) and the final one
    let json = run(&[]);
    assert_eq!(json.lines().count(), 3, "{json}");
    for l in json.lines() {
        let v: serde_json::Value = serde_json::from_str(l).unwrap();
        assert_eq!(v["channels"].as_array().unwrap().len(), 2);
    }
    // 2 channels per snapshot, the last two marked final; no escape codes
    let lines = run(&["--lines"]);
    assert_eq!(lines.lines().count(), 6, "{lines}");
    assert!(
        lines
            .lines()
            .skip(4)
            .all(|l| l.starts_with("final t=200.0s"))
    );
    assert!(!lines.contains('\x1b'));
}

/// --model: each snapshot carries the fitted model, N, K, B come from it with CIs, and the
/// --until progress has a time left from the model with an interval around it.
#[test]
fn model_snapshots_and_a_model_time_left() {
    use imunoise::pipeline::live::{Event, Live, LiveSettings};
    let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-8)".parse().unwrap();
    let x = model
        .simulate_stream(200_000, 100.0, 5, 0)
        .unwrap()
        .into_values();
    let settings = LiveSettings {
        rate_hz: 100.0,
        every_s: 500.0,
        model: Some("WN + RW".into()),
        until: vec!["K=5%".parse().unwrap(), "RW.gamma2=10%".parse().unwrap()],
        ..LiveSettings::default()
    };
    let mut live = Live::new(settings, "sim").unwrap();
    live.feed(b"gyro_x_dps\n").unwrap();
    let snaps: Vec<_> = live
        .feed_values(&[&x])
        .unwrap()
        .into_iter()
        .filter_map(|e| match e {
            Event::Snapshot(s) => Some(s),
            Event::BadLine(_) | Event::Refused(_) => None,
        })
        .collect();
    assert_eq!(snaps.len(), 4);
    let last = snaps.last().unwrap();
    let c = &last.channels[0];
    assert!(c.model.as_deref().unwrap().starts_with("WN(sigma2="));
    let k = c.k_term.as_ref().unwrap();
    assert_eq!(
        k.source,
        imunoise::gmwm_prep::noise_terms::TermSource::Model
    );
    let (p_k, p_g) = (&last.progress[0], &last.progress[1]);
    assert_eq!((p_k.basis, p_g.basis), ("model", "model"));
    // K = √(γ²/Δt): its CI is the square root of γ²'s, both e^{∓r} on the log scale, so
    // K's relative half-width is sinh(r/2) where γ²'s is sinh(r) (closed form; rounding only)
    let (hk, hg) = (p_k.rel_halfwidth.unwrap(), p_g.rel_halfwidth.unwrap());
    assert!(
        ((hg.asinh() / 2.0).sinh() / hk - 1.0).abs() < 1e-9,
        "{hk} {hg}"
    );
    // K at 5 % is r = 2·asinh(0.05) = 0.09998, γ² at 10 % r = asinh(0.1) = 0.09983: the same
    // record to 0.3 % (n ∝ r⁻²), each solved to 0.2 % in h (0.4 % in n)
    let (tk, tg) = (p_k.time_left_s.unwrap(), p_g.time_left_s.unwrap());
    assert!(p_k.time_left_lo_s.unwrap() <= tk && tk <= p_k.time_left_hi_s.unwrap());
    assert!((tk / tg - 1.0).abs() < 0.02, "{tk} {tg}");
    // a parameter target needs a model, and a component the model has
    let bad = LiveSettings {
        until: vec!["AR1.phi=10%".parse().unwrap()],
        ..LiveSettings::default()
    };
    assert!(Live::new(bad.clone(), "x").is_err());
    let with_model = LiveSettings {
        model: Some("WN + RW".into()),
        ..bad
    };
    assert!(Live::new(with_model, "x").is_err());
}

/// Raw binary rows (`--binary f32 --channels 6`, as `imunoise avar` reads them) through a pipe
/// in pieces cut inside rows, two channels picked by `--columns 2,5`: the final snapshot equals
/// `imunoise avar` on a CSV of the same values (each f32 printed exactly as its f64 value). A
/// row holding NaN is reported with its row number and channel; `stop` keeps the rows before
/// it, `skip` leaves it out. A partial last row is reported too, never dropped silently.
#[test]
fn binary_rows_through_a_pipe_equal_avar_and_bad_rows_are_located() {
    let dir = tempfile::tempdir().unwrap();
    let (n, k, bad) = (30_000usize, 6usize, 12_345usize);
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut u = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) as f32
    };
    let rows: Vec<Vec<f32>> = (0..n)
        .map(|i| {
            (0..k)
                .map(|c| u() + (i % 97) as f32 * 1e-3 * c as f32)
                .collect()
        })
        .collect();
    let bytes = |rows: &[Vec<f32>]| -> Vec<u8> {
        rows.iter()
            .flat_map(|r| r.iter().flat_map(|v| v.to_le_bytes()))
            .collect()
    };
    let csv_of = |rows: &[Vec<f32>], name: &str| {
        let mut t = String::from("ch2,ch5\n");
        for r in rows {
            t += &format!("{},{}\n", r[1] as f64, r[4] as f64);
        }
        let p = dir.path().join(name);
        std::fs::write(&p, t).unwrap();
        p
    };
    let run = |input: &[u8], policy: &str| {
        run_piped(
            bin()
                .args(["live", "-", "--rate", "100", "--every", "100", "--json"])
                .args(["--binary", "f32", "--channels", "6", "--columns", "2,5"])
                .args(["--on-error", policy]),
            input,
            7_777,
        )
    };

    // clean: 30,000 rows of 24 bytes, 3 snapshots of 10^4 rows and the final one
    let out = run(&bytes(&rows), "stop");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(stdout.lines().count(), 4, "{stdout}");
    assert_final_equals_avar(&stdout, &csv_of(&rows, "all.csv"), n);

    // NaN in row 12346 (1-based), channel 5: byte offset 12345·24 + 4·4
    let mut with_nan = rows.clone();
    with_nan[bad][4] = f32::NAN;
    let want = format!(
        "<stdin>:12346:5: a value that is not finite in row 12346 channel 5 (byte offset {})",
        bad * 24 + 16
    );
    let stop = run(&bytes(&with_nan), "stop");
    assert_eq!(stop.status.code(), Some(2));
    let err = String::from_utf8_lossy(&stop.stderr);
    assert!(err.contains(&want), "{err}");
    let stdout = String::from_utf8(stop.stdout).unwrap();
    assert_final_equals_avar(&stdout, &csv_of(&rows[..bad], "before.csv"), bad);

    let skip = run(&bytes(&with_nan), "skip");
    assert!(skip.status.success());
    assert!(String::from_utf8_lossy(&skip.stderr).contains(&want));
    let without: Vec<Vec<f32>> = rows
        .iter()
        .enumerate()
        .filter(|&(i, _)| i != bad)
        .map(|(_, r)| r.clone())
        .collect();
    let stdout = String::from_utf8(skip.stdout).unwrap();
    assert_final_equals_avar(&stdout, &csv_of(&without, "without.csv"), n - 1);

    // 10 bytes of a 30,001st row: reported, the 30,000 whole rows kept
    let mut cut = bytes(&rows);
    cut.extend_from_slice(&[0u8; 10]);
    let out = run(&cut, "stop");
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("the input ends inside row 30001: 10 of its 6 × 4 bytes"),
        "{err}"
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_final_equals_avar(&stdout, &csv_of(&rows, "all2.csv"), n);
    // with skip: reported all the same, and the run ends well
    let out = run(&cut, "skip");
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("ends inside row 30001"), "{err}");
}
