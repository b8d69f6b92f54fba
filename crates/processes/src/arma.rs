//! Moving average of order 2 (`MA2`) and ARMA(p, q) with p ≤ 4, q ≤ 2 (`ARMA11` … `ARMA42`).
//!
//! X_t = φ_1 X_{t−1} + … + φ_p X_{t−p} + W_t + θ_1 W_{t−1} + … + θ_q W_{t−q},
//! W_t ~ N(0, σ²) (σ² the innovation variance, unit², like MA1's and AR(p)'s `sigma2`).
//! MA(1) stays [`crate::Ma1`] and AR(p) stays [`crate::Ar1`] / [`crate::ArP`]: an [`Arma`]
//! has q ≥ 1 and is either MA(2) (p = 0) or has p ≥ 1.
//!
//! # Validation
//! - AR part: stationary, i.e. every root of 1 − φ_1 z − … − φ_p z^p outside the unit
//!   circle, checked as for [`crate::ArP`] through the partial autocorrelations (every
//!   |κ_k| < 1, the Durbin-Levinson step-down).
//! - MA part: finite coefficients only, as for MA1. Any θ gives a stationary process, so
//!   simulation and theory take every θ. Invertibility (roots of 1 + θ_1 z + … + θ_q z^q
//!   outside the unit circle) is **not** required when built, but the AV (like every
//!   second-order quantity) cannot tell a root ζ from 1/ζ̄ — the MA polynomials with a root
//!   flipped give the same autocovariance up to σ² — so the fit (`gmwm-prep`) searches
//!   the invertible region only (the "partial autocorrelations" of −θ through tanh, as MA1's
//!   θ = tanh η), which is the identifiability rule. [`Arma::is_invertible`] says which.
//! - A common factor of the AR and MA polynomials (e.g. ARMA(1,1) with θ_1 = −φ_1, which is
//!   white noise) is a valid process but not identifiable; it is not refused.
//!
//! # Autocovariance (exact)
//! With Y_t = θ(B) W_t (MA part, γ_Y(k) = σ² Σ_j θ_j θ_{j+|k|}, θ_0 = 1, zero for |k| > q)
//! and g the autocovariance of the AR(p) with unit innovation variance
//! ([`ar_unit_acvf`], Durbin-Levinson), X = φ(B)⁻¹ Y has
//! γ_X(h) = Σ_{|k| ≤ q} γ_Y(k) g(h − k): a finite sum of exact terms.

use crate::ar_p::{AR_MAX_ORDER, check_stationary, phi_from_pacf, step_down};
use crate::error::{ProcessError, Result};

/// Largest MA order of an [`Arma`].
pub const MA_MAX_ORDER: usize = 2;

/// Model-string codes of the (p, q) orders: `CODES[p][q]`; "" where (p, q) is not an
/// [`Arma`] (q = 0 is AR(p), (0, 1) is MA1).
pub(crate) const CODES: [[&str; 3]; 5] = [
    ["", "", "MA2"],
    ["", "ARMA11", "ARMA12"],
    ["", "ARMA21", "ARMA22"],
    ["", "ARMA31", "ARMA32"],
    ["", "ARMA41", "ARMA42"],
];

/// The (p, q) orders of [`Arma`]: (0, 2), then p = 1 … 4 with q = 1, 2.
pub(crate) fn orders() -> impl Iterator<Item = (usize, usize)> {
    (0..=AR_MAX_ORDER).flat_map(|p| {
        (1..=MA_MAX_ORDER)
            .map(move |q| (p, q))
            .filter(|&(p, q)| is_arma_order(p, q))
    })
}

/// Parameter names of the (p, q) orders, `NAMES[p][q]`: φ_1 … φ_p, θ_1 … θ_q, σ².
pub(crate) const NAMES: [[&[&str]; 3]; 5] = [
    [&[], &[], &["theta1", "theta2", "sigma2"]],
    [
        &[],
        &["phi1", "theta1", "sigma2"],
        &["phi1", "theta1", "theta2", "sigma2"],
    ],
    [
        &[],
        &["phi1", "phi2", "theta1", "sigma2"],
        &["phi1", "phi2", "theta1", "theta2", "sigma2"],
    ],
    [
        &[],
        &["phi1", "phi2", "phi3", "theta1", "sigma2"],
        &["phi1", "phi2", "phi3", "theta1", "theta2", "sigma2"],
    ],
    [
        &[],
        &["phi1", "phi2", "phi3", "phi4", "theta1", "sigma2"],
        &["phi1", "phi2", "phi3", "phi4", "theta1", "theta2", "sigma2"],
    ],
];

