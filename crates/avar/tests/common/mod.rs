//! Shared helpers for the integration tests: locating ../shared/data, readers, generators.
#![allow(dead_code)]

use std::path::PathBuf;

use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

/// `<workspace root>/../shared/data`, or None (the caller prints a one-line skip message).
pub fn data_dir() -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let d = root.join("../shared/data");
    if d.is_dir() { Some(d) } else { None }
}

/// Returns the data dir or prints the skip line.
pub fn data_or_skip(test: &str) -> Option<PathBuf> {
    let d = data_dir();
    if d.is_none() {
        eprintln!("skip {test}: ../shared/data not found");
    }
    d
}

/// NBS14 1000-point set (REFERENCES §7): n_0 = 1234567890, n_{i+1} = 16807 n_i mod (2^31 − 1),
/// y_i = n_i / (2^31 − 1). NOTE: the published deviations (and the shipped vector) use
/// i = 0..999, i.e. the set starts with the seed itself, not i = 1..1000 as REFERENCES §7 says
/// (with i = 1..1000 ADEV(1) would be 0.2923406 instead of 0.2922319).
pub fn nbs14_1000() -> Vec<f64> {
    let mut n: u64 = 1_234_567_890;
    (0..1000)
        .map(|_| {
            let y = n as f64 / 2_147_483_647.0;
            n = (16807 * n) % 2_147_483_647;
            y
        })
        .collect()
}

/// One-column CSV with a header line.
pub fn read_column_csv(path: &std::path::Path) -> Vec<f64> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.trim().parse().unwrap())
        .collect()
}

/// Little-endian f64 file, `cols` columns row-major; returns column `col`.
pub fn read_f64_column(path: &std::path::Path, cols: usize, col: usize) -> Vec<f64> {
    let b = std::fs::read(path).unwrap();
    b.chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .skip(col)
        .step_by(cols)
        .collect()
}

/// A Stable32 table row: (AF, tau, n_terms, alpha, min_sigma, sigma, max_sigma).
#[derive(Debug, Clone, Copy)]
pub struct S32Row {
    pub af: u64,
    pub tau: f64,
    pub n: u64,
    pub alpha: i32,
    pub min: f64,
    pub sigma: f64,
    pub max: f64,
}

pub fn read_stable32(path: &std::path::Path) -> Vec<S32Row> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            S32Row {
                af: f[0].parse().unwrap(),
                tau: f[1].parse().unwrap(),
                n: f[2].parse().unwrap(),
                alpha: f[3].parse().unwrap(),
                min: f[4].parse().unwrap(),
                sigma: f[5].parse().unwrap(),
                max: f[6].parse().unwrap(),
            }
        })
        .collect()
}

/// Gaussian white noise with variance sigma2 (fixed seed).
pub fn white_noise(n: usize, sigma2: f64, seed: u64) -> Vec<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let s = sigma2.sqrt();
    (0..n)
        .map(|_| {
            let z: f64 = StandardNormal.sample(&mut rng);
            s * z
        })
        .collect()
}

/// Random walk with innovation variance gamma2, starting at 0.
pub fn random_walk(n: usize, gamma2: f64, seed: u64) -> Vec<f64> {
    let w = white_noise(n, gamma2, seed);
    let mut acc = 0.0;
    w.iter()
        .map(|v| {
            acc += v;
            acc
        })
        .collect()
}

/// Relative difference.
pub fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}
