//! Readers for the logs people record IMUs in: ROS 2 MCAP, ROS 1 bags, ROS 2 SQLite
//! (`.db3`), PX4 ULog and ArduPilot DataFlash. One module per format, each behind the
//! [`LogReader`] interface; the format is picked by extension (or `--log-format`).
//!
//! A reader lists its topics ([`LogReader::topics`]) and reads one IMU topic into stamped
//! columns ([`LogReader::read_imu`]). [`select_topics`] applies the `--topic` rules and
//! [`timing::prepare`] orders the samples by stamp, estimates the rate and counts gaps.
//! Files are memory-mapped (or read by SQLite page by page): never copied whole.
//!
//! Units: bags (ROS REP 103) give angular velocity in rad/s and linear acceleration in
//! m/s²; PX4 and ArduPilot log the same units. Channel names carry them as suffixes
//! (`gyro_x_rads`, `acc_x_mps2`), which [`crate::units::infer_unit`] reads.

use crate::error::{Error, Result};
use serde::Serialize;
#[cfg(any(feature = "mcap", feature = "rosbag"))]
use std::mem::MaybeUninit;
use std::path::Path;

pub mod imu_msg;
pub mod timing;

#[cfg(feature = "dataflash")]
pub mod dataflash;
#[cfg(feature = "db3")]
pub mod db3;
#[cfg(feature = "mcap")]
pub mod mcap;
#[cfg(feature = "rosbag")]
pub mod rosbag1;
#[cfg(feature = "ulog")]
pub mod ulog;

pub use timing::{GapPolicy, Timing};

/// A log file format.
///
/// ```
/// use clap::ValueEnum;
/// use imunoise::logs::LogFormat;
/// // `--log-format` and the JSON output spell it in lower case
/// assert_eq!(LogFormat::from_str("ulog", false), Ok(LogFormat::Ulog));
/// assert_eq!(serde_json::to_string(&LogFormat::Dataflash).unwrap(), "\"dataflash\"");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LogFormat {
    /// ROS 2 MCAP (`.mcap`), CDR-encoded messages.
    Mcap,
    /// ROS 1 bag (`.bag`).
    Bag,
    /// ROS 2 SQLite storage (`.db3`).
    Db3,
    /// PX4 ULog (`.ulg`).
    Ulog,
    /// ArduPilot DataFlash binary log (`.bin`).
    Dataflash,
}

impl LogFormat {
    /// The format of a path by its extension, if it is a log format.
    ///
    /// ```
    /// use imunoise::logs::LogFormat;
    /// assert_eq!(LogFormat::from_path("run.mcap".as_ref()), Some(LogFormat::Mcap));
    /// assert_eq!(LogFormat::from_path("imu.csv".as_ref()), None);
    /// ```
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Some(match ext.as_str() {
            "mcap" => LogFormat::Mcap,
            "bag" => LogFormat::Bag,
            "db3" => LogFormat::Db3,
            "ulg" => LogFormat::Ulog,
            "bin" => LogFormat::Dataflash,
            _ => return None,
        })
    }

    /// The cargo feature that builds this format's reader.
    ///
    /// ```
    /// use imunoise::logs::LogFormat;
    /// assert_eq!(LogFormat::Bag.feature(), "rosbag");
    /// assert_eq!(LogFormat::Mcap.feature(), "mcap");
    /// ```
    pub fn feature(self) -> &'static str {
        match self {
            LogFormat::Mcap => "mcap",
            LogFormat::Bag => "rosbag",
            LogFormat::Db3 => "db3",
            LogFormat::Ulog => "ulog",
            LogFormat::Dataflash => "dataflash",
        }
    }
}

/// A topic (bags) or message/instance (ULog, DataFlash) of a log, as
/// [`LogReader::topics`] lists it ([`open`] shows one read from an MCAP file).
///
/// ```
/// use imunoise::logs::TopicInfo;
/// let t = TopicInfo {
///     name: "/imu0".into(),
///     msg_type: "sensor_msgs/msg/Imu".into(),
///     count: 720_000,
///     is_imu: true,
/// };
/// // plain data, serializable
/// let v = serde_json::to_value(&t)?;
/// assert_eq!((v["name"].as_str(), v["count"].as_u64()), (Some("/imu0"), Some(720_000)));
/// # Ok::<(), serde_json::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TopicInfo {
    /// Topic name (`/imu0`), or message name and instance (`sensor_combined`, `IMU[1]`).
    pub name: String,
    /// Message type (`sensor_msgs/msg/Imu`, …).
    pub msg_type: String,
    /// Number of messages.
    pub count: u64,
    /// Whether imunoise reads IMU samples from it.
    pub is_imu: bool,
}

