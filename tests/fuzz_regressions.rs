//! Inputs that coverage-guided fuzzing (fuzz/, `cargo xtask fuzz --coverage`) found to make a
//! reader panic, abort, run longer than 1 s or allocate more than 1 GiB, minimised by libFuzzer
//! and kept in `tests/fixtures/fuzz/<target>/`. Each is driven through the reader as its fuzz
//! target drives it; each must now give a value or an error (exit code 2), and the test says
//! which.

use imunoise::io::{BinaryType, ReadOptions, read_bytes};
use imunoise::logs::{self, GapPolicy, LogFormat};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The system allocator, noting the largest single allocation of the calling thread (what
/// libFuzzer's -malloc_limit_mb checks), so that a test can bound it.
struct Largest;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

/// The largest single allocation of any thread since the start (the readers decode chunks on
/// rayon's threads). The other tests of this file allocate far less than the 1 GiB bound it
/// is checked against.
static LARGEST_ANY_THREAD: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

fn note(size: usize) {
    let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
    LARGEST_ANY_THREAD.fetch_max(size, std::sync::atomic::Ordering::Relaxed);
}

// SAFETY: every call is passed on to the system allocator unchanged.
unsafe impl GlobalAlloc for Largest {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Largest = Largest;

/// `f`'s value and the largest single allocation it made on this thread, in bytes.
fn largest_allocation<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LARGEST.with(|l| l.set(0));
    let r = f();
    (r, LARGEST.with(|l| l.get()))
}

fn fixture(target: &str, name: &str) -> Vec<u8> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/fuzz")
        .join(target)
        .join(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// What the log targets do (fuzz/src/lib.rs): open, summarize, read every IMU topic and order
/// it by stamp. Returns the first error (or `None` when everything read), and checks the time
/// limit of the fuzzing (1 s, here 10 s for slow debug builds under a loaded machine).
fn read_log(format: LogFormat, ext: &str, bytes: &[u8]) -> Option<imunoise::Error> {
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = dir.path().join(format!("x.{ext}"));
    std::fs::write(&path, bytes).unwrap();
    let t0 = Instant::now();
    let result = (|| {
        let r = logs::open_checked(&path, format, false, &imunoise::Ui::quiet())?;
        logs::summarize(r.as_ref())?;
        for t in r.topics()?.iter().filter(|t| t.is_imu) {
            let s = r.read_imu(&t.name)?;
            logs::timing::prepare(s.stamps_ns, s.columns, None, GapPolicy::Longest, "x")?;
        }
        Ok::<(), imunoise::Error>(())
    })();
    assert!(
        t0.elapsed() < Duration::from_secs(10),
        "{format:?} took {:?}",
        t0.elapsed()
    );
    result.err()
}

/// An error the command reports with exit code 2 (bad input), not an internal error.
fn user_error(e: Option<imunoise::Error>) -> String {
    let e = e.expect("an error");
    assert_eq!(e.exit_code(), 2, "{e}");
    e.to_string()
}

#[allow(dead_code)]
fn raw(kind: BinaryType, channels: usize, bytes: &[u8], name: &str) -> imunoise::Result<usize> {
    let opts = ReadOptions {
        binary: Some(kind),
        channels: Some(channels),
        ..Default::default()
    };
    read_bytes(bytes, name, &opts).map(|t| t.n_rows())
}

/// A 27-byte gzip file (`gx\n1\n2\n`) whose trailer claims 4,294,967,280 bytes uncompressed:
/// the reader reserved that much before decompressing (libFuzzer: out-of-memory,
/// malloc(4294967280)). The hint is now capped at 1032 times the input (deflate's largest
/// expansion), so the file reads: its CRC and size disagree with the data, an error.
#[test]
fn gzip_trailer_claiming_4_gib_reserves_no_more_than_the_input_can_give() {
    let bytes = fixture("gzip", "forged-trailer-4gib.gz");
    assert_eq!(bytes.len(), 27);
    let size = u32::from_le_bytes(bytes[23..27].try_into().unwrap());
    assert_eq!(size, 0xffff_fff0);
    let (r, largest) =
        largest_allocation(|| read_bytes(&bytes, "x.csv.gz", &ReadOptions::default()));
    // the cap: 27 · 1032 bytes; the decoder's own state is a few tens of kB (bound 1 MiB)
    assert!(largest < 1 << 20, "largest allocation {largest} bytes");
    let e = r.unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
    assert!(e.to_string().contains("cannot decompress gzip data"), "{e}");
    // the same data with its true size (7 bytes) in the trailer reads
    let mut fixed = bytes.clone();
    fixed[23..27].copy_from_slice(&7u32.to_le_bytes());
    let t = read_bytes(&fixed, "x.csv.gz", &ReadOptions::default()).unwrap();
    assert_eq!(t.columns, vec![vec![1.0, 2.0]]);
}

/// A ULog file and a DataFlash log (mutated seeds) whose IMU stamps lie more than 2^63 ns
/// (292 years) apart: the differences of sorted stamps overflowed i64 (debug builds: "attempt
/// to subtract with overflow" in `rate_from_stamps` and `timing::prepare`). A difference beyond
/// i64 now counts as i64::MAX ns; the files read to the end, a value or a user error.
#[test]
fn stamps_further_apart_than_i64_do_not_overflow() {
    // closed form: two stamps 2^64 − 1 ns apart give Δt = i64::MAX ns
    assert_eq!(
        logs::rate_from_stamps(&[i64::MIN, i64::MAX]),
        Some(1e9 / i64::MAX as f64)
    );
    let stamps = vec![i64::MIN, 0, 1, 2, i64::MAX];
    let cols = vec![vec![0.0; 5]];
    let r = logs::timing::prepare(stamps, cols, None, GapPolicy::Longest, "x");
    assert!(r.is_ok() || r.unwrap_err().exit_code() == 2);
    for (format, ext, dir, name) in [
        (
            LogFormat::Ulog,
            "ulg",
            "ulog",
            "stamps-apart-beyond-i64.ulg",
        ),
        (
            LogFormat::Dataflash,
            "bin",
            "dataflash",
            "stamps-apart-beyond-i64.bin",
        ),
    ] {
        if let Some(e) = read_log(format, ext, &fixture(dir, name)) {
            user_error(Some(e));
        }
    }
}

/// A model string whose repeat count, 1.2·10^18, the parser turned into a vector of that many
/// components ("capacity overflow" panic). A model now has at most 1000 components.
#[test]
fn model_string_with_a_repeat_count_of_1e18_is_refused() {
    let bytes = fixture("model", "repeat-count-1e18.txt");
    let s = std::str::from_utf8(&bytes).unwrap();
    assert!(s.starts_with("01244444444444444414"), "{s:?}");
    let e = s.parse::<imunoise::processes::Model>().unwrap_err();
    assert!(e.to_string().contains("at most 1000 components"), "{e}");
}

/// An MCAP file (a mutated seed, 50,766 bytes) whose footer points its summary section into
/// the data section, at a run of records that holds uncompressed chunks and, further on, a
/// record claiming 7·10^13 bytes. The `mcap` crate (0.26.0) read that "summary" as it was and
/// subtracted an inner record's length from its chunk's remainder ("attempt to subtract with
/// overflow", `sans_io/linear_reader.rs:745`, through `Summary::read`). The reader now walks
/// the summary section before the crate sees it: a summary holding a chunk, or a record that
/// runs past the footer, is not used and the messages are streamed instead; the file reads to a
/// value or a user error.
#[test]
fn mcap_summary_pointing_into_the_data_section_is_not_handed_to_the_crate() {
    let bytes = fixture("mcap", "open-linear-reader-overflow.mcap");
    assert_eq!(bytes.len(), 50_766);
    // the footer (29 bytes before the closing magic): opcode 0x02, then its summary start
    let footer = bytes.len() - 8 - 29;
    assert_eq!(bytes[footer], 0x02);
    let start = u64::from_le_bytes(bytes[footer + 9..footer + 17].try_into().unwrap()) as usize;
    assert_eq!(start, 15_388);
    // walking the records from there meets a chunk (opcode 0x06) before the footer
    let mut at = start;
    let mut chunks = 0;
    while at < footer {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        if len > footer - at - 9 {
            break;
        }
        chunks += usize::from(bytes[at] == 0x06);
        at += 9 + len;
    }
    assert_eq!(chunks, 3);
    if let Some(e) = read_log(LogFormat::Mcap, "mcap", &bytes) {
        user_error(Some(e));
    }
}

/// An MCAP file (a corpus input of the 30-minute fuzzing run, 115,590 bytes) with a channel
/// record inside an uncompressed chunk whose topic string claims 2,474,639,360 bytes in a
/// 346-byte record. The `mcap` crate parses records with binrw, which reserved the claimed
/// length before reading it: a 2.47 GB allocation (libFuzzer out-of-memory,
/// `malloc(2474639360)`, when the corpus was replayed for line coverage; in the fuzzing run
/// itself the allocation was made on a rayon thread and went unreported). The reader now
/// checks that a record's length-prefixed fields fit in it before the crate parses it
/// (`fields_fit`), and parses only the records it uses.
#[test]
fn mcap_record_field_claiming_2_gib_is_refused_before_the_crate_reserves_it() {
    let bytes = fixture("mcap", "channel-field-2gib.mcap");
    assert_eq!(bytes.len(), 115_590);
    // the channel record at byte 13,373: opcode 0x04, length 346, then id, schema id and the
    // topic's u32 length
    let at = 13_373;
    assert_eq!(bytes[at], 0x04);
    assert_eq!(
        u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()),
        346
    );
    let topic = u32::from_le_bytes(bytes[at + 13..at + 17].try_into().unwrap());
    assert_eq!(topic, 2_474_639_360);
    let e = read_log(LogFormat::Mcap, "mcap", &bytes);
    let largest = LARGEST_ANY_THREAD.load(std::sync::atomic::Ordering::Relaxed);
    // libFuzzer's -malloc_limit_mb=1024
    assert!(largest < 1 << 30, "largest allocation {largest} bytes");
    let msg = user_error(e);
    assert!(msg.contains("longer than the record"), "{msg}");
}

/// A ROS 1 bag (found by the bag target within 2 minutes of a run under the 1 GiB allocator
/// cap, 116,510 bytes) whose index states more than 2^28 messages on an IMU topic. The reader
/// reserved room for the stated count, capped at 2^28 samples: 2 GiB for each of the seven
/// columns (`imunoise-fuzz: allocation of 2147483648 bytes exceeds the 1 GiB limit`; with
/// `-detect_leaks=0` libFuzzer's own -malloc_limit_mb had never reported it). A stated count
/// now reserves at most `logs::MAX_RESERVE` samples (128 MiB a column).
#[test]
fn bag_index_claiming_2_pow_28_messages_reserves_no_more_than_max_reserve() {
    let bytes = fixture("bag", "index-count-2gib.bag");
    assert_eq!(bytes.len(), 116_510);
    assert!(bytes.starts_with(b"#ROSBAG V2.0\n"));
    let e = read_log(LogFormat::Bag, "bag", &bytes);
    let largest = LARGEST_ANY_THREAD.load(std::sync::atomic::Ordering::Relaxed);
    // the allocator cap of the fuzz targets (and libFuzzer's -malloc_limit_mb=1024); a column
    // of MAX_RESERVE f64 is 2^27 bytes
    assert!(largest < 1 << 30, "largest allocation {largest} bytes");
    assert!(
        largest <= logs::MAX_RESERVE * 8,
        "largest allocation {largest} bytes"
    );
    if let Some(e) = e {
        user_error(Some(e));
    }
}
