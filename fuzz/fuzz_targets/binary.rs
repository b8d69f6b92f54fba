//! The raw binary reader: the first byte picks the element type (f64, f32, i16, i32) and the
//! channels per row (1 to 8), the rest is the file.
#![no_main]
use imunoise::io::{BinaryType, ReadOptions, read_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&sel, rest)) = data.split_first() else {
        return;
    };
    let kind = [
        BinaryType::F64,
        BinaryType::F32,
        BinaryType::I16,
        BinaryType::I32,
    ][(sel & 3) as usize];
    let opts = ReadOptions {
        binary: Some(kind),
        channels: Some(1 + ((sel >> 2) & 7) as usize),
        ..Default::default()
    };
    if let Ok(t) = read_bytes(rest, "x.raw", &opts) {
        imunoise_fuzz::use_table(t);
    }
});
