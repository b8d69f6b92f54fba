//! Shared helpers of the statistical tests: sample moments, their asymptotic standard
//! errors from theory, and a plain Allan variance (book eq. 4.2).
#![allow(dead_code)] // each test binary uses a subset

use processes::Model;

/// Tolerance of every Monte Carlo check, in standard errors. With fixed seeds a check
/// either always passes or always fails; 4 SE makes a spurious failure of one check a
/// 6e-5 event when the seed is changed.
pub const N_SE: f64 = 4.0;

/// Sample mean.
pub fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Sample autocovariance γ̂(h) = (1/n) Σ_{t=1}^{n−h} (x_t − x̄)(x_{t+h} − x̄).
pub fn acov(x: &[f64], h: usize) -> f64 {
    let m = mean(x);
    let n = x.len();
    x[..n - h]
        .iter()
        .zip(&x[h..])
        .map(|(a, b)| (a - m) * (b - m))
        .sum::<f64>()
        / n as f64
}

/// Theoretical autocovariance of a stationary model at `rate_hz`.
pub fn gamma(model: &Model, h: u64, rate_hz: f64) -> f64 {
    model.autocovariance(h, rate_hz).expect("stationary model")
}

/// Largest lag summed in the long-run sums below: beyond it every process used in the
/// tests has |ρ(h)| < 0.99^20000 ≈ 2e-88, so the truncation is far below rounding.
const MAX_LAG: u64 = 20_000;

/// Exact variance of the sample mean of n values of a stationary process:
/// Var(x̄) = (1/n) [γ(0) + 2 Σ_{h=1}^{n−1} (1 − h/n) γ(h)].
pub fn se_mean(model: &Model, n: usize, rate_hz: f64) -> f64 {
    let nf = n as f64;
    let mut s = gamma(model, 0, rate_hz);
    for h in 1..(n as u64).min(MAX_LAG) {
        s += 2.0 * (1.0 - h as f64 / nf) * gamma(model, h, rate_hz);
    }
    (s / nf).sqrt()
}

/// Asymptotic SE of the sample variance γ̂(0) of a linear process with iid noise of
/// kurtosis η = E e⁴ / σ⁴ (Bartlett's formula, Brockwell & Davis Prop. 7.3.1):
/// n Var(γ̂(0)) → (η − 3) γ(0)² + 2 Σ_{h=−∞}^{∞} γ(h)². Gaussian processes (and sums of
/// independent Gaussian processes) have η = 3.
pub fn se_variance(model: &Model, n: usize, rate_hz: f64, eta: f64) -> f64 {
    let g0 = gamma(model, 0, rate_hz);
    let mut s = g0 * g0;
    for h in 1..MAX_LAG {
        s += 2.0 * gamma(model, h, rate_hz).powi(2);
    }
    (((eta - 3.0) * g0 * g0 + 2.0 * s) / n as f64).sqrt()
}

/// Asymptotic SE of the sample autocorrelation ρ̂(h) of a linear process with iid noise
/// (Bartlett's formula, Brockwell & Davis Thm. 7.2.1):
/// n Var(ρ̂(h)) → w_hh = Σ_{k=1}^{∞} [ρ(k+h) + ρ(k−h) − 2ρ(h)ρ(k)]².
pub fn se_acf(model: &Model, h: u64, n: usize, rate_hz: f64) -> f64 {
    let rho = |k: i64| {
        model
            .autocorrelation(k.unsigned_abs(), rate_hz)
            .expect("stationary model")
    };
    let h = h as i64;
    let rh = rho(h);
    let w: f64 = (1..MAX_LAG as i64)
        .map(|k| (rho(k + h) + rho(k - h) - 2.0 * rh * rho(k)).powi(2))
        .sum();
    (w / n as f64).sqrt()
}

/// Asserts |estimate − theory| ≤ N_SE · se, printing the context on failure.
pub fn assert_within(what: &str, estimate: f64, theory: f64, se: f64) {
    let z = (estimate - theory) / se;
    assert!(
        z.abs() <= N_SE,
        "{what}: estimate {estimate:.6e}, theory {theory:.6e}, SE {se:.3e}, z = {z:.2}"
    );
}

/// Maximal-overlap Allan variance, book eq. 4.2, computed directly:
/// AV(m) = 1/(2(T − 2m + 1)) Σ_{k=2m}^{T} (X̄_k − X̄_{k−m})², X̄_k the mean of X_{k−m+1..k}.
/// With cumulative sums C_k (C_0 = 0): X̄_k − X̄_{k−m} = (C_k − 2C_{k−m} + C_{k−2m}) / m.
pub fn moav(x: &[f64], m: usize) -> f64 {
    let t = x.len();
    assert!(t >= 2 * m, "need at least 2m samples");
    let mut c = Vec::with_capacity(t + 1);
    c.push(0.0);
    let mut s = 0.0;
    for v in x {
        s += v;
        c.push(s);
    }
    let mf = m as f64;
    let sum: f64 = (2 * m..=t)
        .map(|k| ((c[k] - 2.0 * c[k - m] + c[k - 2 * m]) / mf).powi(2))
        .sum();
    sum / (2.0 * (t - 2 * m + 1) as f64)
}
