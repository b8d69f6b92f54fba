//! Reading: a file (text, gzip, raw binary or a log) into a [`Table`] with its rate, as
//! [`Input`] says. The `imunoise` command's input flags map one to one onto [`Input`]'s
//! fields.

use crate::error::{Error, Result};
use crate::io::{self, BinaryType, ReadOptions, Table};
use crate::logs;
use crate::ui::Ui;
use std::path::PathBuf;

/// What to read and how: the library form of the command's input flags.
///
/// ```no_run
/// use imunoise::pipeline::read::Input;
/// let input = Input { rate: Some(100.0), ..Input::new("imu.csv.gz") };
/// let table = input.read(&imunoise::Ui::quiet())?;
/// println!("{} channels at {} Hz", table.columns.len(), table.rate()?);
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Input {
    /// The file (a folder for a ROS 2 bag; `-` for standard input).
    pub file: PathBuf,
    /// Sampling rate in Hz; required for input without time stamps. For stamped input the
    /// rate comes from the stamps (median Δt) and a rate more than 1 % away is an error.
    pub rate: Option<f64>,
    /// Columns to read: header names or 1-based indices and ranges (`gyro_x,acc_z`, `1-3`).
    pub columns: Option<String>,
    /// Raw little-endian binary of this type, row-major.
    pub binary: Option<BinaryType>,
    /// Channels per row of binary input.
    pub channels: Option<usize>,
    /// A factor every value is multiplied by.
    pub scale: Option<f64>,
    /// Channel names (comma list, after `columns`), replacing the header's.
    pub names: Option<String>,
    /// Units: one for all channels or a comma list (see [`crate::units`]); default: from
    /// the channel names' suffixes.
    pub unit: Option<String>,
    /// IMU topics of a log to read (empty: the only IMU topic).
    pub topic: Vec<String>,
    /// The log format when the extension does not tell.
    pub log_format: Option<logs::LogFormat>,
    /// Text input: the column holding time stamps.
    pub time_column: Option<String>,
    /// Unit of `time_column`.
    pub time_unit: TimeUnit,
    /// What to do with gaps in time-stamped input.
    pub gaps: logs::GapPolicy,
    /// Logs: the instance of each `topic` (ULog multi id, DataFlash `I`): `--topic
    /// sensor_gyro` with instance 1 reads `sensor_gyro[1]` (see [`logs::instance_topic`]).
    pub instance: Option<u32>,
    /// Logs: refuse a cut-off file instead of reading its complete messages with a warning.
    pub strict: bool,
}

impl Input {
    /// Reads `file` with every option at its default (text, gzip or a log by extension).
    ///
    /// ```
    /// use imunoise::pipeline::read::{Input, TimeUnit};
    /// let input = Input::new("imu.csv");
    /// assert_eq!(input.file, std::path::Path::new("imu.csv"));
    /// assert!(input.rate.is_none() && input.columns.is_none() && input.topic.is_empty());
    /// assert_eq!(input.time_unit, TimeUnit::S);
    /// assert_eq!(input.gaps, imunoise::logs::GapPolicy::Refuse);
    /// ```
    pub fn new(file: impl Into<PathBuf>) -> Self {
        Input {
            file: file.into(),
            rate: None,
            columns: None,
            binary: None,
            channels: None,
            scale: None,
            names: None,
            unit: None,
            topic: Vec::new(),
            log_format: None,
            time_column: None,
            time_unit: TimeUnit::S,
            gaps: logs::GapPolicy::Refuse,
            instance: None,
            strict: false,
        }
    }

    /// Each channel's unit: `unit` if given, else from the channel names (see
    /// [`crate::units::channel_units`]).
    ///
    /// ```
    /// use imunoise::pipeline::read::Input;
    /// use imunoise::processes::Unit;
    /// let text = b"gyro_x_dps,acc_x_g\n1,2\n";
    /// let t = imunoise::io::read_bytes(text, "mem.csv", &Default::default())?;
    /// assert_eq!(Input::new("mem.csv").units(&t)?, [Unit::DegPerSec, Unit::G]);
    /// let given = Input { unit: Some("rad/s,m/s^2".into()), ..Input::new("mem.csv") };
    /// assert_eq!(given.units(&t)?, [Unit::RadPerSec, Unit::MetrePerSec2]);
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn units(&self, table: &Table) -> Result<Vec<processes::Unit>> {
        crate::units::channel_units(&table.names, self.unit.as_deref())
    }
}

