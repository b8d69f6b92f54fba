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
    /// File offsets of the chunks checked by [`check_records`].
    chunks: std::collections::BTreeSet<u64>,
    /// The largest record or uncompressed chunk in the file (bytes): the record length limit
    /// of [`BoundedStream`].
    limit: usize,
}

/// Why [`BoundedStream::for_each`] stopped early.
enum Stop {
    /// The crate's error, after this many messages.
    Corrupt(u64, String),
    /// The callback's error (a message that does not decode).
    Message(Error),
}

/// The messages of a mapped MCAP file, in file order, like `mcap::read::RawMessageStream` but
/// read through the crate's sans-io reader with a record length limit: a length read from a
/// corrupt (compressed) chunk larger than any record the file can hold is an error, not an
/// attempt to reserve it (found by `cargo xtask fuzz`: 3.6·10¹⁷ bytes, an abort).
struct BoundedStream<'a> {
    buf: &'a [u8],
    reader: mcap::sans_io::LinearReader,
    channels: mcap::read::ChannelAccumulator<'static>,
}

impl<'a> BoundedStream<'a> {
    fn new(buf: &'a [u8], limit: usize) -> Self {
        BoundedStream {
            buf,
            reader: mcap::sans_io::LinearReader::new_with_options(
                mcap::sans_io::LinearReaderOptions::default()
                    .with_record_length_limit(limit)
                    .with_skip_end_magic(true),
            ),
            channels: mcap::read::ChannelAccumulator::default(),
        }
    }

    /// Calls `f(header, data, channels)` for each message up to the data end record; returns
    /// the number of messages, or why it stopped.
    fn for_each(
        &mut self,
        mut f: impl FnMut(
            &mcap::records::MessageHeader,
            &[u8],
            &mcap::read::ChannelAccumulator<'static>,
        ) -> Result<()>,
    ) -> std::result::Result<u64, Stop> {
        use mcap::records::Record;
        let mut n = 0u64;
        while let Some(event) = self.reader.next_event() {
            match event.map_err(|e| Stop::Corrupt(n, e.to_string()))? {
                mcap::sans_io::LinearReadEvent::ReadRequest(need) => {
                    let len = need.min(self.buf.len());
                    self.reader.insert(len).copy_from_slice(&self.buf[..len]);
                    self.reader.notify_read(len);
                    self.buf = &self.buf[len..];
                }
                mcap::sans_io::LinearReadEvent::Record { data, opcode } => {
                    match mcap::parse_record(opcode, data)
                        .map_err(|e| Stop::Corrupt(n, e.to_string()))?
                    {
                        Record::Schema { header, data } => self
                            .channels
                            .add_schema(header, std::borrow::Cow::Owned(data.into_owned()))
                            .map_err(|e| Stop::Corrupt(n, e.to_string()))?,
                        Record::Channel(c) => self
                            .channels
                            .add_channel(c)
                            .map_err(|e| Stop::Corrupt(n, e.to_string()))?,
                        Record::Message { header, data } => {
                            f(&header, &data, &self.channels).map_err(Stop::Message)?;
                            n += 1;
                        }
                        Record::DataEnd(_) => break,
                        _ => {}
                    }
                }
            }
        }
        Ok(n)
    }
}