/// The samples of one IMU topic in recording order, with their stamps.
///
/// ```
/// use imunoise::logs::{IMU_NAMES, ImuSeries, imu_msg::ImuSample};
/// let mut s = ImuSeries::with_capacity(2);
/// for (i, g) in [0.5, -0.5].into_iter().enumerate() {
///     let (gyro, acc) = ([g, 0.0, 0.0], [0.0, 0.0, 9.81]);
///     s.push(&ImuSample { stamp_ns: 1_000 * i as i64, gyro, acc });
/// }
/// assert_eq!(s.names, IMU_NAMES);
/// assert_eq!(s.stamps_ns, [0, 1_000]);
/// assert_eq!(s.columns[0], [0.5, -0.5]); // gyro_x_rads
/// assert_eq!(s.columns[5], [9.81, 9.81]); // acc_z_mps2
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct ImuSeries {
    /// Stamps (ns; header stamps for bags, the log's microseconds × 1000 otherwise).
    pub stamps_ns: Vec<i64>,
    /// Channel names with unit suffixes (`gyro_x_rads`, …, `acc_z_mps2`).
    pub names: Vec<String>,
    /// One column per channel, same length as `stamps_ns`.
    pub columns: Vec<Vec<f64>>,
}

#[cfg(any(feature = "mcap", feature = "rosbag"))]
/// Where a log reader's chunk decoder puts the samples: a growing [`ImuSeries`], or a
/// [`SliceSink`] (the chunk's place in the final columns).
pub(crate) trait SamplePush {
    /// Appends one sample.
    fn push_sample(&mut self, s: &imu_msg::ImuSample);
}

#[cfg(any(feature = "mcap", feature = "rosbag"))]
impl SamplePush for ImuSeries {
    fn push_sample(&mut self, s: &imu_msg::ImuSample) {
        self.push(s);
    }
}

#[cfg(any(feature = "mcap", feature = "rosbag"))]
/// A chunk's place in the final columns, of the length its log's index gives; more
/// messages than that set `overflow` (and are not stored).
pub(crate) struct SliceSink<'a> {
    pub(crate) stamps: &'a mut [MaybeUninit<i64>],
    pub(crate) columns: [&'a mut [MaybeUninit<f64>]; 6],
    pub(crate) n: usize,
    pub(crate) overflow: bool,
}

#[cfg(any(feature = "mcap", feature = "rosbag"))]
impl SamplePush for SliceSink<'_> {
    fn push_sample(&mut self, s: &imu_msg::ImuSample) {
        let i = self.n;
        if i >= self.stamps.len() {
            self.overflow = true;
            return;
        }
        self.stamps[i].write(s.stamp_ns);
        for k in 0..3 {
            self.columns[k][i].write(s.gyro[k]);
            self.columns[3 + k][i].write(s.acc[k]);
        }
        self.n += 1;
    }
}

