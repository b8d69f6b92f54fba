//! AR1 and GM closed forms and gradients near φ = 1 (and −1) against references evaluated
//! in double-double arithmetic (~32 digits): the textbook formula
//! v² N/D with N = m − 3φ − mφ² + 4φ^(m+1) − φ^(2m+1), D = m²(1−φ)²(1−φ²), whose O(m)
//! terms cancel to N ≈ (2/3)m³(1−φ)³ — harmless with 32 digits when m²(1−φ)³ ≥ 1e-12 — and,
//! below that, the book's Lemma 4.2 ACF sum (loses ≈ log10(1/(m(1−φ))) digits; O(m), so
//! used for m ≤ 2^20).
//! Derivatives: the exact derivative of either expression, also in double-double.

mod common;
use common::dd::Dd;
use processes::{Ar1, GaussMarkov, Process};
use spectral::allan_variance_with_gradient;
use spectral::tolerances::{EXTENDED_REF_REL, GRADIENT_EXTENDED_REL};

fn d(x: f64) -> Dd {
    Dd::from(x)
}

/// (F, dF/dφ) with AV_AR1 = v² F, from the textbook closed form.
fn textbook(phi: Dd, m: u64) -> (Dd, Dd) {
    let one = d(1.0);
    let mf = d(m as f64);
    let pm = phi.powu(m);
    let p2m = pm * pm;
    let n = mf - d(3.0) * phi - mf * phi * phi + d(4.0) * pm * phi - p2m * phi;
    let np = -(d(2.0) * mf * phi) - d(3.0) + d(4.0) * (mf + one) * pm - (d(2.0) * mf + one) * p2m;
    let a = one - phi;
    let b = one + phi;
    let dd_ = mf * mf * a * a * a * b; // m²(1−φ)²(1−φ²) = m² a³ b
    // D' = m²(−3a² b + a³)
    let dp = mf * mf * (a * a * a - d(3.0) * a * a * b);
    let f = n.div(dd_);
    let fp = (np * dd_ - n * dp).div(dd_ * dd_);
    (f, fp)
}

/// (F, dF/dφ) from the Lemma 4.2 ACF sum: F = B/(m² (1−φ)(1+φ)).
fn lemma42(phi: Dd, m: u64) -> (Dd, Dd) {
    let one = d(1.0);
    let n = 2 * m as usize;
    let mut pw = vec![one];
    for k in 1..=n {
        let prev = pw[k - 1];
        pw.push(prev * phi);
    }
    // ρ(h) = φ^h, ρ'(h) = h φ^(h−1)
    let rp = |h: usize| {
        if h == 0 {
            d(0.0)
        } else {
            d(h as f64) * pw[h - 1]
        }
    };
    let mu = m as usize;
    let mut b = d(m as f64) * (one - pw[mu]);
    let mut bp = -(d(m as f64) * rp(mu));
    for i in 1..mu {
        let w = d(i as f64);
        b = b + w * (d(2.0) * pw[mu - i] - pw[i] - pw[n - i]);
        bp = bp + w * (d(2.0) * rp(mu - i) - rp(i) - rp(n - i));
    }
    let s = (one - phi) * (one + phi); // 1/σ_X² per unit v²
    let mf = d(m as f64);
    let f = b.div(s * mf * mf);
    // d/dφ [B/s] = B'/s + B·2φ/s²
    let fp = (bp.div(s) + b * d(2.0) * phi.div(s * s)).div(mf * mf);
    (f, fp)
}

/// Whether the textbook formula is accurate in double-double: its terms are O(m) and
/// N ≈ (2/3) m³ (1−φ)³, a loss of ≈ 1.5/(m² (1−φ)³); ≤ 1.5e12 keeps ~20 digits.
fn textbook_ok(a: f64, m: u64) -> bool {
    (m as f64).powi(2) * a.powi(3) >= 1e-12
}

