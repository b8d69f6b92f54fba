//! ROS 1 bags (`.bag`, format 2.0) with the crate `rosbag`: the file is memory-mapped, and
//! `sensor_msgs/Imu` messages are decoded in place ([`super::imu_msg::decode_ros1`]). With an
//! index that names every chunk, the chunks (none, bz2 or lz4) holding the topic are
//! decompressed and decoded in parallel, each into its place in the final columns; otherwise
//! one after the other.
//!
//! Counts come from the index section (chunk info records). The bag header is checked
//! here before the crate slices the file with it. A bag without a usable index (a recording
//! that was not closed, or a file cut off while it was written: its index, written last, is
//! missing) is read by a walk of our own over its records instead: connection records, and
//! chunks (none, bz2 or lz4) with their connection and message records. The walk stops at
//! the first incomplete record; in an uncompressed chunk cut short, its complete records are
//! read too ([`LogReader::truncation`] says where the file is cut).

use super::imu_msg::{decode_ros1, is_imu_type};
use super::{ImuSeries, LogFormat, LogReader, SamplePush, TopicInfo, Truncation};
use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// Connection id → (topic, type).
type Connections = BTreeMap<u32, (String, String)>;

/// An open ROS 1 bag.
///
/// ```
/// use imunoise::logs::imu_msg::{ImuSample, encode_ros1};
/// // a ROS 1 bag: records of a header (`name=value` fields, each after its u32 length) and
/// // data, each after its u32 length; here one uncompressed chunk of 100 IMU messages at
/// // 100 Hz on /imu0, and the index
/// let field = |name: &str, val: &[u8]| {
///     let mut v = ((name.len() + 1 + val.len()) as u32).to_le_bytes().to_vec();
///     v.extend([name.as_bytes(), b"=", val].concat());
///     v
/// };
/// let record = |fields: &[Vec<u8>], data: &[u8]| {
///     let h = fields.concat();
///     let mut v = (h.len() as u32).to_le_bytes().to_vec();
///     v.extend([&h[..], &(data.len() as u32).to_le_bytes(), data].concat());
///     v
/// };
/// let time = |ns: i64| [(ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32]
///     .map(u32::to_le_bytes)
///     .concat();
/// let u32le = |x: u32| x.to_le_bytes();
/// let conn = record(
///     &[field("op", &[7]), field("conn", &u32le(0)), field("topic", b"/imu0")],
///     &[field("topic", b"/imu0"), field("type", b"sensor_msgs/Imu"),
///         field("md5sum", b"6a62c6daae103f4ff57a132d6f95cec2"),
///         field("message_definition", b"")]
///         .concat(),
/// );
/// let (mut chunk, mut index) = (conn.clone(), Vec::new());
/// let stamp = |i: i64| 1_000_000_000 + 10_000_000 * i;
/// for i in 0..100 {
///     let (gyro, acc) = ([0.0, 0.5, 0.0], [0.0, 0.0, 9.81]);
///     let s = ImuSample { stamp_ns: stamp(i), gyro, acc };
///     index.extend([time(s.stamp_ns), u32le(chunk.len() as u32).to_vec()].concat());
///     let t = time(s.stamp_ns);
///     let head = [field("op", &[2]), field("conn", &u32le(0)), field("time", &t)];
///     chunk.extend(record(&head, &encode_ros1(&s, i as u32, "imu")));
/// }
/// let header = |index_pos: u64| {
///     let fields = [field("op", &[3]), field("index_pos", &index_pos.to_le_bytes()),
///         field("conn_count", &u32le(1)), field("chunk_count", &u32le(1))];
///     record(&fields, &[b' '; 64])
/// };
/// let chunk_pos = 13 + header(0).len(); // after the version line and the header record
/// let size = u32le(chunk.len() as u32);
/// let chunk_head = [field("op", &[5]), field("compression", b"none"), field("size", &size)];
/// let mut body = record(&chunk_head, &chunk);
/// body.extend(record(
///     &[field("op", &[4]), field("ver", &u32le(1)), field("conn", &u32le(0)),
///         field("count", &u32le(100))],
///     &index,
/// ));
/// let index_pos = (chunk_pos + body.len()) as u64;
/// body.extend(conn);
/// body.extend(record(
///     &[field("op", &[6]), field("ver", &u32le(1)),
///         field("chunk_pos", &(chunk_pos as u64).to_le_bytes()),
///         field("start_time", &time(stamp(0))), field("end_time", &time(stamp(99))),
///         field("count", &u32le(1))],
///     &[u32le(0), u32le(100)].concat(),
/// ));
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("run.bag");
/// std::fs::write(&path, [&b"#ROSBAG V2.0\n"[..], &header(index_pos), &body].concat())?;
/// use imunoise::logs::{LogReader, rosbag1::BagReader};
/// let reader = BagReader::open(&path)?;
/// let t = &reader.topics()?[0];
/// assert_eq!((t.name.as_str(), t.msg_type.as_str()), ("/imu0", "sensor_msgs/Imu"));
/// assert_eq!((t.count, t.is_imu), (100, true));
/// let s = reader.read_imu("/imu0")?;
/// assert_eq!(imunoise::logs::rate_from_stamps(&s.stamps_ns), Some(100.0));
/// assert_eq!((s.columns[1][0], s.columns[5][99]), (0.5, 9.81));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct BagReader {
    file: String,
    /// Without a usable index: the bag read by a walk over its records.
    walked: Option<Walked>,
    bag: rosbag::RosBag,
    /// The file, for the walk over the chunk section's record headers
    /// ([`Self::chunk_starts`]; positioned reads: mapping them would keep whole page-cache
    /// folios of the file resident a second time, beside the crate's own map).
    fh: std::fs::File,
    /// The chunk section: from the end of the bag header record to the index.
    section: (usize, usize),
}

