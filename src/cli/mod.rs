//! The `imunoise` command: argument parsing (clap) and the subcommands.
//!
//! Every subcommand prints machine-readable output on stdout and messages on stderr;
//! errors return an [`Error`] whose [`Error::exit_code`] the binary exits with.

use crate::error::{Error, Result};
use crate::io::{self, BinaryType, ReadOptions, Table};
use crate::logs;
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;

pub mod analyze;
pub mod avar_cmd;
pub mod demo;
pub mod export;
pub mod fit;
pub mod simulate;
pub mod theory;
pub mod topics;

macro_rules! exit_codes {
    () => {
        "Exit codes: 0 success; 2 bad input or arguments (the message names the file and the line and column, or the option); 1 a failure of the machine (disk full, no permission to write an output, a read error of the device). No input makes imunoise panic: a panic is a bug."
    };
}

/// The exit-code policy, shown by `imunoise --help` (and stated in the README).
pub const EXIT_CODES: &str = exit_codes!();

/// Stochastic calibration of inertial sensors: Allan variance with confidence intervals,
/// theoretical curves of noise models, simulation.
#[derive(Debug, Parser)]
#[command(name = "imunoise", version, about, long_about = None)]
#[command(
    after_help = concat!("Examples:\n  imunoise demo\n  imunoise avar log.csv.gz --rate 100 --format json\n  imunoise simulate --model \"WN(sigma2=1e-4)+RW(gamma2=1e-10)\" -n 100000 --rate 100 --seed 1 -o sim.csv\n\n", exit_codes!())
)]
pub struct Cli {
    /// No progress bars or notes on stderr (errors are still printed).
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// The subcommand.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Allan variance (with confidence intervals) of every channel of a log file.
    #[command(after_help = avar_cmd::EXAMPLES)]
    Avar(avar_cmd::AvarArgs),
    /// Fit a noise model per channel (GMWM, AVLR or IEEE 952 read-off) with CIs.
    #[command(after_help = fit::EXAMPLES)]
    Fit(fit::FitArgs),
    /// Everything for a log: AV, model selection and fit, IEEE table, plots, report.html,
    /// results.json, avar.csv and a Kalibr imu.yaml.
    #[command(after_help = analyze::EXAMPLES)]
    Analyze(analyze::AnalyzeArgs),
    /// Write the noise values of an analysis (results.json) into the config files of
    /// Kalibr, OpenVINS, ORB-SLAM3, VINS-Fusion and Basalt, with their conventions in comments.
    #[command(after_help = export::EXAMPLES)]
    Export(export::ExportArgs),
    /// List the topics of a log (ROS bag, ULog, DataFlash): message types, counts and the
    /// rate from the stamps of IMU topics.
    #[command(after_help = topics::EXAMPLES)]
    Topics(topics::TopicsArgs),
    /// Simulate K independent channels of a noise model to CSV or raw f64.
    #[command(after_help = simulate::EXAMPLES)]
    Simulate(simulate::SimulateArgs),
    /// Theoretical Allan variance/deviation of a model and of each of its components.
    #[command(after_help = theory::EXAMPLES)]
    Theory(theory::TheoryArgs),
    /// Simulate a realistic 6-axis MEMS IMU with known noise, analyse it and print true
    /// against estimated parameters. Needs no files.
    #[command(after_help = demo::EXAMPLES)]
    Demo(demo::DemoArgs),
}

/// Runs the parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    let ui = Ui::new(cli.quiet);
    match cli.command {
        Command::Avar(a) => avar_cmd::run(&a, &ui),
        Command::Fit(a) => fit::run(&a, &ui),
        Command::Analyze(a) => analyze::run(&a, &ui),
        Command::Topics(a) => topics::run(&a, &ui),
        Command::Export(a) => export::run(&a, &ui),
        Command::Simulate(a) => simulate::run(&a, &ui),
        Command::Theory(a) => theory::run(&a, &ui),
        Command::Demo(a) => demo::run(&a, &ui),
    }
}

/// Progress and notes on stderr: shown only when stderr is a terminal and not `--quiet`.
#[derive(Debug, Clone, Copy)]
pub struct Ui {
    /// Whether progress bars are drawn.
    pub progress: bool,
    /// Whether notes are printed.
    pub notes: bool,
}

impl Ui {
    /// Decides from `--quiet` and whether stderr is a terminal.
    pub fn new(quiet: bool) -> Self {
        Ui {
            progress: !quiet && std::io::stderr().is_terminal(),
            notes: !quiet,
        }
    }

