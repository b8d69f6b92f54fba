//! ROS 2 MCAP (`.mcap`) with the format owners' crate `mcap`: the file is memory-mapped,
//! chunks are decompressed one at a time (zstd, lz4 or none), and each `sensor_msgs/msg/Imu`
//! message is decoded in place ([`super::imu_msg`]; CDR, or ROS 1 encoding when the channel
//! says `ros1`).

use super::imu_msg::{ImuSample, decode_cdr, decode_ros1, is_imu_type};
use super::{ImuSeries, LogFormat, LogReader, TopicInfo, map_file};
use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// A mapped MCAP file.
pub struct McapReader {
    file: String,
    map: memmap2::Mmap,
}

type Decoder = fn(&[u8]) -> std::result::Result<ImuSample, String>;

fn decoder(schema: Option<&str>, encoding: &str) -> Option<Decoder> {
    if !schema.is_some_and(is_imu_type) {
        return None;
    }
    match encoding {
        "cdr" => Some(decode_cdr),
        "ros1" => Some(decode_ros1),
        _ => None,
    }
}

impl McapReader {
    /// Maps `path`; the header magic is checked here, everything else while reading.
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let map = map_file(path)?;
        if !map.starts_with(b"\x89MCAP0\r\n") {
            return Err(Error::File {
                file,
                message: "not an MCAP file (no MCAP magic at its start)".to_string(),
            });
        }
        Ok(McapReader { file, map })
    }

    fn corrupt(&self, after: u64, e: impl std::fmt::Display) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("truncated or corrupt MCAP file (after {after} messages): {e}"),
        }
    }

    /// Topics by a full pass over the messages (when the file has no usable summary).
    fn scan_topics(&self) -> Result<Vec<TopicInfo>> {
        let mut stream =
            mcap::read::RawMessageStream::new(&self.map).map_err(|e| self.corrupt(0, e))?;
        let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
        for (n, m) in stream.by_ref().enumerate() {
            let m = m.map_err(|e| self.corrupt(n as u64, e))?;
            *counts.entry(m.header.channel_id).or_default() += 1;
        }
        let mut by_topic: BTreeMap<String, TopicInfo> = BTreeMap::new();
        for (id, count) in counts {
            let Some(ch) = stream.get_channel(id) else {
                continue;
            };
            add(&mut by_topic, &ch, count);
        }
        Ok(by_topic.into_values().collect())
    }
}

fn add(by_topic: &mut BTreeMap<String, TopicInfo>, ch: &mcap::Channel<'_>, count: u64) {
    let schema = ch.schema.as_ref().map(|s| s.name.as_str());
    let is_imu = decoder(schema, &ch.message_encoding).is_some();
    let e = by_topic
        .entry(ch.topic.clone())
        .or_insert_with(|| TopicInfo {
            name: ch.topic.clone(),
            msg_type: schema.unwrap_or("(no schema)").to_string(),
            count: 0,
            is_imu,
        });
    e.count += count;
}