/// Whether (p, q) is the order of an [`Arma`]: q ∈ {1, 2}, p ≤ 4, and not (0, 1) (MA1).
///
/// ```
/// use processes::arma::is_arma_order;
/// assert!(is_arma_order(0, 2) && is_arma_order(2, 1) && is_arma_order(4, 2));
/// assert!(!is_arma_order(0, 1) && !is_arma_order(2, 0) && !is_arma_order(5, 1));
/// ```
pub fn is_arma_order(p: usize, q: usize) -> bool {
    p <= AR_MAX_ORDER && (1..=MA_MAX_ORDER).contains(&q) && !(p == 0 && q == 1)
}

/// Autocovariance g(0) … g(n−1) of the AR(p) φ(B) X = W with **unit** innovation variance,
/// for any p ≤ 4 (p = 0: g = 1, 0, 0, …); `None` if φ is not stationary. ρ by the
/// Durbin-Levinson recursion from the partial autocorrelations, γ(0) = 1/Π(1 − κ_k²).
///
/// ```
/// use processes::arma::ar_unit_acvf;
/// let g = ar_unit_acvf(&[0.5], 3).unwrap();
/// assert!((g[0] - 1.0 / 0.75).abs() < 1e-15 && (g[2] - 0.25 / 0.75).abs() < 1e-15);
/// assert_eq!(ar_unit_acvf(&[], 3), Some(vec![1.0, 0.0, 0.0]));
/// assert!(ar_unit_acvf(&[1.0], 3).is_none());
/// ```
pub fn ar_unit_acvf(phi: &[f64], n: usize) -> Option<Vec<f64>> {
    let p = phi.len();
    let kappa = step_down(phi)?;
    let mut rho = Vec::with_capacity(n.max(p + 1));
    rho.push(1.0);
    let mut a: Vec<f64> = Vec::new();
    let mut v = 1.0;
    for (k, &kk) in kappa.iter().enumerate() {
        let s: f64 = (0..k).map(|j| a[j] * rho[k - j]).sum();
        rho.push(kk * v + s);
        let next: Vec<f64> = (0..k).map(|j| a[j] - kk * a[k - 1 - j]).collect();
        a = next;
        a.push(kk);
        v *= 1.0 - kk * kk;
    }
    while rho.len() < n {
        let h = rho.len();
        rho.push((0..p).map(|j| phi[j] * rho[h - 1 - j]).sum());
    }
    rho.truncate(n);
    let g0 = 1.0 / kappa.iter().map(|k| 1.0 - k * k).product::<f64>();
    Some(rho.into_iter().map(|r| g0 * r).collect())
}

/// Exact autocovariance γ(0) … γ(n−1) (unit²) of the ARMA(p, q) with coefficients φ
/// (p ≤ 4, stationary), θ (q ≤ 2, any finite) and innovation variance σ²: for any orders,
/// including q = 0 (AR(p)) and p = 0 (MA(q)). γ(h) = Σ_{|k| ≤ q} γ_Y(k) g(h − k) (see the
/// module docs). `None` if φ is not stationary.
///
/// ```
/// use processes::arma::arma_acvf;
/// // MA(1): γ(0) = σ²(1 + θ²), γ(1) = σ²θ, then 0
/// let g = arma_acvf(&[], &[0.5], 2.0, 4).unwrap();
/// assert_eq!(g, vec![2.5, 1.0, 0.0, 0.0]);
/// ```
pub fn arma_acvf(phi: &[f64], theta: &[f64], sigma2: f64, n: usize) -> Option<Vec<f64>> {
    let q = theta.len();
    let g = ar_unit_acvf(phi, n + q)?;
    let mut t = vec![1.0];
    t.extend_from_slice(theta);
    // γ_Y(k), k = 0 … q
    let gy: Vec<f64> = (0..=q)
        .map(|k| sigma2 * (0..=q - k).map(|j| t[j] * t[j + k]).sum::<f64>())
        .collect();
    Some(
        (0..n)
            .map(|h| {
                let mut s = gy[0] * g[h];
                for (k, &c) in gy.iter().enumerate().skip(1) {
                    s += c * (g[h + k] + g[h.abs_diff(k)]);
                }
                s
            })
            .collect(),
    )
}

