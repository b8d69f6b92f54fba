//! `imunoise simulate`: K independent channels of a model, to CSV or raw f64.

use super::{Ui, parse_rate};
use crate::error::{Error, Result};
pub use crate::pipeline::simulate::{simulate_channels, write_csv, write_f64};
use processes::Model;
use std::io::Write;
use std::path::PathBuf;

/// Examples shown by `imunoise simulate --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise simulate --model \"WN(sigma2=1e-4)+RW(gamma2=1e-10)+AR1(phi=0.995,sigma2=1e-7)\" -n 1000000 --rate 100 --seed 1 -o sim.csv
  imunoise simulate --model \"WN(1e-4)\" -n 100000 --rate 100 --seed 7 --channels 3 -o sim.f64

Channel k is stream k of the seed: the output depends only on (model, n, rate, seed, k).";

/// Arguments of `imunoise simulate`.
#[derive(Debug, Clone, clap::Args)]
pub struct SimulateArgs {
    /// The model with all parameter values (per sample), e.g. "WN(sigma2=1e-4)+RW(gamma2=1e-10)";
    /// a sinusoid's frequency may be given in Hz at --rate: "SIN(alpha2=2e-4, f_hz=8)".
    #[arg(long, short)]
    pub model: String,
    /// Number of samples per channel.
    #[arg(short, long = "samples", value_name = "N")]
    pub n: usize,
    /// Sampling rate in Hz (> 0; sets the GM discretisation).
    #[arg(long, short, value_name = "HZ", value_parser = parse_rate, allow_negative_numbers = true)]
    pub rate: f64,
    /// Random seed.
    #[arg(long, short, default_value_t = 1)]
    pub seed: u64,
    /// Number of independent channels.
    #[arg(long, short = 'k', default_value_t = 1)]
    pub channels: usize,
    /// Output file: CSV with a header line (ch1,…), or raw little-endian f64, row-major, when
    /// the name ends in `.f64`. `-` or absent: CSV on stdout.
    #[arg(long, short)]
    pub output: Option<PathBuf>,
}

/// Runs `imunoise simulate`.
pub fn run(args: &SimulateArgs, ui: &Ui) -> Result<()> {
    let model = Model::parse_at_rate(&args.model, args.rate)?;
    if args.channels == 0 {
        return Err(Error::Usage("--channels must be at least 1".into()));
    }
    let pb = ui.spinner(format!("simulating {} × {} samples", args.channels, args.n));
    let cols = simulate_channels(&model, args.n, args.rate, args.seed, args.channels)?;
    pb.finish_and_clear();
    let names: Vec<String> = (1..=args.channels).map(|k| format!("ch{k}")).collect();
    match &args.output {
        Some(path) if path.as_os_str() != "-" => {
            let name = path.display().to_string();
            crate::output::check_file(path, "-o")?;
            let f = std::fs::File::create(path).map_err(|e| Error::write(&name, e))?;
            let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
            let binary = path.extension().is_some_and(|e| e == "f64");
            if binary {
                write_f64(&mut w, &cols)
            } else {
                write_csv(&mut w, &names, &cols)
            }
            .and_then(|_| w.flush())
            .map_err(|e| Error::write(&name, e))?;
            ui.note(format!(
                "wrote {} channel(s) × {} samples of {model} at {} Hz to {name}{}",
                args.channels,
                args.n,
                args.rate,
                if binary { " (raw f64, row-major)" } else { "" }
            ));
        }
        _ => {
            let stdout = std::io::stdout();
            let mut w = std::io::BufWriter::new(stdout.lock());
            write_csv(&mut w, &names, &cols)
                .and_then(|_| w.flush())
                .map_err(|e| Error::write("<stdout>", e))?;
        }
    }
    Ok(())
}