#[cfg(any(feature = "mcap", feature = "rosbag"))]
/// Reads `parts` (a log's chunks) in parallel straight into their places in the final
/// columns: part k holds `counts[k]` samples (from the log's index) and `read(part, base,
/// sink)` decodes them into `sink`, `base` being the index of its first sample in the series.
/// No per-part series to join afterwards (that join took 0.37 s of one thread for 1.08·10^7
/// MCAP messages). `Ok(None)` when a part holds another number of samples than its count
/// (the index does not match the data: the caller reads another way) or the columns cannot be
/// reserved or would hold more than 2^27 samples (1 GiB per column); otherwise the first error in part order, or the series.
pub(crate) fn read_parts_into<P: Sync>(
    parts: &[P],
    counts: &[usize],
    read: impl Fn(&P, usize, &mut SliceSink<'_>) -> Result<()> + Sync,
) -> Result<Option<ImuSeries>> {
    use rayon::prelude::*;
    let Some(total) = counts.iter().try_fold(0usize, |a, &n| a.checked_add(n)) else {
        return Ok(None);
    };
    if total > MAX_PARALLEL {
        return Ok(None);
    }
    let mut stamps_v: Vec<i64> = Vec::new();
    let mut cols_v: Vec<Vec<f64>> = (0..6).map(|_| Vec::new()).collect();
    if stamps_v.try_reserve_exact(total).is_err()
        || !cols_v
            .iter_mut()
            .all(|c| c.try_reserve_exact(total).is_ok())
    {
        return Ok(None);
    }
    let mut stamps = &mut stamps_v.spare_capacity_mut()[..total];
    let mut cols: Vec<&mut [MaybeUninit<f64>]> = cols_v
        .iter_mut()
        .map(|c| &mut c.spare_capacity_mut()[..total])
        .collect();
    let mut jobs = Vec::with_capacity(parts.len());
    let mut base = 0;
    for (part, &n) in parts.iter().zip(counts) {
        let (here, rest) = std::mem::take(&mut stamps).split_at_mut(n);
        stamps = rest;
        let columns: [&mut [MaybeUninit<f64>]; 6] = std::array::from_fn(|k| {
            let (here, rest) = std::mem::take(&mut cols[k]).split_at_mut(n);
            cols[k] = rest;
            here
        });
        let sink = SliceSink {
            stamps: here,
            columns,
            n: 0,
            overflow: false,
        };
        jobs.push((part, base, sink));
        base += n;
    }
    let done: Vec<Result<bool>> = jobs
        .into_par_iter()
        .map(|(part, base, mut sink)| {
            read(part, base, &mut sink)?;
            Ok(!sink.overflow && sink.n == sink.stamps.len())
        })
        .collect();
    if done.iter().any(|d| matches!(d, Ok(false))) {
        return Ok(None);
    }
    for d in done {
        d?;
    }
    // SAFETY: the sinks' slices partition [0, total) of each column's spare capacity, and
    // every sink wrote all of its slice (n == its length, checked above).
    unsafe {
        stamps_v.set_len(total);
        cols_v.iter_mut().for_each(|c| c.set_len(total));
    }
    Ok(Some(ImuSeries {
        stamps_ns: stamps_v,
        names: IMU_NAMES.iter().map(|s| s.to_string()).collect(),
        columns: cols_v,
    }))
}

/// The most samples a reader reserves room for up front from a count the file states
/// (2^24 = 16,777,216 samples: 128 MiB per column of f64; 4.7 hours at 1 kHz). Counts come
/// from indexes and statistics records that a damaged or forged file can set to anything (a
/// 116 kB ROS bag whose chunk info claims 2^28 IMU messages made the reader reserve 2 GiB per
/// column); longer series grow as their samples are read.
///
/// ```
/// use imunoise::logs::{ImuSeries, MAX_RESERVE};
/// let s = ImuSeries::with_capacity(usize::MAX);
/// assert!(s.stamps_ns.capacity() >= MAX_RESERVE && s.stamps_ns.capacity() < 2 * MAX_RESERVE);
/// ```
pub const MAX_RESERVE: usize = 1 << 24;

/// The most samples [`read_parts_into`] reserves in one go: 2^27, so that each column is at
/// most 1 GiB (a larger total from an index is read the other way, growing as it goes).
#[cfg(any(feature = "mcap", feature = "rosbag"))]
const MAX_PARALLEL: usize = 1 << 27;

/// The six channel names of an IMU, units as suffixes (rad/s, m/s²).
pub const IMU_NAMES: [&str; 6] = [
    "gyro_x_rads",
    "gyro_y_rads",
    "gyro_z_rads",
    "acc_x_mps2",
    "acc_y_mps2",
    "acc_z_mps2",
];

impl ImuSeries {
    /// An empty series with the six [`IMU_NAMES`] channels and room for `n` samples, at most
    /// [`MAX_RESERVE`] (the series grows past that as samples are pushed).
    ///
    /// ```
    /// use imunoise::logs::{IMU_NAMES, ImuSeries};
    /// let s = ImuSeries::with_capacity(1000);
    /// assert_eq!(s.names, IMU_NAMES);
    /// assert_eq!(s.columns.len(), 6);
    /// assert!(s.stamps_ns.is_empty());
    /// assert!(s.columns.iter().all(|c| c.is_empty() && c.capacity() >= 1000));
    /// ```
    pub fn with_capacity(n: usize) -> Self {
        // `n` is often a count the file states (an index, a statistics record, a COUNT(*)),
        // which a forged file sets as it likes: room for more than MAX_RESERVE samples is
        // made by pushing them, not reserved up front
        let n = n.min(MAX_RESERVE);
        ImuSeries {
            stamps_ns: Vec::with_capacity(n),
            names: IMU_NAMES.iter().map(|s| s.to_string()).collect(),
            columns: (0..6).map(|_| Vec::with_capacity(n)).collect(),
        }
    }

    /// Appends one sample (stamp in ns, gyro in rad/s, acc in m/s²).
    ///
    /// ```
    /// use imunoise::logs::{ImuSeries, imu_msg::ImuSample};
    /// let mut s = ImuSeries::with_capacity(1);
    /// s.push(&ImuSample { stamp_ns: 7, gyro: [1.0, 2.0, 3.0], acc: [4.0, 5.0, 6.0] });
    /// assert_eq!(s.stamps_ns, [7]);
    /// let row: Vec<f64> = s.columns.iter().map(|c| c[0]).collect();
    /// assert_eq!(row, [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]); // gyro x, y, z, then acc x, y, z
    /// ```
    #[inline]
    pub fn push(&mut self, s: &imu_msg::ImuSample) {
        self.stamps_ns.push(s.stamp_ns);
        for k in 0..3 {
            self.columns[k].push(s.gyro[k]);
            self.columns[3 + k].push(s.acc[k]);
        }
    }

    /// Errors on non-finite values, naming the message (1-based) and channel.
    ///
    /// ```
    /// use imunoise::logs::{ImuSeries, imu_msg::ImuSample};
    /// let mut s = ImuSeries::with_capacity(2);
    /// s.push(&ImuSample { stamp_ns: 0, gyro: [0.0; 3], acc: [0.0; 3] });
    /// assert!(s.check_finite("run.mcap (/imu0)").is_ok());
    /// s.push(&ImuSample { stamp_ns: 1, gyro: [0.0, f64::NAN, 0.0], acc: [0.0; 3] });
    /// let e = s.check_finite("run.mcap (/imu0)").unwrap_err();
    /// assert_eq!(
    ///     e.to_string(),
    ///     "run.mcap (/imu0): message 2 has gyro_y_rads = NaN: values must be finite"
    /// );
    /// ```
    pub fn check_finite(&self, what: &str) -> Result<()> {
        for (c, col) in self.columns.iter().enumerate() {
            if let Some(i) = col.iter().position(|v| !v.is_finite()) {
                return Err(Error::File {
                    file: what.to_string(),
                    message: format!(
                        "message {} has {} = {}: values must be finite",
                        i + 1,
                        self.names[c],
                        col[i]
                    ),
                });
            }
        }
        Ok(())
    }
}

/// Where a log is cut off (the power went while it was written): the reader keeps every
/// complete message before the cut and drops the incomplete bytes after it.
///
/// ```
/// use imunoise::logs::Truncation;
/// let t = Truncation { offset: 65_515, dropped_bytes: 21, last_stamp_ns: Some(84_000_000_000) };
/// assert_eq!(
///     t.to_string(),
///     "the file is cut off: the 21 bytes from byte 65515 on are an incomplete message and \
///      were dropped; every complete message before them was read (the last one stamped \
///      84.000000 s)"
/// );
/// // under --strict the same finding refuses the file, as an input error
/// assert_eq!(t.refuse("ap.bin").exit_code(), 2);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Truncation {
    /// File offset of the first byte dropped (the start of the incomplete message or record).
    pub offset: u64,
    /// Bytes dropped, from `offset` to the end of the file (or of the data section).
    pub dropped_bytes: u64,
    /// Stamp of the last complete message before the cut (ns, on the log's clock), if known.
    pub last_stamp_ns: Option<i64>,
}

