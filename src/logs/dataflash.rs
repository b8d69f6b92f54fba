//! ArduPilot DataFlash logs (`.bin`), read by a small strict reader of our own over the
//! memory-mapped file.
//!
//! Why not `ardupilot-binlog`: reading its code, its reader skips bytes it cannot parse
//! (it rescans for the next header, up to a limit) without telling the caller, and it
//! builds an owned entry (name string, field vector) per message. Here a byte that is not
//! where a message header must be is an error naming its offset: nothing is skipped.
//!
//! Layout: each message is `A3 95 type` then a payload whose size and field types come
//! from the FMT message (type 128: type u8, length u8, name `char[4]`, format `char[16]`,
//! labels `char[64]`). IMU messages are those named `IMU…` with `TimeUS` (µs), `GyrX/Y/Z`
//! (rad/s) and `AccX/Y/Z` (m/s²); an `I` field is the instance (`IMU[1]`). Older firmware
//! logs the instances as the messages `IMU`, `IMU2`, `IMU3` (no `I` field): these are the
//! topics `IMU[0]`, `IMU[1]`, `IMU[2]` (type `IMU`, `IMU2`, `IMU3`).
//!
//! The batch sampler (ArduPilot `INS_LOG_BAT_*`; `libraries/AP_InertialSensor/LogStructure.h`):
//! an `ISBH` header (`N` batch number, `type` 0 accelerometer or 1 gyro, `instance`, `mul`,
//! `smp_cnt`, `SampleUS` the first sample's time, `smp_rate` Hz) then `ISBD` messages (`N`,
//! `seqno` = index of the message in its batch, `x, y, z` 32 int16 samples each). Sample i of
//! message `seqno` is at `SampleUS + (32 seqno + i) / smp_rate` with the value `x[i] / mul`
//! (rad/s, m/s²): a missing message leaves a gap in the stamps. These are the topics
//! `ISB_gyro[k]` and `ISB_acc[k]` (three channels each).
//!
//! A log cut off inside a message (the power went while it was written: the common case)
//! is read up to its last complete message; [`LogReader::truncation`] says where it is cut.

use super::imu_msg::ImuSample;
use super::{ImuSeries, LogFormat, LogReader, TopicInfo, Truncation, map_file};
use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// A mapped DataFlash log.
///
/// ```
/// // an ArduPilot DataFlash log: a FMT message describing IMU, then IMU messages
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("ap.bin");
/// let pad = |s: &str, n: usize| {
///     let mut v = s.as_bytes().to_vec();
///     v.resize(n, 0);
///     v
/// };
/// let mut log = vec![0xA3, 0x95, 0x80, 0x40, 36]; // FMT of type 0x40, 36 bytes
/// log.extend(pad("IMU", 4));
/// log.extend(pad("QBffffff", 16));
/// log.extend(pad("TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ", 64));
/// for i in 0..100u64 {
///     log.extend_from_slice(&[0xA3, 0x95, 0x40]);
///     log.extend_from_slice(&(2500 * i).to_le_bytes()); // µs: 400 Hz
///     log.push(0); // instance
///     for v in [0.25f32, 0.0, 0.0, 0.0, 0.0, -9.75] {
///         log.extend_from_slice(&v.to_le_bytes());
///     }
/// }
/// std::fs::write(&path, log)?;
/// use imunoise::logs::{LogReader, dataflash::DataflashReader};
/// let reader = DataflashReader::open(&path)?;
/// let t = &reader.topics()?[0];
/// assert_eq!((t.name.as_str(), t.msg_type.as_str(), t.count), ("IMU[0]", "IMU", 100));
/// let s = reader.read_imu("IMU[0]")?;
/// assert_eq!(s.stamps_ns[1], 2_500_000); // µs × 1000
/// assert_eq!((s.columns[0][0], s.columns[5][0]), (0.25, -9.75));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct DataflashReader {
    file: String,
    map: memmap2::Mmap,
    /// Where the file is cut off (from the walk at open).
    truncation: Option<Truncation>,
}

/// Size of a DataFlash field type character.
fn char_size(c: u8) -> Option<usize> {
    Some(match c {
        b'b' | b'B' | b'M' => 1,
        b'h' | b'H' | b'c' | b'C' => 2,
        b'i' | b'I' | b'f' | b'n' | b'e' | b'E' | b'L' => 4,
        b'd' | b'q' | b'Q' => 8,
        b'N' => 16,
        b'Z' | b'a' => 64,
        _ => return None,
    })
}

