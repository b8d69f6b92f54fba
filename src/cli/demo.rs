//! `imunoise demo`: a simulated 6-axis MEMS IMU with known noise, analysed end to end.
//!
//! The true models (per sample, at 100 Hz; units °/s for the gyros, m/s² for the
//! accelerometers) are in [`DEMO_IMU`] and printed by `imunoise demo --help`.

use super::Ui;
use crate::error::{Error, Result};
use crate::pipeline::fit::LevelCis;
use crate::pipeline::report::num;
use avar::{AllanVariance, AvarConfig};
use gmwm_prep::units::{IeeeTerm, process_ieee};

use processes::{Model, Unit};
use serde::Serialize;
use std::io::Write;

/// One channel of the demo IMU: name, unit and true model (per-sample parameters).
#[derive(Debug, Clone, Copy)]
pub struct DemoChannel {
    /// Channel name.
    pub name: &'static str,
    /// Unit text (`deg/s` or `m/s^2`).
    pub unit: &'static str,
    /// True model in the text form of `processes::Model`.
    pub model: &'static str,
}

/// The demo IMU: a mid-grade MEMS unit at 100 Hz. Gyros: angle random walk
/// N = 0.3 °/√h (σ² = 2.5e-3 (°/s)²), rate random walk K ≈ 6 °/h/√h (γ² = 7.7e-12),
/// a Gauss-Markov bias of correlation time ≈ 10 s and σ ≈ 7 °/h (AR1 φ = 0.999).
/// Accelerometers: velocity random walk N = 0.03 m/s/√h (σ² = 2.5e-5 (m/s²)²), K ≈
/// 4.3 m/s/h/√h (γ² = 4e-12), a bias of correlation time ≈ 10 s and σ ≈ 20 µg (φ = 0.999).
/// The axes differ slightly, as real ones do.
pub const DEMO_IMU: [DemoChannel; 6] = [
    DemoChannel {
        name: "gyro_x",
        unit: "deg/s",
        model: "WN(sigma2=2.5e-3) + RW(gamma2=7.7e-12) + AR1(phi=0.999, sigma2=8e-9)",
    },
    DemoChannel {
        name: "gyro_y",
        unit: "deg/s",
        model: "WN(sigma2=2.2e-3) + RW(gamma2=9e-12) + AR1(phi=0.999, sigma2=6e-9)",
    },
    DemoChannel {
        name: "gyro_z",
        unit: "deg/s",
        model: "WN(sigma2=3e-3) + RW(gamma2=6e-12) + AR1(phi=0.998, sigma2=1.2e-8)",
    },
    DemoChannel {
        name: "acc_x",
        unit: "m/s^2",
        model: "WN(sigma2=2.5e-5) + RW(gamma2=4e-12) + AR1(phi=0.999, sigma2=8e-11)",
    },
    DemoChannel {
        name: "acc_y",
        unit: "m/s^2",
        model: "WN(sigma2=2.8e-5) + RW(gamma2=3e-12) + AR1(phi=0.999, sigma2=8e-11)",
    },
    DemoChannel {
        name: "acc_z",
        unit: "m/s^2",
        model: "WN(sigma2=3.2e-5) + RW(gamma2=5e-12) + AR1(phi=0.999, sigma2=1e-10)",
    },
];

/// Sampling rate of the demo IMU (Hz).
pub const DEMO_RATE_HZ: f64 = 100.0;

/// Examples shown by `imunoise demo --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise demo
  imunoise demo --samples 4000000 --seed 7
  imunoise demo --bootstrap 100 --out /tmp/demo

It fits WN + RW + AR1 to each axis by GMWM. The CIs are delta-method intervals with the exact
covariance of the Allan variance estimates implied by the fitted model (or, with --bootstrap B,
its parametric-bootstrap estimate). Next to each marginal 95% CI it prints a simultaneous
interval: Bonferroni over all K = 24 parameters (each at level 1 - 0.05/24 = 99.79%), which
cover all true values together with probability >= 95%. \"Recovered\" is judged on those.

