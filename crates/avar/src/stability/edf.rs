//! Equivalent degrees of freedom of the family, for power-law noise S_y ∝ f^α.
//!
//! * ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV: Greenhall & Riley's general algorithm ("Uncertainty
//!   of stability variances based on finite differences", 35th PTTI, 2003; C. A. Greenhall,
//!   W. J. Riley): a variance built from d-th differences (d = 2 Allan, 3 Hadamard) of phase
//!   averaged over m/F samples (F = m unmodified, F = 1 modified), stride S (S = m overlapping,
//!   1 non-overlapping). For J = min(M, (d + 1)S) ≤ 100 the basic sum is evaluated exactly; beyond,
//!   the paper's asymptotic coefficients (its tables 1–3) are used.
//! * TOTDEV: NIST SP 1065 §5.2.11, edf = b·(T/τ) − c with (b, c) = (1.50, 0) white FM,
//!   (1.17, 0.22) flicker FM, (0.93, 0.36) random-walk FM, T/τ = N/m for N phase points; for
//!   white and flicker PM, for which that table has no entry, the simple AV formulas of SP 1065
//!   table 5: white PM (N + 1)(N − 2m)/(2(N − m)), flicker PM
//!   exp(√(ln((N − 1)/(2m)) · ln((2m + 1)(N − 1)/4))). These reproduce Stable32's TOTDEV bounds
//!   at α = 1 (OCXO octave table; the Greenhall AV EDF does not: 5610 against Stable32's ≈ 8200
//!   at m = 8).

use super::Statistic;

const J_MAX: f64 = 100.0;

fn sw(t: f64, alpha: i32) -> f64 {
    let lg = |p: i32| {
        if t == 0.0 {
            0.0
        } else {
            t.powi(p) * t.abs().ln()
        }
    };
    match alpha {
        2 => -t.abs(),
        1 => lg(2),
        0 => t.abs().powi(3),
        -1 => -lg(4),
        -2 => -t.abs().powi(5),
        -3 => lg(6),
        _ => t.abs().powi(7),
    }
}

fn sx(t: f64, f: f64, alpha: i32) -> f64 {
    if f.is_infinite() {
        return sw(t, alpha + 2);
    }
    f * f * (2.0 * sw(t, alpha) - sw(t - 1.0 / f, alpha) - sw(t + 1.0 / f, alpha))
}

/// The binomial weights of the d-th difference, as (lag, weight) for lag 0..=d.
fn sz(t: f64, f: f64, alpha: i32, d: u32) -> f64 {
    let w: &[f64] = match d {
        1 => &[2.0, -1.0],
        2 => &[6.0, -4.0, 1.0],
        _ => &[20.0, -15.0, 6.0, -1.0],
    };
    let mut s = w[0] * sx(t, f, alpha);
    for (k, wk) in w.iter().enumerate().skip(1) {
        let k = k as f64;
        s += wk * (sx(t - k, f, alpha) + sx(t + k, f, alpha));
    }
    s
}

fn basic_sum(j: f64, m: f64, s: f64, f: f64, alpha: i32, d: u32) -> f64 {
    let mut sum = sz(0.0, f, alpha, d).powi(2) + (1.0 - j / m) * sz(j / s, f, alpha, d).powi(2);
    let mut i = 1.0;
    while i < j {
        sum += 2.0 * (1.0 - i / m) * sz(i / s, f, alpha, d).powi(2);
        i += 1.0;
    }
    sum
}

