//! Exactness of the MOAV against the literal eq. 4.2 control and published reference values.

mod common;

use avar::{AvarConfig, CiMethod, Estimator, InputKind, Scales, allan_variance, moav_reference};
use common::*;

/// Fast vs. control (same formula, different summation): both carry ~1e-15 relative rounding.
const TOL_CONTROL: f64 = 1e-11;
/// NBS14 published values are printed with 7 significant digits: half a unit in the 7th digit.
const TOL_NBS14_7DIGITS: f64 = 5e-7;
/// Stable32 prints 5 significant digits.
const TOL_STABLE32: f64 = 1e-4;
/// OCXO octave tables: computed from a differently digitised input file (see the test).
const TOL_OCXO_001: f64 = 2e-3;

fn cfg(scales: Scales) -> AvarConfig {
    AvarConfig {
        scales,
        ci: CiMethod::None,
        ..AvarConfig::default()
    }
}

#[test]
fn fast_matches_control_on_all_scales() {
    let x: Vec<f64> = white_noise(700, 2.0, 1)
        .iter()
        .zip(random_walk(700, 0.01, 2))
        .map(|(a, b)| a + b)
        .collect();
    let av = allan_variance(&x, 3.0, &cfg(Scales::All)).unwrap();
    assert_eq!(av.points.len(), 350);
    for p in &av.points {
        let r = moav_reference(&x, p.m).unwrap();
        assert!(
            rel(p.avar, r) < TOL_CONTROL,
            "m={} fast={} control={}",
            p.m,
            p.avar,
            r
        );
        assert_eq!(p.n_terms, 700 - 2 * p.m + 1);
        assert_eq!(p.tau, p.m as f64 / 3.0);
    }
}

#[test]
fn angle_input_gives_the_same_av_as_rate_input() {
    let rate = 50.0;
    let x = white_noise(3001, 1.0, 3);
    // integrate: theta_0 = 0, theta_k = theta_{k-1} + x_k / rate
    let mut theta = vec![0.0];
    for v in &x {
        theta.push(theta.last().unwrap() + v / rate);
    }
    for est in [Estimator::Overlapping, Estimator::NonOverlapping] {
        let a = allan_variance(
            &x,
            rate,
            &AvarConfig {
                estimator: est,
                ..cfg(Scales::DyadicWithOne)
            },
        )
        .unwrap();
        let b = allan_variance(
            &theta,
            rate,
            &AvarConfig {
                estimator: est,
                input: InputKind::Angle,
                ..cfg(Scales::DyadicWithOne)
            },
        )
        .unwrap();
        assert_eq!(a.n, b.n);
        for (p, q) in a.points.iter().zip(&b.points) {
            assert_eq!((p.m, p.n_terms), (q.m, q.n_terms));
            // theta carries the integration rounding (~1e-16 relative of |theta|)
            assert!(
                rel(q.avar, p.avar) < 1e-9,
                "{est:?} m={} {} vs {}",
                p.m,
                p.avar,
                q.avar
            );
        }
    }
}

#[test]
fn nonoverlapping_matches_a_direct_block_mean_computation() {
    let x = white_noise(1003, 1.0, 4);
    let av = allan_variance(
        &x,
        1.0,
        &AvarConfig {
            estimator: Estimator::NonOverlapping,
            ..cfg(Scales::All)
        },
    )
    .unwrap();
    for p in &av.points {
        let m = p.m as usize;
        let means: Vec<f64> = x
            .chunks_exact(m)
            .map(|c| c.iter().sum::<f64>() / m as f64)
            .collect();
        let s: f64 = means.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum();
        let direct = s / (2.0 * (means.len() - 1) as f64);
        assert_eq!(p.n_terms as usize, means.len() - 1);
        assert!(rel(p.avar, direct) < TOL_CONTROL, "m={m}");
    }
}

