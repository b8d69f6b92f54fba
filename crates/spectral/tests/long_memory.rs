//! PLP (ARFIMA(0, d, 0)) and FGN (issue 28): the theoretical AV three ways (closed form,
//! Lemma 4.2 on the exact ACF, Lemma 4.1 quadrature of the PSD), the white-noise special
//! cases d = 0 and H = 1/2, and the Hurwitz zeta of the FGN PSD.

use processes::{Fgn, Plp, Process, WhiteNoise};
use spectral::long_memory::{fgn_avar, hurwitz_zeta, plp_avar};
use spectral::{allan_variance, lemma42_allan_variance, psd, quadrature_allan_variance};

const MS: [u64; 10] = [1, 2, 3, 5, 10, 37, 100, 1000, 10_000, 1 << 15];
const DS: [f64; 6] = [-0.45, -0.2, 0.05, 0.3, 0.45, 0.49];
const HS: [f64; 6] = [0.05, 0.3, 0.45, 0.7, 0.9, 0.98];

#[test]
fn plp_closed_form_equals_lemma42() {
    // two independent exact routes: the Gamma-ratio closed form (~1e-14) and the Lemma 4.2
    // sum (ACF form) of the exact ACF up to lag 2m. Tolerance 1e-10: the ACF recursion has
    // relative error ≤ 2hε ≈ 1.5e-11 at h = 2^16, the error the sum inherits (the worst
    // case, measured 1.9e-11, is printed).
    let mut worst = 0f64;
    for d in DS {
        let p = Plp::new(2.0, d).unwrap();
        let pr = Process::from(p);
        for m in MS {
            let c = allan_variance(&pr, m, 100.0).unwrap();
            let l = lemma42_allan_variance(&pr, m, 100.0).unwrap();
            assert_eq!(c, plp_avar(&p, m));
            worst = worst.max((c - l).abs() / c);
            assert!((c - l).abs() <= 1e-10 * c, "d={d} m={m}: {c} vs {l}");
        }
    }
    eprintln!("PLP closed form vs Lemma 4.2: worst relative difference {worst:.2e}");
}

#[test]
fn fgn_closed_form_equals_lemma42() {
    // closed form from the fBm increments vs Lemma 4.2 (ACF form) on γ(h) (binomial series
    // at h ≥ 2): 1e-10 (measured 4.2e-13)
    let mut worst = 0f64;
    for h in HS {
        let f = Process::from(Fgn::new(0.5, h).unwrap());
        for m in MS {
            let c = allan_variance(&f, m, 100.0).unwrap();
            let l = lemma42_allan_variance(&f, m, 100.0).unwrap();
            worst = worst.max((c - l).abs() / c);
            assert!((c - l).abs() <= 1e-10 * c, "H={h} m={m}: {c} vs {l}");
        }
    }
    eprintln!("FGN closed form vs Lemma 4.2: worst relative difference {worst:.2e}");
}

#[test]
fn quadrature_agrees() {
    // Lemma 4.1 on the PSD, singular at f = 0 for d > 0 / H > 1/2 (S ~ f^{−2d}, f^{1−2H});
    // the kernel vanishes like f², so the integrand goes to 0 like f^{2−2d} (f^{3−2H}) and
    // the geometrically graded first panel integrates it: 1e-6 relative
    let (mut wp, mut wf) = (0f64, 0f64);
    for d in DS {
        let p = Process::from(Plp::new(1e-4, d).unwrap());
        for m in MS {
            let c = allan_variance(&p, m, 100.0).unwrap();
            let q = quadrature_allan_variance(&p, m, 100.0).unwrap();
            wp = wp.max((c - q).abs() / c);
            assert!((c - q).abs() <= 1e-6 * c, "PLP d={d} m={m}: {c} vs {q}");
        }
    }
    for h in HS {
        let f = Process::from(Fgn::new(3.0, h).unwrap());
        for m in MS {
            let c = allan_variance(&f, m, 100.0).unwrap();
            let q = quadrature_allan_variance(&f, m, 100.0).unwrap();
            wf = wf.max((c - q).abs() / c);
            assert!((c - q).abs() <= 1e-6 * c, "FGN H={h} m={m}: {c} vs {q}");
        }
    }
    eprintln!("quadrature vs closed form: worst relative difference PLP {wp:.2e}, FGN {wf:.2e}");
}

#[test]
fn white_noise_special_cases() {
    // PLP with d = 0 and FGN with H = 1/2 are WN(σ²): AV, gradient in σ², Lemma 4.2, PSD
    let wn = Process::from(WhiteNoise::new(1.5).unwrap());
    let p = Process::from(Plp::new(1.5, 0.0).unwrap());
    let f = Process::from(Fgn::new(1.5, 0.5).unwrap());
    for m in MS {
        let w = allan_variance(&wn, m, 10.0).unwrap();
        for x in [&p, &f] {
            let a = allan_variance(x, m, 10.0).unwrap();
            let l = lemma42_allan_variance(x, m, 10.0).unwrap();
            assert!((a - w).abs() <= 1e-12 * w, "{x:?} m={m}: {a} vs {w}");
            assert!((l - w).abs() <= 1e-12 * w, "{x:?} m={m}: {l} vs {w}");
            let g = spectral::allan_variance_gradient(x, m, 10.0).unwrap();
            assert!((g[0] - 1.0 / m as f64).abs() <= 1e-12 / m as f64);
        }
    }
    for fr in [0.1, 1.0, 2.5, 4.9] {
        let w = psd(&wn, fr, 10.0).unwrap();
        for x in [&p, &f] {
            let s = psd(x, fr, 10.0).unwrap();
            assert!((s - w).abs() <= 1e-12 * w, "{x:?} f={fr}: {s} vs {w}");
        }
    }
}

#[test]
fn fgn_av_gradient_matches_central_difference() {
    // ∂AV/∂H analytic vs a central difference of the closed form (step 1e-6, error ~1e-9)
    for h in [0.2, 0.5, 0.8] {
        for m in [1u64, 4, 1000] {
            let g = spectral::allan_variance_gradient(&Fgn::new(2.0, h).unwrap().into(), m, 1.0)
                .unwrap();
            let e = 1e-6;
            let fd = (fgn_avar(&Fgn::new(2.0, h + e).unwrap(), m)
                - fgn_avar(&Fgn::new(2.0, h - e).unwrap(), m))
                / (2.0 * e);
            assert!(
                (g[1] - fd).abs() <= 1e-7 * fd.abs().max(1e-3),
                "H={h} m={m}"
            );
        }
    }
}

#[test]
fn hurwitz_zeta_reference_values() {
    // ζ(3) (Apéry), ζ(2, 1/2) = 3ζ(2) = π²/2, ζ(1.5) = 2.612375348685488 (DLMF 25.6)
    assert!((hurwitz_zeta(3.0, 1.0) - 1.202_056_903_159_594_3).abs() < 2e-15);
    let pi2 = std::f64::consts::PI.powi(2);
    assert!((hurwitz_zeta(2.0, 0.5) - pi2 / 2.0).abs() < 1e-14);
    assert!((hurwitz_zeta(1.5, 1.0) - 2.612_375_348_685_488).abs() < 1e-14);
    // recurrence ζ(a, q) = q^{−a} + ζ(a, q + 1)
    for (a, q) in [(1.1, 0.01), (2.7, 0.3), (1.9, 0.999)] {
        let l = hurwitz_zeta(a, q);
        let r = q.powf(-a) + hurwitz_zeta(a, q + 1.0);
        assert!((l - r).abs() <= 1e-14 * l, "a={a} q={q}");
    }
}
