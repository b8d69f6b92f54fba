//! Fast, reproducible simulation of latent processes and composite models.
//!
//! [`Model::simulate`] draws one path X_1, …, X_n of a model (the sum of its components,
//! book Definition 2.8); [`Model::simulate_components`] also returns every component
//! separately (book Example 2.4); [`Model::simulate_stream`] draws independent stream
//! number `stream` for the same seed (e.g. one per channel of a simulated IMU), and
//! [`Process::simulate_into`] adds one process's path to a buffer.
//!
//! # Conventions (book §2.2)
//! Time indices t = 1, …, n are stored at positions 0, …, n − 1.
//! - WN: X_t iid N(0, σ²).
//! - QN: X_t = U_t − U_{t−1}, U_0, …, U_n iid uniform on (−a, a) with a² / 3 = Q², so
//!   γ(0) = 2Q², γ(1) = −Q² and AV(m) = 3Q²/m².
//! - DR: X_t = ω t exactly.
//! - RW: X_0 = 0, X_t = X_{t−1} + ε_t, ε_t iid N(0, γ²).
//! - AR1: X_1 ~ N(0, v²/(1 − φ²)) (the stationary law, so the path is exactly stationary,
//!   unlike simts which starts at 0), then X_t = φ X_{t−1} + Z_t, Z_t iid N(0, v²).
//! - GM: the AR1 of [`GaussMarkov::to_ar1`](crate::GaussMarkov::to_ar1) at the given rate.
//! - MA1: X_t = W_t + θ W_{t−1}, W_0, …, W_n iid N(0, σ²) (W_0 is drawn too, so the path is
//!   stationary).
//! - SIN: X_t = α sin(βt + U) with U = 2π·u, u the first uniform on [0, 1) of the
//!   component's stream (so a path is one phase; βt + U is formed in f64, which for
//!   t ~ 10⁹ leaves ~10⁻⁷ rad of phase rounding).
//! - BI: the sum of its AR1 states ([`BiasInstability::ar1_states`](crate::BiasInstability::ar1_states)),
//!   each simulated as an AR1 (stationary start). A BI with an AUTO band takes the band
//!   m = 1 … n of the simulated record.
//!
//! # Random streams and reproducibility
//! The output depends only on (model, n, rate, seed, stream), never on the number of rayon
//! threads: it is the same bits on 1 or 64 threads.
//! - A xoshiro256++ state is derived from `(seed, stream)`: word i of the 256-bit state is
//!   `mix(seed + (i+1)·G) ^ mix(stream · K_i)`, where `mix` is the SplitMix64 finalizer
//!   (a bijection of u64 with mix(0) = 0), G the golden-ratio increment and K_i odd
//!   constants; distinct streams of one seed thus start from distinct states.
//! - Component c of the model (in model order) starts from that state advanced by c
//!   `long_jump`s (2^192 steps each); components never share random numbers.
//! - The time axis is cut into chunks of [`CHUNK_LEN`] = 2^16 samples; chunk k of component
//!   c uses the component's state advanced by k `jump`s (2^128 steps each). These states are
//!   computed sequentially (≈ 1 µs per chunk), then chunks are simulated in parallel.
//! - QN and MA1 need the previous innovation: a full chunk k draws U_{s−1}, …, U_{e−2} for
//!   its samples s..e from its own stream, and its last innovation U_{e−1} is the first
//!   draw of chunk k + 1's stream, which chunk k + 1 uses as its own U_{s−1}. Every
//!   innovation is drawn exactly once, and no fix-up is needed. The final chunk of a path,
//!   if partial, draws all its innovations itself.
//! - Hence simulating fewer samples gives a prefix of a longer simulation (same model, seed
//!   and stream), for every process.
//! - RW and AR1/GM are recurrences. Chunks are processed in groups (a few per thread so the
//!   data stays in cache): (1) in parallel, each chunk runs the recurrence from 0 (for
//!   chunk 0 of an AR1, from its stationary draw), giving a local path y and its last value
//!   e_k; (2) sequentially, the carries C_0 = 0, C_{k+1} = e_k + C_k (RW) or
//!   e_k + φ^L C_k (AR1); (3) in parallel, X = y + C_k (RW) or X = y + φ^{j+1} C_k for the
//!   j-th sample of the chunk (AR1), which is the exact solution of the recurrence. The
//!   powers φ^{j+1} are four running products (lane j mod 4 times φ⁴ per step), and φ^L in
//!   (2) is the very value lane 3 reaches, so a chunk's last value is exactly the next
//!   chunk's carry.
//! - The total is summed in model order: total = ((c_0 + c_1) + c_2) + …, so
//!   [`Simulation::total`] is bit for bit [`Model::simulate`] and the sum of
//!   [`Simulation::components`] — except around a BI component, whose states are added to the
//!   total one by one (((c_0 + s_1) + s_2) + …) while its component path is (s_1 + s_2) + …:
//!   the two agree to rounding.
//! - A BI's state 0 uses the component's generator state; its state j ≥ 1 starts from the
//!   state of stream `stream` of the seed mix64(seed ⊕ j·K_BI) advanced by as many
//!   `long_jump`s as the component's index (a distinct seed per state, so its numbers are
//!   independent of the other components' for every practical purpose, but not provably
//!   disjoint as the jumps are).
//!
//! # Memory and speed
//! The output is written once into fresh zeroed memory (no separate zeroing pass); on Linux,
//! buffers of 4 MiB and more are advised transparent huge pages, which made first touching
//! the output 5× cheaper on the project's VM. Recurrences keep only a few chunks of scratch
//! per thread. Each component of a composite fills a block of 512 samples in turn, so a
//! composite costs about the sum of its parts without the per-part output traffic.
//!
//! Thread scaling into a fresh buffer: a model without recurrence (only WN, QN, DR, MA1) is
//! one parallel loop over all its chunks. The pool gives each thread a contiguous run of
//! chunks, so each thread page-faults its own huge pages as it writes them, with no serial
//! pass and no barrier. Through the recurrences' groups of 8 chunks (4 MB, so 191 barriers
//! at n = 10^8) the thread that finished its share first, or took fewer page faults in it,
//! waited for the other at every barrier: 13 ms of 130 on 2 threads even into an
//! already-faulted buffer. Measured for WN, n = 10^8 (fresh 800 MB output), best of 9 runs
//! under `chrt -f 10` on the project's 2-core VM: groups 260–270 ms on 1 thread, 141–151 ms
//! on 2 (1.75–1.85×); one loop 225–253 ms and 118–130 ms (1.91–1.99×), 5–12 ms more than
//! into an already-faulted buffer; criterion, min / median of 10: 232 / 261 ms and
//! 120 / 133 ms. Tried and not kept: `MADV_POPULATE_WRITE` of each chunk by its worker just
//! before generating (131 vs 130 ms on 2 threads: one huge-page fault already maps 2 MiB);
//! 4 KiB pages, i.e. no huge-page advice (560–570 ms and 315–323 ms, with or without
//! populate). A private `mmap` (e.g. `MAP_NORESERVE`) cannot back the output, a `Vec` that
//! the global allocator frees.
//!
//! Normal variates come from `rand_distr`'s ziggurat `StandardNormal`; uniforms from the top
//! 52 bits of a 64-bit draw. Changing either changes the streams (see the value-stability
//! test).
//!
//! ```
//! use processes::Model;
//! let model: Model = "WN(sigma2=1) + AR1(phi=0.9, sigma2=0.19)".parse()?;
//! let x = model.simulate(1000, 100.0, 42)?;
//! assert_eq!(x.len(), 1000);
//! assert_eq!(x, model.simulate(1000, 100.0, 42)?); // reproducible
//! let sim = model.simulate_components(1000, 100.0, 42)?;
//! assert_eq!(sim.total, x);
//! assert_eq!(sim.components[1].name(), "AR1(phi=0.9, sigma2=0.19)");
//! # Ok::<(), processes::ProcessError>(())
//! ```

