//! File-backed sample sources for the streamed Allan variance ([`avar::SampleSource`]).
//!
//! * A raw little-endian f64 file of one channel (no scale, read as is) is memory-mapped and
//!   used in place ([`MappedSamples::map_f64`]): the estimator reads it by position and
//!   releases the pages of every range it is done with (`madvise(MADV_DONTNEED)`), so the
//!   process keeps a bounded window of the file resident, whatever its size.
//! * Any other raw binary layout (f32, i16, i32; several interleaved channels; a row stride
//!   with padding or a header; a scale factor), gzip-compressed binary, and standard input or
//!   a pipe (which cannot seek) are decoded once, in one pass over the input, into one compact
//!   f64 copy per channel ([`decode_binary`]): in anonymous memory when all the copies fit in a
//!   quarter of the memory available (8 bytes per sample and channel resident, no disk
//!   writes), otherwise in temporary files (in the system's temporary directory, deleted when
//!   the source is dropped; the same 8 bytes per sample and channel of disk space), mapped as
//!   above. Gzip, standard input and pipes always go to temporary files, read sequentially in
//!   bounded memory. Every channel of an interleaved file comes out of the same single pass.
//! * [`for_channel_groups`] (what `imunoise avar` uses) decodes a regular uncompressed file a
//!   group of channels at a time instead, into the same buffers for every group
//!   ([`group_size`] channels per pass over the file: 2 of 6 f64 channels), so that the
//!   memory is that of the group, not of every channel.
//!
//! The values are those the in-memory reader ([`crate::io`]) produces, bit for bit (the same
//! conversion and the same multiplication by the scale), so the Allan variance is identical.

use crate::error::{Error, Result};
use crate::io::BinaryType;
pub use crate::mapped::MappedSamples;
use crate::mapped::{Backing, page_size, whole_rows};
use avar::SampleSource;
use std::io::{Read, Write};
use std::path::Path;

/// The layout of a raw binary file: element type, channels per row, row stride and header.
///
/// ```
/// use imunoise::io::BinaryType;
/// use imunoise::source::BinaryLayout;
/// let l = BinaryLayout::new(BinaryType::I16, 6);
/// assert_eq!(l.row_bytes(), 12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BinaryLayout {
    /// Element type (little-endian).
    pub kind: BinaryType,
    /// Values per row (≥ 1).
    pub channels: usize,
    /// Bytes from one row to the next; `None`: `channels × kind.size()` (no padding).
    pub stride: Option<usize>,
    /// Bytes skipped at the start of the file.
    pub header: usize,
    /// Factor every value is multiplied by (e.g. counts → °/s); `None`: 1.
    pub scale: Option<f64>,
}

impl BinaryLayout {
    /// `channels` values of type `kind` per row, no padding, no header, no scale.
    ///
    /// ```
    /// use imunoise::io::BinaryType;
    /// use imunoise::source::BinaryLayout;
    /// let l = BinaryLayout::new(BinaryType::F32, 6);
    /// assert_eq!((l.kind, l.channels), (BinaryType::F32, 6));
    /// assert_eq!((l.stride, l.header, l.scale), (None, 0, None));
    /// ```
    pub fn new(kind: BinaryType, channels: usize) -> Self {
        BinaryLayout {
            kind,
            channels,
            stride: None,
            header: 0,
            scale: None,
        }
    }

    /// Bytes per row.
    ///
    /// ```
    /// use imunoise::io::BinaryType;
    /// use imunoise::source::BinaryLayout;
    /// let l = BinaryLayout::new(BinaryType::F64, 3);
    /// assert_eq!(l.row_bytes(), 3 * 8);
    /// // a stride, when given, includes any padding
    /// assert_eq!(BinaryLayout { stride: Some(32), ..l }.row_bytes(), 32);
    /// ```
    pub fn row_bytes(&self) -> usize {
        self.stride.unwrap_or(self.channels * self.kind.size())
    }

    fn check(&self) -> Result<()> {
        if self.channels == 0 {
            return Err(Error::Usage("--channels must be at least 1".to_string()));
        }
        if self.row_bytes() < self.channels * self.kind.size() {
            return Err(Error::Usage(format!(
                "a row stride of {} bytes cannot hold {} values of {} bytes",
                self.row_bytes(),
                self.channels,
                self.kind.size()
            )));
        }
        if let Some(s) = self.scale
            && !(s.is_finite() && s != 0.0)
        {
            return Err(Error::Usage(format!(
                "--scale must be finite and non-zero, got {s}"
            )));
        }
        Ok(())
    }
}

/// Whether `file` holds gzip data: it starts with the gzip magic bytes and its first byte
/// decompresses (raw samples can begin with the magic bytes by chance: f64 1.19e117 does;
/// they are then read raw, as by [`crate::io::read_bytes`]).
pub(crate) fn is_gzip(file: &Path) -> bool {
    let mut head = [0u8; 2];
    let magic = std::fs::File::open(file)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| head == [0x1f, 0x8b]);
    magic
        && std::fs::File::open(file).is_ok_and(|f| {
            let mut one = [0u8; 1];
            flate2::read::MultiGzDecoder::new(std::io::BufReader::new(f))
                .read(&mut one)
                .is_ok()
        })
}

