//! The M-estimator of scale: the robust mean square s solving (1/n) Σ χ_c(d²/s) = a(c) for
//! the biweight, by Newton's method on ln s from a MAD-based start, bracketed when Newton
//! leaves its neighbourhood (the Newton state is shared with the lock-step solver).

use serde::{Deserialize, Serialize};

use super::biweight::Biweight;
use crate::error::AvarError;

/// The robust M-estimate of the mean square of `d` (values whose mean is taken to be zero,
/// e.g. Allan differences or wavelet coefficients): the root s of
/// (1/n) Σ χ_c(d²/s) = a(c) on the branch that is consistent at the Gaussian model, found by
/// a Newton iteration on ln s from the MAD-based start (median |d| / 0.6745)², safeguarded by
/// a bracket grown from that start when Newton leaves its neighbourhood; for more than 2^16
/// values the median is that of an evenly spaced subsample of 2^16. Returns 0 when every
/// value is 0.
///
/// Errors: empty input or a non-finite value.
///
/// ```
/// use avar::robust::{Biweight, robust_mean_square};
/// let b = Biweight::with_efficiency(0.6).unwrap();
/// // ±1 alternating, plus one gross outlier: the mean square goes from 1 to 1 + 1e6/1001 ≈ 1000,
/// // the robust one moves by 0.1 % (it is 1.53 here, not 1: these values are not Gaussian)
/// let mut d: Vec<f64> = (0..1000).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
/// let clean = robust_mean_square(&d, &b).unwrap();
/// d.push(1000.0);
/// let s = robust_mean_square(&d, &b).unwrap();
/// assert!((s / clean - 1.0).abs() < 2e-3, "{s} vs {clean}");
/// ```
pub fn robust_mean_square(d: &[f64], bw: &Biweight) -> Result<f64, AvarError> {
    robust_mean_square_detail(d, bw).map(|r| r.s)
}

simd_dispatch! {
    /// Σ χ_c(u) and −Σ u χ_c'(u) over u = d²·`inv` (`inv_c2` = 1/c²), branch-free in eight
    /// accumulator lanes so that the compiler vectorizes it (w = 0 past c² instead of a branch),
    /// with AVX-512 or AVX2 as [`crate::simd::level`] allows. The lanes and their order of summation are
    /// fixed by the code (no FMA contraction), so every instruction set gives the same bits.
    fn chi_sums(d: &[f64], inv: f64, inv_c2: f64) -> (f64, f64) => chi_sums_lanes
}

#[inline(always)]
fn chi_sums_lanes(d: &[f64], inv: f64, inv_c2: f64) -> (f64, f64) {
    const L: usize = 8;
    let mut g = [0.0f64; L];
    let mut dg = [0.0f64; L];
    let chunks = d.chunks_exact(L);
    let rest = chunks.remainder();
    for xs in chunks {
        for j in 0..L {
            let u = xs[j] * xs[j] * inv;
            let w = (1.0 - u * inv_c2).max(0.0);
            let w3 = w * w * w;
            let chi = u * w3 * w;
            g[j] += chi;
            // u χ'(u) = u (1 − u/c²)⁴ − 4 u²/c² (1 − u/c²)³
            dg[j] += 4.0 * u * u * inv_c2 * w3 - chi;
        }
    }
    for (j, &x) in rest.iter().enumerate() {
        let u = x * x * inv;
        let w = (1.0 - u * inv_c2).max(0.0);
        let w3 = w * w * w;
        let chi = u * w3 * w;
        g[j] += chi;
        dg[j] += 4.0 * u * u * inv_c2 * w3 - chi;
    }
    let sum = |a: [f64; L]| ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]));
    (sum(g), sum(dg))
}

