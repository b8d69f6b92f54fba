//! `imunoise theory`: theoretical Allan variance/deviation of a model and its components.

use super::{Format, Ui, parse_rate, parse_scales};
use crate::error::{Error, Result};
pub use crate::pipeline::theory::{
    ComponentCurve, PsdPoint, TheoryJson, TheoryPoint, curves, psd_curve,
};
use avar::Scales;
use processes::Model;
use std::io::Write;

/// Examples shown by `imunoise theory --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise theory --model \"WN(sigma2=1e-4)+RW(gamma2=1e-10)+AR1(phi=0.995,sigma2=1e-7)\" --rate 100
  imunoise theory --model \"QN(q2=1e-6)+WN(1e-4)\" --rate 200 --scales octave -n 100000 --format json

The model's parameters are per sample (Δt = 1/rate) in the signal's unit u (WN sigma2 in u²,
RW gamma2 in u² per sample, …); m is in samples, tau = m/rate in seconds, the AV in u² and the
AD in u. The table and CSV give the AD of the whole model and of each component.

JSON shape: {\"model\",\"rate_hz\",\"points\":[{\"m\",\"tau\",\"avar\",\"adev\"}],
\"components\":[{\"name\",\"points\":[…]}],\"psd\":[{\"f\",\"psd\"}]} (top-level points are the
whole model; psd is two-sided, in u²/Hz at f in Hz).";

/// Arguments of `imunoise theory`.
#[derive(Debug, Clone, clap::Args)]
pub struct TheoryArgs {
    /// The model with all parameter values (per sample); a sinusoid's frequency may be given
    /// in Hz at --rate: "SIN(alpha2=2e-4, f_hz=8)".
    #[arg(long, short)]
    pub model: String,
    /// Sampling rate in Hz (> 0).
    #[arg(long, short, value_name = "HZ", value_parser = parse_rate, allow_negative_numbers = true)]
    pub rate: f64,
    /// Cluster sizes: dyadic (default), dyadic1, octave, decade, all, logN, or m1,m2,…
    #[arg(long, default_value = "dyadic", value_parser = parse_scales)]
    pub scales: Scales,
    /// Length of the record the scale grid is made for (as if the data had N samples).
    #[arg(
        short = 'n',
        long = "samples",
        value_name = "N",
        default_value_t = 1_000_000
    )]
    pub n: usize,
    /// Output format: table, json or csv.
    #[arg(long, short, value_enum, default_value = "table")]
    pub format: Format,
}

/// Runs `imunoise theory`.
pub fn run(args: &TheoryArgs, _ui: &Ui) -> Result<()> {
    let model = Model::parse_at_rate(&args.model, args.rate)?;
    let ms = args
        .scales
        .cluster_sizes(args.n)
        .map_err(|e| Error::Usage(format!("--scales: {e}")))?;
    let doc = curves(&model, args.rate, &ms)?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let res = match args.format {
        Format::Json => serde_json::to_writer(&mut out, &doc)
            .map_err(std::io::Error::other)
            .and_then(|_| writeln!(out)),
        Format::Table | Format::Csv => {
            let csv = args.format == Format::Csv;
            let mut r = Ok(());
            if csv {
                let mut head = "m,tau,adev".to_string();
                for c in &doc.components {
                    head.push_str(&format!(",\"adev {}\"", c.name));
                }
                r = writeln!(out, "{head}");
            } else {
                r = r.and_then(|_| {
                    writeln!(
                        out,
                        "model: {} at {} Hz (Allan deviation)",
                        doc.model, doc.rate_hz
                    )
                });
                let mut head = format!("{:>10} {:>12} {:>12}", "m", "tau [s]", "total");
                for c in &doc.components {
                    let code = c.name.split('(').next().unwrap_or(&c.name);
                    head.push_str(&format!(" {code:>12}"));
                }
                r = r.and_then(|_| writeln!(out, "{head}"));
            }
            for (i, p) in doc.points.iter().enumerate() {
                let mut line = if csv {
                    format!("{},{},{:e}", p.m, p.tau, p.adev)
                } else {
                    format!(
                        "{:>10} {:>12} {:>12.5e}",
                        p.m,
                        format!("{:.4}", p.tau),
                        p.adev
                    )
                };
                for c in &doc.components {
                    if csv {
                        line.push_str(&format!(",{:e}", c.points[i].adev));
                    } else {
                        line.push_str(&format!(" {:>12.5e}", c.points[i].adev));
                    }
                }
                r = r.and_then(|_| writeln!(out, "{line}"));
            }
            r
        }
    };
    res.and_then(|_| out.flush())
        .map_err(|e| Error::write("<stdout>", e))
}