/// Whether [`decode_binary`] uses `file` in place (a map of the file itself, whose values
/// nobody has looked at yet) rather than decoding it: one f64 channel without scale, no row
/// padding, an 8-byte-aligned header, a regular uncompressed file.
pub(crate) fn used_in_place(file: &Path, layout: &BinaryLayout) -> bool {
    layout.kind == BinaryType::F64
        && layout.channels == 1
        && layout.stride.is_none_or(|s| s == 8)
        && layout.scale.is_none_or(|s| s == 1.0)
        && layout.header.is_multiple_of(8)
        && cfg!(target_endian = "little")
        && is_regular(file)
        && !is_gzip(file)
}

/// The error for the non-finite value `v` at 0-based `row` of 0-based `channel` of `name`.
pub(crate) fn non_finite(name: &str, row: usize, channel: usize, v: f64) -> Error {
    Error::Located {
        file: name.to_string(),
        line: row + 1,
        column: channel + 1,
        message: format!(
            "{v} in row {} channel {}: values must be finite",
            row + 1,
            channel + 1
        ),
    }
}

/// Why `file` cannot be read by position, if it cannot: `Some("is standard input")` for `-`,
/// `Some("is not a regular file (a pipe, FIFO or device)")`, `Some("is gzip-compressed")`;
/// `None` for a regular uncompressed file, for a folder (a ROS 2 bag, which its reader opens),
/// and for a path that cannot be looked up (missing, or no permission: the read then says
/// which, with no note about a pipe before it). Such
/// inputs are decoded once, in one sequential pass (raw binary: into temporary files; text:
/// whole into memory), and the commands say so.
///
/// ```
/// use imunoise::source::unseekable;
/// assert_eq!(unseekable(std::path::Path::new("-")), Some("is standard input"));
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("w.f64");
/// std::fs::write(&p, [0u8; 16]).unwrap();
/// assert_eq!(unseekable(&p), None);
/// assert_eq!(unseekable(dir.path()), None); // a folder: a ROS 2 bag, or an error of its own
/// assert_eq!(unseekable(&dir.path().join("missing.f64")), None);
/// ```
pub fn unseekable(file: &Path) -> Option<&'static str> {
    if file.as_os_str() == "-" {
        Some("is standard input")
    } else if std::fs::metadata(file).is_err() || file.is_dir() {
        None
    } else if !is_regular(file) {
        Some("is not a regular file (a pipe, FIFO or device)")
    } else if is_gzip(file) {
        Some("is gzip-compressed")
    } else {
        None
    }
}

/// Window of [`decode_text`] in bytes of text: the parse of one window (its values as f64,
/// about half its size for 17-digit CSV) is what is held in memory at a time.
pub const TEXT_WINDOW: usize = 64 << 20;

