//! Model-based covariance of the maximum-overlapping AV estimates (the machinery behind
//! [`crate::inference::model_covariance`], where the derivation is stated).
//!
//! Everything is expressed through V(h) = Var(C_{t+h} − C_t), the variogram of the
//! cumulative sum C of the process (a generalized covariance −V/2 for RW, whose C has no
//! stationary increments), and the lag sum Σ_k N(k) g(k)² is evaluated exactly near every
//! kink of the summand and by graded Gauss–Legendre panels (with the Euler–Maclaurin end
//! correction) in between, where the summand is a smooth polynomial-times-exponential.

use crate::cov_matrix::CovMatrix;
use crate::error::{FitError, Result};
use processes::{Model, Process};

/// Direct summation at each end of a smooth stretch (and of every stretch shorter than 4×).
const DIRECT: i64 = 16;
/// Width of the first Gauss panel; later panels double (graded towards the kinks).
const FIRST_PANEL: f64 = 16.0;

/// 8-point Gauss–Legendre nodes and weights on [−1, 1] (positive half).
const GL_X: [f64; 4] = [
    0.183_434_642_495_649_8,
    0.525_532_409_916_329,
    0.796_666_477_413_626_7,
    0.960_289_856_497_536_3,
];
const GL_W: [f64; 4] = [
    0.362_683_783_378_362,
    0.313_706_645_877_887_3,
    0.222_381_034_453_374_5,
    0.101_228_536_290_376_3,
];

/// An AR1 (or GM as AR1) term of V.
#[derive(Debug, Clone, Copy)]
struct ArTerm {
    phi: f64,
    /// λ = −ln φ (φ > 0) or −ln|φ| (φ < 0); unused for φ = 0.
    lam: f64,
    /// 2φγ(0)/(1−φ)² (φ > 0 form) or γ(0)/(1−φ)² (φ ≤ 0 form).
    scale: f64,
    /// sinh λ − λ, without cancellation (φ > 0 form).
    sinh_minus: f64,
}

/// V(h) of a sum of independent components (h ≠ 0 forms plus V(0) = 0).
#[derive(Debug, Clone, Default)]
pub(crate) struct Variogram {
    /// coefficient of |h| (WN σ², MA1 σ²(1+θ)²)
    lin: f64,
    /// constant for h ≠ 0 (QN 2Q², MA1 −2θσ²)
    konst: f64,
    /// RW γ²: V = −γ²(|h|³ − |h|)/6
    rw: f64,
    ar: Vec<ArTerm>,
    /// any AR1 with φ < 0 (the summand alternates: sum even and odd lags separately)
    pub(crate) alternating: bool,
    /// drift slope ω per sample (deterministic D = ω m²)
    pub(crate) drift: f64,
}

fn sinh_minus_x(l: f64) -> f64 {
    if l < 0.1 {
        let l2 = l * l;
        l * l2 * (1.0 / 6.0 + l2 * (1.0 / 120.0 + l2 * (1.0 / 5040.0 + l2 / 362_880.0)))
    } else {
        l.sinh() - l
    }
}

/// e^{−u} − 1 + u for u ≥ 0, without cancellation.
fn exp_tail(u: f64) -> f64 {
    if u < 0.1 {
        let mut term = u * u / 2.0;
        let mut s = term;
        for k in 3..=10 {
            term *= -u / k as f64;
            s += term;
        }
        s
    } else {
        (-u).exp_m1() + u
    }
}