The simulated IMU (100 Hz, parameters per sample):
  gyro_x [deg/s]  WN(sigma2=2.5e-3) + RW(gamma2=7.7e-12) + AR1(phi=0.999,  sigma2=8e-9)
  gyro_y [deg/s]  WN(sigma2=2.2e-3) + RW(gamma2=9e-12)   + AR1(phi=0.999,  sigma2=6e-9)
  gyro_z [deg/s]  WN(sigma2=3e-3)   + RW(gamma2=6e-12)   + AR1(phi=0.998,  sigma2=1.2e-8)
  acc_x [m/s^2]   WN(sigma2=2.5e-5) + RW(gamma2=4e-12)   + AR1(phi=0.999,  sigma2=8e-11)
  acc_y [m/s^2]   WN(sigma2=2.8e-5) + RW(gamma2=3e-12)   + AR1(phi=0.999,  sigma2=8e-11)
  acc_z [m/s^2]   WN(sigma2=3.2e-5) + RW(gamma2=5e-12)   + AR1(phi=0.999,  sigma2=1e-10)
i.e. gyros N ≈ 0.3 °/√h, K ≈ 6 °/h/√h, a 5–10 s Gauss-Markov bias of ≈ 6–7 °/h;
accelerometers N ≈ 0.03 m/s/√h, K ≈ 4 m/s/h/√h, a 10 s bias of ≈ 20 µg.";

/// Arguments of `imunoise demo`.
#[derive(Debug, Clone, clap::Args)]
pub struct DemoArgs {
    /// Samples per channel (at 100 Hz; the default is 2^20 ≈ 2.9 h).
    #[arg(short = 'n', long = "samples", default_value_t = 1 << 20)]
    pub n: usize,
    /// Random seed of the simulation.
    #[arg(long, short, default_value_t = 2024)]
    pub seed: u64,
    /// Output directory of the analysis report (report.html, plots, results.json, avar.csv,
    /// imu.yaml, and demo.json: true against estimated values with both intervals).
    #[arg(long, short, default_value = "imunoise-demo")]
    pub out: std::path::PathBuf,
    /// CIs from a B-replicate parametric-bootstrap covariance of the AV instead of the
    /// exact model-implied one (0, the default: no simulation, no Monte Carlo noise in V).
    #[arg(long, default_value_t = 0, value_name = "B")]
    pub bootstrap: usize,
}

/// The demo's simulated record: names, units, true models and samples.
pub struct DemoData {
    /// Channel names.
    pub names: Vec<String>,
    /// Channel units.
    pub units: Vec<Unit>,
    /// True models.
    pub models: Vec<Model>,
    /// Samples, one vector per channel.
    pub columns: Vec<Vec<f64>>,
}

/// Simulates the demo IMU: channel k is stream k of `seed`.
pub fn simulate(n: usize, seed: u64) -> Result<DemoData> {
    use rayon::prelude::*;
    let models: Vec<Model> = DEMO_IMU
        .iter()
        .map(|c| c.model.parse::<Model>())
        .collect::<std::result::Result<_, _>>()?;
    let columns = models
        .par_iter()
        .enumerate()
        .map(|(k, m)| {
            m.simulate_stream(n, DEMO_RATE_HZ, seed, k as u64)
                .map(|t| t.into_values())
        })
        .collect::<std::result::Result<Vec<_>, _>>()?;
    Ok(DemoData {
        names: DEMO_IMU.iter().map(|c| c.name.to_string()).collect(),
        units: DEMO_IMU
            .iter()
            .map(|c| c.unit.parse::<Unit>())
            .collect::<std::result::Result<_, _>>()?,
        models,
        columns,
    })
}

/// The true IEEE value of `term` in a model (from its WN/RW/QN/DR component), if any.
pub fn true_ieee(model: &Model, term: IeeeTerm, unit: &Unit) -> Option<(f64, String)> {
    let procs = model.processes().ok()?;
    procs.iter().find_map(|p| {
        let q = process_ieee(p.kind(), &p.params(), DEMO_RATE_HZ, unit);
        let first = q.first()?;
        (first.name == term.symbol()).then(|| (first.value, first.unit.clone()))
    })
}