/// The columns of a regular, uncompressed text file (CSV, TSV or whitespace-separated, as
/// [`crate::io::parse_text`] reads it; `select` as `--columns`) parsed in windows of `window`
/// bytes ([`crate::io::parse_text_windows`]), each value times `scale`, and written to one
/// compact f64 temporary file per column, mapped as a [`SampleSource`]: memory for one window,
/// 8 bytes per value of disk space. The values are those of the in-memory reader, bit for
/// bit, and so are the errors. Returns the columns' names and their sources.
///
/// ```
/// use avar::SampleSource;
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("x.csv");
/// std::fs::write(&p, "gx,gy\n1,2\n3,4\n5,6\n").unwrap();
/// let (names, cols) = imunoise::source::decode_text(&p, "x.csv", None, Some(0.5), 5).unwrap();
/// assert_eq!(names, ["gx", "gy"]);
/// assert_eq!(cols[1].samples(), &[1.0, 2.0, 3.0]);
/// ```
pub fn decode_text(
    file: &Path,
    name: &str,
    select: Option<&[crate::io::ColumnSpec]>,
    scale: Option<f64>,
    window: usize,
) -> Result<(Vec<String>, Vec<MappedSamples>)> {
    if let Some(scale) = scale
        && !(scale.is_finite() && scale != 0.0)
    {
        return Err(Error::Usage(format!(
            "--scale must be finite and non-zero, got {scale}"
        )));
    }
    let tmp_err = |e: std::io::Error| Error::File {
        file: name.to_string(),
        message: format!("cannot write the temporary decoded copy: {e}"),
    };
    let mut files: Vec<std::io::BufWriter<std::fs::File>> = Vec::new();
    let mut rows = 0usize;
    let mut bytes = Vec::new();
    // per column, the first row the scale takes beyond f64 (reported for the first such
    // column, as the in-memory reader does)
    let mut scaled_out: Vec<Option<usize>> = Vec::new();
    let names = crate::io::parse_text_windows(file, name, select, window, |cols| {
        if files.is_empty() {
            for _ in &cols {
                let f = tempfile::tempfile().map_err(tmp_err)?;
                files.push(std::io::BufWriter::with_capacity(1 << 20, f));
            }
            scaled_out = vec![None; cols.len()];
        }
        for (k, (w, col)) in files.iter_mut().zip(&cols).enumerate() {
            bytes.clear();
            bytes.reserve(8 * col.len());
            for (r, &v) in col.iter().enumerate() {
                let v = match scale {
                    Some(s) => v * s,
                    None => v,
                };
                if !v.is_finite() && scaled_out[k].is_none() {
                    scaled_out[k] = Some(rows + r);
                }
                bytes.extend_from_slice(&v.to_le_bytes());
            }
            w.write_all(&bytes).map_err(tmp_err)?;
        }
        rows += cols.first().map_or(0, Vec::len);
        Ok(())
    })?;
    let first_out = scaled_out
        .iter()
        .enumerate()
        .find_map(|(k, r)| r.map(|r| (k, r)));
    if let (Some((k, row)), Some(scale)) = (first_out, scale) {
        // as the in-memory reader says it
        return Err(Error::Usage(format!(
            "--scale {scale:e} takes the value of channel {:?} at row {} beyond the range of f64",
            names[k],
            row + 1
        )));
    }
    let sources = files
        .into_iter()
        .map(|w| {
            let f = w.into_inner().map_err(|e| tmp_err(e.into_error()))?;
            MappedSamples::from_file(&f, name, 0)
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((names, sources))
}

/// The subject of the notes on an input that cannot be read by position: "standard input",
/// or the file and why (from [`unseekable`]), e.g. "x.f64.gz is gzip-compressed and".
pub(crate) fn unseekable_subject(file: &Path, why: &str) -> String {
    if file.as_os_str() == "-" {
        "standard input".to_string()
    } else {
        format!("{} {why} and", file.display())
    }
}

/// Whether `file` is a regular file (not standard input `-`, a pipe or a FIFO).
pub(crate) fn is_regular(file: &Path) -> bool {
    file.as_os_str() != "-" && std::fs::metadata(file).is_ok_and(|m| m.is_file())
}

/// Opens the raw binary `file` laid out as `layout` as one [`SampleSource`] per channel of
/// `channels` (0-based; all channels when empty), in that order. A single f64 channel without
/// scale in a regular uncompressed file is mapped in place; everything else (other types,
/// several channels, a stride, a scale, gzip, standard input `-` or a pipe) is decoded once, in
/// one sequential pass, into compact temporary f64 files (see the module docs). `name` is used
/// in messages. Errors like [`crate::io::parse_binary`]: a file that is not a whole number of
/// rows, an empty file, and a non-finite value (naming its row and channel); a file mapped in
/// place is not read here, so its values are checked by what reads them (the table reader's
/// finiteness pass, or the estimator, which refuses a non-finite sample naming its index).
///
/// ```
/// use avar::SampleSource;
/// use imunoise::io::BinaryType;
/// use imunoise::source::{decode_binary, BinaryLayout};
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("x.i16");
/// let bytes: Vec<u8> = [1i16, 10, 2, 20, 3, 30].iter().flat_map(|v| v.to_le_bytes()).collect();
/// std::fs::write(&p, bytes).unwrap();
/// let layout = BinaryLayout { scale: Some(0.5), ..BinaryLayout::new(BinaryType::I16, 2) };
/// let s = decode_binary(&p, "x.i16", &layout, &[]).unwrap();
/// assert_eq!(s[0].samples(), &[0.5, 1.0, 1.5]);
/// assert_eq!(s[1].samples(), &[5.0, 10.0, 15.0]);
/// ```
pub fn decode_binary(
    file: &Path,
    name: &str,
    layout: &BinaryLayout,
    channels: &[usize],
) -> Result<Vec<MappedSamples>> {
    layout.check()?;
    let all: Vec<usize> = (0..layout.channels).collect();
    let channels = if channels.is_empty() { &all } else { channels };
    if let Some(&c) = channels.iter().find(|&&c| c >= layout.channels) {
        return Err(Error::Usage(format!(
            "--columns: column {} does not exist (the file has {} columns)",
            c + 1,
            layout.channels
        )));
    }
    if used_in_place(file, layout) {
        return Ok(vec![MappedSamples::map_f64(file, name, layout.header)?]);
    }
    if is_regular(file) && !is_gzip(file) {
        return decode_file(file, name, layout, channels);
    }
    let reader: Box<dyn Read> = if file.as_os_str() == "-" {
        Box::new(std::io::stdin().lock())
    } else {
        let f = std::fs::File::open(file).map_err(|e| Error::io(name, e))?;
        if is_regular(file) && is_gzip(file) {
            Box::new(flate2::read::MultiGzDecoder::new(std::io::BufReader::new(
                f,
            )))
        } else {
            Box::new(f)
        }
    };
    decode_stream(reader, name, layout, channels)
}

/// The single decoding pass of [`decode_binary`]: rows in blocks of about 4 MiB, each selected
/// channel converted, scaled, checked and appended to its temporary file.
fn decode_stream(
    mut reader: Box<dyn Read>,
    name: &str,
    layout: &BinaryLayout,
    channels: &[usize],
) -> Result<Vec<MappedSamples>> {
    let tmp_err = |e: std::io::Error| Error::File {
        file: name.to_string(),
        message: format!("cannot write the temporary decoded copy: {e}"),
    };
    let row = layout.row_bytes();
    let size = layout.kind.size();
    let mut files = Vec::with_capacity(channels.len());
    for _ in channels {
        files.push(tempfile::tempfile().map_err(tmp_err)?);
    }
    // skip the header
    let mut skipped = 0usize;
    let mut sink = [0u8; 4096];
    while skipped < layout.header {
        let want = (layout.header - skipped).min(sink.len());
        let got = read_full(&mut reader, &mut sink[..want]).map_err(|e| Error::io(name, e))?;
        if got == 0 {
            break;
        }
        skipped += got;
    }
    let rows_per_block = ((4 << 20) / row).max(1);
    let mut buf = vec![0u8; rows_per_block * row];
    let mut outs: Vec<Vec<u8>> = channels
        .iter()
        .map(|_| Vec::with_capacity(rows_per_block * 8))
        .collect();
    let mut rows = 0usize;
    let mut total = 0usize;
    loop {
        let got = read_full(&mut reader, &mut buf).map_err(|e| Error::io(name, e))?;
        total += got;
        let whole = got / row;
        for (o, &c) in outs.iter_mut().zip(channels) {
            o.resize(8 * whole, 0);
            decode_block(&buf[..whole * row], rows, name, layout, c, o)?;
        }
        for (f, o) in files.iter_mut().zip(&outs) {
            f.write_all(o).map_err(tmp_err)?;
        }
        rows += whole;
        if got < buf.len() {
            if got % row != 0 {
                return Err(whole_rows(name, total, layout.channels, size));
            }
            break;
        }
    }
    if rows == 0 {
        return Err(Error::File {
            file: name.to_string(),
            message: "the file is empty".to_string(),
        });
    }
    files
        .iter()
        .map(|f| MappedSamples::from_file(f, name, 0))
        .collect()
}

/// The decoding pass of [`decode_binary`] for a regular uncompressed file: blocks of rows
/// read with positioned reads and decoded in parallel (rayon), each channel's values written
/// at their place in its temporary file; a non-finite value of the first block that holds
/// one is reported.
fn decode_file(
    file: &Path,
    name: &str,
    layout: &BinaryLayout,
    channels: &[usize],
) -> Result<Vec<MappedSamples>> {
    decode_file_within(file, name, layout, channels, memory_budget())
}

/// [`decode_file`] keeping the decoded copies in memory when they take at most `budget` bytes.
fn decode_file_within(
    file: &Path,
    name: &str,
    layout: &BinaryLayout,
    channels: &[usize],
    budget: usize,
) -> Result<Vec<MappedSamples>> {
    use rayon::prelude::*;
    use std::os::unix::fs::FileExt;
    let tmp_err = |e: std::io::Error| Error::File {
        file: name.to_string(),
        message: format!("cannot write the temporary decoded copy: {e}"),
    };
    let f = std::fs::File::open(file).map_err(|e| Error::io(name, e))?;
    let size = f.metadata().map_err(|e| Error::io(name, e))?.len() as usize;
    let body = size.saturating_sub(layout.header);
    let row = layout.row_bytes();
    let kind = layout.kind;
    if body == 0 {
        return Err(Error::File {
            file: name.to_string(),
            message: "the file is empty".to_string(),
        });
    }
    if !body.is_multiple_of(row) {
        return Err(whole_rows(name, body, layout.channels, kind.size()));
    }
    let rows = body / row;
    // blocks of about 1 MiB of input, which stay in cache while every channel is taken out
    let per_block = ((1 << 20) / row).max(1);
    if 8 * rows * channels.len() <= budget {
        return decode_to_memory(&f, name, layout, channels, rows, per_block);
    }
    let mut files = Vec::with_capacity(channels.len());
    for _ in channels {
        let t = tempfile::tempfile().map_err(tmp_err)?;
        t.set_len(8 * rows as u64).map_err(tmp_err)?;
        files.push(t);
    }
    let blocks = rows.div_ceil(per_block);
    let results: Vec<Result<()>> = (0..blocks)
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(inb, outb): &mut (Vec<u8>, Vec<u8>), b| {
                let r0 = b * per_block;
                let k = per_block.min(rows - r0);
                inb.resize(k * row, 0);
                f.read_exact_at(inb, (layout.header + r0 * row) as u64)
                    .map_err(|e| Error::io(name, e))?;
                for (t, &c) in files.iter().zip(channels) {
                    outb.resize(8 * k, 0);
                    decode_block(inb, r0, name, layout, c, outb)?;
                    t.write_all_at(outb, 8 * r0 as u64).map_err(tmp_err)?;
                }
                Ok(())
            },
        )
        .collect();
    results.into_iter().collect::<Result<()>>()?;
    files
        .iter()
        .map(|t| MappedSamples::from_file(t, name, 0))
        .collect()
}

/// Bytes of decoded samples [`decode_binary`] keeps in memory rather than in temporary files:
/// a quarter of the memory available when the input is opened (`MemAvailable`), so that
/// several channels are decoded without writing gigabytes to the disk while there is room.
pub(crate) fn memory_budget() -> usize {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("MemAvailable:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse::<usize>().ok())
        })
        .map_or(0, |kib| kib * 1024 / 4)
}

