//! Reading IMU logs: delimited text (CSV, TSV, whitespace) with or without a header,
//! gzip-compressed transparently, and raw little-endian binary, memory-mapped.
//!
//! Every problem is an [`Error`] that names the file, and for a bad cell its line and
//! column; nothing is silently skipped.
//!
//! # Text format
//! - The delimiter is taken from the first row: `,` if it has one, else a tab, else runs
//!   of spaces/tabs. Spaces around cells are allowed; `\r\n` line ends too.
//! - Lines starting with `#` before the first row are comments. A UTF-8 BOM is ignored.
//! - The first row is a header when none of its cells is a number; its names become the
//!   channel names (otherwise `col1`, `col2`, …).
//! - Every row must have as many cells as the first; blank lines are allowed only at the
//!   end of the file. NaN and infinities are errors.
//!
//! # Speed
//! The parser is hand-written over the bytes of the whole file (memory-mapped when not
//! compressed) rather than built on the `csv` crate: a numeric log needs no quoting rules,
//! and parsing each cell in place with `fast-float2` (Eisel–Lemire, correctly rounded)
//! avoids building a record per row. Large inputs are cut at line ends into chunks parsed
//! in parallel (rayon). Line and column of an error are computed only when one occurs.

use crate::error::{Error, Result};
use rayon::prelude::*;
use std::io::Read;
use std::path::Path;

/// The element type of raw binary input (`--binary`).
///
/// ```
/// use imunoise::io::BinaryType;
/// // the names `--binary` takes
/// assert_eq!("f32".parse::<BinaryType>(), Ok(BinaryType::F32));
/// assert_eq!("int16".parse::<BinaryType>(), Ok(BinaryType::I16));
/// assert!("u8".parse::<BinaryType>().is_err());
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryType {
    /// Little-endian IEEE 754 double.
    F64,
    /// Little-endian IEEE 754 single.
    F32,
    /// Little-endian two's-complement 16-bit integer (counts).
    I16,
    /// Little-endian two's-complement 32-bit integer (counts).
    I32,
}

impl BinaryType {
    /// Bytes per value.
    ///
    /// ```
    /// use imunoise::io::BinaryType;
    /// assert_eq!(BinaryType::F64.size(), std::mem::size_of::<f64>());
    /// assert_eq!(BinaryType::I16.size(), std::mem::size_of::<i16>());
    /// ```
    pub fn size(self) -> usize {
        match self {
            BinaryType::F64 => 8,
            BinaryType::F32 | BinaryType::I32 => 4,
            BinaryType::I16 => 2,
        }
    }
    /// Reads one little-endian value from exactly `size()` bytes.
    fn read(self, b: &[u8]) -> f64 {
        match self {
            BinaryType::F64 => f64::from_le_bytes(b.try_into().expect("8 bytes")),
            BinaryType::F32 => f32::from_le_bytes(b.try_into().expect("4 bytes")) as f64,
            BinaryType::I16 => i16::from_le_bytes(b.try_into().expect("2 bytes")) as f64,
            BinaryType::I32 => i32::from_le_bytes(b.try_into().expect("4 bytes")) as f64,
        }
    }
}

impl std::str::FromStr for BinaryType {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "f64" | "float64" | "double" => Ok(BinaryType::F64),
            "f32" | "float32" | "float" => Ok(BinaryType::F32),
            "i16" | "int16" => Ok(BinaryType::I16),
            "i32" | "int32" => Ok(BinaryType::I32),
            _ => Err(format!(
                "unknown binary type {s:?}; expected f64, f32, i16 or i32"
            )),
        }
    }
}

/// Which columns to keep (`--columns`): names or 1-based indices, and index ranges `a-b`.
///
/// ```
/// use imunoise::io::{ColumnSpec, parse_columns, resolve_columns};
/// let spec = vec![ColumnSpec::Name("acc_z".into()), ColumnSpec::Range(1, 2)];
/// let names: Vec<String> = ["gyro_x", "gyro_y", "acc_z"].map(String::from).to_vec();
/// assert_eq!(resolve_columns(&spec, &names)?, [2, 0, 1]);
/// assert_eq!(parse_columns("acc_z,1-2")?, spec);
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ColumnSpec {
    /// A 1-based column index.
    Index(usize),
    /// An inclusive 1-based index range.
    Range(usize, usize),
    /// A header name.
    Name(String),
}

/// Parses a `--columns` list such as `gyro_x,gyro_y` or `1,3-5`.
///
/// ```
/// use imunoise::io::{ColumnSpec, parse_columns};
/// assert_eq!(
///     parse_columns("gyro_x, 3, 4-6")?,
///     [ColumnSpec::Name("gyro_x".into()), ColumnSpec::Index(3), ColumnSpec::Range(4, 6)]
/// );
/// assert!(parse_columns("0").is_err()); // indices count from 1
/// assert!(parse_columns("5-2").is_err());
/// assert!(parse_columns("a,,b").is_err());
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn parse_columns(list: &str) -> Result<Vec<ColumnSpec>> {
    let mut out = Vec::new();
    for item in list.split(',').map(str::trim) {
        if item.is_empty() {
            return Err(Error::Usage(format!("--columns {list:?}: empty item")));
        }
        if let Ok(i) = item.parse::<usize>() {
            if i == 0 {
                return Err(Error::Usage("--columns: indices count from 1".to_string()));
            }
            out.push(ColumnSpec::Index(i));
        } else if let Some((a, b)) = item.split_once('-')
            && let (Ok(a), Ok(b)) = (a.trim().parse::<usize>(), b.trim().parse::<usize>())
        {
            if a == 0 || b < a {
                return Err(Error::Usage(format!(
                    "--columns: bad range {item:?} (indices count from 1, a ≤ b)"
                )));
            }
            out.push(ColumnSpec::Range(a, b));
        } else {
            out.push(ColumnSpec::Name(item.to_string()));
        }
    }
    Ok(out)
}