/// ψ-weights ψ_0 … ψ_{n−1} of X_t = Σ ψ_j W_{t−j}: ψ_0 = 1,
/// ψ_j = θ_j + Σ_{k=1}^{min(j,p)} φ_k ψ_{j−k} (θ_j = 0 for j > q).
///
/// ```
/// use processes::arma::psi_weights;
/// // ARMA(1,1): ψ_j = (φ + θ) φ^{j−1}
/// let psi = psi_weights(&[0.5], &[0.3], 4);
/// for (j, want) in [1.0, 0.8, 0.4, 0.2].iter().enumerate() {
///     assert!((psi[j] - want).abs() < 1e-15);
/// }
/// ```
pub fn psi_weights(phi: &[f64], theta: &[f64], n: usize) -> Vec<f64> {
    let mut psi: Vec<f64> = Vec::with_capacity(n);
    for j in 0..n {
        let mut v = if j == 0 {
            1.0
        } else {
            theta.get(j - 1).copied().unwrap_or(0.0)
        };
        for k in 1..=phi.len().min(j) {
            v += phi[k - 1] * psi[j - k];
        }
        psi.push(v);
    }
    psi
}

/// MA(2) or ARMA(p, q), p ≤ 4, q ∈ {1, 2} (not (0, 1): that is MA1; q = 0 is AR(p)):
/// coefficients φ_1 … φ_p, θ_1 … θ_q (dimensionless) and innovation variance `sigma2`
/// (unit²). Model-string syntax `MA2(theta1=…, theta2=…, sigma2=…)` and `ARMApq(phi1=…, …,
/// phip=…, theta1=…, …, thetaq=…, sigma2=…)` with the two digits p, q, e.g.
/// `ARMA21(phi1=1.2, phi2=-0.8, theta1=0.4, sigma2=1e-4)`.
///
/// ```
/// use processes::Arma;
/// let a = Arma::new(&[0.5], &[0.3], 2.0)?;
/// assert_eq!((a.p(), a.q(), a.code()), (1, 1, "ARMA11"));
/// // γ(1)/γ(0) of ARMA(1,1): (1 + φθ)(φ + θ) / (1 + 2φθ + θ²)
/// let g = a.acvf(2);
/// assert!((g[1] / g[0] - 1.15 * 0.8 / 1.39).abs() < 1e-15);
/// assert!(Arma::new(&[1.1], &[0.3], 1.0).is_err()); // not stationary
/// assert!(Arma::new(&[], &[0.3], 1.0).is_err()); // MA(1) is MA1
/// assert!(Arma::new(&[], &[2.0, 0.5], 1.0)?.is_invertible() == false);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arma {
    pub(crate) p: u8,
    pub(crate) q: u8,
    pub(crate) phi: [f64; AR_MAX_ORDER],
    pub(crate) theta: [f64; MA_MAX_ORDER],
    pub(crate) sigma2: f64,
}