/// The connections of `topic` that carry `sensor_msgs/Imu`.
fn imu_ids(conns: &Connections, topic: &str) -> Vec<u32> {
    conns
        .iter()
        .filter(|(_, (t, tp))| t == topic && is_imu_type(tp))
        .map(|(&id, _)| id)
        .collect()
}

/// Per chunk of the index: its record's offset and (connection, messages) pairs.
type ChunkInfos = Vec<(u64, Vec<(u32, u32)>)>;

const VERSION: &[u8] = b"#ROSBAG V2.0\n";

/// Reads `index_pos` from the bag header record and checks it lies inside the file; returns
/// the chunk section (from the end of the header record to the index) and whether the index
/// is there (without it, the section runs to the end of the file).
fn check_header(b: &[u8], file: &str) -> Result<((usize, usize), bool)> {
    let bad = |m: &str| Error::File {
        file: file.to_string(),
        message: m.to_string(),
    };
    if !b.starts_with(VERSION) {
        return Err(bad("not a ROS 1 bag (no \"#ROSBAG V2.0\" at its start)"));
    }
    let u32_at = |o: usize| -> Option<usize> {
        Some(u32::from_le_bytes(b.get(o..o + 4)?.try_into().ok()?) as usize)
    };
    let hlen = u32_at(VERSION.len()).ok_or_else(|| bad("truncated bag header"))?;
    let h0 = VERSION.len() + 4;
    let header = b
        .get(h0..h0 + hlen)
        .ok_or_else(|| bad("truncated bag header"))?;
    let mut p = 0;
    let mut index_pos = None;
    while p + 4 <= header.len() {
        let n = u32::from_le_bytes(header[p..p + 4].try_into().expect("4")) as usize;
        let f = header
            .get(p + 4..p + 4 + n)
            .ok_or_else(|| bad("corrupt bag header"))?;
        if let Some(v) = f.strip_prefix(b"index_pos=")
            && v.len() == 8
        {
            index_pos = Some(u64::from_le_bytes(v.try_into().expect("8")));
        }
        p += 4 + n;
    }
    let data_len = u32_at(h0 + hlen).ok_or_else(|| bad("truncated bag header"))?;
    let start = h0 + hlen + 4 + data_len;
    if start > b.len() {
        return Err(bad("truncated bag header"));
    }
    match index_pos {
        None => Err(bad("corrupt bag header (no index_pos)")),
        // not closed (0), or cut off before its index
        Some(i) if i == 0 || i > b.len() as u64 => Ok(((start, b.len()), false)),
        Some(i) if (i as usize) < start => Err(bad(&format!(
            "corrupt bag: its index starts at byte {i}, inside its header"
        ))),
        Some(i) => Ok(((start, i as usize), true)),
    }
}