/// How to read an input file.
///
/// ```
/// use imunoise::io::{BinaryType, ReadOptions, parse_columns, read_bytes};
/// // the second and first columns, times 2, renamed
/// let opts = ReadOptions {
///     columns: Some(parse_columns("b,a")?),
///     scale: Some(2.0),
///     names: Some(vec!["y".into(), "x".into()]),
///     ..Default::default()
/// };
/// let t = read_bytes(b"a,b\n1,2\n3,4\n", "mem.csv", &opts)?;
/// assert_eq!(t.names, ["y", "x"]);
/// assert_eq!(t.columns, [vec![4.0, 8.0], vec![2.0, 6.0]]);
/// // raw binary: two i16 channels per row
/// let opts = ReadOptions {
///     binary: Some(BinaryType::I16),
///     channels: Some(2),
///     ..Default::default()
/// };
/// let bytes: Vec<u8> = [1i16, -1, 2, -2].iter().flat_map(|v| v.to_le_bytes()).collect();
/// let t = read_bytes(&bytes, "mem.i16", &opts)?;
/// assert_eq!(t.columns, [vec![1.0, 2.0], vec![-1.0, -2.0]]);
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, Default)]
pub struct ReadOptions {
    /// Raw binary element type; `None` for text.
    pub binary: Option<BinaryType>,
    /// Channels per row for binary input (default 1).
    pub channels: Option<usize>,
    /// Factor applied to every value (e.g. counts → physical units); default 1.
    pub scale: Option<f64>,
    /// Columns to keep, in the order given; `None` keeps all.
    pub columns: Option<Vec<ColumnSpec>>,
    /// Channel names overriding the header (after column selection).
    pub names: Option<Vec<String>>,
}

/// One channel's samples: owned, or held by a [`crate::mapped::MappedSamples`] (a raw f64 file
/// used in place, or the copy its decoder made), read through `&[f64]` either way.
///
/// ```
/// use imunoise::io::Column;
/// let mut c = Column::from(vec![1.0, 2.0]);
/// assert_eq!(&c[..], &[1.0, 2.0]);
/// c.to_mut().push(3.0);
/// assert_eq!(c, vec![1.0, 2.0, 3.0]);
/// ```
#[derive(Clone)]
pub enum Column {
    /// Samples in a vector.
    Owned(Vec<f64>),
    /// Samples in a map (shared: a clone does not copy them).
    Mapped(std::sync::Arc<crate::mapped::MappedSamples>),
}

impl Column {
    /// The samples as a vector to change, copying mapped ones first.
    ///
    /// ```
    /// use imunoise::io::Column;
    /// use imunoise::source::MappedSamples;
    /// let dir = tempfile::tempdir()?;
    /// let p = dir.path().join("x.f64");
    /// let bytes: Vec<u8> = [1.0f64, 2.0].iter().flat_map(|v| v.to_le_bytes()).collect();
    /// std::fs::write(&p, bytes)?;
    /// let mut c = Column::Mapped(std::sync::Arc::new(MappedSamples::map_f64(&p, "x.f64", 0)?));
    /// c.to_mut()[0] = 5.0;
    /// assert!(matches!(c, Column::Owned(_))); // a copy was made to change...
    /// assert_eq!(c, vec![5.0, 2.0]);
    /// assert_eq!(std::fs::read(&p)?[..8], 1.0f64.to_le_bytes()); // ...the file is untouched
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn to_mut(&mut self) -> &mut Vec<f64> {
        if let Column::Mapped(m) = self {
            *self = Column::Owned(avar::SampleSource::samples(&**m).to_vec());
        }
        match self {
            Column::Owned(v) => v,
            Column::Mapped(_) => unreachable!("made owned above"),
        }
    }

    /// The samples as a vector (a copy of mapped ones).
    ///
    /// ```
    /// use imunoise::io::Column;
    /// use imunoise::source::MappedSamples;
    /// assert_eq!(Column::from(vec![1.0, 2.0]).into_vec(), [1.0, 2.0]);
    /// let dir = tempfile::tempdir()?;
    /// let p = dir.path().join("x.f64");
    /// let bytes: Vec<u8> = [3.0f64, 4.0].iter().flat_map(|v| v.to_le_bytes()).collect();
    /// std::fs::write(&p, bytes)?;
    /// let c = Column::Mapped(std::sync::Arc::new(MappedSamples::map_f64(&p, "x.f64", 0)?));
    /// assert_eq!(c.into_vec(), [3.0, 4.0]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn into_vec(self) -> Vec<f64> {
        match self {
            Column::Owned(v) => v,
            Column::Mapped(m) => avar::SampleSource::samples(&*m).to_vec(),
        }
    }
}

impl std::ops::Deref for Column {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        match self {
            Column::Owned(v) => v,
            Column::Mapped(m) => avar::SampleSource::samples(&**m),
        }
    }
}

impl From<Vec<f64>> for Column {
    fn from(v: Vec<f64>) -> Self {
        Column::Owned(v)
    }
}

impl std::fmt::Debug for Column {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl PartialEq for Column {
    fn eq(&self, other: &Column) -> bool {
        **self == **other
    }
}

impl PartialEq<Vec<f64>> for Column {
    fn eq(&self, other: &Vec<f64>) -> bool {
        **self == other[..]
    }
}

/// A table of channels read from a file: one column of samples per channel.
///
/// ```
/// use imunoise::io::Table;
/// let t = Table {
///     file: "<array>".into(),
///     names: vec!["gx".into(), "gy".into()],
///     columns: vec![vec![0.1, 0.2, 0.3].into(), vec![1.0, 2.0, 3.0].into()],
///     rate_hz: Some(100.0),
///     timing: None,
///     topic: None,
/// };
/// assert_eq!(t.n_rows(), 3);
/// assert_eq!(t.columns[1][2], 3.0);
/// // what a CSV of the same values reads to, but for the file name and the rate
/// let text = b"gx,gy\n0.1,1\n0.2,2\n0.3,3\n";
/// let csv = imunoise::io::read_bytes(text, "<array>", &Default::default())?;
/// assert_eq!(Table { rate_hz: Some(100.0), ..csv }, t);
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The file as the user named it (for messages).
    pub file: String,
    /// Channel names (header names, or `col1`, … / `ch1`, …).
    pub names: Vec<String>,
    /// The samples, one column per channel, all of the same length.
    pub columns: Vec<Column>,
    /// The sampling rate (Hz) when known: from `--rate`, or from the time stamps of a log
    /// (see [`crate::logs::timing`]). `None` for text and binary read without `--rate`.
    pub rate_hz: Option<f64>,
    /// What the time stamps said (logs, and text with `--time-column`).
    pub timing: Option<crate::logs::Timing>,
    /// The topic (or log message) the samples come from, for logs.
    pub topic: Option<String>,
}