    /// A spinner with a message (hidden when progress is off).
    pub fn spinner(&self, msg: impl Into<String>) -> ProgressBar {
        if !self.progress {
            return ProgressBar::hidden();
        }
        let pb = ProgressBar::new_spinner();
        if let Ok(style) = ProgressStyle::with_template("{spinner} {msg} {elapsed}") {
            pb.set_style(style);
        }
        pb.set_message(msg.into());
        pb.enable_steady_tick(std::time::Duration::from_millis(120));
        pb
    }

    /// A bar of `len` steps with a message (hidden when progress is off).
    pub fn bar(&self, len: u64, msg: impl Into<String>) -> ProgressBar {
        if !self.progress {
            return ProgressBar::hidden();
        }
        let pb = ProgressBar::new(len);
        if let Ok(style) =
            ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed}")
        {
            pb.set_style(style.progress_chars("=> "));
        }
        pb.set_message(msg.into());
        pb
    }

    /// Prints a note on stderr unless quiet.
    pub fn note(&self, msg: impl AsRef<str>) {
        if self.notes {
            eprintln!("{}", msg.as_ref());
        }
    }
}

/// A sampling rate in Hz: a finite number > 0.
pub fn parse_rate(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!(
            "the sampling rate must be a finite number > 0 Hz, got {s}"
        ))
    }
}

/// A finite non-zero factor: a number or a fraction `a/b`.
pub fn parse_factor(s: &str) -> std::result::Result<f64, String> {
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| format!("{s:?} is not a number or a fraction a/b"))
    };
    let v = match s.split_once('/') {
        Some((a, b)) => num(a)? / num(b)?,
        None => num(s)?,
    };
    if v.is_finite() && v != 0.0 {
        Ok(v)
    } else {
        Err(format!("the factor must be finite and non-zero, got {s}"))
    }
}

/// The input file and how to read it (shared by the analysis subcommands).
#[derive(Debug, Clone, Args)]
pub struct InputArgs {
    /// Input log: a ROS 1 `.bag`, a ROS 2 `.mcap` or `.db3` bag, a PX4 `.ulg` or ArduPilot
    /// `.bin` log, or CSV, TSV or whitespace-separated text with or without a header line
    /// (gzip-compressed is read transparently), or raw little-endian binary with --binary.
    /// Logs are recognised by extension (or --log-format). `-` reads standard input; standard
    /// input, pipes and FIFOs are read into memory first (regular files are memory-mapped).
    pub file: PathBuf,
    /// Sampling rate in Hz (> 0). Required for inputs without time stamps; for logs (and
    /// text with --time-column) the rate comes from the stamps (median Δt), and a --rate
    /// more than 1 % away from it is an error.
    #[arg(long, short = 'r', value_name = "HZ", value_parser = parse_rate, allow_negative_numbers = true)]
    pub rate: Option<f64>,
    /// Columns to analyse: header names or 1-based indices and ranges, e.g. `gyro_x,acc_z` or `1-3`.
    #[arg(long, value_name = "LIST")]
    pub columns: Option<String>,
    /// Read raw little-endian binary of this type (f64, f32, i16, i32), row-major.
    #[arg(long, value_name = "TYPE")]
    pub binary: Option<BinaryType>,
    /// Channels per row of binary input.
    #[arg(long, value_name = "K")]
    pub channels: Option<usize>,
    /// Multiply every value by this factor, a number or a fraction (e.g. 1/131 for
    /// MPU-6050 gyro counts → °/s).
    #[arg(long, value_name = "FACTOR", allow_negative_numbers = true, value_parser = parse_factor)]
    pub scale: Option<f64>,
    /// Channel names (comma list, after --columns), replacing the header's.
    #[arg(long, value_name = "LIST")]
    pub names: Option<String>,
    /// Units: one for all channels or a comma list (deg/s, rad/s, g, m/s^2, none).
    /// Default: inferred from name suffixes (_dps, _rads, _g, _mps2), else none.
    #[arg(long, value_name = "UNIT")]
    pub unit: Option<String>,
    /// IMU topic of a bag (or message of a ULog/DataFlash log) to read; repeatable
    /// (`analyze` writes one report per topic). Default: the only IMU topic
    /// (see `imunoise topics FILE`).
    #[arg(long, value_name = "NAME")]
    pub topic: Vec<String>,
    /// The log format when the extension does not tell (mcap, bag, db3, ulog, dataflash).
    #[arg(long, value_name = "FORMAT", value_enum)]
    pub log_format: Option<logs::LogFormat>,
    /// Text input: the column (name or 1-based index) holding time stamps; the rate then
    /// comes from the stamps and gaps are checked as for logs.
    #[arg(long, value_name = "COLUMN")]
    pub time_column: Option<String>,
    /// Unit of --time-column: s, ms, us or ns.
    #[arg(long, value_name = "UNIT", default_value = "s")]
    pub time_unit: TimeUnit,
    /// Time-stamped input whose gaps (Δt > 1.5 nominal) miss more than 0.1 % of its samples:
    /// refuse it (default), analyse the longest gap-free segment, or ignore the gaps.
    #[arg(long, value_name = "POLICY", value_enum, default_value = "refuse")]
    pub gaps: logs::GapPolicy,
}

