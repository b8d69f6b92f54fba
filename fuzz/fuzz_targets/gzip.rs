//! The gzip reader: the bytes as a `.gz` file read as text, and as raw f64 samples.
#![no_main]
use imunoise::io::{BinaryType, ReadOptions, read_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(t) = read_bytes(data, "x.csv.gz", &ReadOptions::default()) {
        imunoise_fuzz::use_table(t);
    }
    let opts = ReadOptions {
        binary: Some(BinaryType::F64),
        ..Default::default()
    };
    let _ = read_bytes(data, "x.f64.gz", &opts);
});