impl Table {
    /// Samples per channel.
    ///
    /// ```
    /// let t = imunoise::io::read_bytes(b"a,b\n1,2\n3,4\n5,6\n", "mem.csv", &Default::default())?;
    /// assert_eq!(t.n_rows(), 3);
    /// assert_eq!(t.n_rows(), t.columns[1].len());
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn n_rows(&self) -> usize {
        self.columns.first().map_or(0, |c| c.len())
    }

    /// The sampling rate (Hz), or a usage error saying that `--rate` is needed.
    ///
    /// ```
    /// let mut t = imunoise::io::read_bytes(b"a\n1\n2\n", "mem.csv", &Default::default())?;
    /// // text has no time stamps: no rate until one is given
    /// let e = t.rate().unwrap_err();
    /// assert!(e.to_string().starts_with("mem.csv: --rate is required"));
    /// t.rate_hz = Some(400.0);
    /// assert_eq!(t.rate()?, 400.0);
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn rate(&self) -> Result<f64> {
        self.rate_hz.ok_or_else(|| rate_required(&self.file))
    }
}

/// The usage error of an input of `file` without time stamps read without `--rate`.
pub(crate) fn rate_required(file: &str) -> Error {
    Error::Usage(format!(
        "{file}: --rate is required (the file has no time stamps; for text with a time column \
         give --time-column NAME)"
    ))
}

/// The bytes of a file: memory-mapped, or decompressed into memory for gzip.
enum Bytes {
    Mapped(memmap2::Mmap),
    Owned(Vec<u8>),
}

impl std::ops::Deref for Bytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        match self {
            Bytes::Mapped(m) => m,
            Bytes::Owned(v) => v,
        }
    }
}

/// What kind of thing a path names, as far as reading it goes.
enum Source {
    /// A regular file: memory-mapped.
    File(std::fs::File),
    /// A pipe, a FIFO or standard input (`-`): read once into memory.
    Stream(Box<dyn Read>),
}

/// Opens `path` for reading, refusing directories and devices with a message in plain words.
fn open(path: &Path, file: &str) -> Result<Source> {
    if path.as_os_str() == "-" {
        return Ok(Source::Stream(Box::new(std::io::stdin())));
    }
    let md = std::fs::metadata(path).map_err(|e| Error::io(file, e))?;
    let what = |kind: &str| Error::File {
        file: file.to_string(),
        message: format!("is {kind}, not a log file; name a file to read"),
    };
    if md.is_dir() {
        return Err(what("a directory"));
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let ft = md.file_type();
        if ft.is_block_device() || ft.is_char_device() {
            return Err(what("a device"));
        }
        if ft.is_fifo() || ft.is_socket() {
            let f = std::fs::File::open(path).map_err(|e| Error::io(file, e))?;
            return Ok(Source::Stream(Box::new(f)));
        }
    }
    if !md.is_file() {
        return Err(what("neither a regular file nor a pipe"));
    }
    Ok(Source::File(
        std::fs::File::open(path).map_err(|e| Error::io(file, e))?,
    ))
}

/// Opens `path` and memory-maps it (or reads a pipe or standard input into memory).
fn load(path: &Path, file: &str) -> Result<Bytes> {
    let f = match open(path, file)? {
        Source::File(f) => f,
        Source::Stream(mut r) => {
            let mut buf = Vec::new();
            r.read_to_end(&mut buf).map_err(|e| Error::io(file, e))?;
            return Ok(Bytes::Owned(buf));
        }
    };
    let len = f.metadata().map_err(|e| Error::io(file, e))?.len();
    if len == 0 {
        return Err(Error::File {
            file: file.to_string(),
            message: "the file is empty".to_string(),
        });
    }
    // SAFETY: the map is read-only and private to this process; as with any mmap, the
    // file must not be truncated by another process while it is read (documented in
    // the command's help).
    let map = unsafe { memmap2::Mmap::map(&f) }.map_err(|e| Error::io(file, e))?;
    Ok(Bytes::Mapped(map))
}

/// The largest factor by which deflate can expand its input (RFC 1951: a 258-byte match in
/// about 2 bits, i.e. 1032:1).
const MAX_DEFLATE_RATIO: usize = 1032;

/// Decompresses `map` when it starts with the gzip magic bytes (whatever the file's name);
/// errors on empty input.
fn gunzip<'a>(map: &'a [u8], file: &str) -> Result<std::borrow::Cow<'a, [u8]>> {
    if map.is_empty() {
        return Err(Error::File {
            file: file.to_string(),
            message: "the input is empty".to_string(),
        });
    }
    if map.len() >= 2 && map[0] == 0x1f && map[1] == 0x8b {
        // The gzip trailer holds the uncompressed size mod 2^32: a capacity hint only, and
        // one that any file can forge (4 GiB in 30 bytes). Deflate expands at most 1032:1,
        // so the hint is capped by that bound on what the input can decompress to.
        let hint = if map.len() >= 4 {
            let t = &map[map.len() - 4..];
            u32::from_le_bytes([t[0], t[1], t[2], t[3]]) as usize
        } else {
            0
        };
        let hint = hint.min(map.len().saturating_mul(MAX_DEFLATE_RATIO));
        let mut out = Vec::with_capacity(hint.max(map.len()));
        flate2::read::MultiGzDecoder::new(map)
            .read_to_end(&mut out)
            .map_err(|e| Error::File {
                file: file.to_string(),
                message: format!("cannot decompress gzip data: {e}"),
            })?;
        if out.is_empty() {
            return Err(Error::File {
                file: file.to_string(),
                message: "the file is empty (after decompression)".to_string(),
            });
        }
        Ok(std::borrow::Cow::Owned(out))
    } else {
        Ok(std::borrow::Cow::Borrowed(map))
    }
}

/// Reads a file into a [`Table`] as `opts` says. `file` is the name used in messages.
///
/// ```
/// use imunoise::io::{ReadOptions, read_bytes, read_table};
/// use std::io::Write;
/// let dir = tempfile::tempdir()?;
/// let text = b"gx,gy\n1,2\n3,4\n";
/// let p = dir.path().join("x.csv");
/// std::fs::write(&p, text)?;
/// let t = read_table(&p, &ReadOptions::default())?;
/// assert_eq!(t.file, p.display().to_string());
/// // the same table as from the bytes
/// assert_eq!(t, read_bytes(text, &t.file, &ReadOptions::default())?);
/// // gzip is decompressed transparently
/// let gz = dir.path().join("x.csv.gz");
/// let mut enc = flate2::write::GzEncoder::new(std::fs::File::create(&gz)?, Default::default());
/// enc.write_all(text)?;
/// enc.finish()?;
/// assert_eq!(read_table(&gz, &ReadOptions::default())?.columns, t.columns);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn read_table(path: &Path, opts: &ReadOptions) -> Result<Table> {
    let file = path.display().to_string();
    let bytes = load(path, &file)?;
    read_bytes(&bytes, &file, opts)
}