/// Unit of a text time column (`--time-unit`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TimeUnit {
    /// Seconds.
    S,
    /// Milliseconds.
    Ms,
    /// Microseconds.
    Us,
    /// Nanoseconds.
    Ns,
}

impl TimeUnit {
    /// Nanoseconds per unit.
    pub fn ns(self) -> f64 {
        match self {
            TimeUnit::S => 1e9,
            TimeUnit::Ms => 1e6,
            TimeUnit::Us => 1e3,
            TimeUnit::Ns => 1.0,
        }
    }
}

impl InputArgs {
    /// The log format of the input, if it is a log (a folder is a ROS 2 bag). With
    /// `--binary` the input is raw binary whatever its extension, and a `.bin` file is a
    /// DataFlash log only when it starts with a DataFlash message header (A3 95).
    pub fn log_format(&self) -> Option<logs::LogFormat> {
        self.log_format.or_else(|| {
            if self.binary.is_some() {
                None
            } else if self.file.is_dir() {
                logs::storage_file(&self.file)
                    .ok()
                    .and_then(|p| logs::LogFormat::from_path(&p))
                    .or(Some(logs::LogFormat::Mcap))
            } else {
                match logs::LogFormat::from_path(&self.file) {
                    Some(logs::LogFormat::Dataflash) => {
                        let mut head = [0u8; 2];
                        let is_df = std::fs::File::open(&self.file)
                            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
                            .is_ok()
                            && head == [0xA3, 0x95];
                        is_df.then_some(logs::LogFormat::Dataflash)
                    }
                    other => other,
                }
            }
        })
    }

    /// Reads the file as the flags say (with a spinner on a terminal). The returned table
    /// has its rate set. Logs with several selected topics are an error here (see
    /// [`InputArgs::read_all`]).
    pub fn read(&self, ui: &Ui) -> Result<Table> {
        let mut all = self.read_all(ui)?;
        if all.len() > 1 {
            return Err(Error::Usage(format!(
                "{} topics selected; this subcommand reads one (analyze takes several)",
                all.len()
            )));
        }
        Ok(all.remove(0))
    }

    /// Reads the file: one table per selected topic for logs, one table otherwise; each
    /// with its rate (from --rate or the stamps) and, for stamped input, its timing.
    pub fn read_all(&self, ui: &Ui) -> Result<Vec<Table>> {
        let size = std::fs::metadata(&self.file).map_or(String::new(), |m| {
            format!(" ({:.1} MB)", m.len() as f64 / 1e6)
        });
        let pb = ui.spinner(format!("reading {}{size}", self.file.display()));
        let t = match self.log_format() {
            Some(fmt) => self.read_log(fmt, ui),
            None => self.read_text_or_binary().map(|t| vec![t]),
        };
        pb.finish_and_clear();
        t
    }

    fn read_text_or_binary(&self) -> Result<Table> {
        if !self.topic.is_empty() {
            return Err(Error::Usage(
                "--topic is for logs (.mcap, .bag, .db3, .ulg, .bin)".to_string(),
            ));
        }
        let mut columns = self.columns.as_deref().map(io::parse_columns).transpose()?;
        let time_col = match &self.time_column {
            None => None,
            Some(_) if self.binary.is_some() => {
                return Err(Error::Usage("--time-column is for text input".to_string()));
            }
            Some(tc) => {
                let spec = io::parse_columns(tc)?;
                if spec.len() != 1 || matches!(spec[0], io::ColumnSpec::Range(..)) {
                    return Err(Error::Usage(format!(
                        "--time-column {tc:?}: give one column name or index"
                    )));
                }
                Some(spec[0].clone())
            }
        };
        let mut time_first = false;
        if let (Some(tc), Some(cols)) = (&time_col, columns.as_mut()) {
            // Read the time column too, first; it is taken out below.
            cols.insert(0, tc.clone());
            time_first = true;
        }
        let opts = ReadOptions {
            binary: self.binary,
            channels: self.channels,
            scale: None,
            columns,
            names: None,
        };
        let mut t = io::read_table(&self.file, &opts)?;
        if let Some(tc) = &time_col {
            let idx = if time_first {
                0
            } else {
                io::resolve_columns(std::slice::from_ref(tc), &t.names)?[0]
            };
            let time = t.columns.remove(idx);
            let tname = t.names.remove(idx);
            if t.columns.is_empty() {
                return Err(Error::Usage(format!(
                    "--time-column {tname:?} is the only column; nothing left to analyse"
                )));
            }
            let k = self.time_unit.ns();
            let stamps: Vec<i64> = time.iter().map(|&v| (v * k).round() as i64).collect();
            let (cols, timing) = logs::timing::prepare(
                stamps,
                std::mem::take(&mut t.columns),
                self.rate,
                self.gaps,
                &t.file,
            )?;
            t.columns = cols;
            t.rate_hz = Some(timing.rate_hz);
            t.timing = Some(timing);
        } else {
            t.rate_hz = self.rate;
        }
        self.finish(&mut t)?;
        if t.rate_hz.is_none() {
            t.rate()?;
        }
        Ok(t)
    }

