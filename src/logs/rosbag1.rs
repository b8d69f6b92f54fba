//! ROS 1 bags (`.bag`, format 2.0) with the crate `rosbag`: the file is memory-mapped,
//! chunks (none, bz2 or lz4) are decompressed one at a time, and `sensor_msgs/Imu`
//! messages are decoded in place ([`super::imu_msg::decode_ros1`]).
//!
//! Counts come from the index section (chunk info records). The bag header is checked
//! here before the crate slices the file with it, so that a truncated or unindexed bag
//! (a recording that was not closed) is an error, not a panic.

use super::imu_msg::{decode_ros1, is_imu_type};
use super::{ImuSeries, LogFormat, LogReader, TopicInfo};
use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// Connection id → (topic, type).
type Connections = BTreeMap<u32, (String, String)>;

/// An open ROS 1 bag.
pub struct BagReader {
    file: String,
    bag: rosbag::RosBag,
}

const VERSION: &[u8] = b"#ROSBAG V2.0\n";

/// Reads `index_pos` from the bag header record and checks it lies inside the file.
fn check_header(b: &[u8], file: &str) -> Result<()> {
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
        Some(_) => Ok(()),
    }
}

impl BagReader {
    /// Opens and maps `path`, checking the bag header.
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let map = super::map_file(path)?;
        check_header(&map, &file)?;
        drop(map);
        let bag = rosbag::RosBag::new(path).map_err(|e| Error::File {
            file: file.clone(),
            message: format!("not a readable ROS 1 bag: {e}"),
        })?;
        Ok(BagReader { file, bag })
    }

    fn corrupt(&self, e: impl std::fmt::Display) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("truncated or corrupt ROS 1 bag: {e}"),
        }
    }

    /// Connections (id → topic, type) and message counts per connection, from the index.
    fn index(&self) -> Result<(Connections, BTreeMap<u32, u64>)> {
        let mut conns = BTreeMap::new();
        let mut counts: BTreeMap<u32, u64> = BTreeMap::new();
        for r in self.bag.index_records() {
            match r.map_err(|e| self.corrupt(e))? {
                rosbag::IndexRecord::Connection(c) => {
                    conns.insert(c.id, (c.topic.to_string(), c.tp.to_string()));
                }
                rosbag::IndexRecord::ChunkInfo(ci) => {
                    for e in ci.entries() {
                        *counts.entry(e.conn_id).or_default() += e.count as u64;
                    }
                }
                rosbag::IndexRecord::IndexData(_) => {}
            }
        }
        Ok((conns, counts))
    }
}

impl LogReader for BagReader {
    fn format(&self) -> LogFormat {
        LogFormat::Bag
    }

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        let (conns, counts) = self.index()?;
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
        let (conns, counts) = self.index()?;
        let ids: Vec<u32> = conns
            .iter()
            .filter(|(_, (t, tp))| t == topic && is_imu_type(tp))
            .map(|(&id, _)| id)
            .collect();
        let n: u64 = ids
            .iter()
            .map(|i| counts.get(i).copied().unwrap_or(0))
            .sum();
        let mut out = ImuSeries::with_capacity(n.min(1 << 28) as usize);
        for r in self.bag.chunk_records() {
            let rosbag::ChunkRecord::Chunk(chunk) = r.map_err(|e| self.corrupt(e))? else {
                continue;
            };
            for m in chunk.messages() {
                if let rosbag::MessageRecord::MessageData(m) = m.map_err(|e| self.corrupt(e))?
                    && ids.contains(&m.conn_id)
                {
                    let s = decode_ros1(m.data).map_err(|why| Error::File {
                        file: self.file.clone(),
                        message: format!(
                            "message {} on {topic} is not a valid sensor_msgs/Imu: {why}",
                            out.stamps_ns.len() + 1
                        ),
                    })?;
                    out.push(&s);
                }
            }
        }
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }
}
