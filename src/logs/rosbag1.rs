//! ROS 1 bags (`.bag`, format 2.0) with the crate `rosbag`: the file is memory-mapped, and
//! `sensor_msgs/Imu` messages are decoded in place ([`super::imu_msg::decode_ros1`]). With an
//! index that names every chunk, the chunks (none, bz2 or lz4) holding the topic are
//! decompressed and decoded in parallel, each into its place in the final columns; otherwise
//! one after the other.
//!
//! Counts come from the index section (chunk info records). The bag header is checked
//! here before the crate slices the file with it, so that a truncated or unindexed bag
//! (a recording that was not closed) is an error, not a panic.

use super::imu_msg::{decode_ros1, is_imu_type};
use super::{ImuSeries, LogFormat, LogReader, SamplePush, TopicInfo};
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
/// the chunk section (from the end of the header record to the index).
fn check_header(b: &[u8], file: &str) -> Result<(usize, usize)> {
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
    match index_pos {
        None => Err(bad("corrupt bag header (no index_pos)")),
        Some(0) => Err(bad(
            "the bag has no index (the recording was not closed); run `rosbag reindex` on it first",
        )),
        Some(i) if (i as usize) < start || i as usize > b.len() => Err(bad(&format!(
            "truncated or corrupt bag: its index starts at byte {i}, but the file has {} bytes",
            b.len()
        ))),
        Some(i) => Ok((start, i as usize)),
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
    /// // a bag whose recording was not closed has no index: refused, saying what to do
    /// let open = dir.path().join("open.bag");
    /// let mut bytes = std::fs::read(&path)?;
    /// let at = bytes.windows(10).position(|w| w == b"index_pos=").unwrap() + 10;
    /// bytes[at..at + 8].copy_from_slice(&0u64.to_le_bytes());
    /// std::fs::write(&open, bytes)?;
    /// let e = BagReader::open(&open).err().unwrap();
    /// assert!(e.to_string().contains("run `rosbag reindex` on it first"));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let map = super::map_file(path)?;
        let section = check_header(&map, &file)?;
        drop(map);
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

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        let (conns, counts, _) = self.index()?;
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
