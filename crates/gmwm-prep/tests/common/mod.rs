//! Helpers shared by this crate's Monte Carlo tests (each test binary uses a part of them).
#![allow(dead_code)]

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

/// Asserts that the mean of the simulated AVs (`per_scale[j]`, R values at cluster size
/// `ms[j]`) lies within 3 standard errors (sd/√R) of `theory[j]` at every scale: the mean of
/// R ≥ 100 independent AVs is close to normal.
pub fn mean_within_3_se(label: &str, ms: &[u64], per_scale: &[Vec<f64>], theory: &[f64]) {
    for (j, &m) in ms.iter().enumerate() {
        let (mean, sd) = mean_sd(&per_scale[j]);
        let z = (mean - theory[j]) / (sd / (per_scale[j].len() as f64).sqrt());
        eprintln!(
            "{label} m={m:6}: mean {mean:.4e} theory {:.4e} z {z:+.2}",
            theory[j]
        );
        assert!(z.abs() <= 3.0, "{label} m={m}: z = {z}");
    }
}

/// Asserts that each parameter's mean over the R fits (`est[r][i]`) lies within 2 Monte Carlo
/// standard errors (sd/√R) of its truth (`truths[i]`, named).
pub fn unbiased_within_2_se<const K: usize>(truths: &[(&str, f64); K], est: &[[f64; K]]) {
    for (i, (name, t)) in truths.iter().enumerate() {
        let col: Vec<f64> = est.iter().map(|e| e[i]).collect();
        let (m, sd) = mean_sd(&col);
        let se = sd / (est.len() as f64).sqrt();
        eprintln!(
            "{name}: truth {t:e}, mean {m:e}, sd {sd:e}, (mean − truth)/SE {:+.2}",
            (m - t) / se
        );
        assert!(
            (m - t).abs() <= 2.0 * se,
            "{name}: mean {m} vs {t} (SE {se})"
        );
    }
}
