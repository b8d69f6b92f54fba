//! ROS 2 MCAP (`.mcap`) with the format owners' crate `mcap`: the file is memory-mapped,
//! and each `sensor_msgs/msg/Imu` message is decoded in place ([`super::imu_msg`]; CDR, or
//! ROS 1 encoding when the channel says `ros1`). With a summary that indexes the chunks (zstd,
//! lz4 or none), the chunks holding the topic are decompressed and decoded in parallel, each
//! into its place in the final columns when the message indexes give the counts; without
//! one, the file is streamed.
//!
//! A file cut off while it was written (no summary, its last record incomplete) is streamed
//! up to its last complete record; when that record is an uncompressed chunk, the complete
//! records inside it are read too (a compressed chunk cut short cannot be decompressed and
//! is dropped whole). [`LogReader::truncation`] says where the file is cut.

use super::imu_msg::{ImuSample, decode_cdr, decode_ros1, is_imu_type};
use super::{ImuSeries, LogFormat, LogReader, SamplePush, TopicInfo, Truncation, map_file};
use crate::error::{Error, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// A mapped MCAP file.
///
/// ```
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
/// use imunoise::logs::{LogReader, mcap::McapReader};
/// let reader = McapReader::open(&path)?;
/// let topics = reader.topics()?;
/// assert_eq!((topics[0].name.as_str(), topics[0].count, topics[0].is_imu), ("/imu0", 200, true));
/// let s = reader.read_imu("/imu0")?;
/// assert_eq!(s.stamps_ns[1] - s.stamps_ns[0], 5_000_000);
/// assert_eq!(s.columns[0][199], 1e-3 * 199.0); // gyro_x_rads, as written
/// assert_eq!(s.columns[5][0], 9.81); // acc_z_mps2
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct McapReader {
    file: String,
    map: memmap2::Mmap,
    /// File offsets of the chunks checked by [`check_records`].
    chunks: std::collections::BTreeSet<u64>,
    /// The largest record or uncompressed chunk in the file (bytes): the record length limit
    /// of [`BoundedStream`].
    limit: usize,
    /// Where a cut-off file is cut ([`Cut`]); `None` for a complete data section.
    cut: Option<Cut>,
}

/// Where a file is cut off: the data section is streamed up to `end` (a record boundary),
/// then the complete records of a cut uncompressed chunk, `tail` (file offsets).
#[derive(Debug, Clone, Copy)]
struct Cut {
    end: usize,
    tail: Option<(usize, usize)>,
    truncation: Truncation,
}

impl Drop for McapReader {
    /// Drops the map's page-table entries in two halves on two threads before the unmap: the
    /// unmap of a 4 GB map, all of it read, took 0.14 s of one thread.
    fn drop(&mut self) {
        let half = self.map.len() / 2;
        let map = &self.map;
        let drop_range = |a: usize, b: usize| {
            // SAFETY: the map is read-only and about to be unmapped; dropping its pages only
            // makes a later read fault them in again from the file (nothing reads it again).
            let _ =
                unsafe { map.unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, a, b - a) };
        };
        if half >= 1 << 26 {
            rayon::join(|| drop_range(0, half), || drop_range(half, map.len()));
        }
    }
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
                    if !Self::record(&mut self.channels, opcode, data, &mut f, &mut n)? {
                        break;
                    }
                }
            }
        }
        Ok(n)
    }

    /// Handles one record (schemas and channels kept, messages to `f`); false at the data
    /// end record.
    fn record(
        channels: &mut mcap::read::ChannelAccumulator<'static>,
        opcode: u8,
        data: &[u8],
        f: &mut impl FnMut(
            &mcap::records::MessageHeader,
            &[u8],
            &mcap::read::ChannelAccumulator<'static>,
        ) -> Result<()>,
        n: &mut u64,
    ) -> std::result::Result<bool, Stop> {
        use mcap::records::Record;
        // only schemas, channels, messages and the data end are used: other records are not
        // parsed (the crate would reserve their fields' claimed lengths), and the fields of
        // those that are must fit in their record first
        if !matches!(opcode, 0x03 | 0x04 | 0x05 | 0x0F) {
            return Ok(true);
        }
        if !fields_fit(opcode, data) {
            return Err(Stop::Corrupt(
                *n,
                format!("a record (opcode {opcode:#04x}) has a field longer than the record"),
            ));
        }
        match mcap::parse_record(opcode, data).map_err(|e| Stop::Corrupt(*n, e.to_string()))? {
            Record::Schema { header, data } => channels
                .add_schema(header, std::borrow::Cow::Owned(data.into_owned()))
                .map_err(|e| Stop::Corrupt(*n, e.to_string()))?,
            Record::Channel(c) => channels
                .add_channel(c)
                .map_err(|e| Stop::Corrupt(*n, e.to_string()))?,
            Record::Message { header, data } => {
                f(&header, &data, channels).map_err(Stop::Message)?;
                *n += 1;
            }
            Record::DataEnd(_) => return Ok(false),
            _ => {}
        }
        Ok(true)
    }

    /// [`Self::for_each`], then the records of `tail` (the complete records of a cut
    /// uncompressed chunk, walked by [`walk_records_until_cut`]).
    fn for_each_then(
        &mut self,
        tail: Option<&[u8]>,
        mut f: impl FnMut(
            &mcap::records::MessageHeader,
            &[u8],
            &mcap::read::ChannelAccumulator<'static>,
        ) -> Result<()>,
    ) -> std::result::Result<u64, Stop> {
        let mut n = self.for_each(&mut f)?;
        if let Some(t) = tail {
            let (recs, _) = walk_records_until_cut(t);
            for (op, start, len) in recs {
                if !Self::record(
                    &mut self.channels,
                    op,
                    &t[start..start + len],
                    &mut f,
                    &mut n,
                )? {
                    break;
                }
            }
        }
        Ok(n)
    }
}

fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    b.get(at..at.checked_add(8)?)
        .map(|s| u64::from_le_bytes(s.try_into().unwrap_or([0; 8])))
}

/// Whether the length-prefixed fields of a record body fit in it (MCAP specification,
/// "Records"). The `mcap` crate parses records with binrw, which reserves a field's claimed
/// length before reading it: a 115 kB file whose channel record claimed a 2.47 GB topic made
/// it reserve that much (found by replaying the fuzz corpus,
/// `tests/fixtures/fuzz/mcap/channel-field-2gib.mcap`). Records of fixed size, and opcodes
/// the crate does not parse, pass.
fn fields_fit(opcode: u8, body: &[u8]) -> bool {
    /// A field: `n` fixed bytes, a string or byte array after a u32 length, a map after a u32
    /// byte length whose entries are string pairs (or fixed, then only its length is
    /// checked), or bytes after a u64 length.
    #[derive(Clone, Copy)]
    enum F {
        Fixed(usize),
        U32,
        MapOfStrings,
        MapFixed,
        U64,
    }
    use F::*;
    let layout: &[F] = match opcode {
        0x03 => &[Fixed(2), U32, U32, U32],            // schema
        0x04 => &[Fixed(4), U32, U32, MapOfStrings],   // channel
        0x07 => &[Fixed(2), MapFixed],                 // message index
        0x08 => &[Fixed(32), MapFixed, Fixed(8), U32], // chunk index
        0x09 => &[Fixed(16), U32, U32, U64],           // attachment
        0x0A => &[Fixed(40), U32, U32],                // attachment index
        0x0B => &[Fixed(42), MapFixed],                // statistics
        0x0C => &[U32, MapOfStrings],                  // metadata
        0x0D => &[Fixed(16), U32],                     // metadata index
        _ => return true,
    };
    let u32_at = |at: usize| -> Option<usize> {
        Some(u32::from_le_bytes(body.get(at..at.checked_add(4)?)?.try_into().ok()?) as usize)
    };
    // the end of a field of `len` bytes after a prefix of `prefix` bytes at `at`, if it fits
    let within = |at: usize, prefix: usize, len: usize, end: usize| -> Option<usize> {
        let e = at.checked_add(prefix)?.checked_add(len)?;
        (e <= end).then_some(e)
    };
    let mut at = 0usize;
    for &f in layout {
        let next = match f {
            Fixed(k) => within(at, 0, k, body.len()),
            U32 => u32_at(at).and_then(|k| within(at, 4, k, body.len())),
            U64 => u64_at(body, at)
                .and_then(|k| usize::try_from(k).ok())
                .and_then(|k| within(at, 8, k, body.len())),
            MapFixed => u32_at(at).and_then(|k| within(at, 4, k, body.len())),
            MapOfStrings => u32_at(at)
                .and_then(|k| within(at, 4, k, body.len()))
                .and_then(|end| {
                    let mut p = at + 4;
                    while p < end {
                        p = within(p, 4, u32_at(p)?, end)?;
                        p = within(p, 4, u32_at(p)?, end)?;
                    }
                    Some(end)
                }),
        };
        match next {
            Some(n) => at = n,
            None => return false,
        }
    }
    true
}

