//! The maximum-overlapping Allan variance of a series that is still being recorded.
//!
//! [`Online`] is fed chunks of one channel's rate samples ([`Online::update`]) and at any moment
//! gives ([`Online::snapshot`]) the same [`AllanVariance`] that [`crate::allan_variance`] would
//! give on all the samples so far (book eq. 4.2, to ~1e-12 relative), at the batch estimator's
//! scales for the current length T that do not exceed a chosen largest cluster size `max_m`,
//! with the same chi-square intervals. [`OnlineChannels`] does the same for several channels.
//!
//! How:
//! * the samples are centred by a pivot (the first sample) and summed into a cumulative sum C
//!   held as a double-double (an exact running error term), so a constant offset of 1e4·std
//!   changes nothing;
//! * one ring holds the last 2·`max_m` + 1024 values of C (16 bytes each); every tracked scale m
//!   adds the squared second differences C_k − 2C_{k−m} + C_{k−2m} of each new k ≥ 2m into a
//!   compensated (Neumaier) sum, in blocks of at most 1024 terms;
//! * the chi-square interval's noise identification (lag-1 autocorrelation of the detrended
//!   non-overlapping cluster means and of their first and second differences, see
//!   [`crate::ci`]) is rebuilt from a fixed set of running compensated moments of the cluster
//!   means, updated as each cluster completes: no cluster mean is stored.
//!
//! Memory is therefore O(`max_m`) per channel ([`Online::heap_bytes`]), whatever the length.
//! Supported configurations: the overlapping estimator on rate input, with the chi-square
//! interval or none (the Gaussian interval needs the whole series; an error says so). Samples
//! of extreme magnitude (beyond about 1e±150) are not rescaled as the batch estimator does.

use rayon::prelude::*;

use crate::ci::{NoiseId, apply_chi_square, decide_level};
use crate::config::{AvarConfig, CiMethod, Estimator, InputKind};
use crate::error::AvarError;
use crate::kernel::compensated::Neumaier;
use crate::result::{AllanVariance, AvarPoint};
use crate::{MIN_SAMPLES, validate_rate_alpha};

/// Samples per block of the update (the partial sums of squares hold at most this many terms).
const BLOCK: usize = 1024;

/// Running moments of the non-overlapping cluster means u_i of one scale (i = 0..n−1), centred
/// by the first one: v_i = u_i − u_0, w_i = v_{i+1} − v_i, z_i = w_{i+1} − w_i.
#[derive(Debug, Clone, Default)]
struct IdMoments {
    n: u64,
    u0: f64,
    v_last: f64,
    w_first: f64,
    w_last: f64,
    z_first: f64,
    z_last: f64,
    sv: Neumaier,
    siv: Neumaier,
    svv: Neumaier,
    s1: Neumaier,
    sww: Neumaier,
    sw1: Neumaier,
    szz: Neumaier,
    sz1: Neumaier,
}

impl IdMoments {
    fn push(&mut self, u: f64) {
        if self.n == 0 {
            self.u0 = u;
        }
        let v = u - self.u0;
        let i = self.n as f64;
        self.sv.add(v);
        self.siv.add(i * v);
        self.svv.add(v * v);
        if self.n >= 1 {
            self.s1.add(self.v_last * v);
            let w = v - self.v_last;
            if self.n == 1 {
                self.w_first = w;
            } else {
                self.sw1.add(self.w_last * w);
                let z = w - self.w_last;
                if self.n == 2 {
                    self.z_first = z;
                } else {
                    self.sz1.add(self.z_last * z);
                }
                self.szz.add(z * z);
                self.z_last = z;
            }
            self.sww.add(w * w);
            self.w_last = w;
        }
        self.v_last = v;
        self.n += 1;
    }