/// One block of rows of `inb` (starting at row `r0`): channel `c` decoded into `out` (the
/// little-endian values converted to f64 as [`crate::io::parse_binary`] converts them, then
/// times the scale); errors on the first non-finite value, named by row and channel.
fn decode_block(
    inb: &[u8],
    r0: usize,
    name: &str,
    layout: &BinaryLayout,
    c: usize,
    out: &mut [u8],
) -> Result<()> {
    // one loop per element type (the conversion inlined), without an early exit: the
    // finiteness of the block is checked once, and only a block that holds a non-finite
    // value is searched for the first one (6 channels × 10^8 rows of f64: the decoding
    // pass took 16 % of `avar`'s cycles with a conversion and a test per value)
    let finite = match layout.kind {
        BinaryType::F64 => decode_typed(inb, layout, c, out, f64::from_le_bytes),
        BinaryType::F32 => decode_typed(inb, layout, c, out, |b| f32::from_le_bytes(b) as f64),
        BinaryType::I16 => decode_typed(inb, layout, c, out, |b| i16::from_le_bytes(b) as f64),
        BinaryType::I32 => decode_typed(inb, layout, c, out, |b| i32::from_le_bytes(b) as f64),
    };
    if finite {
        return Ok(());
    }
    let (r, v) = out
        .chunks_exact(8)
        .map(|o| f64::from_le_bytes(o.try_into().expect("8 bytes")))
        .enumerate()
        .find(|(_, v)| !v.is_finite())
        .expect("a non-finite value");
    Err(non_finite(name, r0 + r, c, v))
}

