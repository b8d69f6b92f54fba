//! Prints wall-clock timings of the MOAV pieces on synthetic data: `cargo run --release -p
//! imunoise-avar --example moav_timing -- 1e7`.

use std::time::Instant;

use avar::{AvarConfig, CiMethod, Scales, allan_variance};

fn main() {
    let n: f64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().unwrap())
        .unwrap_or(1e7);
    let n = n as usize;
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let x: Vec<f64> = (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let lanes = |x: &[f64]| {
        let mut acc = [0.0f64; 16];
        for c in x.chunks_exact(16) {
            for l in 0..16 {
                acc[l] += c[l];
            }
        }
        acc.iter().sum::<f64>()
    };
    for _ in 0..2 {
        let t = Instant::now();
        let v = lanes(&x);
        println!(
            "one vectorised pass (sum): {:.2} ms ({v:.3})",
            t.elapsed().as_secs_f64() * 1e3
        );
    }
    for (name, scales, ci) in [
        ("dyadic, no CI", Scales::Dyadic, CiMethod::None),
        ("dyadic, chi2 CI", Scales::Dyadic, CiMethod::ChiSquare),
        (
            "m = 1..=1024 no CI",
            Scales::Explicit((1..=1024).collect()),
            CiMethod::None,
        ),
    ] {
        let c = AvarConfig {
            scales,
            ci,
            ..AvarConfig::default()
        };
        let t = Instant::now();
        let av = allan_variance(&x, 1.0, &c).unwrap();
        println!(
            "{name}: {:.2} ms ({} scales)",
            t.elapsed().as_secs_f64() * 1e3,
            av.points.len()
        );
    }
}
