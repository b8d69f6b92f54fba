//! Autoregressive process of order p = 2 … 4 (`AR2`, `AR3`, `AR4`; order 1 is [`crate::Ar1`]).
//!
//! X_t = φ_1 X_{t−1} + … + φ_p X_{t−p} + ε_t, ε_t ~ N(0, σ²) (σ² the innovation variance,
//! unit², like AR1's `sigma2`). Stationarity (all roots of 1 − φ_1 z − … − φ_p z^p outside
//! the unit circle) is checked when built through the partial autocorrelations κ_1 … κ_p
//! (the Durbin-Levinson step-down): the process is stationary iff every |κ_k| < 1.

use crate::error::{ProcessError, Result};

/// Largest order supported by [`ArP`].
pub const AR_MAX_ORDER: usize = 4;

/// Autoregressive process of order p ∈ {2, 3, 4}: coefficients φ_1 … φ_p (dimensionless)
/// and innovation variance `sigma2` (unit²). Model-string syntax
/// `AR2(phi1=…, phi2=…, sigma2=…)`, likewise `AR3`, `AR4`.
///
/// AR(2) with complex roots (φ_1² + 4φ_2 < 0) is a damped oscillation, the response of a
/// resonant filter: ρ(h) = r^h (cos hθ + c sin hθ), r = √(−φ_2), cos θ = φ_1 / (2r).
///
/// ```
/// use processes::ArP;
/// let a = ArP::new(&[1.6, -0.8], 1.0)?;
/// assert_eq!(a.order(), 2);
/// // κ_2 = φ_2, κ_1 = φ_1 / (1 − φ_2)
/// let k = a.pacf();
/// assert!((k[1] + 0.8).abs() < 1e-15 && (k[0] - 1.6 / 1.8).abs() < 1e-15);
/// assert!(ArP::new(&[0.5, 0.6], 1.0).is_err()); // φ_1 + φ_2 ≥ 1: a unit root crossed
/// assert!(ArP::new(&[0.1; 5], 1.0).is_err()); // p > 4
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArP {
    pub(crate) p: u8,
    pub(crate) phi: [f64; AR_MAX_ORDER],
    pub(crate) sigma2: f64,
}

/// Partial autocorrelations of the AR polynomial φ (Durbin-Levinson step-down); `None` if
/// some |κ_k| ≥ 1 (not stationary) or a value is not finite.
pub(crate) fn step_down(phi: &[f64]) -> Option<Vec<f64>> {
    let p = phi.len();
    let mut a = phi.to_vec();
    let mut kappa = vec![0.0; p];
    for k in (1..=p).rev() {
        let kk = a[k - 1];
        if !(kk.is_finite() && kk.abs() < 1.0) {
            return None;
        }
        kappa[k - 1] = kk;
        let d = 1.0 - kk * kk;
        let prev: Vec<f64> = (1..k).map(|j| (a[j - 1] + kk * a[k - j - 1]) / d).collect();
        a[..k - 1].copy_from_slice(&prev);
    }
    Some(kappa)
}

/// Refuses AR coefficients φ (non-empty, finite) that are not stationary, for the process
/// `code` (an AR(p), or the AR part of an ARMA): some partial autocorrelation |κ_k| ≥ 1.
pub(crate) fn check_stationary(code: &'static str, phi: &[f64]) -> Result<()> {
    if step_down(phi).is_none() {
        return Err(ProcessError::InvalidParameter {
            process: code,
            name: "phi",
            value: phi.last().copied().unwrap_or(f64::NAN),
            requirement: "not stationary: a root of 1 − φ1 z − … − φp z^p lies on or inside the unit circle (some partial autocorrelation |κ_k| ≥ 1)",
        });
    }
    Ok(())
}

/// AR coefficients φ from partial autocorrelations κ (Durbin-Levinson step-up).
///
/// ```
/// use processes::ar_p::phi_from_pacf;
/// let phi = phi_from_pacf(&[0.5, -0.25]);
/// assert_eq!(phi, vec![0.5 * 1.25, -0.25]); // φ_1 = κ_1 (1 − κ_2), φ_2 = κ_2
/// ```
pub fn phi_from_pacf(kappa: &[f64]) -> Vec<f64> {
    let mut a: Vec<f64> = Vec::with_capacity(kappa.len());
    for (k, &kk) in kappa.iter().enumerate() {
        let next: Vec<f64> = (0..k).map(|j| a[j] - kk * a[k - 1 - j]).collect();
        a = next;
        a.push(kk);
    }
    a
}