use crate::error::{ProcessError, Result};
use crate::model::Model;
use crate::process::Process;
use crate::series::TimeSeries;
use rand_core::{Rng, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;

/// Number of samples per chunk of the fixed chunk layout (2^16). Each chunk of each
/// component has its own random stream; this constant is part of the reproducibility
/// contract (changing it changes every simulated path).
///
/// ```
/// use processes::{Model, CHUNK_LEN};
/// // A shorter path is a prefix of a longer one, across chunk boundaries too.
/// let m: Model = "WN(sigma2=1) + RW(gamma2=0.01)".parse()?;
/// let long = m.simulate(2 * CHUNK_LEN + 5, 1.0, 3)?;
/// let short = m.simulate(CHUNK_LEN + 1, 1.0, 3)?;
/// assert_eq!(short.values(), &long.values()[..CHUNK_LEN + 1]);
/// # Ok::<(), processes::ProcessError>(())
/// ```
pub const CHUNK_LEN: usize = 1 << 16;

/// Samples per inner block: each component fills a block in turn, so the block stays in L1.
const BLOCK_LEN: usize = 512;
const _: () = assert!(BLOCK_LEN.is_multiple_of(LANES) && CHUNK_LEN.is_multiple_of(BLOCK_LEN));

/// Minimum number of chunks per group of the recurrence scheme (the group size does not
/// change the output; it only keeps the scratch data in cache).
const MIN_GROUP_CHUNKS: usize = 8;

/// Golden-ratio increment of SplitMix64.
const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;
/// Odd multipliers mixing the stream number into each state word.
const STREAM_KEYS: [u64; 4] = [
    0xD1B5_4A32_D192_ED03,
    0xAEF1_7502_108E_F2D9,
    0xF135_7AEA_2E62_A9C5,
    0xCB9C_59B3_F9F8_7D4D,
];

/// A simulated composite path with each component separately (book Example 2.4).
///
/// `components[c]` is the path of the model's component c, named by its text form (e.g.
/// `"AR1(phi=0.9, sigma2=1)"`); `total` is their sum, named by the model's text form, and is
/// bit for bit what [`Model::simulate`] returns for the same arguments.
///
/// ```
/// use processes::Model;
/// let model: Model = "2*AR1(phi=0.9, sigma2=1) + WN(sigma2=2)".parse()?;
/// let sim = model.simulate_components(500, 1.0, 7)?;
/// assert_eq!(sim.components.len(), 3);
/// let sum: f64 = sim.components.iter().map(|c| c.values()[10]).sum();
/// assert_eq!(sim.total.values()[10], sum);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Simulation {
    /// One series per model component, in model order.
    pub components: Vec<TimeSeries>,
    /// The sum of the components (the observed process).
    pub total: TimeSeries,
}

/// SplitMix64 output function: a bijection of u64 with mix64(0) = 0.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The generator state of stream `stream` of `seed` (before any component long-jump).
fn stream_state(seed: u64, stream: u64) -> Xoshiro256PlusPlus {
    let mut bytes = [0u8; 32];
    for (i, word) in bytes.chunks_exact_mut(8).enumerate() {
        let w = mix64(seed.wrapping_add(GOLDEN.wrapping_mul(i as u64 + 1)))
            ^ mix64(stream.wrapping_mul(STREAM_KEYS[i]));
        word.copy_from_slice(&w.to_le_bytes());
    }
    // `from_seed` maps the (astronomically unlikely) all-zero state to a valid one.
    Xoshiro256PlusPlus::from_seed(bytes)
}

/// Uniform on (−1, 1) from the top 52 bits j of a draw: (j + ½)·2^-51 − 1, computed
/// exactly. The 2^52 values are symmetric about 0 (j ↔ 2^52 − 1 − j), so the mean is
/// exactly 0 and the variance 1/3 up to 2^-104.
#[inline(always)]
fn uniform_pm1(rng: &mut Xoshiro256PlusPlus) -> f64 {
    const SCALE: f64 = 1.0 / (1u64 << 51) as f64;
    ((rng.next_u64() >> 12) as f64 + 0.5) * SCALE - 1.0
}

#[inline(always)]
fn normal(rng: &mut Xoshiro256PlusPlus) -> f64 {
    StandardNormal.sample(rng)
}

/// The sampling recipe of one component at a given rate.
#[derive(Debug, Clone, Copy)]
enum Gen {
    White {
        sd: f64,
    },
    /// U uniform on (−a, a).
    Quant {
        a: f64,
    },
    Drift {
        omega: f64,
    },
    Walk {
        sd: f64,
    },
    /// `sd0` is the stationary standard deviation, `phi_l` = φ^L as [`ar1_powers`] gives it.
    Ar1 {
        phi: f64,
        sd: f64,
        sd0: f64,
        phi_l: f64,
    },
    Ma1 {
        theta: f64,
        sd: f64,
    },
    /// α, β and the phase U (drawn in [`CompPlan::new`]).
    Sin {
        amp: f64,
        beta: f64,
        phase: f64,
    },
}

