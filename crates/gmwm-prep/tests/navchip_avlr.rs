//! AVLR on the NavChip gyro curves published by R avar (REFERENCES §7):
//! `avlr(qn = 1:4, wn = 6:8, rw = 10:13)` on the three gyro axes pooled gives
//! WN 5.945877e−05, QN 7.208553e−06, RW 3.062325e−05 (per-second N, Q, K in rad/s units).

use gmwm_prep::AvCurve;
use gmwm_prep::avlr::{AvlrWindows, avlr_pooled};
use processes::ProcessKind;
use std::path::PathBuf;

/// R avar prints 7 significant digits: agreement to 1e-6 relative is the best the reference
/// allows.
const PUBLISHED_REL_TOL: f64 = 1e-6;

fn data_dir() -> Option<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    d.is_dir().then_some(d)
}

#[test]
fn navchip_gyro_avlr_matches_r_avar() {
    let Some(dir) = data_dir() else {
        eprintln!("skipped: ../shared/data not found");
        return;
    };
    let text = std::fs::read_to_string(dir.join("sensor_curves/avar_curves.csv")).unwrap();
    let mut curves = Vec::new();
    for axis in 0..3 {
        let (mut tau, mut av, mut rate) = (Vec::new(), Vec::new(), 0.0);
        for line in text.lines().skip(1) {
            let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            if f[0] == 4.0 && f[1] == axis as f64 {
                rate = f[2];
                tau.push(f[4]);
                av.push(f[5]);
            }
        }
        assert_eq!(tau.len(), 20, "NavChip axis {axis}");
        curves.push(AvCurve::from_tau(&tau, &av, rate).unwrap());
    }
    let w = AvlrWindows {
        qn: Some((0, 3)),
        wn: Some((5, 7)),
        rw: Some((9, 12)),
        dr: None,
    };
    let fit = avlr_pooled(&curves, &w).unwrap();
    for (kind, want) in [
        (ProcessKind::WhiteNoise, 5.945877e-05),
        (ProcessKind::QuantizationNoise, 7.208553e-06),
        (ProcessKind::RandomWalk, 3.062325e-05),
    ] {
        let got = fit.get(kind).unwrap().value;
        assert!(
            (got / want - 1.0).abs() < PUBLISHED_REL_TOL,
            "{kind}: {got:e} vs R avar {want:e}"
        );
    }
}
