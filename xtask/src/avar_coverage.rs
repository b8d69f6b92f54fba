//! `cargo xtask avar-coverage [--reps N] [--n T] [--seed S]`: Monte Carlo coverage of the Allan
//! variance confidence intervals of the `avar` crate (issue 4, acceptance "coverage").
//!
//! For white noise, a random walk and an AR(1), `reps` series of T samples are simulated with
//! fixed seeds (`processes`), the MOAV is computed at the book's dyadic scales with each CI family
//! (chi-square/EDF — the default —, Gaussian/Lemma 4.4, and the Haar WV η interval of `wv`
//! at level j = log2(m) + 1, which estimates AV(m)/2), and the fraction of intervals containing
//! the true AV (`spectral::model_allan_variance`) is tabulated. The acceptance: the default 95 %
//! CI covers in 95 % ± 2.5 % at every scale whose (median) EDF is at least 10.

use crate::args::parsed;
use avar::{AvarConfig, CiMethod, Scales, allan_variance, haar_wavelet_variance};
use processes::Model;
use rayon::prelude::*;

/// Nominal non-coverage.
const ALPHA: f64 = 0.05;
/// Acceptance band around 1 − ALPHA.
const BAND: f64 = 0.025;
/// Scales whose median EDF is below this are reported but not judged.
const MIN_EDF: f64 = 10.0;

struct Cell {
    m: u64,
    truth: f64,
    edf_median: f64,
    chi2: f64,
    gauss: f64,
    gauss_neg: f64,
    haar: f64,
}

/// Runs the report.
pub fn run(args: &[String]) -> Result<(), String> {
    let reps: usize = parsed(args, "--reps", 1000)?;
    let n: usize = parsed(args, "--n", 1 << 15)?;
    let seed: u64 = parsed(args, "--seed", 20_240_404)?;
    if reps < 400 {
        return Err("the acceptance needs >= 400 replications".into());
    }
    let rate = 1.0;
    let models = ["WN(sigma2=1)", "RW(gamma2=1)", "AR1(phi=0.9, sigma2=1)"];
    println!(
        "# avar CI coverage: {reps} replications, T = {n}, nominal {:.0} %, seed {seed}\n",
        100.0 * (1.0 - ALPHA)
    );
    println!(
        "MC standard error of a coverage near 95 %: {:.2} %\n",
        100.0 * (0.95f64 * 0.05 / reps as f64).sqrt()
    );
    let mut all_ok = true;
    for (mi, text) in models.iter().enumerate() {
        let model: Model = text.parse().map_err(|e| format!("{text}: {e}"))?;
        let ms = Scales::Dyadic.cluster_sizes(n).map_err(|e| e.to_string())?;
        let truth: Vec<f64> = ms
            .iter()
            .map(|&m| spectral::model_allan_variance(&model, m, rate).map_err(|e| e.to_string()))
            .collect::<Result<_, _>>()?;
        let levels = ms.len() as u32 + 1; // level j <-> m = 2^(j-1); m = 2..2^J' needs levels up to J'+1
        type Rep = (Vec<bool>, Vec<f64>, Vec<bool>, Vec<bool>, Vec<bool>);
        let runs: Vec<Rep> = (0..reps)
            .into_par_iter()
            .map(|r| {
                let x = model.simulate(n, rate, seed + (mi as u64) * 1_000_000 + r as u64).map_err(|e| e.to_string())?;
                let x = x.values();
                let chi = allan_variance(x, rate, &AvarConfig { alpha: ALPHA, ..AvarConfig::default() }).map_err(|e| e.to_string())?;
                let gau = allan_variance(x, rate, &AvarConfig { alpha: ALPHA, ci: CiMethod::Gaussian, ..AvarConfig::default() })
                    .map_err(|e| e.to_string())?;
                let wv = haar_wavelet_variance(x, rate, Some(levels), ALPHA).map_err(|e| e.to_string())?;
                let cover = |lo: Option<f64>, hi: Option<f64>, t: f64| matches!((lo, hi), (Some(l), Some(h)) if l <= t && t <= h);
                let c1 = chi.points.iter().zip(&truth).map(|(p, &t)| cover(p.avar_lo, p.avar_hi, t)).collect();
                let e1 = chi.points.iter().map(|p| p.edf.unwrap_or(f64::NAN)).collect();
                let c2 = gau.points.iter().zip(&truth).map(|(p, &t)| cover(p.avar_lo, p.avar_hi, t)).collect();
                let n2 = gau.points.iter().map(|p| p.lower_negative).collect();
                let c3 = ms
                    .iter()
                    .zip(&truth)
                    .map(|(&m, &t)| {
                        let w = &wv.points[m.trailing_zeros() as usize]; // level log2(m) + 1
                        w.wv_lo <= t / 2.0 && t / 2.0 <= w.wv_hi
                    })
                    .collect();
                Ok((c1, e1, c2, n2, c3))
            })
            .collect::<Result<_, String>>()?;
        let frac =
            |f: &dyn Fn(&Rep) -> bool| runs.iter().filter(|r| f(r)).count() as f64 / reps as f64;
        let cells: Vec<Cell> = ms
            .iter()
            .enumerate()
            .map(|(s, &m)| {
                let mut edfs: Vec<f64> = runs.iter().map(|r| r.1[s]).collect();
                edfs.sort_by(|a, b| a.total_cmp(b));
                Cell {
                    m,
                    truth: truth[s],
                    edf_median: edfs[edfs.len() / 2],
                    chi2: frac(&|r| r.0[s]),
                    gauss: frac(&|r| r.2[s]),
                    gauss_neg: frac(&|r| r.3[s]),
                    haar: frac(&|r| r.4[s]),
                }
            })
            .collect();
        println!("## {text}\n");
        println!(
            "| m | true AV | median EDF | chi-square (default) | Gaussian (Lemma 4.4) | Gaussian lower < 0 | Haar WV η | judged |"
        );
        println!("|---:|---:|---:|---:|---:|---:|---:|:---|");
        for c in &cells {
            let judged = c.edf_median >= MIN_EDF;
            let ok = (c.chi2 - (1.0 - ALPHA)).abs() <= BAND;
            if judged && !ok {
                all_ok = false;
            }
            println!(
                "| {} | {:.4e} | {:.1} | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {} |",
                c.m,
                c.truth,
                c.edf_median,
                100.0 * c.chi2,
                100.0 * c.gauss,
                100.0 * c.gauss_neg,
                100.0 * c.haar,
                if !judged {
                    "EDF < 10"
                } else if ok {
                    "PASS"
                } else {
                    "FAIL"
                }
            );
        }
        println!();
    }
    println!(
        "acceptance (default chi-square CI within {:.1} % ± {:.1} % at every scale with median EDF >= {MIN_EDF}): {}",
        100.0 * (1.0 - ALPHA),
        100.0 * BAND,
        if all_ok { "PASS" } else { "FAIL" }
    );
    if all_ok {
        Ok(())
    } else {
        Err("coverage acceptance failed".into())
    }
}