/// Unit of a text time column (`--time-unit`).
///
/// ```
/// use clap::ValueEnum;
/// use imunoise::pipeline::read::TimeUnit;
/// assert_eq!(TimeUnit::from_str("us", false), Ok(TimeUnit::Us));
/// assert_eq!(imunoise::pipeline::read::Input::new("x.csv").time_unit, TimeUnit::S);
/// ```
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
    ///
    /// ```
    /// use imunoise::pipeline::read::TimeUnit;
    /// assert_eq!(TimeUnit::S.ns(), 1e9);
    /// assert_eq!(TimeUnit::Ms.ns(), 1e3 * TimeUnit::Us.ns());
    /// assert_eq!(TimeUnit::Ns.ns(), 1.0);
    /// ```
    pub fn ns(self) -> f64 {
        match self {
            TimeUnit::S => 1e9,
            TimeUnit::Ms => 1e6,
            TimeUnit::Us => 1e3,
            TimeUnit::Ns => 1.0,
        }
    }

    /// A time stamp `v` in this unit as integer nanoseconds (rounded), as the stamps of
    /// `--time-column` are read by `avar` and `live` alike.
    pub(crate) fn stamp_ns(self, v: f64) -> i64 {
        (v * self.ns()).round() as i64
    }
}

/// `--time-column`: one column of stamps in `--time-unit`, or two written `SEC+NSEC`, whole
/// seconds and nanoseconds (the two fields of a ROS message header's stamp, columns 1 and 2
/// of `ros2 topic echo --csv`), each a column name or 1-based index.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TimeColumns {
    /// The stamp columns as asked for: [stamp] or [seconds, nanoseconds].
    pub(crate) specs: Vec<io::ColumnSpec>,
    unit: TimeUnit,
}

impl TimeColumns {
    /// Parses `--time-column` (`COL` or `SEC+NSEC`) with the unit of a one-column stamp.
    pub(crate) fn parse(tc: &str, unit: TimeUnit) -> Result<TimeColumns> {
        let one = |part: &str| -> Result<io::ColumnSpec> {
            let spec = io::parse_columns(part)?;
            match spec.as_slice() {
                [s] if !matches!(s, io::ColumnSpec::Range(..)) => Ok(s.clone()),
                _ => Err(Error::Usage(format!(
                    "--time-column {tc:?}: give one column name or index, or two as SEC+NSEC \
                     (whole seconds and nanoseconds)"
                ))),
            }
        };
        let specs = match tc.split_once('+') {
            Some((sec, nsec)) => vec![one(sec.trim())?, one(nsec.trim())?],
            None => vec![one(tc)?],
        };
        if specs.len() == 2 && specs[0] == specs[1] {
            return Err(Error::Usage(format!(
                "--time-column {tc:?}: the seconds and nanoseconds columns are the same"
            )));
        }
        Ok(TimeColumns { specs, unit })
    }

    /// The stamp (ns) of a row from the values of its stamp columns, in the order of
    /// [`TimeColumns::specs`]: v·(ns per unit) rounded, or seconds·10^9 + nanoseconds (a
    /// fraction of the seconds counted too; exact for whole seconds and nanoseconds).
    pub(crate) fn stamp_ns(&self, v: &[f64]) -> i64 {
        match *v {
            [sec, nsec] => {
                let whole = sec.trunc();
                (whole as i64)
                    .saturating_mul(1_000_000_000)
                    .saturating_add(((sec - whole) * 1e9 + nsec).round() as i64)
            }
            _ => self.unit.stamp_ns(v[0]),
        }
    }