impl Variogram {
    pub(crate) fn new(model: &Model, rate_hz: f64) -> Result<Self> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(FitError::InvalidArgument(format!(
                "sampling rate must be finite and > 0, got {rate_hz}"
            )));
        }
        let mut v = Variogram::default();
        for p in model.processes()? {
            match p {
                Process::WhiteNoise(w) => v.lin += w.sigma2(),
                Process::QuantizationNoise(q) => v.konst += 2.0 * q.q2(),
                Process::Ma1(a) => {
                    let (t, s) = (a.theta(), a.sigma2());
                    v.lin += s * (1.0 + t) * (1.0 + t);
                    v.konst -= 2.0 * t * s;
                }
                Process::RandomWalk(r) => v.rw += r.gamma2(),
                Process::Drift(d) => v.drift += d.omega(),
                Process::Ar1(a) => v.push_ar(a.phi(), None, a.stationary_variance()),
                Process::GaussMarkov(g) => {
                    let lam = g.beta() / rate_hz;
                    v.push_ar((-lam).exp(), Some(lam), g.sigma2())
                }
                Process::ArP(_) => {
                    return Err(FitError::InvalidArgument(
                        "the model covariance of the AV is not implemented for AR2/AR3/AR4".into(),
                    ));
                }
                Process::Arma(_) => {
                    return Err(FitError::InvalidArgument(
                        "the model covariance of the AV is not implemented for MA2/ARMA".into(),
                    ));
                }
                Process::Sinusoid(_) => {
                    return Err(FitError::InvalidArgument(
                        "the model covariance of the AV assumes a Gaussian process; a random-phase \
                         sinusoid (SIN) is not one"
                            .into(),
                    ));
                }
                Process::BiasInstability(b) => {
                    let (t, u) = b.band().states()?;
                    let b2 = b.b() * b.b();
                    for (&t, &u) in t.iter().zip(&u) {
                        v.push_ar((-1.0 / t).exp(), Some(1.0 / t), b2 * u);
                    }
                }
                Process::Plp(_) | Process::Fgn(_) => {
                    return Err(FitError::InvalidArgument(
                        "the model covariance of the AV is not implemented for the long-memory \
                         PLP/FGN (use the bootstrap covariance)"
                            .into(),
                    ));
                }
            }
        }
        Ok(v)
    }

    fn push_ar(&mut self, phi: f64, lam: Option<f64>, g0: f64) {
        if phi > 0.0 {
            let lam = lam.unwrap_or_else(|| -(phi - 1.0).ln_1p());
            let one_minus = -(-lam).exp_m1();
            self.ar.push(ArTerm {
                phi,
                lam,
                scale: 2.0 * phi * g0 / (one_minus * one_minus),
                sinh_minus: sinh_minus_x(lam),
            });
        } else if phi == 0.0 {
            self.lin += g0;
        } else {
            self.alternating = true;
            self.ar.push(ArTerm {
                phi,
                lam: -(-phi).ln(),
                scale: g0 / ((1.0 - phi) * (1.0 - phi)),
                sinh_minus: 0.0,
            });
        }
    }

    /// V(h) at a lag |h| (real, ≥ 0); `odd` is the parity of the integer lag it stands for
    /// (used by φ < 0 only). h = 0 exactly gives 0.
    #[inline]
    fn at(&self, h: f64, odd: bool) -> f64 {
        let h = h.abs();
        if h == 0.0 {
            return 0.0;
        }
        let mut v = self.lin * h + self.konst - self.rw * (h * h * h - h) / 6.0;
        for a in &self.ar {
            if a.phi > 0.0 {
                v += a.scale * (h * a.sinh_minus + exp_tail(a.lam * h));
            } else {
                let pow = (-a.lam * h).exp();
                let pow = if odd { -pow } else { pow };
                v += a.scale * (h * (1.0 - a.phi * a.phi) - 2.0 * a.phi * (1.0 - pow));
            }
        }
        v
    }
}

/// One pair of scales (m_i, m_j) of a series of n samples.
pub(crate) struct Pair<'a> {
    pub(crate) v: &'a Variogram,
    pub(crate) mi: i64,
    pub(crate) mj: i64,
    pub(crate) n: i64,
}

const ALPHA: [f64; 3] = [1.0, -2.0, 1.0];

