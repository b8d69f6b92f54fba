//! The text reader (CSV/TSV/whitespace, header or not) on arbitrary bytes, whole and with a
//! column selection, then the rate and a time column as the command uses them.
#![no_main]
use imunoise::io::{ReadOptions, parse_columns, read_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(t) = read_bytes(data, "x.csv", &ReadOptions::default()) {
        imunoise_fuzz::use_table(t);
    }
    let opts = ReadOptions {
        columns: parse_columns("3,1").ok(),
        ..Default::default()
    };
    let _ = read_bytes(data, "x.csv", &opts);
    // the windowed reader (text too large to hold is decoded window by window), 7 rows a window
    let path = imunoise_fuzz::scratch("csv");
    std::fs::write(&path, data).expect("writing the scratch file");
    let _ = imunoise::io::parse_text_windows(&path, "x.csv", None, 7, |_| Ok(()));
});