/// Reads the bytes of a log (text, or raw binary with `opts.binary`; gzip-compressed data are
/// decompressed first) into a [`Table`] as `opts` says. `file` is the name used in messages.
/// Any bytes give either a table of finite values or an error naming `file` (and the line and
/// column where there is one): never a panic.
///
/// ```
/// use imunoise::io::{read_bytes, ReadOptions};
/// let t = read_bytes(b"gyro_x,gyro_y\n1,2\n3,4\n", "mem.csv", &ReadOptions::default()).unwrap();
/// assert_eq!(t.columns, vec![vec![1.0, 3.0], vec![2.0, 4.0]]);
/// let e = read_bytes(b"x\n1\nabc\n", "mem.csv", &ReadOptions::default()).unwrap_err();
/// assert!(e.to_string().starts_with("mem.csv:3:1:"));
/// ```
pub fn read_bytes(bytes: &[u8], file: &str, opts: &ReadOptions) -> Result<Table> {
    // Raw binary samples can begin with the gzip magic bytes by chance (f64 1.19e117 does):
    // binary input not named *.gz is read raw when it does not decompress.
    let bytes = match gunzip(bytes, file) {
        Err(_) if opts.binary.is_some() && !file.ends_with(".gz") => {
            std::borrow::Cow::Borrowed(bytes)
        }
        r => r?,
    };
    let file = file.to_string();
    let mut table = match opts.binary {
        Some(kind) => parse_binary(&bytes, &file, kind, opts.channels.unwrap_or(1))?,
        None => {
            if opts.channels.is_some() {
                return Err(Error::Usage(
                    "--channels is for binary input; text input has its columns".to_string(),
                ));
            }
            parse_text(&bytes, &file, opts.columns.as_deref())?
        }
    };
    if opts.binary.is_some()
        && let Some(spec) = &opts.columns
    {
        let idx = resolve_columns(spec, &table.names)?;
        table.names = idx.iter().map(|&i| table.names[i].clone()).collect();
        let mut cols: Vec<Option<Column>> = table.columns.into_iter().map(Some).collect();
        table.columns = idx
            .iter()
            .map(|&i| cols[i].take().unwrap_or_else(|| Vec::new().into()))
            .collect();
        if table.columns.iter().any(|c| c.is_empty()) && table.n_rows() > 0 {
            return Err(Error::Usage(
                "--columns names the same column twice".to_string(),
            ));
        }
    }
    if let Some(scale) = opts.scale {
        if !(scale.is_finite() && scale != 0.0) {
            return Err(Error::Usage(format!(
                "--scale must be finite and non-zero, got {scale}"
            )));
        }
        for (k, c) in table.columns.iter_mut().enumerate() {
            c.to_mut().iter_mut().for_each(|v| *v *= scale);
            // a scale that takes a value beyond f64 is named, not turned into inf/0 silently
            if let Some(row) = c.iter().position(|v| !v.is_finite()) {
                return Err(Error::Usage(format!(
                    "--scale {scale:e} takes the value of channel {:?} at row {} beyond the range of f64",
                    table.names[k],
                    row + 1
                )));
            }
        }
    }
    if let Some(names) = &opts.names {
        if names.len() != table.names.len() {
            return Err(Error::Usage(format!(
                "--names gives {} names for {} channels",
                names.len(),
                table.names.len()
            )));
        }
        table.names = names.clone();
    }
    Ok(table)
}

/// Resolves a column selection against the header names; returns 0-based indices.
///
/// ```
/// use imunoise::io::{parse_columns, resolve_columns};
/// let names: Vec<String> = ["t", "gx", "gy", "gz"].map(String::from).to_vec();
/// assert_eq!(resolve_columns(&parse_columns("gz,2-3")?, &names)?, [3, 1, 2]);
/// assert!(resolve_columns(&parse_columns("5")?, &names).is_err()); // no such column
/// assert!(resolve_columns(&parse_columns("gx,2")?, &names).is_err()); // column 2 twice
/// assert!(resolve_columns(&parse_columns("ax")?, &names).is_err());
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn resolve_columns(spec: &[ColumnSpec], names: &[String]) -> Result<Vec<usize>> {
    let n = names.len();
    let mut out = Vec::new();
    let check = |i: usize| -> Result<usize> {
        if i == 0 || i > n {
            Err(Error::Usage(format!(
                "--columns: column {i} does not exist (the file has {n} columns)"
            )))
        } else {
            Ok(i - 1)
        }
    };
    for s in spec {
        match s {
            ColumnSpec::Index(i) => out.push(check(*i)?),
            ColumnSpec::Range(a, b) => {
                for i in *a..=*b {
                    out.push(check(i)?);
                }
            }
            ColumnSpec::Name(name) => match names.iter().position(|h| h == name) {
                Some(i) => out.push(i),
                None => {
                    return Err(Error::Usage(format!(
                        "--columns: no column named {name:?}; the columns are {}",
                        names.join(", ")
                    )));
                }
            },
        }
    }
    let mut seen = vec![false; n];
    for &i in &out {
        if std::mem::replace(&mut seen[i], true) {
            return Err(Error::Usage(format!(
                "--columns names column {} ({:?}) twice",
                i + 1,
                names[i]
            )));
        }
    }
    Ok(out)
}

