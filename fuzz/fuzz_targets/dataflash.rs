//! The Dataflash reader (`imunoise topics`/`analyze` on a `.bin` file) on arbitrary bytes.
#![no_main]
use imunoise::logs::LogFormat;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| imunoise_fuzz::read_log(LogFormat::Dataflash, "bin", data));
