//! A memory-mapped file of f64 samples used in place as an [`avar::SampleSource`]
//! ([`MappedSamples`]), with the far walk's positioned-read window on it. The readers
//! ([`crate::io`]: a table's mapped column) and the sample sources ([`crate::source`]: the
//! streamed Allan variance) both hold one; it depends on neither.

use crate::error::{Error, Result};
use avar::SampleSource;
use std::path::Path;

/// A memory-mapped file of little-endian f64 samples used in place as a [`SampleSource`]
/// (the map starts at `offset` bytes and holds `len` samples); released ranges drop their
/// resident pages. When it maps a temporary file, the file is deleted on drop.
///
/// ```
/// use imunoise::avar::SampleSource;
/// use imunoise::source::MappedSamples;
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("x.f64");
/// let x: Vec<f64> = (0..1000).map(|i| (i % 10) as f64).collect();
/// std::fs::write(&p, x.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
/// let s = MappedSamples::map_f64(&p, "x.f64", 0)?;
/// assert_eq!(s.samples(), &x[..]);
/// // a source for the streamed Allan variance: the same curve as from the slice
/// let cfg = imunoise::avar::AvarConfig::default();
/// let av = imunoise::avar::allan_variance_source(&s, 10.0, &cfg)?;
/// assert_eq!(av, imunoise::avar::allan_variance(&x, 10.0, &cfg)?);
/// # Ok::<(), imunoise::Error>(())
/// ```
pub struct MappedSamples {
    pub(crate) backing: Backing,
    pub(crate) offset: usize,
    pub(crate) len: usize,
    pub(crate) page: usize,
    /// Page ranges released but not yet dropped (see [`RELEASE_BATCH`]).
    pub(crate) pending: std::sync::Mutex<Vec<(usize, usize)>>,
}

/// Released page ranges are dropped together once they add up to this many bytes: each
/// `madvise(MADV_DONTNEED)` on a map shared by several threads makes the kernel interrupt the
/// other cores to flush their TLBs, and the walk releases small ranges thousands of times (at
/// 10^8 samples, the interrupts were about 13 % of the command's cycles); coalesced, the same
/// pages go in a few hundred calls, at the cost of at most this much more resident memory.
const RELEASE_BATCH: usize = 4 << 20;

/// Where the samples of a [`MappedSamples`] live.
pub(crate) enum Backing {
    /// A read-only map of a file (the input, or a temporary decoded copy), and the file.
    File(memmap2::Mmap, std::fs::File),
    /// Anonymous memory holding a decoded copy (never released: it is the only copy).
    Anon(memmap2::MmapMut),
}

impl Backing {
    fn bytes(&self) -> &[u8] {
        match self {
            Backing::File(m, _) => m,
            Backing::Anon(m) => m,
        }
    }
}

impl std::fmt::Debug for MappedSamples {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MappedSamples")
            .field("len", &self.len)
            .finish()
    }
}

impl MappedSamples {
    /// Maps `file` (a regular file holding one channel of raw little-endian f64 after
    /// `header` bytes, a multiple of 8) for use in place. `name` is used in messages.
    ///
    /// ```
    /// use avar::SampleSource;
    /// let dir = tempfile::tempdir().unwrap();
    /// let p = dir.path().join("x.f64");
    /// let bytes: Vec<u8> = [1.5f64, -2.0, 4.0].iter().flat_map(|v| v.to_le_bytes()).collect();
    /// std::fs::write(&p, bytes).unwrap();
    /// let s = imunoise::source::MappedSamples::map_f64(&p, "x.f64", 0).unwrap();
    /// assert_eq!(s.samples(), &[1.5, -2.0, 4.0]);
    /// ```
    pub fn map_f64(file: &Path, name: &str, header: usize) -> Result<MappedSamples> {
        let f = std::fs::File::open(file).map_err(|e| Error::io(name, e))?;
        Self::from_file(&f, name, header)
    }

    pub(crate) fn from_file(f: &std::fs::File, name: &str, header: usize) -> Result<MappedSamples> {
        if cfg!(target_endian = "big") || !header.is_multiple_of(8) {
            return Err(Error::Usage(format!(
                "{name}: cannot map f64 samples in place (header {header} bytes)"
            )));
        }
        let size = f.metadata().map_err(|e| Error::io(name, e))?.len() as usize;
        let body = size.saturating_sub(header);
        if body == 0 {
            return Err(Error::File {
                file: name.to_string(),
                message: "the file is empty".to_string(),
            });
        }
        if !body.is_multiple_of(8) {
            return Err(whole_rows(name, body, 1, 8));
        }
        // SAFETY: the map is read-only and private to this process; as with any mmap, the
        // file must not be truncated by another process while it is read (documented in the
        // command's help). Temporary files are ours alone.
        let map = unsafe { memmap2::Mmap::map(f) }.map_err(|e| Error::io(name, e))?;
        Ok(MappedSamples {
            backing: Backing::File(map, f.try_clone().map_err(|e| Error::io(name, e))?),
            offset: header,
            len: body / 8,
            page: page_size(),
            pending: Default::default(),
        })
    }
}

impl SampleSource for MappedSamples {
    fn samples(&self) -> &[f64] {
        let bytes = &self.backing.bytes()[self.offset..self.offset + 8 * self.len];
        // SAFETY: the map is page-aligned and `offset` a multiple of 8, so the pointer is
        // aligned for f64; the range is inside the map; every bit pattern is a valid f64; the
        // map is read-only and lives as long as `self`.
        unsafe { std::slice::from_raw_parts(bytes.as_ptr().cast::<f64>(), self.len) }
    }

