//! PX4 ULog (`.ulg`), read by a small reader of our own over the memory-mapped file.
//!
//! Why not `yule_log`: it pulls `env_logger`, `regex` and `lazy_static` into the tree for a
//! format whose parts we need fit in a page. The facts used, from the ULog specification
//! (PX4 `docs/en/dev_log/ulog_file_format.md`) and checked against pyulog on PX4's own logs:
//!
//! - a 16-byte header (magic, version, start time), then messages of `u16 size, u8 type,
//!   payload`;
//! - `B` (flag bits, the first message): bit 0 of the first incompatible-flag byte says data
//!   is appended, at the (up to three) non-zero file offsets that follow; the messages of one
//!   part end where the next part starts, and a message that runs past that point is dropped
//!   (as pyulog does). Other incompatible flags are refused;
//! - `F` (format: `name:type field;…`), with nested types by format name and arrays
//!   `type[n]`; the fields are packed in definition order, and flattened as pyulog names them
//!   (`gyro_rad[0]`, `nested.field`);
//! - `A` (subscription: multi id = instance, message id, name) and `R` (unsubscription);
//! - `D` (data: message id, then the packed fields). The trailing fields whose flattened
//!   names start with `_padding` may be omitted by the logger (PX4 does), so a message may be
//!   shorter than its format by them, never by more;
//! - other message types (`I M P Q L C S O`, and types this reader does not know) are skipped.
//!
//! A file that ends inside a message (the power went while it was written) is read up to
//! the last complete message ([`LogReader::truncation`] says where it is cut).
//!
//! IMU topics, fields by name (instance k > 0 is the topic `name[k]`):
//! - `sensor_combined`: `timestamp` (µs), `gyro_rad[0..3]` (rad/s),
//!   `accelerometer_m_s2[0..3]` (m/s²);
//! - `sensor_gyro` / `sensor_accel`: `timestamp_sample` (µs; `timestamp` without it) and
//!   `x, y, z` (rad/s, m/s²): three channels;
//! - `sensor_gyro_fifo` / `sensor_accel_fifo` (PX4 `msg/SensorGyroFifo.msg`): up to 32 int16
//!   samples per message in `x[32], y[32], z[32]`, `samples` of them valid, `dt` µs apart,
//!   the last one at `timestamp_sample`; values × `scale` (rad/s or m/s² per count; 1 when
//!   the format has no `scale`). Each sample becomes one stamped row.

use super::{ImuSeries, LogFormat, LogReader, TopicInfo, Truncation, map_file};
use crate::error::{Error, Result};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

const MAGIC: &[u8] = b"ULog\x01\x12\x35";

/// A mapped ULog file.
///
/// ```
/// // a PX4 ULog: the 16-byte header, then messages (u16 size, type, body)
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("px4.ulg");
/// let mut log = b"ULog\x01\x12\x35\x01".to_vec();
/// log.extend_from_slice(&0u64.to_le_bytes());
/// let mut msg = |ty: u8, body: &[u8]| {
///     log.extend_from_slice(&(body.len() as u16).to_le_bytes());
///     log.push(ty);
///     log.extend_from_slice(body);
/// };
/// let format = "sensor_combined:uint64_t timestamp;float[3] gyro_rad;float[3] accelerometer_m_s2;";
/// msg(b'F', format.as_bytes());
/// msg(b'A', b"\x00\x00\x00sensor_combined"); // instance 0, message id 0
/// for i in 0..100u64 {
///     let mut d = vec![0u8, 0]; // message id 0
///     d.extend_from_slice(&(4000 * i).to_le_bytes()); // µs: 250 Hz
///     for v in [0.5f32, 0.0, 0.0, 0.0, 0.0, -9.75] {
///         d.extend_from_slice(&v.to_le_bytes());
///     }
///     msg(b'D', &d);
/// }
/// std::fs::write(&path, log)?;
/// use imunoise::logs::{LogReader, ulog::UlogReader};
/// let reader = UlogReader::open(&path)?;
/// let t = &reader.topics()?[0];
/// assert_eq!((t.name.as_str(), t.count, t.is_imu), ("sensor_combined", 100, true));
/// let s = reader.read_imu("sensor_combined")?;
/// assert_eq!(s.stamps_ns[1], 4_000_000); // µs × 1000
/// assert_eq!((s.columns[0][0], s.columns[5][0]), (0.5, -9.75)); // f32 values, exact in f64
/// assert!(reader.truncation().is_none());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct UlogReader {
    file: String,
    map: memmap2::Mmap,
    /// What the pass at open found.
    scan: Scan,
}