/// Parses raw little-endian binary, row-major with `channels` values per row.
///
/// ```
/// use imunoise::io::{BinaryType, parse_binary};
/// let bytes: Vec<u8> = [1.5f32, -2.0, 3.0, 4.25].iter().flat_map(|v| v.to_le_bytes()).collect();
/// let t = parse_binary(&bytes, "x.f32", BinaryType::F32, 2)?;
/// assert_eq!(t.names, ["ch1", "ch2"]);
/// assert_eq!(t.columns, [vec![1.5, 3.0], vec![-2.0, 4.25]]);
/// // 16 bytes are not a whole number of 12-byte rows
/// assert!(parse_binary(&bytes, "x.f32", BinaryType::F32, 3).is_err());
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn parse_binary(bytes: &[u8], file: &str, kind: BinaryType, channels: usize) -> Result<Table> {
    if channels == 0 {
        return Err(Error::Usage("--channels must be at least 1".to_string()));
    }
    let row = kind.size() * channels;
    if bytes.is_empty() {
        return Err(Error::File {
            file: file.to_string(),
            message: "the file is empty".to_string(),
        });
    }
    if !bytes.len().is_multiple_of(row) {
        return Err(Error::File {
            file: file.to_string(),
            message: format!(
                "size {} bytes is not a whole number of rows of {channels} × {} bytes \
                 ({} bytes left over): wrong --binary type or --channels?",
                bytes.len(),
                kind.size(),
                bytes.len() % row
            ),
        });
    }
    let n = bytes.len() / row;
    let mut columns: Vec<Vec<f64>> = (0..channels).map(|_| Vec::with_capacity(n)).collect();
    for (r, chunk) in bytes.chunks_exact(row).enumerate() {
        for (c, col) in columns.iter_mut().enumerate() {
            let v = kind.read(&chunk[c * kind.size()..(c + 1) * kind.size()]);
            if !v.is_finite() {
                return Err(Error::Located {
                    file: file.to_string(),
                    line: r + 1,
                    column: c + 1,
                    message: format!(
                        "{v} in row {} channel {} (byte offset {}): values must be finite",
                        r + 1,
                        c + 1,
                        r * row + c * kind.size()
                    ),
                });
            }
            col.push(v);
        }
    }
    Ok(Table {
        file: file.to_string(),
        names: (1..=channels).map(|c| format!("ch{c}")).collect(),
        columns: columns.into_iter().map(Column::from).collect(),
        rate_hz: None,
        timing: None,
        topic: None,
    })
}

/// How cells are separated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Delim {
    /// A single byte (`,` or tab), with optional spaces around cells.
    Byte(u8),
    /// Runs of spaces and tabs.
    Whitespace,
}

/// What went wrong at a byte offset (line and column are computed afterwards).
#[derive(Debug)]
enum Fault {
    NotANumber { start: usize, end: usize },
    NonFinite { start: usize, end: usize },
    Ragged { line_start: usize, at: usize },
    BlankLine { at: usize },
}

impl Fault {
    fn offset(&self) -> usize {
        match *self {
            Fault::NotANumber { start, .. } | Fault::NonFinite { start, .. } => start,
            Fault::Ragged { at, .. } | Fault::BlankLine { at } => at,
        }
    }
}

fn is_eol(b: u8) -> bool {
    b == b'\n' || b == b'\r'
}

/// End of the cell starting at `p`: the next delimiter or line end.
fn cell_end(bytes: &[u8], mut p: usize, delim: Delim) -> usize {
    while p < bytes.len() {
        let b = bytes[p];
        let stop = match delim {
            Delim::Byte(d) => b == d || is_eol(b),
            Delim::Whitespace => b == b' ' || b == b'\t' || is_eol(b),
        };
        if stop {
            break;
        }
        p += 1;
    }
    p
}

/// Skips spaces (and tabs unless the tab is the delimiter).
#[inline]
fn skip_blank(bytes: &[u8], mut p: usize, delim: Delim) -> usize {
    while p < bytes.len()
        && (bytes[p] == b' ' || (bytes[p] == b'\t' && delim != Delim::Byte(b'\t')))
    {
        p += 1;
    }
    p
}

/// Parses the rows in `bytes[start..end]` (which begins at a line start) into one vector
/// per selected column. `keep[c]` tells whether column `c` is parsed; `ncols` cells are
/// expected on every row.
fn parse_rows(
    bytes: &[u8],
    start: usize,
    end: usize,
    delim: Delim,
    keep: &[bool],
    rows_hint: usize,
) -> std::result::Result<Vec<Vec<f64>>, Fault> {
    let ncols = keep.len();
    let nkeep = keep.iter().filter(|&&k| k).count();
    let mut out: Vec<Vec<f64>> = (0..nkeep).map(|_| Vec::with_capacity(rows_hint)).collect();
    let data = &bytes[..end];
    let mut p = start;
    while p < end {
        let line_start = p;
        // A blank line: fine at the end of the input, an error before data.
        let q = skip_blank(data, p, Delim::Whitespace);
        if q >= end || is_eol(data[q]) {
            let mut r = q;
            while r < bytes.len() && (is_eol(bytes[r]) || bytes[r] == b' ' || bytes[r] == b'\t') {
                r += 1;
            }
            if r >= bytes.len() {
                break; // only blank lines remain in the file
            }
            return Err(Fault::BlankLine { at: line_start });
        }
        let mut k = 0;
        for (c, &want) in keep.iter().enumerate() {
            p = skip_blank(data, p, delim);
            if p >= end || is_eol(data[p]) || (matches!(delim, Delim::Byte(d) if data[p] == d)) {
                if p < end && !is_eol(data[p]) && c + 1 < ncols {
                    // An empty cell between two delimiters.
                    return Err(Fault::NotANumber { start: p, end: p });
                }
                return Err(Fault::Ragged { line_start, at: p });
            }
            let cell = p;
            if want {
                match fast_float2::parse_partial::<f64, _>(&data[p..]) {
                    Ok((v, used)) => {
                        p += used;
                        // The number must fill the cell.
                        let after = skip_blank(data, p, delim);
                        let ok = after >= end
                            || is_eol(data[after])
                            || match delim {
                                Delim::Byte(d) => data[after] == d,
                                Delim::Whitespace => after > p,
                            };
                        if !ok {
                            return Err(Fault::NotANumber {
                                start: cell,
                                end: cell_end(data, p, delim),
                            });
                        }
                        if !v.is_finite() {
                            return Err(Fault::NonFinite {
                                start: cell,
                                end: p,
                            });
                        }
                        out[k].push(v);
                        k += 1;
                    }
                    Err(_) => {
                        return Err(Fault::NotANumber {
                            start: cell,
                            end: cell_end(data, p, delim),
                        });
                    }
                }
            } else {
                p = cell_end(data, p, delim);
            }
            p = skip_blank(data, p, delim);
            let last = c + 1 == ncols;
            if p >= end || is_eol(data[p]) {
                if !last {
                    return Err(Fault::Ragged { line_start, at: p });
                }
            } else if last {
                // More cells than the first row.
                return Err(Fault::Ragged { line_start, at: p });
            } else if let Delim::Byte(d) = delim {
                if data[p] != d {
                    return Err(Fault::NotANumber {
                        start: cell,
                        end: cell_end(data, p, delim),
                    });
                }
                p += 1;
            }
        }
        // Line end: "\n", "\r\n" or a lone "\r".
        if p < end && data[p] == b'\r' {
            p += 1;
        }
        if p < end && data[p] == b'\n' {
            p += 1;
        }
    }
    Ok(out)
}

