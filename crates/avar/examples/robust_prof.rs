//! Times the robust Allan variance of a white-noise + random-walk rate series (profiling aid):
//! `cargo run -p imunoise-avar --release --example robust_prof -- [T] [reps] [channels]
//! [uniform|gauss]`, the channels estimated in parallel as `imunoise analyze` does. The white
//! noise is uniform by default, Gaussian (Box–Muller) with `gauss`: the robust estimator's
//! Newton iteration starts nearer its root on Gaussian data.
use avar::robust::{RobustScratch, robust_allan_variance_from_with};
use avar::{AvarConfig, allan_variance};
use rayon::prelude::*;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n = args
        .get(1)
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(1.08e7) as usize;
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let channels: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(6);
    let gauss = args.get(4).is_some_and(|s| s == "gauss");
    let xs: Vec<Vec<f64>> = (0..channels as u64)
        .map(|c| {
            let mut s = 0x9E37_79B9_7F4A_7C15u64 ^ (c + 1);
            let mut rw = 0.0;
            (0..n)
                .map(|_| {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    let u = (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                    let w = if gauss {
                        s ^= s << 13;
                        s ^= s >> 7;
                        s ^= s << 17;
                        let v = ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64;
                        (-2.0 * v.ln()).sqrt() * (std::f64::consts::TAU * (u + 0.5)).cos()
                    } else {
                        u
                    };
                    rw += u * 1e-4;
                    w + rw
                })
                .collect()
        })
        .collect();
    let cfg = AvarConfig::default();
    let classical: Vec<_> = xs
        .iter()
        .map(|x| allan_variance(x, 1000.0, &cfg).expect("AV"))
        .collect();
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        let scratch = RobustScratch::default();
        let r: Vec<_> = xs
            .par_iter()
            .zip(&classical)
            .map(|(x, c)| {
                robust_allan_variance_from_with(x, c.clone(), &cfg, 0.6, &scratch).expect("robust")
            })
            .collect();
        best = best.min(t.elapsed().as_secs_f64());
        std::hint::black_box(r);
    }
    println!(
        "robust AV, {channels} × {n:.2e}: best of {reps} {:.1} ms",
        1e3 * best
    );
}
