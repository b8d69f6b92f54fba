//! `cargo xtask gmwm-mc [--reps R] [--boot B] [--n T] [--seed S] [--case NAME]
//! [--weighting diag|model-diag|model-full] [--reweight K]`: Monte Carlo report of the
//! GMWM-type estimator of `gmwm-prep` (issue 5, acceptance "simulation").
//!
//! For each case (WN + RW + AR1; QN + WN + RW; WN + 2*AR1 with time constants a decade
//! apart; WN + RW + BI, the bias instability simulated over the band of the fitted scales;
//! AR2 + WN + RW, the AR(2) a damped oscillation of period 8 samples; SIN + WN; PLP + WN), R series of T samples are simulated with fixed seeds (replicate r = stream r,
//! replicates run in parallel), the MOAV is computed at the book's dyadic scales with
//! chi-square CIs (`avar` defaults), and
//! - the GMWM is fitted (default weighting of `GmwmOptions`, or `--weighting`);
//! - AVLR with automatically chosen windows is fitted (for WN/QN/RW/DR parameters);
//! - the delta-method CIs B V Bᵀ use V = the model covariance of the AV at θ̂
//!   (`inference::fit_covariance`, no bootstrap) — the acceptance coverage;
//! - with `--boot B` > 0, a parametric bootstrap of B replicates at θ̂ also gives delta-method
//!   CIs with the bootstrap V, percentile CIs and the bias-corrected estimate 2θ̂ − mean(θ*).
//!
//! Table: truth, mean, bias, MC standard error of the mean (sd/√R), |bias|/SE (acceptance ≤ 2),
//! RMSE of GMWM and AVLR, coverage of the 95 % CIs (acceptance 95 % ± 5 % for the model-V
//! delta method), and the bootstrap columns. Ends with the timing of 100 bootstrap
//! replications at T = 10^6.

use crate::args::parsed;
use avar::{AvarConfig, allan_variance};
use gmwm_prep::AvCurve;
use gmwm_prep::avlr::{AvlrWindows, avlr};
use gmwm_prep::bootstrap::{BootstrapOptions, parametric_bootstrap};
use gmwm_prep::gmwm::{GmwmOptions, Weighting, fit};
use gmwm_prep::inference::{delta_method, diagonal_covariance, fit_covariance};
use processes::{Model, ProcessKind};
use std::time::Instant;

const ALPHA: f64 = 0.05;
/// `--reweight K`: reweighting steps of the diagonal weighting (GmwmOptions default 8).
static REWEIGHT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(8);
/// `--weighting diag|model-diag|model-full` (0, 1, 2): GmwmOptions::weighting.
static WEIGHTING: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

fn weighting() -> Weighting {
    match WEIGHTING.load(std::sync::atomic::Ordering::Relaxed) {
        1 => Weighting::ModelDiagonal,
        2 => Weighting::ModelFull,
        _ => Weighting::Diagonal,
    }
}
const RATE: f64 = 100.0;

struct Rep {
    theta: Vec<f64>,
    /// bootstrap bias-corrected estimate 2θ̂ − mean θ*
    theta_bc: Option<Vec<f64>>,
    avlr: Vec<Option<f64>>,
    /// delta method with V = the model covariance of the AV at θ̂ (no bootstrap); `None`
    /// where the model covariance is not implemented (AR2/AR3/AR4, PLP, FGN) or the model has
    /// no Gaussian covariance (a SIN): the acceptance then uses the bootstrap V
    cover_model: Option<Vec<bool>>,
    /// delta method with V = diag of the curve's CI variances (ignores the correlations)
    cover_diag: Vec<bool>,
    /// delta method with V = the bootstrap covariance, and percentile CIs (with --boot B > 0)
    cover_delta: Option<Vec<bool>>,
    cover_pct: Option<Vec<bool>>,
    converged: bool,
}

