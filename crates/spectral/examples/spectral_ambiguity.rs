//! Book §4.1: two different PSDs with the same Allan variance.
//!
//! S_Y(f) = c/f (flicker noise) and S_X(f) = (c + a sin(2π log₂ f))/f, |a| ≤ c, differ
//! by up to a/c = 50 % here, yet their AVs (Lemma 4.1 quadrature, continuous time) agree
//! at every averaging time; both equal 4c ln 2.
//!
//! Run: `cargo run -p imunoise-spectral --example spectral_ambiguity`

use spectral::ambiguity::FlickerAmbiguity;

fn main() -> Result<(), spectral::SpectralError> {
    let rate = 100.0; // Hz: τ = m / rate
    let amb = FlickerAmbiguity::new(2e-6, 1e-6)?;
    println!(
        "S_Y(f) = c/f, S_X(f) = (c + a sin(2π log2 f))/f, c = {:e}, a = {:e}",
        amb.c(),
        amb.a()
    );
    println!("(two-sided PSD in unit²/Hz, f in Hz)\n");
    println!(
        "{:>12} {:>14} {:>14} {:>10}",
        "f [Hz]", "S_Y", "S_X", "S_X/S_Y"
    );
    for f in [
        0.01,
        0.1,
        1.0,
        2f64.powf(0.25),
        2f64.powf(0.75),
        3.0,
        10.0,
        40.0,
    ] {
        let (y, x) = (amb.psd_y(f), amb.psd_x(f));
        println!("{f:>12.5} {y:>14.6e} {x:>14.6e} {:>10.4}", x / y);
    }
    println!("\nAllan variance at dyadic scales (rate {rate} Hz), Lemma 4.1 quadrature:");
    println!(
        "{:>8} {:>10} {:>20} {:>20} {:>10}",
        "m", "tau [s]", "AV_Y", "AV_X", "rel diff"
    );
    let mut worst = 0.0f64;
    for j in 1..=16 {
        let m = 1u64 << j;
        let tau = m as f64 / rate;
        let (ay, ax) = (amb.allan_variance_y(tau)?, amb.allan_variance_x(tau)?);
        let d = (ax - ay).abs() / ay;
        worst = worst.max(d);
        println!("{m:>8} {tau:>10.2} {ay:>20.14e} {ax:>20.14e} {d:>10.2e}");
    }
    println!(
        "\nclosed form 4c ln 2 = {:.14e}; max relative AV difference {worst:.2e}",
        amb.closed_form_allan_variance()
    );
    Ok(())
}
