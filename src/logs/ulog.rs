//! PX4 ULog (`.ulg`), read by a small reader of our own over the memory-mapped file.
//!
//! Why not `yule_log`: it pulls `env_logger`, `regex` and `lazy_static` into the tree for a
//! format whose parts we need fit in a page: the 16-byte header, then messages of
//! `u16 size, u8 type, payload`. We use `F` (format: `name:type field;…`), `A` (subscription:
//! multi id, message id, name) and `D` (data: message id, then the packed fields), and count
//! `O` (dropout) messages. Fields are packed in definition order; nested types and arrays are
//! sized from their formats.
//!
//! IMU topics: `sensor_combined` (`timestamp` µs, `gyro_rad[3]` rad/s,
//! `accelerometer_m_s2[3]` m/s²); instance k > 0 is named `sensor_combined[k]`.

use super::imu_msg::ImuSample;
use super::{ImuSeries, LogFormat, LogReader, TopicInfo, map_file};
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
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct UlogReader {
    file: String,
    map: memmap2::Mmap,
}

/// Byte size of a field type (`float`, `uint64_t`, a nested format, …), arrays excluded.
fn type_size(t: &str, formats: &HashMap<String, String>, depth: usize) -> Option<usize> {
    Some(match t {
        "int8_t" | "uint8_t" | "bool" | "char" => 1,
        "int16_t" | "uint16_t" => 2,
        "int32_t" | "uint32_t" | "float" => 4,
        "int64_t" | "uint64_t" | "double" => 8,
        nested if depth < 8 => fields(formats.get(nested)?, formats, depth + 1)?
            .last()
            .map_or(0, |f| f.offset + f.size),
        _ => return None,
    })
}

/// A field of a format: name, base type, byte offset and total size.
#[derive(Debug, Clone)]
struct Field {
    name: String,
    base: String,
    offset: usize,
    size: usize,
}

/// The fields of a format body `type name;type[3] name;…`.
fn fields(body: &str, formats: &HashMap<String, String>, depth: usize) -> Option<Vec<Field>> {
    let mut out = Vec::new();
    let mut off = 0;
    for item in body.split(';').filter(|s| !s.trim().is_empty()) {
        let (ty, name) = item.trim().split_once(' ')?;
        let (base, count) = match ty.split_once('[') {
            Some((b, rest)) => (b, rest.strip_suffix(']')?.parse::<usize>().ok()?),
            None => (ty, 1),
        };
        let size = type_size(base, formats, depth)? * count;
        out.push(Field {
            name: name.to_string(),
            base: base.to_string(),
            offset: off,
            size,
        });
        off += size;
    }
    Some(out)
}

/// What one pass over the file finds.
struct Scan {
    /// message name → format body.
    formats: HashMap<String, String>,
    /// msg_id → (topic name, message name).
    subs: HashMap<u16, (String, String)>,
    /// msg_id → number of data messages.
    counts: HashMap<u16, u64>,
}

impl UlogReader {
    /// Maps `path` and checks the ULog header.
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
    /// # std::fs::write(&path, log)?;
    /// // `path`: a PX4 ULog with 100 `sensor_combined` messages at 250 Hz
    /// use imunoise::logs::ulog::UlogReader;
    /// assert!(UlogReader::open(&path).is_ok());
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
        Ok(UlogReader { file, map })
    }

    fn corrupt(&self, at: usize, what: &str) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("truncated or corrupt ULog at byte {at}: {what}"),
        }
    }

    /// Walks the messages; `on_data(msg_id, payload after the id)` for each `D`.
    fn walk(&self, mut on_data: impl FnMut(u16, &[u8]) -> Result<()>) -> Result<Scan> {
        let b = &self.map[..];
        let mut p = 16;
        let mut scan = Scan {
            formats: HashMap::new(),
            subs: HashMap::new(),
            counts: HashMap::new(),
        };
        while p < b.len() {
            if p + 3 > b.len() {
                return Err(self.corrupt(p, "a message header is cut short"));
            }
            let size = u16::from_le_bytes([b[p], b[p + 1]]) as usize;
            let ty = b[p + 2];
            let body = b
                .get(p + 3..p + 3 + size)
                .ok_or_else(|| self.corrupt(p, "the last message is cut short"))?;
            match ty {
                b'F' => {
                    let s = std::str::from_utf8(body)
                        .map_err(|_| self.corrupt(p, "format message is not text"))?;
                    let (name, fmt) = s
                        .split_once(':')
                        .ok_or_else(|| self.corrupt(p, "format message without ':'"))?;
                    scan.formats.insert(name.to_string(), fmt.to_string());
                }
                b'A' => {
                    if body.len() < 3 {
                        return Err(self.corrupt(p, "subscription message too short"));
                    }
                    let multi = body[0];
                    let id = u16::from_le_bytes([body[1], body[2]]);
                    let name = String::from_utf8_lossy(&body[3..]).into_owned();
                    let topic = if multi == 0 {
                        name.clone()
                    } else {
                        format!("{name}[{multi}]")
                    };
                    scan.subs.insert(id, (topic, name));
                }
                b'D' => {
                    if body.len() < 2 {
                        return Err(self.corrupt(p, "data message too short"));
                    }
                    let id = u16::from_le_bytes([body[0], body[1]]);
                    if !scan.subs.contains_key(&id) {
                        return Err(self.corrupt(p, &format!("data for unknown message id {id}")));
                    }
                    *scan.counts.entry(id).or_default() += 1;
                    on_data(id, &body[2..])?;
                }
                b'B' | b'I' | b'M' | b'P' | b'Q' | b'L' | b'C' | b'S' | b'O' | b'R' => {}
                other => {
                    return Err(self.corrupt(p, &format!("unknown message type {other:#04x}")));
                }
            }
            p += 3 + size;
        }
        Ok(scan)
    }
}