/// The file's summary section, read by the `mcap` crate only once its records have been
/// walked here: `None` when the file has none or when it is not sound (then the messages are
/// streamed). The footer's `summary_start` comes from the file, so it may point anywhere,
/// into the data section too; the crate's reader trusts the lengths of an uncompressed chunk's
/// inner records and subtracts them from the chunk's (found by `cargo xtask fuzz`: an overflow
/// panic in `mcap` 0.26.0 `sans_io/linear_reader.rs`, input
/// `tests/fixtures/fuzz/mcap/open-linear-reader-overflow.mcap`). A summary section holds no
/// chunks (MCAP specification, "Summary Section"), so a chunk record there, a record that runs
/// past the footer, or a start outside the file, makes the summary unusable.
fn summary(map: &[u8]) -> Option<mcap::Summary> {
    const FOOTER: usize = 1 + 8 + 20; // opcode, length, summary start, offset start, CRC
    let footer_at = map.len().checked_sub(FOOTER + 8)?;
    if footer_at < 8 || map[footer_at] != 0x02 || !map.ends_with(b"\x89MCAP0\r\n") {
        return None;
    }
    let start = u64_at(map, footer_at + 9)?;
    if start == 0 {
        return None; // no summary section
    }
    let start = usize::try_from(start)
        .ok()
        .filter(|&s| s >= 8 && s <= footer_at)?;
    let section = &map[start..footer_at];
    let mut at = 0usize;
    while at < section.len() {
        let len = usize::try_from(u64_at(section, at + 1)?).ok()?;
        if section[at] == 0x06 || len > section.len().saturating_sub(at + 9) {
            return None;
        }
        if !fields_fit(section[at], &section[at + 9..at + 9 + len]) {
            return None;
        }
        at += 9 + len;
    }
    mcap::Summary::read(map).ok().flatten()
}

/// The records (opcode, body start, body length) of `b`, up to a data end record: every
/// length must fit in what remains.
fn walk_records(b: &[u8]) -> std::result::Result<Vec<(u8, usize, usize)>, String> {
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
}

/// The complete records (opcode, body start, body length) of `b`, up to a data end record
/// or the first record that runs past the end of `b`, whose offset is returned too (a file
/// cut off while it was written).
fn walk_records_until_cut(b: &[u8]) -> (Vec<(u8, usize, usize)>, Option<usize>) {
    let mut out = Vec::new();
    let mut at = 0usize;
    while at < b.len() {
        let op = b[at];
        let Some(len) = u64_at(b, at + 1) else {
            return (out, Some(at));
        };
        let start = at + 9;
        if len > (b.len() - start.min(b.len())) as u64 {
            return (out, Some(at));
        }
        out.push((op, start, len as usize));
        at = start + len as usize;
        if op == 0x0F {
            break;
        }
    }
    (out, None)
}

/// The log time (ns) of the last message among the records `recs` of `b`: of a message
/// record, or the end time of a chunk record that holds messages.
fn last_log_time(b: &[u8], recs: &[(u8, usize, usize)]) -> Option<i64> {
    recs.iter().rev().find_map(|&(op, start, len)| {
        let body = b.get(start..start + len)?;
        match op {
            0x05 => u64_at(body, 6).map(|t| t as i64),
            0x06 => {
                let (t0, t1) = (u64_at(body, 0)?, u64_at(body, 8)?);
                (t0 != 0 || t1 != 0).then_some(t1 as i64)
            }
            _ => None,
        }
    })
}

