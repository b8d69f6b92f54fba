//! Inference checked against closed forms.

use gmwm_prep::AvCurve;
use gmwm_prep::bootstrap::{BootstrapOptions, avlr_bootstrap, parametric_bootstrap};
use gmwm_prep::gmwm::{CovMatrix, GmwmOptions, Weighting, fit};
use gmwm_prep::inference::{delta_method, diagonal_covariance, select_by_wic};
use gmwm_prep::stats::z_two_sided;
use gmwm_prep::theory::model_avar;
use processes::Model;

/// Linear algebra on well-conditioned small systems: agreement to 1e-9 relative.
const LINALG_REL_TOL: f64 = 1e-9;

fn noisy_wn_curve() -> AvCurve {
    // σ² = 1e-4 at m = 2..2^10 with a deterministic ±3 % ripple, EDF 100 at every scale
    let m: Vec<u64> = (1..=10).map(|j| 1u64 << j).collect();
    let av: Vec<f64> = m
        .iter()
        .enumerate()
        .map(|(j, &mj)| 1e-4 / mj as f64 * (1.0 + 0.03 * (j as f64).sin()))
        .collect();
    let mut c = AvCurve::from_m(&m, &av, 100.0).unwrap();
    for p in &mut c.points {
        p.edf = Some(100.0);
    }
    c
}

#[test]
fn white_noise_delta_method_is_the_weighted_mean_formula() {
    // WN only, Ω = V⁻¹ with V diagonal: ν_j = σ²/m_j is linear, A_j = 1/m_j, and
    // Var(σ̂²) = 1 / Σ_j 1/(m_j² V_jj); J = Q with J − 1 dof; WIC = Q + 2.
    let c = noisy_wn_curve();
    let v = diagonal_covariance(&c);
    let opts = GmwmOptions {
        weighting: Weighting::Full(v.clone()),
        ..Default::default()
    };
    let f = fit(&c, &"WN".parse().unwrap(), &opts).unwrap();
    // the estimate itself: Σ (ν̂_j/m_j)/V_jj / Σ 1/(m_j² V_jj)
    let (mut num, mut den) = (0.0, 0.0);
    for (j, p) in c.points.iter().enumerate() {
        let a = 1.0 / p.m as f64;
        num += a * p.avar / v.get(j, j);
        den += a * a / v.get(j, j);
    }
    assert!(
        (f.theta[0] / (num / den) - 1.0).abs() < 1e-8,
        "{} vs {}",
        f.theta[0],
        num / den
    );
    let inf = delta_method(&f, &v, 0.05).unwrap();
    let se = (1.0 / den).sqrt();
    assert!((inf.se[0] / se - 1.0).abs() < LINALG_REL_TOL);
    let j = inf.j_test.unwrap();
    assert_eq!(j.dof, c.len() - 1);
    assert!(
        (j.statistic / inf.objective - 1.0).abs() < 1e-7,
        "{j:?} vs Q {}",
        inf.objective
    );
    assert!((inf.wic - (inf.objective + 2.0)).abs() < 1e-7 * inf.wic);
    // the CI is log-symmetric with the two-sided quantile
    let z = z_two_sided(0.05);
    let r = z * se / f.theta[0];
    assert!((inf.ci[0].1 / f.theta[0] - r.exp()).abs() < LINALG_REL_TOL);
    assert!((inf.ci[0].0 / f.theta[0] - (-r).exp()).abs() < LINALG_REL_TOL);
}

#[test]
fn wic_selects_the_generating_sub_model_on_an_exact_curve() {
    let truth: Model = "WN(sigma2=1e-4) + RW(gamma2=1e-10)".parse().unwrap();
    let m: Vec<u64> = (1..=16).map(|j| 1u64 << j).collect();
    let av = model_avar(&truth, &m, 100.0).unwrap();
    let c = AvCurve::from_m(&m, &av, 100.0).unwrap().with_n(1 << 18);
    let v = diagonal_covariance(&c);
    let ranked = select_by_wic(
        &c,
        &"QN + WN + RW".parse().unwrap(),
        &GmwmOptions::default(),
        &v,
    )
    .unwrap();
    assert_eq!(ranked.len(), 7);
    // QN + WN + RW also reaches Q = 0 but pays 2 more in WIC
    assert_eq!(ranked[0].template, "WN + RW", "{ranked:#?}");
}