/// Greenhall & Riley (2003) table 1: modified variances, (a0, a1) by α (2..−4) and d (1..3).
fn table1(alpha: i32, d: u32) -> (f64, f64) {
    const T: [[(f64, f64); 3]; 7] = [
        [
            (2.0 / 3.0, 1.0 / 3.0),
            (7.0 / 9.0, 0.5),
            (22.0 / 25.0, 2.0 / 3.0),
        ],
        [(0.840, 0.345), (0.997, 0.616), (1.141, 0.843)],
        [(1.079, 0.368), (1.033, 0.607), (1.184, 0.848)],
        [(f64::NAN, f64::NAN), (1.048, 0.534), (1.180, 0.816)],
        [(f64::NAN, f64::NAN), (1.302, 0.535), (1.175, 0.777)],
        [(f64::NAN, f64::NAN), (f64::NAN, f64::NAN), (1.194, 0.703)],
        [(f64::NAN, f64::NAN), (f64::NAN, f64::NAN), (1.489, 0.702)],
    ];
    T[(2 - alpha) as usize][d as usize - 1]
}

/// Table 2: unmodified variances.
fn table2(alpha: i32, d: u32) -> (f64, f64) {
    const T: [[(f64, f64); 3]; 7] = [
        [(1.5, 0.5), (35.0 / 18.0, 1.0), (231.0 / 100.0, 1.5)],
        [(78.6, 25.2), (790.0, 410.0), (9950.0, 6520.0)],
        [
            (2.0 / 3.0, 1.0 / 6.0),
            (2.0 / 3.0, 1.0 / 3.0),
            (7.0 / 9.0, 0.5),
        ],
        [(f64::NAN, f64::NAN), (0.852, 0.375), (0.997, 0.617)],
        [(f64::NAN, f64::NAN), (1.079, 0.368), (1.033, 0.607)],
        [(f64::NAN, f64::NAN), (f64::NAN, f64::NAN), (1.053, 0.553)],
        [(f64::NAN, f64::NAN), (f64::NAN, f64::NAN), (1.302, 0.535)],
    ];
    T[(2 - alpha) as usize][d as usize - 1]
}

/// Table 3: unmodified variances at α = 1, (b0, b1) by d.
fn table3(d: u32) -> (f64, f64) {
    [(6.0, 4.0), (15.23, 12.0), (47.8, 40.0)][d as usize - 1]
}

