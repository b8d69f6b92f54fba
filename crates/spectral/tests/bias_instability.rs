//! Bias instability (BI, issue 28): its AV three ways — the closed form (sum of the states'
//! GM closed forms), the Lemma 4.2 sum of its exact ACF and the Lemma 4.1 quadrature of its
//! PSD — its flat plateau (2 ln 2/π)·B² over the band, and its analytic gradient.

use processes::{BI_FLAT_FROM_M, BI_FLAT_TOLERANCE, BiBand, BiasInstability, Process};
use spectral::{
    allan_variance, allan_variance_gradient, lemma42_allan_variance, psd, quadrature_allan_variance,
};

const RATE: f64 = 100.0;
/// Closed form vs the Lemma 4.2 sum (issue 28 acceptance: 1e-10).
const SUM_REL: f64 = 1e-10;
/// Closed form vs the quadrature (issue 28 acceptance: 1e-6).
const QUAD_REL: f64 = 1e-6;

fn bi(b: f64, lo: u64, hi: u64) -> Process {
    BiasInstability::new(b, BiBand::new(lo, hi).unwrap())
        .unwrap()
        .into()
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

#[test]
fn closed_form_lemma42_and_quadrature_agree() {
    for p in [bi(2e-3, 1, 4096), bi(0.5, 64, 1 << 16)] {
        let mut grid = vec![1u64, 2, 3, 4, 7];
        grid.extend((3..=18).map(|j| 1u64 << j));
        let (mut ws, mut wq) = (0.0f64, 0.0f64);
        for m in grid {
            let c = allan_variance(&p, m, RATE).unwrap();
            let s = lemma42_allan_variance(&p, m, RATE).unwrap();
            let q = quadrature_allan_variance(&p, m, RATE).unwrap();
            assert!(rel(s, c) <= SUM_REL, "m={m}: closed {c:e} vs sum {s:e}");
            assert!(
                rel(q, c) <= QUAD_REL,
                "m={m}: closed {c:e} vs quadrature {q:e}"
            );
            ws = ws.max(rel(s, c));
            wq = wq.max(rel(q, c));
        }
        eprintln!("{p:?}: max rel. gap sum {ws:.2e}, quadrature {wq:.2e}");
    }
}

#[test]
fn av_is_flat_at_the_ieee_plateau_over_the_band() {
    // Every integer m on a 1/50-decade grid of max(m_lo, 16) … m_hi, for bands from a few
    // decades to the 5.2·10⁵ scales of a 1.5-hour 100 Hz record.
    let b = 3e-4;
    let plateau = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI * b * b;
    for (lo, hi) in [
        (1u64, 1u64 << 19),
        (1, 1000),
        (20, 100_000),
        (100, 1_000_000),
    ] {
        let p = bi(b, lo, hi);
        let from = lo.max(BI_FLAT_FROM_M);
        let (mut dmin, mut dmax) = (f64::INFINITY, f64::NEG_INFINITY);
        let steps = ((hi as f64 / from as f64).log10() * 50.0).ceil() as i32;
        for i in 0..=steps {
            let m = ((from as f64) * 10f64.powf(i as f64 / 50.0)).round() as u64;
            let m = m.clamp(from, hi);
            let d = allan_variance(&p, m, RATE).unwrap() / plateau - 1.0;
            dmin = dmin.min(d);
            dmax = dmax.max(d);
        }
        eprintln!("band [{lo}, {hi}]: AV/plateau − 1 in [{dmin:.4}, {dmax:.4}]");
        assert!(
            dmin >= -BI_FLAT_TOLERANCE && dmax <= BI_FLAT_TOLERANCE,
            "band [{lo}, {hi}]: [{dmin}, {dmax}]"
        );
    }
    // below m = 16 the discrete states cannot follow 1/f: the AV sags (documented −35 % at 1)
    let p = bi(b, 1, 1 << 19);
    let d1 = allan_variance(&p, 1, RATE).unwrap() / plateau - 1.0;
    assert!(d1 < -0.3 && d1 > -0.4, "{d1}");
}

#[test]
fn gradient_is_twice_av_over_b() {
    // AV ∝ B²: the analytic ∂AV/∂B against a central difference (truncation O(h²) exactly 0
    // for a quadratic; rounding ~1e-16/1e-6).
    let (lo, hi, b) = (1, 1 << 12, 2e-3);
    for m in [1u64, 10, 100, 1000, 4096] {
        let g = allan_variance_gradient(&bi(b, lo, hi), m, RATE).unwrap();
        let h = 1e-6 * b;
        let fd = (allan_variance(&bi(b + h, lo, hi), m, RATE).unwrap()
            - allan_variance(&bi(b - h, lo, hi), m, RATE).unwrap())
            / (2.0 * h);
        assert!(rel(g[0], fd) < 1e-8, "m={m}: {} vs {fd}", g[0]);
    }
}

#[test]
fn psd_is_the_sum_of_the_states_and_acf_of_the_model() {
    let p = bi(1e-3, 1, 1 << 12);
    let Process::BiasInstability(b) = p else {
        unreachable!()
    };
    let states = b.ar1_states().unwrap();
    for f in [1e-4, 0.01, 1.0, 10.0, 50.0] {
        let want: f64 = states
            .iter()
            .map(|a| psd(&Process::from(*a), f, RATE).unwrap())
            .sum();
        // the AR1 route forms 1 − φ from φ = e^{−1/T} rounded, T up to 4·10⁵ samples:
        // relative error ≤ 2.2e-16·4e5 ≈ 1e-10 in 1 − φ, 2e-10 in (1 − φ)²
        assert!(rel(psd(&p, f, RATE).unwrap(), want) < 1e-9, "f={f}");
    }
    for h in [0u64, 1, 10, 1000] {
        let want: f64 = states
            .iter()
            .map(|a| Process::from(*a).autocovariance(h, RATE).unwrap())
            .sum();
        assert!(
            rel(p.autocovariance(h, RATE).unwrap(), want) < 1e-12,
            "h={h}"
        );
    }
    // an AUTO band has no theory yet
    let auto = Process::from(BiasInstability::new(1e-3, BiBand::AUTO).unwrap());
    assert!(allan_variance(&auto, 4, RATE).is_err());
    assert!(psd(&auto, 1.0, RATE).is_err());
    assert!(lemma42_allan_variance(&auto, 4, RATE).is_err());
}