impl std::fmt::Display for Truncation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.dropped_bytes == 0 {
            write!(
                f,
                "the file is cut off at byte {}, after a complete message (no bytes dropped; \
                 the records a closed file ends with are missing); every message before it \
                 was read",
                self.offset
            )?;
        } else {
            write!(
                f,
                "the file is cut off: the {} bytes from byte {} on are an incomplete message \
                 and were dropped; every complete message before them was read",
                self.dropped_bytes, self.offset
            )?;
        }
        match self.last_stamp_ns {
            Some(t) => write!(f, " (the last one stamped {:.6} s)", t as f64 * 1e-9),
            None => write!(f, " (none of them carries a stamp)"),
        }
    }
}

impl Truncation {
    /// The error `--strict` gives for a cut-off `file` (exit code 2).
    ///
    /// ```
    /// use imunoise::logs::Truncation;
    /// let t = Truncation { offset: 100, dropped_bytes: 7, last_stamp_ns: None };
    /// assert!(t.refuse("x.ulg").to_string().contains("--strict refuses cut-off logs"));
    /// ```
    pub fn refuse(&self, file: &str) -> Error {
        Error::File {
            file: file.to_string(),
            message: format!(
                "{self}; --strict refuses cut-off logs (without it the complete messages are read)"
            ),
        }
    }
}

/// Opens a log as [`open`] does and reports a cut-off file ([`LogReader::truncation`]): an
/// error under `strict`, else a warning through `ui` (the notes on stderr).
///
/// ```
/// # #[cfg(feature = "dataflash")] {
/// use imunoise::logs::{LogFormat, open_checked};
/// let pad = |s: &str, n: usize| {
///     let mut v = s.as_bytes().to_vec();
///     v.resize(n, 0);
///     v
/// };
/// // a DataFlash log: a FMT for BARO (TimeUS, Alt), two BARO messages, half of a third
/// let mut log = vec![0xA3, 0x95, 0x80, 0x41, 15];
/// log.extend([pad("BARO", 4), pad("Qf", 16), pad("TimeUS,Alt", 64)].concat());
/// for t in [1_000_000u64, 1_100_000, 1_200_000] {
///     log.extend([&[0xA3, 0x95, 0x41][..], &t.to_le_bytes(), &2.5f32.to_le_bytes()].concat());
/// }
/// log.truncate(log.len() - 6);
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("cut.bin");
/// std::fs::write(&path, &log)?;
/// let ui = imunoise::Ui::quiet();
/// let r = open_checked(&path, LogFormat::Dataflash, false, &ui)?;
/// assert_eq!(r.topics()?[0].count, 2);
/// let t = r.truncation().unwrap();
/// assert_eq!((t.offset, t.dropped_bytes, t.last_stamp_ns), (89 + 30, 9, Some(1_100_000_000)));
/// assert!(open_checked(&path, LogFormat::Dataflash, true, &ui).is_err());
/// # }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn open_checked(
    path: &Path,
    format: LogFormat,
    strict: bool,
    ui: &crate::ui::Ui,
) -> Result<Box<dyn LogReader>> {
    let reader = open(path, format)?;
    if let Some(t) = reader.truncation() {
        let file = path.display().to_string();
        if strict {
            return Err(t.refuse(&file));
        }
        ui.note(format!("warning: {file}: {t}"));
    }
    Ok(reader)
}

/// The topic of instance `k` of message `name`: `name[k]`, or `name` itself for instance 0
/// when the log names it so (ULog's first instance). `None` when `topics` has neither.
///
/// ```
/// use imunoise::logs::{TopicInfo, instance_topic};
/// let t = |name: &str| TopicInfo { name: name.into(), msg_type: "sensor_gyro".into(), count: 6, is_imu: true };
/// let topics = [t("sensor_gyro"), t("sensor_gyro[1]"), t("sensor_gyro[2]")];
/// assert_eq!(instance_topic(&topics, "sensor_gyro", 1).as_deref(), Some("sensor_gyro[1]"));
/// assert_eq!(instance_topic(&topics, "sensor_gyro", 0).as_deref(), Some("sensor_gyro"));
/// assert_eq!(instance_topic(&topics, "sensor_gyro", 3), None);
/// ```
pub fn instance_topic(topics: &[TopicInfo], name: &str, k: u32) -> Option<String> {
    let with = format!("{name}[{k}]");
    topics
        .iter()
        .find(|t| t.name == with)
        .or_else(|| {
            (k == 0)
                .then(|| topics.iter().find(|t| t.name == name))
                .flatten()
        })
        .map(|t| t.name.clone())
}