    /// The identification of [`crate::ci::identify_noise`] on the n cluster means, from the
    /// moments: level 0 the residuals of the least-squares line, level d ≥ 1 the centred d-th
    /// differences (the line drops out of them).
    fn identify(&self) -> Option<NoiseId> {
        let n = self.n as usize;
        if n < crate::ci::MIN_ID_CLUSTERS {
            return None;
        }
        let nf = n as f64;
        let tm = (nf - 1.0) / 2.0;
        let sv = self.sv.value();
        let a = sv / nf;
        let stv = self.siv.value() - tm * sv;
        let sxx = nf * (nf * nf - 1.0) / 12.0;
        let b = stv / sxx;
        let vl = self.v_last;
        // Σ r_i² and Σ r_i r_{i+1} of r_i = v_i − a − b·(i − tm) (v_0 = 0)
        let den0 = self.svv.value() - a * sv - b * stv;
        let stt1 = sxx - tm * tm - tm;
        let num0 = self.s1.value() - a * (2.0 * sv - vl) - b * (2.0 * stv - (tm + 1.0) * vl)
            + a * a * (nf - 1.0)
            + b * b * stt1;
        if let Ok(id) = decide_level(&[(num0, den0)], 0, n) {
            return id;
        }
        // centred lag sums of a difference series x (len terms, sum s, ends f and l)
        let centred = |sxx: f64, sx1: f64, s: f64, f: f64, l: f64, len: f64| {
            let mu = s / len;
            let den = sxx - 2.0 * mu * s + len * mu * mu;
            let num = sx1 - mu * (2.0 * s - f - l) + (len - 1.0) * mu * mu;
            (num, den)
        };
        let p1 = centred(
            self.sww.value(),
            self.sw1.value(),
            vl,
            self.w_first,
            self.w_last,
            nf - 1.0,
        );
        if let Ok(id) = decide_level(&[p1], 1, n) {
            return id;
        }
        let p2 = centred(
            self.szz.value(),
            self.sz1.value(),
            self.w_last - self.w_first,
            self.z_first,
            self.z_last,
            nf - 2.0,
        );
        decide_level(&[p2], 2, n).unwrap_or(None)
    }
}

/// What one tracked scale accumulates.
#[derive(Debug, Clone, Default)]
struct ScaleAcc {
    /// Σ (C_k − 2C_{k−m} + C_{k−2m})² over k = 2m..T.
    sum: Neumaier,
    /// The next cluster boundary (a multiple of m) at which a cluster mean completes.
    next_boundary: u64,
    id: IdMoments,
}

/// An online maximum-overlapping Allan variance of one channel (see the [module](self) docs).
///
/// ```
/// use avar::{allan_variance, AvarConfig, online::Online};
/// let x: Vec<f64> = (0..5000).map(|i| ((i * 7919) % 101) as f64 + 1e4).collect();
/// let cfg = AvarConfig::default();
/// let mut on = Online::new(100.0, 256, &cfg).unwrap();
/// for chunk in x.chunks(77) {
///     on.update(chunk).unwrap();
/// }
/// let live = on.snapshot().unwrap();
/// let batch = allan_variance(&x, 100.0, &cfg).unwrap();
/// assert_eq!(live.n, 5000);
/// assert_eq!(live.points.last().unwrap().m, 256); // the batch goes on to m = 2048
/// for (p, q) in live.points.iter().zip(&batch.points) {
///     assert_eq!(p.m, q.m);
///     assert!((p.avar - q.avar).abs() <= 1e-12 * q.avar);
///     assert_eq!(p.noise_alpha, q.noise_alpha);
/// }
/// ```
#[derive(Debug, Clone)]
pub struct Online {
    rate_hz: f64,
    config: AvarConfig,
    max_m: u64,
    /// Tracked cluster sizes, ascending.
    ms: Vec<u64>,
    acc: Vec<ScaleAcc>,
    /// Ring of (hi, lo) of the centred cumulative sum C_k at index k & mask.
    ring: Vec<[f64; 2]>,
    mask: usize,
    t: u64,
    pivot: f64,
    c_hi: f64,
    c_lo: f64,
    /// Partial sums of squares of the current block, one per scale (reused).
    part: Vec<f64>,
}

