//! Book §4.1 (spectral ambiguity), issue 3 acceptance: S_Y = c/f and
//! S_X = (c + a sin(2π log₂ f))/f have AVs (Lemma 4.1 quadrature, continuous time,
//! τ = m/rate) within 1e-8 relative over m = 2..2^16 while the PSDs differ by ≥ 10 %.

use spectral::ambiguity::FlickerAmbiguity;
use spectral::tolerances::{AMBIGUITY_AV_REL, AMBIGUITY_PSD_MIN_REL_DIFF, QUADRATURE_REL};

const RATE: f64 = 100.0;

#[test]
fn avs_agree_to_1e8_while_psds_differ_by_more_than_10_percent() {
    let amb = FlickerAmbiguity::new(2e-6, 1e-6).unwrap();
    // every m from 2 to 2^16 (dyadic and not)
    let mut worst = (0.0f64, 0u64);
    let closed = amb.closed_form_allan_variance();
    let mut worst_closed = 0.0f64;
    for m in 2..=(1u64 << 16) {
        let tau = m as f64 / RATE;
        let (ay, ax) = (
            amb.allan_variance_y(tau).unwrap(),
            amb.allan_variance_x(tau).unwrap(),
        );
        let d = (ax - ay).abs() / ay;
        if d > worst.0 {
            worst = (d, m);
        }
        worst_closed = worst_closed.max((ay - closed).abs() / closed);
        assert!(
            d <= AMBIGUITY_AV_REL,
            "m={m}: AV_Y {ay:e} vs AV_X {ax:e} ({d:e})"
        );
    }
    // and S_Y's AV is the flicker closed form 4c ln 2 (an absolute check of the quadrature)
    assert!(
        worst_closed <= QUADRATURE_REL,
        "AV_Y vs 4c ln2: {worst_closed:e}"
    );
    // the PSDs differ: max relative difference over a log grid of frequencies
    let mut max_diff = 0.0f64;
    for i in 0..=4000 {
        let f = 10f64.powf(-4.0 + 7.0 * i as f64 / 4000.0);
        max_diff = max_diff.max((amb.psd_x(f) - amb.psd_y(f)).abs() / amb.psd_y(f));
    }
    assert!(
        max_diff >= AMBIGUITY_PSD_MIN_REL_DIFF,
        "PSDs differ by only {max_diff}"
    );
    eprintln!(
        "ambiguity: max |AV_X − AV_Y|/AV_Y = {:e} (m = {}), max |AV_Y − 4c ln2|/(4c ln2) = {worst_closed:e}, max PSD difference {:.1} %",
        worst.0,
        worst.1,
        100.0 * max_diff
    );
}

#[test]
fn invalid_pairs_are_rejected() {
    assert!(FlickerAmbiguity::new(1.0, 1.5).is_err()); // S_X would go negative
    assert!(FlickerAmbiguity::new(1.0, 0.0).is_err());
    assert!(FlickerAmbiguity::new(-1.0, 0.5).is_err());
    assert!(FlickerAmbiguity::new(1.0, f64::NAN).is_err());
}
