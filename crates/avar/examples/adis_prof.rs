//! Times the Allan variance of the six ADIS16405 channels (1e6 samples each) with the default
//! chi-square CI, the way `imunoise avar` runs it (profiling aid):
//! `cargo run -p imunoise-avar --release --example adis_prof -- [reps] [ci|none]`.
use avar::{AvarConfig, CiMethod, allan_variance};
use rayon::prelude::*;
use std::io::Read;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let reps: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10);
    let ci = match args.get(2).map(String::as_str) {
        Some("none") => CiMethod::None,
        _ => CiMethod::ChiSquare,
    };
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/adis16405/adis16405_imu1.csv.gz"
    );
    let Ok(f) = std::fs::File::open(path) else {
        eprintln!("{path} not found");
        return;
    };
    let mut text = String::new();
    flate2::read::GzDecoder::new(f)
        .read_to_string(&mut text)
        .expect("gzip text");
    let mut cols = vec![Vec::new(); 6];
    for line in text.lines().skip(1) {
        for (c, v) in cols.iter_mut().zip(line.split(',')) {
            c.push(v.parse::<f64>().expect("number"));
        }
    }
    let cfg = AvarConfig {
        ci,
        ..AvarConfig::default()
    };
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        let r: Vec<_> = cols
            .par_iter()
            .map(|c| allan_variance(c, 100.0, &cfg).expect("avar"))
            .collect();
        std::hint::black_box(r);
        best = best.min(t.elapsed().as_secs_f64());
    }
    println!(
        "6 × {} samples, {ci:?}: best {:.1} ms",
        cols[0].len(),
        1e3 * best
    );
}