#[test]
fn nbs14_adev_and_oadev_match_published_values() {
    // NIST SP 1065 / published NBS14 deviations (REFERENCES §7 and data/nbs14/reference_deviations.csv)
    let adev = [(1u64, 0.2922319), (10, 0.09965736), (100, 0.03897804)];
    let oadev = [(1u64, 0.2922319), (10, 0.09159953), (100, 0.03241343)];
    let mut sets = vec![("generated", nbs14_1000())];
    if let Some(d) = data_or_skip("nbs14 shipped vector") {
        sets.push((
            "shipped",
            read_column_csv(&d.join("nbs14/nbs14_1000pt_frequency.csv")),
        ));
    }
    if sets.len() == 2 {
        // the generator reproduces the shipped vector (printed with 17 significant digits)
        for (a, b) in sets[0].1.iter().zip(&sets[1].1) {
            assert!((a - b).abs() <= f64::EPSILON * b.abs(), "{a} vs {b}");
        }
    }
    for (name, y) in sets {
        assert_eq!(y.len(), 1000);
        for (est, table) in [
            (Estimator::NonOverlapping, adev),
            (Estimator::Overlapping, oadev),
        ] {
            let c = AvarConfig {
                estimator: est,
                ..cfg(Scales::Explicit(vec![1, 10, 100]))
            };
            let av = allan_variance(&y, 1.0, &c).unwrap();
            for ((m, want), p) in table.iter().zip(&av.points) {
                assert_eq!(p.m, *m);
                assert!(
                    rel(p.adev, *want) < TOL_NBS14_7DIGITS,
                    "{name} {est:?} tau={m}: {} vs {want}",
                    p.adev
                );
            }
        }
    }
}

#[test]
fn nbs14_phase_vector_matches_published_values() {
    let Some(d) = data_or_skip("nbs14_phase_vector_matches_published_values") else {
        return;
    };
    let x = read_column_csv(&d.join("nbs14/nbs14_10pt_phase.csv"));
    let angle = |est| AvarConfig {
        estimator: est,
        input: InputKind::Angle,
        ..cfg(Scales::Explicit(vec![1, 2]))
    };
    let a = allan_variance(&x, 1.0, &angle(Estimator::NonOverlapping)).unwrap();
    let o = allan_variance(&x, 1.0, &angle(Estimator::Overlapping)).unwrap();
    assert!(rel(a.points[0].adev, 91.22945) < TOL_NBS14_7DIGITS);
    assert!(rel(a.points[1].adev, 115.8082) < TOL_NBS14_7DIGITS);
    assert!(rel(o.points[0].adev, 91.22945) < TOL_NBS14_7DIGITS);
    assert!(rel(o.points[1].adev, 85.95287) < TOL_NBS14_7DIGITS);
}

fn check_stable32(x: &[f64], input: InputKind, table: &std::path::Path, est: Estimator) -> usize {
    let rows = read_stable32(table);
    assert!(!rows.is_empty());
    let c = AvarConfig {
        estimator: est,
        input,
        ..cfg(Scales::Explicit(rows.iter().map(|r| r.af).collect()))
    };
    let av = allan_variance(x, 1.0, &c).unwrap();
    for (r, p) in rows.iter().zip(&av.points) {
        assert_eq!(p.m, r.af);
        assert_eq!(p.n_terms, r.n, "{table:?} AF={}", r.af);
        assert!(
            rel(p.adev, r.sigma) < TOL_STABLE32,
            "{table:?} AF={} ours={} stable32={}",
            r.af,
            p.adev,
            r.sigma
        );
    }
    rows.len()
}

#[test]
fn phase_dat_matches_stable32_tables() {
    let Some(d) = data_or_skip("phase_dat_matches_stable32_tables") else {
        return;
    };
    let x = read_column_csv(&d.join("phasedat/phase_dat.csv"));
    assert_eq!(x.len(), 1001);
    let p = d.join("phasedat");
    let n = check_stable32(
        &x,
        InputKind::Angle,
        &p.join("stable32_phase_dat_oadev.txt"),
        Estimator::Overlapping,
    ) + check_stable32(
        &x,
        InputKind::Angle,
        &p.join("stable32_phase_dat_oadev_octave.txt"),
        Estimator::Overlapping,
    ) + check_stable32(
        &x,
        InputKind::Angle,
        &p.join("stable32_phase_dat_adev_octave.txt"),
        Estimator::NonOverlapping,
    ) + check_stable32(
        &x,
        InputKind::Angle,
        &p.join("stable32_phase_dat_adev.txt"),
        Estimator::NonOverlapping,
    );
    assert!(n > 20);
}

