//! `cargo xtask robust-mc [--reps R] [--n T] [--seed S] [--eq-reps R2] [--eq-n T2]
//! [--weighting diag|model-full] [--efficiency E] [--part all|contam|equality]`: Monte Carlo report of the
//! robust GMWM and of the two-recording equality test (issue 15 acceptance). The report in the
//! crate is `crates/gmwm-prep/robust-mc-report.md` (this task's stdout).
//!
//! **Contamination.** WN(σ² = 1e-4) + RW(γ² = 1e-10) + AR1(φ = 0.995, σ² = 1e-7) at 100 Hz,
//! R series of T samples (replicate r = stream r of the seed), each fitted with the classical
//! and the robust (efficiency 0.6) AV, clean and with 0.5 % additive outliers of ±20σ
//! (σ = √σ²_WN = 0.01; positions and signs from a splitmix64 stream of (seed, r); each sample
//! is hit with probability 0.005). CIs: delta method with the model covariance of the AV at
//! θ̂ (×1/e for the robust AV). Acceptance: clean robust |bias| ≤ 2 MC SE and RMSE ≤ 1.4×
//! classical; contaminated robust RMSE ≤ 0.5× classical for every parameter and robust CI
//! coverage ≥ 90 %.
//!
//! **Equality test.** Pairs of recordings of the same model (size) and pairs where the second
//! recording has one parameter doubled (power), R2 pairs each, T2 samples per recording,
//! [`gmwm_prep::multi::fit_joint`]'s Wald test at 5 %. Acceptance: power ≥ 90 %, size about
//! 5 % (within 2 binomial SE: ≤ 5 % + 2·√(0.05·0.95/R2)).

use crate::args::parsed;
use avar::AvarConfig;
use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, Weighting, fit};
use gmwm_prep::inference::{delta_method, fit_covariance};
use gmwm_prep::multi::fit_joint;
use gmwm_prep::robust::fit_robust;
use processes::Model;
use rayon::prelude::*;
use std::time::Instant;

const RATE: f64 = 100.0;
const ALPHA: f64 = 0.05;
/// `--efficiency E` (default 0.6), stored as f64 bits.
static EFF_BITS: std::sync::atomic::AtomicU64 =
    std::sync::atomic::AtomicU64::new(0x3FE3_3333_3333_3333);

fn eff() -> f64 {
    f64::from_bits(EFF_BITS.load(std::sync::atomic::Ordering::Relaxed))
}
const TRUTH: &str = "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.995, sigma2=1e-7)";
const TEMPLATE: &str = "WN + RW + AR1";
const NAMES: [&str; 4] = ["WN.sigma2", "RW.gamma2", "AR1.phi", "AR1.sigma2"];

fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Adds ±`size` to each sample with probability `p` (deterministic in (seed, r)).
pub fn contaminate(x: &mut [f64], p: f64, size: f64, seed: u64, r: u64) -> usize {
    let mut s = seed ^ r.wrapping_mul(0xd1b5_4a32_d192_ed03) ^ 0x5151;
    let thr = (p * (u64::MAX as f64)) as u64;
    let mut k = 0;
    for v in x.iter_mut() {
        if splitmix(&mut s) < thr {
            let sign = if splitmix(&mut s) & 1 == 0 { 1.0 } else { -1.0 };
            *v += sign * size;
            k += 1;
        }
    }
    k
}

struct Est {
    theta: Vec<f64>,
    cover: Vec<bool>,
}

fn classical(x: &[f64], t: &Model, opts: &GmwmOptions, want: &[f64]) -> Result<Est, String> {
    let av = avar::allan_variance(x, RATE, &AvarConfig::default()).map_err(|e| e.to_string())?;
    let c = AvCurve::from_avar(&av).map_err(|e| e.to_string())?;
    let f = fit(&c, t, opts).map_err(|e| e.to_string())?;
    finish(f, want)
}

fn robust(x: &[f64], t: &Model, opts: &GmwmOptions, want: &[f64]) -> Result<Est, String> {
    let o = GmwmOptions {
        robust: Some(eff()),
        ..opts.clone()
    };
    let r = fit_robust(x, RATE, &AvarConfig::default(), t, &o).map_err(|e| e.to_string())?;
    finish(r.fit, want)
}

fn finish(f: gmwm_prep::gmwm::GmwmFit, want: &[f64]) -> Result<Est, String> {
    let v = fit_covariance(&f).map_err(|e| e.to_string())?;
    let inf = delta_method(&f, &v, ALPHA).map_err(|e| e.to_string())?;
    Ok(Est {
        cover: inf
            .ci
            .iter()
            .zip(want)
            .map(|(c, w)| c.0 <= *w && *w <= c.1)
            .collect(),
        theta: f.theta,
    })
}

struct Stats {
    mean: f64,
    se: f64,
    rmse: f64,
    cover: f64,
}