/// Offsets of `timestamp`, `gyro_rad[3]` and `accelerometer_m_s2[3]` in a format.
fn imu_layout(
    body: &str,
    formats: &HashMap<String, String>,
) -> Option<(usize, usize, usize, usize)> {
    let f = fields(body, formats, 0)?;
    let get = |n: &str, base: &str, size: usize| {
        f.iter()
            .find(|x| x.name == n && x.base == base && x.size == size)
            .map(|x| x.offset)
    };
    let total = f.last().map_or(0, |x| x.offset + x.size);
    Some((
        get("timestamp", "uint64_t", 8)?,
        get("gyro_rad", "float", 12)?,
        get("accelerometer_m_s2", "float", 12)?,
        total,
    ))
}

impl LogReader for UlogReader {
    fn format(&self) -> LogFormat {
        LogFormat::Ulog
    }

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        let scan = self.walk(|_, _| Ok(()))?;
        let mut by: BTreeMap<String, TopicInfo> = BTreeMap::new();
        for (id, (topic, name)) in &scan.subs {
            let is_imu = name == "sensor_combined"
                && scan
                    .formats
                    .get(name)
                    .and_then(|b| imu_layout(b, &scan.formats))
                    .is_some();
            let e = by.entry(topic.clone()).or_insert_with(|| TopicInfo {
                name: topic.clone(),
                msg_type: name.clone(),
                count: 0,
                is_imu,
            });
            e.count += scan.counts.get(id).copied().unwrap_or(0);
        }
        Ok(by.into_values().collect())
    }

    fn read_imu(&self, topic: &str) -> Result<ImuSeries> {
        let mut out = ImuSeries::with_capacity(0);
        // Subscriptions and formats come before their data, so the layout is known by the
        // first data message of the topic.
        let mut layout: HashMap<u16, Option<(usize, usize, usize, usize)>> = HashMap::new();
        let mut formats: HashMap<String, String> = HashMap::new();
        let mut subs: HashMap<u16, (String, String)> = HashMap::new();
        let b = &self.map[..];
        let mut p = 16;
        while p < b.len() {
            if p + 3 > b.len() {
                return Err(self.corrupt(p, "a message header is cut short"));
            }
            let size = u16::from_le_bytes([b[p], b[p + 1]]) as usize;
            let ty = b[p + 2];
            let body = b
                .get(p + 3..p + 3 + size)
                .ok_or_else(|| self.corrupt(p, "the last message is cut short"))?;
            match ty {
                b'F' => {
                    if let Some((n, f)) = std::str::from_utf8(body)
                        .ok()
                        .and_then(|s| s.split_once(':'))
                    {
                        formats.insert(n.to_string(), f.to_string());
                    }
                }
                b'A' if body.len() >= 3 => {
                    let multi = body[0];
                    let id = u16::from_le_bytes([body[1], body[2]]);
                    let name = String::from_utf8_lossy(&body[3..]).into_owned();
                    let t = if multi == 0 {
                        name.clone()
                    } else {
                        format!("{name}[{multi}]")
                    };
                    subs.insert(id, (t, name));
                }
                b'D' if body.len() >= 2 => {
                    let id = u16::from_le_bytes([body[0], body[1]]);
                    let lay = *layout.entry(id).or_insert_with(|| {
                        subs.get(&id)
                            .filter(|(t, _)| t == topic)
                            .and_then(|(_, name)| imu_layout(formats.get(name)?, &formats))
                    });
                    if let Some((ts, g, a, total)) = lay {
                        let d = &body[2..];
                        if d.len() < total {
                            return Err(self.corrupt(
                                p,
                                &format!(
                                    "{topic} message shorter than its format ({} < {total} bytes)",
                                    d.len()
                                ),
                            ));
                        }
                        let f = |o: usize| {
                            f32::from_le_bytes(d[o..o + 4].try_into().expect("4")) as f64
                        };
                        out.push(&ImuSample {
                            stamp_ns: (u64::from_le_bytes(d[ts..ts + 8].try_into().expect("8"))
                                as i64)
                                .saturating_mul(1000),
                            gyro: [f(g), f(g + 4), f(g + 8)],
                            acc: [f(a), f(a + 4), f(a + 8)],
                        });
                    }
                }
                _ => {}
            }
            p += 3 + size;
        }
        // The same strict pass as topics() for corrupt files.
        self.walk(|_, _| Ok(()))?;
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }
}
