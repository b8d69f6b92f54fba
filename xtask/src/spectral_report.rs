//! `cargo xtask spectral-table`: the `spectral` crate's three-way agreement table
//! (closed form vs Lemma 4.2 sum vs Lemma 4.1 quadrature) as Markdown, for the README.
//! The same numbers are asserted in `crates/spectral/tests/three_ways.rs`; this report
//! also covers m up to 2^30 for the quadrature and prints rough single-thread timings
//! (the criterion bench `cargo bench -p imunoise-spectral` is the reference for speed).

use processes::{
    Ar1, Drift, GaussMarkov, Ma1, Model, Process, QuantizationNoise, RandomWalk, WhiteNoise,
};
use spectral::{
    allan_variance, lemma42_allan_variance, model_allan_variance, quadrature_allan_variance,
};
use std::time::Instant;

const RATE: f64 = 100.0;

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn fixtures() -> Vec<Process> {
    let mut v: Vec<Process> = vec![
        WhiteNoise::new(2.5e-3).unwrap().into(),
        QuantizationNoise::new(1.3e-4).unwrap().into(),
        RandomWalk::new(1e-6).unwrap().into(),
        Drift::new(-3e-5).unwrap().into(),
    ];
    for phi in [-0.99999, -0.3, 0.5, 0.995, 0.99999] {
        v.push(Ar1::new(phi, 1e-6).unwrap().into());
    }
    for beta in [10.0, 1e-3, 1e-5] {
        v.push(GaussMarkov::new(beta, 4e-6).unwrap().into());
    }
    for theta in [-1.0, 0.3] {
        v.push(Ma1::new(theta, 1e-4).unwrap().into());
    }
    v
}

pub fn run(_args: &[String]) -> Result<(), String> {
    let err = |e: spectral::SpectralError| e.to_string();
    let mut grid = vec![1u64, 2, 3, 4, 7];
    grid.extend((3..=20).map(|j| 1u64 << j));
    let big = [1u64 << 25, (1 << 30) - 1, 1 << 30];
    println!(
        "| process | max rel. gap, Lemma 4.2 (m ≤ 2^20) | max rel. gap, Lemma 4.1 (m ≤ 2^20) | Lemma 4.1, m up to 2^30 |"
    );
    println!("|---|---|---|---|");
    for p in fixtures() {
        let (mut ws, mut wq, mut wb) = (0.0f64, 0.0f64, 0.0f64);
        for &m in &grid {
            let c = allan_variance(&p, m, RATE).map_err(err)?;
            ws = ws.max(rel(lemma42_allan_variance(&p, m, RATE).map_err(err)?, c));
            wq = wq.max(rel(quadrature_allan_variance(&p, m, RATE).map_err(err)?, c));
        }
        for &m in &big {
            let c = allan_variance(&p, m, RATE).map_err(err)?;
            wb = wb.max(rel(quadrature_allan_variance(&p, m, RATE).map_err(err)?, c));
        }
        println!(
            "| {}{:?} | {ws:.1e} | {wq:.1e} | {wb:.1e} |",
            p.kind(),
            p.params()
        );
    }
    println!(
        "\nDR: its spectrum is the distribution (ω·rate)²/(8π²)·δ''(f), applied analytically (not an independent check); RW uses its generalized PSD γ²Δt/(4 sin²(πfΔt))."
    );
    // rough timings
    let model: Model =
        "QN(1e-7) + WN(1e-4) + RW(1e-10) + DR(1e-8) + AR1(0.9995, 1e-8) + GM(0.01, 1e-6)"
            .parse()
            .map_err(|e: processes::ProcessError| e.to_string())?;
    let reps = 2000;
    let t = Instant::now();
    let mut s = 0.0;
    for _ in 0..reps {
        for j in 1..=30 {
            s += model_allan_variance(&model, 1 << j, RATE).map_err(err)?;
        }
    }
    let per = t.elapsed().as_secs_f64() / reps as f64;
    let ar = Process::from(Ar1::new(0.9995, 1e-8).unwrap());
    let t = Instant::now();
    for j in 0..=30 {
        s += quadrature_allan_variance(&ar, 1 << j, RATE).map_err(err)?;
    }
    let q = t.elapsed().as_secs_f64() / 31.0;
    println!(
        "\nclosed form, 6-component model at 30 dyadic scales: {:.1} µs; Lemma 4.1 quadrature (AR1): {:.0} µs per m (checksum {s:.3e})",
        per * 1e6,
        q * 1e6
    );
    Ok(())
}