fn stats(v: &[&Est], k: usize, want: f64) -> Stats {
    let r = v.len() as f64;
    let mean = v.iter().map(|e| e.theta[k]).sum::<f64>() / r;
    let sd = (v.iter().map(|e| (e.theta[k] - mean).powi(2)).sum::<f64>() / (r - 1.0)).sqrt();
    let rmse = (v.iter().map(|e| (e.theta[k] - want).powi(2)).sum::<f64>() / r).sqrt();
    let cover = v.iter().filter(|e| e.cover[k]).count() as f64 / r;
    Stats {
        mean,
        se: sd / r.sqrt(),
        rmse,
        cover,
    }
}

fn contamination(reps: usize, n: usize, seed: u64, opts: &GmwmOptions) -> Result<bool, String> {
    let truth: Model = TRUTH.parse().map_err(|e| format!("{e}"))?;
    let t: Model = TEMPLATE.parse().map_err(|e| format!("{e}"))?;
    let want: Vec<f64> = truth
        .processes()
        .map_err(|e| e.to_string())?
        .iter()
        .flat_map(|p| p.params())
        .collect();
    let size = 20.0 * want[0].sqrt();
    // cost of one replicate, measured first (serially)
    let t0 = Instant::now();
    {
        let x = truth
            .simulate_stream(n, RATE, seed, 0)
            .map_err(|e| e.to_string())?
            .into_values();
        classical(&x, &t, opts, &want)?;
        robust(&x, &t, opts, &want)?;
    }
    let one = t0.elapsed().as_secs_f64();
    println!(
        "Cost of one replicate (clean series: simulate, classical and robust AV, two fits, two model covariances), measured serially before the run: {one:.2} s; the run does this twice per replicate (clean and contaminated) on {} threads.\n",
        rayon::current_num_threads()
    );
    let t0 = Instant::now();
    type Four = (Est, Est, Est, Est, usize);
    let out: Vec<Four> = (0..reps)
        .into_par_iter()
        .map(|r| -> Result<Four, String> {
            let mut x = truth
                .simulate_stream(n, RATE, seed, r as u64)
                .map_err(|e| e.to_string())?
                .into_values();
            let cc = classical(&x, &t, opts, &want)?;
            let cr = robust(&x, &t, opts, &want)?;
            let k = contaminate(&mut x, 0.005, size, seed, r as u64);
            let dc = classical(&x, &t, opts, &want)?;
            let dr = robust(&x, &t, opts, &want)?;
            Ok((cc, cr, dc, dr, k))
        })
        .collect::<Result<_, _>>()?;
    let secs = t0.elapsed().as_secs_f64();
    let hits: f64 = out.iter().map(|o| o.4 as f64).sum::<f64>() / (reps * n) as f64;
    println!(
        "## Robust vs classical GMWM: truth {TRUTH}; fitted {TEMPLATE}\n\nR = {reps}, T = {n}, seed {seed}, weighting {:?}, efficiency {}; outliers ±{size} (20σ_WN) at {:.3} % of the samples; {secs:.0} s.\n",
        opts.weighting,
        eff(),
        100.0 * hits
    );
    let mut ok = true;
    for (label, pick_c, pick_r) in [
        (
            "clean",
            (|o: &Four| &o.0) as fn(&Four) -> &Est,
            (|o: &Four| &o.1) as fn(&Four) -> &Est,
        ),
        ("0.5 % outliers of 20σ", |o: &Four| &o.2, |o: &Four| &o.3),
    ] {
        println!("### {label}\n");
        println!(
            "| parameter | truth | robust mean | robust bias/truth | MC SE/truth | \\|bias\\|/SE | classical bias/truth | RMSE robust | RMSE classical | ratio | cover robust | cover classical |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
        let vc: Vec<&Est> = out.iter().map(pick_c).collect();
        let vr: Vec<&Est> = out.iter().map(pick_r).collect();
        for k in 0..want.len() {
            let (c, r) = (stats(&vc, k, want[k]), stats(&vr, k, want[k]));
            let z = (r.mean - want[k]).abs() / r.se;
            let ratio = r.rmse / c.rmse;
            let pass = if label == "clean" {
                z <= 2.0 && ratio <= 1.4
            } else {
                ratio <= 0.5 && r.cover >= 0.9
            };
            ok &= pass;
            println!(
                "| {} | {:.4e} | {:.4e} | {:+.4} | {:.4} | {:.2} | {:+.4} | {:.3e} | {:.3e} | {:.3} | {:.1} % | {:.1} % |{}",
                NAMES[k],
                want[k],
                r.mean,
                (r.mean - want[k]) / want[k],
                r.se / want[k],
                z,
                (c.mean - want[k]) / want[k],
                r.rmse,
                c.rmse,
                ratio,
                100.0 * r.cover,
                100.0 * c.cover,
                if pass { "" } else { " **fails**" }
            );
        }
        println!(
            "\nacceptance ({}): {}\n",
            if label == "clean" {
                "robust |bias| ≤ 2 SE and RMSE ≤ 1.4× classical"
            } else {
                "robust RMSE ≤ 0.5× classical and robust coverage ≥ 90 %"
            },
            if ok { "PASS so far" } else { "FAIL" }
        );
    }
    Ok(ok)
}

fn equality(reps: usize, n: usize, seed: u64, opts: &GmwmOptions) -> Result<bool, String> {
    let t: Model = TEMPLATE.parse().map_err(|e| format!("{e}"))?;
    let cases = [
        ("equal (size)", TRUTH),
        (
            "RW γ² doubled (power)",
            "WN(sigma2=1e-4) + RW(gamma2=2e-10) + AR1(phi=0.995, sigma2=1e-7)",
        ),
        (
            "AR1 σ² doubled (power)",
            "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.995, sigma2=2e-7)",
        ),
    ];
    let a: Model = TRUTH.parse().map_err(|e| format!("{e}"))?;
    println!(
        "## Two-recording equality test (Wald, 5 %): {TEMPLATE}, R = {reps} pairs, T = {n} per recording, seed {seed}\n"
    );
    println!(
        "| second recording | rejected by Wald | rejected by the J-type moment test | failed fits | seconds |"
    );
    println!("|---|---|---|---|---|");
    let size_max = 0.05 + 2.0 * (0.05 * 0.95 / reps as f64).sqrt();
    let mut ok = true;
    for (ci, (label, second)) in cases.iter().enumerate() {
        let b: Model = second.parse().map_err(|e| format!("{e}"))?;
        let t0 = Instant::now();
        let res: Vec<Option<(bool, bool)>> = (0..reps)
            .into_par_iter()
            .map(|r| {
                let s = seed.wrapping_add(1000 * ci as u64);
                let xa = a
                    .simulate_stream(n, RATE, s, 2 * r as u64)
                    .ok()?
                    .into_values();
                let xb = b
                    .simulate_stream(n, RATE, s, 2 * r as u64 + 1)
                    .ok()?
                    .into_values();
                let curves: Vec<AvCurve> = [xa, xb]
                    .iter()
                    .map(|x| {
                        avar::allan_variance(x, RATE, &AvarConfig::default())
                            .ok()
                            .and_then(|av| AvCurve::from_avar(&av).ok())
                    })
                    .collect::<Option<_>>()?;
                let j = fit_joint(&curves, &t, opts, ALPHA).ok()?;
                Some((j.wald.p_value < 0.05, j.moments.p_value < 0.05))
            })
            .collect();
        let secs = t0.elapsed().as_secs_f64();
        let done: Vec<(bool, bool)> = res.iter().flatten().copied().collect();
        let rw = done.iter().filter(|d| d.0).count() as f64 / done.len().max(1) as f64;
        let rj = done.iter().filter(|d| d.1).count() as f64 / done.len().max(1) as f64;
        let pass = if ci == 0 { rw <= size_max } else { rw >= 0.9 };
        ok &= pass;
        println!(
            "| {label} | {:.1} % | {:.1} % | {} | {secs:.0} |{}",
            100.0 * rw,
            100.0 * rj,
            reps - done.len(),
            if pass { "" } else { " **fails**" }
        );
    }
    println!(
        "\nacceptance (size ≤ {:.1} %, power ≥ 90 %): {}\n",
        100.0 * size_max,
        if ok { "PASS" } else { "FAIL" }
    );
    Ok(ok)
}

/// Runs the report.
pub fn run(args: &[String]) -> Result<(), String> {
    let reps: usize = parsed(args, "--reps", 200)?;
    let n: usize = parsed(args, "--n", 1_000_000)?;
    let seed: u64 = parsed(args, "--seed", 20_261_125)?;
    let eq_reps: usize = parsed(args, "--eq-reps", 100)?;
    let eq_n: usize = parsed(args, "--eq-n", 1_000_000)?;
    let part: String = parsed(args, "--part", "all".to_string())?;
    let e: f64 = parsed(args, "--efficiency", 0.6)?;
    EFF_BITS.store(e.to_bits(), std::sync::atomic::Ordering::Relaxed);
    let w: String = parsed(args, "--weighting", "diag".to_string())?;
    let weighting = match w.as_str() {
        "diag" => Weighting::Diagonal,
        "model-full" => Weighting::ModelFull,
        other => return Err(format!("--weighting {other}: expected diag or model-full")),
    };
    let opts = GmwmOptions {
        weighting,
        ..GmwmOptions::default()
    };
    println!("# Robust and multi-recording fitting: Monte Carlo report ({RATE} Hz, 95 % CIs)\n");
    let mut ok = true;
    if part == "all" || part == "contam" {
        ok &= contamination(reps, n, seed, &opts)?;
    }
    if part == "all" || part == "equality" {
        ok &= equality(eq_reps, eq_n, seed, &opts)?;
    }
    println!("overall: {}", if ok { "PASS" } else { "FAIL" });
    Ok(())
}