impl Arma {
    /// Builds MA(2) (`phi` empty, two θ) or ARMA(p, q) from φ (p = `phi.len()` ≤ 4), θ
    /// (q = `theta.len()` ∈ {1, 2}) and σ² > 0 (unit²). Errors name the offending parameter
    /// and say why: a non-finite value, σ² ≤ 0, a non-stationary AR part, an order that is
    /// not an ARMA's (q = 0 is AR(p), (0, 1) is MA1).
    ///
    /// ```
    /// use processes::Arma;
    /// assert!(Arma::new(&[1.6, -0.8], &[0.5, 0.2], 1.0).is_ok());
    /// assert!(Arma::new(&[0.5, 0.6], &[0.1], 1.0).is_err()); // φ1 + φ2 ≥ 1
    /// assert!(Arma::new(&[0.5], &[f64::NAN], 1.0).is_err());
    /// assert!(Arma::new(&[0.5], &[0.1], 0.0).is_err());
    /// ```
    pub fn new(phi: &[f64], theta: &[f64], sigma2: f64) -> Result<Self> {
        let (p, q) = (phi.len(), theta.len());
        if !is_arma_order(p, q) {
            return Err(ProcessError::InvalidArgument(format!(
                "ARMA(p, q) takes p ≤ {AR_MAX_ORDER} AR and q = 1 or 2 MA coefficients (MA(1) is MA1, q = 0 is AR(p)), got p = {p}, q = {q}"
            )));
        }
        let code = CODES[p][q];
        let names = NAMES[p][q];
        if !(sigma2.is_finite() && sigma2 > 0.0) {
            return Err(ProcessError::InvalidParameter {
                process: code,
                name: "sigma2",
                value: sigma2,
                requirement: "must be finite and > 0",
            });
        }
        if let Some((i, &bad)) = phi
            .iter()
            .chain(theta)
            .enumerate()
            .find(|(_, x)| !x.is_finite())
        {
            return Err(ProcessError::InvalidParameter {
                process: code,
                name: names[i],
                value: bad,
                requirement: "must be finite",
            });
        }
        if p > 0 {
            check_stationary(code, phi)?;
        }
        let mut a = [0.0; AR_MAX_ORDER];
        a[..p].copy_from_slice(phi);
        let mut t = [0.0; MA_MAX_ORDER];
        t[..q].copy_from_slice(theta);
        Ok(Arma {
            p: p as u8,
            q: q as u8,
            phi: a,
            theta: t,
            sigma2,
        })
    }

    /// Builds from the parameters in model order (φ_1 … φ_p, θ_1 … θ_q, σ²).
    pub(crate) fn from_params(p: usize, q: usize, v: &[f64]) -> Result<Self> {
        if v.len() != p + q + 1 {
            return Err(ProcessError::InvalidArgument(format!(
                "ARMA({p},{q}) takes {} parameters, got {}",
                p + q + 1,
                v.len()
            )));
        }
        Arma::new(&v[..p], &v[p..p + q], v[p + q])
    }