/// A primitive field type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Prim {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Prim {
    fn parse(t: &str) -> Option<Prim> {
        Some(match t {
            "int8_t" | "char" => Prim::I8,
            "uint8_t" | "bool" => Prim::U8,
            "int16_t" => Prim::I16,
            "uint16_t" => Prim::U16,
            "int32_t" => Prim::I32,
            "uint32_t" => Prim::U32,
            "int64_t" => Prim::I64,
            "uint64_t" => Prim::U64,
            "float" => Prim::F32,
            "double" => Prim::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Prim::I8 | Prim::U8 => 1,
            Prim::I16 | Prim::U16 => 2,
            Prim::I32 | Prim::U32 | Prim::F32 => 4,
            Prim::I64 | Prim::U64 | Prim::F64 => 8,
        }
    }

    /// The value at `b[o..]` (the caller checked the bounds) as f64.
    fn get(self, b: &[u8], o: usize) -> f64 {
        let a = |n: usize| -> [u8; 8] {
            let mut x = [0u8; 8];
            x[..n].copy_from_slice(&b[o..o + n]);
            x
        };
        match self {
            Prim::I8 => b[o] as i8 as f64,
            Prim::U8 => b[o] as f64,
            Prim::I16 => i16::from_le_bytes([b[o], b[o + 1]]) as f64,
            Prim::U16 => u16::from_le_bytes([b[o], b[o + 1]]) as f64,
            Prim::I32 => i32::from_le_bytes(a(4)[..4].try_into().expect("4")) as f64,
            Prim::U32 => u32::from_le_bytes(a(4)[..4].try_into().expect("4")) as f64,
            Prim::F32 => f32::from_le_bytes(a(4)[..4].try_into().expect("4")) as f64,
            Prim::I64 => i64::from_le_bytes(a(8)) as f64,
            Prim::U64 => u64::from_le_bytes(a(8)) as f64,
            Prim::F64 => f64::from_le_bytes(a(8)),
        }
    }

    /// An integer stamp at `b[o..]` (µs).
    fn get_u64(self, b: &[u8], o: usize) -> Option<u64> {
        match self {
            Prim::U64 | Prim::I64 => Some(u64::from_le_bytes(b[o..o + 8].try_into().ok()?)),
            Prim::U32 => Some(u32::from_le_bytes(b[o..o + 4].try_into().ok()?) as u64),
            _ => None,
        }
    }
}

/// A primitive field of a flattened format: name as pyulog gives it (`gyro_rad[0]`,
/// `nested.field`), type and byte offset.
#[derive(Debug, Clone)]
struct Field {
    name: String,
    prim: Prim,
    offset: usize,
}

/// The fields of format `name`, flattened (nested formats expanded, arrays element by
/// element), appended to `out` from byte `off`; returns the end offset. `None` when a
/// format is missing or malformed, or nesting is deeper than 16.
fn flatten(
    name: &str,
    formats: &HashMap<String, String>,
    prefix: &str,
    mut off: usize,
    out: &mut Vec<Field>,
    depth: usize,
) -> Option<usize> {
    if depth > 16 {
        return None;
    }
    let body = formats.get(name)?;
    for item in body.split(';').filter(|s| !s.trim().is_empty()) {
        let (ty, fname) = item.trim().split_once(' ')?;
        let (base, count) = match ty.split_once('[') {
            Some((b, rest)) => (b, Some(rest.strip_suffix(']')?.parse::<usize>().ok()?)),
            None => (ty, None),
        };
        if count.is_some_and(|n| n > 1 << 16) {
            return None;
        }
        let full = format!("{prefix}{}", fname.trim());
        let names: Vec<String> = match count {
            None => vec![full],
            Some(n) => (0..n).map(|i| format!("{full}[{i}]")).collect(),
        };
        for n in names {
            match Prim::parse(base) {
                Some(p) => {
                    out.push(Field {
                        name: n,
                        prim: p,
                        offset: off,
                    });
                    off += p.size();
                }
                None => off = flatten(base, formats, &format!("{n}."), off, out, depth + 1)?,
            }
        }
    }
    Some(off)
}