impl Gen {
    fn new(p: &Process, rate_hz: f64, n: usize) -> Result<Self> {
        Ok(match *p {
            Process::WhiteNoise(w) => Gen::White {
                sd: w.sigma2().sqrt(),
            },
            Process::QuantizationNoise(q) => Gen::Quant {
                a: (3.0 * q.q2()).sqrt(),
            },
            Process::Drift(d) => Gen::Drift { omega: d.omega() },
            Process::RandomWalk(r) => Gen::Walk {
                sd: r.gamma2().sqrt(),
            },
            Process::Ar1(a) => Self::ar1(a.phi(), a.sigma2(), a.stationary_variance(), n),
            Process::GaussMarkov(g) => {
                let a = g.to_ar1(rate_hz)?;
                Self::ar1(a.phi(), a.sigma2(), a.stationary_variance(), n)
            }
            Process::Ma1(m) => Gen::Ma1 {
                theta: m.theta(),
                sd: m.sigma2().sqrt(),
            },
            Process::BiasInstability(_) => {
                return Err(ProcessError::InvalidArgument(
                    "a BI is simulated through its AR1 states".into(),
                ));
            }
            Process::Sinusoid(p) => Gen::Sin {
                amp: p.alpha2().sqrt(),
                beta: p.beta(),
                phase: 0.0,
            },
            Process::ArP(_) => {
                return Err(ProcessError::InvalidArgument(
                    "AR2/AR3/AR4 are simulated by Model::simulate/simulate_components (sequentially, ArP::simulate), not by the chunked per-process path".into(),
                ));
            }
            Process::Arma(_) => {
                return Err(ProcessError::InvalidArgument(
                    "MA2/ARMA are simulated by Model::simulate/simulate_components (sequentially, Arma::simulate), not by the chunked per-process path".into(),
                ));
            }
            Process::Plp(_) | Process::Fgn(_) => {
                return Err(ProcessError::InvalidArgument(
                    "PLP/FGN are simulated by Model::simulate/simulate_components (circulant embedding, whole record at once), not by the chunked per-process path".into(),
                ));
            }
        })
    }

    fn ar1(phi: f64, v2: f64, stationary: f64, n: usize) -> Self {
        // φ^L exactly as the fix-up pass reaches it (lane 3 after (L − 1)/4 steps), so the
        // last value of a chunk is bit for bit the next chunk's carry. Only carries between
        // chunks use it, so a single chunk skips the 2^14 products.
        let mut phi_l = phi;
        if n > CHUNK_LEN {
            let ([.., p4], step) = ar1_powers(phi);
            phi_l = p4;
            for _ in 0..(CHUNK_LEN - 1) / LANES {
                phi_l *= step;
            }
        }
        Gen::Ar1 {
            phi,
            sd: v2.sqrt(),
            sd0: stationary.sqrt(),
            phi_l,
        }
    }

    fn is_recurrence(&self) -> bool {
        matches!(self, Gen::Walk { .. } | Gen::Ar1 { .. })
    }

    fn uses_rng(&self) -> bool {
        !matches!(self, Gen::Drift { .. } | Gen::Sin { .. })
    }

    /// Next carry from the carry into a chunk and the chunk's local end value.
    fn next_carry(&self, carry: f64, local_end: f64) -> f64 {
        match *self {
            Gen::Walk { .. } => local_end + carry,
            Gen::Ar1 { phi_l, .. } => local_end + phi_l * carry,
            _ => 0.0,
        }
    }

    /// Runs the recurrence of chunk `k` from 0 (chunk 0 of AR1: from the stationary draw)
    /// into `dst`; returns the last value.
    fn local_path(&self, rng: &mut Xoshiro256PlusPlus, k: usize, dst: &mut [f64]) -> f64 {
        // Draw a block of standard normals in place, then run the recurrence over it: the
        // two loops are each tight (the running value stays in a register).
        match *self {
            Gen::Walk { sd } => {
                let mut y = 0.0;
                for block in dst.chunks_mut(BLOCK_LEN) {
                    fill_normals(rng, block);
                    for x in block.iter_mut() {
                        y += sd * *x;
                        *x = y;
                    }
                }
                y
            }
            Gen::Ar1 { phi, sd, sd0, .. } => {
                let mut y = 0.0;
                for (b, block) in dst.chunks_mut(BLOCK_LEN).enumerate() {
                    fill_normals(rng, block);
                    let rest = if b == 0 {
                        // X_1 of chunk 0 from the stationary law; other chunks start at 0.
                        y = if k == 0 { sd0 } else { sd } * block[0];
                        block[0] = y;
                        &mut block[1..]
                    } else {
                        block
                    };
                    for x in rest.iter_mut() {
                        y = phi * y + sd * *x;
                        *x = y;
                    }
                }
                y
            }
            _ => 0.0,
        }
    }
}

/// Independent chains of the AR1 fix-up powers (4 multiplications in flight instead of
/// one dependent chain).
const LANES: usize = 4;

/// The powers φ^{j+1} of the AR1 fix-up for the j-th sample of a chunk are kept in
/// [`LANES`] chains: lane r holds φ^{r+1} at first and is multiplied by φ^4 after each of
/// its samples (j ≡ r mod 4). Returns the initial lanes [φ, φ², φ³, φ⁴] and the step φ⁴.
fn ar1_powers(phi: f64) -> ([f64; LANES], f64) {
    let p2 = phi * phi;
    let p3 = p2 * phi;
    let p4 = p3 * phi;
    ([phi, p2, p3, p4], p4)
}

/// Fills `dst` with standard normal draws.
#[inline(always)]
fn fill_normals(rng: &mut Xoshiro256PlusPlus, dst: &mut [f64]) {
    for x in dst.iter_mut() {
        *x = normal(rng);
    }
}

/// One component ready to simulate: its recipe and the generator state of every chunk
/// (one more than the number of chunks: QN and MA1 look one draw ahead).
struct CompPlan {
    recipe: Gen,
    states: Vec<Xoshiro256PlusPlus>,
}

fn n_chunks(n: usize) -> usize {
    n.div_ceil(CHUNK_LEN)
}