/// Checks the chunk record body `c`: a plausible uncompressed size (at most 1024 times its
/// compressed size plus 64 MiB, and at most 16 GiB), and with `records`, the records of an
/// uncompressed chunk fitting in it. Returns the uncompressed size.
fn check_chunk(c: &[u8], records: bool) -> std::result::Result<usize, String> {
    let uncompressed = u64_at(c, 16).ok_or("a chunk header is cut short")?;
    let clen = c
        .get(28..32)
        .map(|s| u32::from_le_bytes(s.try_into().unwrap_or([0; 4])) as usize)
        .ok_or("a chunk header is cut short")?;
    let compression = c.get(32..32 + clen).ok_or("a chunk header is cut short")?;
    let compressed = u64_at(c, 32 + clen).ok_or("a chunk header is cut short")?;
    let body = c.get(40 + clen..).unwrap_or(&[]);
    if compressed != body.len() as u64 {
        return Err(format!(
            "a chunk claims {compressed} bytes of records but holds {}",
            body.len()
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
        if records {
            walk_records(body)?;
        }
    }
    Ok(uncompressed as usize)
}

/// Walks the records of the data section (opcode, u64 length, body) before the `mcap` crate
/// reads them: every length must fit in what remains, and every chunk must claim a plausible
/// uncompressed size ([`check_chunk`]). The crate reserves the sizes a file claims before
/// checking them, so a corrupt length would otherwise abort the process on a failed
/// allocation (found by `cargo xtask fuzz`). The records inside an uncompressed chunk are
/// walked only before the messages are streamed from the whole map
/// ([`McapReader::check_all_chunks`]); a chunk read on its own needs no walk (see
/// [`McapReader::decode_chunk`]). Walking them all here was a first pass over the file (0.2 s of
/// the 1.0 s read of a 4 GB file). Returns the chunks' offsets and the record length limit.
fn check_records(
    map: &[u8],
) -> std::result::Result<(std::collections::BTreeSet<u64>, usize, Option<Cut>), String> {
    let body = &map[8..];
    let (top, cut_at) = walk_records_until_cut(body);
    let mut limit = top.iter().fold(1usize << 16, |l, &(_, _, len)| l.max(len));
    let mut chunks = std::collections::BTreeSet::new();
    for &(_, start, len) in top.iter().filter(|r| r.0 == 0x06) {
        limit = limit.max(check_chunk(&body[start..start + len], false)?);
        chunks.insert((8 + start - 9) as u64);
    }
    // a data section that ends without its data end record is cut too (at a record boundary)
    let ended = top.last().is_some_and(|r| r.0 == 0x0F);
    let cut_at = cut_at.or((!ended).then_some(body.len()));
    let cut = cut_at.map(|at| {
        let end = 8 + at;
        let mut last = last_log_time(body, &top);
        // a cut uncompressed chunk: its complete records are read too
        let rest = &map[end..];
        let tail = (|| {
            if rest.first() != Some(&0x06) {
                return None;
            }
            let c = rest.get(9..)?;
            let clen = u32::from_le_bytes(c.get(28..32)?.try_into().ok()?) as usize;
            if clen != 0 || c.len() < 40 {
                return None;
            }
            let from = end + 9 + 40;
            let (recs, inner_cut) = walk_records_until_cut(&map[from..]);
            let upto = inner_cut.map_or(map.len(), |c| from + c);
            if let Some(t) = last_log_time(&map[from..], &recs) {
                last = Some(t);
            }
            Some((from, upto))
        })();
        let drop_from = tail.map_or(end, |t| t.1);
        Cut {
            end,
            tail,
            truncation: Truncation {
                offset: drop_from as u64,
                dropped_bytes: (map.len() - drop_from) as u64,
                last_stamp_ns: last,
            },
        }
    });
    if let Some(c) = &cut {
        limit = limit.max(c.tail.map_or(0, |t| t.1 - t.0));
    }
    Ok((chunks, limit, cut))
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
    ///
    /// ```
    /// # use imunoise::logs::imu_msg::{ImuSample, encode_cdr};
    /// # let dir = tempfile::tempdir()?;
    /// # let path = dir.path().join("run.mcap");
    /// # let file = std::io::BufWriter::new(std::fs::File::create(&path)?);
    /// # let mut w = mcap::WriteOptions::new().profile("ros2").create(file)?;
    /// # let schema = w.add_schema("sensor_msgs/msg/Imu", "ros2msg", b"(definition omitted)")?;
    /// # let channel = w.add_channel(schema, "/imu0", "cdr", &Default::default())?;
    /// # for i in 0..200 {
    /// #     let stamp_ns = 1_700_000_000_000_000_000 + 5_000_000 * i as i64;
    /// #     let (gyro, acc) = ([1e-3 * i as f64, 0.0, 0.0], [0.0, 0.0, 9.81]);
    /// #     let s = ImuSample { stamp_ns, gyro, acc };
    /// #     let header = mcap::records::MessageHeader {
    /// #         channel_id: channel,
    /// #         sequence: i,
    /// #         log_time: stamp_ns as u64,
    /// #         publish_time: stamp_ns as u64,
    /// #     };
    /// #     w.write_to_known_channel(&header, &encode_cdr(&s, "imu_link"))?;
    /// # }
    /// # w.finish()?;
    /// // `path`: an MCAP file with 200 IMU messages at 200 Hz on /imu0 (written by the `mcap` crate)
    /// use imunoise::logs::mcap::McapReader;
    /// assert!(McapReader::open(&path).is_ok());
    /// // not an MCAP file: refused at once, as an input error
    /// let other = dir.path().join("other.mcap");
    /// std::fs::write(&other, b"#ROSBAG V2.0\n")?;
    /// assert_eq!(McapReader::open(&other).err().map(|e| e.exit_code()), Some(2));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn open(path: &Path) -> Result<Self> {
        let file = path.display().to_string();
        let map = map_file(path)?;
        if !map.starts_with(b"\x89MCAP0\r\n") {
            return Err(Error::File {
                file,
                message: "not an MCAP file (no MCAP magic at its start)".to_string(),
            });
        }
        let (chunks, limit, cut) = check_records(&map).map_err(|e| Error::File {
            file: file.clone(),
            message: format!("truncated or corrupt MCAP file: {e}"),
        })?;
        Ok(McapReader {
            file,
            map,
            chunks,
            limit,
            cut,
        })
    }

    /// The file up to its cut (the whole map when it is complete).
    fn data(&self) -> &[u8] {
        &self.map[..self.cut.map_or(self.map.len(), |c| c.end)]
    }

    /// The complete records of a cut uncompressed chunk.
    fn tail(&self) -> Option<&[u8]> {
        self.cut.and_then(|c| c.tail).map(|(a, b)| &self.map[a..b])
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

    /// [`check_chunk`] with its records, for the chunk record at file offset `at` (one of
    /// `self.chunks`, whose lengths [`check_records`] checked).
    fn check_chunk_at(&self, at: u64) -> Result<()> {
        let at = at as usize;
        let len = u64_at(&self.map, at + 1).unwrap_or(0) as usize;
        let body = self.map.get(at + 9..at + 9 + len).unwrap_or(&[]);
        check_chunk(body, true)
            .map(|_| ())
            .map_err(|e| Error::File {
                file: self.file.clone(),
                message: format!("truncated or corrupt MCAP file: {e}"),
            })
    }

    /// [`check_chunk_at`](Self::check_chunk_at) for every chunk (in parallel; the first error
    /// in file order), before the messages are streamed from the whole map.
    fn check_all_chunks(&self) -> Result<()> {
        use rayon::prelude::*;
        let at: Vec<u64> = self.chunks.iter().copied().collect();
        let done: Vec<Result<()>> = at.par_iter().map(|&a| self.check_chunk_at(a)).collect();
        done.into_iter().collect()
    }

    fn corrupt(&self, after: u64, e: impl std::fmt::Display) -> Error {
        Error::File {
            file: self.file.clone(),
            message: format!("truncated or corrupt MCAP file (after {after} messages): {e}"),
        }
    }

    /// Topics by a full pass over the messages (when the file has no usable summary).
    fn scan_topics(&self) -> Result<Vec<TopicInfo>> {
        self.check_all_chunks()?;
        let mut stream = BoundedStream::new(self.data(), self.limit);
        let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
        stream
            .for_each_then(self.tail(), |h, _, _| {
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
    /// With a summary that indexes the chunks (every index pointing at a chunk record that
    /// `check_records` checked): the chunks holding `topic` are decoded in parallel (rayon),
    /// in file order, which is the recording order ([`read_direct`](Self::read_direct), else
    /// [`read_joined`](Self::read_joined)). `None` when the file has no chunk index (then it
    /// is streamed).
    fn read_chunks_parallel(&self, topic: &str) -> Result<Option<ImuSeries>> {
        let Some(summary) = summary(&self.map) else {
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
        // With message indexes (what writers emit by default), every chunk decodes straight
        // into its place in the final columns, with no per-chunk copies to join afterwards
        // (that join took 0.37 s of one thread for 1.08·10^7 messages).
        if let Some(out) = self.read_direct(&chunks, &decoders, topic)? {
            return Ok(Some(out));
        }
        self.read_joined(&chunks, &decoders, topic).map(Some)
    }

    /// [`read_chunks_parallel`](Self::read_chunks_parallel) into the final columns, each chunk
    /// in the place its message index gives: `Ok(None)` when a chunk has no usable index, or
    /// its index does not match its contents, or the columns cannot be reserved (then
    /// [`read_joined`](Self::read_joined) reads the chunks).
    fn read_direct(
        &self,
        chunks: &[&mcap::records::ChunkIndex],
        decoders: &BTreeMap<u16, Decoder>,
        topic: &str,
    ) -> Result<Option<ImuSeries>> {
        let Some(counts) = self.indexed_counts(chunks, decoders) else {
            return Ok(None);
        };
        super::read_parts_into(chunks, &counts, |ci, _, sink| {
            self.decode_chunk(ci, topic, decoders, sink)
        })
    }

    /// [`read_chunks_parallel`](Self::read_chunks_parallel) chunk by chunk into series of
    /// their own, joined in file order.
    fn read_joined(
        &self,
        chunks: &[&mcap::records::ChunkIndex],
        decoders: &BTreeMap<u16, Decoder>,
        topic: &str,
    ) -> Result<ImuSeries> {
        use rayon::prelude::*;
        let parts: Vec<Result<ImuSeries>> = chunks
            .par_iter()
            .map(|ci| {
                let mut out = ImuSeries::with_capacity(0);
                self.decode_chunk(ci, topic, decoders, &mut out)?;
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
        Ok(out)
    }

    /// The messages of the channels in `decoders` in each chunk, from the chunk's message index
    /// records (a u32 byte length of 16-byte entries after the channel id): `None` when a chunk
    /// has no index for them or an index record is not where and what the chunk index says.
    fn indexed_counts(
        &self,
        chunks: &[&mcap::records::ChunkIndex],
        decoders: &BTreeMap<u16, Decoder>,
    ) -> Option<Vec<usize>> {
        let map: &[u8] = &self.map;
        chunks
            .iter()
            .map(|ci| {
                let mut n = 0usize;
                let mut any = false;
                for (id, &off) in &ci.message_index_offsets {
                    if !decoders.contains_key(id) {
                        continue;
                    }
                    let at = usize::try_from(off).ok()?;
                    let h = map.get(at..at.checked_add(15)?)?;
                    let len = u64::from_le_bytes(h[1..9].try_into().ok()?);
                    let ch = u16::from_le_bytes(h[9..11].try_into().ok()?);
                    let bytes = u32::from_le_bytes(h[11..15].try_into().ok()?) as u64;
                    // the record lies in the file, and no more messages than the chunk can
                    // hold (a message record takes at least 31 bytes)
                    let fits = (at as u64 + 9).checked_add(len)? <= map.len() as u64;
                    let count = bytes / 16;
                    if h[0] != 0x07
                        || ch != *id
                        || !bytes.is_multiple_of(16)
                        || len != 6 + bytes
                        || !fits
                        || count > ci.uncompressed_size / 31
                    {
                        return None;
                    }
                    n = n.checked_add(usize::try_from(count).ok()?)?;
                    any = true;
                }
                any.then_some(n)
            })
            .collect()
    }

    /// Decodes the messages of the channels in `decoders` in one indexed chunk into `sink`;
    /// `ci` points at one of the chunks `check_records` checked (`read_chunks_parallel` makes
    /// sure of it for every index it passes on).
    fn decode_chunk(
        &self,
        ci: &mcap::records::ChunkIndex,
        topic: &str,
        decoders: &BTreeMap<u16, Decoder>,
        sink: &mut impl SamplePush,
    ) -> Result<()> {
        // The chunk record alone, as long as its own header says (checked by `check_records`;
        // not the length the index claims): its records then end where its data ends, so a
        // record inside it that claims more than what is left stops the crate's reader at
        // the end of the slice (an error, after at most `limit` bytes reserved) instead of
        // running on into the next records. So the records of an uncompressed chunk need no
        // walk of their own here (the whole-map paths do walk them: `check_all_chunks`).
        let start = usize::try_from(ci.chunk_start_offset).unwrap_or(usize::MAX);
        let rec = u64_at(&self.map, start.saturating_add(1))
            .and_then(|len| {
                let end = start
                    .checked_add(9)?
                    .checked_add(usize::try_from(len).ok()?)?;
                self.map.get(start..end)
            })
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
                    sink.push_sample(&d(data).map_err(|why| self.not_imu(topic, which(), why))?);
                }
                Ok(())
            })
            .map_err(|s| self.stop(s))?;
        Ok(())
    }
}

impl LogReader for McapReader {
    fn format(&self) -> LogFormat {
        LogFormat::Mcap
    }

    fn truncation(&self) -> Option<Truncation> {
        self.cut.map(|c| c.truncation)
    }

    fn topics(&self) -> Result<Vec<TopicInfo>> {
        // The summary (when the recording was closed properly) has the counts.
        if let Some(summary) = summary(&self.map)
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
        let hint = summary(&self.map)
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
        self.check_all_chunks()?;
        let mut out = ImuSeries::with_capacity(hint.min(1 << 28) as usize);
        let mut stream = BoundedStream::new(self.data(), self.limit);
        // Per channel id: None = not looked up yet, Some(None) = not this topic.
        let mut dec: Vec<Option<Option<Decoder>>> = vec![None; 1 << 16];
        let r = stream.for_each_then(self.tail(), |h, data, channels| {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::logs::SliceSink;
    use crate::logs::imu_msg::encode_cdr;
    use std::mem::MaybeUninit;

    /// Writes `n` Imu messages on /imu0 and `n / 3` on /imu1 (interleaved), in chunks of about
    /// `chunk` bytes (zstd, or uncompressed with `plain`), with or without message indexes;
    /// the values are distinct per message.
    fn write_with(path: &Path, n: usize, chunk: u64, indexes: bool, plain: bool) {
        let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
        let mut w = mcap::WriteOptions::new()
            .profile("ros2")
            .chunk_size(Some(chunk))
            .compression((!plain).then_some(mcap::Compression::Zstd))
            .emit_message_indexes(indexes)
            .create(f)
            .unwrap();
        let s = w
            .add_schema("sensor_msgs/msg/Imu", "ros2msg", b"(omitted)")
            .unwrap();
        let ids = [
            w.add_channel(s, "/imu0", "cdr", &BTreeMap::new()).unwrap(),
            w.add_channel(s, "/imu1", "cdr", &BTreeMap::new()).unwrap(),
        ];
        let mut seq = 0;
        for i in 0..n {
            for (k, &id) in ids.iter().enumerate() {
                if k == 1 && i % 3 != 0 {
                    continue;
                }
                let v = (i * 7 + k) as f64 * 0.125 - 3.0;
                let sample = ImuSample {
                    stamp_ns: 1_000_000 * i as i64 + k as i64,
                    gyro: [v, v + 1.0, v + 2.0],
                    acc: [v + 3.0, v + 4.0, v + 5.0],
                };
                let t = sample.stamp_ns as u64;
                let header = mcap::records::MessageHeader {
                    channel_id: id,
                    sequence: seq,
                    log_time: t,
                    publish_time: t,
                };
                w.write_to_known_channel(&header, &encode_cdr(&sample, "imu"))
                    .unwrap();
                seq += 1;
            }
        }
        w.finish().unwrap();
    }

    fn write(path: &Path, n: usize, chunk: u64, indexes: bool) {
        write_with(path, n, chunk, indexes, false)
    }

    fn chunks_and_decoders(
        r: &McapReader,
        topic: &str,
    ) -> (Vec<mcap::records::ChunkIndex>, BTreeMap<u16, Decoder>) {
        // the guarded read: a file the `mcap` crate wrote passes its walk
        let summary = summary(&r.map).expect("a sound summary section");
        let decoders = summary
            .channels
            .iter()
            .filter(|(_, c)| c.topic == topic)
            .map(|(&id, _)| (id, decode_cdr as Decoder))
            .collect();
        let mut chunks = summary.chunk_indexes.clone();
        chunks.sort_by_key(|c| c.chunk_start_offset);
        (chunks, decoders)
    }

    /// Every chunk read straight into its place (from its message index) gives the same
    /// series, bit for bit, as the chunks read into series of their own and joined (the path
    /// of a file written without message indexes); an index whose counts do not match the
    /// chunks, or no index at all, makes the direct read decline.
    #[test]
    fn direct_and_joined_reads_agree() {
        let dir = std::env::temp_dir().join(format!("imunoise-mcap-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (with, without) = (dir.join("with.mcap"), dir.join("without.mcap"));
        // 5000 + 1667 messages of 324 bytes in chunks of about 40 kB: about 55 chunks, the
        // last one partial
        write(&with, 5000, 40_000, true);
        write(&without, 5000, 40_000, false);
        for topic in ["/imu0", "/imu1"] {
            let r = McapReader::open(&with).unwrap();
            let (chunks, dec) = chunks_and_decoders(&r, topic);
            assert!(chunks.len() > 40, "{} chunks", chunks.len());
            let refs: Vec<&mcap::records::ChunkIndex> = chunks.iter().collect();
            let counts = r.indexed_counts(&refs, &dec).expect("indexed");
            let want = if topic == "/imu0" { 5000 } else { 1667 };
            assert_eq!(counts.iter().sum::<usize>(), want);
            let direct = r.read_direct(&refs, &dec, topic).unwrap().expect("direct");
            let joined = r.read_joined(&refs, &dec, topic).unwrap();
            assert_eq!(direct.stamps_ns, joined.stamps_ns);
            assert_eq!(direct.columns, joined.columns);
            assert_eq!(direct.stamps_ns.len(), want);
            // the public read takes the direct path here, and the joined one on the same
            // messages written without message indexes
            assert_eq!(r.read_imu(topic).unwrap().columns, direct.columns);
            let plain = McapReader::open(&without).unwrap();
            let (pc, pd) = chunks_and_decoders(&plain, topic);
            let prefs: Vec<&mcap::records::ChunkIndex> = pc.iter().collect();
            assert!(plain.indexed_counts(&prefs, &pd).is_none());
            assert!(plain.read_direct(&prefs, &pd, topic).unwrap().is_none());
            let p = plain.read_imu(topic).unwrap();
            assert_eq!((p.stamps_ns, p.columns), (direct.stamps_ns, direct.columns));
            // the first chunk given the last chunk's index record (same channel, fewer
            // messages) and the other way round: the counts no longer match the chunks
            let mut bad = chunks.clone();
            let last = bad.len() - 1;
            let (a, b) = (
                bad[0].message_index_offsets.clone(),
                bad[last].message_index_offsets.clone(),
            );
            bad[0].message_index_offsets = b;
            bad[last].message_index_offsets = a;
            let brefs: Vec<&mcap::records::ChunkIndex> = bad.iter().collect();
            let bc = r.indexed_counts(&brefs, &dec).expect("still well formed");
            assert_ne!(bc, counts);
            assert!(r.read_direct(&brefs, &dec, topic).unwrap().is_none());
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// An uncompressed chunk whose last record claims more bytes than the chunk has left, or
    /// whose middle record claims 1000 bytes more than it has: reading it chunk by chunk
    /// (with no walk over its records first) is a clear error, not a panic or a read past
    /// the chunk; so is streaming the whole file (which walks them first).
    #[test]
    fn an_inner_record_past_its_chunk_is_an_error() {
        let dir = std::env::temp_dir().join(format!("imunoise-mcap-inner-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.mcap");
        write_with(&good, 600, 40_000, true, true);
        let bytes = std::fs::read(&good).unwrap();
        let r = McapReader::open(&good).unwrap();
        let (chunks, _) = chunks_and_decoders(&r, "/imu0");
        let o = chunks[1].chunk_start_offset as usize;
        let len = u64_at(&bytes, o + 1).unwrap() as usize;
        let body = &bytes[o + 9..o + 9 + len];
        assert_eq!(check_chunk(body, true).unwrap(), len - 40, "uncompressed");
        let recs = walk_records(&body[40..]).unwrap();
        assert!(recs.len() > 20);
        for (which, k, extra) in [
            ("last", recs.len() - 1, 64),
            ("middle", recs.len() / 2, 1000),
        ] {
            let (op, start, rlen) = recs[k];
            assert_eq!(op, 0x05, "a message record");
            let at = o + 9 + 40 + start - 8; // its length field
            let mut bad = bytes.clone();
            bad[at..at + 8].copy_from_slice(&((rlen + extra) as u64).to_le_bytes());
            let p = dir.join(format!("{which}.mcap"));
            std::fs::write(&p, &bad).unwrap();
            let r = McapReader::open(&p).unwrap();
            let e = r.read_imu("/imu0").unwrap_err().to_string();
            assert!(e.contains("truncated or corrupt MCAP"), "{which}: {e}");
            let e = r.scan_topics().unwrap_err().to_string();
            assert!(e.contains("truncated or corrupt MCAP"), "{which}: {e}");
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A chunk sink flags more messages than its index gave, and counts fewer.
    #[test]
    fn slice_sink_flags_overflow_and_counts() {
        let s = ImuSample {
            stamp_ns: 5,
            gyro: [1.0, 2.0, 3.0],
            acc: [4.0, 5.0, 6.0],
        };
        let mut st = [MaybeUninit::uninit(); 2];
        let mut c: [[MaybeUninit<f64>; 2]; 6] = [[MaybeUninit::uninit(); 2]; 6];
        let [c0, c1, c2, c3, c4, c5] = &mut c;
        let mut sink = SliceSink {
            stamps: &mut st,
            columns: [c0, c1, c2, c3, c4, c5],
            n: 0,
            overflow: false,
        };
        sink.push_sample(&s);
        assert_eq!((sink.n, sink.overflow), (1, false));
        sink.push_sample(&s);
        sink.push_sample(&s);
        assert_eq!((sink.n, sink.overflow), (2, true));
        // SAFETY: both elements of the last column were written above
        assert_eq!(unsafe { c[5][1].assume_init() }, 6.0);
    }
}