/// The high-rate IMU topics of a flight log, which analyses prefer when no `--topic` is
/// given: PX4's `sensor_gyro_fifo` and `sensor_accel_fifo`, ArduPilot's batch sampler
/// `ISB_gyro[k]` and `ISB_acc[k]`; of each, the first instance present. Empty when the log has
/// none of them.
///
/// ```
/// use imunoise::logs::{TopicInfo, preferred_topics};
/// let t = |name: &str| TopicInfo { name: name.into(), msg_type: String::new(), count: 9, is_imu: true };
/// let topics = [t("ISB_acc[1]"), t("ISB_gyro[0]"), t("ISB_gyro[1]"), t("IMU[0]")];
/// assert_eq!(preferred_topics(&topics), ["ISB_gyro[0]", "ISB_acc[1]"]);
/// assert!(preferred_topics(&[t("sensor_combined")]).is_empty());
/// ```
pub fn preferred_topics(topics: &[TopicInfo]) -> Vec<String> {
    let mut out = Vec::new();
    for family in [
        "sensor_gyro_fifo",
        "sensor_accel_fifo",
        "ISB_gyro[",
        "ISB_acc[",
    ] {
        let mut of: Vec<&TopicInfo> = topics
            .iter()
            .filter(|t| t.is_imu && t.count > 0 && t.name.starts_with(family))
            .filter(|t| {
                family.ends_with('[') || t.name == family || t.name[family.len()..].starts_with('[')
            })
            .collect();
        of.sort_by_key(|t| (t.name.len(), t.name.clone()));
        if let Some(t) = of.first() {
            out.push(t.name.clone());
        }
    }
    out
}

/// What every log reader offers.
///
/// ```
/// use imunoise::logs::imu_msg::ImuSample;
/// use imunoise::logs::{ImuSeries, LogFormat, LogReader, TopicInfo};
/// /// A log in memory: /imu0 with three messages at 200 Hz, and a camera topic.
/// struct Fake;
/// impl LogReader for Fake {
///     fn format(&self) -> LogFormat {
///         LogFormat::Mcap
///     }
///     fn topics(&self) -> imunoise::Result<Vec<TopicInfo>> {
///         let topic = |name: &str, msg_type: &str, count, is_imu| TopicInfo {
///             name: name.into(),
///             msg_type: msg_type.into(),
///             count,
///             is_imu,
///         };
///         Ok(vec![
///             topic("/imu0", "sensor_msgs/msg/Imu", 3, true),
///             topic("/cam", "sensor_msgs/msg/Image", 1, false),
///         ])
///     }
///     fn read_imu(&self, _topic: &str) -> imunoise::Result<ImuSeries> {
///         let mut s = ImuSeries::with_capacity(3);
///         for i in 0..3 {
///             let (gyro, acc) = ([0.0; 3], [0.0, 0.0, 9.81]);
///             s.push(&ImuSample { stamp_ns: 5_000_000 * i, gyro, acc });
///         }
///         Ok(s)
///     }
/// }
/// let topics = Fake.topics()?;
/// assert_eq!(topics.iter().filter(|t| t.is_imu).count(), 1);
/// let s = Fake.read_imu("/imu0")?;
/// assert_eq!(s.stamps_ns.len(), topics[0].count as usize);
/// // the library's functions take any reader
/// assert_eq!(imunoise::logs::select_topics(&Fake, "fake", &[])?, ["/imu0"]);
/// # Ok::<(), imunoise::Error>(())
/// ```
pub trait LogReader {
    /// The file's format.
    fn format(&self) -> LogFormat;
    /// All topics (messages) with type and count, in a stable order.
    fn topics(&self) -> Result<Vec<TopicInfo>>;
    /// The samples of one IMU topic, in recording order. The topic exists and is an IMU
    /// topic ([`select_topics`] checks that first).
    fn read_imu(&self, topic: &str) -> Result<ImuSeries>;
    /// Where the file is cut off, if it is: the readers keep every complete message before
    /// the cut ([`open_checked`] warns, or refuses under `--strict`). `None` by default.
    fn truncation(&self) -> Option<Truncation> {
        None
    }
}