impl ArP {
    /// Builds AR(p) from φ_1 … φ_p (p = `phi.len()` ∈ {2, 3, 4}) and σ² > 0 (unit²);
    /// errors name the offending parameter (`phi`, `sigma2`) and say why.
    ///
    /// ```
    /// use processes::ArP;
    /// assert!(ArP::new(&[0.5, 0.2], 2.0).is_ok());
    /// assert!(ArP::new(&[0.5, 0.2], 0.0).is_err());
    /// assert!(ArP::new(&[0.5], 1.0).is_err()); // order 1 is AR1
    /// ```
    pub fn new(phi: &[f64], sigma2: f64) -> Result<Self> {
        let p = phi.len();
        if !(2..=AR_MAX_ORDER).contains(&p) {
            return Err(ProcessError::InvalidArgument(format!(
                "AR(p) takes 2 to {AR_MAX_ORDER} coefficients (order 1 is AR1), got {p}"
            )));
        }
        let code = ["", "", "AR2", "AR3", "AR4"][p];
        if !(sigma2.is_finite() && sigma2 > 0.0) {
            return Err(ProcessError::InvalidParameter {
                process: code,
                name: "sigma2",
                value: sigma2,
                requirement: "must be finite and > 0",
            });
        }
        if let Some((i, &bad)) = phi.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(ProcessError::InvalidParameter {
                process: code,
                name: ["phi1", "phi2", "phi3", "phi4"][i],
                value: bad,
                requirement: "must be finite",
            });
        }
        check_stationary(code, phi)?;
        let mut a = [0.0; AR_MAX_ORDER];
        a[..p].copy_from_slice(phi);
        Ok(ArP {
            p: p as u8,
            phi: a,
            sigma2,
        })
    }

    /// Builds AR(p) from partial autocorrelations κ_k ∈ (−1, 1) and σ² (unit²).
    ///
    /// ```
    /// use processes::ArP;
    /// let a = ArP::from_pacf(&[0.3, -0.2, 0.1], 1.0)?;
    /// let k = a.pacf();
    /// assert!((k[0] - 0.3).abs() < 1e-15 && (k[2] - 0.1).abs() < 1e-15);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn from_pacf(kappa: &[f64], sigma2: f64) -> Result<Self> {
        ArP::new(&phi_from_pacf(kappa), sigma2)
    }

    /// The order p.
    ///
    /// ```
    /// assert_eq!(processes::ArP::new(&[0.1, 0.1, 0.1], 1.0)?.order(), 3);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn order(&self) -> usize {
        self.p as usize
    }

    /// φ_1 … φ_p (dimensionless).
    ///
    /// ```
    /// assert_eq!(processes::ArP::new(&[0.1, 0.2], 1.0)?.phi(), [0.1, 0.2]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn phi(&self) -> &[f64] {
        &self.phi[..self.p as usize]
    }

    /// Innovation variance σ² (unit²).
    ///
    /// ```
    /// assert_eq!(processes::ArP::new(&[0.1, 0.2], 3.0)?.sigma2(), 3.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn sigma2(&self) -> f64 {
        self.sigma2
    }

    /// Partial autocorrelations κ_1 … κ_p, each in (−1, 1).
    ///
    /// ```
    /// let a = processes::ArP::new(&[0.3, 0.0], 1.0)?;
    /// assert_eq!(a.pacf(), vec![0.3, 0.0]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn pacf(&self) -> Vec<f64> {
        step_down(self.phi()).unwrap_or_default()
    }

    /// Stationary variance γ(0) = σ² / Π_k (1 − κ_k²) (unit²).
    ///
    /// ```
    /// // φ_2 = 0 is AR(1): γ(0) = σ²/(1 − φ_1²)
    /// let a = processes::ArP::new(&[0.5, 0.0], 3.0)?;
    /// assert!((a.stationary_variance() - 4.0).abs() < 1e-15);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn stationary_variance(&self) -> f64 {
        self.sigma2 / self.pacf().iter().map(|k| 1.0 - k * k).product::<f64>()
    }

    /// Autocorrelations ρ(0) … ρ(n−1): ρ(1) … ρ(p) by the Durbin-Levinson recursion from the
    /// partial autocorrelations (the Yule-Walker solution), then ρ(h) = Σ φ_j ρ(h − j).
    ///
    /// ```
    /// let a = processes::ArP::new(&[0.5, 0.0], 1.0)?;
    /// let r = a.acf(4);
    /// assert!((r[3] - 0.125).abs() < 1e-15); // AR(1): φ^h
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn acf(&self, n: usize) -> Vec<f64> {
        let p = self.order();
        let kappa = self.pacf();
        let mut rho = Vec::with_capacity(n.max(p + 1));
        rho.push(1.0);
        let mut a: Vec<f64> = Vec::new();
        let mut v = 1.0;
        for (k, &kk) in kappa.iter().enumerate() {
            // ρ_{k+1} = κ_{k+1} v_k + Σ_j a^{(k)}_j ρ_{k+1−j}
            let s: f64 = (0..k).map(|j| a[j] * rho[k - j]).sum();
            rho.push(kk * v + s);
            let next: Vec<f64> = (0..k).map(|j| a[j] - kk * a[k - 1 - j]).collect();
            a = next;
            a.push(kk);
            v *= 1.0 - kk * kk;
        }
        let phi = self.phi();
        while rho.len() < n {
            let h = rho.len();
            rho.push((0..p).map(|j| phi[j] * rho[h - 1 - j]).sum());
        }
        rho.truncate(n);
        rho
    }

    /// Order-k prediction coefficients a^{(k)} and prediction-error variances (unit²) for
    /// k = 0 … p−1: the Cholesky factor of the stationary p×p Toeplitz covariance in
    /// Durbin-Levinson form, used to draw an exact stationary start.
    pub(crate) fn start_recursion(&self) -> Vec<(Vec<f64>, f64)> {
        let kappa = self.pacf();
        let mut out = Vec::with_capacity(self.order());
        let mut a: Vec<f64> = Vec::new();
        let mut v = self.stationary_variance();
        for (k, &kk) in kappa.iter().enumerate() {
            out.push((a.clone(), v));
            let next: Vec<f64> = (0..k).map(|j| a[j] - kk * a[k - 1 - j]).collect();
            a = next;
            a.push(kk);
            v *= 1.0 - kk * kk;
        }
        out
    }
}