/// A message format from FMT.
#[derive(Debug, Clone)]
struct Fmt {
    name: String,
    len: usize,
    /// For IMU messages: offsets of TimeUS, GyrX..Z, AccX..Z (f32) and the instance byte.
    imu: Option<ImuLayout>,
    /// Offset of a `TimeUS` field (u64 µs).
    time: Option<usize>,
    /// The instance of an old-style IMU message without an `I` field: 0 for `IMU`, k − 1
    /// for `IMUk`.
    old_instance: Option<u32>,
    /// Batch sampler messages: their fields.
    isb: Option<Isb>,
}

/// The field offsets of the batch sampler's messages.
#[derive(Debug, Clone, Copy)]
enum Isb {
    /// `ISBH`: N, type, instance, mul, SampleUS, smp_rate.
    Header {
        n: usize,
        ty: usize,
        inst: usize,
        mul: usize,
        sample_us: usize,
        rate: usize,
    },
    /// `ISBD`: N, seqno, x, y, z (32 int16 each).
    Data {
        n: usize,
        seqno: usize,
        xyz: [usize; 3],
    },
}

/// A batch's header: sensor type (0 accelerometer, 1 gyro), instance, multiplier, first
/// sample time (µs) and rate (Hz).
#[derive(Debug, Clone, Copy)]
struct Batch {
    ty: u8,
    inst: u8,
    mul: f64,
    sample_us: u64,
    rate: f64,
}

impl Batch {
    fn topic(&self) -> String {
        format!(
            "ISB_{}[{}]",
            if self.ty == 1 { "gyro" } else { "acc" },
            self.inst
        )
    }
}

/// Reads the batch sampler's messages as [`DataflashReader::walk`] passes them.
#[derive(Default)]
struct Batches {
    /// Batch number → its header.
    by_n: std::collections::HashMap<u16, Batch>,
}

impl Batches {
    /// Records an `ISBH`; for an `ISBD`, its batch (if its header came before it).
    fn see(&mut self, f: &Fmt, m: &[u8]) -> Option<Batch> {
        let u16_at = |o: usize| u16::from_le_bytes([m[o], m[o + 1]]);
        match f.isb? {
            Isb::Header {
                n,
                ty,
                inst,
                mul,
                sample_us,
                rate,
            } => {
                self.by_n.insert(
                    u16_at(n),
                    Batch {
                        ty: m[ty],
                        inst: m[inst],
                        mul: u16_at(mul) as f64,
                        sample_us: u64::from_le_bytes(m[sample_us..sample_us + 8].try_into().ok()?),
                        rate: f32::from_le_bytes(m[rate..rate + 4].try_into().ok()?) as f64,
                    },
                );
                None
            }
            Isb::Data { n, .. } => self.by_n.get(&u16_at(n)).copied(),
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct ImuLayout {
    time: usize,
    gyr: [usize; 3],
    acc: [usize; 3],
    instance: Option<usize>,
}

fn parse_fmt(p: &[u8]) -> Option<(u8, Fmt)> {
    if p.len() < 86 {
        return None;
    }
    let ty = p[0];
    let len = p[1] as usize;
    let text = |b: &[u8]| {
        String::from_utf8_lossy(b)
            .trim_end_matches('\0')
            .trim()
            .to_string()
    };
    let name = text(&p[2..6]);
    let format = text(&p[6..22]);
    let labels = text(&p[22..86]);
    let labels: Vec<&str> = labels.split(',').collect();
    let mut offs = Vec::new();
    let mut o = 3usize; // header bytes
    for c in format.bytes() {
        offs.push((o, c));
        o += char_size(c)?;
    }
    if o != len {
        return None;
    }
    let at = |l: &str, want: u8| {
        labels
            .iter()
            .position(|x| *x == l)
            .and_then(|i| offs.get(i))
            .filter(|(_, c)| *c == want)
            .map(|(o, _)| *o)
    };
    let old_instance = match name.strip_prefix("IMU") {
        Some("") => Some(0),
        Some(k) if k.len() == 1 => k.parse::<u32>().ok().filter(|&k| k >= 2).map(|k| k - 1),
        _ => None,
    };
    let imu = (|| {
        if !name.starts_with("IMU") {
            return None;
        }
        Some(ImuLayout {
            time: at("TimeUS", b'Q')?,
            gyr: [at("GyrX", b'f')?, at("GyrY", b'f')?, at("GyrZ", b'f')?],
            acc: [at("AccX", b'f')?, at("AccY", b'f')?, at("AccZ", b'f')?],
            instance: at("I", b'B'),
        })
    })();
    let old_instance = old_instance.filter(|_| imu.is_some_and(|l| l.instance.is_none()));
    let isb = match name.as_str() {
        "ISBH" => (|| {
            Some(Isb::Header {
                n: at("N", b'H')?,
                ty: at("type", b'B')?,
                inst: at("instance", b'B')?,
                mul: at("mul", b'H')?,
                sample_us: at("SampleUS", b'Q')?,
                rate: at("smp_rate", b'f')?,
            })
        })(),
        "ISBD" => (|| {
            Some(Isb::Data {
                n: at("N", b'H')?,
                seqno: at("seqno", b'H')?,
                xyz: [at("x", b'a')?, at("y", b'a')?, at("z", b'a')?],
            })
        })(),
        _ => None,
    };
    Some((
        ty,
        Fmt {
            time: at("TimeUS", b'Q'),
            name,
            len,
            imu,
            old_instance,
            isb,
        },
    ))
}

impl DataflashReader {
    /// Maps `path` and checks that it starts with a DataFlash message header.
    ///
    /// ```
    /// # let dir = tempfile::tempdir()?;
    /// # let path = dir.path().join("ap.bin");
    /// # let pad = |s: &str, n: usize| {
    /// #     let mut v = s.as_bytes().to_vec();
    /// #     v.resize(n, 0);
    /// #     v
    /// # };
    /// # let mut log = vec![0xA3, 0x95, 0x80, 0x40, 36]; // FMT of type 0x40, 36 bytes
    /// # log.extend(pad("IMU", 4));
    /// # log.extend(pad("QBffffff", 16));
    /// # log.extend(pad("TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ", 64));
    /// # for i in 0..100u64 {
    /// #     log.extend_from_slice(&[0xA3, 0x95, 0x40]);
    /// #     log.extend_from_slice(&(2500 * i).to_le_bytes()); // µs: 400 Hz
    /// #     log.push(0); // instance
    /// #     for v in [0.25f32, 0.0, 0.0, 0.0, 0.0, -9.75] {
    /// #         log.extend_from_slice(&v.to_le_bytes());
    /// #     }
    /// # }
    /// # std::fs::write(&path, log)?;
    /// // `path`: a DataFlash log with 100 IMU messages of instance 0 at 400 Hz
    /// use imunoise::logs::dataflash::DataflashReader;
    /// assert!(DataflashReader::open(&path).is_ok());
    /// let raw = dir.path().join("raw.bin");
    /// std::fs::write(&raw, [0u8; 64])?;
    /// let e = DataflashReader::open(&raw).err().unwrap();
    /// assert!(e.to_string().contains("not an ArduPilot DataFlash log"));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let map = map_file(path)?;
        if map.len() < 3 || map[0] != 0xA3 || map[1] != 0x95 {
            return Err(Error::File {
                file,
                message: "not an ArduPilot DataFlash log (no A3 95 message header at its start)"
                    .to_string(),
            });
        }
        let mut r = DataflashReader {
            file,
            map,
            truncation: None,
        };
        r.truncation = r.walk(|_, _| {})?;
        Ok(r)
    }

    fn corrupt(&self, at: usize, what: &str) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("truncated or corrupt DataFlash log at byte {at}: {what}"),
        }
    }