/// True against estimated value of one parameter (or IEEE 952 term).
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    /// Channel name.
    pub channel: String,
    /// Process code and parameter name, e.g. `"RW gamma2"`, or the IEEE term (`"N"`, `"K"`).
    pub parameter: String,
    /// Unit of `truth` and `estimate` (empty for per-sample parameters).
    #[serde(skip_serializing_if = "String::is_empty")]
    pub unit: String,
    /// True value.
    pub truth: f64,
    /// Estimate.
    pub estimate: f64,
    /// Marginal CI (level 1 − alpha), if any.
    pub ci: Option<(f64, f64)>,
    /// Simultaneous interval (Bonferroni, level 1 − alpha/K), if any.
    pub sim_ci: Option<(f64, f64)>,
}

fn covers(ci: Option<(f64, f64)>, x: f64) -> Option<bool> {
    ci.map(|(a, b)| a <= x && x <= b)
}

impl Comparison {
    /// Whether the marginal CI covers the truth.
    pub fn covered(&self) -> Option<bool> {
        covers(self.ci, self.truth)
    }
    /// Whether the simultaneous interval covers the truth.
    pub fn sim_covered(&self) -> Option<bool> {
        covers(self.sim_ci, self.truth)
    }
}

/// Compares the fitted parameters (model order) with the true model's; `sim` are the
/// simultaneous intervals of the same parameters, if computed.
pub fn compare(
    name: &str,
    truth: &Model,
    fit: &crate::pipeline::fit::ChannelFit,
    sim: Option<&LevelCis>,
) -> Vec<Comparison> {
    let true_params: Vec<f64> = truth
        .processes()
        .map(|ps| ps.iter().flat_map(|p| p.params()).collect())
        .unwrap_or_default();
    fit.parameters
        .iter()
        .zip(true_params)
        .enumerate()
        .map(|(i, (p, t))| Comparison {
            channel: name.to_string(),
            parameter: format!("{} {}", p.process, p.name),
            unit: String::new(),
            truth: t,
            estimate: p.value,
            ci: p.ci_lo.zip(p.ci_hi),
            sim_ci: sim.and_then(|s| s.parameters.get(i).copied()),
        })
        .collect()
}

/// The IEEE 952 terms N and K of a channel: true against estimated, with both intervals.
pub fn compare_ieee(
    name: &str,
    truth: &Model,
    unit: &Unit,
    fit: &crate::pipeline::fit::ChannelFit,
    sim: Option<&LevelCis>,
) -> Vec<Comparison> {
    [IeeeTerm::N, IeeeTerm::K]
        .into_iter()
        .filter_map(|term| {
            let (t, u) = true_ieee(truth, term, unit)?;
            let est = fit.ieee.get(term.symbol())?;
            let s = sim.and_then(|s| s.ieee.get(term.symbol()));
            Some(Comparison {
                channel: name.to_string(),
                parameter: term.symbol().to_string(),
                unit: u,
                truth: t,
                estimate: est.value,
                ci: est.ci_lo.zip(est.ci_hi),
                sim_ci: s.and_then(|s| s.ci_lo.zip(s.ci_hi)),
            })
        })
        .collect()
}

/// `demo.json`: the demo's true against estimated values with both kinds of interval.
#[derive(Debug, Serialize)]
pub struct DemoJson<'a> {
    /// Family level: the simultaneous intervals cover all parameters jointly with ≥ 1 − alpha.
    pub alpha: f64,
    /// Number of parameters K in the Bonferroni family.
    pub k: usize,
    /// `"bonferroni"`.
    pub simultaneous_method: &'static str,
    /// Level of each simultaneous interval, 1 − alpha/K.
    pub simultaneous_level: f64,
    /// How the marginal intervals were computed (as `ci_method` of `imunoise fit`).
    pub ci_method: crate::pipeline::fit::CiMethod,
    /// Per-sample parameters.
    pub parameters: &'a [Comparison],
    /// IEEE 952 terms N and K (functions of WN σ² and RW γ², so in the same family).
    pub ieee: &'a [Comparison],
}