/// [`robust_mean_square`] with a flag saying whether the estimating equation had a root.
///
/// ```
/// use avar::robust::{Biweight, robust_mean_square_detail};
/// let b = Biweight::with_efficiency(0.6).unwrap();
/// let d: Vec<f64> = (0..100).map(|i| ((i * 37) % 19) as f64 - 9.0).collect();
/// assert!(robust_mean_square_detail(&d, &b).unwrap().root);
/// ```
pub fn robust_mean_square_detail(d: &[f64], bw: &Biweight) -> Result<RobustScale, AvarError> {
    if d.is_empty() {
        return Err(AvarError::Empty);
    }
    // one pass: the mean square is finite unless a value is not (or the squares overflow)
    let ms = sq_sum(d) / d.len() as f64;
    if !ms.is_finite()
        && let Some((index, &value)) = d.iter().enumerate().find(|(_, v)| !v.is_finite())
    {
        return Err(AvarError::NonFinite { index, value });
    }
    if ms == 0.0 {
        return Ok(RobustScale { s: 0.0, root: true });
    }
    let c2 = bw.c * bw.c;
    let n = d.len() as f64;
    // g(ln s) = mean χ(d²/s) − a and its derivative −mean(u χ'(u))
    let eval = |s: f64| -> (f64, f64) {
        let (g, dg) = chi_sums(d, 1.0 / s, 1.0 / c2);
        (g / n - bw.a, dg / n)
    };
    // The start: the MAD of the differences, of an evenly spaced subsample of at most 2^16 of
    // them (a start only: the root solves the equation over all of them).
    let stride = d.len().div_ceil(1 << 16);
    let mut abs: Vec<f64> = d.iter().step_by(stride).map(|x| x.abs()).collect();
    let mid = abs.len() / 2;
    let (_, med, _) = abs.select_nth_unstable_by(mid, f64::total_cmp);
    let mad = *med / 0.674_489_750_196_081_7;
    drop(abs);
    // the mean square or the MAD's square (heavily quantized data can have more than half
    // the differences at 0)
    let s0 = newton_start(ms, mad);
    const LN2: f64 = std::f64::consts::LN_2;
    let x0 = s0.ln();
    let (g0, dg0) = eval(s0);
    // The clean case first: Newton on ln s from that start, accepted when it stays within
    // ln 2 of the start on the side the sign of g(start) points to and ends on a decreasing
    // stretch of g (the consistent branch); 2–4 passes instead of the bracket's 8.
    if let Some(x) = newton_from_start(x0, g0, dg0, &eval) {
        return Ok(RobustScale {
            s: x.exp(),
            root: true,
        });
    }
    // bracket [lo, hi] in ln s with g(lo) > 0 > g(hi), the one nearest the start
    let mut best = (g0, x0);
    let mut bracket = None;
    if g0 >= 0.0 {
        // up until negative: g < 0 for certain once s > mean square / a
        let (mut x, mut prev) = (x0, x0);
        for _ in 0..400 {
            prev = x;
            x += LN2;
            if eval(x.exp()).0 < 0.0 {
                break;
            }
        }
        bracket = Some((prev, x));
    } else {
        // down a little (the clean case: the root is near the start)
        let mut x = x0;
        for _ in 0..6 {
            let xn = x - LN2;
            let g = eval(xn.exp()).0;
            if g > best.0 {
                best = (g, xn);
            }
            if g > 0.0 {
                bracket = Some((xn, x));
                break;
            }
            x = xn;
        }
        if bracket.is_none() {
            // up: a positive stretch above the start (e.g. most differences near 0)
            // (bounded even if the mean square overflowed: 2^400 above the start)
            let top = (2.0 * ms / bw.a).ln().min(x0 + 400.0 * LN2);
            let mut x = x0;
            let mut pos: Option<f64> = None;
            while x < top {
                let xn = x + 0.5 * LN2;
                let g = eval(xn.exp()).0;
                if g > best.0 {
                    best = (g, xn);
                }
                if g > 0.0 {
                    pos = Some(xn);
                } else if let Some(p) = pos {
                    bracket = Some((p, xn));
                    break;
                }
                x = xn;
            }
        }
    }
    let Some((mut lo, mut hi)) = bracket else {
        // no root: the contamination exceeds the estimator's breakdown at this scale. Like
        // `gmwm` (which minimizes the squared estimating equation), take the s where the
        // equation comes closest to holding: the maximum of g, by golden section.
        let (mut a, mut b) = (best.1 - LN2, best.1 + LN2);
        let r = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..60 {
            let (c, d) = (b - r * (b - a), a + r * (b - a));
            if eval(c.exp()).0 > eval(d.exp()).0 {
                b = d;
            } else {
                a = c;
            }
        }
        return Ok(RobustScale {
            s: (0.5 * (a + b)).exp(),
            root: false,
        });
    };
    // g decreases in ln s on the consistent branch: safeguarded Newton
    let mut x = 0.5 * (lo + hi);
    for _ in 0..200 {
        let (g, dg) = eval(x.exp());
        if g > 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let mut next = if dg < 0.0 { x - g / dg } else { f64::NAN };
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        let step = (next - x).abs();
        x = next;
        if step < 1e-13 || hi - lo < 1e-13 {
            break;
        }
    }
    Ok(RobustScale {
        s: x.exp(),
        root: true,
    })
}