/// Walks the records of the data section (opcode, u64 length, body) before the `mcap` crate
/// reads them: every length must fit in what remains, and every chunk must claim a plausible
/// uncompressed size (at most 1024 times its compressed size plus 64 MiB, and at most 16 GiB),
/// with the records of an uncompressed chunk fitting in it too. The crate reserves the sizes a
/// file claims before checking them, so a corrupt length would otherwise abort the process on
/// a failed allocation (found by `cargo xtask fuzz`). Returns the chunks' offsets.
fn check_records(
    map: &[u8],
) -> std::result::Result<(std::collections::BTreeSet<u64>, usize), String> {
    let u64_at = |b: &[u8], at: usize| -> Option<u64> {
        b.get(at..at + 8)
            .map(|s| u64::from_le_bytes(s.try_into().unwrap_or([0; 8])))
    };
    let walk = |b: &[u8]| -> std::result::Result<Vec<(u8, usize, usize)>, String> {
        // (opcode, body start, body length)
        let mut out = Vec::new();
        let mut at = 0usize;
        while at < b.len() {
            let op = b[at];
            let len = u64_at(b, at + 1).ok_or("a record header runs past the end")?;
            let start = at + 9;
            if len > (b.len() - start.min(b.len())) as u64 {
                return Err(format!(
                    "a record at byte {at} claims {len} bytes, more than the {} that remain",
                    b.len().saturating_sub(start)
                ));
            }
            out.push((op, start, len as usize));
            at = start + len as usize;
            if op == 0x0F {
                break; // data end: the summary follows
            }
        }
        Ok(out)
    };
    let body = &map[8..];
    // each chunk's checks, in parallel: the records of an uncompressed chunk are walked one by
    // one, and that walk is the first read of most of the file's pages (mapping them is most of
    // its cost: 0.56 s for a 4 GB file on one thread)
    let check_chunk = |start: usize, len: usize| -> std::result::Result<usize, String> {
        let c = &body[start..start + len];
        let uncompressed = u64_at(c, 16).ok_or("a chunk header is cut short")?;
        let clen = c
            .get(28..32)
            .map(|s| u32::from_le_bytes(s.try_into().unwrap_or([0; 4])) as usize)
            .ok_or("a chunk header is cut short")?;
        let compression = c.get(32..32 + clen).ok_or("a chunk header is cut short")?;
        let compressed = u64_at(c, 32 + clen).ok_or("a chunk header is cut short")?;
        let records = c.get(40 + clen..).unwrap_or(&[]);
        if compressed != records.len() as u64 {
            return Err(format!(
                "a chunk claims {compressed} bytes of records but holds {}",
                records.len()
            ));
        }
        if uncompressed > compressed.saturating_mul(1024).saturating_add(1 << 26)
            || uncompressed > 1 << 34
        {
            return Err(format!(
                "a chunk claims {uncompressed} bytes uncompressed from {compressed} compressed"
            ));
        }
        if compression.is_empty() {
            if uncompressed != compressed {
                return Err("an uncompressed chunk's sizes differ".to_string());
            }
            walk(records)?;
        }
        Ok(uncompressed as usize)
    };
    let top = walk(body)?;
    let mut limit = top.iter().fold(1usize << 16, |l, &(_, _, len)| l.max(len));
    let chunk_recs: Vec<(usize, usize)> = top
        .iter()
        .filter(|r| r.0 == 0x06)
        .map(|&(_, start, len)| (start, len))
        .collect();
    // the first error in file order, whatever the threads
    let sizes: Vec<std::result::Result<usize, String>> = {
        use rayon::prelude::*;
        chunk_recs
            .par_iter()
            .map(|&(start, len)| check_chunk(start, len))
            .collect()
    };
    let mut chunks = std::collections::BTreeSet::new();
    for (&(start, _), size) in chunk_recs.iter().zip(sizes) {
        limit = limit.max(size?);
        chunks.insert((8 + start - 9) as u64);
    }
    Ok((chunks, limit))
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
        let (chunks, limit) = check_records(&map).map_err(|e| Error::File {
            file: file.clone(),
            message: format!("truncated or corrupt MCAP file: {e}"),
        })?;
        Ok(McapReader {
            file,
            map,
            chunks,
            limit,
        })
    }

    fn stop(&self, s: Stop) -> Error {
        match s {
            Stop::Corrupt(n, e) => self.corrupt(n, e),
            Stop::Message(e) => e,
        }
    }

    /// A message of `topic` that is not a valid `sensor_msgs/Imu`: `which` says which.
    fn not_imu(&self, topic: &str, which: String, why: String) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("{which} on {topic} is not a valid sensor_msgs/Imu: {why}"),
        }
    }

    fn corrupt(&self, after: u64, e: impl std::fmt::Display) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("truncated or corrupt MCAP file (after {after} messages): {e}"),
        }
    }

    /// Topics by a full pass over the messages (when the file has no usable summary).
    fn scan_topics(&self) -> Result<Vec<TopicInfo>> {
        let mut stream = BoundedStream::new(&self.map, self.limit);
        let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
        stream
            .for_each(|h, _, _| {
                *counts.entry(h.channel_id).or_default() += 1;
                Ok(())
            })
            .map_err(|s| self.stop(s))?;
        let mut by_topic: BTreeMap<String, TopicInfo> = BTreeMap::new();
        for (id, count) in counts {
            let Some(ch) = stream.channels.get(id) else {
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
        // an index that points anywhere but at a checked chunk is not used (streamed instead)
        if summary.chunk_indexes.is_empty()
            || summary
                .chunk_indexes
                .iter()
                .any(|c| !self.chunks.contains(&c.chunk_start_offset))
        {
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
                // the chunk record alone, read with the record length limit (see BoundedStream)
                let start = ci.chunk_start_offset as usize;
                let end = start.saturating_add(ci.chunk_length as usize);
                let rec = self
                    .map
                    .get(start..end)
                    .ok_or_else(|| self.corrupt(0, "a chunk index points past the end"))?;
                let mut stream = BoundedStream::new(rec, self.limit);
                stream.reader = mcap::sans_io::LinearReader::new_with_options(
                    mcap::sans_io::LinearReaderOptions::default()
                        .with_record_length_limit(self.limit)
                        .with_skip_start_magic(true)
                        .with_skip_end_magic(true),
                );
                stream
                    .for_each(|h, data, _| {
                        if let Some(d) = decoders.get(&h.channel_id) {
                            let which = || format!("the message logged at {} ns", h.log_time);
                            out.push(&d(data).map_err(|why| self.not_imu(topic, which(), why))?);
                        }
                        Ok(())
                    })
                    .map_err(|s| self.stop(s))?;
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
        let mut stream = BoundedStream::new(&self.map, self.limit);
        // Per channel id: None = not looked up yet, Some(None) = not this topic.
        let mut dec: Vec<Option<Option<Decoder>>> = vec![None; 1 << 16];
        let r = stream.for_each(|h, data, channels| {
            let id = h.channel_id as usize;
            let d = match dec[id] {
                Some(d) => d,
                None => {
                    let d = channels.get(h.channel_id).and_then(|ch| {
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
                let which = format!("message {}", out.stamps_ns.len() + 1);
                out.push(&d(data).map_err(|why| self.not_imu(topic, which, why))?);
            }
            Ok(())
        });
        r.map_err(|s| self.stop(s))?;
        out.check_finite(&format!("{} ({topic})", self.file))?;
        Ok(out)
    }
}
