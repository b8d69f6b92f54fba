//! Theoretical AV of MA(2) and ARMA(p, q) ([`processes::Arma`]) from the exact
//! autocovariance, and its gradient.

use crate::lemma42::KahanSum;
use processes::Arma;

/// Theoretical AV of an MA(2) / ARMA(p, q) at cluster size `m` (unit², samples), by Lemma 4.2
/// regrouped by lag, AV = 1/m² · [m(γ_0 − γ_m) + Σ_{0<k<m} (2m − 3k) γ_k − Σ_{m<k<2m} (2m − k) γ_k],
/// with γ_0 … γ_{max(p, q)} exact ([`Arma::acvf`]) and γ_k = Σ φ_j γ_{k−j} beyond q. The sum
/// stops once k > q and the last max(p, 1) values of |γ| are below 1e-20 γ_0 (the ACF decays
/// geometrically, so the rest is below f64 resolution of the sum; for MA(2) the sum is
/// finite and exact: γ_k = 0 for k > 2). O(min(m, decay length)).
///
/// ```
/// use processes::Arma;
/// use spectral::arma::arma_avar;
/// // MA(2), m ≥ 3: AV = [m γ0 + (2m − 3) γ1 + (2m − 6) γ2] / m²
/// let a = Arma::new(&[], &[0.5, 0.25], 2.0)?;
/// let (g0, g1, g2) = (2.0 * 1.3125, 2.0 * 0.625, 2.0 * 0.25);
/// let m = 10.0;
/// let want = (m * g0 + (2.0 * m - 3.0) * g1 + (2.0 * m - 6.0) * g2) / (m * m);
/// assert!((arma_avar(&a, 10) - want).abs() < 1e-15 * want);
/// # Ok::<(), processes::ProcessError>(())
/// ```
pub fn arma_avar(a: &Arma, m: u64) -> f64 {
    let (p, q) = (a.p(), a.q());
    let phi = a.phi();
    let mut g = a.acvf(p.max(q) + 1);
    let g0 = g[0];
    let mf = m as f64;
    let mut b = KahanSum::default();
    b.add(mf * g0);
    let w = |k: u64| -> f64 {
        if k < m {
            2.0 * mf - 3.0 * k as f64
        } else if k == m {
            -mf
        } else {
            -(2.0 * mf - k as f64)
        }
    };
    let tail = p.max(1);
    let mut k = 1u64;
    while k < 2 * m {
        let i = k as usize;
        if i >= g.len() {
            let v: f64 = (0..p).map(|j| phi[j] * g[i - 1 - j]).sum();
            g.push(v);
        }
        b.add_product(w(k), g[i]);
        if i > q && i >= tail && g[i + 1 - tail..=i].iter().all(|x| x.abs() < 1e-20 * g0) {
            break;
        }
        k += 1;
    }
    b.value() / (mf * mf)
}

/// [`arma_avar`] and its gradient in the order of [`Arma::params`] (φ, θ, σ²): ∂AV/∂σ² =
/// AV/σ² (AV ∝ σ²); ∂AV/∂φ_j and ∂AV/∂θ_j by central differences (step 1e-6, one-sided
/// where a step in φ would leave the stationary region).
///
/// ```
/// use processes::Arma;
/// use spectral::arma::arma_avar_gradient;
/// let a = Arma::new(&[0.5], &[0.3], 2.0)?;
/// let (av, g) = arma_avar_gradient(&a, 8);
/// assert_eq!(g.len(), 3);
/// assert!((g[2] - av / 2.0).abs() < 1e-15 * av);
/// # Ok::<(), processes::ProcessError>(())
/// ```
pub fn arma_avar_gradient(a: &Arma, m: u64) -> (f64, Vec<f64>) {
    let av = arma_avar(a, m);
    let mut v = a.params();
    let n = v.len() - 1;
    let mut g = Vec::with_capacity(n + 1);
    for j in 0..n {
        let h = 1e-6;
        let mut at = |d: f64| {
            let x = v[j];
            v[j] = x + d;
            let r = Arma::new(&v[..a.p()], &v[a.p()..n], a.sigma2())
                .ok()
                .map(|b| arma_avar(&b, m));
            v[j] = x;
            r
        };
        let (u, dn) = (at(h), at(-h));
        g.push(match (u, dn) {
            (Some(u), Some(d)) => (u - d) / (2.0 * h),
            (Some(u), None) => (u - av) / h,
            (None, Some(d)) => (av - d) / h,
            (None, None) => f64::NAN,
        });
    }
    g.push(av / a.sigma2());
    (av, g)
}
