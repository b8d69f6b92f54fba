//! Every invalid simulation request gives a descriptive error, never a panic.

use processes::{Model, Process, ProcessError, WhiteNoise};

fn model() -> Model {
    "WN(sigma2=1) + AR1(phi=0.5, sigma2=1)".parse().unwrap()
}

#[test]
fn slots_cannot_be_simulated() {
    let m: Model = "WN(sigma2=1) + 2*AR1".parse().unwrap();
    let expected = ProcessError::UnspecifiedComponent {
        index: 1,
        kind: "AR1",
    };
    assert_eq!(m.simulate(10, 1.0, 1).unwrap_err(), expected);
    assert_eq!(m.simulate_components(10, 1.0, 1).unwrap_err(), expected);
    assert_eq!(m.simulate_stream(10, 1.0, 1, 3).unwrap_err(), expected);
    assert!(expected.to_string().contains("slot to be estimated"));
}

#[test]
fn zero_samples_is_an_error() {
    let e = model().simulate(0, 1.0, 1).unwrap_err();
    assert!(matches!(e, ProcessError::InvalidArgument(_)));
    assert!(e.to_string().contains("0 samples"), "{e}");
    assert!(model().simulate_components(0, 1.0, 1).is_err());
    let p = Process::from(WhiteNoise::new(1.0).unwrap());
    assert!(p.simulate_into(&mut [], 1.0, 1, 0, 0).is_err());
}

#[test]
fn bad_rates_are_errors() {
    let p = Process::from(WhiteNoise::new(1.0).unwrap());
    for rate in [0.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let e = model().simulate(10, rate, 1).unwrap_err();
        assert!(matches!(e, ProcessError::InvalidRate(_)), "{rate}: {e:?}");
        assert!(e.to_string().contains("sampling rate"));
        assert!(model().simulate_components(10, rate, 1).is_err());
        assert!(p.simulate_into(&mut [0.0; 4], rate, 1, 0, 0).is_err());
    }
}

#[test]
fn a_gm_that_is_no_ar1_at_this_rate_is_an_error() {
    // β Δt = 1e-320: φ = e^{−βΔt} rounds to 1, outside (−1, 1).
    let m: Model = "GM(beta=1e-320, sigma2=1)".parse().unwrap();
    let e = m.simulate(10, 1.0, 1).unwrap_err();
    assert!(e.to_string().contains("phi = 1"), "{e}");
}

#[test]
fn overflowing_paths_are_errors_naming_the_index() {
    // X_t = ω t overflows f64 from t = 2 on.
    let m: Model = "DR(omega=1e308)".parse().unwrap();
    match m.simulate(10, 1.0, 1).unwrap_err() {
        ProcessError::NonFiniteValue { index, value, .. } => {
            assert_eq!(index, 1);
            assert!(value.is_infinite());
        }
        other => panic!("expected a non-finite value, got {other:?}"),
    }
    // A stationary variance v²/(1 − φ²) beyond f64.
    let m: Model = "AR1(phi=0.999999, sigma2=1e308)".parse().unwrap();
    assert!(matches!(
        m.simulate_components(5, 1.0, 1),
        Err(ProcessError::NonFiniteValue { index: 0, .. })
    ));
}

#[test]
fn impossible_lengths_are_errors() {
    // 2^60 samples = 8 EiB: the allocation is refused, not attempted.
    let e = model().simulate(1 << 60, 1.0, 1).unwrap_err();
    assert!(e.to_string().contains("cannot allocate"), "{e}");
    assert!(model().simulate(usize::MAX, 1.0, 1).is_err());
}
