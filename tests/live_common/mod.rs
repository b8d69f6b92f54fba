//! What the `live` tests share: the binary, the tolerances of the online against the batch
//! estimate, and the comparison of one channel's points.

#![allow(dead_code)] // each test file uses its own part

use std::process::Command;

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
