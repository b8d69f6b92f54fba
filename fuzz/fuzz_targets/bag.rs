//! The Bag reader (`imunoise topics`/`analyze` on a `.bag` file) on arbitrary bytes.
#![no_main]
use imunoise::logs::LogFormat;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| imunoise_fuzz::read_log(LogFormat::Bag, "bag", data));