/// Line (from 1), column (characters, from 1) and the line's start for a byte offset.
fn locate(bytes: &[u8], offset: usize) -> (usize, usize, usize) {
    let offset = offset.min(bytes.len());
    let before = &bytes[..offset];
    let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let column = 1 + String::from_utf8_lossy(&bytes[line_start..offset])
        .chars()
        .count();
    (line, column, line_start)
}

/// Counts the cells of the line starting at `line_start`.
fn count_cells(bytes: &[u8], line_start: usize, delim: Delim) -> usize {
    let end = bytes[line_start..]
        .iter()
        .position(|&b| is_eol(b))
        .map_or(bytes.len(), |i| line_start + i);
    let line = &bytes[line_start..end];
    match delim {
        Delim::Byte(d) => line.iter().filter(|&&b| b == d).count() + 1,
        Delim::Whitespace => line
            .split(|&b| b == b' ' || b == b'\t')
            .filter(|s| !s.is_empty())
            .count(),
    }
}

fn fault_to_error(bytes: &[u8], file: &str, fault: Fault, ncols: usize, delim: Delim) -> Error {
    let (line, column, _) = locate(bytes, fault.offset());
    let text = |a: usize, b: usize| String::from_utf8_lossy(&bytes[a..b.max(a)]).into_owned();
    let message = match fault {
        Fault::NotANumber { start, end } if start == end => "empty cell".to_string(),
        Fault::NotANumber { start, end } => format!("not a number: {:?}", text(start, end)),
        Fault::NonFinite { start, end } => format!(
            "{} is not a finite number (NaN and infinities are not allowed)",
            text(start, end)
        ),
        Fault::Ragged { line_start, .. } => format!(
            "ragged row: {} cells, but the first row has {ncols}",
            count_cells(bytes, line_start, delim)
        ),
        Fault::BlankLine { .. } => "blank line before the end of the data".to_string(),
    };
    Error::Located {
        file: file.to_string(),
        line,
        column,
        message,
    }
}

/// Splits the first row into cells (text, byte offset).
fn split_row(line: &[u8], base: usize, delim: Delim) -> Vec<(String, usize)> {
    let mut cells = Vec::new();
    match delim {
        Delim::Byte(d) => {
            let mut s = 0;
            for (i, &b) in line
                .iter()
                .enumerate()
                .chain(std::iter::once((line.len(), &d)))
            {
                if b == d {
                    let raw = &line[s..i];
                    let lead = raw.iter().take_while(|&&c| c == b' ').count();
                    let t = String::from_utf8_lossy(raw).trim().to_string();
                    cells.push((t, base + s + lead));
                    s = i + 1;
                }
            }
        }
        Delim::Whitespace => {
            let mut i = 0;
            while i < line.len() {
                while i < line.len() && (line[i] == b' ' || line[i] == b'\t') {
                    i += 1;
                }
                let s = i;
                while i < line.len() && line[i] != b' ' && line[i] != b'\t' {
                    i += 1;
                }
                if i > s {
                    cells.push((String::from_utf8_lossy(&line[s..i]).into_owned(), base + s));
                }
            }
        }
    }
    cells
}

fn is_number(cell: &str) -> bool {
    matches!(fast_float2::parse_partial::<f64, _>(cell.as_bytes()), Ok((_, n)) if n == cell.len())
}

/// What the first lines of delimited text say: the delimiter, the column names, where the
/// data rows start, and which columns are kept, in the order asked for.
struct TextLayout {
    delim: Delim,
    names: Vec<String>,
    /// Kept columns (0-based), in the order asked for.
    order: Vec<usize>,
    /// Whether each of the row's columns is parsed.
    keep: Vec<bool>,
    data_start: usize,
    /// Length of the first row (a capacity hint).
    row_len: usize,
}

impl TextLayout {
    fn new(bytes: &[u8], file: &str, select: Option<&[ColumnSpec]>) -> Result<TextLayout> {
        let mut p = 0;
        if bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
            p = 3;
        }
        // Skip leading comment and blank lines.
        loop {
            let q = skip_blank(bytes, p, Delim::Whitespace);
            if q >= bytes.len() {
                return Err(no_rows(file));
            }
            if bytes[q] == b'#' || is_eol(bytes[q]) {
                p = bytes[q..]
                    .iter()
                    .position(|&b| b == b'\n')
                    .map_or(bytes.len(), |i| q + i + 1);
                continue;
            }
            break;
        }
        let first_end = bytes[p..]
            .iter()
            .position(|&b| is_eol(b))
            .map_or(bytes.len(), |i| p + i);
        let first = &bytes[p..first_end];
        let delim = if first.contains(&b',') {
            Delim::Byte(b',')
        } else if first.contains(&b'\t') {
            Delim::Byte(b'\t')
        } else {
            Delim::Whitespace
        };
        let cells = split_row(first, p, delim);
        let ncols = cells.len();
        // A header when no cell of the first row is a number.
        let header = cells.iter().all(|(c, _)| !is_number(c));
        let names: Vec<String> = if header {
            if let Some((_, off)) = cells.iter().find(|(c, _)| c.is_empty()) {
                let (line, column, _) = locate(bytes, *off);
                return Err(Error::Located {
                    file: file.to_string(),
                    line,
                    column,
                    message: "empty column name in the header".to_string(),
                });
            }
            cells.iter().map(|(c, _)| c.clone()).collect()
        } else {
            (1..=ncols).map(|c| format!("col{c}")).collect()
        };
        let data_start = if header {
            let mut q = first_end;
            if q < bytes.len() && bytes[q] == b'\r' {
                q += 1;
            }
            if q < bytes.len() && bytes[q] == b'\n' {
                q += 1;
            }
            q
        } else {
            p
        };
        let order = match select {
            Some(spec) => resolve_columns(spec, &names)?,
            None => (0..ncols).collect(),
        };
        let mut keep = vec![false; ncols];
        for &i in &order {
            keep[i] = true;
        }
        Ok(TextLayout {
            delim,
            names,
            order,
            keep,
            data_start,
            row_len: (first_end - p + 1).max(1),
        })
    }

    /// The rows of `bytes[lo..hi)` (from a line start to a line start or the end), cut at line
    /// ends into chunks parsed in parallel: the kept columns in the order asked for. Errors
    /// name the line and column in the whole of `bytes`.
    fn parse_span(&self, bytes: &[u8], file: &str, lo: usize, hi: usize) -> Result<Vec<Vec<f64>>> {
        let body = hi - lo;
        let threads = rayon::current_num_threads().max(1);
        let n_chunks = if body < (1 << 20) {
            1
        } else {
            (threads * 4).min(body >> 18).max(1)
        };
        let mut bounds = vec![lo];
        for k in 1..n_chunks {
            let target = lo + body * k / n_chunks;
            let prev = *bounds.last().expect("non-empty");
            if target <= prev {
                continue;
            }
            match bytes[target..hi].iter().position(|&b| b == b'\n') {
                Some(i) if target + i + 1 < hi => bounds.push(target + i + 1),
                _ => break,
            }
        }
        bounds.push(hi);
        bounds.dedup();
        let ncols = self.keep.len();
        let parts: Vec<std::result::Result<Vec<Vec<f64>>, Fault>> = bounds
            .par_windows(2)
            .map(|w| {
                parse_rows(
                    bytes,
                    w[0],
                    w[1],
                    self.delim,
                    &self.keep,
                    (w[1] - w[0]) / self.row_len + 16,
                )
            })
            .collect();
        let nkeep = self.keep.iter().filter(|&&k| k).count();
        let total: usize = parts
            .iter()
            .map(|r| r.as_ref().map_or(0, |c| c.first().map_or(0, Vec::len)))
            .sum();
        let mut cols: Vec<Vec<f64>> = (0..nkeep).map(|_| Vec::with_capacity(total)).collect();
        for part in parts {
            let part = part.map_err(|f| fault_to_error(bytes, file, f, ncols, self.delim))?;
            for (dst, src) in cols.iter_mut().zip(part) {
                dst.extend_from_slice(&src);
            }
        }
        // `cols` is in file order of the kept columns; put it in the order asked for.
        let mut file_order: Vec<usize> = self.order.clone();
        file_order.sort_unstable();
        let mut by_index: Vec<Option<Vec<f64>>> = vec![None; ncols];
        for (i, c) in file_order.into_iter().zip(cols) {
            by_index[i] = Some(c);
        }
        Ok(self
            .order
            .iter()
            .map(|&i| by_index[i].take().expect("each column once"))
            .collect())
    }

    /// The names of the kept columns, in the order asked for.
    fn kept_names(&self) -> Vec<String> {
        self.order.iter().map(|&i| self.names[i].clone()).collect()
    }
}

