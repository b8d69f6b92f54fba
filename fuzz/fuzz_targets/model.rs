//! The model-string parser (`--model`, `processes::Model::from_str`) on arbitrary UTF-8; what it
//! accepts prints to a string that parses to the same model.
#![no_main]
use imunoise::processes::Model;
// the capped global allocator (fuzz/src/lib.rs)
use imunoise_fuzz as _;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(s) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(m) = s.parse::<Model>() {
        let printed = m.to_string();
        let again: Model = printed
            .parse()
            .unwrap_or_else(|e| panic!("{s:?} printed as {printed:?} does not parse: {e}"));
        assert_eq!(again, m, "{s:?} printed as {printed:?}");
        let _ = format!("{m:.4}");
    }
});