    /// Walks every message; `on(fmt, message bytes including the header)`. Returns where
    /// the file is cut off: a last message (or message header) that the file ends inside.
    fn walk(&self, mut on: impl FnMut(&Fmt, &[u8])) -> Result<Option<Truncation>> {
        let b = &self.map[..];
        let mut fmts: Vec<Option<Fmt>> = vec![None; 256];
        // FMT describes itself; a log normally starts with that FMT, but be safe.
        fmts[0x80] = Some(Fmt {
            name: "FMT".into(),
            len: 89,
            imu: None,
            time: None,
            old_instance: None,
            isb: None,
        });
        let mut last_stamp = None;
        let mut p = 0;
        while p < b.len() {
            let rest = &b[p..];
            let cut = || Truncation {
                offset: p as u64,
                dropped_bytes: (b.len() - p) as u64,
                last_stamp_ns: last_stamp,
            };
            if rest.len() < 3 {
                // a message header cut short, if what is there can start one
                if rest[0] == 0xA3 && rest.get(1).is_none_or(|&x| x == 0x95) {
                    return Ok(Some(cut()));
                }
                return Err(self.corrupt(p, "expected a message header (A3 95)"));
            }
            if b[p] != 0xA3 || b[p + 1] != 0x95 {
                return Err(self.corrupt(p, "expected a message header (A3 95)"));
            }
            let ty = b[p + 2] as usize;
            let Some(f) = &fmts[ty] else {
                return Err(self.corrupt(p, &format!("message type {ty} has no FMT before it")));
            };
            let Some(m) = b.get(p..p + f.len) else {
                return Ok(Some(cut()));
            };
            let len = f.len.max(3);
            if ty == 0x80 {
                let (t, nf) = parse_fmt(&m[3..])
                    .ok_or_else(|| self.corrupt(p, "a FMT message that cannot be parsed"))?;
                fmts[t as usize] = Some(nf);
            } else {
                if let Some(o) = f.time {
                    let us = u64::from_le_bytes(m[o..o + 8].try_into().expect("8"));
                    last_stamp = Some((us as i64).saturating_mul(1000));
                }
                on(f, m);
            }
            p += len;
        }
        Ok(None)
    }
}