fn no_rows(file: &str) -> Error {
    Error::File {
        file: file.to_string(),
        message: "the file is empty (no data rows)".to_string(),
    }
}

/// Parses delimited text (see the module docs) into a [`Table`], keeping the columns of
/// `select` (all when `None`).
///
/// ```
/// use imunoise::io::{parse_columns, parse_text};
/// // a comment, no header: the channels are named col1, col2, …; whitespace-separated
/// let t = parse_text(b"# imu log\n1 2 3\n4 5 6\n", "x.txt", None)?;
/// assert_eq!(t.names, ["col1", "col2", "col3"]);
/// assert_eq!(t.columns[2], vec![3.0, 6.0]);
/// assert!(t.rate_hz.is_none());
/// // with a header (tab-separated), selecting columns
/// let t = parse_text(b"gx\tgy\tgz\n1\t2\t3\n", "x.tsv", Some(&parse_columns("gz,gx")?))?;
/// assert_eq!(t.names, ["gz", "gx"]);
/// assert_eq!(t.columns, [vec![3.0], vec![1.0]]);
/// // a bad cell is located by line and column
/// let e = parse_text(b"1,2\n3,x\n", "x.csv", None).unwrap_err();
/// assert!(e.to_string().starts_with("x.csv:2:3:"));
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn parse_text(bytes: &[u8], file: &str, select: Option<&[ColumnSpec]>) -> Result<Table> {
    let layout = TextLayout::new(bytes, file, select)?;
    let cols = layout.parse_span(bytes, file, layout.data_start, bytes.len())?;
    if cols.first().is_none_or(Vec::is_empty) {
        return Err(no_rows(file));
    }
    Ok(Table {
        file: file.to_string(),
        names: layout.kept_names(),
        columns: cols.into_iter().map(Column::from).collect(),
        rate_hz: None,
        timing: None,
        topic: None,
    })
}