fn chunk_len(n: usize, k: usize) -> usize {
    (n - k * CHUNK_LEN).min(CHUNK_LEN)
}

impl CompPlan {
    fn new(mut recipe: Gen, mut state: Xoshiro256PlusPlus, n: usize) -> Self {
        if let Gen::Sin { phase, .. } = &mut recipe {
            // u in [0, 1) from the top 53 bits
            let u = (state.clone().next_u64() >> 11) as f64 / (1u64 << 53) as f64;
            *phase = 2.0 * std::f64::consts::PI * u;
        }
        let states = if recipe.uses_rng() {
            let count = n_chunks(n) + 1;
            let mut v = Vec::with_capacity(count);
            for _ in 0..count {
                v.push(state.clone());
                state.jump();
            }
            v
        } else {
            Vec::new()
        };
        Self { recipe, states }
    }
}

/// The per-chunk state of one component while its values are produced block by block.
enum Cursor<'a> {
    White {
        rng: Xoshiro256PlusPlus,
        sd: f64,
    },
    /// QN (`scale` = a, values U) and MA1 (`scale` = σ, values W): `own` draws come from
    /// this chunk's stream, the last one is `ahead` (first draw of the next chunk).
    Lagged {
        rng: Xoshiro256PlusPlus,
        quant: bool,
        scale: f64,
        theta: f64,
        prev: f64,
        ahead: f64,
        own: usize,
        pos: usize,
    },
    Drift {
        omega: f64,
        t: u64,
    },
    Sin {
        amp: f64,
        beta: f64,
        phase: f64,
        t: u64,
    },
    Walk {
        local: &'a [f64],
        carry: f64,
        pos: usize,
    },
    Ar1 {
        local: &'a [f64],
        carry: f64,
        /// φ^{j+1} for the next sample of each lane (see [`ar1_powers`]).
        q: [f64; LANES],
        step: f64,
        done: bool,
        pos: usize,
    },
}

impl<'a> Cursor<'a> {
    fn new(plan: &CompPlan, k: usize, len: usize, local: &'a [f64], carry: f64) -> Self {
        match plan.recipe {
            Gen::White { sd } => Cursor::White {
                rng: plan.states[k].clone(),
                sd,
            },
            Gen::Quant { a } => Self::lagged(plan, k, len, true, a, 1.0),
            Gen::Ma1 { theta, sd } => Self::lagged(plan, k, len, false, sd, theta),
            Gen::Drift { omega } => Cursor::Drift {
                omega,
                t: (k * CHUNK_LEN) as u64 + 1,
            },
            Gen::Sin { amp, beta, phase } => Cursor::Sin {
                amp,
                beta,
                phase,
                t: (k * CHUNK_LEN) as u64 + 1,
            },
            Gen::Walk { .. } => Cursor::Walk {
                local,
                carry,
                pos: 0,
            },
            Gen::Ar1 { phi, .. } => {
                let (q, step) = ar1_powers(phi);
                Cursor::Ar1 {
                    local,
                    carry,
                    q,
                    step,
                    done: carry == 0.0,
                    pos: 0,
                }
            }
        }
    }

    fn lagged(plan: &CompPlan, k: usize, len: usize, quant: bool, scale: f64, theta: f64) -> Self {
        let draw = |rng: &mut Xoshiro256PlusPlus| {
            if quant {
                scale * uniform_pm1(rng)
            } else {
                scale * normal(rng)
            }
        };
        let mut rng = plan.states[k].clone();
        let prev = draw(&mut rng);
        // A full chunk takes its last innovation from the next chunk's stream; the final,
        // partial chunk of a path draws all of its own, so a shorter path is a prefix of a
        // longer one.
        let (own, ahead) = if len == CHUNK_LEN {
            (len - 1, draw(&mut plan.states[k + 1].clone()))
        } else {
            (len, 0.0)
        };
        Cursor::Lagged {
            rng,
            quant,
            scale,
            theta,
            prev,
            ahead,
            own,
            pos: 0,
        }
    }

    /// Writes the next `dst.len()` values of the component.
    #[inline(always)]
    fn fill(&mut self, dst: &mut [f64]) {
        match self {
            Cursor::White { rng, sd } => {
                let sd = *sd;
                for x in dst.iter_mut() {
                    *x = sd * normal(rng);
                }
            }
            Cursor::Lagged {
                rng,
                quant,
                scale,
                theta,
                prev,
                ahead,
                own,
                pos,
            } => {
                let n_own = dst.len().min(*own - (*pos).min(*own));
                let (head, tail) = dst.split_at_mut(n_own);
                let (scale, theta) = (*scale, *theta);
                let mut u_prev = *prev;
                if *quant {
                    for x in head.iter_mut() {
                        let u = scale * uniform_pm1(rng);
                        *x = u - u_prev;
                        u_prev = u;
                    }
                } else {
                    for x in head.iter_mut() {
                        let w = scale * normal(rng);
                        *x = w + theta * u_prev;
                        u_prev = w;
                    }
                }
                if let Some(x) = tail.first_mut() {
                    // The chunk's last sample uses the next chunk's first draw.
                    let u = *ahead;
                    *x = if *quant {
                        u - u_prev
                    } else {
                        u + theta * u_prev
                    };
                    u_prev = u;
                }
                *prev = u_prev;
                *pos += dst.len();
            }
            Cursor::Drift { omega, t } => {
                let omega = *omega;
                for x in dst.iter_mut() {
                    *x = omega * *t as f64;
                    *t += 1;
                }
            }
            Cursor::Sin {
                amp,
                beta,
                phase,
                t,
            } => {
                let (a, b, u) = (*amp, *beta, *phase);
                for x in dst.iter_mut() {
                    *x = a * (b * *t as f64 + u).sin();
                    *t += 1;
                }
            }
            Cursor::Walk { local, carry, pos } => {
                let src = &local[*pos..*pos + dst.len()];
                let c = *carry;
                for (x, y) in dst.iter_mut().zip(src) {
                    *x = y + c;
                }
                *pos += dst.len();
            }
            Cursor::Ar1 {
                local,
                carry,
                q,
                step,
                done,
                pos,
            } => {
                let src = &local[*pos..*pos + dst.len()];
                *pos += dst.len();
                if *done {
                    dst.copy_from_slice(src);
                    return;
                }
                // Blocks start at multiples of BLOCK_LEN (a multiple of LANES), so sample i
                // of the block belongs to lane i mod LANES.
                let (c, st) = (*carry, *step);
                let mut lanes = *q;
                for (xs, ys) in dst.chunks_mut(LANES).zip(src.chunks(LANES)) {
                    for ((x, y), p) in xs.iter_mut().zip(ys).zip(lanes.iter_mut()) {
                        *x = y + *p * c;
                        *p *= st;
                    }
                }
                *q = lanes;
                // |φ^{j+1} C| only decreases: once every lane gives exactly 0, all later
                // corrections are 0 and y + 0 = y.
                if lanes.iter().all(|p| p * c == 0.0) {
                    *done = true;
                }
            }
        }
    }
}