/// [`decode_block`] for values of S bytes converted by `conv`: writes every value (times the
/// scale) and returns whether all of them are finite.
#[inline(always)]
fn decode_typed<const S: usize>(
    inb: &[u8],
    layout: &BinaryLayout,
    c: usize,
    out: &mut [u8],
    conv: impl Fn([u8; S]) -> f64,
) -> bool {
    let row = layout.row_bytes();
    let mut finite = true;
    let rows = inb.chunks(row).map(|r| &r[c * S..c * S + S]);
    match layout.scale {
        None => {
            for (o, b) in out.chunks_exact_mut(8).zip(rows) {
                let v = conv(b.try_into().expect("S bytes"));
                finite &= v.is_finite();
                o.copy_from_slice(&v.to_le_bytes());
            }
        }
        Some(s) => {
            for (o, b) in out.chunks_exact_mut(8).zip(rows) {
                let v = conv(b.try_into().expect("S bytes")) * s;
                finite &= v.is_finite();
                o.copy_from_slice(&v.to_le_bytes());
            }
        }
    }
    finite
}

/// `n` anonymous buffers of `rows` f64 each (the decoders' channel copies).
fn anon_buffers(n: usize, rows: usize, name: &str) -> Result<Vec<memmap2::MmapMut>> {
    (0..n)
        .map(|_| memmap2::MmapMut::map_anon(8 * rows).map_err(|e| Error::io(name, e)))
        .collect()
}

/// [`decode_file`] into anonymous memory (when it fits in [`memory_budget`]).
fn decode_to_memory(
    f: &std::fs::File,
    name: &str,
    layout: &BinaryLayout,
    channels: &[usize],
    rows: usize,
    per_block: usize,
) -> Result<Vec<MappedSamples>> {
    let mut maps = anon_buffers(channels.len(), rows, name)?;
    decode_into(f, name, layout, channels, rows, per_block, &mut maps)?;
    Ok(maps
        .into_iter()
        .map(|m| MappedSamples {
            backing: Backing::Anon(m),
            offset: 0,
            len: rows,
            page: page_size(),
            pending: Default::default(),
        })
        .collect())
}

/// Runs `f` on every selected channel of a raw binary file, a group of channels at a time,
/// handing it the position of the group's first channel in `channels` (all of them when
/// empty) and the group's sources; the results are those of [`decode_binary`]'s sources, bit
/// for bit. A regular uncompressed file that needs decoding (another type, interleaved
/// channels, a scale, a stride) is decoded group by group into the same anonymous buffers,
/// [`group_size`] channels per pass over the file, instead of into a copy of every channel at
/// once: 8 bytes per row and channel of the group, not of the file. A file used in place, a
/// gzip file, standard input, a pipe, and a file whose single channel does not fit in memory
/// go through [`decode_binary`] as one group (a file used in place is then handed unread: the
/// estimators check its samples).
///
/// ```
/// use avar::SampleSource;
/// use imunoise::io::BinaryType;
/// use imunoise::source::{BinaryLayout, for_channel_groups};
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("x.i16");
/// let bytes: Vec<u8> = [1i16, 10, 2, 20, 3, 30].iter().flat_map(|v| v.to_le_bytes()).collect();
/// std::fs::write(&p, bytes).unwrap();
/// let layout = BinaryLayout::new(BinaryType::I16, 2);
/// let mut seen = Vec::new();
/// for_channel_groups(&p, "x.i16", &layout, &[], |first, group| {
///     for (k, s) in group.iter().enumerate() {
///         seen.push((first + k, s.samples().to_vec()));
///     }
///     Ok(())
/// })
/// .unwrap();
/// assert_eq!(seen, vec![(0, vec![1.0, 2.0, 3.0]), (1, vec![10.0, 20.0, 30.0])]);
/// ```
pub fn for_channel_groups(
    file: &Path,
    name: &str,
    layout: &BinaryLayout,
    channels: &[usize],
    mut f: impl FnMut(usize, &[&dyn SampleSource]) -> Result<()>,
) -> Result<()> {
    layout.check()?;
    let all: Vec<usize> = (0..layout.channels).collect();
    let channels = if channels.is_empty() { &all } else { channels };
    let Some((fh, rows, group)) = grouping(file, name, layout, channels)? else {
        let sources = decode_binary(file, name, layout, channels)?;
        let refs: Vec<&dyn SampleSource> = sources.iter().map(|s| s as &dyn SampleSource).collect();
        return f(0, &refs);
    };
    let row = layout.row_bytes();
    let per_block = ((1 << 20) / row).max(1);
    let mut maps = anon_buffers(group, rows, name)?;
    for (g, cs) in channels.chunks(group).enumerate() {
        let maps = &mut maps[..cs.len()];
        decode_into(&fh, name, layout, cs, rows, per_block, maps)?;
        let views: Vec<avar::source::SliceSource<'_>> = maps
            .iter()
            .map(|m| {
                // SAFETY: an anonymous map is page-aligned and holds 8·rows bytes, every bit
                // pattern is a valid f64, and the shared borrow of `maps` keeps the buffer
                // alive and unchanged while the views live.
                avar::source::SliceSource(unsafe {
                    std::slice::from_raw_parts(m.as_ptr().cast::<f64>(), rows)
                })
            })
            .collect();
        let refs: Vec<&dyn SampleSource> = views.iter().map(|s| s as &dyn SampleSource).collect();
        f(g * group, &refs)?;
    }
    Ok(())
}

