//! Robust and multi-recording fitting on real data (issue 15). Tests that read `../shared/data`
//! skip with a message when it is absent.

use avar::AvarConfig;
use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::robust::{contamination_check, fit_robust};
use processes::Model;
use std::path::PathBuf;

fn data(rel: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(rel);
    if p.is_file() {
        Some(p)
    } else {
        eprintln!("skip: {} not found", p.display());
        None
    }
}

fn read_f64(p: &PathBuf) -> Vec<f64> {
    std::fs::read(p)
        .unwrap()
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect()
}

fn inside(curve: &AvCurve, fitted: &[f64]) -> usize {
    curve
        .points
        .iter()
        .zip(fitted)
        .filter(|(p, v)| p.avar_lo.unwrap() <= **v && **v <= p.avar_hi.unwrap())
        .count()
}

/// MTi-G gyro X with outliers: classical and robust AV and fits side by side; the robust fit
/// must lie inside the robust AV CIs at >= 90 % of scales (issue 15 acceptance).
///
/// Finding: the robust curve is 27 % below the classical one at m = 2 and meets it at
/// m ≈ 256 (0.16 % of the m = 2 differences get zero weight). Its small-scale shape is not
/// that of white noise (AV(2)/AV(4) = 1.78), so WN + RW + AR1 fits it at 3 of 17 scales only
/// (J test p ≈ 1e-99); one more AR1 (WN + RW + 2·AR1, a short AR1 with φ ≈ 0.13 taking the
/// place of WN) fits it at 17 of 17 (J test p ≈ 0.7). The check flags the record as
/// contaminated at the 7 smallest scales.
#[test]
fn mtig_outliers_classical_vs_robust() {
    let Some(p) = data("mtig_outliers/cont_imu1_gyro_x.f64") else {
        return;
    };
    let x = read_f64(&p);
    assert_eq!(x.len(), 500_000);
    let rate = 100.0;
    let template: Model = "WN + RW + 2*AR1".parse().unwrap();
    let opts = GmwmOptions::default();
    let r = fit_robust(&x, rate, &AvarConfig::default(), &template, &opts).unwrap();
    let cl_curve = AvCurve::from_avar(&r.avar.classical).unwrap();
    let cl = fit(&cl_curve, &template, &opts).unwrap();
    let chk = contamination_check(&x, &r.avar, 0.01, 5).unwrap();
    eprintln!("{}", chk.message);
    for (i, s) in chk.scales.iter().enumerate() {
        eprintln!(
            "m = {:>6}  classical {:.4e} [fit {:.4e}]  robust {:.4e} [{:.4e}, {:.4e}] fit {:.4e}  z = {:.2} root {} rejected {}",
            s.m,
            s.classical,
            cl.fitted[i],
            s.robust,
            r.curve.points[i].avar_lo.unwrap(),
            r.curve.points[i].avar_hi.unwrap(),
            r.fit.fitted[i],
            s.z,
            r.avar.root_found[i],
            r.avar.rejected[i]
        );
    }
    eprintln!(
        "classical fit: {}\nrobust fit:    {}",
        cl.model, r.fit.model
    );
    let n_in = inside(&r.curve, &r.fit.fitted);
    eprintln!(
        "robust fit inside the robust CIs at {n_in}/{} scales",
        r.curve.len()
    );
    assert!(r.fit.convergence.converged);
    assert!(chk.contaminated);
    assert!(!chk.windows.is_empty());
    assert!(
        n_in as f64 >= 0.9 * r.curve.len() as f64,
        "{n_in}/{}",
        r.curve.len()
    );
}
