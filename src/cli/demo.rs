//! `imunoise demo`: a simulated 6-axis MEMS IMU with known noise, analysed end to end.
//!
//! The true models (per sample, at 100 Hz; units °/s for the gyros, m/s² for the
//! accelerometers) are in [`DEMO_IMU`] and printed by `imunoise demo --help`.

use super::Ui;
use super::analyze::num;
use crate::error::{Error, Result};
use avar::{AllanVariance, AvarConfig};
use gmwm_prep::units::{IeeeTerm, process_ieee};

use processes::{Model, Unit};
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
    /// Output directory of the analysis report (report.html, plots, results.json, imu.yaml).
    #[arg(long, short, default_value = "imunoise-demo")]
    pub out: std::path::PathBuf,
    /// Parametric bootstrap replications for the CIs.
    #[arg(long, default_value_t = 40, value_name = "B")]
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

/// True against estimated value of one parameter.
#[derive(Debug, Clone)]
pub struct Comparison {
    /// Channel name.
    pub channel: String,
    /// Process code and parameter name, e.g. `"RW gamma2"`.
    pub parameter: String,
    /// True value.
    pub truth: f64,
    /// Estimate.
    pub estimate: f64,
    /// CI bounds, if any.
    pub ci: Option<(f64, f64)>,
}

impl Comparison {
    /// Whether the CI covers the truth.
    pub fn covered(&self) -> Option<bool> {
        self.ci.map(|(a, b)| a <= self.truth && self.truth <= b)
    }
}

/// Compares the fitted parameters (model order) with the true model's.
pub fn compare(name: &str, truth: &Model, fit: &super::fit::ChannelFit) -> Vec<Comparison> {
    let true_params: Vec<f64> = truth
        .processes()
        .map(|ps| ps.iter().flat_map(|p| p.params()).collect())
        .unwrap_or_default();
    fit.parameters
        .iter()
        .zip(true_params)
        .map(|(p, t)| Comparison {
            channel: name.to_string(),
            parameter: format!("{} {}", p.process, p.name),
            truth: t,
            estimate: p.value,
            ci: p.ci_lo.zip(p.ci_hi),
        })
        .collect()
}

/// Runs `imunoise demo`.
pub fn run(args: &DemoArgs, ui: &Ui) -> Result<()> {
    if args.n < 1 << 14 {
        return Err(Error::Usage(
            "--samples: the demo needs at least 16384 samples per channel".into(),
        ));
    }
    let t0 = std::time::Instant::now();
    let pb = ui.spinner("simulating the demo IMU");
    let data = simulate(args.n, args.seed)?;
    pb.finish_and_clear();
    let table = crate::io::Table {
        file: "<demo>".into(),
        names: data.names.clone(),
        columns: data.columns,
    };
    let curves: Vec<(String, AllanVariance)> =
        super::avar_cmd::compute(&table, DEMO_RATE_HZ, &AvarConfig::default(), ui)?;
    // The true template (the structure is known; its values are estimated).
    let settings = super::fit::FitSettings {
        model: data.models[0].template().to_string(),
        method: super::fit::Method::Gmwm,
        select: false,
        bootstrap: args.bootstrap,
        seed: args.seed.wrapping_add(1),
        alpha: 0.05,
    };
    let fits = super::fit::fit_all(&curves, &data.units, &settings, ui)?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let mut w = |s: String| writeln!(out, "{s}").map_err(|e| Error::io("<stdout>", e));
    w(format!(
        "imunoise demo: simulated 6-axis MEMS IMU, {} samples per channel at {} Hz ({:.1} h), seed {}",
        args.n,
        DEMO_RATE_HZ,
        args.n as f64 / DEMO_RATE_HZ / 3600.0,
        args.seed
    ))?;
    w(format!(
        "GMWM fit of {} on the Allan variance, 95% CIs from a {}-replicate parametric bootstrap covariance:",
        settings.model, args.bootstrap
    ))?;
    w(format!(
        "{:<8} {:<11} {:>11} {:>11} {:>25}  {}",
        "channel", "parameter", "true", "estimate", "95% CI", "covered"
    ))?;
    let (mut n_cov, mut n_all) = (0, 0);
    let mut extra = String::from(
        "<h2>Demo: true against estimated parameters</h2><table><tr><th class=l>channel</th><th class=l>parameter</th><th>true</th><th>estimate</th><th>95% CI</th><th>covered</th></tr>\n",
    );
    for (k, f) in fits.iter().enumerate() {
        for c in compare(&data.names[k], &data.models[k], f) {
            extra.push_str(&format!(
                "<tr><td class=l>{}</td><td class=l>{}</td><td>{:.4e}</td><td>{:.4e}</td><td>{}</td><td>{}</td></tr>\n",
                c.channel,
                c.parameter,
                c.truth,
                c.estimate,
                c.ci.map_or("-".into(), |(a, b)| format!("[{a:.3e}, {b:.3e}]")),
                match c.covered() {
                    Some(true) => "yes",
                    Some(false) => "<span class=no>no</span>",
                    None => "-",
                }
            ));
            let cov = c.covered();
            n_all += 1;
            n_cov += usize::from(cov == Some(true));
            w(format!(
                "{:<8} {:<11} {:>11.4e} {:>11.4e} {:>25}  {}",
                c.channel,
                c.parameter,
                c.truth,
                c.estimate,
                c.ci.map_or("-".into(), |(a, b)| format!("[{a:.3e}, {b:.3e}]")),
                match cov {
                    Some(true) => "yes",
                    Some(false) => "NO",
                    None => "-",
                }
            ))?;
        }
    }
    w(format!(
        "{n_cov} of {n_all} true parameters lie within their 95% CIs (about 95% are expected to)."
    ))?;
    w("IEEE 952 units (true vs GMWM estimate):".into())?;
    for (k, f) in fits.iter().enumerate() {
        let unit = &data.units[k];
        for term in [IeeeTerm::N, IeeeTerm::K] {
            let (Some((truth, u)), Some(est)) = (
                true_ieee(&data.models[k], term, unit),
                f.ieee.get(term.symbol()),
            ) else {
                continue;
            };
            w(format!(
                "{:<8} {:<2} true {:>10} estimate {:>10} {:>25} {u}",
                data.names[k],
                term.symbol(),
                num(truth),
                num(est.value),
                match (est.ci_lo, est.ci_hi) {
                    (Some(a), Some(b)) => format!("[{}, {}]", num(a), num(b)),
                    _ => "-".into(),
                }
            ))?;
        }
    }
    extra.push_str("</table>\n");
    let inp = super::analyze::ReportInput {
        source: "imunoise demo (simulated 6-axis MEMS IMU)",
        rate_hz: DEMO_RATE_HZ,
        names: &table.names,
        columns: &table.columns,
        units: &data.units,
        curves: &curves,
        fits: &fits,
        extra_html: extra,
    };
    super::analyze::write_report(&args.out, &inp, ui)?;
    w(format!(
        "report (plots, results.json, avar.csv, imu.yaml) written to {}",
        args.out.join("report.html").display()
    ))?;
    out.flush().map_err(|e| Error::io("<stdout>", e))?;
    ui.note(format!("done in {:.2} s", t0.elapsed().as_secs_f64()));
    Ok(())
}