/// Whether [`for_channel_groups`] decodes `file` by groups: `Some((the open file, rows,
/// channels per group))` for a regular uncompressed file of whole rows that is not used in
/// place, whose single channel fits in [`memory_budget`]; `None` otherwise (then
/// [`decode_binary`] reads it, and gives the messages of a bad file).
fn grouping(
    file: &Path,
    name: &str,
    layout: &BinaryLayout,
    channels: &[usize],
) -> Result<Option<(std::fs::File, usize, usize)>> {
    if channels.iter().any(|&c| c >= layout.channels)
        || used_in_place(file, layout)
        || !is_regular(file)
        || is_gzip(file)
    {
        return Ok(None);
    }
    let fh = std::fs::File::open(file).map_err(|e| Error::io(name, e))?;
    let size = fh.metadata().map_err(|e| Error::io(name, e))?.len() as usize;
    let body = size.saturating_sub(layout.header);
    let row = layout.row_bytes();
    if body == 0 || !body.is_multiple_of(row) {
        return Ok(None);
    }
    let rows = body / row;
    let group = group_size(channels.len(), layout.kind.size(), rows, memory_budget());
    Ok((group > 0).then_some((fh, rows, group)))
}

/// Channels that [`for_channel_groups`] decodes per pass over a file of `k` selected channels
/// of `size`-byte values and `rows` rows, within `budget` bytes of buffers (0: not even one
/// channel fits; the caller then decodes into temporary files).
///
/// With g channels per pass, the file is read k/g times and g buffers of 8·rows bytes are
/// touched for the first time once. Their costs per byte, measured on this project's machine
/// (6 interleaved f64 channels × 10^8 rows, 2026-11-26: the pass 0.24 s for 4.8 GB, the first
/// touch 0.29 s for 0.8 GB), put the best g at about k·√(0.14·size/8), so k·size/24 rounded up
/// is used: 2 of 6 f64 channels (1.18× faster than all 6 at once, a third of the memory), 1
/// for up to 12 channels of i16.
///
/// ```
/// use imunoise::source::group_size;
/// assert_eq!(group_size(6, 8, 1_000_000, usize::MAX), 2);
/// assert_eq!(group_size(6, 2, 1_000_000, usize::MAX), 1);
/// assert_eq!(group_size(6, 8, 1_000_000, 8_000_000), 1); // one buffer fits
/// assert_eq!(group_size(6, 8, 1_000_000, 7_999_999), 0); // none does
/// ```
pub fn group_size(k: usize, size: usize, rows: usize, budget: usize) -> usize {
    let fit = budget / rows.saturating_mul(8).max(1);
    (k * size).div_ceil(24).clamp(1, k.max(1)).min(fit)
}

/// The parallel decoding pass of [`decode_to_memory`] and [`for_channel_groups`]: `channels` of
/// the file written into `maps` (8·rows bytes each), in blocks of `per_block` rows.
fn decode_into(
    f: &std::fs::File,
    name: &str,
    layout: &BinaryLayout,
    channels: &[usize],
    rows: usize,
    per_block: usize,
    maps: &mut [memmap2::MmapMut],
) -> Result<()> {
    use rayon::prelude::*;
    use std::os::unix::fs::FileExt;
    let row = layout.row_bytes();
    // per block, its slice of every channel's map
    let mut per: Vec<Vec<&mut [u8]>> = Vec::new();
    let mut its: Vec<_> = maps
        .iter_mut()
        .map(|m| m.chunks_mut(8 * per_block))
        .collect();
    loop {
        let blk: Vec<&mut [u8]> = its.iter_mut().filter_map(Iterator::next).collect();
        if blk.is_empty() {
            break;
        }
        per.push(blk);
    }
    drop(its);
    let results: Vec<Result<()>> = per
        .into_par_iter()
        .enumerate()
        .map_init(Vec::new, |inb: &mut Vec<u8>, (b, outs)| {
            let r0 = b * per_block;
            let k = per_block.min(rows - r0);
            inb.resize(k * row, 0);
            f.read_exact_at(inb, (layout.header + r0 * row) as u64)
                .map_err(|e| Error::io(name, e))?;
            for (out, &c) in outs.into_iter().zip(channels) {
                decode_block(inb, r0, name, layout, c, out)?;
            }
            Ok(())
        })
        .collect();
    results.into_iter().collect::<Result<()>>()
}