impl BagReader {
    /// Opens and maps `path`, checking the bag header.
    ///
    /// ```
    /// # use imunoise::logs::imu_msg::{ImuSample, encode_ros1};
    /// # let field = |name: &str, val: &[u8]| {
    /// #     let mut v = ((name.len() + 1 + val.len()) as u32).to_le_bytes().to_vec();
    /// #     v.extend([name.as_bytes(), b"=", val].concat());
    /// #     v
    /// # };
    /// # let record = |fields: &[Vec<u8>], data: &[u8]| {
    /// #     let h = fields.concat();
    /// #     let mut v = (h.len() as u32).to_le_bytes().to_vec();
    /// #     v.extend([&h[..], &(data.len() as u32).to_le_bytes(), data].concat());
    /// #     v
    /// # };
    /// # let time = |ns: i64| [(ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32]
    /// #     .map(u32::to_le_bytes)
    /// #     .concat();
    /// # let u32le = |x: u32| x.to_le_bytes();
    /// # let conn = record(
    /// #     &[field("op", &[7]), field("conn", &u32le(0)), field("topic", b"/imu0")],
    /// #     &[field("topic", b"/imu0"), field("type", b"sensor_msgs/Imu"),
    /// #         field("md5sum", b"6a62c6daae103f4ff57a132d6f95cec2"),
    /// #         field("message_definition", b"")]
    /// #         .concat(),
    /// # );
    /// # let (mut chunk, mut index) = (conn.clone(), Vec::new());
    /// # let stamp = |i: i64| 1_000_000_000 + 10_000_000 * i;
    /// # for i in 0..100 {
    /// #     let (gyro, acc) = ([0.0, 0.5, 0.0], [0.0, 0.0, 9.81]);
    /// #     let s = ImuSample { stamp_ns: stamp(i), gyro, acc };
    /// #     index.extend([time(s.stamp_ns), u32le(chunk.len() as u32).to_vec()].concat());
    /// #     let t = time(s.stamp_ns);
    /// #     let head = [field("op", &[2]), field("conn", &u32le(0)), field("time", &t)];
    /// #     chunk.extend(record(&head, &encode_ros1(&s, i as u32, "imu")));
    /// # }
    /// # let header = |index_pos: u64| {
    /// #     let fields = [field("op", &[3]), field("index_pos", &index_pos.to_le_bytes()),
    /// #         field("conn_count", &u32le(1)), field("chunk_count", &u32le(1))];
    /// #     record(&fields, &[b' '; 64])
    /// # };
    /// # let chunk_pos = 13 + header(0).len(); // after the version line and the header record
    /// # let size = u32le(chunk.len() as u32);
    /// # let chunk_head = [field("op", &[5]), field("compression", b"none"), field("size", &size)];
    /// # let mut body = record(&chunk_head, &chunk);
    /// # body.extend(record(
    /// #     &[field("op", &[4]), field("ver", &u32le(1)), field("conn", &u32le(0)),
    /// #         field("count", &u32le(100))],
    /// #     &index,
    /// # ));
    /// # let index_pos = (chunk_pos + body.len()) as u64;
    /// # body.extend(conn);
    /// # body.extend(record(
    /// #     &[field("op", &[6]), field("ver", &u32le(1)),
    /// #         field("chunk_pos", &(chunk_pos as u64).to_le_bytes()),
    /// #         field("start_time", &time(stamp(0))), field("end_time", &time(stamp(99))),
    /// #         field("count", &u32le(1))],
    /// #     &[u32le(0), u32le(100)].concat(),
    /// # ));
    /// # let dir = tempfile::tempdir()?;
    /// # let path = dir.path().join("run.bag");
    /// # std::fs::write(&path, [&b"#ROSBAG V2.0\n"[..], &header(index_pos), &body].concat())?;
    /// // `path`: a ROS 1 bag with 100 IMU messages at 100 Hz on /imu0 (one uncompressed chunk)
    /// use imunoise::logs::rosbag1::BagReader;
    /// assert!(BagReader::open(&path).is_ok());
    /// // a bag whose recording was not closed has no index: read by a walk over its records
    /// let open = dir.path().join("open.bag");
    /// let mut bytes = std::fs::read(&path)?;
    /// let at = bytes.windows(10).position(|w| w == b"index_pos=").unwrap() + 10;
    /// bytes[at..at + 8].copy_from_slice(&0u64.to_le_bytes());
    /// std::fs::write(&open, &bytes)?;
    /// use imunoise::logs::LogReader;
    /// let r = BagReader::open(&open)?;
    /// assert_eq!(r.read_imu("/imu0")?.stamps_ns.len(), 100);
    /// assert!(r.truncation().is_none());
    /// // cut off 10 bytes into its chunk's last message: the 99 before it are read
    /// let last = [&b"time="[..], &time(stamp(99))].concat();
    /// // the record: header length (4), op (4 + 4), conn (4 + 9), time field length (4), time=
    /// let msg = bytes.windows(13).position(|w| w == last).unwrap() - 29;
    /// std::fs::write(&open, &bytes[..msg + 10])?;
    /// let r = BagReader::open(&open)?;
    /// assert_eq!(r.read_imu("/imu0")?.stamps_ns.len(), 99);
    /// let t = r.truncation().unwrap();
    /// assert_eq!((t.offset, t.dropped_bytes, t.last_stamp_ns), (msg as u64, 10, Some(stamp(98))));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let map = super::map_file(path)?;
        let (section, indexed) = check_header(&map, &file)?;
        let walked = if indexed {
            drop(map);
            None
        } else {
            let cut = index_beyond_end(&map);
            Some(Walked::new(map, section.0, &file, cut)?)
        };
        let fh = std::fs::File::open(path).map_err(|e| Error::File {
            file: file.clone(),
            message: e.to_string(),
        })?;
        let bag = rosbag::RosBag::new(path).map_err(|e| Error::File {
            file: file.clone(),
            message: format!("not a readable ROS 1 bag: {e}"),
        })?;
        Ok(BagReader {
            file,
            walked,
            bag,
            fh,
            section,
        })
    }

    fn corrupt(&self, e: impl std::fmt::Display) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("truncated or corrupt ROS 1 bag: {e}"),
        }
    }

    /// Connections (id → topic, type) and message counts per connection, from the index.
    fn index(&self) -> Result<(Connections, BTreeMap<u32, u64>, ChunkInfos)> {
        let mut conns = BTreeMap::new();
        let mut counts: BTreeMap<u32, u64> = BTreeMap::new();
        let mut chunks = Vec::new();
        for r in self.bag.index_records() {
            match r.map_err(|e| self.corrupt(e))? {
                rosbag::IndexRecord::Connection(c) => {
                    conns.insert(c.id, (c.topic.to_string(), c.tp.to_string()));
                }
                rosbag::IndexRecord::ChunkInfo(ci) => {
                    let mut per = Vec::new();
                    for e in ci.entries() {
                        *counts.entry(e.conn_id).or_default() += e.count as u64;
                        per.push((e.conn_id, e.count));
                    }
                    chunks.push((ci.chunk_pos, per));
                }
                rosbag::IndexRecord::IndexData(_) => {}
            }
        }
        Ok((conns, counts, chunks))
    }

    /// The offsets of the chunk records in the chunk section, by a walk over its records'
    /// lengths (header length, header, data length; the data is skipped), or `None` when a
    /// length runs past the section or a read fails (the sequential read then reports it).
    fn chunk_starts(&self) -> Option<Vec<u64>> {
        use std::os::unix::fs::FileExt;
        let (mut at, end) = self.section;
        let mut buf = vec![0u8; 4096];
        let mut out = Vec::new();
        while at < end {
            // the record's header length, header and data length, in one read when they fit
            let got = buf.len().min(end - at);
            self.fh.read_exact_at(&mut buf[..got], at as u64).ok()?;
            let hlen = u32::from_le_bytes(buf.get(..4)?.try_into().ok()?) as usize;
            if hlen + 8 > got {
                if hlen + 8 > end - at {
                    return None;
                }
                buf.resize(hlen + 8, 0);
                self.fh
                    .read_exact_at(&mut buf[..hlen + 8], at as u64)
                    .ok()?;
            }
            let header = &buf[4..4 + hlen];
            let dlen = u32::from_le_bytes(buf[4 + hlen..8 + hlen].try_into().ok()?) as usize;
            let next = (at + 8 + hlen).checked_add(dlen)?;
            if next > end {
                return None;
            }
            // the op field (name=value with a u32 length): 5 is a chunk
            let mut p = 0;
            while p + 4 <= header.len() {
                let n = u32::from_le_bytes(header[p..p + 4].try_into().ok()?) as usize;
                let f = header.get(p + 4..(p + 4).checked_add(n)?)?;
                if f == b"op=\x05" {
                    out.push(at as u64);
                }
                p += 4 + n;
            }
            at = next;
        }
        Some(out)
    }

    /// The parallel read of [`read_imu`](LogReader::read_imu) alone (for tests): `Ok(None)`
    /// when the index does not match the chunks and `read_imu` reads them one after the other.
    #[doc(hidden)]
    pub fn read_imu_parallel(&self, topic: &str) -> Result<Option<ImuSeries>> {
        let (conns, _, chunks) = self.index()?;
        let ids = imu_ids(&conns, topic);
        self.read_parallel(&ids, chunks, topic)
    }

    /// With an index whose chunk infos name every chunk record of the file: the chunks holding
    /// `ids` decoded in parallel, each into its place in the final columns
    /// ([`super::read_parts_into`]). `Ok(None)`: the index does not match the chunks (then they
    /// are read one after the other).
    fn read_parallel(
        &self,
        ids: &[u32],
        mut chunks: ChunkInfos,
        topic: &str,
    ) -> Result<Option<ImuSeries>> {
        chunks.sort_by_key(|c| c.0);
        let Some(starts) = self.chunk_starts() else {
            return Ok(None);
        };
        if chunks.len() != starts.len() || chunks.iter().zip(&starts).any(|(c, &s)| c.0 != s) {
            return Ok(None);
        }
        let parts: Vec<(u64, usize)> = chunks
            .iter()
            .map(|(pos, per)| {
                let n: u64 = per
                    .iter()
                    .filter(|(c, _)| ids.contains(c))
                    .map(|&(_, k)| k as u64)
                    .sum();
                (*pos, n as usize)
            })
            .filter(|&(_, n)| n > 0)
            .collect();
        let counts: Vec<usize> = parts.iter().map(|p| p.1).collect();
        super::read_parts_into(&parts, &counts, |&(pos, _), base, sink| {
            let mut it = self.bag.chunk_records();
            it.seek(pos).map_err(|e| self.corrupt(e))?;
            let chunk = match it.next() {
                Some(Ok(rosbag::ChunkRecord::Chunk(c))) => c,
                Some(Err(e)) => return Err(self.corrupt(e)),
                _ => return Err(self.corrupt(format!("no chunk record at byte {pos}"))),
            };
            self.decode_chunk(&chunk, ids, topic, base, sink)
        })
    }

    /// Decodes the messages of `ids` in `chunk` into `sink`; `before` messages of the topic
    /// come before the chunk (for the message numbers of errors).
    fn decode_chunk(
        &self,
        chunk: &rosbag::record_types::Chunk<'_>,
        ids: &[u32],
        topic: &str,
        before: usize,
        sink: &mut impl SamplePush,
    ) -> Result<()> {
        let mut k = 0;
        for m in chunk.messages() {
            if let rosbag::MessageRecord::MessageData(m) = m.map_err(|e| self.corrupt(e))?
                && ids.contains(&m.conn_id)
            {
                let s = decode_ros1(m.data).map_err(|why| Error::File {
                    file: self.file.clone(),
                    message: format!(
                        "message {} on {topic} is not a valid sensor_msgs/Imu: {why}",
                        before + k + 1
                    ),
                })?;
                sink.push_sample(&s);
                k += 1;
            }
        }
        Ok(())
    }
}

