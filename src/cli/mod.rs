//! The `imunoise` command: argument parsing (clap) and the subcommands.
//!
//! Every subcommand prints machine-readable output on stdout and messages on stderr;
//! errors return an [`crate::Error`] whose [`crate::Error::exit_code`] the binary exits with.

use crate::error::Result;
use crate::io::{BinaryType, Table};
use crate::logs;
use crate::pipeline::read::Input;
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

pub mod analyze;
pub mod avar_cmd;
pub mod demo;
pub mod export;
pub mod fit;
pub mod live;
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
    /// Calibrate while recording: the Allan deviation and N, K, B with their CIs, refreshed
    /// as samples arrive on standard input, a FIFO, a serial device or a growing file.
    #[command(after_help = live::EXAMPLES)]
    Live(live::LiveArgs),
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
        Command::Live(a) => live::run(&a, &ui),
        Command::Topics(a) => topics::run(&a, &ui),
        Command::Export(a) => export::run(&a, &ui),
        Command::Simulate(a) => simulate::run(&a, &ui),
        Command::Theory(a) => theory::run(&a, &ui),
        Command::Demo(a) => demo::run(&a, &ui),
    }
}

pub use crate::ui::Ui;

pub use crate::export::parse_inflation;
pub use crate::pipeline::read::{parse_factor, parse_rate};

/// The input file and how to read it (shared by the analysis subcommands).
#[derive(Debug, Clone, Args)]
pub struct InputArgs {
    /// Input log: a ROS 1 `.bag`, a ROS 2 `.mcap` or `.db3` bag, a PX4 `.ulg` or ArduPilot
    /// `.bin` log, or CSV, TSV or whitespace-separated text with or without a header line
    /// (gzip-compressed is read transparently), or raw little-endian binary with --binary.
    /// Logs are recognised by extension (or --log-format). `-` reads standard input.
    /// Memory: `avar` streams raw binary (--binary): a regular file of one f64 channel is
    /// used in place (memory-mapped, a bounded window resident; without a CI the memory grows
    /// by only 16 bytes per 128 samples); other types, several channels and --scale are decoded
    /// a group of channels at a time into reused buffers (2 of 6 f64 channels per pass over the
    /// file: 8 bytes per sample of each channel of the group) while they fit in a quarter of
    /// the available memory, else into temporary files; gzip, standard input and pipes (which
    /// cannot seek) are decoded once into temporary files (8 bytes per sample and channel of
    /// disk space, not memory), and a note says so. A regular uncompressed text file larger
    /// than a quarter of the available memory (without --time-column) is parsed in 64 MiB
    /// windows into such temporary files too; other text, gzip text and text from standard
    /// input or a pipe are read whole into memory (a note says so for standard input and
    /// pipes). The
    /// chi-square CI (the default) streams too, reading the series three more times with 16
    /// bytes per 64 samples and 16 MiB per thread; the Gaussian CI holds 8 more bytes per
    /// sample. Series shorter than 4194304 samples are estimated in memory (8 bytes per
    /// sample). `fit` and `analyze` read a regular raw binary file through the same
    /// sources (one f64 channel used in place, other layouts decoded once in parallel), then
    /// hold their working data in memory; gzip, standard input and pipes, text and logs are
    /// read whole into memory (standard input, pipes and FIFOs first as bytes; regular files
    /// are memory-mapped).
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
    /// `SEC+NSEC` names two columns, whole seconds and nanoseconds, as ROS headers carry
    /// stamps (`--time-column 1+2` for `ros2 topic echo --csv`): exact, where one column of
    /// nanoseconds since 1970 is read as a number to about 0.25 µs.
    #[arg(long, value_name = "COLUMN")]
    pub time_column: Option<String>,
    /// Unit of --time-column: s, ms, us or ns.
    #[arg(long, value_name = "UNIT", default_value = "s")]
    pub time_unit: TimeUnit,
    /// Time-stamped input whose gaps (Δt > 1.5 nominal) miss more than 0.1 % of its samples:
    /// refuse it (default), analyse the longest gap-free segment, or ignore the gaps.
    #[arg(long, value_name = "POLICY", value_enum, default_value = "refuse")]
    pub gaps: logs::GapPolicy,
    /// Logs: the instance of the --topic message to read (ULog multi-instance topics such as
    /// `--topic sensor_gyro --instance 1`, DataFlash `--topic IMU --instance 1`).
    #[arg(long, value_name = "K")]
    pub instance: Option<u32>,
    /// Logs: refuse a cut-off file (one that ends inside a message, as when the power goes)
    /// instead of reading every complete message before the cut with a warning.
    #[arg(long)]
    pub strict: bool,
}

pub use crate::pipeline::read::TimeUnit;

impl InputArgs {
    /// The library's read specification these flags describe.
    pub fn spec(&self) -> Input {
        Input {
            file: self.file.clone(),
            rate: self.rate,
            columns: self.columns.clone(),
            binary: self.binary,
            channels: self.channels,
            scale: self.scale,
            names: self.names.clone(),
            unit: self.unit.clone(),
            topic: self.topic.clone(),
            log_format: self.log_format,
            time_column: self.time_column.clone(),
            time_unit: self.time_unit,
            gaps: self.gaps,
            instance: self.instance,
            strict: self.strict,
        }
    }

    /// Reads the file as the flags say: see [`Input::read`].
    pub fn read(&self, ui: &Ui) -> Result<Table> {
        self.spec().read(ui)
    }

    /// Reads every selected topic: see [`Input::read_all`].
    pub fn read_all(&self, ui: &Ui) -> Result<Vec<Table>> {
        self.spec().read_all(ui)
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

pub use crate::pipeline::estimate::parse_scales;

pub use crate::pipeline::estimate::avar_error;