#[test]
fn bootstrap_is_reproducible_and_uses_the_two_sided_quantile() {
    let truth: Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse().unwrap();
    let x = truth.simulate(1 << 14, 100.0, 3).unwrap();
    let av = avar::allan_variance(x.values(), 100.0, &avar::AvarConfig::default()).unwrap();
    let c = AvCurve::from_avar(&av).unwrap();
    let tpl: Model = "WN + RW".parse().unwrap();
    let opts = GmwmOptions::default();
    let f = fit(&c, &tpl, &opts).unwrap();
    let bo = BootstrapOptions::new(8, 11, 1 << 14);
    let a = parametric_bootstrap(&f, &tpl, &opts, &bo).unwrap();
    let b = parametric_bootstrap(&f, &tpl, &opts, &bo).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.av_cov.n, c.len());
    // AVLR bootstrap: CI = θ̂ ± z_{1−α/2} sd exactly
    let w = gmwm_prep::avlr::AvlrWindows {
        wn: Some((0, 3)),
        ..Default::default()
    };
    let fit_avlr = gmwm_prep::avlr::avlr(&c, &w).unwrap();
    let bb = avlr_bootstrap(&fit_avlr, &c.m(), &bo).unwrap();
    let e = &bb.estimates[0];
    let z = z_two_sided(0.05);
    assert!((e.ci_hi.unwrap() - e.per_sample - z * e.sd.unwrap()).abs() < 1e-12 * e.per_sample);
    assert!(BootstrapOptions::new(1, 1, 10).replications == 1);
    assert!(parametric_bootstrap(&f, &tpl, &opts, &BootstrapOptions::new(1, 1, 1 << 14)).is_err());
    let bad = CovMatrix::new(2, vec![1.0, 0.0, 0.0, f64::NAN]);
    assert!(bad.is_err());
}

#[test]
fn haar_wv_moments_fit_back_and_full_weighting_is_used() {
    // Haar WV at τ_j = 2m is AV(m)/2 (REFERENCES §3): an exact WV curve must give the truth.
    let truth: Model = "WN(sigma2=1e-4) + AR1(phi=0.99, sigma2=1e-7)"
        .parse()
        .unwrap();
    let m: Vec<u64> = (1..=14).map(|j| 1u64 << j).collect();
    let wv: Vec<f64> = model_avar(&truth, &m, 100.0)
        .unwrap()
        .iter()
        .map(|v| v / 2.0)
        .collect();
    let c = AvCurve::from_m(&m, &wv, 100.0).unwrap().with_n(1 << 16);
    let opts = GmwmOptions {
        moments: gmwm_prep::gmwm::Moments::HaarWaveletVariance,
        ..Default::default()
    };
    let f = fit(&c, &truth.template(), &opts).unwrap();
    for (a, b) in f.theta.iter().zip([1e-4, 0.99, 1e-7]) {
        assert!((a / b - 1.0).abs() < 1e-6, "{:?}", f.theta);
    }
    // A full V with correlations gives a different estimate than its diagonal on a noisy
    // curve: the off-diagonal terms are used.
    let noisy = noisy_wn_curve();
    let d = diagonal_covariance(&noisy);
    let j = d.n;
    let mut full = d.data.clone();
    for a in 0..j {
        for b in 0..j {
            if a != b {
                full[a * j + b] = 0.5 * (d.get(a, a) * d.get(b, b)).sqrt();
            }
        }
    }
    let fd = fit(
        &noisy,
        &"WN".parse().unwrap(),
        &GmwmOptions {
            weighting: Weighting::Full(d),
            ..Default::default()
        },
    )
    .unwrap();
    let ff = fit(
        &noisy,
        &"WN".parse().unwrap(),
        &GmwmOptions {
            weighting: Weighting::Full(CovMatrix::new(j, full).unwrap()),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        (fd.theta[0] / ff.theta[0] - 1.0).abs() > 1e-4,
        "{} vs {}",
        fd.theta[0],
        ff.theta[0]
    );
}

#[test]
fn model_covariance_of_white_noise_is_the_closed_form() {
    // WN: D(t) has autocovariance σ² r(k), r = 2m − 3|k| (|k| ≤ m), |k| − 2m (m ≤ |k| ≤ 2m),
    // so Var(AV̂) = σ⁴ (K S0 − S1) / (2 K² m⁴) with S0 = Σ r² = 2m(4m² + 5)/3 and
    // S1 = Σ |k| r² = 2m²(2m² + 1)/3 (exact for 4m ≤ K). Rounding only: 1e-9 relative.
    const TOL: f64 = 1e-9;
    let s2 = 3e-4;
    let model: Model = format!("WN(sigma2={s2})").parse().unwrap();
    let n = 1_000_000u64;
    let m: Vec<u64> = vec![1, 2, 5, 64, 1000, 1 << 17];
    let v = gmwm_prep::inference::model_covariance(&model, &m, 100.0, n).unwrap();
    for (j, &mj) in m.iter().enumerate() {
        let (mf, k) = (mj as f64, (n - 2 * mj + 1) as f64);
        let s0 = 2.0 * mf * (4.0 * mf * mf + 5.0) / 3.0;
        let s1 = 2.0 * mf * mf * (2.0 * mf * mf + 1.0) / 3.0;
        let want = s2 * s2 * (k * s0 - s1) / (2.0 * k * k * mf.powi(4));
        let got = v.get(j, j);
        assert!((got / want - 1.0).abs() < TOL, "m={mj}: {got} vs {want}");
    }
}

#[test]
fn model_covariance_matches_simulated_replicates() {
    // 400 replicates of WN + RW + AR1 at n = 2^14: the empirical variance of AV̂ at each
    // scale and the covariance of neighbouring scales must agree with the model covariance
    // within 4 standard errors of the empirical moments (SE from the replicates' own fourth
    // moments; a false alarm has probability < 1e-4 per comparison).
    const Z: f64 = 4.0;
    let model: Model = "WN(sigma2=1e-4) + RW(gamma2=1e-8) + AR1(phi=0.98, sigma2=1e-6)"
        .parse()
        .unwrap();
    let (n, reps) = (1usize << 14, 400usize);
    let m: Vec<u64> = vec![1, 4, 16, 64, 256, 1024];
    let cfg = avar::AvarConfig::default();
    let rows: Vec<Vec<f64>> = (0..reps)
        .map(|r| {
            gmwm_prep::bootstrap::simulate_curve(&model, &m, 100.0, n, 20261121, r as u64, &cfg)
                .unwrap()
                .avar()
        })
        .collect();
    let v = gmwm_prep::inference::model_covariance(&model, &m, 100.0, n as u64).unwrap();
    let mean: Vec<f64> = (0..m.len())
        .map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / reps as f64)
        .collect();
    let pairs: Vec<(usize, usize)> = (0..m.len())
        .map(|j| (j, j))
        .chain((1..m.len()).map(|j| (j - 1, j)))
        .collect();
    for (a, b) in pairs {
        let prods: Vec<f64> = rows
            .iter()
            .map(|r| (r[a] - mean[a]) * (r[b] - mean[b]))
            .collect();
        let c = prods.iter().sum::<f64>() / (reps - 1) as f64;
        let var_p = prods.iter().map(|p| (p - c) * (p - c)).sum::<f64>() / (reps - 1) as f64;
        let se = (var_p / reps as f64).sqrt();
        let want = v.get(a, b);
        assert!(
            (c - want).abs() <= Z * se,
            "m=({}, {}): empirical {c} ± {se} vs model {want}",
            m[a],
            m[b]
        );
    }
}