fn topic_of(f: &Fmt, m: &[u8]) -> String {
    match (f.imu.and_then(|l| l.instance), f.old_instance) {
        (Some(i), _) => format!("{}[{}]", f.name, m[i]),
        (None, Some(k)) => format!("IMU[{k}]"),
        (None, None) => f.name.clone(),
    }
}

/// Whether message `m` of format `f` belongs to `topic` (`name[k]` split as `want`).
fn is_topic(f: &Fmt, m: &[u8], topic: &str, want: Option<(&str, u32)>) -> bool {
    match (f.imu.and_then(|l| l.instance), f.old_instance, want) {
        (Some(i), _, Some((name, k))) => name == f.name && m[i] as u32 == k,
        (None, Some(k), Some((name, kk))) => name == "IMU" && k == kk,
        (None, None, _) => f.name == topic,
        _ => false,
    }
}

impl DataflashReader {
    /// The samples of a batch sampler topic (`ISB_gyro[k]`, `ISB_acc[k]`).
    fn read_batches(&self, topic: &str) -> Result<ImuSeries> {
        let names = if topic.starts_with("ISB_gyro") {
            ["gyro_x_rads", "gyro_y_rads", "gyro_z_rads"]
        } else {
            ["acc_x_mps2", "acc_y_mps2", "acc_z_mps2"]
        };
        let mut out = ImuSeries {
            stamps_ns: Vec::new(),
            names: names.iter().map(|s| s.to_string()).collect(),
            columns: vec![Vec::new(); 3],
        };
        let mut batches = Batches::default();
        self.walk(|f, m| {
            let Some(b) = batches.see(f, m) else { return };
            let Some(Isb::Data { seqno, xyz, .. }) = f.isb else {
                return;
            };
            if b.topic() != topic {
                return;
            }
            let k = u16::from_le_bytes([m[seqno], m[seqno + 1]]) as u64;
            for i in 0..32u64 {
                let dt_ns = ((32 * k + i) as f64 * 1e9 / b.rate).round() as i64;
                out.stamps_ns.push(
                    (b.sample_us as i64)
                        .saturating_mul(1000)
                        .saturating_add(dt_ns),
                );
                for (c, &o) in out.columns.iter_mut().zip(&xyz) {
                    let at = o + 2 * i as usize;
                    c.push(i16::from_le_bytes([m[at], m[at + 1]]) as f64 / b.mul);
                }
            }
        })?;
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }
}

impl LogReader for DataflashReader {
    fn format(&self) -> LogFormat {
        LogFormat::Dataflash
    }

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        let mut by: BTreeMap<String, TopicInfo> = BTreeMap::new();
        let mut batches = Batches::default();
        self.walk(|f, m| {
            let batch = batches.see(f, m);
            let t = batch.map_or_else(|| topic_of(f, m), |b| b.topic());
            by.entry(t.clone())
                .or_insert_with(|| TopicInfo {
                    name: t,
                    msg_type: f.name.clone(),
                    count: 0,
                    is_imu: f.imu.is_some() || batch.is_some(),
                })
                .count += 1;
        })?;
        Ok(by.into_values().collect())
    }

    fn read_imu(&self, topic: &str) -> Result<ImuSeries> {
        if topic.starts_with("ISB_") {
            return self.read_batches(topic);
        }
        let mut out = ImuSeries::with_capacity(0);
        let want = topic
            .strip_suffix(']')
            .and_then(|t| t.split_once('['))
            .and_then(|(n, k)| Some((n, k.parse::<u32>().ok()?)));
        self.walk(|f, m| {
            let Some(l) = f.imu else { return };
            if !is_topic(f, m, topic, want) {
                return;
            }
            let g = |o: usize| f32::from_le_bytes(m[o..o + 4].try_into().expect("4")) as f64;
            out.push(&ImuSample {
                stamp_ns: (u64::from_le_bytes(m[l.time..l.time + 8].try_into().expect("8")) as i64)
                    .saturating_mul(1000),
                gyro: [g(l.gyr[0]), g(l.gyr[1]), g(l.gyr[2])],
                acc: [g(l.acc[0]), g(l.acc[1]), g(l.acc[2])],
            });
        })?;
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }

    fn truncation(&self) -> Option<Truncation> {
        self.truncation
    }
}