/// Greenhall & Riley's EDF of a variance of d-th phase differences (d = 1, 2, 3), at cluster
/// size m, for `n_phase` phase points, integer α (clamped to the range where the variance
/// converges: α > 1 − 2d, and α ≤ 2), modified (phase averaged over m) or not, overlapping
/// (stride S = m) or not (S = 1). Returns NaN where the algorithm is undefined (too few terms).
///
/// ```
/// use avar::stability::edf::edf_greenhall_general;
/// // agrees with the AV-only implementation for d = 2, unmodified
/// let a = edf_greenhall_general(-1, 2, 16, 1001, true, false);
/// let b = avar::ci::edf_greenhall(-1, 16, 1001, true);
/// assert!((a / b - 1.0).abs() < 1e-12);
/// // at m = 1 the modified and unmodified variances coincide
/// let mv = edf_greenhall_general(0, 2, 1, 1001, true, true);
/// let av = edf_greenhall_general(0, 2, 1, 1001, true, false);
/// assert!((mv / av - 1.0).abs() < 1e-12);
/// ```
pub fn edf_greenhall_general(
    alpha: i32,
    d: u32,
    m: u64,
    n_phase: u64,
    overlapping: bool,
    modified: bool,
) -> f64 {
    let d = d.clamp(1, 3);
    let alpha = alpha.clamp(2 - 2 * d as i32, 2);
    let df = d as f64;
    let mf = m as f64;
    let n = n_phase as f64;
    let f = if modified { 1.0 } else { mf };
    let s = if overlapping { mf } else { 1.0 };
    let l = mf / f + mf * df;
    let big_m = 1.0 + (s * (n - l) / mf).floor();
    if big_m < 1.0 {
        return f64::NAN;
    }
    let j = big_m.min((df + 1.0) * s);
    let r = big_m / s;
    let inv = if modified {
        // case 1: modified variances, all α
        if j <= J_MAX {
            basic_sum(j, big_m, s, 1.0, alpha, d) / (sz(0.0, 1.0, alpha, d).powi(2) * big_m)
        } else if r > df + 1.0 {
            let (a0, a1) = table1(alpha, d);
            (a0 - a1 / r) / r
        } else {
            let mp = J_MAX / r;
            basic_sum(J_MAX, J_MAX, mp, 1.0, alpha, d) / (sz(0.0, 1.0, alpha, d).powi(2) * J_MAX)
        }
    } else if alpha <= 0 {
        // case 2: unmodified, α ≤ 0
        if j <= J_MAX {
            let mp = if mf * (df + 1.0) <= J_MAX {
                mf
            } else {
                f64::INFINITY
            };
            basic_sum(j, big_m, s, mp, alpha, d) / (sz(0.0, mp, alpha, d).powi(2) * big_m)
        } else if r > df + 1.0 {
            let (a0, a1) = table2(alpha, d);
            (a0 - a1 / r) / r
        } else {
            let mp = J_MAX / r;
            basic_sum(J_MAX, J_MAX, mp, f64::INFINITY, alpha, d)
                / (sz(0.0, f64::INFINITY, alpha, d).powi(2) * J_MAX)
        }
    } else if alpha == 1 {
        // case 3: unmodified, flicker PM
        if j <= J_MAX {
            basic_sum(j, big_m, s, mf, 1, d) / (sz(0.0, mf, 1, d).powi(2) * big_m)
        } else if r > df + 1.0 {
            let (a0, a1) = table2(1, d);
            let (b0, b1) = table3(d);
            (a0 - a1 / r) / ((b0 + b1 * mf.ln()).powi(2) * r)
        } else {
            let mp = J_MAX / r;
            let (b0, b1) = table3(d);
            basic_sum(J_MAX, J_MAX, mp, mp, 1, d) / ((b0 + b1 * mf.ln()).powi(2) * J_MAX)
        }
    } else {
        // case 4: unmodified, white PM: a0 = C(4d, 2d)/C(2d, d)², a1 = d/2
        let (a0, a1) = table2(2, d);
        if r.ceil() <= df {
            basic_sum(j, big_m, s, mf, 2, d) / (sz(0.0, mf, 2, d).powi(2) * big_m)
        } else {
            (a0 - a1 / r) / big_m
        }
    };
    1.0 / inv
}

/// The EDF of `statistic` at cluster size m for identified α and `n_phase` phase points
/// (rate samples + 1), as Stable32 computes it (see the module text).
///
/// ```
/// use avar::stability::{edf::edf, Statistic};
/// // TOTDEV, white FM: 1.5·N/m
/// assert!((edf(Statistic::Totdev, 0, 100, 10_001) - 150.015).abs() < 1e-9);
/// // TDEV has the EDF of MDEV
/// assert_eq!(edf(Statistic::Tdev, -1, 8, 1001), edf(Statistic::Mdev, -1, 8, 1001));
/// ```
pub fn edf(statistic: Statistic, alpha: i32, m: u64, n_phase: u64) -> f64 {
    if statistic == Statistic::Totdev {
        let nm = n_phase as f64 / m as f64;
        return match alpha.clamp(-2, 2) {
            0 => 1.5 * nm,
            -1 => 1.17 * nm - 0.22,
            -2 => 0.93 * nm - 0.36,
            1 => {
                let (n, mf) = (n_phase as f64, m as f64);
                let a = ((n - 1.0) / (2.0 * mf)).ln().max(0.0);
                let b = ((2.0 * mf + 1.0) * (n - 1.0) / 4.0).ln().max(0.0);
                (a * b).sqrt().exp()
            }
            _ => {
                let (n, mf) = (n_phase as f64, m as f64);
                (n + 1.0) * (n - 2.0 * mf) / (2.0 * (n - mf))
            }
        };
    }
    edf_greenhall_general(
        alpha,
        statistic.diff_order(),
        m,
        n_phase,
        statistic.overlapping(),
        statistic.modified(),
    )
}