impl Online {
    /// An empty accumulator for samples at `rate_hz` Hz that tracks the cluster sizes of
    /// `config.scales` up to `max_m` samples (τ_max = `max_m` / `rate_hz` seconds).
    ///
    /// Errors: a bad rate or alpha, `max_m` = 0, a configuration other than the overlapping
    /// estimator on rate input with the chi-square interval or none, or a grid with no scale
    /// up to `max_m`.
    ///
    /// ```
    /// use avar::{AvarConfig, CiMethod, online::Online};
    /// let on = Online::new(100.0, 1 << 10, &AvarConfig::default()).unwrap();
    /// assert_eq!(on.cluster_sizes().len(), 10); // m = 2, 4, …, 1024
    /// let gauss = AvarConfig { ci: CiMethod::Gaussian, ..Default::default() };
    /// let e = Online::new(100.0, 64, &gauss).unwrap_err();
    /// assert!(e.to_string().starts_with("online estimator: it supports the overlapping"));
    /// ```
    pub fn new(rate_hz: f64, max_m: u64, config: &AvarConfig) -> Result<Online, AvarError> {
        validate_rate_alpha(rate_hz, config.alpha)?;
        if max_m == 0 {
            return Err(AvarError::ZeroScale);
        }
        if config.estimator != Estimator::Overlapping
            || config.input != InputKind::Rate
            || config.ci == CiMethod::Gaussian
        {
            return Err(AvarError::Online(format!(
                "it supports the overlapping estimator on rate input with the chi-square \
                 interval or none, not {:?} / {:?} / {:?}",
                config.estimator, config.input, config.ci
            )));
        }
        let big_t = usize::try_from(max_m.saturating_mul(4).saturating_add(4))
            .map_err(|_| AvarError::InvalidScales(format!("max_m = {max_m} is too large")))?;
        let ms: Vec<u64> = match &config.scales {
            crate::Scales::Explicit(list) => {
                let mut l: Vec<u64> = list.iter().copied().filter(|&m| m <= max_m).collect();
                if l.contains(&0) {
                    return Err(AvarError::ZeroScale);
                }
                l.sort_unstable();
                l.dedup();
                l
            }
            s => s
                .cluster_sizes(big_t)?
                .into_iter()
                .filter(|&m| m <= max_m)
                .collect(),
        };
        let Some(&top) = ms.last() else {
            return Err(AvarError::InvalidScales(format!(
                "the grid {:?} has no cluster size up to max_m = {max_m}",
                config.scales
            )));
        };
        let len = (2 * top as usize + BLOCK + 1).next_power_of_two();
        let acc = ms
            .iter()
            .map(|&m| ScaleAcc {
                next_boundary: m,
                ..ScaleAcc::default()
            })
            .collect();
        Ok(Online {
            rate_hz,
            config: config.clone(),
            max_m,
            part: vec![0.0; ms.len()],
            ms,
            acc,
            ring: vec![[0.0; 2]; len],
            mask: len - 1,
            t: 0,
            pivot: 0.0,
            c_hi: 0.0,
            c_lo: 0.0,
        })
    }

    /// The tracked cluster sizes (samples, ascending): those of the configured grid up to
    /// `max_m`. A snapshot reports those the batch estimator has at the current length.
    pub fn cluster_sizes(&self) -> &[u64] {
        &self.ms
    }

    /// The largest cluster size tracked (samples), as given to [`Online::new`].
    pub fn max_m(&self) -> u64 {
        self.max_m
    }

    /// Number of samples accumulated so far.
    ///
    /// ```
    /// use avar::{AvarConfig, online::Online};
    /// let mut on = Online::new(1.0, 8, &AvarConfig::default()).unwrap();
    /// assert!(on.is_empty());
    /// on.update(&[0.5; 10]).unwrap();
    /// assert_eq!((on.len(), on.max_m(), on.cluster_sizes()), (10, 8, &[2u64, 4, 8][..]));
    /// ```
    pub fn len(&self) -> u64 {
        self.t
    }

    /// True before the first sample.
    pub fn is_empty(&self) -> bool {
        self.t == 0
    }

    /// Bytes held on the heap (from the capacities of the buffers): O(`max_m`), independent of
    /// the number of samples fed.
    ///
    /// ```
    /// use avar::{AvarConfig, online::Online};
    /// let mut on = Online::new(1.0, 64, &AvarConfig::default()).unwrap();
    /// let before = on.heap_bytes();
    /// on.update(&vec![1.0; 100_000]).unwrap();
    /// assert_eq!(on.heap_bytes(), before);
    /// ```
    pub fn heap_bytes(&self) -> usize {
        self.ring.capacity() * std::mem::size_of::<[f64; 2]>()
            + self.ms.capacity() * std::mem::size_of::<u64>()
            + self.acc.capacity() * std::mem::size_of::<ScaleAcc>()
            + self.part.capacity() * std::mem::size_of::<f64>()
            + match &self.config.scales {
                crate::Scales::Explicit(l) => l.capacity() * std::mem::size_of::<u64>(),
                _ => 0,
            }
    }