/// How the first component enters the output buffer.
#[derive(Clone, Copy, PartialEq)]
enum First {
    /// `out` = c_0 (a fresh buffer).
    Assign,
    /// `out` += c_0 (adding to existing data).
    Add,
}

/// Simulates the components of `plans` over `out.len()` samples into `out` (their sum) and,
/// when given, into each component buffer. Returns the first index where `out` is not
/// finite, if any.
fn run(
    plans: &[CompPlan],
    out: &mut [f64],
    mut comps: Option<&mut [Vec<f64>]>,
    first: First,
) -> Result<Option<usize>> {
    let n = out.len();
    let total_chunks = n_chunks(n);
    let rec: Vec<usize> = (0..plans.len())
        .filter(|&j| plans[j].recipe.is_recurrence())
        .collect();
    // Recurrences need groups (their scratch stays in cache, their carries are sequential).
    // Without one, a single group spans the path: the pool splits it into contiguous runs
    // of chunks with no barrier every few chunks (see "Memory and speed" above).
    let group = if rec.is_empty() {
        total_chunks
    } else {
        (4 * rayon::current_num_threads()).max(MIN_GROUP_CHUNKS)
    };
    // Room per chunk and recurrence in the scratch buffer: a chunk, or all of a short path.
    let room = CHUNK_LEN.min(n);
    let stride = rec.len() * room;
    let mut scratch = try_zeros(stride * group.min(total_chunks))?;
    let mut carries = vec![0.0f64; rec.len()];
    let mut first_bad: Option<usize> = None;

    for g0 in (0..total_chunks).step_by(group) {
        let g1 = (g0 + group).min(total_chunks);
        let (lo, hi) = (g0 * CHUNK_LEN, (g1 * CHUNK_LEN).min(n));

        // A single chunk runs on the calling thread: no hand-off to the pool.
        let parallel = g1 - g0 > 1;

        // (1) local paths of the recurrences, in parallel over chunks.
        let local_chunk = |ci: usize, s: &mut [f64]| -> Vec<f64> {
            let k = g0 + ci;
            let len = chunk_len(n, k);
            rec.iter()
                .zip(s.chunks_mut(room))
                .map(|(&j, dst)| {
                    let plan = &plans[j];
                    let mut rng = plan.states[k].clone();
                    plan.recipe.local_path(&mut rng, k, &mut dst[..len])
                })
                .collect()
        };
        let ends: Vec<Vec<f64>> = if rec.is_empty() {
            vec![Vec::new(); g1 - g0]
        } else if parallel {
            scratch[..(g1 - g0) * stride]
                .par_chunks_mut(stride)
                .enumerate()
                .map(|(ci, s)| local_chunk(ci, s))
                .collect()
        } else {
            vec![local_chunk(0, &mut scratch[..stride])]
        };

        // (2) carries, sequentially: into_chunk[ci][r] is C_k for chunk g0 + ci.
        let mut into_chunk = Vec::with_capacity(g1 - g0);
        for e in &ends {
            into_chunk.push(carries.clone());
            for (r, &j) in rec.iter().enumerate() {
                carries[r] = plans[j].recipe.next_carry(carries[r], e[r]);
            }
        }

        // (3) every component, block by block, summed in model order; in parallel over chunks.
        let mut comp_chunks: Vec<Vec<&mut [f64]>> = (g0..g1).map(|_| Vec::new()).collect();
        if let Some(cs) = comps.as_deref_mut() {
            for c in cs.iter_mut() {
                for (ci, piece) in c[lo..hi].chunks_mut(CHUNK_LEN).enumerate() {
                    comp_chunks[ci].push(piece);
                }
            }
        }
        let scratch_ref = &scratch;
        let rec_ref = &rec;
        let final_chunk = |ci: usize, o: &mut [f64], mut cc: Vec<&mut [f64]>, carry: Vec<f64>| {
            let k = g0 + ci;
            let len = o.len();
            let mut cursors: Vec<Cursor<'_>> = plans
                .iter()
                .enumerate()
                .map(|(j, plan)| {
                    let (local, c): (&[f64], f64) = match rec_ref.iter().position(|&r| r == j) {
                        Some(r) => {
                            let at = ci * stride + r * room;
                            (&scratch_ref[at..at + len], carry[r])
                        }
                        None => (&[], 0.0),
                    };
                    Cursor::new(plan, k, len, local, c)
                })
                .collect();
            let mut tmp = [0.0f64; BLOCK_LEN];
            let mut bad = None;
            for b0 in (0..len).step_by(BLOCK_LEN) {
                let b1 = (b0 + BLOCK_LEN).min(len);
                let ob = &mut o[b0..b1];
                for (j, cur) in cursors.iter_mut().enumerate() {
                    if j == 0 && first == First::Assign {
                        cur.fill(ob);
                        if let Some(c) = cc.get_mut(0) {
                            c[b0..b1].copy_from_slice(ob);
                        }
                    } else {
                        let t = &mut tmp[..b1 - b0];
                        cur.fill(t);
                        for (x, v) in ob.iter_mut().zip(t.iter()) {
                            *x += v;
                        }
                        if let Some(c) = cc.get_mut(j) {
                            c[b0..b1].copy_from_slice(t);
                        }
                    }
                }
                if bad.is_none() {
                    // A branch-free test first (vectorizes); locate only on failure.
                    if ob.iter().fold(false, |acc, v| acc | !v.is_finite()) {
                        bad = ob.iter().position(|v| !v.is_finite()).map(|i| b0 + i);
                    }
                }
            }
            bad.map(|i| lo + ci * CHUNK_LEN + i)
        };
        let bad = if parallel {
            out[lo..hi]
                .par_chunks_mut(CHUNK_LEN)
                .zip(comp_chunks.into_par_iter())
                .zip(into_chunk.into_par_iter())
                .enumerate()
                .filter_map(|(ci, ((o, cc), carry))| final_chunk(ci, o, cc, carry))
                .min()
        } else {
            let cc = comp_chunks.pop().unwrap_or_default();
            let carry = into_chunk.pop().unwrap_or_default();
            final_chunk(0, &mut out[lo..hi], cc, carry)
        };
        if first_bad.is_none() {
            first_bad = bad;
        }
    }
    Ok(first_bad)
}