fn interval(ci: Option<(f64, f64)>, f: impl Fn(f64) -> String) -> String {
    ci.map_or("-".into(), |(a, b)| format!("[{}, {}]", f(a), f(b)))
}

fn yes_no(c: Option<bool>, no: &str) -> String {
    match c {
        Some(true) => "yes".into(),
        Some(false) => no.into(),
        None => "-".into(),
    }
}

/// Counts (covered, with an interval) among comparisons, on the simultaneous (`sim`) or the
/// marginal intervals.
pub fn count_covered(v: &[Comparison], sim: bool) -> (usize, usize) {
    let c: Vec<Option<bool>> = v
        .iter()
        .map(|c| if sim { c.sim_covered() } else { c.covered() })
        .collect();
    (
        c.iter().filter(|x| **x == Some(true)).count(),
        c.iter().filter(|x| x.is_some()).count(),
    )
}

/// Everything the demo estimates: the simulated record, its AV, the fits, and true against
/// estimated values with marginal and simultaneous intervals.
pub struct DemoRun {
    /// The simulated record (names, units, true models; `columns` moved into `table`).
    pub table: crate::io::Table,
    /// Channel units.
    pub units: Vec<Unit>,
    /// True models.
    pub models: Vec<Model>,
    /// Allan variance of each channel.
    pub curves: Vec<(String, AllanVariance)>,
    /// GMWM fit of each channel.
    pub fits: Vec<crate::pipeline::fit::ChannelFit>,
    /// Per-sample parameters, true against estimated.
    pub params: Vec<Comparison>,
    /// IEEE 952 N and K, true against estimated.
    pub ieee: Vec<Comparison>,
    /// Family level alpha (0.05).
    pub alpha: f64,
    /// Number K of parameters in the Bonferroni family.
    pub k: usize,
    /// How the marginal CIs were computed.
    pub ci_method: crate::pipeline::fit::CiMethod,
}

impl DemoRun {
    /// Level of each simultaneous interval, alpha/K.
    pub fn alpha_sim(&self) -> f64 {
        self.alpha / self.k as f64
    }
}

/// Simulates the demo IMU (`n` samples per channel, `seed`), computes the AV, fits the true
/// template WN + RW + AR1 by GMWM (CIs from the model-implied covariance of the AV, or from a
/// `bootstrap`-replicate parametric bootstrap when > 0) and compares with the truth, with
/// simultaneous Bonferroni intervals over all K parameters next to the marginal 95% CIs.
///
/// ```no_run
/// use imunoise::cli::{Ui, demo};
/// let ui = Ui { progress: false, notes: false };
/// let run = demo::estimate(1 << 20, 7, 0, &ui)?;
/// let (covered, total) = demo::count_covered(&run.params, true);
/// println!("{covered} of {total} true parameters within their simultaneous 95% intervals");
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn estimate(n: usize, seed: u64, bootstrap: usize, ui: &Ui) -> Result<DemoRun> {
    if n < 1 << 14 {
        return Err(Error::Usage(
            "--samples: the demo needs at least 16384 samples per channel".into(),
        ));
    }
    if bootstrap == 1 {
        return Err(Error::Usage(
            "--bootstrap: a bootstrap needs at least 2 replicates (0: no bootstrap)".into(),
        ));
    }
    let pb = ui.spinner("simulating the demo IMU");
    let data = simulate(n, seed)?;
    pb.finish_and_clear();
    let table = crate::io::Table {
        file: "<demo>".into(),
        names: data.names,
        columns: data.columns.into_iter().map(Into::into).collect(),
        rate_hz: Some(DEMO_RATE_HZ),
        timing: None,
        topic: None,
    };
    let curves: Vec<(String, AllanVariance)> =
        crate::pipeline::estimate::compute(&table, DEMO_RATE_HZ, &AvarConfig::default(), ui)?;
    // The true template (the structure is known; its values are estimated).
    let alpha = 0.05;
    let settings = crate::pipeline::fit::FitSettings {
        model: data.models[0].template().to_string(),
        method: crate::pipeline::fit::Method::Gmwm,
        select: false,
        bootstrap,
        seed: seed.wrapping_add(1),
        alpha,
        weighting: crate::pipeline::fit::FitWeighting::Diagonal,
        tau_min: None,
        tau_max: None,
    };
    let fits = crate::pipeline::fit::fit_all(&curves, &data.units, &settings, ui)?;
    // Simultaneous intervals: Bonferroni over every parameter of every channel.
    let k: usize = fits.iter().map(|f| f.parameters.len()).sum();
    let sims = fits
        .iter()
        .map(|f| f.cis_at(alpha / k as f64))
        .collect::<Result<Vec<_>>>()?;
    let mut params = Vec::new();
    let mut ieee = Vec::new();
    for (i, f) in fits.iter().enumerate() {
        let name = &table.names[i];
        params.extend(compare(name, &data.models[i], f, sims[i].as_ref()));
        ieee.extend(compare_ieee(
            name,
            &data.models[i],
            &data.units[i],
            f,
            sims[i].as_ref(),
        ));
    }
    let ci_method = fits
        .first()
        .map_or(crate::pipeline::fit::CiMethod::None, |f| f.ci_method);
    Ok(DemoRun {
        table,
        units: data.units,
        models: data.models,
        curves,
        fits,
        params,
        ieee,
        alpha,
        k,
        ci_method,
    })
}

