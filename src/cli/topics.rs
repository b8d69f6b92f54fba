//! `imunoise topics FILE`: the topics of a log with message types, counts and, for IMU
//! topics, the rate from the header stamps (1 / median Δt).

use super::{Format, Ui};
use crate::error::{Error, Result};
use crate::logs;
use std::io::Write;
use std::path::PathBuf;

/// Examples shown by `imunoise topics --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise topics run.mcap
  imunoise topics run.mcap --format json

  imunoise topics flight.ulg
  imunoise avar flight.ulg --topic sensor_gyro --instance 1

IMU topics (sensor_msgs/Imu) are marked with *; pass one to the other subcommands with
--topic NAME (several --topic for analyze). The rate is 1 / median Δt of the header stamps.
PX4 ULog: sensor_combined, sensor_gyro, sensor_accel and the FIFO topics sensor_gyro_fifo /
sensor_accel_fifo (one row per sample); instance k is NAME[k] (or --topic NAME --instance k).
ArduPilot DataFlash: IMU[k] (old logs' IMU, IMU2, IMU3 are IMU[0], IMU[1], IMU[2]) and the
batch sampler's ISB_gyro[k] / ISB_acc[k]. Without --topic, analyze reads the high-rate
topics (FIFO, batch sampler) when the log has them. A log cut off inside a message (the
power went) is read up to its last complete message with a warning; --strict refuses it.";

/// Arguments of `imunoise topics`.
#[derive(Debug, Clone, clap::Args)]
pub struct TopicsArgs {
    /// The log: .mcap, .bag, .db3, .ulg or .bin (by extension unless --log-format), or a
    /// ROS 2 bag folder.
    pub file: PathBuf,
    /// The log format when the extension does not tell.
    #[arg(long, value_name = "FORMAT", value_enum)]
    pub log_format: Option<logs::LogFormat>,
    /// Refuse a cut-off log (one that ends inside a message) instead of listing its complete
    /// messages with a warning.
    #[arg(long)]
    pub strict: bool,
    /// Output format (table or json; csv is the table with commas).
    #[arg(long, value_enum, default_value = "table")]
    pub format: Format,
}

/// Runs `imunoise topics`.
pub fn run(args: &TopicsArgs, ui: &Ui) -> Result<()> {
    let path = logs::storage_file(&args.file)?;
    let file = path.display().to_string();
    let fmt = args
        .log_format
        .or_else(|| logs::LogFormat::from_path(&path))
        .ok_or_else(|| {
            Error::Usage(format!(
                "{file}: not a log by its extension (.mcap, .bag, .db3, .ulg, .bin); give --log-format"
            ))
        })?;
    let pb = ui.spinner(format!("reading {file}"));
    let reader = logs::open_checked(&path, fmt, args.strict, ui)?;
    let all = logs::summarize(reader.as_ref());
    pb.finish_and_clear();
    let all = all?;
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let r = match args.format {
        Format::Json => serde_json::to_writer_pretty(&mut out, &all)
            .map_err(std::io::Error::other)
            .and_then(|_| writeln!(out)),
        Format::Csv => {
            let mut r = writeln!(out, "topic,type,messages,rate_hz,imu");
            for t in &all {
                r = r.and_then(|_| {
                    writeln!(
                        out,
                        "{},{},{},{},{}",
                        t.info.name,
                        t.info.msg_type,
                        t.info.count,
                        t.rate_hz.map_or(String::new(), |r| format!("{r}")),
                        t.info.is_imu
                    )
                });
            }
            r
        }
        Format::Table => {
            let w = all
                .iter()
                .map(|t| t.info.name.len())
                .max()
                .unwrap_or(5)
                .max(5);
            let wt = all
                .iter()
                .map(|t| t.info.msg_type.len())
                .max()
                .unwrap_or(4)
                .max(4);
            let mut r = writeln!(
                out,
                "  {:w$}  {:wt$}  {:>10}  {:>12}",
                "topic", "type", "messages", "rate (Hz)"
            );
            for t in &all {
                r = r.and_then(|_| {
                    writeln!(
                        out,
                        "{} {:w$}  {:wt$}  {:>10}  {:>12}",
                        if t.info.is_imu { '*' } else { ' ' },
                        t.info.name,
                        t.info.msg_type,
                        t.info.count,
                        t.rate_hz.map_or("-".to_string(), |r| format!("{r:.3}"))
                    )
                });
            }
            r
        }
    };
    r.and_then(|_| out.flush())
        .map_err(|e| Error::io("<stdout>", e))
}