/// A zero-filled vector of `len` values, or an error if it cannot be allocated.
///
/// Large buffers come from `alloc_zeroed` (fresh zero pages from the OS, no `memset` pass):
/// on this project's machine writing 80 MB twice (zeroing, then simulating) cost as much as
/// generating 10^7 normal variates, so the zeroing pass is avoided; on Linux they are also
/// offered huge pages (see `advise_huge_pages`).
fn try_zeros(len: usize) -> Result<Vec<f64>> {
    let too_big = || {
        ProcessError::InvalidArgument(format!(
            "cannot allocate {len} samples ({} bytes)",
            len.saturating_mul(std::mem::size_of::<f64>())
        ))
    };
    if len == 0 {
        return Ok(Vec::new());
    }
    let layout = std::alloc::Layout::array::<f64>(len).map_err(|_| too_big())?;
    // SAFETY: `layout` has a non-zero size (len > 0, f64 is 8 bytes). The pointer, if not
    // null, was allocated by the global allocator with exactly this layout (size
    // len * size_of::<f64>(), align_of::<f64>()), which is what `Vec<f64>` with capacity
    // `len` expects; all `len` elements are initialized, because the all-zero bit pattern
    // is the valid f64 value 0.0.
    let mut v = unsafe {
        let ptr = std::alloc::alloc_zeroed(layout).cast::<f64>();
        if ptr.is_null() {
            return Err(too_big());
        }
        Vec::from_raw_parts(ptr, len, len)
    };
    advise_huge_pages(&mut v);
    Ok(v)
}

/// Buffers of at least this many bytes are offered transparent huge pages.
const HUGE_PAGE_MIN_BYTES: usize = 4 << 20;

