//! Book §4.4.2: the Allan deviation of a white noise process.
//!
//! Simulates WN with σ² = 1 and T = 10^5 (as the book's code `gen_gts(WN(sigma2 = 1),
//! n = 10^5)`; the book's text says σ² = 10², its code uses 1) and prints its mean and
//! variance, then the Allan deviation at the dyadic scales m = 2^j, j = 1, …, ⌊log2 T⌋ − 1,
//! computed by the book's eq. 4.2 (maximal overlap), next to the theory σ/√m (eq. 4.3:
//! slope −1/2 in log-log). The eq.-4.2 estimator is written out here because the `avar`
//! crate is a higher layer.
//!
//! Run: `cargo run -p imunoise-processes --example white_noise_4_4_2`

use processes::{Model, ProcessError, WhiteNoise};

const T: usize = 100_000;
const SIGMA2: f64 = 1.0;
const SEED: u64 = 442;

/// Book eq. 4.2: AV(m) = 1/(2(T − 2m + 1)) Σ_{k=2m}^{T} (X̄_k − X̄_{k−m})², with
/// X̄_k − X̄_{k−m} = (C_k − 2C_{k−m} + C_{k−2m}) / m for the cumulative sums C.
fn moav(x: &[f64], m: usize) -> f64 {
    let mut c = vec![0.0; x.len() + 1];
    for (i, v) in x.iter().enumerate() {
        c[i + 1] = c[i] + v;
    }
    let mf = m as f64;
    let s: f64 = (2 * m..=x.len())
        .map(|k| ((c[k] - 2.0 * c[k - m] + c[k - 2 * m]) / mf).powi(2))
        .sum();
    s / (2.0 * (x.len() - 2 * m + 1) as f64)
}

fn main() -> Result<(), ProcessError> {
    let model = Model::from(WhiteNoise::new(SIGMA2)?);
    let x = model.simulate(T, 1.0, SEED)?;
    let v = x.values();
    let mean = v.iter().sum::<f64>() / T as f64;
    let var = v.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (T - 1) as f64;
    println!("{model}, T = {T}, seed {SEED}");
    println!(
        "mean {mean:.5} (theory 0, SE {:.5})",
        (SIGMA2 / T as f64).sqrt()
    );
    println!("variance {var:.5} (theory {SIGMA2})");
    println!();
    println!("    m     AD (eq. 4.2)   sigma/sqrt(m)   ratio");
    let j_max = (T as f64).log2().floor() as u32 - 1;
    for j in 1..=j_max {
        let m = 1usize << j;
        let ad = moav(v, m).sqrt();
        let theory = (SIGMA2 / m as f64).sqrt();
        println!("{m:>6} {ad:>14.6} {theory:>15.6} {:>8.3}", ad / theory);
    }
    Ok(())
}