/// Where Newton's method on g(ln s) starts, from the mean square `ms` of the differences and
/// the MAD-based scale `mad` (of a subsample): the mean square when the two agree within 10 %
/// (clean data: the root then lies within the sampling noise of the difference between the
/// robust and the classical estimates, ≈ 3.5·10⁻⁴ in ln s at 10⁷ differences, against ≈ 10⁻²
/// for the MAD of 2^16 of them, which saves one pass of the quadratically converging
/// iteration), the MAD's square otherwise (contamination pulls the mean square away), and
/// the mean square when the MAD is 0 (heavily quantized data).
///
/// Either start leads to the same root where Newton's method is accepted (the caller's
/// neighbourhood rule); only the number of passes differs.
pub(super) fn newton_start(ms: f64, mad: f64) -> f64 {
    let s_mad = mad * mad;
    if s_mad.is_nan() || s_mad <= 0.0 {
        return ms;
    }
    if (ms / s_mad).ln().abs() < 0.1 {
        ms
    } else {
        s_mad
    }
}

/// Newton's method on g(ln s) from the start `x0` ([`newton_start`]; module doc of
/// [`robust_mean_square_detail`]): the root if every step keeps g decreasing, the iterate
/// within ln 2 of `x0` on the side sign g(x0) points to, and the error estimate falls below
/// [`NEWTON_ERR`];
/// `None` otherwise (the caller then brackets).
fn newton_from_start(x0: f64, g0: f64, dg0: f64, eval: &dyn Fn(f64) -> (f64, f64)) -> Option<f64> {
    let mut n = Newton::start(x0, g0);
    let (mut g, mut dg) = (g0, dg0);
    loop {
        match n.step(g, dg) {
            NewtonStep::Eval(x) => (g, dg) = eval(x.exp()),
            NewtonStep::Root(x) => return Some(x),
            NewtonStep::Failed => return None,
        }
    }
}

/// The state of [`newton_from_start`] (so that several scales can step together, each pass
/// over the data evaluating g for all of them: [`solve_lockstep`]).
///
/// [`solve_lockstep`]: super::lockstep::solve_lockstep
#[derive(Debug, Clone, Copy)]
pub(super) struct Newton {
    x: f64,
    lo: f64,
    hi: f64,
    steps: u32,
    /// The previous step's length (0 before the first).
    last: f64,
}

/// What [`Newton::step`] asks for next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum NewtonStep {
    /// g and g' at ln s = this.
    Eval(f64),
    /// Converged at ln s = this.
    Root(f64),
    /// Left the neighbourhood of the start or a non-decreasing stretch: bracket instead.
    Failed,
}