    /// Adds the next samples (rate unit, in time order). A chunk holding a NaN or an infinite
    /// value is rejected whole (error with the sample's index counted from the first sample
    /// ever fed) and leaves the accumulator as it was.
    ///
    /// ```
    /// use avar::{AvarConfig, AvarError, online::Online};
    /// let mut on = Online::new(1.0, 4, &AvarConfig::default()).unwrap();
    /// on.update(&[1.0, 2.0]).unwrap();
    /// let e = on.update(&[3.0, f64::NAN]).unwrap_err();
    /// assert!(matches!(e, AvarError::NonFinite { index: 3, .. }));
    /// assert_eq!(on.len(), 2);
    /// ```
    pub fn update(&mut self, x: &[f64]) -> Result<(), AvarError> {
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(AvarError::NonFinite {
                index: self.t as usize + i,
                value: x[i],
            });
        }
        if self.t == 0
            && let Some(&first) = x.first()
        {
            self.pivot = first;
        }
        for block in x.chunks(BLOCK) {
            self.update_block(block);
        }
        Ok(())
    }

    fn update_block(&mut self, x: &[f64]) {
        let mask = self.mask;
        let len = self.ring.len();
        let t0 = self.t as usize;
        // C_k for k = t0+1 ..= t0+b (double-double: hi + lo)
        let (mut hi, mut lo) = (self.c_hi, self.c_lo);
        let pivot = self.pivot;
        let mut k = t0 + 1;
        let mut rest = x;
        while !rest.is_empty() {
            let at = k & mask;
            let n = rest.len().min(len - at);
            for (slot, &v) in self.ring[at..at + n].iter_mut().zip(&rest[..n]) {
                let y = v - pivot;
                let s = hi + y;
                let bp = s - hi;
                lo += (hi - (s - bp)) + (y - bp);
                hi = s;
                *slot = [hi, lo];
            }
            rest = &rest[n..];
            k += n;
        }
        self.c_hi = hi;
        self.c_lo = lo;
        let t1 = t0 + x.len();
        // squared second differences, k = max(t0 + 1, 2m) ..= t1
        for (j, &m) in self.ms.iter().enumerate() {
            let m = m as usize;
            let k_lo = (t0 + 1).max(2 * m);
            if k_lo > t1 {
                // scales are ascending: the larger ones have not started either
                for p in &mut self.part[j..] {
                    *p = 0.0;
                }
                break;
            }
            let mut s = 0.0;
            let mut k = k_lo;
            while k <= t1 {
                let (a0, a1, a2) = (k & mask, (k - m) & mask, (k - 2 * m) & mask);
                let n = (t1 + 1 - k).min(len - a0).min(len - a1).min(len - a2);
                s += sum_sq(
                    &self.ring[a0..a0 + n],
                    &self.ring[a1..a1 + n],
                    &self.ring[a2..a2 + n],
                );
                k += n;
            }
            self.part[j] = s;
        }
        for (a, &p) in self.acc.iter_mut().zip(&self.part) {
            a.sum.add(p);
        }
        // cluster means completed in this block
        for (a, &m) in self.acc.iter_mut().zip(&self.ms) {
            while a.next_boundary as usize <= t1 {
                let b = a.next_boundary as usize;
                let (c1, c0) = (self.ring[b & mask], self.ring[(b - m as usize) & mask]);
                let inv = 1.0 / m as f64;
                a.id.push(((c1[0] - c0[0]) + (c1[1] - c0[1])) * inv);
                a.next_boundary += m;
            }
        }
        self.t = t1 as u64;
    }

    /// The Allan variance of all the samples so far at the batch estimator's scales for this
    /// length that do not exceed `max_m`, with the configured interval: equal to
    /// [`crate::allan_variance`] on the same samples to ~1e-12 relative at those scales.
    ///
    /// Errors as the batch estimator: no sample, fewer than [`MIN_SAMPLES`], a grid with no
    /// scale for this length.
    ///
    /// ```
    /// use avar::{AvarConfig, AvarError, CiMethod, Scales, online::Online};
    /// let cfg = AvarConfig { scales: Scales::Explicit(vec![1]), ci: CiMethod::None, ..Default::default() };
    /// let mut on = Online::new(1.0, 1, &cfg).unwrap();
    /// on.update(&[1.0, -1.0, 1.0]).unwrap();
    /// assert!(matches!(on.snapshot(), Err(AvarError::TooShort { got: 3, need: 4 })));
    /// on.update(&[-1.0]).unwrap();
    /// // neighbours differ by ±2: AV(1) = 4/2 over T − 1 = 3 terms
    /// assert_eq!(on.snapshot().unwrap().points[0].avar, 2.0);
    /// ```
    pub fn snapshot(&self) -> Result<AllanVariance, AvarError> {
        let t = self.t as usize;
        crate::check_len(t, t)?;
        debug_assert!(t >= MIN_SAMPLES);
        let ms: Vec<u64> = self
            .config
            .scales
            .cluster_sizes(t)?
            .into_iter()
            .filter(|&m| m <= self.max_m)
            .collect();
        if ms.is_empty() {
            return Err(AvarError::InvalidScales(format!(
                "no cluster size up to max_m = {} for T = {t} samples",
                self.max_m
            )));
        }
        let mut points = Vec::with_capacity(ms.len());
        let mut ids = Vec::with_capacity(ms.len());
        for &m in &ms {
            let j = self.ms.binary_search(&m).map_err(|_| {
                AvarError::InvalidScales(format!("cluster size {m} is not tracked"))
            })?;
            let n_terms = crate::n_terms(t, m, Estimator::Overlapping);
            let scale = 1.0 / m as f64;
            let avar = self.acc[j].sum.value() * scale * scale / (2.0 * n_terms as f64);
            points.push(AvarPoint::bare(m, self.rate_hz, avar, n_terms));
            if self.config.ci == CiMethod::ChiSquare {
                ids.push(self.acc[j].id.identify());
            }
        }
        if self.config.ci == CiMethod::ChiSquare {
            apply_chi_square(&ids, t, &self.config, &mut points);
        }
        Ok(AllanVariance {
            rate_hz: self.rate_hz,
            n: t,
            estimator: Estimator::Overlapping,
            input: InputKind::Rate,
            ci: self.config.ci,
            alpha: self.config.alpha,
            mean: self.pivot + (self.c_hi + self.c_lo) / t as f64,
            points,
        })
    }
}