impl LogReader for BagReader {
    fn format(&self) -> LogFormat {
        LogFormat::Bag
    }

    fn truncation(&self) -> Option<Truncation> {
        self.walked.as_ref().and_then(|w| w.truncation)
    }

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        let (conns, counts) = match &self.walked {
            Some(w) => (w.conns.clone(), w.counts.clone()),
            None => {
                let (c, n, _) = self.index()?;
                (c, n)
            }
        };
        let mut by_topic: BTreeMap<String, TopicInfo> = BTreeMap::new();
        for (id, (topic, tp)) in conns {
            let e = by_topic.entry(topic.clone()).or_insert_with(|| TopicInfo {
                name: topic,
                is_imu: is_imu_type(&tp),
                msg_type: tp,
                count: 0,
            });
            e.count += counts.get(&id).copied().unwrap_or(0);
        }
        Ok(by_topic.into_values().collect())
    }

    fn read_imu(&self, topic: &str) -> Result<ImuSeries> {
        if let Some(w) = &self.walked {
            let ids = imu_ids(&w.conns, topic);
            let n: u64 = ids
                .iter()
                .map(|i| w.counts.get(i).copied().unwrap_or(0))
                .sum();
            let mut out = ImuSeries::with_capacity(n.min(1 << 28) as usize);
            w.walk(&self.file, &mut |_, _| {}, &mut |conn, _, data| {
                if ids.contains(&conn) {
                    let s = decode_ros1(data).map_err(|why| Error::File {
                        file: self.file.clone(),
                        message: format!(
                            "message {} on {topic} is not a valid sensor_msgs/Imu: {why}",
                            out.stamps_ns.len() + 1
                        ),
                    })?;
                    out.push(&s);
                }
                Ok(())
            })?;
            out.check_finite(&format!("{} ({topic})", self.file))?;
            return Ok(out);
        }
        let (conns, counts, chunks) = self.index()?;
        let ids = imu_ids(&conns, topic);
        if let Some(out) = self.read_parallel(&ids, chunks, topic)? {
            out.check_finite(&format!("{} ({topic})", self.file))?;
            return Ok(out);
        }
        let n: u64 = ids
            .iter()
            .map(|i| counts.get(i).copied().unwrap_or(0))
            .sum();
        let mut out = ImuSeries::with_capacity(n.min(1 << 28) as usize);
        for r in self.bag.chunk_records() {
            let rosbag::ChunkRecord::Chunk(chunk) = r.map_err(|e| self.corrupt(e))? else {
                continue;
            };
            let before = out.stamps_ns.len();
            self.decode_chunk(&chunk, &ids, topic, before, &mut out)?;
        }
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }
}

