//! Helpers shared by this crate's Monte Carlo tests.

use avar::{AvarConfig, allan_variance};

/// Mean and sample standard deviation (divisor n − 1) of `x`.
pub fn mean_sd(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|a| (a - m) * (a - m)).sum::<f64>() / (n - 1.0);
    (m, v.sqrt())
}

/// The Allan variance (default scales) of `r` simulated paths at `rate` Hz: the cluster sizes
/// and, per scale, the `r` values. `path(k)` gives path k.
pub fn simulated_avs(
    r: u64,
    rate: f64,
    mut path: impl FnMut(u64) -> Vec<f64>,
) -> (Vec<u64>, Vec<Vec<f64>>) {
    let mut per_scale: Vec<Vec<f64>> = Vec::new();
    let mut ms: Vec<u64> = Vec::new();
    for k in 0..r {
        let x = path(k);
        let av = allan_variance(&x, rate, &AvarConfig::default()).unwrap();
        if ms.is_empty() {
            ms = av.points.iter().map(|p| p.m).collect();
            per_scale = vec![Vec::new(); ms.len()];
        }
        for (j, p) in av.points.iter().enumerate() {
            per_scale[j].push(p.avar);
        }
    }
    (ms, per_scale)
}
