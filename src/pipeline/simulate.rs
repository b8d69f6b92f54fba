//! Simulating: independent channels of a noise model, and their CSV and raw f64 writers
//! (what `imunoise simulate` and the Python `simulate` produce).

use crate::error::{Error, Result};
use processes::Model;
use std::io::Write;

/// Simulates `channels` independent streams of `model`.
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