    /// The AR order p (0 … 4).
    ///
    /// ```
    /// assert_eq!(processes::Arma::new(&[], &[0.1, 0.2], 1.0)?.p(), 0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn p(&self) -> usize {
        self.p as usize
    }

    /// The MA order q (1 or 2).
    ///
    /// ```
    /// assert_eq!(processes::Arma::new(&[0.3], &[0.1, 0.2], 1.0)?.q(), 2);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn q(&self) -> usize {
        self.q as usize
    }

    /// The model-string code, `MA2` or `ARMApq`.
    ///
    /// ```
    /// assert_eq!(processes::Arma::new(&[0.3, 0.1], &[0.1], 1.0)?.code(), "ARMA21");
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn code(&self) -> &'static str {
        CODES[self.p()][self.q()]
    }

    /// φ_1 … φ_p (dimensionless).
    ///
    /// ```
    /// assert_eq!(processes::Arma::new(&[0.3], &[0.1], 1.0)?.phi(), [0.3]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn phi(&self) -> &[f64] {
        &self.phi[..self.p()]
    }

    /// θ_1 … θ_q (dimensionless).
    ///
    /// ```
    /// assert_eq!(processes::Arma::new(&[0.3], &[0.1, -0.2], 1.0)?.theta(), [0.1, -0.2]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn theta(&self) -> &[f64] {
        &self.theta[..self.q()]
    }

    /// Innovation variance σ² (unit²).
    ///
    /// ```
    /// assert_eq!(processes::Arma::new(&[0.3], &[0.1], 4.0)?.sigma2(), 4.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }

    /// The parameters in model order: φ_1 … φ_p, θ_1 … θ_q, σ².
    ///
    /// ```
    /// let a = processes::Arma::new(&[0.3], &[0.1], 4.0)?;
    /// assert_eq!(a.params(), vec![0.3, 0.1, 4.0]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn params(&self) -> Vec<f64> {
        let mut v = self.phi().to_vec();
        v.extend_from_slice(self.theta());
        v.push(self.sigma2);
        v
    }

    /// Whether the MA part is invertible: every root of 1 + θ_1 z + … + θ_q z^q lies
    /// strictly outside the unit circle (the region the fit searches).
    ///
    /// ```
    /// use processes::Arma;
    /// assert!(Arma::new(&[], &[0.5, 0.3], 1.0)?.is_invertible());
    /// assert!(!Arma::new(&[0.2], &[-1.0], 1.0)?.is_invertible()); // root z = 1
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn is_invertible(&self) -> bool {
        let neg: Vec<f64> = self.theta().iter().map(|t| -t).collect();
        step_down(&neg).is_some()
    }

    /// Autocovariance γ(0) … γ(n−1) (unit²), exact (see the module docs).
    ///
    /// ```
    /// // MA(2): γ(0) = σ²(1 + θ1² + θ2²), γ(1) = σ²(θ1 + θ1θ2), γ(2) = σ²θ2, then 0
    /// let a = processes::Arma::new(&[], &[0.5, 0.25], 2.0)?;
    /// let g = a.acvf(4);
    /// assert_eq!(g, vec![2.0 * 1.3125, 2.0 * 0.625, 0.5, 0.0]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn acvf(&self, n: usize) -> Vec<f64> {
        arma_acvf(self.phi(), self.theta(), self.sigma2, n).unwrap_or_default()
    }

    /// Stationary variance γ(0) (unit²).
    ///
    /// ```
    /// let a = processes::Arma::new(&[0.5], &[0.5], 1.0)?;
    /// // ARMA(1,1): σ²(1 + 2φθ + θ²)/(1 − φ²)
    /// assert!((a.stationary_variance() - 1.75 / 0.75).abs() < 1e-15);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn stationary_variance(&self) -> f64 {
        self.acvf(1).first().copied().unwrap_or(f64::NAN)
    }

    /// Long-run variance S = Σ_h γ(h) = σ² θ(1)² / φ(1)² (unit²): the white-noise level the
    /// AV approaches, AV(m) ≈ S/m for large m.
    ///
    /// ```
    /// let a = processes::Arma::new(&[0.5], &[0.5], 1.0)?;
    /// assert!((a.long_run_variance() - 9.0).abs() < 1e-15); // 1.5² / 0.5²
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn long_run_variance(&self) -> f64 {
        let th: f64 = 1.0 + self.theta().iter().sum::<f64>();
        let ph: f64 = 1.0 - self.phi().iter().sum::<f64>();
        self.sigma2 * th * th / (ph * ph)
    }

    /// Covariance (row-major, (p+q)×(p+q)) of the stationary state
    /// (X_0, X_{−1}, …, X_{1−p}, W_0, W_{−1}, …, W_{1−q}): Cov(X_{−i}, X_{−j}) = γ(|i−j|),
    /// Cov(X_{−i}, W_{−j}) = σ² ψ_{j−i} (j ≥ i, else 0), Cov(W_{−i}, W_{−j}) = σ² δ_ij.
    fn state_covariance(&self) -> Vec<f64> {
        let (p, q) = (self.p(), self.q());
        let d = p + q;
        let g = self.acvf(p.max(1));
        let psi = psi_weights(self.phi(), self.theta(), q + 1);
        let mut c = vec![0.0; d * d];
        for i in 0..p {
            for j in 0..p {
                c[i * d + j] = g[i.abs_diff(j)];
            }
            for j in 0..q {
                let v = if j >= i {
                    self.sigma2 * psi[j - i]
                } else {
                    0.0
                };
                c[i * d + p + j] = v;
                c[(p + j) * d + i] = v;
            }
        }
        for j in 0..q {
            c[(p + j) * d + p + j] = self.sigma2;
        }
        c
    }

    /// Simulates X_1 … X_n exactly, stationary from the start, with seed `seed`: the state
    /// (X_0 … X_{1−p}, W_0 … W_{1−q}) is drawn from its stationary Gaussian law (Cholesky
    /// factor of its (p+q)×(p+q) covariance: γ, σ²ψ and σ²I blocks), then
    /// X_t = Σ φ_j X_{t−j} + W_t + Σ θ_j W_{t−j} runs on with W_t iid N(0, σ²).
    /// Sequential (one pass); `Model::simulate` calls it for ARMA/MA2 components.
    ///
    /// ```
    /// let a = processes::Arma::new(&[1.6, -0.8], &[0.4], 1.0)?;
    /// let x = a.simulate(1000, 7)?;
    /// assert_eq!(x.len(), 1000);
    /// assert_eq!(x, a.simulate(1000, 7)?); // reproducible
    /// assert!(a.simulate(0, 7).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn simulate(&self, n: usize, seed: u64) -> Result<Vec<f64>> {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        if n == 0 {
            return Err(ProcessError::InvalidArgument(
                "cannot simulate 0 samples (n must be at least 1)".into(),
            ));
        }
        let (p, q) = (self.p(), self.q());
        let d = p + q;
        let c = self.state_covariance();
        // Cholesky L Lᵀ = C (a pivot that rounds to ≤ 0 is a deterministic direction: 0)
        let mut l = vec![0.0; d * d];
        for i in 0..d {
            for j in 0..=i {
                let s: f64 = (0..j).map(|k| l[i * d + k] * l[j * d + k]).sum();
                if i == j {
                    l[i * d + i] = (c[i * d + i] - s).max(0.0).sqrt();
                } else {
                    let djj = l[j * d + j];
                    l[i * d + j] = if djj > 0.0 {
                        (c[i * d + j] - s) / djj
                    } else {
                        0.0
                    };
                }
            }
        }
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let z: Vec<f64> = (0..d).map(|_| StandardNormal.sample(&mut rng)).collect();
        let state: Vec<f64> = (0..d)
            .map(|i| (0..=i).map(|k| l[i * d + k] * z[k]).sum())
            .collect();
        // xs[k] = X_{1−p+k−…}: keep the p last X and q last W, newest first
        let mut xs: Vec<f64> = state[..p].to_vec();
        let mut ws: Vec<f64> = state[p..].to_vec();
        let (phi, theta, sd) = (self.phi(), self.theta(), self.sigma2.sqrt());
        let mut x = Vec::with_capacity(n);
        for _ in 0..n {
            let z: f64 = StandardNormal.sample(&mut rng);
            let w = sd * z;
            let mut v = w;
            for j in 0..p {
                v += phi[j] * xs[j];
            }
            for j in 0..q {
                v += theta[j] * ws[j];
            }
            if p > 0 {
                xs.rotate_right(1);
                xs[0] = v;
            }
            ws.rotate_right(1);
            ws[0] = w;
            x.push(v);
        }
        Ok(x)
    }
}