/// A subscription (`A` message) with its format's layout.
#[derive(Debug, Clone)]
struct Sub {
    /// The topic: the message name, `name[k]` for instance k > 0.
    topic: String,
    /// The message (format) name.
    name: String,
    /// The flattened fields; empty when the format is missing or malformed.
    fields: Vec<Field>,
    /// The format's size without and with its trailing `_padding` fields (bytes).
    min_size: usize,
    max_size: usize,
    /// Offset of a `uint64_t timestamp` field.
    stamp: Option<usize>,
}

impl Sub {
    fn new(topic: String, name: String, formats: &HashMap<String, String>) -> Sub {
        let mut fields = Vec::new();
        let max = flatten(&name, formats, "", 0, &mut fields, 0);
        let Some(max_size) = max else {
            return Sub {
                topic,
                name,
                fields: Vec::new(),
                min_size: 0,
                max_size: usize::MAX,
                stamp: None,
            };
        };
        let kept = fields
            .iter()
            .rposition(|f| !f.name.starts_with("_padding"))
            .map_or(0, |i| i + 1);
        let min_size = fields
            .get(kept.wrapping_sub(1))
            .map_or(0, |f| f.offset + f.prim.size());
        fields.truncate(kept);
        let stamp = fields
            .iter()
            .find(|f| f.name == "timestamp" && f.prim == Prim::U64)
            .map(|f| f.offset);
        Sub {
            topic,
            name,
            fields,
            min_size,
            max_size,
            stamp,
        }
    }

    fn field(&self, name: &str) -> Option<&Field> {
        self.fields.iter().find(|f| f.name == name)
    }
}

/// What one pass over the file finds.
struct Scan {
    /// Topic → (message name, number of data messages, whether imunoise reads it).
    topics: BTreeMap<String, (String, u64, bool)>,
    truncation: Option<Truncation>,
}