/// A bag read by a walk over its records (no usable index).
struct Walked {
    map: memmap2::Mmap,
    /// Where the records start (after the bag header record).
    start: usize,
    conns: Connections,
    counts: BTreeMap<u32, u64>,
    truncation: Option<Truncation>,
    /// The record time of the last message (ns).
    last_stamp: Option<i64>,
}

/// Whether the bag header's `index_pos` lies beyond the end of `b` (cut off before its index).
fn index_beyond_end(b: &[u8]) -> bool {
    let at = b.windows(10).position(|w| w == b"index_pos=");
    at.and_then(|a| b.get(a + 10..a + 18))
        .map(|v| u64::from_le_bytes(v.try_into().expect("8")))
        .is_some_and(|i| i > b.len() as u64)
}

/// A record of `b` at `at`: its header fields (name, value), its data range and the offset
/// after it; `None` when it runs past the end of `b` (or its header is malformed).
/// A record's header fields (name, value), its data range and the offset after it.
type RecordAt<'a> = (Vec<(&'a [u8], &'a [u8])>, (usize, usize), usize);

fn bag_record(b: &[u8], at: usize) -> Option<RecordAt<'_>> {
    let u32_at = |o: usize| -> Option<usize> {
        Some(u32::from_le_bytes(b.get(o..o.checked_add(4)?)?.try_into().ok()?) as usize)
    };
    let hlen = u32_at(at)?;
    let h0 = at.checked_add(4)?;
    let header = b.get(h0..h0.checked_add(hlen)?)?;
    let dlen = u32_at(h0 + hlen)?;
    let d0 = h0 + hlen + 4;
    let d1 = d0.checked_add(dlen)?;
    if d1 > b.len() {
        return None;
    }
    Some((fields(header)?, (d0, d1), d1))
}