fn one_rep(
    truth: &Model,
    template: &Model,
    n: usize,
    seed: u64,
    r: u64,
    boot: usize,
    want: &[f64],
) -> Result<Rep, String> {
    let x = truth
        .simulate_stream(n, RATE, seed, r)
        .map_err(|e| e.to_string())?;
    let av = allan_variance(x.values(), RATE, &AvarConfig::default()).map_err(|e| e.to_string())?;
    drop(x);
    let curve = AvCurve::from_avar(&av).map_err(|e| e.to_string())?;
    let opts = GmwmOptions {
        reweight_iterations: REWEIGHT.load(std::sync::atomic::Ordering::Relaxed),
        weighting: weighting(),
        ..GmwmOptions::default()
    };
    let f = fit(&curve, template, &opts).map_err(|e| e.to_string())?;
    // AVLR with automatic windows, mapped onto the template's parameters
    let mut avlr_theta = vec![None; f.theta.len()];
    if let Ok(w) = AvlrWindows::auto(&curve)
        && let Ok(a) = avlr(&curve, &w)
    {
        let mut at = 0;
        for k in &f.kinds {
            if let Some(e) = a.get(*k)
                && matches!(
                    k,
                    ProcessKind::WhiteNoise
                        | ProcessKind::QuantizationNoise
                        | ProcessKind::RandomWalk
                )
            {
                avlr_theta[at] = Some(e.per_sample);
            }
            at += k.n_params();
        }
    }
    let covers = |ci: &[(f64, f64)]| -> Vec<bool> {
        ci.iter()
            .zip(want)
            .map(|(c, w)| c.0 <= *w && *w <= c.1)
            .collect()
    };
    // the model covariance assumes a Gaussian process (not a random-phase SIN) and is not
    // implemented for every kind (AR(p), the long-memory PLP/FGN): then the acceptance
    // coverage is the bootstrap-V one (run with --boot B > 0)
    let gaussian = !f.kinds.iter().any(|k| {
        matches!(
            k,
            ProcessKind::Sinusoid | ProcessKind::Plp | ProcessKind::Fgn
        )
    });
    let cover_model = match (gaussian, fit_covariance(&f)) {
        (true, Ok(v_model)) => Some(covers(
            &delta_method(&f, &v_model, ALPHA)
                .map_err(|e| e.to_string())?
                .ci,
        )),
        _ => None,
    };
    let cover_diag = covers(
        &delta_method(&f, &diagonal_covariance(&curve), ALPHA)
            .map_err(|e| e.to_string())?
            .ci,
    );
    let (mut cover_delta, mut cover_pct, mut theta_bc) = (None, None, None);
    if boot > 0 {
        let b = parametric_bootstrap(
            &f,
            template,
            &opts,
            &BootstrapOptions::new(boot, seed ^ 0x9e37_79b9_7f4a_7c15 ^ r, n),
        )
        .map_err(|e| e.to_string())?;
        let inf = delta_method(&f, &b.av_cov, ALPHA).map_err(|e| e.to_string())?;
        cover_delta = Some(covers(&inf.ci));
        cover_pct = Some(covers(&b.ci));
        let p = f.theta.len();
        theta_bc = Some(
            (0..p)
                .map(|k| {
                    let mean = b.theta.iter().map(|t| t[k]).sum::<f64>() / b.theta.len() as f64;
                    2.0 * f.theta[k] - mean
                })
                .collect(),
        );
    }
    Ok(Rep {
        theta_bc,
        theta: f.theta,
        avlr: avlr_theta,
        cover_model,
        cover_diag,
        cover_delta,
        cover_pct,
        converged: f.convergence.converged,
    })
}

/// The band of cluster sizes (first to last m) of the default MOAV of `n` samples.
fn fit_band(n: usize) -> Result<processes::BiBand, String> {
    let wn: Model = "WN(sigma2=1)"
        .parse()
        .map_err(|e: processes::ProcessError| e.to_string())?;
    let x = wn.simulate(n, RATE, 1).map_err(|e| e.to_string())?;
    let av = allan_variance(x.values(), RATE, &AvarConfig::default()).map_err(|e| e.to_string())?;
    let (lo, hi) = match (av.points.first(), av.points.last()) {
        (Some(a), Some(b)) => (a.m, b.m),
        _ => return Err(format!("no scales for n = {n}")),
    };
    processes::BiBand::new(lo, hi).map_err(|e| e.to_string())
}