impl Pair<'_> {
    /// Which side of the finite filters' support lag `k` lies on: 0 inside (|k| small),
    /// +1 beyond k = 2m_i, −1 below k = −2m_j (there only the AR terms are left).
    fn side(&self, k: i64) -> i8 {
        if k > 2 * self.mi {
            1
        } else if k < -2 * self.mj {
            -1
        } else {
            0
        }
    }

    /// g(k) = Cov(D_i(t+k), D_j(t)) = −½ Σ_{a,b} α_a α_b V(k − a m_i + b m_j).
    ///
    /// Outside the support (`side` ≠ 0) every V argument has one sign, the polynomial parts
    /// cancel exactly and are dropped (they would only leave rounding noise), and an AR1 with
    /// φ = e^{−λ} > 0 gives the factored −½ s e^{−λd} (1−e^{−λm_i})² (1−e^{−λm_j})², d the
    /// distance past the support — no cancellation however small λm is.
    #[inline]
    fn g(&self, k: f64, odd: bool, side: i8) -> f64 {
        if side != 0 {
            let d = if side > 0 {
                k - 2.0 * self.mi as f64
            } else {
                -k - 2.0 * self.mj as f64
            };
            let mut s = 0.0;
            for a in &self.v.ar {
                if a.phi > 0.0 {
                    let ei = (-a.lam * self.mi as f64).exp_m1();
                    let ej = (-a.lam * self.mj as f64).exp_m1();
                    s += -0.5 * a.scale * (-a.lam * d).exp() * ei * ei * ej * ej;
                } else {
                    // V's exponential part 2φ s φ^|h|, summed over the 9 terms
                    for (ai, &aa) in ALPHA.iter().enumerate() {
                        for (bi, &bb) in ALPHA.iter().enumerate() {
                            let off = -(ai as i64) * self.mi + (bi as i64) * self.mj;
                            let odd_h = odd ^ (off.rem_euclid(2) == 1);
                            let h = (k + off as f64).abs();
                            let pow = (-a.lam * h).exp();
                            let pow = if odd_h { -pow } else { pow };
                            s += -0.5 * aa * bb * 2.0 * a.phi * a.scale * pow;
                        }
                    }
                }
            }
            return s;
        }
        let mut s = 0.0;
        for (a, &aa) in ALPHA.iter().enumerate() {
            for (b, &bb) in ALPHA.iter().enumerate() {
                let off = -(a as i64) * self.mi + (b as i64) * self.mj;
                let odd_h = odd ^ (off.rem_euclid(2) == 1);
                s += aa * bb * self.v.at(k + off as f64, odd_h);
            }
        }
        -0.5 * s
    }

    /// N(k): the number of (s, t) with s − t = k, s ∈ [2m_i, n], t ∈ [2m_j, n].
    #[inline]
    fn count(&self, k: f64) -> f64 {
        let n = self.n as f64;
        let hi = n.min(n - k);
        let lo = (2.0 * self.mj as f64).max(2.0 * self.mi as f64 - k);
        (hi - lo + 1.0).max(0.0)
    }

    /// (Σ_k N(k) g(k)², Σ_k N(k) g(k)) over all lags.
    pub(crate) fn sums(&self) -> (f64, f64) {
        let klo = 2 * self.mi - self.n;
        let khi = self.n - 2 * self.mj;
        // kinks of the summand: zeros of the V arguments and of N's pieces
        let mut kinks: Vec<i64> = vec![klo, khi, 0, 2 * self.mi - 2 * self.mj];
        for a in 0..3 {
            for b in 0..3 {
                kinks.push(a * self.mi - b * self.mj);
            }
        }
        // beyond the outermost V kink only AR terms survive
        let vmin = -2 * self.mj;
        let vmax = 2 * self.mi;
        kinks.retain(|&k| (klo..=khi).contains(&k));
        kinks.sort_unstable();
        kinks.dedup();
        let mut s2 = 0.0;
        let mut s1 = 0.0;
        let step: i64 = if self.v.alternating { 2 } else { 1 };
        let has_ar = !self.v.ar.is_empty();
        for w in kinks.windows(2) {
            let (p, q) = (w[0], w[1]);
            if !has_ar && (q <= vmin || p >= vmax) {
                // g ≡ 0 outside the support of the finite filters
                continue;
            }
            for par in 0..step {
                // lattice k = start + step·j, p < k < q
                let first = p + 1 + (par - (p + 1)).rem_euclid(step);
                if first >= q {
                    continue;
                }
                let cnt = (q - 1 - first) / step + 1;
                let (a, b) = self.lattice_sum(first, step, cnt);
                s2 += a;
                s1 += b;
            }
        }
        for &k in &kinks {
            let kf = k as f64;
            let g = self.g(kf, k.rem_euclid(2) == 1, 0);
            let c = self.count(kf);
            s2 += c * g * g;
            s1 += c * g;
        }
        (s2, s1)
    }

    #[inline]
    fn term(&self, k: f64, odd: bool, side: i8) -> (f64, f64) {
        let g = self.g(k, odd, side);
        let c = self.count(k);
        (c * g * g, c * g)
    }

    /// Σ_{j=0}^{cnt−1} of the summand at k = first + step·j (a kink-free stretch).
    fn lattice_sum(&self, first: i64, step: i64, cnt: i64) -> (f64, f64) {
        let odd = first.rem_euclid(2) == 1; // constant parity when step = 2
        // a kink-free stretch lies on one side of the support
        let side = self.side(first);
        let at = |j: f64| {
            let k = first as f64 + step as f64 * j;
            let o = if step == 2 { odd } else { false };
            self.term(k, o, side)
        };
        let direct = |lo: i64, hi: i64, acc: &mut (f64, f64)| {
            for j in lo..hi {
                let k = first + step * j;
                let (a, b) = self.term(k as f64, k.rem_euclid(2) == 1, side);
                acc.0 += a;
                acc.1 += b;
            }
        };
        let mut acc = (0.0, 0.0);
        if cnt <= 4 * DIRECT || step == 1 && self.v.ar.is_empty() && cnt <= 64 * DIRECT {
            direct(0, cnt, &mut acc);
            return acc;
        }
        direct(0, DIRECT, &mut acc);
        direct(cnt - DIRECT, cnt, &mut acc);
        // middle j ∈ [DIRECT, cnt − DIRECT − 1] as ∫_{lo−½}^{hi+½} minus the EM end term
        let x0 = DIRECT as f64 - 0.5;
        let x1 = (cnt - DIRECT) as f64 - 0.5;
        let mid = 0.5 * (x0 + x1);
        let panel = |lo: f64, hi: f64, acc: &mut (f64, f64)| {
            let (c, r) = (0.5 * (lo + hi), 0.5 * (hi - lo));
            for (x, w) in GL_X.iter().zip(&GL_W) {
                let (a1, b1) = at(c - r * x);
                let (a2, b2) = at(c + r * x);
                acc.0 += w * r * (a1 + a2);
                acc.1 += w * r * (b1 + b2);
            }
        };
        let mut width = FIRST_PANEL;
        let mut lo = x0;
        let mut hi = x1;
        while lo < mid {
            let e = (lo + width).min(mid);
            panel(lo, e, &mut acc);
            let s = (hi - width).max(mid);
            panel(s, hi, &mut acc);
            lo = e;
            hi = s;
            width *= 2.0;
        }
        // Euler–Maclaurin: Σ f(j) = ∫_{lo−½}^{hi+½} f − [f′(hi+½) − f′(lo−½)]/24 + …
        let d = |x: f64| {
            let (a1, b1) = at(x + 0.5);
            let (a0, b0) = at(x - 0.5);
            (a1 - a0, b1 - b0)
        };
        let (da1, db1) = d(x1);
        let (da0, db0) = d(x0);
        acc.0 -= (da1 - da0) / 24.0;
        acc.1 -= (db1 - db0) / 24.0;
        acc
    }
}