/// The `name=value` fields of a record header (each after its u32 length).
fn fields(h: &[u8]) -> Option<Vec<(&[u8], &[u8])>> {
    let mut out = Vec::new();
    let mut p = 0;
    while p < h.len() {
        let n = u32::from_le_bytes(h.get(p..p + 4)?.try_into().ok()?) as usize;
        let f = h.get(p + 4..(p + 4).checked_add(n)?)?;
        let eq = f.iter().position(|&c| c == b'=')?;
        out.push((&f[..eq], &f[eq + 1..]));
        p += 4 + n;
    }
    Some(out)
}

fn field<'a>(f: &[(&[u8], &'a [u8])], name: &str) -> Option<&'a [u8]> {
    f.iter().find(|(n, _)| *n == name.as_bytes()).map(|x| x.1)
}

fn u32_of(v: Option<&[u8]>) -> Option<u32> {
    Some(u32::from_le_bytes(v?.try_into().ok()?))
}

/// Callbacks of [`Walked::walk`]: a connection (id, topic, type); a message (connection,
/// record time in ns, serialized data).
type OnConn<'a> = dyn FnMut(u32, (String, String)) + 'a;
type OnMsg<'a> = dyn FnMut(u32, i64, &[u8]) -> Result<()> + 'a;

impl Walked {
    /// Walks the bag from `start`; `cut` says its header points at an index beyond the end
    /// of the file (so a walk that ends cleanly still found a file cut off, between records).
    fn new(map: memmap2::Mmap, start: usize, file: &str, cut: bool) -> Result<Walked> {
        let mut w = Walked {
            map,
            start,
            conns: Connections::new(),
            counts: BTreeMap::new(),
            truncation: None,
            last_stamp: None,
        };
        let mut conns = Connections::new();
        let mut counts: BTreeMap<u32, u64> = BTreeMap::new();
        let mut last = None;
        w.truncation = w.walk(
            file,
            &mut |id, c| {
                conns.insert(id, c);
            },
            &mut |conn, t, _| {
                *counts.entry(conn).or_default() += 1;
                last = Some(t);
                Ok(())
            },
        )?;
        w.last_stamp = last;
        w.conns = conns;
        w.counts = counts;
        if cut && w.truncation.is_none() {
            w.truncation = Some(Truncation {
                offset: w.map.len() as u64,
                dropped_bytes: 0,
                last_stamp_ns: w.last_stamp,
            });
        }
        Ok(w)
    }