    fn release(&self, lo: usize, hi: usize) {
        let Backing::File(map, _) = &self.backing else {
            return;
        };
        // the whole pages inside the byte range of [lo, hi)
        let a = (self.offset + 8 * lo.min(self.len)).next_multiple_of(self.page);
        let b = (self.offset + 8 * hi.min(self.len)) / self.page * self.page;
        if a >= b {
            return;
        }
        // batch the ranges (RELEASE_BATCH), coalescing neighbours; the whole series at once
        // (the end of the walk) goes at once
        let ranges = {
            let Ok(mut p) = self.pending.lock() else {
                return;
            };
            p.push((a, b));
            let total: usize = p.iter().map(|(a, b)| b - a).sum();
            if total < RELEASE_BATCH && hi < self.len {
                return;
            }
            std::mem::take(&mut *p)
        };
        for (a, b) in coalesce(ranges) {
            // SAFETY: MADV_DONTNEED on a read-only private file mapping that was never written
            // drops the page-table entries only; the next read maps the same file contents
            // again (from the page cache or the disk), so no value changes. Errors are
            // ignored: release is a hint.
            let _ =
                unsafe { map.unchecked_advise_range(memmap2::UncheckedAdvice::DontNeed, a, b - a) };
        }
    }

    fn window(&self) -> Option<Box<dyn avar::source::SampleWindow + '_>> {
        let Backing::File(_, file) = &self.backing else {
            return None;
        };
        // room for a shift of up to one class step of the far walk (2^20 samples)
        let period = 1 << 20;
        // address space only (MAP_NORESERVE): pages exist where filled
        let buf = memmap2::MmapOptions::new()
            .len(8 * (self.len + period))
            .no_reserve_swap()
            .map_anon()
            .ok()?;
        Some(Box::new(PreadWindow {
            src: self,
            file,
            buf,
            base: 0,
            period,
        }))
    }
}

/// The far walk's window on a [`MappedSamples`]: an anonymous private mapping as long as the
/// series (address space only: pages exist where filled), filled with positioned reads
/// (`pread`) of the file and emptied with `madvise(MADV_DONTNEED)`. Mapping the file for these
/// scattered 16 KiB chunks would instead map whole page-cache folios (up to 2 MiB each on
/// current kernels) and keep a large part of the file resident.
///
/// The window is 8·(T + period) bytes of address space, and the view starts `base` bytes into
/// it, chosen at each [`rebase`](avar::source::SampleWindow::rebase) so that the chunks of
/// every residue class land on the same pages: the walk faults its pages in once per window
/// and then only copies into them (a few MiB per thread at 10^9 samples).
struct PreadWindow<'a> {
    src: &'a MappedSamples,
    file: &'a std::fs::File,
    buf: memmap2::MmapMut,
    base: usize,
    period: usize,
}

impl avar::source::SampleWindow for PreadWindow<'_> {
    fn fill(&mut self, lo: usize, hi: usize) {
        use std::os::unix::fs::FileExt;
        let hi = hi.min(self.src.len);
        if lo >= hi {
            return;
        }
        let (a, b) = (8 * lo, 8 * hi);
        let dst = &mut self.buf[self.base + a..self.base + b];
        if self
            .file
            .read_exact_at(dst, (self.src.offset + a) as u64)
            .is_err()
        {
            // a failed read: copy from the map instead (the same bytes)
            dst.copy_from_slice(
                &self.src.backing.bytes()[self.src.offset + a..self.src.offset + b],
            );
        }
    }

    fn view(&self) -> &[f64] {
        let v = &self.buf[self.base..self.base + 8 * self.src.len];
        // SAFETY: `base` is a multiple of 8 in a page-aligned map, so the pointer is aligned
        // for f64; the range is inside the map, which lives as long as `self`; every bit
        // pattern is a valid f64.
        unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<f64>(), self.src.len) }
    }

    fn clear(&mut self) {}

    fn rebase(&mut self, origin: usize, period: usize) {
        // sample origin + j·period then sits at byte 8·period·(j + 1) whatever the origin
        if period <= self.period {
            self.base = 8 * (period - origin % period);
        }
    }
}

/// Sorted, with overlapping and touching ranges merged.
fn coalesce(mut ranges: Vec<(usize, usize)>) -> Vec<(usize, usize)> {
    ranges.sort_unstable();
    let mut out: Vec<(usize, usize)> = Vec::with_capacity(ranges.len());
    for (a, b) in ranges {
        match out.last_mut() {
            Some(last) if a <= last.1 => last.1 = last.1.max(b),
            _ => out.push((a, b)),
        }
    }
    out
}

pub(crate) fn page_size() -> usize {
    // SAFETY: sysconf has no preconditions.
    let p = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    if p > 0 { p as usize } else { 4096 }
}

pub(crate) fn whole_rows(name: &str, len: usize, channels: usize, size: usize) -> Error {
    let row = channels * size;
    Error::File {
        file: name.to_string(),
        message: format!(
            "size {len} bytes is not a whole number of rows of {channels} × {size} bytes \
             ({} bytes left over): wrong --binary type or --channels?",
            len % row
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn released_ranges_coalesce() {
        // touching and overlapping ranges merge, gaps stay, order does not matter
        let r = coalesce(vec![
            (8192, 12288),
            (0, 4096),
            (4096, 8192),
            (20480, 24576),
            (10000, 16384),
        ]);
        assert_eq!(r, vec![(0, 16384), (20480, 24576)]);
        assert!(coalesce(Vec::new()).is_empty());
    }
}