/// Reads until `buf` is full or the input ends; returns the bytes read.
fn read_full(r: &mut dyn Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn decoding_matches_the_in_memory_reader() {
        let dir = tempfile::tempdir().unwrap();
        let vals: Vec<i32> = (0..3000).map(|i| (i * 7919) % 2001 - 1000).collect();
        let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let p = write(dir.path(), "x.i32", &bytes);
        let layout = BinaryLayout {
            scale: Some(1.0 / 131.0),
            ..BinaryLayout::new(BinaryType::I32, 3)
        };
        let s = decode_binary(&p, "x.i32", &layout, &[2, 0]).unwrap();
        let t = crate::io::parse_binary(&bytes, "x.i32", BinaryType::I32, 3).unwrap();
        let scaled =
            |c: usize| -> Vec<f64> { t.columns[c].iter().map(|v| v * (1.0 / 131.0)).collect() };
        assert_eq!(s[0].samples(), &scaled(2)[..]);
        assert_eq!(s[1].samples(), &scaled(0)[..]);
    }

    /// Channel groups (two f64 channels per pass, in a permuted selection; one i16 channel
    /// per pass; a file used in place; gzip) hand every selected channel once, in order, with
    /// the samples of [`decode_binary`]; a non-finite value in a later group is reported by
    /// row and channel after the earlier groups ran.
    #[test]
    fn channel_groups_equal_the_decoded_copies() {
        let dir = tempfile::tempdir().unwrap();
        // more rows than one decoding block, not a whole number of blocks
        let rows = 30_001;
        let k = 5;
        let vals: Vec<f64> = (0..k * rows)
            .map(|i| ((i * 7919) % 2001) as f64 * 0.25 - 250.0)
            .collect();
        let f64s: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let i16s: Vec<u8> = vals
            .iter()
            .flat_map(|v| (*v as i16).to_le_bytes())
            .collect();
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut gz, &f64s[..8 * rows]).unwrap();
        let cases = [
            (
                write(dir.path(), "five.f64", &f64s),
                BinaryLayout::new(BinaryType::F64, k),
                vec![4, 1, 3, 0, 2],
                2,
            ),
            (
                write(dir.path(), "five.i16", &i16s),
                BinaryLayout {
                    scale: Some(0.5),
                    ..BinaryLayout::new(BinaryType::I16, k)
                },
                vec![],
                1,
            ),
            (
                write(dir.path(), "one.f64", &f64s[..8 * rows]),
                BinaryLayout::new(BinaryType::F64, 1),
                vec![],
                1,
            ),
            (
                write(dir.path(), "one.f64.gz", &gz.finish().unwrap()),
                BinaryLayout::new(BinaryType::F64, 1),
                vec![],
                1,
            ),
        ];
        for (p, layout, sel, per_group) in cases {
            let want = decode_binary(&p, "x", &layout, &sel).unwrap();
            let mut got: Vec<Vec<f64>> = Vec::new();
            let mut sizes = Vec::new();
            for_channel_groups(&p, "x", &layout, &sel, |first, group| {
                assert_eq!(first, got.len(), "{}", p.display());
                sizes.push(group.len());
                got.extend(group.iter().map(|s| s.samples().to_vec()));
                Ok(())
            })
            .unwrap();
            assert_eq!(got.len(), want.len(), "{}", p.display());
            for (g, w) in got.iter().zip(&want) {
                assert_eq!(&g[..], w.samples(), "{}", p.display());
            }
            assert!(
                sizes.iter().all(|&n| n <= per_group),
                "{}: {sizes:?}",
                p.display()
            );
            assert_eq!(sizes[0], per_group.min(got.len()), "{}", p.display());
        }
        // an infinity in channel 2 (0-based), the second group of two: the first group runs
        let mut bad = vals.clone();
        bad[1234 * k + 2] = f64::INFINITY;
        let bytes: Vec<u8> = bad.iter().flat_map(|v| v.to_le_bytes()).collect();
        let p = write(dir.path(), "bad.f64", &bytes);
        let mut ran = 0;
        let e = for_channel_groups(
            &p,
            "bad.f64",
            &BinaryLayout::new(BinaryType::F64, k),
            &[],
            |_, g| {
                ran += g.len();
                Ok(())
            },
        )
        .unwrap_err()
        .to_string();
        assert_eq!(ran, 2);
        let want = decode_binary(&p, "bad.f64", &BinaryLayout::new(BinaryType::F64, k), &[])
            .unwrap_err()
            .to_string();
        assert_eq!(e, want);
        assert!(e.contains("row 1235 channel 3"), "{e}");
    }

    /// The decoded copies in temporary files (a budget of 0 bytes) equal those in memory, and
    /// a non-finite value is reported by row and channel there too.
    #[test]
    fn temporary_files_match_memory() {
        let dir = tempfile::tempdir().unwrap();
        // more rows than one decoding block (1 MiB of input), not a whole number of blocks
        let rows = 70_001;
        let vals: Vec<f32> = (0..3 * rows)
            .map(|i| ((i * 7919) % 2001) as f32 - 1000.5)
            .collect();
        let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let p = write(dir.path(), "x.f32", &bytes);
        let layout = BinaryLayout {
            scale: Some(0.25),
            ..BinaryLayout::new(BinaryType::F32, 3)
        };
        let mem = decode_file_within(&p, "x.f32", &layout, &[2, 0], usize::MAX).unwrap();
        let tmp = decode_file_within(&p, "x.f32", &layout, &[2, 0], 0).unwrap();
        assert!(matches!(mem[0].backing, Backing::Anon(_)));
        assert!(matches!(tmp[0].backing, Backing::File(..)));
        for (a, b) in mem.iter().zip(&tmp) {
            assert_eq!(a.samples(), b.samples());
        }
        let want: Vec<f64> = (0..rows)
            .map(|r| f64::from(vals[3 * r + 2]) * 0.25)
            .collect();
        assert_eq!(tmp[0].samples(), &want[..]);
        let mut bad = bytes.clone();
        bad[(3 * 50_000 + 1) * 4..(3 * 50_000 + 2) * 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let p = write(dir.path(), "bad.f32", &bad);
        let e = decode_file_within(&p, "bad.f32", &layout, &[1], 0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 50001 channel 2"), "{e}");
    }

    #[test]
    fn stride_header_and_errors() {
        let dir = tempfile::tempdir().unwrap();
        // 16-byte header, rows of one f32 and 4 padding bytes
        let mut bytes = vec![0xAAu8; 16];
        for v in [1.0f32, 2.0, 3.0] {
            bytes.extend_from_slice(&v.to_le_bytes());
            bytes.extend_from_slice(&[0xFF; 4]);
        }
        let p = write(dir.path(), "x.bin", &bytes);
        let layout = BinaryLayout {
            stride: Some(8),
            header: 16,
            ..BinaryLayout::new(BinaryType::F32, 1)
        };
        let s = decode_binary(&p, "x.bin", &layout, &[]).unwrap();
        assert_eq!(s[0].samples(), &[1.0, 2.0, 3.0]);
        // a partial row
        let p = write(dir.path(), "y.f64", &[0u8; 12]);
        let e = decode_binary(&p, "y.f64", &BinaryLayout::new(BinaryType::F64, 1), &[]);
        assert!(e.unwrap_err().to_string().contains("4 bytes left over"));
        // a NaN, named by row and channel
        let mut b: Vec<u8> = Vec::new();
        for v in [1.0f64, 2.0, f64::NAN, 4.0] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        let p = write(dir.path(), "z.f64", &b);
        let e = decode_binary(&p, "z.f64", &BinaryLayout::new(BinaryType::F64, 2), &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("row 2 channel 1"), "{e}");
        // and through the sequential decoder (gzip): an infinity after the scale, in a later
        // read block, named by row and channel
        use flate2::write::GzEncoder;
        let rows = 300_000; // more than one block of the sequential reader (4 MiB)
        let raw: Vec<u8> = (0..rows)
            .flat_map(|r| {
                let bad = r == 250_000;
                [1.0f64, if bad { f64::MAX } else { 2.0 }, 3.0]
            })
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let mut gz = GzEncoder::new(Vec::new(), flate2::Compression::fast());
        gz.write_all(&raw).unwrap();
        let p = write(dir.path(), "w.f64.gz", &gz.finish().unwrap());
        let layout = BinaryLayout {
            scale: Some(10.0),
            ..BinaryLayout::new(BinaryType::F64, 3)
        };
        let e = decode_binary(&p, "w.f64.gz", &layout, &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains("inf in row 250001 channel 2"), "{e}");
    }

    #[test]
    fn gzip_is_decoded_and_release_keeps_values() {
        use flate2::write::GzEncoder;
        let dir = tempfile::tempdir().unwrap();
        let vals: Vec<f64> = (0..100_000).map(|i| (i as f64).sin()).collect();
        let raw: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let mut gz = GzEncoder::new(Vec::new(), flate2::Compression::fast());
        gz.write_all(&raw).unwrap();
        let p = write(dir.path(), "x.f64.gz", &gz.finish().unwrap());
        let s = decode_binary(&p, "x.f64.gz", &BinaryLayout::new(BinaryType::F64, 1), &[]).unwrap();
        assert_eq!(s[0].samples(), &vals[..]);
        // in place, released, read again: the same values
        let p = write(dir.path(), "x.f64", &raw);
        let s = decode_binary(&p, "x.f64", &BinaryLayout::new(BinaryType::F64, 1), &[]).unwrap();
        s[0].release(0, vals.len());
        assert_eq!(s[0].samples(), &vals[..]);
    }
}
