//! Issue 15, point 4: the model QN + WN + RW + 2·AR1 that issue 5 showed the ADIS16405 gyros
//! need. On the gyro axes of `../shared/data/adis16405/adis16405_imu{1,2}.csv.gz` (100 Hz,
//! °/s), model selection by WIC over the sub-models of QN + WN + RW + 2·AR1 (as
//! `imunoise analyze` does by default: diagonal Ω, V = the diagonal AV covariance of the curve
//! for the WIC) picks a model, refitted alone, whose fitted AV lies inside the 95 % chi-square
//! AV CIs at >= 90 % of the scales on the X and Y axes of both recordings.
//!
//! Finding (asserted): on the Z axes it does not, and no model of the processes crate does.
//! The Z curve zig-zags at the smallest scales (imu1: AV(2)/AV(4) = 4.07, AV(4)/AV(8) = 1.66,
//! AV(8)/AV(16) = 2.34, then 2.0 per octave), a signature of a periodic component that no
//! sum of QN, WN, RW, AR1 (φ > 0) and MA1 produces. With 2·AR1 the fit puts its AV inside the
//! CIs at 9 of 18 scales (imu1); adding a third or fourth AR1 or an MA1 does not change that
//! (8–9 of 18 under the diagonal and the model-full Ω). Skips when the data are absent.

use flate2::read::GzDecoder;
use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmOptions, fit};
use gmwm_prep::inference::{diagonal_covariance, select_by_wic};
use processes::Model;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;

fn gyros(name: &str) -> Option<[Vec<f64>; 3]> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/adis16405")
        .join(name);
    if !path.is_file() {
        eprintln!("skipped: {} not found", path.display());
        return None;
    }
    let rd = BufReader::new(GzDecoder::new(std::fs::File::open(&path).unwrap()));
    let mut cols: [Vec<f64>; 3] = Default::default();
    for l in rd.lines().skip(1) {
        let l = l.unwrap();
        for (c, v) in cols.iter_mut().zip(l.split(',')) {
            c.push(v.parse().unwrap());
        }
    }
    Some(cols)
}

#[test]
fn adis16405_gyro_axes_selected_model_inside_the_cis() {
    let full: Model = "QN + WN + RW + 2*AR1".parse().unwrap();
    let opts = GmwmOptions::default();
    for file in ["adis16405_imu1.csv.gz", "adis16405_imu2.csv.gz"] {
        let Some(cols) = gyros(file) else {
            return;
        };
        for (axis, x) in ["x", "y", "z"].iter().zip(&cols) {
            assert_eq!(x.len(), 1_000_000);
            let av = avar::allan_variance(x, 100.0, &avar::AvarConfig::default()).unwrap();
            let curve = AvCurve::from_avar(&av).unwrap();
            let cands = select_by_wic(&curve, &full, &opts, &diagonal_covariance(&curve)).unwrap();
            let best: Model = cands[0].template.parse().unwrap();
            let f = fit(&curve, &best, &opts).unwrap();
            let inside = curve
                .points
                .iter()
                .zip(&f.fitted)
                .filter(|(p, v)| p.avar_lo.unwrap() <= **v && **v <= p.avar_hi.unwrap())
                .count();
            eprintln!(
                "{file} gyro {axis}: selected {} -> {}; inside at {inside}/{} scales",
                cands[0].template,
                f.model,
                curve.len()
            );
            assert!(f.convergence.converged);
            let share = inside as f64 / curve.len() as f64;
            if *axis == "z" {
                assert!(
                    share < 0.9,
                    "{file} gyro z: finding changed, {inside} inside"
                );
            } else {
                assert!(share >= 0.9, "{file} gyro {axis}: {inside}/{}", curve.len());
            }
        }
    }
}