impl McapReader {
    /// With a summary that indexes the chunks: the chunks holding `topic` are decoded in
    /// parallel (rayon) and joined in file order, which is the recording order. `None` when
    /// the file has no chunk index (then it is streamed).
    fn read_chunks_parallel(&self, topic: &str) -> Result<Option<ImuSeries>> {
        use rayon::prelude::*;
        let Ok(Some(summary)) = mcap::Summary::read(&self.map) else {
            return Ok(None);
        };
        if summary.chunk_indexes.is_empty() {
            return Ok(None);
        }
        let decoders: BTreeMap<u16, Decoder> = summary
            .channels
            .iter()
            .filter(|(_, c)| c.topic == topic)
            .filter_map(|(&id, c)| {
                decoder(
                    c.schema.as_ref().map(|s| s.name.as_str()),
                    &c.message_encoding,
                )
                .map(|d| (id, d))
            })
            .collect();
        let mut chunks: Vec<&mcap::records::ChunkIndex> = summary
            .chunk_indexes
            .iter()
            .filter(|c| {
                c.message_index_offsets.is_empty()
                    || c.message_index_offsets
                        .keys()
                        .any(|id| decoders.contains_key(id))
            })
            .collect();
        chunks.sort_by_key(|c| c.chunk_start_offset);
        let parts: Vec<Result<ImuSeries>> = chunks
            .par_iter()
            .map(|ci| {
                let mut out = ImuSeries::with_capacity(0);
                let stream = summary
                    .stream_chunk(&self.map, ci)
                    .map_err(|e| self.corrupt(0, e))?;
                for m in stream {
                    let m = m.map_err(|e| self.corrupt(0, e))?;
                    if let Some(d) = decoders.get(&m.channel.id) {
                        let s = d(&m.data).map_err(|why| Error::File {
                            file: self.file.clone(),
                            message: format!(
                                "the message on {topic} logged at {} ns is not a valid sensor_msgs/Imu: {why}",
                                m.log_time
                            ),
                        })?;
                        out.push(&s);
                    }
                }
                Ok(out)
            })
            .collect();
        let total: usize = parts
            .iter()
            .map(|p| p.as_ref().map_or(0, |s| s.stamps_ns.len()))
            .sum();
        let mut out = ImuSeries::with_capacity(total);
        for p in parts {
            let p = p?;
            out.stamps_ns.extend_from_slice(&p.stamps_ns);
            for (dst, src) in out.columns.iter_mut().zip(&p.columns) {
                dst.extend_from_slice(src);
            }
        }
        Ok(Some(out))
    }
}

impl LogReader for McapReader {
    fn format(&self) -> LogFormat {
        LogFormat::Mcap
    }

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        // The summary (when the recording was closed properly) has the counts.
        if let Ok(Some(summary)) = mcap::Summary::read(&self.map)
            && let Some(stats) = &summary.stats
            && !summary.channels.is_empty()
        {
            let mut by_topic = BTreeMap::new();
            for (id, ch) in &summary.channels {
                let count = stats.channel_message_counts.get(id).copied().unwrap_or(0);
                add(&mut by_topic, ch, count);
            }
            return Ok(by_topic.into_values().collect());
        }
        self.scan_topics()
    }

    fn read_imu(&self, topic: &str) -> Result<ImuSeries> {
        if let Some(out) = self.read_chunks_parallel(topic)? {
            out.check_finite(&format!("{} ({topic})", self.file))?;
            return Ok(out);
        }
        let hint = mcap::Summary::read(&self.map)
            .ok()
            .flatten()
            .and_then(|s| {
                let stats = s.stats.as_ref()?;
                Some(
                    s.channels
                        .iter()
                        .filter(|(_, c)| c.topic == topic)
                        .map(|(id, _)| stats.channel_message_counts.get(id).copied().unwrap_or(0))
                        .sum::<u64>(),
                )
            })
            .unwrap_or(0);
        let mut out = ImuSeries::with_capacity(hint.min(1 << 28) as usize);
        let mut stream =
            mcap::read::RawMessageStream::new(&self.map).map_err(|e| self.corrupt(0, e))?;
        // Per channel id: None = not looked up yet, Some(None) = not this topic.
        let mut dec: Vec<Option<Option<Decoder>>> = vec![None; 1 << 16];
        let mut n = 0u64;
        while let Some(m) = stream.next() {
            let m = m.map_err(|e| self.corrupt(n, e))?;
            n += 1;
            let id = m.header.channel_id as usize;
            let d = match dec[id] {
                Some(d) => d,
                None => {
                    let d = stream.get_channel(m.header.channel_id).and_then(|ch| {
                        if ch.topic == topic {
                            decoder(
                                ch.schema.as_ref().map(|s| s.name.as_str()),
                                &ch.message_encoding,
                            )
                        } else {
                            None
                        }
                    });
                    dec[id] = Some(d);
                    d
                }
            };
            if let Some(d) = d {
                let s = d(&m.data).map_err(|why| Error::File {
                    file: self.file.clone(),
                    message: format!(
                        "message {} on {topic} is not a valid sensor_msgs/Imu: {why}",
                        out.stamps_ns.len() + 1
                    ),
                })?;
                out.push(&s);
            }
        }
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }
}
