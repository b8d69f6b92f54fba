//! Times the streamed MOAV kernel on a long white-noise series (profiling aid):
//! `cargo run -p imunoise-avar --release --example stream_prof -- [T] [reps] [SET]`, SET one
//! of the named sets below or `ms=a,b,c` (cluster sizes); `IMUNOISE_SIMD` caps the level.
use avar::{AvarConfig, CiMethod, Scales, allan_variance};
use std::time::Instant;

/// User + system CPU time of the process (s), from /proc/self/stat (clock ticks of 10 ms).
fn cpu_s() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let rest = s.rsplit_once(')')?.1.to_owned();
            let f: Vec<&str> = rest.split_whitespace().collect();
            let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok());
            Some((tick(11)? + tick(12)?) / 100.0)
        })
        .unwrap_or(f64::NAN)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args
        .get(1)
        .and_then(|s| s.parse::<f64>().ok())
        .unwrap_or(1e8) as usize;
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(3);
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let x: Vec<f64> = (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            1e-3 + ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e-6
        })
        .collect();
    // optional re-alignment of the data (bytes past a 64-byte boundary), to measure its effect
    let shift: usize = std::env::var("SHIFT")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(99);
    let mut store: Vec<f64>;
    let x: &[f64] = if shift < 8 {
        store = vec![0.0; n + 16];
        let off = (64 - (store.as_ptr() as usize % 64)) / 8 % 8;
        let st = off + shift;
        store[st..st + n].copy_from_slice(&x);
        &store[st..st + n]
    } else {
        &x
    };
    eprintln!("data at {} mod 64", x.as_ptr() as usize % 64);
    let j_max = (n as f64).log2().floor() as u32 - 1;
    let sets: Vec<(&str, Scales)> = vec![
        ("dyadic", Scales::Dyadic),
        ("m=2", Scales::Explicit(vec![2])),
        ("lo", Scales::Explicit((1..=9).map(|j| 1u64 << j).collect())),
        (
            "mid",
            Scales::Explicit((10..=14).map(|j| 1u64 << j).collect()),
        ),
        (
            "hi",
            Scales::Explicit((15..=19).map(|j| 1u64 << j).collect()),
        ),
        (
            "near",
            Scales::Explicit((1..=19).map(|j| 1u64 << j).collect()),
        ),
        ("m=2^10", Scales::Explicit(vec![1 << 10])),
        ("m=2^15", Scales::Explicit(vec![1 << 15])),
        ("m=2^24", Scales::Explicit(vec![1 << 24])),
        (
            "far 2^21..",
            Scales::Explicit((21..=j_max).map(|j| 1u64 << j).collect()),
        ),
    ];
    let only = args.get(3).cloned();
    // `ms=a,b,c`: an explicit list of cluster sizes instead of the named sets
    let mut sets = sets;
    if let Some(list) = only.as_deref().and_then(|o| o.strip_prefix("ms=")) {
        let ms: Vec<u64> = list.split(',').filter_map(|v| v.parse().ok()).collect();
        sets = vec![(only.as_deref().unwrap_or_default(), Scales::Explicit(ms))];
    }
    for (name, scales) in sets {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let cfg = AvarConfig {
            scales,
            ci: CiMethod::None,
            ..AvarConfig::default()
        };
        let mut best = f64::INFINITY;
        let c0 = cpu_s();
        for _ in 0..reps {
            let t = Instant::now();
            let av = allan_variance(x, 1.0, &cfg).unwrap();
            std::hint::black_box(av);
            best = best.min(t.elapsed().as_secs_f64());
        }
        let cpu = (cpu_s() - c0) / reps as f64;
        println!(
            "{name:>12}: {:.1} ms wall (best), {:.0} ms CPU (mean)",
            1e3 * best,
            1e3 * cpu
        );
    }
}