impl Newton {
    pub(super) fn start(x0: f64, g0: f64) -> Self {
        let (lo, hi) = if g0 >= 0.0 {
            (x0, x0 + std::f64::consts::LN_2)
        } else {
            (x0 - std::f64::consts::LN_2, x0)
        };
        Newton {
            x: x0,
            lo,
            hi,
            steps: 0,
            last: 0.0,
        }
    }

    /// One Newton step from g, g' at the current iterate.
    pub(super) fn step(&mut self, g: f64, dg: f64) -> NewtonStep {
        if self.steps == 30 || !(dg < 0.0 && g.is_finite()) {
            return NewtonStep::Failed;
        }
        self.steps += 1;
        let next = self.x - g / dg;
        if !(next >= self.lo && next <= self.hi) {
            return NewtonStep::Failed;
        }
        let step = (next - self.x).abs();
        self.x = next;
        // quadratic convergence: the error of `next` is about K·step², K estimated from the
        // last two steps (NEWTON_ERR)
        let k = if self.last > 0.0 {
            (step / (self.last * self.last)).max(NEWTON_K_MIN)
        } else {
            1.0
        };
        self.last = step;
        if k * step * step < NEWTON_ERR {
            NewtonStep::Root(next)
        } else {
            NewtonStep::Eval(next)
        }
    }
}

/// Newton's method on g(ln s) stops once the error of its iterate is estimated below this
/// (relative, in s). Near the root the error after a step δ is about K·δ² with K =
/// |g''/(2g')|, estimated by δ_n/δ_{n−1}² from the last two steps (K = 1 after the first
/// step, and never below [`NEWTON_K_MIN`], in case the previous step was not yet in the
/// quadratic regime). Measured on this module's iterations (white noise and white noise +
/// random walk, m = 1 … 2^20): K = 0.10–0.14, so the last step is typically 2·10⁻⁷–3·10⁻⁷.
/// The root is not defined more finely than about this: g is a sum of up to 10⁷ and more
/// terms whose rounding moves the root by about 10⁻¹³ in ln s. (Stopping at a step below
/// 10⁻⁹, as before, cost one more pass over the differences at about a third of the scales.)
const NEWTON_ERR: f64 = 1e-14;

/// The smallest K of [`NEWTON_ERR`]'s estimate.
const NEWTON_K_MIN: f64 = 0.05;

/// The result of [`robust_mean_square_detail`].
///
/// ```
/// use avar::robust::{Biweight, robust_mean_square, robust_mean_square_detail};
/// let b = Biweight::with_efficiency(0.6).unwrap();
/// let d: Vec<f64> = (0..100).map(|i| ((i * 37) % 19) as f64 - 9.0).collect();
/// let r = robust_mean_square_detail(&d, &b).unwrap();
/// assert!(r.root);
/// assert_eq!(r.s, robust_mean_square(&d, &b).unwrap());
/// // s solves (1/n) Σ χ_c(d²/s) = a(c); Newton stops about 1e-14 from the root in ln s
/// let g = d.iter().map(|v| b.chi(v * v / r.s)).sum::<f64>() / d.len() as f64;
/// assert!((g - b.a).abs() < 1e-9);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RobustScale {
    /// The robust mean square s (unit² of the input).
    pub s: f64,
    /// False when the estimating equation has no root (contamination beyond the breakdown
    /// point at this scale): s then maximizes (1/n) Σ χ_c(d²/s) − a(c), as in `gmwm`.
    pub root: bool,
}

simd_dispatch! {
    /// Σ x² over `x` in eight accumulator lanes.
    fn sq_sum(x: &[f64]) -> f64 => sq_sum_lanes
}