    /// Walks the records from `start`; returns where the file is cut off.
    fn walk(
        &self,
        file: &str,
        on_conn: &mut OnConn<'_>,
        on_msg: &mut OnMsg<'_>,
    ) -> Result<Option<Truncation>> {
        let b = &self.map[..];
        let bad = |at: usize, m: &str| Error::File {
            file: file.to_string(),
            message: format!("corrupt ROS 1 bag at byte {at}: {m}"),
        };
        let mut last: Option<i64> = None;
        // the records of `r` (a chunk's data, or the file): connections and messages;
        // returns the offset in `r` of an incomplete record
        let inner = |r: &[u8],
                     last: &mut Option<i64>,
                     on_conn: &mut OnConn<'_>,
                     on_msg: &mut OnMsg<'_>|
         -> Result<Option<usize>> {
            let mut at = 0;
            while at < r.len() {
                let Some((f, (d0, d1), next)) = bag_record(r, at) else {
                    return Ok(Some(at));
                };
                match field(&f, "op") {
                    Some([7]) => conn_record(&f, &r[d0..d1], on_conn),
                    Some([2]) => {
                        let conn = u32_of(field(&f, "conn")).unwrap_or(u32::MAX);
                        let t = field(&f, "time")
                            .filter(|t| t.len() == 8)
                            .map(|t| {
                                let s = u32::from_le_bytes(t[..4].try_into().expect("4"));
                                let ns = u32::from_le_bytes(t[4..].try_into().expect("4"));
                                s as i64 * 1_000_000_000 + ns as i64
                            })
                            .unwrap_or(0);
                        *last = Some(t);
                        on_msg(conn, t, &r[d0..d1])?;
                    }
                    _ => {}
                }
                at = next;
            }
            Ok(None)
        };
        let mut at = self.start;
        while at < b.len() {
            let cut = |offset: usize, last: Option<i64>| Truncation {
                offset: offset as u64,
                dropped_bytes: (b.len() - offset) as u64,
                last_stamp_ns: last,
            };
            let Some((f, (d0, d1), next)) = bag_record(b, at) else {
                // incomplete: an uncompressed chunk's complete records are read
                let h = b
                    .get(at..at + 4)
                    .map(|x| u32::from_le_bytes(x.try_into().expect("4")));
                let head = h.and_then(|n| {
                    let h0 = at + 4;
                    let f = fields(b.get(h0..h0.checked_add(n as usize)?)?)?;
                    Some((f, h0 + n as usize + 4))
                });
                if let Some((f, d0)) = head
                    && field(&f, "op") == Some(&[5])
                    && field(&f, "compression") == Some(b"none")
                    && d0 <= b.len()
                {
                    let r = &b[d0..];
                    return Ok(Some(match inner(r, &mut last, on_conn, on_msg)? {
                        Some(c) => cut(d0 + c, last),
                        None => cut(b.len(), last),
                    }));
                }
                return Ok(Some(cut(at, last)));
            };
            match field(&f, "op") {
                Some([7]) => conn_record(&f, &b[d0..d1], on_conn),
                Some([5]) => {
                    let data = &b[d0..d1];
                    let size = u32_of(field(&f, "size")).unwrap_or(0) as usize;
                    let plain: std::borrow::Cow<'_, [u8]> = match field(&f, "compression") {
                        Some(b"none") => data.into(),
                        Some(b"lz4") => decompress(lz4_read(data), size)
                            .map_err(|e| bad(at, &format!("an lz4 chunk: {e}")))?
                            .into(),
                        Some(b"bz2") => {
                            decompress(Ok(Box::new(bzip2::read::BzDecoder::new(data))), size)
                                .map_err(|e| bad(at, &format!("a bz2 chunk: {e}")))?
                                .into()
                        }
                        _ => return Err(bad(at, "a chunk of unknown compression")),
                    };
                    if let Some(c) = inner(&plain, &mut last, on_conn, on_msg)? {
                        return Err(bad(
                            at,
                            &format!("a record {c} bytes into a chunk runs past it"),
                        ));
                    }
                }
                _ => {}
            }
            at = next;
        }
        Ok(None)
    }
}