/// θ of the invertible MA polynomial with "partial autocorrelations" κ ∈ (−1, 1)^q of −θ:
/// θ = −step-up(κ). The fit's map onto the invertible region.
///
/// ```
/// use processes::arma::theta_from_pacf;
/// assert_eq!(theta_from_pacf(&[0.5]), vec![-0.5]);
/// ```
pub fn theta_from_pacf(kappa: &[f64]) -> Vec<f64> {
    phi_from_pacf(kappa).into_iter().map(|x| -x).collect()
}

/// The "partial autocorrelations" κ of −θ (inverse of [`theta_from_pacf`]); `None` if θ is
/// not invertible.
///
/// ```
/// use processes::arma::{pacf_of_theta, theta_from_pacf};
/// let k = pacf_of_theta(&theta_from_pacf(&[0.3, -0.6])).unwrap();
/// assert!((k[0] - 0.3).abs() < 1e-15 && (k[1] + 0.6).abs() < 1e-15);
/// assert!(pacf_of_theta(&[2.0]).is_none());
/// ```
pub fn pacf_of_theta(theta: &[f64]) -> Option<Vec<f64>> {
    let neg: Vec<f64> = theta.iter().map(|t| -t).collect();
    step_down(&neg)
}

/// Partial autocorrelations κ of the AR polynomial φ (any p ≤ 4; empty for p = 0); `None`
/// if φ is not stationary. Inverse of [`crate::ar_p::phi_from_pacf`].
///
/// ```
/// use processes::arma::pacf_of_phi;
/// assert_eq!(pacf_of_phi(&[0.5]), Some(vec![0.5]));
/// assert_eq!(pacf_of_phi(&[]), Some(vec![]));
/// assert!(pacf_of_phi(&[0.5, 0.6]).is_none());
/// ```
pub fn pacf_of_phi(phi: &[f64]) -> Option<Vec<f64>> {
    step_down(phi)
}
