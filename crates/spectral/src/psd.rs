//! Power spectral densities (PSD) of the latent processes.
//!
//! # Convention
//! **Two-sided** PSD, frequency f in **Hz**, value in **unit²/Hz**; for a process sampled at
//! `rate` Hz (Δt = 1/rate):
//!
//! S(f) = Δt · Σ_h γ(h) e^(−2πi f h Δt),   so that   γ(0) = ∫_{−rate/2}^{rate/2} S(f) df.
//!
//! S is even and periodic with period `rate`; it is given for every finite f (the Nyquist
//! band |f| ≤ rate/2 is the fundamental one). The one-sided PSD is 2 S(f) on [0, rate/2].
//! With this convention the book's Lemma 4.1, AV = 4∫_0^∞ sin⁴(πfτ)/(πfτ)² S(f) df,
//! holds exactly for the periodic S (see [`crate::quadrature`]) and gives AV = N²/τ for
//! a continuous white noise of PSD N² (the IEEE Std 952 reading).
//!
//! | process | S(f), s = sin²(πfΔt) |
//! |---|---|
//! | WN  | σ² Δt |
//! | QN  | 4 Q² Δt s — the book's Def. 2.3 with its sin²(πf/Δt) read as sin²(πfΔt), matching γ(0) = 2Q², γ(±1) = −Q² |
//! | AR1 | v² Δt / ((1−φ)² + 4φ s) (= v²Δt/(1 − 2φ cos 2πfΔt + φ²)) |
//! | GM  | AR1 with φ = e^(−βΔt), v² = σ_G²(1 − φ²) |
//! | MA1 | σ² Δt ((1+θ)² − 4θ s) |
//! | MA2, ARMA(p,q) | σ² Δt \|1 + Σ θ_k e^{−ikω}\|² / \|1 − Σ φ_k e^{−ikω}\|², ω = 2πfΔt |
//! | RW  | γ² Δt / (4 s) — *generalized* PSD (≈ γ²/(4π² f² Δt) near 0, a 1/f² law): the RW's increments are WN(γ²) and the difference filter has gain 4s |
//! | SIN | not a function: the line spectrum (α²/4)[δ(f − f₀) + δ(f + f₀)], f₀ = β·rate/(2π) |
//! | DR  | not a function: the ramp ωt has the generalized spectrum (ω·rate)²/(8π²) · δ''(f) |
//!
//! The drift's generalized spectrum is what makes Lemma 4.1 return ω²m²/2: applied to the
//! kernel K(f) = sin⁴(πfτ)/(πfτ)² (K''(0) = 2π²τ²) it gives 2 · (ωr)²/(8π²) · 2π²τ² =
//! ω²m²/2. [`psd`] returns [`SpectralError::NotAFunction`] for DR.
//!
//! All forms are evaluated as sums of non-negative terms (using s or c = cos²(πfΔt),
//! whichever avoids cancellation), so they stay accurate for φ, θ near ±1.

use crate::error::{Result, SpectralError, check_rate};
use processes::{Model, Process};