/// Opens a log with the reader of `format`; the file is mapped, not read.
///
/// ```
/// # #[cfg(feature = "mcap")] {
/// use imunoise::logs::imu_msg::{ImuSample, encode_cdr};
/// // an MCAP file with 200 IMU messages at 200 Hz on /imu0 (written with the `mcap` crate)
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("run.mcap");
/// let file = std::io::BufWriter::new(std::fs::File::create(&path)?);
/// let mut w = mcap::WriteOptions::new().profile("ros2").create(file)?;
/// let schema = w.add_schema("sensor_msgs/msg/Imu", "ros2msg", b"(definition omitted)")?;
/// let channel = w.add_channel(schema, "/imu0", "cdr", &Default::default())?;
/// for i in 0..200 {
///     let stamp_ns = 1_700_000_000_000_000_000 + 5_000_000 * i as i64;
///     let (gyro, acc) = ([1e-3 * i as f64, 0.0, 0.0], [0.0, 0.0, 9.81]);
///     let s = ImuSample { stamp_ns, gyro, acc };
///     let header = mcap::records::MessageHeader {
///         channel_id: channel,
///         sequence: i,
///         log_time: stamp_ns as u64,
///         publish_time: stamp_ns as u64,
///     };
///     w.write_to_known_channel(&header, &encode_cdr(&s, "imu_link"))?;
/// }
/// w.finish()?;
/// use imunoise::logs::{LogFormat, open};
/// let reader = open(&path, LogFormat::Mcap)?;
/// assert_eq!(reader.format(), LogFormat::Mcap);
/// let s = reader.read_imu("/imu0")?;
/// assert_eq!(s.stamps_ns.len(), 200);
/// assert_eq!(s.columns[0][10], 1e-3 * 10.0); // CDR stores the f64 as it is
/// assert_eq!(imunoise::logs::rate_from_stamps(&s.stamps_ns), Some(200.0));
/// // the wrong reader for the file is an input error
/// assert_eq!(open(&path, LogFormat::Ulog).err().map(|e| e.exit_code()), Some(2));
/// # }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn open(path: &Path, format: LogFormat) -> Result<Box<dyn LogReader>> {
    let file = path.display().to_string();
    match format {
        #[cfg(feature = "mcap")]
        LogFormat::Mcap => Ok(Box::new(mcap::McapReader::open(path)?)),
        #[cfg(feature = "rosbag")]
        LogFormat::Bag => Ok(Box::new(rosbag1::BagReader::open(path)?)),
        #[cfg(feature = "db3")]
        LogFormat::Db3 => Ok(Box::new(db3::Db3Reader::open(path)?)),
        #[cfg(feature = "ulog")]
        LogFormat::Ulog => Ok(Box::new(ulog::UlogReader::open(path)?)),
        #[cfg(feature = "dataflash")]
        LogFormat::Dataflash => Ok(Box::new(dataflash::DataflashReader::open(path)?)),
        #[allow(unreachable_patterns)]
        other => Err(Error::Usage(format!(
            "{file}: this imunoise was built without the {:?} reader (cargo feature \"{}\")",
            other,
            other.feature()
        ))),
    }
}

/// A ROS 2 bag is a folder (`metadata.yaml` and the storage files): returns its one
/// `.mcap` or `.db3` file. Any other path is returned as it is.
///
/// ```
/// let p = std::path::Path::new("run.mcap");
/// assert_eq!(imunoise::logs::storage_file(p).unwrap(), p);
/// ```
pub fn storage_file(path: &Path) -> Result<std::path::PathBuf> {
    if !path.is_dir() {
        return Ok(path.to_path_buf());
    }
    let dir = path.display().to_string();
    let mut found: Vec<std::path::PathBuf> = std::fs::read_dir(path)
        .map_err(|e| Error::io(&dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            matches!(
                LogFormat::from_path(p),
                Some(LogFormat::Mcap | LogFormat::Db3)
            )
        })
        .collect();
    found.sort();
    match found.len() {
        1 => Ok(found.remove(0)),
        0 => Err(Error::Usage(format!(
            "{dir} is a folder without a .mcap or .db3 file (a ROS 2 bag folder holds one)"
        ))),
        k => Err(Error::Usage(format!(
            "{dir} holds {k} storage files (a split bag: {}); give one of them",
            found
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}

/// Memory-maps a whole file read-only (shared by the readers).
#[cfg_attr(
    not(any(
        feature = "mcap",
        feature = "rosbag",
        feature = "ulog",
        feature = "dataflash"
    )),
    allow(dead_code)
)]
pub(crate) fn map_file(path: &Path) -> Result<memmap2::Mmap> {
    let file = path.display().to_string();
    let f = std::fs::File::open(path).map_err(|e| Error::io(&file, e))?;
    let len = f.metadata().map_err(|e| Error::io(&file, e))?.len();
    if len == 0 {
        return Err(Error::File {
            file,
            message: "the file is empty".to_string(),
        });
    }
    // SAFETY: read-only private map; the file must not be truncated while it is read
    // (as for the text reader).
    unsafe { memmap2::Mmap::map(&f) }.map_err(|e| Error::io(file, e))
}

/// A topic with the rate from its stamps (for `imunoise topics` and the messages of
/// [`select_topics`]).
///
/// ```
/// # use imunoise::logs::imu_msg::ImuSample;
/// # use imunoise::logs::{ImuSeries, LogFormat, LogReader, TopicInfo};
/// # /// A log in memory: /imu0 with three messages at 200 Hz, and a camera topic.
/// # struct Fake;
/// # impl LogReader for Fake {
/// #     fn format(&self) -> LogFormat {
/// #         LogFormat::Mcap
/// #     }
/// #     fn topics(&self) -> imunoise::Result<Vec<TopicInfo>> {
/// #         let topic = |name: &str, msg_type: &str, count, is_imu| TopicInfo {
/// #             name: name.into(),
/// #             msg_type: msg_type.into(),
/// #             count,
/// #             is_imu,
/// #         };
/// #         Ok(vec![
/// #             topic("/imu0", "sensor_msgs/msg/Imu", 3, true),
/// #             topic("/cam", "sensor_msgs/msg/Image", 1, false),
/// #         ])
/// #     }
/// #     fn read_imu(&self, _topic: &str) -> imunoise::Result<ImuSeries> {
/// #         let mut s = ImuSeries::with_capacity(3);
/// #         for i in 0..3 {
/// #             let (gyro, acc) = ([0.0; 3], [0.0, 0.0, 9.81]);
/// #             s.push(&ImuSample { stamp_ns: 5_000_000 * i, gyro, acc });
/// #         }
/// #         Ok(s)
/// #     }
/// # }
/// // `Fake`: a LogReader of a log in memory: /imu0 (3 messages at 200 Hz) and /cam (an image)
/// let all = imunoise::logs::summarize(&Fake)?;
/// assert_eq!(all[0].to_string(), "/imu0 (sensor_msgs/msg/Imu, 3 messages, 200.0 Hz)");
/// assert_eq!(all[1].to_string(), "/cam (sensor_msgs/msg/Image, 1 messages)");
/// let json = serde_json::to_value(&all[0]).unwrap();
/// assert_eq!((json["name"].as_str(), json["rate_hz"].as_f64()), (Some("/imu0"), Some(200.0)));
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TopicSummary {
    /// Name, type, count.
    #[serde(flatten)]
    pub info: TopicInfo,
    /// 1 / median Δt of the sorted stamps (Hz), for IMU topics with ≥ 2 distinct stamps.
    pub rate_hz: Option<f64>,
}

impl std::fmt::Display for TopicSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ({}, {} messages",
            self.info.name, self.info.msg_type, self.info.count
        )?;
        if let Some(r) = self.rate_hz {
            write!(f, ", {r:.1} Hz")?;
        }
        write!(f, ")")
    }
}