/// How an IMU topic's messages become rows.
#[derive(Debug, Clone)]
struct ImuLayout {
    /// The stamp field (µs).
    stamp: Field,
    /// Channel names (`gyro_x_rads`, …) and their fields.
    channels: Vec<(&'static str, Field)>,
    /// FIFO topics: the fields `samples` and `dt` (µs), the scale (from `scale`, else 1) and
    /// the 32 elements of each channel's array.
    fifo: Option<Fifo>,
}

#[derive(Debug, Clone)]
struct Fifo {
    samples: Field,
    dt: Field,
    scale: Option<Field>,
    /// Per channel, the array elements `x[0..n]` etc.
    elems: Vec<Vec<Field>>,
}

const GYRO: [&str; 3] = ["gyro_x_rads", "gyro_y_rads", "gyro_z_rads"];
const ACC: [&str; 3] = ["acc_x_mps2", "acc_y_mps2", "acc_z_mps2"];

/// The layout of an IMU topic by its fields' names, or `None` for other messages.
fn imu_layout(sub: &Sub) -> Option<ImuLayout> {
    let f = |n: &str| sub.field(n).cloned();
    let stamp_of = |names: &[&str]| names.iter().find_map(|n| f(n));
    let xyz = |names: [&'static str; 3]| -> Option<Vec<(&'static str, Field)>> {
        ["x", "y", "z"]
            .iter()
            .zip(names)
            .map(|(a, n)| Some((n, f(a)?)))
            .collect()
    };
    match sub.name.as_str() {
        "sensor_combined" => {
            let mut channels = Vec::new();
            for (k, n) in GYRO.iter().enumerate() {
                channels.push((*n, f(&format!("gyro_rad[{k}]"))?));
            }
            for (k, n) in ACC.iter().enumerate() {
                channels.push((*n, f(&format!("accelerometer_m_s2[{k}]"))?));
            }
            Some(ImuLayout {
                stamp: stamp_of(&["timestamp"])?,
                channels,
                fifo: None,
            })
        }
        "sensor_gyro" | "sensor_accel" => Some(ImuLayout {
            stamp: stamp_of(&["timestamp_sample", "timestamp"])?,
            channels: xyz(if sub.name == "sensor_gyro" { GYRO } else { ACC })?,
            fifo: None,
        }),
        "sensor_gyro_fifo" | "sensor_accel_fifo" => {
            let names = if sub.name == "sensor_gyro_fifo" {
                GYRO
            } else {
                ACC
            };
            let mut elems = Vec::new();
            for a in ["x", "y", "z"] {
                let e: Vec<Field> = (0..).map_while(|i| f(&format!("{a}[{i}]"))).collect();
                if e.is_empty() {
                    return None;
                }
                elems.push(e);
            }
            Some(ImuLayout {
                stamp: stamp_of(&["timestamp_sample", "timestamp"])?,
                channels: names.iter().map(|n| (*n, elems[0][0].clone())).collect(),
                fifo: Some(Fifo {
                    samples: f("samples")?,
                    dt: f("dt")?,
                    scale: f("scale"),
                    elems,
                }),
            })
        }
        _ => None,
    }
}

impl UlogReader {
    /// Maps `path`, checks the ULog header and walks the messages once (topics, counts and
    /// where the file is cut off, if it is).
    ///
    /// ```
    /// # let dir = tempfile::tempdir()?;
    /// # let path = dir.path().join("px4.ulg");
    /// # let mut log = b"ULog\x01\x12\x35\x01".to_vec();
    /// # log.extend_from_slice(&0u64.to_le_bytes());
    /// # let mut msg = |ty: u8, body: &[u8]| {
    /// #     log.extend_from_slice(&(body.len() as u16).to_le_bytes());
    /// #     log.push(ty);
    /// #     log.extend_from_slice(body);
    /// # };
    /// # let format = "sensor_combined:uint64_t timestamp;float[3] gyro_rad;float[3] accelerometer_m_s2;";
    /// # msg(b'F', format.as_bytes());
    /// # msg(b'A', b"\x00\x00\x00sensor_combined"); // instance 0, message id 0
    /// # for i in 0..100u64 {
    /// #     let mut d = vec![0u8, 0]; // message id 0
    /// #     d.extend_from_slice(&(4000 * i).to_le_bytes()); // µs: 250 Hz
    /// #     for v in [0.5f32, 0.0, 0.0, 0.0, 0.0, -9.75] {
    /// #         d.extend_from_slice(&v.to_le_bytes());
    /// #     }
    /// #     msg(b'D', &d);
    /// # }
    /// # std::fs::write(&path, &log)?;
    /// // `path`: a PX4 ULog with 100 `sensor_combined` messages of 37 bytes at 250 Hz
    /// use imunoise::logs::{LogReader, ulog::UlogReader};
    /// assert!(UlogReader::open(&path).is_ok());
    /// // cut 14 bytes into its last message: the 99 complete ones are read
    /// let cut = dir.path().join("cut.ulg");
    /// std::fs::write(&cut, &log[..log.len() - 23])?;
    /// let r = UlogReader::open(&cut)?;
    /// assert_eq!(r.read_imu("sensor_combined")?.stamps_ns.len(), 99);
    /// let t = r.truncation().unwrap();
    /// assert_eq!((t.offset, t.dropped_bytes), (log.len() as u64 - 37, 14));
    /// assert_eq!(t.last_stamp_ns, Some(98 * 4_000_000));
    /// let junk = dir.path().join("junk.ulg");
    /// std::fs::write(&junk, b"not a ulog file at all")?;
    /// let e = UlogReader::open(&junk).err().unwrap();
    /// assert!(e.to_string().contains("not a PX4 ULog file"));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let map = map_file(path)?;
        if map.len() < 16 || &map[..7] != MAGIC {
            return Err(Error::File {
                file,
                message: "not a PX4 ULog file (no ULog header)".to_string(),
            });
        }
        let mut r = UlogReader {
            file,
            map,
            scan: Scan {
                topics: BTreeMap::new(),
                truncation: None,
            },
        };
        let mut topics: BTreeMap<String, (String, u64, bool)> = BTreeMap::new();
        // topics subscribed to without data are listed too
        let mut subscribed: Vec<(String, String, bool)> = Vec::new();
        let truncation = r.walk_inner(
            &mut |sub, _| {
                let e = topics
                    .entry(sub.topic.clone())
                    .or_insert_with(|| (sub.name.clone(), 0, imu_layout(sub).is_some()));
                e.1 += 1;
                Ok(())
            },
            &mut |sub| {
                subscribed.push((
                    sub.topic.clone(),
                    sub.name.clone(),
                    imu_layout(sub).is_some(),
                ))
            },
        )?;
        for (topic, name, is_imu) in subscribed {
            topics.entry(topic).or_insert((name, 0, is_imu));
        }
        r.scan = Scan { topics, truncation };
        Ok(r)
    }