/// Covariance matrix (J×J, unit⁴) of the maximum-overlapping AV estimates (book eq. 4.2) at
/// cluster sizes `m` (samples) of a series of `n` samples of the fully specified `model`
/// (per-sample parameters, `rate_hz` used by GM only), assuming Gaussian noise. This is the
/// exact finite-n covariance, not a large-n approximation.
///
/// **Derivation.** With C_t = x_1 + … + x_t (C_0 = 0) and D_i(t) = C_t − 2C_{t−m_i} + C_{t−2m_i},
/// the estimator is AV̂_i = Q_i / (2 K_i m_i²), Q_i = Σ_{t=2m_i}^{n} D_i(t)², K_i = n − 2m_i + 1.
/// D_i is stationary for every process here and, for independent components,
/// g_ij(k) = Cov(D_i(t+k), D_j(t)) = −½ Σ_{a,b∈{0,1,2}} α_a α_b V(k − a m_i + b m_j), α = (1, −2, 1),
/// where V(h) = Var(C_{t+h} − C_t) is the variogram of C summed over the components
/// (−V/2 is a generalized covariance, valid because α annihilates constants and linear trends):
/// WN σ²|h|; QN 2Q² (h ≠ 0); MA1 σ²((1+θ)²|h| − 2θ) (h ≠ 0); RW −γ²(|h|³ − |h|)/6;
/// AR1 γ(0)(|h|(1 − φ²) − 2φ(1 − φ^|h|))/(1 − φ)², evaluated for φ > 0 as
/// 2φγ(0)/(1−φ)² · (|h|(sinh λ − λ) + e^{−λ|h|} − 1 + λ|h|), λ = −ln φ (no cancellation);
/// GM as AR1 with φ = e^{−β/rate}; V(0) = 0. (k = 0, i = j gives Var D = 4V(m) − V(2m), the
/// book's Lemma 4.2.) For Gaussian zero-mean D, Isserlis' theorem gives
/// Cov(D_i(s)², D_j(t)²) = 2 g_ij(s−t)², hence
/// Cov(Q_i, Q_j) = 2 Σ_k N_ij(k) g_ij(k)², N_ij(k) = #{(s, t): s − t = k, s ≥ 2m_i, t ≥ 2m_j, s, t ≤ n}.
/// A drift ω (deterministic) shifts D_i by μ_i = ω m_i²: it leaves no variance of its own but
/// adds the cross term 4 μ_i μ_j Σ_k N_ij(k) g_ij(k). So
/// Cov(AV̂_i, AV̂_j) = [2 Σ N g² + 4 μ_i μ_j Σ N g] / (4 K_i K_j m_i² m_j²).
/// The lag sum runs over up to 2n lags; between its ≤ 13 kinks (zeros of the V arguments and
/// of N's pieces) the summand is a polynomial plus exponentials in k, so it is summed exactly
/// over 16 lags next to each kink and by graded 8-point Gauss–Legendre panels plus the
/// Euler–Maclaurin end term in between (AR1 with φ < 0: even and odd lags separately).
/// Cost O(J² log n), independent of m.
///
/// Errors: empty `m`, m = 0, 2m > n, non-positive rate, a model with unset parameters.
///
/// ```
/// use gmwm_prep::inference::model_covariance;
/// // White noise: Var(AV̂(m)) ≈ σ⁴(4m² + 5)/(3 K m³) for K = n − 2m + 1 ≫ m.
/// let wn: processes::Model = "WN(sigma2=2)".parse()?;
/// let v = model_covariance(&wn, &[8, 16], 1.0, 1_000_000)?;
/// let k = (1_000_000 - 16 + 1) as f64;
/// let approx = 4.0 * (4.0 * 64.0 + 5.0) / (3.0 * k * 512.0);
/// assert!((v.get(0, 0) / approx - 1.0).abs() < 1e-4);
/// assert!(v.get(0, 1) > 0.0 && v.get(0, 1) < v.get(0, 0));
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
pub fn model_covariance(model: &Model, m: &[u64], rate_hz: f64, n: u64) -> Result<CovMatrix> {
    use rayon::prelude::*;
    if m.is_empty() {
        return Err(FitError::InvalidArgument("no cluster sizes".into()));
    }
    if n > (i64::MAX / 8) as u64 {
        return Err(FitError::InvalidArgument(format!(
            "series length {n} too large"
        )));
    }
    if let Some(&bad) = m.iter().find(|&&x| x == 0 || x > n / 2) {
        return Err(FitError::InvalidArgument(format!(
            "cluster size {bad} is not in [1, n/2] for n = {n}"
        )));
    }
    let v = Variogram::new(model, rate_hz)?;
    let j = m.len();
    let pairs: Vec<(usize, usize)> = (0..j).flat_map(|a| (a..j).map(move |b| (a, b))).collect();
    let vals: Vec<f64> = pairs
        .par_iter()
        .map(|&(a, b)| {
            let pair = Pair {
                v: &v,
                mi: m[a] as i64,
                mj: m[b] as i64,
                n: n as i64,
            };
            let (s2, s1) = pair.sums();
            let (mi, mj) = (m[a] as f64, m[b] as f64);
            let (ki, kj) = ((n - 2 * m[a] + 1) as f64, (n - 2 * m[b] + 1) as f64);
            let mu = v.drift * v.drift * mi * mi * mj * mj;
            (2.0 * s2 + 4.0 * mu * s1) / (4.0 * ki * kj * mi * mi * mj * mj)
        })
        .collect();
    let mut data = vec![0.0; j * j];
    for (&(a, b), &x) in pairs.iter().zip(&vals) {
        data[a * j + b] = x;
        data[b * j + a] = x;
    }
    CovMatrix::new(j, data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inference::model_covariance;

    /// Independent route: Cov(xᵀA_i x, xᵀA_j x) = 2 tr(A_i Σ A_j Σ) + 4 μᵀA_i Σ A_j μ for
    /// Gaussian x ~ N(μ, Σ), with the explicit n×n covariance of x_1..x_n (RW started at 0,
    /// which D does not see) and A_i = Σ_t d_t d_tᵀ / (2 K_i m_i²).
    fn brute(model: &Model, m: &[u64], n: usize) -> Vec<f64> {
        let mut sig = vec![0.0; n * n];
        let mut mu = vec![0.0; n];
        for p in model.processes().unwrap() {
            for s in 0..n {
                for t in 0..n {
                    let h = s.abs_diff(t);
                    sig[s * n + t] += match p {
                        Process::WhiteNoise(w) => w.sigma2() * f64::from(h == 0),
                        Process::QuantizationNoise(q) => {
                            q.q2() * [2.0, -1.0].get(h).copied().unwrap_or(0.0)
                        }
                        Process::Ma1(a) => {
                            let t2 = a.theta();
                            a.sigma2() * [1.0 + t2 * t2, t2].get(h).copied().unwrap_or(0.0)
                        }
                        Process::RandomWalk(r) => r.gamma2() * (s.min(t) + 1) as f64,
                        Process::Ar1(a) => a.stationary_variance() * a.phi().powi(h as i32),
                        Process::GaussMarkov(g) => {
                            g.sigma2() * (-g.beta() / 100.0 * h as f64).exp()
                        }
                        _ => 0.0,
                    };
                }
                if let Process::Drift(d) = p {
                    mu[s] += d.omega() * (s + 1) as f64;
                }
            }
        }
        // d vectors (x index 0..n−1 is x_1..x_n); D(t) = Σ_{u<m} x_{t−u} − Σ_{m≤u<2m} x_{t−u}
        let dvecs = |mm: usize| -> Vec<Vec<f64>> {
            (2 * mm..=n)
                .map(|t| {
                    let mut d = vec![0.0; n];
                    for u in 0..2 * mm {
                        d[t - 1 - u] = if u < mm { 1.0 } else { -1.0 };
                    }
                    d
                })
                .collect()
        };
        let sd = |a: &[f64], b: &[f64]| -> f64 {
            let mut s = 0.0;
            for x in 0..n {
                if a[x] == 0.0 {
                    continue;
                }
                for y in 0..n {
                    s += a[x] * sig[x * n + y] * b[y];
                }
            }
            s
        };
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let j = m.len();
        let mut out = vec![0.0; j * j];
        for a in 0..j {
            for b in 0..j {
                let (da, db) = (dvecs(m[a] as usize), dvecs(m[b] as usize));
                let mut c = 0.0;
                for x in &da {
                    for y in &db {
                        let g = sd(x, y);
                        c += 2.0 * g * g + 4.0 * dot(x, &mu) * dot(y, &mu) * g;
                    }
                }
                let norm = |mm: u64| 2.0 * (n as f64 - 2.0 * mm as f64 + 1.0) * (mm * mm) as f64;
                out[a * j + b] = c / (norm(m[a]) * norm(m[b]));
            }
        }
        out
    }

    #[test]
    fn matches_explicit_quadratic_form_covariance() {
        // Every kind, odd and even cluster sizes, φ < 0 (alternating lags): the two routes
        // share only the definition of the estimator. Agreement to rounding (the lag sums
        // here are short, so everything is summed directly): relative 1e-9.
        const TOL: f64 = 1e-9;
        let n = 48;
        for spec in [
            "WN(sigma2=2) + QN(q2=0.5) + RW(gamma2=0.01)",
            "AR1(phi=0.9, sigma2=1) + MA1(theta=-0.4, sigma2=0.3)",
            "AR1(phi=-0.7, sigma2=1) + WN(sigma2=0.5) + DR(omega=0.05)",
            "GM(beta=20, sigma2=1) + RW(gamma2=0.02) + DR(omega=-0.01)",
        ] {
            let model: Model = spec.parse().unwrap();
            let m = [1, 3, 4, 10];
            let got = model_covariance(&model, &m, 100.0, n as u64).unwrap();
            let want = brute(&model, &m, n);
            for (k, w) in want.iter().enumerate() {
                let g = got.data[k];
                let scale = (got.get(k / 4, k / 4) * got.get(k % 4, k % 4)).sqrt();
                assert!(
                    (g - w).abs() <= TOL * scale,
                    "{spec} entry {k}: {g} vs brute force {w}"
                );
            }
        }
    }

    #[test]
    fn quadrature_matches_the_full_lag_sum() {
        // Long stretches go through the graded Gauss panels; the reference sums every lag
        // (2n terms) with the same summand. Truncation of the panels (polynomials of degree
        // ≤ 7 are integrated exactly, exponentials are resolved by the grading) and the
        // Euler–Maclaurin remainder stay below 1e-7 relative.
        const TOL: f64 = 1e-7;
        let n = 40_000;
        for spec in [
            "WN(sigma2=1e-4) + RW(gamma2=1e-10) + AR1(phi=0.995, sigma2=1e-7)",
            "QN(q2=1e-5) + AR1(phi=0.9, sigma2=1e-6) + AR1(phi=0.9999, sigma2=1e-9)",
            "AR1(phi=-0.99, sigma2=1) + DR(omega=1e-4)",
        ] {
            let model: Model = spec.parse().unwrap();
            let v = Variogram::new(&model, 100.0).unwrap();
            for (mi, mj) in [(2, 2), (8, 64), (512, 4096), (3000, 7)] {
                let pair = Pair { v: &v, mi, mj, n };
                let (q2, q1) = pair.sums();
                let (mut d2, mut d1) = (0.0, 0.0);
                let mut mag = 0.0;
                for k in (2 * mi - n)..=(n - 2 * mj) {
                    let (a, b) = pair.term(k as f64, k.rem_euclid(2) == 1, pair.side(k));
                    d2 += a;
                    d1 += b;
                    mag += b.abs();
                }
                assert!(
                    (q2 - d2).abs() <= TOL * d2,
                    "{spec} ({mi},{mj}): {q2} vs {d2}"
                );
                assert!(
                    (q1 - d1).abs() <= TOL * mag,
                    "{spec} ({mi},{mj}): {q1} vs {d1}"
                );
            }
        }
    }
}