/// The PSD from s = sin²(πfΔt) and c = cos²(πfΔt) (both given accurately).
/// `None` for DR. RW at s = 0 gives +∞.
pub(crate) fn psd_sc(process: &Process, s: f64, c: f64, dt: f64) -> Option<f64> {
    Some(match *process {
        Process::WhiteNoise(p) => p.sigma2() * dt,
        Process::QuantizationNoise(p) => 4.0 * p.q2() * dt * s,
        Process::Ma1(p) => {
            let t = p.theta();
            let shape = if t >= 0.0 {
                (1.0 - t) * (1.0 - t) + 4.0 * t * c
            } else {
                (1.0 + t) * (1.0 + t) - 4.0 * t * s
            };
            p.sigma2() * dt * shape
        }
        Process::Ar1(p) => {
            let phi = p.phi();
            let den = if phi >= 0.0 {
                (1.0 - phi) * (1.0 - phi) + 4.0 * phi * s
            } else {
                (1.0 + phi) * (1.0 + phi) - 4.0 * phi * c
            };
            p.sigma2() * dt / den
        }
        Process::GaussMarkov(g) => {
            let l = g.beta() * dt;
            let phi = (-l).exp();
            let a = -(-l).exp_m1();
            let v2 = g.sigma2() * -(-2.0 * l).exp_m1();
            v2 * dt / (a * a + 4.0 * phi * s)
        }
        Process::RandomWalk(p) => p.gamma2() * dt / (4.0 * s),
        Process::Drift(_) | Process::Sinusoid(_) => return None,
        Process::ArP(a) => {
            // σ²Δt / |1 − Σ φ_k e^{−ikω}|², ω = 2πfΔt: cos ω = c − s, sin ω = 2√(sc)
            let (c1, s1) = (c - s, 2.0 * (s * c).sqrt());
            let (mut ck, mut sk) = (1.0, 0.0);
            let (mut re, mut im) = (1.0, 0.0);
            for &f in a.phi() {
                (ck, sk) = (ck * c1 - sk * s1, sk * c1 + ck * s1);
                re -= f * ck;
                im += f * sk;
            }
            a.sigma2() * dt / (re * re + im * im)
        }
        Process::Arma(a) => {
            // σ²Δt |1 + Σ θ_k e^{−ikω}|² / |1 − Σ φ_k e^{−ikω}|², ω = 2πfΔt
            let (c1, s1) = (c - s, 2.0 * (s * c).sqrt());
            let poly = |coef: &[f64], sign: f64| {
                let (mut ck, mut sk) = (1.0, 0.0);
                let (mut re, mut im) = (1.0, 0.0);
                for &f in coef {
                    (ck, sk) = (ck * c1 - sk * s1, sk * c1 + ck * s1);
                    re += sign * f * ck;
                    im -= sign * f * sk;
                }
                re * re + im * im
            };
            a.sigma2() * dt * poly(a.theta(), 1.0) / poly(a.phi(), -1.0)
        }
        Process::BiasInstability(b) => {
            // the sum of its states' GM spectra (L_i = 1/T_i per sample)
            let (t, u) = b.band().states().ok()?;
            let b2 = b.b() * b.b();
            t.iter()
                .zip(&u)
                .map(|(&t, &u)| {
                    let l = 1.0 / t;
                    let phi = (-l).exp();
                    let a = -(-l).exp_m1();
                    let v2 = b2 * u * -(-2.0 * l).exp_m1();
                    v2 * dt / (a * a + 4.0 * phi * s)
                })
                .sum()
        }
        Process::Plp(p) => crate::long_memory::plp_psd(&p, s, dt),
        Process::Fgn(f) => crate::long_memory::fgn_psd(&f, s, c, dt),
    })
}

pub(crate) const SINUSOID_NOT_A_FUNCTION: SpectralError = SpectralError::NotAFunction {
    process: "SIN",
    why: "a random-phase sinusoid has the line spectrum (alpha2/4)[delta(f - f0) + delta(f + f0)], f0 = beta*rate/(2 pi); its AV is alpha2 sin^4(beta m/2)/(m sin(beta/2))^2 (closed form)",
};

pub(crate) const DRIFT_NOT_A_FUNCTION: SpectralError = SpectralError::NotAFunction {
    process: "DR",
    why: "a deterministic ramp has the generalized spectrum (omega*rate)^2/(8 pi^2) * delta''(f); its AV is omega^2 m^2 / 2 (closed form)",
};

/// sin²(πfΔt) and cos²(πfΔt), each without cancellation (reduced to the Nyquist band).
pub(crate) fn sin_cos_sq(f_hz: f64, rate: f64) -> (f64, f64) {
    // y = f/rate reduced to [0, 1/2]: S is even and periodic in f with period `rate`.
    let mut y = (f_hz / rate).rem_euclid(1.0);
    if y > 0.5 {
        y = 1.0 - y;
    }
    let x = std::f64::consts::PI * y;
    let t = std::f64::consts::PI * (0.5 - y);
    (x.sin().powi(2), t.sin().powi(2))
}