/// [`parse_text`] of the text file `path` in windows of about `window` bytes (each ends at
/// the first line end at least `window` bytes past its start), handing the values of each window (the kept columns, in the order asked for) to `f`
/// instead of collecting them: memory for one window, whatever the file's size. The values
/// and the errors (lines and columns in the whole file) are those of [`parse_text`]. Returns
/// the kept columns' names. For a regular uncompressed file (memory-mapped, and the pages of
/// each window parsed are released; standard input and pipes are read into memory first, and
/// gzip-compressed data are refused); `file` is the name used in messages.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("x.csv");
/// std::fs::write(&p, "gx,gy\n1,2\n3,4\n5,6\n").unwrap();
/// let mut seen = Vec::new();
/// // a window ends at the first line end at least 3 bytes on: one row each here
/// let names = imunoise::io::parse_text_windows(&p, "x.csv", None, 3, |cols| {
///     seen.push(cols);
///     Ok(())
/// })
/// .unwrap();
/// assert_eq!(names, ["gx", "gy"]);
/// assert_eq!(seen.len(), 3);
/// assert_eq!(seen[2], vec![vec![5.0], vec![6.0]]);
/// ```
pub fn parse_text_windows(
    path: &Path,
    file: &str,
    select: Option<&[ColumnSpec]>,
    window: usize,
    mut f: impl FnMut(Vec<Vec<f64>>) -> Result<()>,
) -> Result<Vec<String>> {
    let loaded = load(path, file)?;
    let bytes: &[u8] = &loaded;
    if bytes.starts_with(&[0x1f, 0x8b]) {
        return Err(Error::File {
            file: file.to_string(),
            message: "is gzip-compressed: it is read whole (read_table), not in windows"
                .to_string(),
        });
    }
    let layout = TextLayout::new(bytes, file, select)?;
    let mut lo = layout.data_start;
    let mut rows = 0usize;
    // the map's pages of the windows already parsed, released (the whole pages before `lo`)
    let page = 4096;
    let mut released = 0usize;
    while lo < bytes.len() {
        let target = lo.saturating_add(window.max(1)).min(bytes.len());
        let hi = if target >= bytes.len() {
            bytes.len()
        } else {
            bytes[target..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(bytes.len(), |i| target + i + 1)
        };
        let cols = layout.parse_span(bytes, file, lo, hi)?;
        rows += cols.first().map_or(0, Vec::len);
        f(cols)?;
        lo = hi;
        if let Bytes::Mapped(map) = &loaded {
            let upto = lo / page * page;
            if upto > released {
                // SAFETY: MADV_DONTNEED on a read-only private file mapping that was never
                // written drops the page-table entries only; a later read (an error's line
                // count) maps the same file contents again. A hint: errors are ignored.
                let _ = unsafe {
                    map.unchecked_advise_range(
                        memmap2::UncheckedAdvice::DontNeed,
                        released,
                        upto - released,
                    )
                };
                released = upto;
            }
        }
    }
    if rows == 0 {
        return Err(no_rows(file));
    }
    Ok(layout.kept_names())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(s: &str) -> Result<Table> {
        parse_text(s.as_bytes(), "t.csv", None)
    }

    fn located(e: Error) -> (usize, usize, String) {
        match e {
            Error::Located {
                line,
                column,
                message,
                ..
            } => (line, column, message),
            other => panic!("expected a located error, got {other}"),
        }
    }

    #[test]
    fn header_names_and_values() {
        let t = text("a, b\n1, 2\n3.5,-4e-3\n").unwrap();
        assert_eq!(t.names, ["a", "b"]);
        assert_eq!(t.columns, [vec![1.0, 3.5], vec![2.0, -4e-3]]);
    }

    #[test]
    fn no_header_tsv_whitespace_crlf_comments() {
        let t = text("# comment\n1\t2\r\n3\t4\r\n\r\n").unwrap();
        assert_eq!(t.names, ["col1", "col2"]);
        assert_eq!(t.columns, [vec![1.0, 3.0], vec![2.0, 4.0]]);
        let t = text("  1   2\n 3 4  \n").unwrap();
        assert_eq!(t.columns, [vec![1.0, 3.0], vec![2.0, 4.0]]);
    }

    #[test]
    fn errors_name_line_and_column() {
        let (l, c, m) = located(text("x,y\n1,2\n3,abc\n").unwrap_err());
        assert_eq!((l, c), (3, 3));
        assert!(m.contains("abc"), "{m}");
        let (l, c, m) = located(text("x,y\n1,2\n3,4,5\n").unwrap_err());
        assert_eq!((l, c), (3, 4));
        assert!(m.contains("3 cells"), "{m}");
        let (l, _, m) = located(text("x,y\n1,2\n3\n").unwrap_err());
        assert_eq!(l, 3);
        assert!(m.contains("1 cells"), "{m}");
        let (l, c, m) = located(text("x,y\n1,NaN\n").unwrap_err());
        assert_eq!((l, c), (2, 3));
        assert!(m.contains("finite"), "{m}");
        let (l, c, _) = located(text("x,y\n1,2.5x\n").unwrap_err());
        assert_eq!((l, c), (2, 3));
        let (l, c, m) = located(text("x,y,z\n1,,3\n").unwrap_err());
        assert_eq!((l, c), (2, 3));
        assert!(m.contains("empty"), "{m}");
        let (l, _, m) = located(text("1,2\n\n3,4\n").unwrap_err());
        assert_eq!(l, 2);
        assert!(m.contains("blank"), "{m}");
        assert!(matches!(text("x,y\n").unwrap_err(), Error::File { .. }));
        assert!(matches!(text("\n\n").unwrap_err(), Error::File { .. }));
    }

    #[test]
    fn column_selection_in_given_order() {
        let t = parse_text(
            b"a,b,c\n1,2,3\n4,5,6\n",
            "t",
            Some(&parse_columns("c,1").unwrap()),
        )
        .unwrap();
        assert_eq!(t.names, ["c", "a"]);
        assert_eq!(t.columns, [vec![3.0, 6.0], vec![1.0, 4.0]]);
        // Cells of unselected columns are not parsed, but rows must still be whole.
        assert!(parse_text(b"a,b\n1,x\n", "t", Some(&parse_columns("a").unwrap())).is_ok());
        assert!(parse_text(b"a,b\n1\n", "t", Some(&parse_columns("a").unwrap())).is_err());
        assert!(parse_text(b"a,b\n1,2\n", "t", Some(&parse_columns("z").unwrap())).is_err());
        assert_eq!(
            parse_columns("2-3,x").unwrap(),
            [ColumnSpec::Range(2, 3), ColumnSpec::Name("x".into())]
        );
    }

    #[test]
    fn chunked_parse_equals_sequential() {
        // Large enough to be cut into parallel chunks; values are exact in binary.
        let mut s = String::from("u,v\n");
        for i in 0..200_000 {
            s.push_str(&format!("{},{}\n", i as f64 * 0.5, -(i as f64)));
        }
        let t = text(&s).unwrap();
        assert_eq!(t.n_rows(), 200_000);
        assert!(
            t.columns[0]
                .iter()
                .enumerate()
                .all(|(i, &v)| v == i as f64 * 0.5)
        );
        // An error late in the file gets the right line number.
        s.push_str("1,oops\n");
        let (l, c, _) = located(text(&s).unwrap_err());
        assert_eq!((l, c), (200_002, 3));
    }

    #[test]
    fn binary_rows_and_errors() {
        let vals = [1.0f64, 2.0, 3.0, 4.0];
        let bytes: Vec<u8> = vals.iter().flat_map(|v| v.to_le_bytes()).collect();
        let t = parse_binary(&bytes, "b", BinaryType::F64, 2).unwrap();
        assert_eq!(t.columns, [vec![1.0, 3.0], vec![2.0, 4.0]]);
        assert!(matches!(
            parse_binary(&bytes[..24], "b", BinaryType::F64, 2),
            Err(Error::File { .. })
        ));
        let mut bad = bytes.clone();
        bad[24..32].copy_from_slice(&f64::NAN.to_le_bytes());
        let (l, c, _) = located(parse_binary(&bad, "b", BinaryType::F64, 2).unwrap_err());
        assert_eq!((l, c), (2, 2));
        let ints: Vec<u8> = [-3i16, 7].iter().flat_map(|v| v.to_le_bytes()).collect();
        let t = parse_binary(&ints, "b", BinaryType::I16, 1).unwrap();
        assert_eq!(t.columns, [vec![-3.0, 7.0]]);
    }
}