#[test]
fn ocxo_matches_stable32_tables() {
    let Some(d) = data_or_skip("ocxo_matches_stable32_tables") else {
        return;
    };
    let y = read_f64_column(&d.join("ocxo/ocxo.f64"), 2, 1);
    assert_eq!(y.len(), 19982);
    let p = d.join("ocxo");
    // the all-tau tables were computed by Stable32 from ocxo_frequency.003 = our fractional
    // frequency column (same statistics header: mean 1.881550e-13)
    check_stable32(
        &y,
        InputKind::Rate,
        &p.join("stable32_oadev_alltau.txt"),
        Estimator::Overlapping,
    );
    check_stable32(
        &y,
        InputKind::Rate,
        &p.join("stable32_adev_alltau.txt"),
        Estimator::NonOverlapping,
    );
    // The octave tables were computed by Stable32 from ocxo_frequency.001, a normalised frequency
    // (≈ 1 + y, header "Average = 1.000000e+00"), i.e. a differently digitised copy of the
    // recording that we do not have: its ADEVs differ from those of our f64 column by up to
    // 1.2e-3 relative, with both signs (4.9e-4 at AF = 1). So only a consistency check here
    // (same grid, same terms, TOL_OCXO_001); exactness is shown on the .003 all-τ tables above.
    for (table, est) in [
        ("stable32_oadev_octave.txt", Estimator::Overlapping),
        ("stable32_adev_octave.txt", Estimator::NonOverlapping),
    ] {
        let rows = read_stable32(&p.join(table));
        // Stable32's non-overlapping octave table stops earlier (at >= 9 clusters): explicit grid
        let scales = match est {
            Estimator::Overlapping => Scales::Octave,
            Estimator::NonOverlapping => Scales::Explicit(rows.iter().map(|r| r.af).collect()),
        };
        let c = AvarConfig {
            estimator: est,
            ..cfg(scales)
        };
        let av = allan_variance(&y, 1.0, &c).unwrap();
        assert_eq!(av.points.len(), rows.len(), "{table}: same grid");
        let mut worst = 0.0f64;
        for (r, q) in rows.iter().zip(&av.points) {
            assert_eq!((q.m, q.n_terms), (r.af, r.n), "{table}");
            worst = worst.max(rel(q.adev, r.sigma));
        }
        eprintln!("ocxo {table}: worst relative difference {worst:e}");
        assert!(worst < TOL_OCXO_001, "{table}: {worst}");
    }
}

/// The reference file holds the book's MOAV computed in extended precision.
const TOL_ADIS_EXTENDED: f64 = 1e-10;

fn check_adis(which: &str) {
    use std::io::Read;
    let Some(d) = data_or_skip("adis16405") else {
        return;
    };
    let mut text = String::new();
    flate2::read::GzDecoder::new(
        std::fs::File::open(d.join(format!("adis16405/adis16405_{which}.csv.gz"))).unwrap(),
    )
    .read_to_string(&mut text)
    .unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    let mut cols: Vec<Vec<f64>> = vec![Vec::with_capacity(1_000_000); header.len()];
    for l in lines.filter(|l| !l.is_empty()) {
        for (c, v) in cols.iter_mut().zip(l.split(',')) {
            c.push(v.parse().unwrap());
        }
    }
    let refs =
        std::fs::read_to_string(d.join(format!("adis16405/reference_moav_{which}.csv"))).unwrap();
    let slices: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
    let avs = avar::allan_variance_channels(&slices, 100.0, &cfg(Scales::Dyadic)).unwrap();
    let mut checked = 0;
    let mut worst = 0.0f64;
    for l in refs.lines().skip(1) {
        let f: Vec<&str> = l.split(',').collect();
        let ci = header.iter().position(|h| h == f[0]).unwrap();
        let m: u64 = f[1].parse().unwrap();
        let want: f64 = f[3].parse().unwrap();
        let p = avs[ci]
            .points
            .iter()
            .find(|p| p.m == m)
            .unwrap_or_else(|| panic!("m={m} missing"));
        assert!((p.tau - f[2].parse::<f64>().unwrap()).abs() < 1e-12);
        let r = rel(p.avar, want);
        worst = worst.max(r);
        assert!(
            r < TOL_ADIS_EXTENDED,
            "{which} {} m={m}: {} vs {want} (rel {r:e})",
            f[0],
            p.avar
        );
        checked += 1;
    }
    // 6 columns x 18 dyadic scales (m = 2..2^18)
    assert_eq!(checked, 6 * 18);
    eprintln!("adis16405 {which}: {checked} values, worst relative difference {worst:e}");
}

#[test]
fn adis16405_imu1_matches_extended_precision_reference() {
    check_adis("imu1");
}

#[test]
fn adis16405_imu2_matches_extended_precision_reference() {
    check_adis("imu2");
}
