//! End-to-end cost of `imunoise avar` on the real ADIS16405 log (1e6 rows × 6 columns,
//! gzip): reading alone (decompress + parse) against reading + Allan variance with
//! chi-square CIs + JSON. The acceptance target is avar ≤ 2 × read. Skips (prints a
//! line) when `../shared/data` is absent.

use criterion::{Criterion, criterion_group, criterion_main};
use imunoise::Ui;
use imunoise::io::{ReadOptions, read_table};
use imunoise::pipeline::estimate::{compute, to_json};
use std::path::PathBuf;

fn bench(c: &mut Criterion) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data/adis16405/adis16405_imu1.csv.gz");
    if !path.exists() {
        eprintln!("skipping adis bench: {} not found", path.display());
        return;
    }
    let ui = Ui {
        progress: false,
        notes: false,
    };
    let mut g = c.benchmark_group("adis16405_imu1");
    g.sample_size(10);
    g.bench_function("read_decompress_parse", |b| {
        b.iter(|| read_table(&path, &ReadOptions::default()).expect("readable"))
    });
    g.bench_function("avar_json_end_to_end", |b| {
        b.iter(|| {
            let t = read_table(&path, &ReadOptions::default()).expect("readable");
            let curves =
                compute(&t, 100.0, &imunoise::avar::AvarConfig::default(), &ui).expect("avar");
            serde_json::to_string(&to_json(&curves)).expect("json")
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
