//! Simulating: independent channels of a noise model, and their CSV and raw f64 writers
//! (what `imunoise simulate` and the Python `simulate` produce).

use crate::error::{Error, Result};
use processes::Model;
use std::io::Write;

/// Simulates `channels` independent streams of `model`.
///
/// ```
/// use imunoise::pipeline::simulate::simulate_channels;
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
/// let cols = simulate_channels(&model, 1000, 100.0, 42, 3)?;
/// assert_eq!(cols.len(), 3);
/// assert!(cols.iter().all(|c| c.len() == 1000));
/// // channel k is stream k of the seed: reproducible, and independent of the others
/// assert_eq!(cols[2], model.simulate_stream(1000, 100.0, 42, 2)?.into_values());
/// assert_eq!(simulate_channels(&model, 1000, 100.0, 42, 3)?, cols);
/// assert_ne!(cols[0], cols[1]);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn simulate_channels(
    model: &Model,
    n: usize,
    rate_hz: f64,
    seed: u64,
    channels: usize,
) -> Result<Vec<Vec<f64>>> {
    use rayon::prelude::*;
    (0..channels as u64)
        .into_par_iter()
        .map(|k| {
            model
                .simulate_stream(n, rate_hz, seed, k)
                .map(|ts| ts.into_values())
                .map_err(Error::from)
        })
        .collect()
}

/// Writes columns as CSV with a header (shortest round-trip decimal form of every value).
///
/// ```
/// use imunoise::pipeline::simulate::{simulate_channels, write_csv};
/// let model: imunoise::processes::Model = "WN(sigma2=1e-4)".parse()?;
/// let cols = simulate_channels(&model, 500, 100.0, 1, 2)?;
/// let mut out = Vec::new();
/// write_csv(&mut out, &["gx".into(), "gy".into()], &cols)?;
/// assert!(out.starts_with(b"gx,gy\n"));
/// // read back, every value is the same f64
/// let t = imunoise::io::read_bytes(&out, "sim.csv", &Default::default())?;
/// assert_eq!(t.names, ["gx", "gy"]);
/// assert_eq!(t.columns, cols);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_csv(out: &mut impl Write, names: &[String], cols: &[Vec<f64>]) -> std::io::Result<()> {
    writeln!(out, "{}", names.join(","))?;
    let n = cols.first().map_or(0, Vec::len);
    let mut line = String::with_capacity(32 * cols.len());
    for i in 0..n {
        line.clear();
        for (c, col) in cols.iter().enumerate() {
            if c > 0 {
                line.push(',');
            }
            use std::fmt::Write as _;
            let _ = write!(line, "{}", col[i]);
        }
        line.push('\n');
        out.write_all(line.as_bytes())?;
    }
    Ok(())
}

/// Writes columns as raw little-endian f64, row-major.
///
/// ```
/// use imunoise::io::{BinaryType, parse_binary};
/// use imunoise::pipeline::simulate::write_f64;
/// let cols = vec![vec![1.0, 2.0, 3.0], vec![-1.0, -2.0, -3.0]];
/// let mut out = Vec::new();
/// write_f64(&mut out, &cols)?;
/// assert_eq!(out.len(), 8 * 3 * 2);
/// assert_eq!(out[8..16], (-1.0f64).to_le_bytes()); // row-major: x₀, y₀, x₁, …
/// let t = parse_binary(&out, "sim.f64", BinaryType::F64, 2)?;
/// assert_eq!(t.columns, cols);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn write_f64(out: &mut impl Write, cols: &[Vec<f64>]) -> std::io::Result<()> {
    let n = cols.first().map_or(0, Vec::len);
    let mut row = Vec::with_capacity(8 * cols.len());
    for i in 0..n {
        row.clear();
        for col in cols {
            row.extend_from_slice(&col[i].to_le_bytes());
        }
        out.write_all(&row)?;
    }
    Ok(())
}