fn lz4_read(data: &[u8]) -> std::io::Result<Box<dyn std::io::Read + '_>> {
    Ok(Box::new(lz4::Decoder::new(data)?))
}

/// Reads a chunk's decoder to its end: at most `size` bytes (the chunk's uncompressed size).
fn decompress(
    r: std::io::Result<Box<dyn std::io::Read + '_>>,
    size: usize,
) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut out = Vec::with_capacity(size.min(1 << 28));
    r?.take(size as u64 + 1).read_to_end(&mut out)?;
    if out.len() != size {
        return Err(std::io::Error::other(format!(
            "{} bytes uncompressed, its header says {size}",
            out.len()
        )));
    }
    Ok(out)
}

/// A connection record (header: conn, topic; data: fields with the type).
fn conn_record(f: &[(&[u8], &[u8])], data: &[u8], on_conn: &mut OnConn<'_>) {
    let Some(id) = u32_of(field(f, "conn")) else {
        return;
    };
    let topic = field(f, "topic").map(|t| String::from_utf8_lossy(t).into_owned());
    let df = fields(data).unwrap_or_default();
    let tp = field(&df, "type").map(|t| String::from_utf8_lossy(t).into_owned());
    if let (Some(topic), Some(tp)) = (topic, tp) {
        on_conn(id, (topic, tp));
    }
}