/// 1 / median Δt of the sorted distinct stamps (Hz); `None` with fewer than 2. A Δt beyond
/// i64 (stamps more than 292 years apart) counts as i64::MAX ns.
///
/// ```
/// assert_eq!(imunoise::logs::rate_from_stamps(&[0, 5_000_000, 10_000_000]), Some(200.0));
/// ```
pub fn rate_from_stamps(stamps_ns: &[i64]) -> Option<f64> {
    let mut s = stamps_ns.to_vec();
    s.sort_unstable();
    s.dedup();
    let mut d: Vec<i64> = s.windows(2).map(|w| w[1].saturating_sub(w[0])).collect();
    if d.is_empty() {
        return None;
    }
    let mid = d.len() / 2;
    let hi = *d.select_nth_unstable(mid).1 as f64;
    let med = if d.len() % 2 == 1 {
        hi
    } else {
        (hi + *d[..mid].iter().max().expect("non-empty") as f64) / 2.0
    };
    Some(1e9 / med)
}

/// Every topic with its rate (IMU topics are read to get it).
///
/// ```
/// # use imunoise::logs::imu_msg::ImuSample;
/// # use imunoise::logs::{ImuSeries, LogFormat, LogReader, TopicInfo};
/// # /// A log in memory: /imu0 with three messages at 200 Hz, and a camera topic.
/// # struct Fake;
/// # impl LogReader for Fake {
/// #     fn format(&self) -> LogFormat {
/// #         LogFormat::Mcap
/// #     }
/// #     fn topics(&self) -> imunoise::Result<Vec<TopicInfo>> {
/// #         let topic = |name: &str, msg_type: &str, count, is_imu| TopicInfo {
/// #             name: name.into(),
/// #             msg_type: msg_type.into(),
/// #             count,
/// #             is_imu,
/// #         };
/// #         Ok(vec![
/// #             topic("/imu0", "sensor_msgs/msg/Imu", 3, true),
/// #             topic("/cam", "sensor_msgs/msg/Image", 1, false),
/// #         ])
/// #     }
/// #     fn read_imu(&self, _topic: &str) -> imunoise::Result<ImuSeries> {
/// #         let mut s = ImuSeries::with_capacity(3);
/// #         for i in 0..3 {
/// #             let (gyro, acc) = ([0.0; 3], [0.0, 0.0, 9.81]);
/// #             s.push(&ImuSample { stamp_ns: 5_000_000 * i, gyro, acc });
/// #         }
/// #         Ok(s)
/// #     }
/// # }
/// // `Fake`: a LogReader of a log in memory: /imu0 (3 messages at 200 Hz) and /cam (an image)
/// let all = imunoise::logs::summarize(&Fake)?;
/// assert_eq!(all.len(), 2);
/// assert_eq!(all[0].info, Fake.topics()?[0]);
/// assert_eq!(all[0].rate_hz, Some(200.0)); // 5 ms between stamps
/// assert_eq!(all[1].rate_hz, None); // not an IMU topic
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn summarize(reader: &dyn LogReader) -> Result<Vec<TopicSummary>> {
    summarize_some(reader, reader.topics()?.iter())
}