    fn corrupt(&self, at: usize, what: &str) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("corrupt ULog at byte {at}: {what}"),
        }
    }

    /// The parts of the data: the main part from byte 16, then each appended part (from the
    /// flag bits message), as (start, end) file offsets.
    fn parts(&self) -> Result<Vec<(usize, usize)>> {
        let b = &self.map[..];
        let len = b.len();
        let mut starts = vec![16usize];
        if len >= 19 && b[18] == b'B' {
            let size = u16::from_le_bytes([b[16], b[17]]) as usize;
            if let Some(body) = b.get(19..19 + size).filter(|x| x.len() >= 40) {
                let incompat = &body[8..16];
                if incompat[0] & !1 != 0 || incompat[1..].iter().any(|&x| x != 0) {
                    return Err(self.corrupt(
                        16,
                        "unknown incompatible flags are set: this ULog cannot be read",
                    ));
                }
                if incompat[0] & 1 == 1 {
                    for k in 0..3 {
                        let o =
                            u64::from_le_bytes(body[16 + 8 * k..24 + 8 * k].try_into().expect("8"));
                        if o == 0 {
                            break;
                        }
                        let o = o.min(len as u64) as usize;
                        if o < *starts.last().expect("non-empty") {
                            return Err(
                                self.corrupt(19, "appended data offsets are not increasing")
                            );
                        }
                        starts.push(o);
                    }
                }
            }
        }
        Ok(starts
            .iter()
            .enumerate()
            .map(|(i, &s)| (s, starts.get(i + 1).copied().unwrap_or(len)))
            .filter(|(s, e)| s < e)
            .collect())
    }

    /// Walks the messages; `on_data(subscription, payload after the id)` for each `D`
    /// message (its size checked against the format). Returns where the file is cut off.
    fn walk(
        &self,
        mut on_data: impl FnMut(&Sub, &[u8]) -> Result<()>,
    ) -> Result<Option<Truncation>> {
        self.walk_inner(&mut on_data, &mut |_| {})
    }

    fn walk_inner(
        &self,
        on_data: &mut dyn FnMut(&Sub, &[u8]) -> Result<()>,
        on_sub: &mut dyn FnMut(&Sub),
    ) -> Result<Option<Truncation>> {
        let b = &self.map[..];
        let mut formats: HashMap<String, String> = HashMap::new();
        let mut subs: HashMap<u16, Sub> = HashMap::new();
        let mut truncation = None;
        let mut last_stamp: Option<i64> = None;
        for (start, end) in self.parts()? {
            let mut p = start;
            while p < end {
                let size = if p + 3 <= end {
                    u16::from_le_bytes([b[p], b[p + 1]]) as usize
                } else {
                    usize::MAX
                };
                if size == usize::MAX || p + 3 + size > end {
                    // an incomplete message: the end of the file, or of a part before
                    // appended data (the last one found is reported)
                    truncation = Some(Truncation {
                        offset: p as u64,
                        dropped_bytes: (end - p) as u64,
                        last_stamp_ns: last_stamp,
                    });
                    break;
                }
                let ty = b[p + 2];
                let body = &b[p + 3..p + 3 + size];
                match ty {
                    b'F' => {
                        let s = std::str::from_utf8(body)
                            .map_err(|_| self.corrupt(p, "a format message is not text"))?;
                        let (name, fmt) = s
                            .split_once(':')
                            .ok_or_else(|| self.corrupt(p, "a format message without ':'"))?;
                        formats.insert(name.to_string(), fmt.trim_end_matches('\0').to_string());
                    }
                    b'A' => {
                        if body.len() < 3 {
                            return Err(self.corrupt(p, "a subscription message is too short"));
                        }
                        let multi = body[0];
                        let id = u16::from_le_bytes([body[1], body[2]]);
                        let name = String::from_utf8_lossy(&body[3..])
                            .trim_end_matches('\0')
                            .to_string();
                        let topic = if multi == 0 {
                            name.clone()
                        } else {
                            format!("{name}[{multi}]")
                        };
                        let sub = Sub::new(topic, name, &formats);
                        on_sub(&sub);
                        subs.insert(id, sub);
                    }
                    b'R' if body.len() >= 2 => {
                        subs.remove(&u16::from_le_bytes([body[0], body[1]]));
                    }
                    b'D' => {
                        if body.len() < 2 {
                            return Err(self.corrupt(p, "a data message is too short"));
                        }
                        let id = u16::from_le_bytes([body[0], body[1]]);
                        let sub = subs.get(&id).ok_or_else(|| {
                            self.corrupt(p, &format!("data for unknown message id {id}"))
                        })?;
                        let d = &body[2..];
                        if d.len() < sub.min_size || d.len() > sub.max_size {
                            return Err(self.corrupt(
                                p,
                                &format!(
                                    "a {} message of {} bytes; its format has {} ({} without \
                                     its trailing padding)",
                                    sub.topic,
                                    d.len(),
                                    sub.max_size,
                                    sub.min_size
                                ),
                            ));
                        }
                        if let Some(o) = sub.stamp {
                            last_stamp = Some(
                                (u64::from_le_bytes(d[o..o + 8].try_into().expect("8")) as i64)
                                    .saturating_mul(1000),
                            );
                        }
                        on_data(sub, d)?;
                    }
                    0 => return Err(self.corrupt(p, "a message of type 0")),
                    _ => {}
                }
                p += 3 + size;
            }
        }
        Ok(truncation)
    }
}