fn reference(phi: Dd, m: u64) -> (Dd, Dd) {
    let a = (d(1.0) - phi).to_f64().abs();
    if textbook_ok(a, m) {
        textbook(phi, m)
    } else {
        lemma42(phi, m)
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

const MS: [u64; 11] = [
    1,
    2,
    3,
    7,
    64,
    1000,
    1 << 14,
    1 << 17,
    1 << 20,
    1 << 25,
    1 << 30,
];

#[test]
fn ar1_near_plus_and_minus_one_matches_double_double() {
    let v2 = 3e-7;
    let (mut worst, mut worst_g) = (0.0f64, 0.0f64);
    let mut worst_at = String::new();
    for phi in [
        0.9f64,
        0.995,
        0.9999,
        0.99999,
        0.9999999,
        0.999999999,
        -0.9,
        -0.99999,
        -0.9999999,
    ] {
        for m in MS {
            // the Lemma 4.2 fallback is O(m): used up to m = 2^20
            if !textbook_ok(1.0 - phi.abs(), m) && m > 1 << 20 {
                continue;
            }
            let p = Process::from(Ar1::new(phi, v2).unwrap());
            let (av, g) = allan_variance_with_gradient(&p, m, 1.0).unwrap();
            let (f, fp) = reference(d(phi), m);
            let (rav, rg) = ((d(v2) * f).to_f64(), (d(v2) * fp).to_f64());
            let e = rel(av, rav);
            worst = worst.max(e);
            assert!(
                e <= EXTENDED_REF_REL,
                "phi={phi} m={m}: {av:e} vs {rav:e} ({e:e})"
            );
            let e = rel(g[0], rg);
            if e > worst_g {
                worst_g = e;
                worst_at = format!("phi={phi} m={m}");
            }
            assert!(
                e <= GRADIENT_EXTENDED_REL,
                "phi={phi} m={m} dphi: {:e} vs {rg:e} ({e:e})",
                g[0]
            );
            let e = rel(g[1], f.to_f64());
            assert!(
                e <= EXTENDED_REF_REL,
                "phi={phi} m={m} dv2: {:e} vs {:e}",
                g[1],
                f.to_f64()
            );
        }
    }
    eprintln!("AR1 vs double-double: worst AV {worst:e}, worst dAV/dphi {worst_g:e} ({worst_at})");
}

#[test]
fn gauss_markov_with_tiny_beta_dt_matches_double_double() {
    let (rate, s2) = (200.0, 5e-6);
    let (mut worst, mut worst_g) = (0.0f64, 0.0f64);
    for beta in [2.0, 0.05, 1e-4, 1e-6] {
        let l = beta / rate;
        let phi = Dd::exp_small(-l);
        let one = d(1.0);
        for m in MS {
            if !textbook_ok(l, m) && m > 1 << 20 {
                continue;
            }
            let p = Process::from(GaussMarkov::new(beta, s2).unwrap());
            let (av, g) = allan_variance_with_gradient(&p, m, rate).unwrap();
            let (f, fp) = reference(phi, m);
            let w = one - phi * phi; // v² = σ_G² (1 − φ²)
            let rav = (d(s2) * w * f).to_f64();
            // dAV/dβ = σ_G² Δt [2φ² F − φ (1−φ²) F_φ]
            let rb = (d(s2) * (d(2.0) * phi * phi * f - phi * w * fp)).to_f64() / rate;
            let rs = (w * f).to_f64();
            let e = rel(av, rav);
            worst = worst.max(e);
            assert!(
                e <= EXTENDED_REF_REL,
                "beta={beta} m={m}: {av:e} vs {rav:e} ({e:e})"
            );
            let e = rel(g[0], rb);
            worst_g = worst_g.max(e);
            assert!(
                e <= GRADIENT_EXTENDED_REL,
                "beta={beta} m={m} dbeta: {:e} vs {rb:e} ({e:e})",
                g[0]
            );
            let e = rel(g[1], rs);
            assert!(
                e <= EXTENDED_REF_REL,
                "beta={beta} m={m} ds2: {:e} vs {rs:e}",
                g[1]
            );
        }
    }
    eprintln!("GM vs double-double: worst AV {worst:e}, worst dAV/dbeta {worst_g:e}");
}