fn list(items: &[TopicSummary]) -> String {
    items
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// Applies the `--topic` rules: with none given and one IMU topic, that one; with none
/// given and several, an error listing them; a given topic must exist, be an IMU topic
/// and hold messages. Every refusal is an [`Error::Usage`] (exit 2) whose message lists
/// the IMU topics with type, count and rate.
///
/// ```
/// # use imunoise::logs::imu_msg::ImuSample;
/// # use imunoise::logs::{ImuSeries, LogFormat, LogReader, TopicInfo};
/// # /// A log in memory: /imu0 with three messages at 200 Hz, and a camera topic.
/// # struct Fake;
/// # impl LogReader for Fake {
/// #     fn format(&self) -> LogFormat {
/// #         LogFormat::Mcap
/// #     }
/// #     fn topics(&self) -> imunoise::Result<Vec<TopicInfo>> {
/// #         let topic = |name: &str, msg_type: &str, count, is_imu| TopicInfo {
/// #             name: name.into(),
/// #             msg_type: msg_type.into(),
/// #             count,
/// #             is_imu,
/// #         };
/// #         Ok(vec![
/// #             topic("/imu0", "sensor_msgs/msg/Imu", 3, true),
/// #             topic("/cam", "sensor_msgs/msg/Image", 1, false),
/// #         ])
/// #     }
/// #     fn read_imu(&self, _topic: &str) -> imunoise::Result<ImuSeries> {
/// #         let mut s = ImuSeries::with_capacity(3);
/// #         for i in 0..3 {
/// #             let (gyro, acc) = ([0.0; 3], [0.0, 0.0, 9.81]);
/// #             s.push(&ImuSample { stamp_ns: 5_000_000 * i, gyro, acc });
/// #         }
/// #         Ok(s)
/// #     }
/// # }
/// // `Fake`: a LogReader of a log in memory: /imu0 (3 messages at 200 Hz) and /cam (an image)
/// use imunoise::logs::select_topics;
/// // none asked for: the only IMU topic
/// assert_eq!(select_topics(&Fake, "run.mcap", &[])?, ["/imu0"]);
/// assert_eq!(select_topics(&Fake, "run.mcap", &["/imu0".into()])?, ["/imu0"]);
/// // not an IMU topic: refused, with the IMU topics listed
/// let e = select_topics(&Fake, "run.mcap", &["/cam".into()]).unwrap_err();
/// assert!(e.to_string().contains("not sensor_msgs/Imu; IMU topics in run.mcap: /imu0"));
/// assert!(select_topics(&Fake, "run.mcap", &["/imu1".into()]).is_err());
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn select_topics(
    reader: &dyn LogReader,
    file: &str,
    requested: &[String],
) -> Result<Vec<String>> {
    let topics = reader.topics()?;
    let imu: Vec<&TopicInfo> = topics.iter().filter(|t| t.is_imu).collect();
    let imu_list = || -> Result<String> {
        let all = summarize_some(reader, imu.iter().copied())?;
        Ok(list(&all))
    };
    if requested.is_empty() {
        return match imu.len() {
            1 if imu[0].count == 0 => Err(Error::Usage(format!(
                "topic {} ({}) in {file} has no messages",
                imu[0].name, imu[0].msg_type
            ))),
            1 => Ok(vec![imu[0].name.clone()]),
            0 => {
                let others = summarize_some(reader, topics.iter())?;
                Err(Error::Usage(format!(
                    "no IMU topic (sensor_msgs/Imu) in {file}; its topics: {}",
                    if others.is_empty() {
                        "none".to_string()
                    } else {
                        list(&others)
                    }
                )))
            }
            k => Err(Error::Usage(format!(
                "{file} has {k} IMU topics; choose one or more with --topic: {}",
                imu_list()?
            ))),
        };
    }
    let mut out = Vec::new();
    for name in requested {
        match topics.iter().find(|t| &t.name == name) {
            None => {
                return Err(Error::Usage(if imu.is_empty() {
                    format!("topic {name} not found; {file} has no IMU topic")
                } else {
                    format!(
                        "topic {name} not found; IMU topics in {file}: {}",
                        imu_list()?
                    )
                }));
            }
            Some(t) if !t.is_imu => {
                return Err(Error::Usage(format!(
                    "topic {name} in {file} has type {}, not sensor_msgs/Imu; IMU topics in {file}: {}",
                    t.msg_type,
                    if imu.is_empty() {
                        "none".to_string()
                    } else {
                        imu_list()?
                    }
                )));
            }
            Some(t) if t.count == 0 => {
                return Err(Error::Usage(format!(
                    "topic {name} ({}) in {file} has no messages",
                    t.msg_type
                )));
            }
            Some(t) => {
                if out.contains(&t.name) {
                    return Err(Error::Usage(format!("--topic {name} is given twice")));
                }
                out.push(t.name.clone());
            }
        }
    }
    Ok(out)
}

fn summarize_some<'a>(
    reader: &dyn LogReader,
    items: impl Iterator<Item = &'a TopicInfo>,
) -> Result<Vec<TopicSummary>> {
    items
        .map(|info| {
            let rate_hz = if info.is_imu && info.count > 1 {
                rate_from_stamps(&reader.read_imu(&info.name)?.stamps_ns)
            } else {
                None
            };
            Ok(TopicSummary {
                info: info.clone(),
                rate_hz,
            })
        })
        .collect()
}