    /// Takes the stamp columns (or their names) out of `v` at the distinct indices `idx`
    /// (one per spec), and returns them in spec order.
    pub(crate) fn take<T>(idx: &[usize], v: &mut Vec<T>) -> Vec<T> {
        let mut order: Vec<usize> = (0..idx.len()).collect();
        order.sort_by_key(|&k| std::cmp::Reverse(idx[k]));
        let mut taken: Vec<Option<T>> = (0..idx.len()).map(|_| None).collect();
        for k in order {
            taken[k] = Some(v.remove(idx[k]));
        }
        taken
            .into_iter()
            .map(|t| t.expect("each index taken once"))
            .collect()
    }
}

impl Input {
    /// The log format of the input, if it is a log (a folder is a ROS 2 bag). With
    /// `--binary` the input is raw binary whatever its extension, and a `.bin` file is a
    /// DataFlash log only when it starts with a DataFlash message header (A3 95).
    ///
    /// ```
    /// use imunoise::io::BinaryType;
    /// use imunoise::logs::LogFormat;
    /// use imunoise::pipeline::read::Input;
    /// assert_eq!(Input::new("run.mcap").log_format(), Some(LogFormat::Mcap));
    /// assert_eq!(Input::new("imu.csv").log_format(), None);
    /// let raw = Input { binary: Some(BinaryType::F64), ..Input::new("run.mcap") };
    /// assert_eq!(raw.log_format(), None);
    /// // a .bin file: DataFlash only with the message header
    /// let dir = tempfile::tempdir()?;
    /// let (df, other) = (dir.path().join("ap.bin"), dir.path().join("raw.bin"));
    /// std::fs::write(&df, [0xA3, 0x95, 0x80])?;
    /// std::fs::write(&other, [0u8; 16])?;
    /// assert_eq!(Input::new(&df).log_format(), Some(LogFormat::Dataflash));
    /// assert_eq!(Input::new(&other).log_format(), None);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
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
    /// [`Input::read_all`]).
    ///
    /// ```
    /// use imunoise::pipeline::{read::Input, simulate};
    /// let model: imunoise::processes::Model = "WN(sigma2=1e-4)".parse()?;
    /// let cols = simulate::simulate_channels(&model, 1000, 100.0, 1, 2)?;
    /// let dir = tempfile::tempdir()?;
    /// let p = dir.path().join("imu.csv");
    /// let names = ["gx".to_string(), "gy".to_string()];
    /// simulate::write_csv(&mut std::fs::File::create(&p)?, &names, &cols)?;
    /// let input = Input { rate: Some(100.0), columns: Some("gy".into()), ..Input::new(&p) };
    /// let t = input.read(&imunoise::Ui::quiet())?;
    /// assert_eq!(t.names, ["gy"]);
    /// assert_eq!(t.rate()?, 100.0);
    /// // the CSV holds each value's shortest round-trip form: the values come back exactly
    /// assert_eq!(t.columns[0], cols[1]);
    /// // without time stamps, the rate must be given
    /// assert!(Input::new(&p).read(&imunoise::Ui::quiet()).is_err());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
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
    /// with its rate (from --rate or the stamps) and, for stamped input, its timing. A regular
    /// raw binary file (`binary` set, not gzip, no time column) comes through
    /// [`crate::source::decode_binary`]: its columns are [`io::Column::Mapped`] (one f64
    /// channel is the file itself), with the values the in-memory reader gives.
    ///
    /// ```
    /// use imunoise::io::{BinaryType, Column};
    /// use imunoise::pipeline::read::{Input, TimeUnit};
    /// let ui = imunoise::Ui::quiet();
    /// let dir = tempfile::tempdir()?;
    /// // text with a time column in ms, 100 Hz stamps: the rate comes from them
    /// let p = dir.path().join("stamped.csv");
    /// let rows: String = (0..500).map(|i| format!("{},{}\n", 10 * i, i % 7)).collect();
    /// std::fs::write(&p, format!("t,gx\n{rows}"))?;
    /// let input = Input {
    ///     time_column: Some("t".into()),
    ///     time_unit: TimeUnit::Ms,
    ///     ..Input::new(&p)
    /// };
    /// let tables = input.read_all(&ui)?;
    /// assert_eq!(tables.len(), 1); // one table: not a log
    /// assert_eq!(tables[0].names, ["gx"]); // the time column is taken out
    /// assert_eq!(tables[0].rate_hz, Some(100.0));
    /// assert_eq!(tables[0].timing.as_ref().map(|t| t.gaps), Some(0));
    /// // one channel of raw f64 is used in place, mapped
    /// let w = dir.path().join("w.f64");
    /// let x: Vec<f64> = (0..256).map(|i| (i % 5) as f64).collect();
    /// std::fs::write(&w, x.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>())?;
    /// let raw = Input { binary: Some(BinaryType::F64), rate: Some(10.0), ..Input::new(&w) };
    /// let t = raw.read_all(&ui)?.remove(0);
    /// assert!(matches!(t.columns[0], Column::Mapped(_)));
    /// assert_eq!(t.columns[0], x);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn read_all(&self, ui: &Ui) -> Result<Vec<Table>> {
        // standard input, pipes and FIFOs cannot be read by position: say what that costs
        // (a path that cannot be looked up gets no note: the read says what is wrong)
        if let Some(why) =
            crate::source::unseekable(&self.file).filter(|_| !crate::source::is_regular(&self.file))
        {
            ui.note(format!(
                "note: {} cannot be read by position: it is read whole into memory first (its \
                 size in bytes, then 8 bytes per value)",
                crate::source::unseekable_subject(&self.file, why),
            ));
        }
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
            Some(tc) => Some(TimeColumns::parse(tc, self.time_unit)?),
        };
        if let Some(kind) = self.binary
            && time_col.is_none()
            && let Some(t) = self.read_binary_file(kind, columns.as_deref())?
        {
            return Ok(t);
        }
        let mut time_first = false;
        if let (Some(tc), Some(cols)) = (&time_col, columns.as_mut()) {
            // Read the time columns too, first; they are taken out below.
            cols.splice(0..0, tc.specs.iter().cloned());
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
                (0..tc.specs.len()).collect()
            } else {
                io::resolve_columns(&tc.specs, &t.names)?
            };
            if idx.len() == 2 && idx[0] == idx[1] {
                return Err(Error::Usage(format!(
                    "--time-column: the seconds and nanoseconds columns are the same ({})",
                    t.names[idx[0]]
                )));
            }
            let time = TimeColumns::take(&idx, &mut t.columns);
            let tname = TimeColumns::take(&idx, &mut t.names).join("+");
            if t.columns.is_empty() {
                return Err(Error::Usage(format!(
                    "--time-column {tname:?} is the only column; nothing left to analyse"
                )));
            }
            let mut v = vec![0.0; time.len()];
            let stamps: Vec<i64> = (0..time[0].len())
                .map(|i| {
                    for (vk, c) in v.iter_mut().zip(&time) {
                        *vk = c[i];
                    }
                    tc.stamp_ns(&v)
                })
                .collect();
            let (cols, timing) = logs::timing::prepare(
                stamps,
                std::mem::take(&mut t.columns)
                    .into_iter()
                    .map(io::Column::into_vec)
                    .collect(),
                self.rate,
                self.gaps,
                &t.file,
            )?;
            t.columns = cols.into_iter().map(Into::into).collect();
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

    /// A raw binary regular file (not gzip) through [`crate::source::decode_binary`]: one f64
    /// channel is used in place (the file mapped, no copy), other layouts are decoded in one
    /// parallel pass (the scale applied there, as [`Input::finish`] would apply it: the same
    /// values). `None` for other inputs, which the in-memory reader takes.
    fn read_binary_file(
        &self,
        kind: BinaryType,
        columns: Option<&[io::ColumnSpec]>,
    ) -> Result<Option<Table>> {
        let name = self.file.display().to_string();
        if name.ends_with(".gz")
            || !crate::source::is_regular(&self.file)
            || crate::source::is_gzip(&self.file)
        {
            return Ok(None);
        }
        let layout = crate::source::BinaryLayout {
            scale: self.scale,
            ..crate::source::BinaryLayout::new(kind, self.channels.unwrap_or(1))
        };
        let all: Vec<String> = (1..=layout.channels).map(|c| format!("ch{c}")).collect();
        let idx: Vec<usize> = match columns {
            Some(spec) => io::resolve_columns(spec, &all)?,
            None => (0..layout.channels).collect(),
        };
        if (1..idx.len()).any(|i| idx[..i].contains(&idx[i])) {
            return Err(Error::Usage(
                "--columns names the same column twice".to_string(),
            ));
        }
        let maps = crate::source::decode_binary(&self.file, &name, &layout, &idx)?;
        // a file used in place has not been looked at yet: its values must be finite too (the
        // decoded copies were checked as they were made)
        if crate::source::used_in_place(&self.file, &layout) {
            use rayon::prelude::*;
            for (m, &c) in maps.iter().zip(&idx) {
                let x = avar::SampleSource::samples(m);
                if let Some(r) = x.par_iter().position_first(|v| !v.is_finite()) {
                    return Err(crate::source::non_finite(&name, r, c, x[r]));
                }
            }
        }
        let mut t = Table {
            file: name,
            names: idx.iter().map(|&i| all[i].clone()).collect(),
            columns: maps
                .into_iter()
                .map(|m| io::Column::Mapped(std::sync::Arc::new(m)))
                .collect(),
            rate_hz: self.rate,
            timing: None,
            topic: None,
        };
        self.finish_names(&mut t)?;
        t.rate()?;
        Ok(Some(t))
    }

    /// `--scale` and `--names`, after the columns are final.
    fn finish(&self, t: &mut Table) -> Result<()> {
        if let Some(scale) = self.scale {
            if !(scale.is_finite() && scale != 0.0) {
                return Err(Error::Usage(format!(
                    "--scale must be finite and non-zero, got {scale}"
                )));
            }
            for (k, c) in t.columns.iter_mut().enumerate() {
                c.to_mut().iter_mut().for_each(|v| *v *= scale);
                // a scale that takes a value beyond f64 is named, not turned into inf silently
                if let Some(row) = c.iter().position(|v| !v.is_finite()) {
                    return Err(Error::Usage(format!(
                        "--scale {scale:e} takes the value of channel {:?} at row {} beyond the \
                         range of f64",
                        t.names[k],
                        row + 1
                    )));
                }
            }
        }
        self.finish_names(t)
    }

    /// `--names`, after the columns are final.
    fn finish_names(&self, t: &mut Table) -> Result<()> {
        t.names = self.renamed(std::mem::take(&mut t.names))?;
        Ok(())
    }

    /// The channel names after `--names` (the given ones, one per channel), or `names` as
    /// they are without it.
    pub(crate) fn renamed(&self, names: Vec<String>) -> Result<Vec<String>> {
        let names = match &self.names {
            None => names,
            Some(list) => {
                let given: Vec<String> = list.split(',').map(|n| n.trim().to_string()).collect();
                if given.len() != names.len() {
                    return Err(Error::Usage(format!(
                        "--names gives {} names for {} channels",
                        given.len(),
                        names.len()
                    )));
                }
                given
            }
        };
        unique_names(&self.file.display().to_string(), &names)?;
        Ok(names)
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
        let reader = logs::open_checked(&path, fmt, self.strict, ui)?;
        let mut requested = self.instance_topics(reader.as_ref(), &file)?;
        if requested.is_empty() {
            requested = preferred(reader.as_ref(), &file, ui)?;
        }
        let topics = logs::select_topics(reader.as_ref(), &file, &requested)?;
        let truncated = reader.truncation();
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
            let timing = logs::Timing {
                truncated,
                ..timing
            };
            ui.note(format!("{topic}: {}", timing.summary()));
            let mut t = Table {
                file: file.clone(),
                names: series.names,
                columns: cols.into_iter().map(Into::into).collect(),
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

/// A flight log's high-rate IMU topics ([`logs::preferred_topics`]), with a note saying they
/// are read.
fn preferred(reader: &dyn logs::LogReader, file: &str, ui: &Ui) -> Result<Vec<String>> {
    let preferred = logs::preferred_topics(&reader.topics()?);
    if !preferred.is_empty() {
        ui.note(format!(
            "note: {file}: reading the high-rate IMU topics {} (choose others with --topic; \
             `imunoise topics {file}` lists them)",
            preferred.join(", ")
        ));
    }
    Ok(preferred)
}

impl Input {
    /// With no `topic` given, a log's high-rate IMU topics (PX4 FIFO, ArduPilot batch
    /// sampler; see [`logs::preferred_topics`]), which the readers use then; a note says so.
    /// Empty for other input, or when topics are given or the log has none.
    ///
    /// ```
    /// use imunoise::pipeline::read::Input;
    /// let ui = imunoise::Ui::quiet();
    /// assert!(Input::new("imu.csv").preferred_topics(&ui)?.is_empty());
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn preferred_topics(&self, ui: &Ui) -> Result<Vec<String>> {
        let Some(fmt) = self.log_format() else {
            return Ok(Vec::new());
        };
        if !self.topic.is_empty() {
            return Ok(Vec::new());
        }
        let path = logs::storage_file(&self.file)?;
        let file = path.display().to_string();
        let reader = logs::open_checked(&path, fmt, self.strict, &Ui::quiet())?;
        preferred(reader.as_ref(), &file, ui)
    }

    /// The topics asked for, with `instance` applied (`--topic sensor_gyro --instance 1` is
    /// `sensor_gyro[1]`).
    fn instance_topics(&self, reader: &dyn logs::LogReader, file: &str) -> Result<Vec<String>> {
        let Some(k) = self.instance else {
            return Ok(self.topic.clone());
        };
        if self.topic.is_empty() {
            return Err(Error::Usage(
                "--instance needs --topic NAME (the message whose instance to read)".to_string(),
            ));
        }
        let all = reader.topics()?;
        self.topic
            .iter()
            .map(|name| {
                logs::instance_topic(&all, name, k).ok_or_else(|| {
                    let have: Vec<&str> = all
                        .iter()
                        .filter(|t| {
                            t.name == *name
                                || t.name
                                    .strip_prefix(name.as_str())
                                    .is_some_and(|r| r.starts_with('[') && r.ends_with(']'))
                        })
                        .map(|t| t.name.as_str())
                        .collect();
                    Error::Usage(format!(
                        "--topic {name} --instance {k}: {file} has no such instance; its \
                         instances of {name}: {}",
                        if have.is_empty() {
                            "none".to_string()
                        } else {
                            have.join(", ")
                        }
                    ))
                })
            })
            .collect()
    }
}

/// Checks that the channel names of `what` (a file, or `<array>`) differ: they key the
/// outputs (plots, `results.json`, config files), and two equal names would overwrite each
/// other's files.
///
/// ```
/// use imunoise::pipeline::read::unique_names;
/// assert!(unique_names("imu.csv", &["gx".into(), "gy".into()]).is_ok());
/// let e = unique_names("imu.csv", &["gx".into(), "gy".into(), "gx".into()]).unwrap_err();
/// assert!(e.to_string().contains("channels 1 and 3 are both named \"gx\""));
/// ```
pub fn unique_names(what: &str, names: &[String]) -> Result<()> {
    for (j, n) in names.iter().enumerate() {
        if let Some(i) = names[..j].iter().position(|m| m == n) {
            return Err(Error::Usage(format!(
                "{what}: channels {} and {} are both named {n:?}; the names key the outputs \
                 (plots, results.json, config files), so they must differ: give --names",
                i + 1,
                j + 1
            )));
        }
    }
    Ok(())
}

/// A sampling rate in Hz (`--rate`): a finite number > 0.
///
/// ```
/// use imunoise::pipeline::read::parse_rate;
/// assert_eq!(parse_rate(" 200 "), Ok(200.0));
/// assert!(parse_rate("0").is_err() && parse_rate("inf").is_err() && parse_rate("x").is_err());
/// ```
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

/// A finite non-zero factor (`--scale`): a number or a fraction `a/b`.
///
/// ```
/// use imunoise::pipeline::read::parse_factor;
/// assert_eq!(parse_factor("1/131"), Ok(1.0 / 131.0));
/// assert_eq!(parse_factor("-2"), Ok(-2.0));
/// assert!(parse_factor("0").is_err() && parse_factor("1/0").is_err());
/// ```
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