/// Runs `imunoise demo`.
pub fn run(args: &DemoArgs, ui: &Ui) -> Result<()> {
    crate::output::create_dir(&args.out, "--out")?;
    let t0 = std::time::Instant::now();
    let r = estimate(args.n, args.seed, args.bootstrap, ui)?;
    let (alpha, k, alpha_sim, ci_method) = (r.alpha, r.k, r.alpha_sim(), r.ci_method);
    let (params, ieee) = (&r.params, &r.ieee);
    let count = count_covered;
    let model = r.models[0].template().to_string();
    let level = crate::pipeline::fit::percent(1.0 - alpha);
    let sim_level = crate::pipeline::fit::percent(1.0 - alpha_sim);
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let mut w = |s: String| writeln!(out, "{s}").map_err(|e| Error::write("<stdout>", e));
    w(format!(
        "imunoise demo: simulated 6-axis MEMS IMU, {} samples per channel at {} Hz ({:.1} h), seed {}",
        args.n,
        DEMO_RATE_HZ,
        args.n as f64 / DEMO_RATE_HZ / 3600.0,
        args.seed
    ))?;
    w(format!(
        "GMWM fit of {} on the Allan variance; CIs by {}.",
        model,
        ci_method.describe(args.bootstrap)
    ))?;
    w(format!(
        "Simultaneous {level} intervals: Bonferroni over all K = {k} parameters, each at level 1 - {alpha}/{k} = {sim_level},\n\
         so that all {k} cover their true values together with probability >= {level} (as far as the\n\
         delta method's large-sample intervals are exact). A marginal {level} CI covers its own parameter\n\
         with {level}; all {k} at once cover only with about {:.0}% if independent.",
        100.0 * (1.0 - alpha).powi(k as i32)
    ))?;
    w(format!(
        "{:<8} {:<11} {:>11} {:>11} {:>25} {:>25}  {}",
        "channel",
        "parameter",
        "true",
        "estimate",
        format!("{level} CI"),
        format!("simultaneous {sim_level}"),
        "covered (sim. / marg.)"
    ))?;
    let e4 = |x: f64| format!("{x:.3e}");
    for c in params {
        w(format!(
            "{:<8} {:<11} {:>11.4e} {:>11.4e} {:>25} {:>25}  {} / {}",
            c.channel,
            c.parameter,
            c.truth,
            c.estimate,
            interval(c.ci, e4),
            interval(c.sim_ci, e4),
            yes_no(c.sim_covered(), "NO"),
            yes_no(c.covered(), "no"),
        ))?;
    }
    let (sc, sn) = count(params, true);
    let (mc, mn) = count(params, false);
    w(format!(
        "{} true parameters lie within their simultaneous {level} intervals (Bonferroni, K = {k}){}; \
         {mc} of {mn} within their marginal {level} CIs (about 95% each are expected to).",
        if sn == 0 {
            "none of the".to_string()
        } else {
            format!("{sc} of {sn}")
        },
        if sn > 0 && sc == sn {
            ": all recovered"
        } else {
            ""
        }
    ))?;
    w("IEEE 952 units (true vs GMWM estimate; N and K are increasing functions of WN sigma2 and\n\
       RW gamma2, so their intervals are the images of those parameters' and belong to the same family):"
        .into())?;
    for c in ieee {
        w(format!(
            "{:<8} {:<2} true {:>10} estimate {:>10} {:>22} {:>22} {:<10} {} / {}",
            c.channel,
            c.parameter,
            num(c.truth),
            num(c.estimate),
            interval(c.ci, num),
            interval(c.sim_ci, num),
            c.unit,
            yes_no(c.sim_covered(), "NO"),
            yes_no(c.covered(), "no"),
        ))?;
    }
    let (ic, inn) = count(ieee, true);
    let (imc, imn) = count(ieee, false);
    w(format!(
        "{ic} of {inn} IEEE terms within their simultaneous {level} intervals; {imc} of {imn} within their marginal {level} CIs."
    ))?;
    // The report: demo.json, and the truth table in report.html.
    crate::output::create_dir(&args.out, "--out")?;
    let dj = DemoJson {
        alpha,
        k,
        simultaneous_method: "bonferroni",
        simultaneous_level: 1.0 - alpha_sim,
        ci_method,
        parameters: params,
        ieee,
    };
    let path = args.out.join("demo.json");
    crate::output::write_file(&path, serde_json::to_string_pretty(&dj)?.as_bytes())?;
    let mut extra = format!(
        "<h2>Demo: true against estimated parameters</h2><p>Simultaneous intervals: Bonferroni over K = {k} parameters (each at {sim_level}), jointly ≥ {level}. {sc} of {sn} true parameters lie within their simultaneous intervals, {mc} of {mn} within their marginal {level} CIs.</p><table><tr><th class=l>channel</th><th class=l>parameter</th><th>true</th><th>estimate</th><th>{level} CI</th><th>simultaneous {sim_level}</th><th>covered (simultaneous)</th><th>covered (marginal)</th></tr>\n"
    );
    let html_yes = |c: Option<bool>| yes_no(c, "<span class=no>no</span>");
    for c in params {
        extra.push_str(&format!(
            "<tr><td class=l>{}</td><td class=l>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            c.channel,
            c.parameter,
            processes::number::sig(c.truth, 4),
            processes::number::sig(c.estimate, 4),
            interval(c.ci, e4),
            interval(c.sim_ci, e4),
            html_yes(c.sim_covered()),
            html_yes(c.covered()),
        ));
    }
    extra.push_str("</table>\n");
    let inp = crate::pipeline::report::ReportInput {
        source: "imunoise demo (simulated 6-axis MEMS IMU)",
        rate_hz: DEMO_RATE_HZ,
        names: &r.table.names,
        columns: &r.table.columns,
        units: &r.units,
        curves: &r.curves,
        fits: &r.fits,
        extra_html: extra,
        bootstrap: args.bootstrap,
        topic: None,
        timing: None,
        robust: None,
        record_halfwidth: 0.1,
    };
    crate::pipeline::report::write_report(&args.out, &inp, ui)?;
    w(format!(
        "report (plots, results.json, demo.json, avar.csv, imu.yaml) written to {}",
        args.out.join("report.html").display()
    ))?;
    out.flush().map_err(|e| Error::write("<stdout>", e))?;
    ui.note(format!("done in {:.2} s", t0.elapsed().as_secs_f64()));
    Ok(())
}
