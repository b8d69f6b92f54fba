//! What the `live` tests share (and `tests/stream.rs` its `run_ok`): the binary, running it,
//! the tolerances of the online against the batch estimate, and the comparison of one
//! channel's points.

#![allow(dead_code)] // each test file uses its own part

use std::io::Write;
use std::process::{Command, Output, Stdio};

/// The online and the batch estimates are two summations of the same squared differences,
/// each ~1e-15 relative (crates/avar/tests/online.rs checks 10^7 samples against the batch
/// and an independent compensated reference).
pub const TOL: f64 = 1e-12;

/// The interval's EDF comes from the identified noise exponent, which the online path
/// computes from running moments of the cluster means: ~1e-10 agreement.
pub const TOL_CI: f64 = 1e-7;

/// The `imunoise` binary of this build.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_imunoise"))
}

/// Runs `cmd` with `input` written to its standard input in pieces of `piece` bytes (cut
/// inside lines, as a pipe delivers them), standard output and error captured. The child may
/// stop reading early (a bad row under `--on-error stop`, a refused gap): a broken pipe ends
/// the writing then, and the exit status tells the rest.
pub fn run_piped(cmd: &mut Command, input: &[u8], piece: usize) -> Output {
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        let mut stdin = child.stdin.take().unwrap();
        for part in input.chunks(piece) {
            if stdin.write_all(part).is_err() {
                break;
            }
        }
    }
    child.wait_with_output().unwrap()
}

/// Runs `cmd` to its end and asserts that it succeeded (its standard error in the message).
pub fn run_ok(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The `results.json` a report folder (`--out`) holds.
pub fn results_json(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("results.json")).unwrap()).unwrap()
}

/// |a − b| / |b|, 0 when equal.
pub fn rel(a: f64, b: f64) -> f64 {
    if a == b { 0.0 } else { ((a - b) / b).abs() }
}

/// Channel `a` (JSON of a snapshot or of `imunoise avar --format json`) against `b`: the same
/// n, the same cluster sizes, and each of `keys` within its relative tolerance at every point.
pub fn assert_points_equal(
    a: &serde_json::Value,
    b: &serde_json::Value,
    what: &str,
    keys: &[(&str, f64)],
) {
    assert_eq!(a["n"], b["n"], "{what}");
    let (pa, pb) = (
        a["points"].as_array().unwrap(),
        b["points"].as_array().unwrap(),
    );
    assert_eq!(pa.len(), pb.len(), "{what}");
    for (p, q) in pa.iter().zip(pb) {
        assert_eq!(p["m"], q["m"], "{what}");
        for &(key, tol) in keys {
            let (x, y) = (p[key].as_f64().unwrap(), q[key].as_f64().unwrap());
            assert!(rel(x, y) <= tol, "{what} m={} {key}: {x} vs {y}", p["m"]);
        }
    }
}
