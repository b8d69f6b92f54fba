//! Issue 3 acceptance for the empirical tools: the FFT autocovariance equals the direct
//! O(N·H) sum to ≤ 1e-10 (relative to γ̂(0)) on 10^5 samples, and the Welch PSD of a
//! simulated AR1 (10^6 samples) lies within its chi-square CI of the theoretical PSD at
//! ≥ 90 % of the frequencies.

use processes::{Ar1, Model, Process};
use spectral::empirical::{WelchConfig, autocovariance, autocovariance_direct, welch};
use spectral::psd;
use spectral::tolerances::{FFT_ACV_REL, WELCH_MIN_COVERAGE};

/// Both FFT paths (one transform of the whole series, and blocks of B ≥ H, a power of two
/// ≥ 2048, transformed at length 2B once N exceeds four blocks) against the direct sum,
/// including lengths that are not a multiple of the block, a last block of one sample, a last
/// block shorter than H, and H = B (the largest lag that cannot wrap around).
#[test]
fn both_fft_paths_equal_the_direct_sum() {
    let model = Model::from(Process::from(Ar1::new(0.9, 1.0).unwrap()));
    let x: Vec<f64> = model
        .simulate(60_013, 10.0, 11)
        .unwrap()
        .into_values()
        .into_iter()
        .map(|v| v - 250.0)
        .collect();
    // (N, H): the whole-series FFT (twice, the second at N = 4B exactly); blocks of 2048 with
    // a last one of 621 samples; a last block of one sample; H = B = 2048 and H = 2047; nine
    // blocks of 2048 and a last one of 644 < H
    for (n, h) in [
        (3000, 1000),
        (8192, 5),
        (60_013, 10),
        (16_385, 1),
        (60_013, 2048),
        (60_013, 2047),
        (19_076, 1000),
    ] {
        let (fast, slow) = (
            autocovariance(&x[..n], h).unwrap(),
            autocovariance_direct(&x[..n], h).unwrap(),
        );
        assert_eq!(fast.len(), h + 1);
        let worst = fast
            .iter()
            .zip(&slow)
            .map(|(a, b)| (a - b).abs() / slow[0])
            .fold(0.0f64, f64::max);
        assert!(worst <= FFT_ACV_REL, "N = {n}, H = {h}: {worst:e}");
    }
}

#[test]
fn fft_autocovariance_equals_the_direct_sum() {
    let model = Model::from(Process::from(Ar1::new(0.95, 1.0).unwrap()));
    // a large offset as well: the mean removal must not cost digits
    let x: Vec<f64> = model
        .simulate(100_000, 10.0, 7)
        .unwrap()
        .into_values()
        .into_iter()
        .map(|v| v + 1e3)
        .collect();
    let h = 1000;
    let (fast, slow) = (
        autocovariance(&x, h).unwrap(),
        autocovariance_direct(&x, h).unwrap(),
    );
    let worst = fast
        .iter()
        .zip(&slow)
        .map(|(a, b)| (a - b).abs() / slow[0])
        .fold(0.0f64, f64::max);
    // per lag, relative to γ̂(h) itself, where γ(h) is far from 0 (γ(100)/γ(0) = 0.95^100 ≈ 0.006)
    let worst_lag = fast[..=100]
        .iter()
        .zip(&slow[..=100])
        .map(|(a, b)| (a - b).abs() / b.abs())
        .fold(0.0f64, f64::max);
    eprintln!(
        "FFT vs direct ACV: max |Δ|/γ(0) = {worst:e}; max per-lag relative (h ≤ 100) = {worst_lag:e}"
    );
    assert!(worst <= FFT_ACV_REL, "{worst:e}");
    assert!(worst_lag <= FFT_ACV_REL, "{worst_lag:e}");
}

#[test]
fn welch_psd_of_simulated_ar1_covers_the_theoretical_psd() {
    let rate = 100.0;
    let p = Process::from(Ar1::new(0.9, 1.0).unwrap());
    let x = Model::from(p)
        .simulate(1_000_000, rate, 2026)
        .unwrap()
        .into_values();
    let est = welch(&x, rate, &WelchConfig::default()).unwrap();
    let ci = est.confidence_intervals(0.95).unwrap();
    let mut inside = 0;
    for (k, f) in est.frequencies_hz.iter().enumerate() {
        let s = psd(&p, *f, rate).unwrap();
        if ci[k].0 <= s && s <= ci[k].1 {
            inside += 1;
        }
    }
    let coverage = inside as f64 / est.psd.len() as f64;
    eprintln!(
        "Welch (L = 4096, 50 % Hann, {} segments, EDF {:.1}): 95 % CI covers S(f) at {:.2} % of {} frequencies",
        est.segments,
        est.edf,
        100.0 * coverage,
        est.psd.len()
    );
    assert!(coverage >= WELCH_MIN_COVERAGE, "coverage {coverage}");
}

#[test]
fn periodogram_of_white_noise_is_flat_at_sigma2_dt() {
    use processes::WhiteNoise;
    use spectral::empirical::periodogram;
    use spectral::tolerances::MC_Z;
    let (sigma2, rate, n) = (2.0, 50.0, 1usize << 16);
    let x = Model::from(Process::from(WhiteNoise::new(sigma2).unwrap()))
        .simulate(n, rate, 99)
        .unwrap()
        .into_values();
    let p = periodogram(&x, rate).unwrap();
    assert_eq!(p.frequencies_hz.len(), n / 2 + 1);
    assert_eq!(p.frequencies_hz[n / 2], rate / 2.0);
    // interior bins: independent S·χ²₂/2 with S = σ²Δt (mean removal does not touch k ≠ 0)
    let interior = &p.psd[1..n / 2];
    let k = interior.len() as f64;
    let mean = interior.iter().sum::<f64>() / k;
    let s = sigma2 / rate;
    let se = s / k.sqrt();
    assert!(
        (mean - s).abs() <= MC_Z * se,
        "mean {mean} vs {s} (SE {se})"
    );
    assert_eq!(p.edf, 2.0);
}
