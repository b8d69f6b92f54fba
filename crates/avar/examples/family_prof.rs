//! Times one statistic of the stability family on a white-noise rate series (profiling aid):
//! `cargo run -p imunoise-avar --release --example family_prof -- [T] [reps] [statistic] [scales]`,
//! scales `octave` (default) or a comma list of cluster sizes m; `CI=chi2` adds the chi-square
//! interval.
use avar::stability::{Statistic, stability};
use avar::{AvarConfig, CiMethod, Scales};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n = args
        .get(1)
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(1e7) as usize;
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let name = args.get(3).map(String::as_str).unwrap_or("ohdev");
    let st = Statistic::ALL
        .into_iter()
        .find(|s| s.name() == name)
        .expect("a statistic name");
    let scales = match args.get(4).map(String::as_str) {
        None | Some("octave") => Scales::Octave,
        Some(list) => Scales::Explicit(list.split(',').map(|v| v.parse().expect("m")).collect()),
    };
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let x: Vec<f64> = (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            1e-3 + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-6
        })
        .collect();
    let cfg = AvarConfig {
        scales,
        // CI=chi2 in the environment: the chi-square interval (default: none)
        ci: if std::env::var("CI").as_deref() == Ok("chi2") {
            CiMethod::ChiSquare
        } else {
            CiMethod::None
        },
        ..AvarConfig::default()
    };
    let mut best = f64::INFINITY;
    let mut bits = 0u64;
    for _ in 0..reps {
        let t = Instant::now();
        let r = stability(&x, 1.0, st, &cfg).expect("estimate");
        best = best.min(t.elapsed().as_secs_f64());
        // a digest of the deviations' bits (and intervals, α), to compare builds bit for bit
        bits = r.points.iter().fold(0, |h, p| {
            let ci = p.dev_lo.unwrap_or(0.0).to_bits() ^ p.dev_hi.unwrap_or(0.0).to_bits();
            h.rotate_left(7) ^ p.dev.to_bits() ^ ci ^ p.alpha.unwrap_or(9) as u64
        });
    }
    println!(
        "{name} T={n:.0e}: best of {reps} {:.2} ms (digest {bits:016x})",
        1e3 * best
    );
    if std::env::var_os("ALPHAS").is_some() {
        let r = stability(&x, 1.0, st, &cfg).expect("estimate");
        let a: Vec<i32> = r.points.iter().map(|p| p.alpha.unwrap_or(9)).collect();
        let e: Vec<String> = r
            .points
            .iter()
            .map(|p| format!("{:.6e}", p.edf.unwrap_or(0.0)))
            .collect();
        println!("alphas {a:?}\nedf {}", e.join(" "));
    }
}