#[inline(always)]
fn sq_sum_lanes(x: &[f64]) -> f64 {
    const L: usize = 8;
    let mut acc = [0.0f64; L];
    let chunks = x.chunks_exact(L);
    let rest = chunks.remainder();
    for ch in chunks {
        for j in 0..L {
            acc[j] += ch[j] * ch[j];
        }
    }
    for (j, &v) in rest.iter().enumerate() {
        acc[j] += v * v;
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// Monte Carlo of the efficiency at 0.6: the variance ratio of the two estimators over
    /// R = 400 samples of n = 2000 iid N(0, 1). The ratio of two sample variances has a
    /// relative SE of about √(2/R)·√(1 − ρ²)·… ≤ √(4/R) = 10 %: the tolerance is 3 × 10 %.
    #[test]
    fn efficiency_by_monte_carlo() {
        let b = Biweight::with_efficiency(0.6).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(15);
        let (r, n) = (400, 2000);
        let mut cl = Vec::new();
        let mut ro = Vec::new();
        for _ in 0..r {
            let d: Vec<f64> = (0..n).map(|_| StandardNormal.sample(&mut rng)).collect();
            cl.push(d.iter().map(|x: &f64| x * x).sum::<f64>() / n as f64);
            ro.push(robust_mean_square(&d, &b).unwrap());
        }
        let var = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64
        };
        let eff = var(&cl) / var(&ro);
        assert!((eff / 0.6 - 1.0).abs() < 0.3, "MC efficiency {eff}");
        // the asymptotic variance 4 Var χ / (n M_c²) = 2 / (n e) of the robust estimator
        let pred = 2.0 / (n as f64 * 0.6);
        assert!(
            (var(&ro) / pred - 1.0).abs() < 0.3,
            "{} vs {pred}",
            var(&ro)
        );
        // consistency: mean within 3 MC SE of 1 (plus the O(1/n) bias, < 1e-3 here)
        let mean = ro.iter().sum::<f64>() / r as f64;
        let se = (var(&ro) / r as f64).sqrt();
        assert!((mean - 1.0).abs() < 3.0 * se + 1e-3, "mean {mean} se {se}");
    }

    #[test]
    fn robust_mean_square_is_scale_equivariant_and_resists_outliers() {
        let b = Biweight::with_efficiency(0.6).unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
        let d: Vec<f64> = (0..5000).map(|_| StandardNormal.sample(&mut rng)).collect();
        let s = robust_mean_square(&d, &b).unwrap();
        let d3: Vec<f64> = d.iter().map(|x| 3.0 * x).collect();
        let s3 = robust_mean_square(&d3, &b).unwrap();
        assert!((s3 / (9.0 * s) - 1.0).abs() < 1e-10);
        // 1 % outliers at 30σ: the mean square grows by ~9, the robust one by < 3 %
        let mut dc = d.clone();
        for i in (0..dc.len()).step_by(100) {
            dc[i] = 30.0;
        }
        let sc = robust_mean_square(&dc, &b).unwrap();
        let msc = dc.iter().map(|x| x * x).sum::<f64>() / dc.len() as f64;
        assert!(msc > 8.0);
        assert!((sc / s - 1.0).abs() < 0.03, "{sc} vs {s}");
        assert_eq!(robust_mean_square(&[0.0; 10], &b).unwrap(), 0.0);
        assert!(robust_mean_square(&[], &b).is_err());
        assert!(robust_mean_square(&[1.0, f64::NAN], &b).is_err());
    }

    /// Newton starts from the mean square when it agrees with the MAD's square within 10 %
    /// (in ln), from the MAD's square otherwise, and from the mean square when the MAD is 0.
    #[test]
    fn newton_start_prefers_the_mean_square_on_clean_data() {
        assert_eq!(newton_start(1.05, 1.0), 1.05);
        assert_eq!(newton_start(0.95, 1.0), 0.95);
        assert_eq!(newton_start(1.2, 1.0), 1.0); // ln 1.2 = 0.18: contaminated
        assert_eq!(newton_start(0.8, 1.0), 1.0);
        assert_eq!(newton_start(3.0, 0.0), 3.0);
    }
}