/// Two-sided PSD S(f) of one process at frequency `f_hz` (Hz) for sampling rate `rate_hz`,
/// in unit²/Hz (see the module docs for the convention and the formulas). RW gives its
/// generalized 1/f²-type spectrum (+∞ at f = 0); DR is an error (its spectrum is a
/// distribution).
///
/// ```
/// use processes::{Process, QuantizationNoise, WhiteNoise};
/// use spectral::psd;
/// let wn = Process::from(WhiteNoise::new(2e-4)?);
/// assert!((psd(&wn, 3.0, 100.0)? - 2e-6).abs() < 1e-20); // σ²Δt, flat
/// // QN at the Nyquist frequency: 4Q²Δt.
/// let qn = Process::from(QuantizationNoise::new(1.0)?);
/// assert!((psd(&qn, 50.0, 100.0)? - 0.04).abs() < 1e-15);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn psd(process: &Process, f_hz: f64, rate_hz: f64) -> Result<f64> {
    let rate = check_rate(rate_hz)?;
    if !f_hz.is_finite() {
        return Err(SpectralError::InvalidFrequency(f_hz));
    }
    crate::error::check_process(process)?;
    if let Process::Sinusoid(_) = process {
        return Err(SINUSOID_NOT_A_FUNCTION);
    }
    let (s, c) = sin_cos_sq(f_hz, rate);
    psd_sc(process, s, c, 1.0 / rate).ok_or(DRIFT_NOT_A_FUNCTION)
}

/// Two-sided PSD of a fully specified model: the sum of its components' PSDs
/// (independent components, book Corollary 4.1's premise). Errors on DR components.
///
/// ```
/// use processes::{WhiteNoise, Ar1};
/// use spectral::{model_psd, psd};
/// let model = (WhiteNoise::new(1.0)? + Ar1::new(0.9, 1.0)?)?;
/// let f = 7.0;
/// let parts: f64 = model.processes()?.iter().map(|p| psd(p, f, 100.0).unwrap()).sum();
/// assert_eq!(model_psd(&model, f, 100.0)?, parts);
/// # Ok::<(), spectral::SpectralError>(())
/// ```
pub fn model_psd(model: &Model, f_hz: f64, rate_hz: f64) -> Result<f64> {
    let mut total = 0.0;
    for p in model.processes()? {
        total += psd(&p, f_hz, rate_hz)?;
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;
    use processes::{Ar1, Ma1, QuantizationNoise};

    /// S(f) = Δt Σ_h γ(h) e^{−2πifhΔt} summed directly for the finite-ACV processes and
    /// a long truncated sum for AR1.
    #[test]
    fn psd_is_the_fourier_transform_of_the_autocovariance() {
        let rate = 50.0;
        let dt = 1.0 / rate;
        let procs: Vec<Process> = vec![
            QuantizationNoise::new(0.3).unwrap().into(),
            Ma1::new(-0.7, 2.0).unwrap().into(),
            Ma1::new(1.5, 2.0).unwrap().into(),
            Ar1::new(0.6, 1.0).unwrap().into(),
            Ar1::new(-0.8, 1.0).unwrap().into(),
        ];
        for p in procs {
            for f in [0.0, 1.3, 12.5, 24.9, 25.0, 31.0] {
                let mut s = p.autocovariance(0, rate).unwrap();
                for h in 1..400u64 {
                    let g = p.autocovariance(h, rate).unwrap();
                    s += 2.0 * g * (2.0 * std::f64::consts::PI * f * h as f64 * dt).cos();
                }
                let direct = s * dt;
                let ours = psd(&p, f, rate).unwrap();
                assert!(
                    (ours - direct).abs()
                        <= crate::tolerances::PSD_FOURIER_REL * direct.abs().max(1e-3 * dt),
                    "{p:?} f={f}: {ours} vs {direct}"
                );
            }
        }
    }
}