/// Σ ((a − b) − (b − c))² over the double-double values (hi and lo parts separately), with
/// four independent lanes.
#[inline]
fn sum_sq(a: &[[f64; 2]], b: &[[f64; 2]], c: &[[f64; 2]]) -> f64 {
    let mut acc = [0.0f64; 4];
    let n = a.len().min(b.len()).min(c.len());
    let (a, b, c) = (&a[..n], &b[..n], &c[..n]);
    let mut ia = a.chunks_exact(4);
    let mut ib = b.chunks_exact(4);
    let mut ic = c.chunks_exact(4);
    for ((ca, cb), cc) in (&mut ia).zip(&mut ib).zip(&mut ic) {
        for l in 0..4 {
            let d = ((ca[l][0] - cb[l][0]) - (cb[l][0] - cc[l][0]))
                + ((ca[l][1] - cb[l][1]) - (cb[l][1] - cc[l][1]));
            acc[l] += d * d;
        }
    }
    for ((x, y), z) in ia
        .remainder()
        .iter()
        .zip(ib.remainder())
        .zip(ic.remainder())
    {
        let d = ((x[0] - y[0]) - (y[0] - z[0])) + ((x[1] - y[1]) - (y[1] - z[1]));
        acc[0] += d * d;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Several channels at one rate and configuration, each an [`Online`]; channels are updated in
/// parallel (rayon) when the chunk is large, with the same results for any thread count.
///
/// ```
/// use avar::{allan_variance, AvarConfig, online::OnlineChannels};
/// let a: Vec<f64> = (0..3000).map(|i| ((i * 31) % 17) as f64).collect();
/// let b: Vec<f64> = (0..3000).map(|i| ((i * 7) % 23) as f64).collect();
/// let rows: Vec<f64> = a.iter().zip(&b).flat_map(|(x, y)| [*x, *y]).collect();
/// let cfg = AvarConfig::default();
/// let mut on = OnlineChannels::new(2, 10.0, 1 << 20, &cfg).unwrap();
/// for chunk in rows.chunks(2 * 100) {
///     on.update_interleaved(chunk).unwrap();
/// }
/// let snaps = on.snapshots().unwrap();
/// let batch = allan_variance(&b, 10.0, &cfg).unwrap();
/// assert_eq!(snaps[1].points.len(), batch.points.len());
/// assert!((snaps[1].points[0].avar - batch.points[0].avar).abs() <= 1e-12 * batch.points[0].avar);
/// ```
#[derive(Debug, Clone)]
pub struct OnlineChannels {
    chans: Vec<Online>,
    scratch: Vec<Vec<f64>>,
}

impl OnlineChannels {
    /// `n_channels` accumulators as [`Online::new`] makes them. Errors as [`Online::new`], or
    /// [`AvarError::Empty`] for no channel.
    pub fn new(
        n_channels: usize,
        rate_hz: f64,
        max_m: u64,
        config: &AvarConfig,
    ) -> Result<OnlineChannels, AvarError> {
        if n_channels == 0 {
            return Err(AvarError::Empty);
        }
        let one = Online::new(rate_hz, max_m, config)?;
        Ok(OnlineChannels {
            chans: vec![one; n_channels],
            scratch: vec![Vec::new(); n_channels],
        })
    }

    /// The channels' accumulators.
    pub fn channels(&self) -> &[Online] {
        &self.chans
    }

    /// Adds one chunk per channel (`chunks[i]` to channel i; lengths may differ). A non-finite
    /// sample in any chunk rejects the whole call (error naming the channel) and changes nothing.
    ///
    /// ```
    /// use avar::{AvarConfig, online::OnlineChannels};
    /// let mut on = OnlineChannels::new(2, 1.0, 4, &AvarConfig::default()).unwrap();
    /// on.update(&[&[1.0, 2.0], &[3.0]]).unwrap(); // lengths may differ
    /// let e = on.update(&[&[1.0], &[f64::NAN]]).unwrap_err();
    /// assert_eq!(e.to_string(), "channel 1: non-finite sample NaN at index 1");
    /// assert_eq!((on.channels()[0].len(), on.channels()[1].len()), (2, 1));
    /// ```
    pub fn update(&mut self, chunks: &[&[f64]]) -> Result<(), AvarError> {
        if chunks.len() != self.chans.len() {
            return Err(AvarError::Online(format!(
                "{} chunks for {} channels",
                chunks.len(),
                self.chans.len()
            )));
        }
        for (i, (c, ch)) in chunks.iter().zip(&self.chans).enumerate() {
            if let Some(k) = c.iter().position(|v| !v.is_finite()) {
                return Err(AvarError::Channel {
                    channel: i,
                    source: Box::new(AvarError::NonFinite {
                        index: ch.t as usize + k,
                        value: c[k],
                    }),
                });
            }
        }
        let total: usize = chunks.iter().map(|c| c.len()).sum();
        let run = |(ch, c): (&mut Online, &&[f64])| {
            // validated above: cannot fail
            let _ = ch.update(c);
        };
        if total >= 1 << 15 {
            self.chans.par_iter_mut().zip(chunks).for_each(run);
        } else {
            self.chans.iter_mut().zip(chunks).for_each(run);
        }
        Ok(())
    }

    /// Adds rows of samples stored row-major (channel 0, 1, …, of the first row, then of the
    /// second, …); `rows.len()` must be a multiple of the number of channels.
    pub fn update_interleaved(&mut self, rows: &[f64]) -> Result<(), AvarError> {
        let n = self.chans.len();
        if !rows.len().is_multiple_of(n) {
            return Err(AvarError::Online(format!(
                "{} values are not whole rows of {n} channels",
                rows.len()
            )));
        }
        let mut scratch = std::mem::take(&mut self.scratch);
        for (i, s) in scratch.iter_mut().enumerate() {
            s.clear();
            s.extend(rows.iter().skip(i).step_by(n));
        }
        let views: Vec<&[f64]> = scratch.iter().map(|s| &s[..]).collect();
        let r = self.update(&views);
        self.scratch = scratch;
        r
    }

    /// One [`Online::snapshot`] per channel (errors name the channel).
    pub fn snapshots(&self) -> Result<Vec<AllanVariance>, AvarError> {
        self.chans
            .iter()
            .enumerate()
            .map(|(i, c)| {
                c.snapshot().map_err(|e| AvarError::Channel {
                    channel: i,
                    source: Box::new(e),
                })
            })
            .collect()
    }
}