#[test]
fn model_full_weighting_is_used_and_is_a_fixed_point() {
    // A simulated curve (n = 2^16, WN + AR1). Weighting::ModelFull iterates
    // Ω = V(θ̂)⁻¹ with V the model covariance of the AV: at its fixed point, refitting with
    // Weighting::Full(V(θ̂)) must return θ̂ itself (to the 1e-8 reweighting tolerance plus
    // optimizer tolerance: 1e-5 relative), while the estimate differs from the diagonal
    // weightings' (the correlations are actually used).
    const FIXED_POINT_TOL: f64 = 1e-5;
    let truth: Model = "WN(sigma2=1e-4) + AR1(phi=0.99, sigma2=1e-6)"
        .parse()
        .unwrap();
    let n = 1usize << 16;
    let m: Vec<u64> = (1..=14).map(|j| 1u64 << j).collect();
    let curve = gmwm_prep::bootstrap::simulate_curve(
        &truth,
        &m,
        100.0,
        n,
        11,
        0,
        &avar::AvarConfig::default(),
    )
    .unwrap();
    let tpl: Model = "WN + AR1".parse().unwrap();
    let with = |w: Weighting| {
        fit(
            &curve,
            &tpl,
            &GmwmOptions {
                weighting: w,
                ..Default::default()
            },
        )
        .unwrap()
    };
    let full = with(Weighting::ModelFull);
    let v = gmwm_prep::inference::fit_covariance(&full).unwrap();
    let again = with(Weighting::Full(v));
    for (a, b) in again.theta.iter().zip(&full.theta) {
        assert!((a / b - 1.0).abs() < FIXED_POINT_TOL, "{a} vs {b}");
    }
    let omega = full.omega();
    assert!(omega.get(0, 1).abs() > 0.0, "Ω must not be diagonal");
    for w in [Weighting::Diagonal, Weighting::ModelDiagonal] {
        let d = with(w.clone());
        let diff = d
            .theta
            .iter()
            .zip(&full.theta)
            .map(|(a, b)| (a / b - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(diff > 1e-4, "{w:?} gives the same estimate ({diff})");
    }
    // without the series length the model weighting is a clear error
    let mut no_n = curve.clone();
    no_n.n = None;
    let e = fit(
        &no_n,
        &tpl,
        &GmwmOptions {
            weighting: Weighting::ModelFull,
            ..Default::default()
        },
    );
    assert!(matches!(e, Err(gmwm_prep::FitError::InvalidArgument(_))));
}