/// Asks Linux to back a large, fresh (untouched) buffer with 2 MiB transparent huge pages.
///
/// Measured on this project's VM: first-touching 80 MB of fresh 4 KiB pages cost 41 ms of
/// CPU (≈ 4 ns per sample, more than drawing the normal variates), with huge pages 8 ms.
/// The advice is only a hint: when THP is disabled or unavailable nothing changes, and an
/// error is ignored. It applies to the 2 MiB-aligned part of the buffer only.
#[cfg(target_os = "linux")]
fn advise_huge_pages(v: &mut [f64]) {
    const HUGE: usize = 1 << 21;
    let bytes = std::mem::size_of_val(v);
    if bytes < HUGE_PAGE_MIN_BYTES {
        return;
    }
    let start = v.as_mut_ptr() as usize;
    let (lo, hi) = (start.next_multiple_of(HUGE), (start + bytes) & !(HUGE - 1));
    if hi > lo {
        // SAFETY: [lo, hi) lies inside the allocation owned by `v` (lo ≥ start, hi ≤ start +
        // bytes) and is page aligned. MADV_HUGEPAGE changes only how the kernel backs these
        // pages, never their contents, so no memory visible to Rust changes; the return
        // value is deliberately ignored (the advice is optional).
        unsafe {
            libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_v: &mut [f64]) {}

fn check_args(n: usize, rate_hz: f64) -> Result<()> {
    if !(rate_hz.is_finite() && rate_hz > 0.0) {
        return Err(ProcessError::InvalidRate(rate_hz));
    }
    if n == 0 {
        return Err(ProcessError::InvalidArgument(
            "cannot simulate 0 samples (n must be at least 1)".into(),
        ));
    }
    Ok(())
}

fn non_finite(name: &str, out: &[f64], index: usize) -> ProcessError {
    ProcessError::NonFiniteValue {
        name: format!("simulated {name} (parameters too large for f64?)"),
        index,
        value: out[index],
    }
}

/// Key separating the seeds of a BI's states (odd).
const BI_STATE_KEY: u64 = 0xA076_1D64_78BD_642F;

/// The processes a component is simulated as: itself, or a BI's AR1 states (band AUTO:
/// m = 1 … n).
fn sim_parts(p: &Process, n: usize) -> Result<Vec<Process>> {
    match p {
        Process::BiasInstability(b) => {
            let band = b.band().or(crate::BiBand::new(1, (n as u64).max(2))?);
            Ok(crate::BiasInstability::new(b.b(), band)?
                .ar1_states()?
                .into_iter()
                .map(Process::from)
                .collect())
        }
        p => Ok(vec![*p]),
    }
}

/// The plans of component number `component` (generator `state`, already long-jumped to
/// the component), one per simulated part (see [`sim_parts`]).
fn component_plans(
    p: &Process,
    n: usize,
    rate_hz: f64,
    (seed, stream, component): (u64, u64, usize),
    state: &Xoshiro256PlusPlus,
) -> Result<Vec<CompPlan>> {
    sim_parts(p, n)?
        .iter()
        .enumerate()
        .map(|(j, part)| {
            let st = if j == 0 {
                state.clone()
            } else {
                let mut s = stream_state(mix64(seed ^ BI_STATE_KEY.wrapping_mul(j as u64)), stream);
                for _ in 0..component {
                    s.long_jump();
                }
                s
            };
            Ok(CompPlan::new(Gen::new(part, rate_hz, n)?, st, n))
        })
        .collect()
}

/// Key separating the seeds of AR(p) components (odd).
const ARP_KEY: u64 = 0xE703_7ED1_A0B4_28DB;

impl Model {
    fn has_arp(&self) -> bool {
        self.kinds().iter().any(|k| {
            matches!(
                k,
                crate::ProcessKind::ArP(_)
                    | crate::ProcessKind::Arma(..)
                    | crate::ProcessKind::Plp
                    | crate::ProcessKind::Fgn
            )
        })
    }

    /// A model with AR(p) components: the other components through the chunked engine (as
    /// the model without them), each AR(p) by [`crate::ArP::simulate`] (sequential, exact,
    /// stationary start) with its own seed from (`seed`, `stream`, component index), added
    /// in model order.
    fn simulate_with_arp(
        &self,
        n: usize,
        rate_hz: f64,
        seed: u64,
        stream: u64,
    ) -> Result<Simulation> {
        let processes = self.processes()?;
        let rest: Vec<Process> = processes
            .iter()
            .filter(|p| {
                !matches!(
                    p,
                    Process::ArP(_) | Process::Arma(_) | Process::Plp(_) | Process::Fgn(_)
                )
            })
            .copied()
            .collect();
        let (mut total, mut rest_parts) = if rest.is_empty() {
            (try_zeros(n)?, Vec::new())
        } else {
            let sim = Model::from_processes(rest)?
                .simulate_components_stream(n, rate_hz, seed, stream)?;
            (sim.total.values().to_vec(), sim.components)
        };
        rest_parts.reverse();
        let mut components = Vec::with_capacity(processes.len());
        for (c, (p, comp)) in processes.iter().zip(self.components()).enumerate() {
            match p {
                Process::ArP(a) => {
                    let s = mix64(seed ^ ARP_KEY.wrapping_mul(c as u64 + 1))
                        ^ mix64(stream.wrapping_add(ARP_KEY));
                    let x = a.simulate(n, s)?;
                    total.iter_mut().zip(&x).for_each(|(t, v)| *t += v);
                    components.push(TimeSeries::from_checked(x, rate_hz, &comp.to_string()));
                }
                Process::Arma(a) => {
                    // the same seed derivation as AR(p): one seed per component index
                    let s = mix64(seed ^ ARP_KEY.wrapping_mul(c as u64 + 1))
                        ^ mix64(stream.wrapping_add(ARP_KEY));
                    let x = a.simulate(n, s)?;
                    total.iter_mut().zip(&x).for_each(|(t, v)| *t += v);
                    components.push(TimeSeries::from_checked(x, rate_hz, &comp.to_string()));
                }
                // PLP/FGN: the whole record by circulant embedding, seeded like an AR(p)
                Process::Plp(_) | Process::Fgn(_) => {
                    let s = mix64(seed ^ ARP_KEY.wrapping_mul(c as u64 + 1))
                        ^ mix64(stream.wrapping_add(ARP_KEY));
                    let x = match p {
                        Process::Plp(q) => q.simulate(n, s)?,
                        Process::Fgn(q) => q.simulate(n, s)?,
                        _ => unreachable!("matched PLP/FGN"),
                    };
                    total.iter_mut().zip(&x).for_each(|(t, v)| *t += v);
                    components.push(TimeSeries::from_checked(x, rate_hz, &comp.to_string()));
                }
                _ => components.push(rest_parts.pop().ok_or_else(|| {
                    ProcessError::InvalidArgument("component bookkeeping".into())
                })?),
            }
        }
        let name = self.to_string();
        if let Some(i) = total.iter().position(|x| !x.is_finite()) {
            return Err(non_finite(&name, &total, i));
        }
        Ok(Simulation {
            components,
            total: TimeSeries::from_checked(total, rate_hz, &name),
        })
    }

    /// The plans of every component's parts and, for each plan, its component's index.
    fn plans(
        &self,
        n: usize,
        rate_hz: f64,
        seed: u64,
        stream: u64,
    ) -> Result<(Vec<CompPlan>, Vec<usize>)> {
        check_args(n, rate_hz)?;
        let processes = self.processes()?;
        let mut state = stream_state(seed, stream);
        let mut plans = Vec::with_capacity(processes.len());
        let mut owner = Vec::with_capacity(processes.len());
        for (c, p) in processes.iter().enumerate() {
            for plan in component_plans(p, n, rate_hz, (seed, stream, c), &state)? {
                plans.push(plan);
                owner.push(c);
            }
            state.long_jump();
        }
        Ok((plans, owner))
    }

    /// Simulates `n` samples X_1, …, X_n of the model at `rate_hz` Hz with random seed
    /// `seed` (stream 0 of [`Self::simulate_stream`]).
    ///
    /// Parameters are per sample (see the crate docs); `rate_hz` only matters for GM
    /// components and the series' time axis. The result, named by the model's text form,
    /// is the same bits for the same arguments on any number of threads. Errors: a slot
    /// without values ([`ProcessError::UnspecifiedComponent`]), `n == 0`
    /// ([`ProcessError::InvalidArgument`]), a rate that is not finite and > 0
    /// ([`ProcessError::InvalidRate`]), or a path that overflows f64.
    ///
    /// ```
    /// use processes::{Model, WhiteNoise, RandomWalk};
    /// let model = (WhiteNoise::new(1e-4)? + RandomWalk::new(1e-9)?)?;
    /// let x = model.simulate(10_000, 100.0, 1)?;
    /// assert_eq!((x.len(), x.rate_hz()), (10_000, 100.0));
    /// assert!("WN + RW".parse::<Model>()?.simulate(10, 1.0, 1).is_err()); // slots
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn simulate(&self, n: usize, rate_hz: f64, seed: u64) -> Result<TimeSeries> {
        self.simulate_stream(n, rate_hz, seed, 0)
    }

    /// As [`Self::simulate`], drawing independent stream number `stream` of `seed`: e.g.
    /// K independent channels are streams 0..K of one seed. `simulate` is stream 0.
    ///
    /// ```
    /// use processes::Model;
    /// let m: Model = "WN(1)".parse()?;
    /// let a = m.simulate_stream(100, 1.0, 5, 0)?;
    /// let b = m.simulate_stream(100, 1.0, 5, 1)?;
    /// assert_eq!(a, m.simulate(100, 1.0, 5)?);
    /// assert_ne!(a.values(), b.values());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn simulate_stream(
        &self,
        n: usize,
        rate_hz: f64,
        seed: u64,
        stream: u64,
    ) -> Result<TimeSeries> {
        check_args(n, rate_hz)?;
        self.processes()?;
        if self.has_arp() {
            return Ok(self.simulate_with_arp(n, rate_hz, seed, stream)?.total);
        }
        let mut out = try_zeros(n)?;
        let (plans, _) = self.plans(n, rate_hz, seed, stream)?;
        let name = self.to_string();
        if let Some(i) = run(&plans, &mut out, None, First::Assign)? {
            return Err(non_finite(&name, &out, i));
        }
        Ok(TimeSeries::from_checked(out, rate_hz, &name))
    }

    /// Simulates `n` samples of the model and returns each component's path as well as
    /// their sum (book Example 2.4). Same arguments, errors and streams as
    /// [`Self::simulate`]; `total` equals `simulate(n, rate_hz, seed)` bit for bit.
    ///
    /// ```
    /// use processes::Model;
    /// let model: Model = "2*AR1(phi=0.9, sigma2=1) + WN(sigma2=1)".parse()?;
    /// let sim = model.simulate_components(1000, 10.0, 3)?;
    /// assert_eq!(sim.components[2].name(), "WN(sigma2=1)");
    /// assert_eq!(sim.total, model.simulate(1000, 10.0, 3)?);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn simulate_components(&self, n: usize, rate_hz: f64, seed: u64) -> Result<Simulation> {
        self.simulate_components_stream(n, rate_hz, seed, 0)
    }

    /// As [`Self::simulate_components`] for stream number `stream` of `seed` (see
    /// [`Self::simulate_stream`]).
    ///
    /// ```
    /// use processes::Model;
    /// let m: Model = "WN(1) + RW(0.01)".parse()?;
    /// let sim = m.simulate_components_stream(100, 1.0, 9, 4)?;
    /// assert_eq!(sim.total, m.simulate_stream(100, 1.0, 9, 4)?);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn simulate_components_stream(
        &self,
        n: usize,
        rate_hz: f64,
        seed: u64,
        stream: u64,
    ) -> Result<Simulation> {
        check_args(n, rate_hz)?;
        self.processes()?;
        if self.has_arp() {
            return self.simulate_with_arp(n, rate_hz, seed, stream);
        }
        let mut out = try_zeros(n)?;
        let (plans, owner) = self.plans(n, rate_hz, seed, stream)?;
        let mut parts = (0..plans.len())
            .map(|_| try_zeros(n))
            .collect::<Result<Vec<_>>>()?;
        let name = self.to_string();
        if let Some(i) = run(&plans, &mut out, Some(&mut parts), First::Assign)? {
            return Err(non_finite(&name, &out, i));
        }
        // a BI's states summed into its component, in order
        let mut comps: Vec<Vec<f64>> = Vec::with_capacity(self.len());
        for (part, &c) in parts.into_iter().zip(&owner) {
            if c < comps.len() {
                let acc = &mut comps[c];
                acc.par_iter_mut()
                    .zip(part.par_iter())
                    .for_each(|(a, b)| *a += b);
            } else {
                comps.push(part);
            }
        }
        let components = comps
            .into_iter()
            .zip(self.components())
            .map(|(v, c)| TimeSeries::from_checked(v, rate_hz, &c.to_string()))
            .collect();
        Ok(Simulation {
            components,
            total: TimeSeries::from_checked(out, rate_hz, &name),
        })
    }
}