impl ArP {
    /// Simulates X_1 … X_n exactly, stationary from the start, with seed `seed`: the first p
    /// values are drawn from the stationary law N(0, Γ_p) (Γ_p the Toeplitz matrix of the
    /// ACF) through its Durbin-Levinson (innovations) Cholesky factor, X_k = Σ a^{(k−1)}_j
    /// X_{k−j} + √v_{k−1} Z_k, then the recursion X_t = Σ φ_j X_{t−j} + σ Z_t runs on.
    /// Sequential (one pass, not chunked); `Model::simulate` does not take AR(p) yet.
    ///
    /// ```
    /// let a = processes::ArP::new(&[1.6, -0.8], 1.0)?;
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
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut x: Vec<f64> = Vec::with_capacity(n);
        for (a, v) in self.start_recursion().into_iter().take(n) {
            let k = x.len();
            let mean: f64 = (0..a.len()).map(|j| a[j] * x[k - 1 - j]).sum();
            let z: f64 = StandardNormal.sample(&mut rng);
            x.push(mean + v.sqrt() * z);
        }
        let (phi, sd, p) = (self.phi(), self.sigma2.sqrt(), self.order());
        while x.len() < n {
            let k = x.len();
            let mean: f64 = (0..p).map(|j| phi[j] * x[k - 1 - j]).sum();
            let z: f64 = StandardNormal.sample(&mut rng);
            x.push(mean + sd * z);
        }
        Ok(x)
    }
}