fn case(
    name: &str,
    truth: &str,
    template: &str,
    reps: usize,
    boot: usize,
    n: usize,
    seed: u64,
) -> Result<bool, String> {
    let truth_m: Model = truth.parse().map_err(|e| format!("{truth}: {e}"))?;
    // a BI without a band is simulated over the band the fit will give it: the scales of the
    // MOAV of T samples
    let truth_m = truth_m
        .with_bi_band(fit_band(n)?)
        .map_err(|e| e.to_string())?;
    let template_m: Model = template.parse().map_err(|e| format!("{template}: {e}"))?;
    let want: Vec<f64> = truth_m
        .processes()
        .map_err(|e| e.to_string())?
        .iter()
        .flat_map(|p| p.params())
        .collect();
    let names: Vec<String> = truth_m
        .kinds()
        .iter()
        .enumerate()
        .flat_map(|(i, k)| {
            k.param_names()
                .iter()
                .map(move |p| format!("{}{}.{}", k.code(), i, p))
        })
        .collect();
    let t0 = Instant::now();
    // replicates in parallel (replicate r is stream r: the result does not depend on threads)
    use rayon::prelude::*;
    let out: Vec<Rep> = (0..reps)
        .into_par_iter()
        .map(|r| one_rep(&truth_m, &template_m, n, seed, r as u64, boot, &want))
        .collect::<Result<_, _>>()?;
    let secs = t0.elapsed().as_secs_f64();
    let rf = reps as f64;
    println!("## {name}: truth {truth}; fitted {template}");
    println!(
        "R = {reps} replications, T = {n}, B = {boot} bootstrap replicates each, seed {seed}, weighting {:?}, {:.0} s; converged {}/{reps}\n",
        weighting(),
        secs,
        out.iter().filter(|r| r.converged).count()
    );
    println!(
        "| parameter | truth | mean | bias/truth | MC SE/truth | \\|bias\\|/SE | RMSE GMWM | RMSE AVLR | cover delta (model V) | cover delta (boot V) | cover pct | BC bias/truth | BC \\|bias\\|/SE | BC RMSE | cover delta (diag V) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut ok = true;
    let mut no_coverage = false;
    for k in 0..want.len() {
        let v: Vec<f64> = out.iter().map(|r| r.theta[k]).collect();
        let mean = v.iter().sum::<f64>() / rf;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (rf - 1.0)).sqrt();
        let se = sd / rf.sqrt();
        let bias = mean - want[k];
        let rmse = (v.iter().map(|x| (x - want[k]).powi(2)).sum::<f64>() / rf).sqrt();
        let av: Vec<f64> = out.iter().filter_map(|r| r.avlr[k]).collect();
        let rmse_avlr = if av.len() == reps {
            let x = (av.iter().map(|x| (x - want[k]).powi(2)).sum::<f64>() / rf).sqrt();
            if rmse >= x {
                ok = false;
            }
            format!("{x:.3e}")
        } else if av.is_empty() {
            "–".into()
        } else {
            format!("({} of {reps})", av.len())
        };
        let pct = |c: Option<f64>| c.map_or("–".to_string(), |c| format!("{:.1} %", 100.0 * c));
        let share = |f: &dyn Fn(&Rep) -> Option<bool>| -> Option<f64> {
            let v: Option<Vec<bool>> = out.iter().map(f).collect();
            v.map(|v| v.iter().filter(|x| **x).count() as f64 / rf)
        };
        let cm = share(&|r| r.cover_model.as_ref().map(|c| c[k]));
        let cdg = share(&|r| Some(r.cover_diag[k])).unwrap_or(0.0);
        let cd = share(&|r| r.cover_delta.as_ref().map(|c| c[k]));
        let cp = share(&|r| r.cover_pct.as_ref().map(|c| c[k]));
        let bc = if out.iter().all(|r| r.theta_bc.is_some()) {
            let vb: Vec<f64> = out
                .iter()
                .filter_map(|r| r.theta_bc.as_ref().map(|t| t[k]))
                .collect();
            let mb = vb.iter().sum::<f64>() / rf;
            let sb =
                (vb.iter().map(|x| (x - mb).powi(2)).sum::<f64>() / (rf - 1.0)).sqrt() / rf.sqrt();
            let rb = (vb.iter().map(|x| (x - want[k]).powi(2)).sum::<f64>() / rf).sqrt();
            format!(
                "{:+.4} | {:.2} | {:.3e}",
                (mb - want[k]) / want[k],
                (mb - want[k]).abs() / sb,
                rb
            )
        } else {
            "– | – | –".to_string()
        };
        let z = bias.abs() / se;
        // the acceptance coverage: model V, else (not implemented for the kind) bootstrap V,
        // else (no bootstrap run) not assessed
        let cover = cm.or(cd);
        if cover.is_none() {
            no_coverage = true;
        }
        if z > 2.0 || cover.is_some_and(|c| (c - 0.95).abs() > 0.05) {
            ok = false;
        }
        println!(
            "| {} | {:.4e} | {:.4e} | {:+.4} | {:.4} | {:.2} | {:.3e} | {} | {} | {} | {} | {} | {:.1} % |",
            names[k],
            want[k],
            mean,
            bias / want[k],
            se / want[k].abs(),
            z,
            rmse,
            rmse_avlr,
            pct(cm),
            pct(cd),
            pct(cp),
            bc,
            100.0 * cdg
        );
    }
    println!(
        "\nacceptance (|bias| ≤ 2 SE, RMSE < AVLR where AVLR estimates, delta coverage with the model V (bootstrap V where the model V is not implemented or the model is not Gaussian) in 95 % ± 5 %): {}{}\n",
        if ok { "PASS" } else { "FAIL" },
        if no_coverage {
            " (coverage not assessed: no model V for this model and no bootstrap; run with --boot B)"
        } else {
            ""
        }
    );
    Ok(ok)
}