impl LogReader for UlogReader {
    fn format(&self) -> LogFormat {
        LogFormat::Ulog
    }

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        Ok(self
            .scan
            .topics
            .iter()
            .map(|(topic, (name, count, is_imu))| TopicInfo {
                name: topic.clone(),
                msg_type: name.clone(),
                count: *count,
                is_imu: *is_imu,
            })
            .collect())
    }

    fn read_imu(&self, topic: &str) -> Result<ImuSeries> {
        let mut out: Option<ImuSeries> = None;
        // the layout per subscription (by topic and format size), looked up once
        let mut layouts: HashMap<(String, usize), Option<ImuLayout>> = HashMap::new();
        let expected = self.scan.topics.get(topic).map_or(0, |t| t.1 as usize);
        self.walk(|sub, d| {
            if sub.topic != topic {
                return Ok(());
            }
            let lay = layouts
                .entry((sub.name.clone(), sub.max_size))
                .or_insert_with(|| imu_layout(sub));
            let Some(lay) = lay else { return Ok(()) };
            let s = out.get_or_insert_with(|| {
                let n = expected.saturating_mul(if lay.fifo.is_some() { 32 } else { 1 });
                ImuSeries {
                    stamps_ns: Vec::with_capacity(n.min(super::MAX_RESERVE)),
                    names: lay.channels.iter().map(|c| c.0.to_string()).collect(),
                    columns: lay
                        .channels
                        .iter()
                        .map(|_| Vec::with_capacity(n.min(super::MAX_RESERVE)))
                        .collect(),
                }
            });
            push_rows(s, lay, d);
            Ok(())
        })?;
        let out = out.unwrap_or_else(|| ImuSeries::with_capacity(0));
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }

    fn truncation(&self) -> Option<Truncation> {
        self.scan.truncation
    }
}

/// Appends the rows of one data message `d` (at least the format's size without padding).
fn push_rows(s: &mut ImuSeries, lay: &ImuLayout, d: &[u8]) {
    let get = |f: &Field| {
        if f.offset + f.prim.size() <= d.len() {
            f.prim.get(d, f.offset)
        } else {
            0.0
        }
    };
    let stamp_us = if lay.stamp.offset + lay.stamp.prim.size() <= d.len() {
        lay.stamp.prim.get_u64(d, lay.stamp.offset).unwrap_or(0)
    } else {
        0
    };
    let stamp_ns = (stamp_us as i64).saturating_mul(1000);
    match &lay.fifo {
        None => {
            s.stamps_ns.push(stamp_ns);
            for (c, (_, f)) in s.columns.iter_mut().zip(&lay.channels) {
                c.push(get(f));
            }
        }
        Some(fifo) => {
            let cap = fifo.elems.iter().map(Vec::len).min().unwrap_or(0);
            let n = (get(&fifo.samples) as usize).min(cap);
            let dt_us = get(&fifo.dt);
            let scale = fifo.scale.as_ref().map_or(1.0, get);
            for i in 0..n {
                // the last sample is at timestamp_sample, the others dt before each other
                let back_ns = ((n - 1 - i) as f64 * dt_us * 1e3).round() as i64;
                s.stamps_ns.push(stamp_ns.saturating_sub(back_ns));
                for (c, e) in s.columns.iter_mut().zip(&fifo.elems) {
                    c.push(get(&e[i]) * scale);
                }
            }
        }
    }
}