    /// `--scale` and `--names`, after the columns are final.
    fn finish(&self, t: &mut Table) -> Result<()> {
        if let Some(scale) = self.scale {
            for c in &mut t.columns {
                c.iter_mut().for_each(|v| *v *= scale);
            }
        }
        if let Some(names) = &self.names {
            let names: Vec<String> = names.split(',').map(|n| n.trim().to_string()).collect();
            if names.len() != t.names.len() {
                return Err(Error::Usage(format!(
                    "--names gives {} names for {} channels",
                    names.len(),
                    t.names.len()
                )));
            }
            t.names = names;
        }
        Ok(())
    }

    fn read_log(&self, fmt: logs::LogFormat, ui: &Ui) -> Result<Vec<Table>> {
        if self.binary.is_some() || self.channels.is_some() || self.time_column.is_some() {
            return Err(Error::Usage(format!(
                "{}: --binary, --channels and --time-column are for text and raw input, not {:?} logs",
                self.file.display(),
                fmt
            )));
        }
        let path = logs::storage_file(&self.file)?;
        let file = path.display().to_string();
        let reader = logs::open(&path, fmt)?;
        let topics = logs::select_topics(reader.as_ref(), &file, &self.topic)?;
        let mut out = Vec::new();
        for topic in topics {
            let series = reader.read_imu(&topic)?;
            let what = format!("{file} ({topic})");
            let (cols, timing) = logs::timing::prepare(
                series.stamps_ns,
                series.columns,
                self.rate,
                self.gaps,
                &what,
            )?;
            ui.note(format!("{topic}: {}", timing.summary()));
            let mut t = Table {
                file: file.clone(),
                names: series.names,
                columns: cols,
                rate_hz: Some(timing.rate_hz),
                timing: Some(timing),
                topic: Some(topic),
            };
            if let Some(spec) = &self.columns {
                let idx = io::resolve_columns(&io::parse_columns(spec)?, &t.names)?;
                t.names = idx.iter().map(|&i| t.names[i].clone()).collect();
                t.columns = idx.iter().map(|&i| t.columns[i].clone()).collect();
            }
            self.finish(&mut t)?;
            out.push(t);
        }
        Ok(out)
    }
}

/// Output formats of the table-like subcommands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Aligned text for people.
    Table,
    /// JSON (shapes documented per subcommand).
    Json,
    /// CSV with a header line.
    Csv,
}

/// Parses `--scales`: `dyadic` (book default), `dyadic1` (with m = 1), `octave`, `decade`,
/// `all`, `logN` (N per decade) or an explicit list `m1,m2,…`.
pub fn parse_scales(s: &str) -> std::result::Result<avar::Scales, String> {
    use avar::Scales;
    let t = s.trim().to_ascii_lowercase();
    Ok(match t.as_str() {
        "dyadic" => Scales::Dyadic,
        "dyadic1" | "dyadic-with-one" => Scales::DyadicWithOne,
        "octave" => Scales::Octave,
        "decade" => Scales::Decade,
        "all" => Scales::All,
        _ if t.starts_with("log") => Scales::LogSpaced {
            per_decade: t[3..]
                .parse()
                .map_err(|_| format!("{s:?}: expected logN with N points per decade"))?,
        },
        _ => Scales::Explicit(
            t.split(',')
                .map(|m| {
                    m.trim().parse::<u64>().map_err(|_| {
                        format!(
                            "{s:?}: expected dyadic, dyadic1, octave, decade, all, logN or a list of cluster sizes m1,m2,…"
                        )
                    })
                })
                .collect::<std::result::Result<_, _>>()?,
        ),
    })
}

/// Maps an `avar` error of one channel to a message naming the file and channel.
pub fn avar_error(file: &str, channel: &str, e: avar::AvarError) -> Error {
    let hint = match e {
        avar::AvarError::NotRepresentable { .. } => " (--scale F multiplies every sample by F)",
        _ => "",
    };
    Error::File {
        file: file.to_string(),
        message: format!("channel {channel:?}: {e}{hint}"),
    }
}
