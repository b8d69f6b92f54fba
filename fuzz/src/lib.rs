//! What the fuzz targets share: each reader is driven the way the `imunoise` command drives
//! it, and every `Err` is an accepted answer; only a panic, an abort, a timeout or an
//! allocation over the limit is a finding.
//!
//! Every target links this crate, and with it [`CappedAlloc`], the global allocator that aborts
//! the process on any single allocation or reallocation above [`ALLOC_LIMIT`] (1 GiB) on any
//! thread: libFuzzer records the input as a `crash-` artifact, and stderr names the size. This
//! is on top of libFuzzer's `-malloc_limit_mb`, not instead of it.

use imunoise::logs::{self, GapPolicy, LogFormat};
use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::sync::OnceLock;

/// The largest single allocation a target may make, in bytes (1 GiB, as `-malloc_limit_mb=1024`).
pub const ALLOC_LIMIT: usize = 1 << 30;

/// The system allocator with a cap: an allocation, zeroed allocation or reallocation of more
/// than [`ALLOC_LIMIT`] bytes prints `imunoise-fuzz: allocation of N bytes exceeds the 1 GiB
/// limit …` on stderr and aborts (SIGABRT, which libFuzzer reports as a deadly signal
/// and saves the input of). Unlike libFuzzer's malloc hook, it does not depend on which thread
/// allocates or on the sanitizer's hooks: rayon's worker threads are held to it too.
pub struct CappedAlloc;

#[global_allocator]
static GLOBAL: CappedAlloc = CappedAlloc;

/// Writes the message without allocating (the allocator is where it comes from) and aborts.
#[cold]
#[inline(never)]
fn over_limit(what: &str, size: usize) -> ! {
    let mut buf = [0u8; 160];
    let mut n = 0;
    let mut put = |b: &[u8]| {
        let k = b.len().min(buf.len() - n);
        buf[n..n + k].copy_from_slice(&b[..k]);
        n += k;
    };
    put(b"\nimunoise-fuzz: ");
    put(what.as_bytes());
    put(b" of ");
    let mut digits = [0u8; 20];
    let (mut v, mut d) = (size, digits.len());
    loop {
        d -= 1;
        digits[d] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    put(&digits[d..]);
    put(b" bytes exceeds the 1 GiB limit (ALLOC_LIMIT, fuzz/src/lib.rs); aborting\n");
    // SAFETY: writing a valid buffer of n bytes to the standard error descriptor.
    unsafe {
        libc::write(2, buf.as_ptr().cast(), n);
    }
    std::process::abort()
}

// SAFETY: every call is forwarded unchanged to `System` (which upholds the contract) once the
// size has been checked; the check itself neither allocates nor touches the memory.
unsafe impl GlobalAlloc for CappedAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if layout.size() > ALLOC_LIMIT {
            over_limit("allocation", layout.size());
        }
        // SAFETY: the caller's layout, as GlobalAlloc::alloc requires.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if layout.size() > ALLOC_LIMIT {
            over_limit("zeroed allocation", layout.size());
        }
        // SAFETY: as for alloc.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > ALLOC_LIMIT {
            over_limit("reallocation", new_size);
        }
        // SAFETY: the caller's pointer, layout and size, as GlobalAlloc::realloc requires.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: ptr was allocated by System with this layout (every path above forwards).
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// A file of this process under the temporary folder, named `x.<ext>` (the readers map files,
/// so the input is written to one and read from there, as the command reads a log).
pub fn scratch(ext: &str) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    let dir = DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("imunoise-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("a scratch folder");
        d
    });
    dir.join(format!("x.{ext}"))
}

/// Opens `data` as a log of `format` (written to a file named `x.<ext>`) and does what
/// `imunoise topics` and `imunoise analyze` do: open (with the truncation check), summarize
/// every topic, then read every IMU topic and order its samples by stamp (both gap policies
/// that keep going).
pub fn read_log(format: LogFormat, ext: &str, data: &[u8]) {
    let path = scratch(ext);
    std::fs::write(&path, data).expect("writing the scratch file");
    let ui = imunoise::Ui::quiet();
    let Ok(reader) = logs::open_checked(&path, format, false, &ui) else {
        return;
    };
    let _ = logs::summarize(reader.as_ref());
    let _ = logs::select_topics(reader.as_ref(), "x", &[]);
    let Ok(topics) = reader.topics() else {
        return;
    };
    for t in topics.iter().filter(|t| t.is_imu) {
        let Ok(s) = reader.read_imu(&t.name) else {
            continue;
        };
        assert_eq!(
            s.stamps_ns.len(),
            s.columns[0].len(),
            "{format:?}: ragged series"
        );
        for policy in [GapPolicy::Longest, GapPolicy::Ignore] {
            let _ =
                logs::timing::prepare(s.stamps_ns.clone(), s.columns.clone(), None, policy, "x");
        }
    }
}

/// After a table is read: its rate (from a time column or not), and, with two or more columns,
/// the first taken as a time column in seconds (`--time-column`), ordered by stamp.
pub fn use_table(t: imunoise::io::Table) {
    let _ = t.rate();
    if t.columns.len() >= 2 && t.n_rows() >= 2 {
        let stamps: Vec<i64> = t.columns[0]
            .iter()
            .map(|&v| (v * 1e9).round() as i64)
            .collect();
        let cols: Vec<Vec<f64>> = t.columns[1..].iter().map(|c| c.to_vec()).collect();
        let _ = logs::timing::prepare(stamps, cols, None, GapPolicy::Longest, "x");
    }
}