fn speed(n: usize, seed: u64) -> Result<(), String> {
    let truth: Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.995, sigma2=1e-7)"
        .parse()
        .map_err(|e: processes::ProcessError| e.to_string())?;
    let template = truth.template();
    let x = truth.simulate(n, RATE, seed).map_err(|e| e.to_string())?;
    let av = allan_variance(x.values(), RATE, &AvarConfig::default()).map_err(|e| e.to_string())?;
    let curve = AvCurve::from_avar(&av).map_err(|e| e.to_string())?;
    let opts = GmwmOptions::default();
    let f = fit(&curve, &template, &opts).map_err(|e| e.to_string())?;
    let t0 = Instant::now();
    let b = parametric_bootstrap(&f, &template, &opts, &BootstrapOptions::new(100, seed, n))
        .map_err(|e| e.to_string())?;
    let s = t0.elapsed().as_secs_f64();
    println!(
        "## speed\n100 bootstrap replications (simulate T = {n}, MOAV with chi-square CIs, refit) of WN + RW + AR1: {s:.1} s on {} threads ({} refits failed); acceptance ≤ 60 s: {}\n",
        rayon::current_num_threads(),
        b.failed,
        if s <= 60.0 { "PASS" } else { "FAIL" }
    );
    Ok(())
}

/// Runs the report.
pub fn run(args: &[String]) -> Result<(), String> {
    let reps: usize = parsed(args, "--reps", 100)?;
    let boot: usize = parsed(args, "--boot", 50)?;
    let n: usize = parsed(args, "--n", 1_000_000)?;
    let seed: u64 = parsed(args, "--seed", 20_261_121)?;
    let which: String = parsed(args, "--case", "all".to_string())?;
    let rw: usize = parsed(
        args,
        "--reweight",
        GmwmOptions::default().reweight_iterations,
    )?;
    REWEIGHT.store(rw, std::sync::atomic::Ordering::Relaxed);
    let w: String = parsed(args, "--weighting", "default".to_string())?;
    let wi = match w.as_str() {
        "default" => match GmwmOptions::default().weighting {
            Weighting::ModelDiagonal => 1,
            Weighting::ModelFull => 2,
            _ => 0,
        },
        "diag" => 0,
        "model-diag" => 1,
        "model-full" => 2,
        other => {
            return Err(format!(
                "--weighting {other}: expected diag, model-diag or model-full"
            ));
        }
    };
    WEIGHTING.store(wi, std::sync::atomic::Ordering::Relaxed);
    println!(
        "# gmwm-prep Monte Carlo report ({RATE} Hz, nominal CI level {:.0} %)\n",
        100.0 * (1.0 - ALPHA)
    );
    let cases = [
        (
            "wn-rw-ar1",
            "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.995, sigma2=1e-7)",
            "WN + RW + AR1",
        ),
        (
            "qn-wn-rw",
            "QN(q2=1e-5) + WN(sigma2=1e-4) + RW(gamma2=1e-10)",
            "QN + WN + RW",
        ),
        (
            "wn-2ar1",
            "WN(sigma2=1e-4) + AR1(phi=0.99, sigma2=1e-7) + AR1(phi=0.999, sigma2=1e-8)",
            "WN + 2*AR1",
        ),
        // bias instability (issue 28): plateau 0.4413·B² = 2.2e-7 between the WN and RW
        // crossings at m ≈ 460 and 6500
        (
            "wn-rw-bi",
            "WN(sigma2=1e-4) + RW(gamma2=1e-10) + BI(B=7e-4)",
            "WN + RW + BI",
        ),
        // AR(2) with complex roots (issue 28): r = √0.81 = 0.9, cos θ = φ1/(2r) = 0.70711,
        // period 2π/θ = 8.0 samples (12.5 Hz at 100 Hz), a damped oscillation. Its AV bump
        // dominates m = 2…4 (6.5e-5 against the WN's 5e-5 and 2.5e-5), the WN m = 16…1000
        // (the AR2's long-run variance σ²/(1 − φ1 − φ2)² = 5.2e-5 is half the WN's), the RW
        // m ≥ 2500
        (
            "ar2-wn-rw",
            "AR2(phi1=1.2728, phi2=-0.81, sigma2=1.5e-5) + WN(sigma2=1e-4) + RW(gamma2=1e-10)",
            "AR2 + WN + RW",
        ),
        // random-phase sinusoid (issue 28): period 2π/0.5 ≈ 12.6 samples; its AV
        // α² sin⁴(βm/2) / (m² sin²(β/2)) is 0.51·α² at m = 4, twice the WN's AV there
        (
            "sin-wn",
            "SIN(alpha2=1e-4, beta=0.5) + WN(sigma2=1e-4)",
            "SIN + WN",
        ),
        // long memory (issue 28): ARFIMA(0, 0.3, 0), AV ∝ m^{-0.4}, over a WN of the same
        // innovation variance (the WN dominates the AV at the smallest scales, the PLP at
        // the large ones)
        (
            "plp-wn",
            "PLP(sigma2=1e-4, d=0.3) + WN(sigma2=1e-4)",
            "PLP + WN",
        ),
    ];
    // not an acceptance case: the slow AR1 carries a tenth of the fast one's variance and
    // is barely visible in the AV (reported to show where the estimator's bias appears)
    let stress = (
        "wn-2ar1-weak",
        "WN(sigma2=1e-4) + AR1(phi=0.99, sigma2=1e-7) + AR1(phi=0.999, sigma2=1e-9)",
        "WN + 2*AR1",
    );
    let mut all = true;
    for (name, truth, template) in cases {
        if which == "all" || which == name {
            all &= case(name, truth, template, reps, boot, n, seed)?;
        }
    }
    if which == "all" || which == stress.0 {
        println!("### stress case (not part of the acceptance)\n");
        case(stress.0, stress.1, stress.2, reps, boot, n, seed)?;
    }
    if which == "all" || which == "speed" {
        speed(n, seed)?;
    }
    println!("overall: {}", if all { "PASS" } else { "FAIL" });
    Ok(())
}