impl Process {
    /// Adds to `out` the path of this process as component number `component` of a model
    /// simulated with (`seed`, `stream`) at `rate_hz` Hz, over `out.len()` samples.
    ///
    /// The added values are bit for bit those of component `component` in
    /// [`Model::simulate_components_stream`], so adding each process of a model in order
    /// to a zero buffer reproduces [`Model::simulate_stream`]. Processes added with the same
    /// (`seed`, `stream`, `component`) share their random numbers: give each its own
    /// `component`. The cost of locating the stream grows linearly with `component`.
    /// Errors for an empty `out`, a bad rate, or a non-finite result (the path is still
    /// added then).
    ///
    /// ```
    /// use processes::{Model, Process, RandomWalk, WhiteNoise};
    /// let (wn, rw) = (Process::from(WhiteNoise::new(1.0)?), Process::from(RandomWalk::new(0.1)?));
    /// let mut x = vec![0.0; 1000];
    /// wn.simulate_into(&mut x, 1.0, 11, 0, 0)?;
    /// rw.simulate_into(&mut x, 1.0, 11, 0, 1)?;
    /// assert_eq!(x, (wn + rw)?.simulate(1000, 1.0, 11)?.into_values());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn simulate_into(
        &self,
        out: &mut [f64],
        rate_hz: f64,
        seed: u64,
        stream: u64,
        component: usize,
    ) -> Result<()> {
        check_args(out.len(), rate_hz)?;
        let mut state = stream_state(seed, stream);
        for _ in 0..component {
            state.long_jump();
        }
        let plans = component_plans(self, out.len(), rate_hz, (seed, stream, component), &state)?;
        match run(&plans, out, None, First::Add)? {
            Some(i) => Err(non_finite(&self.kind().to_string(), out, i)),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mix64_is_zero_at_zero_and_stream_states_differ() {
        assert_eq!(mix64(0), 0);
        let a = stream_state(1, 0);
        let b = stream_state(1, 1);
        let c = stream_state(2, 0);
        assert_ne!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn uniform_is_symmetric_and_inside_the_open_interval() {
        // Extreme draws map to ±(1 − 2^-52), never ±1, and j ↔ 2^52 − 1 − j mirror exactly.
        const SCALE: f64 = 1.0 / (1u64 << 51) as f64;
        let f = |j: u64| (j as f64 + 0.5) * SCALE - 1.0;
        let top = (1u64 << 52) - 1;
        assert_eq!(f(0), -1.0 + 2f64.powi(-52));
        assert_eq!(f(top), 1.0 - 2f64.powi(-52));
        for j in [0, 1, 12345, 1 << 40, (1 << 51) - 1, 1 << 51] {
            assert_eq!(f(j), -f(top - j), "j = {j}");
        }
    }

    #[test]
    fn impossible_allocations_are_errors() {
        assert!(try_zeros(usize::MAX / 4).is_err()); // layout overflow
        assert!(try_zeros(1 << 60).is_err()); // 8 EiB: the allocator refuses
        assert_eq!(try_zeros(0).unwrap().len(), 0);
        assert!(try_zeros(3).unwrap().iter().all(|&v| v == 0.0));
    }

    #[test]
    fn chunk_geometry() {
        assert_eq!(n_chunks(1), 1);
        assert_eq!(n_chunks(CHUNK_LEN), 1);
        assert_eq!(n_chunks(CHUNK_LEN + 1), 2);
        assert_eq!(chunk_len(CHUNK_LEN + 1, 1), 1);
        assert_eq!(chunk_len(3 * CHUNK_LEN, 2), CHUNK_LEN);
    }
}
