//! Inputs that coverage-guided fuzzing (fuzz/, `cargo xtask fuzz --coverage`) found to make a
//! reader panic, abort, run longer than 1 s or allocate more than 1 GiB, minimised by libFuzzer
//! and kept in `tests/fixtures/fuzz/<target>/`. Each is driven through the reader as its fuzz
//! target drives it; each must now give a value or an error (exit code 2), and the test says
//! which.

use imunoise::io::{BinaryType, ReadOptions, read_bytes};
use imunoise::logs::{self, GapPolicy, LogFormat};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn fixture(target: &str, name: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/fuzz")
        .join(target)
        .join(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// What the log targets do (fuzz/src/lib.rs): open, summarize, read every IMU topic and order
/// it by stamp. Returns the first error (or `None` when everything read), and checks the time
/// limit of the fuzzing (1 s, here 10 s for slow debug builds under a loaded machine).
fn read_log(format: LogFormat, ext: &str, bytes: &[u8]) -> Option<imunoise::Error> {
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = dir.path().join(format!("x.{ext}"));
    std::fs::write(&path, bytes).unwrap();
    let t0 = Instant::now();
    let result = (|| {
        let r = logs::open_checked(&path, format, false, &imunoise::Ui::quiet())?;
        logs::summarize(r.as_ref())?;
        for t in r.topics()?.iter().filter(|t| t.is_imu) {
            let s = r.read_imu(&t.name)?;
            logs::timing::prepare(s.stamps_ns, s.columns, None, GapPolicy::Longest, "x")?;
        }
        Ok::<(), imunoise::Error>(())
    })();
    assert!(
        t0.elapsed() < Duration::from_secs(10),
        "{format:?} took {:?}",
        t0.elapsed()
    );
    result.err()
}

/// An error the command reports with exit code 2 (bad input), not an internal error.
fn user_error(e: Option<imunoise::Error>) -> String {
    let e = e.expect("an error");
    assert_eq!(e.exit_code(), 2, "{e}");
    e.to_string()
}

#[allow(dead_code)]
fn raw(kind: BinaryType, channels: usize, bytes: &[u8], name: &str) -> imunoise::Result<usize> {
    let opts = ReadOptions {
        binary: Some(kind),
        channels: Some(channels),
        ..Default::default()
    };
    read_bytes(bytes, name, &opts).map(|t| t.n_rows())
}
