//! The streamed MOAV kernel ([`overlapping_sums_stream`]): the sums of squared second
//! differences of a long rate series with no series-sized buffer, only checkpoints of the
//! centred cumulative sum every [`G`] samples. The near scales (2m ≤ [`far_m`]) run on the
//! [`SEG_NEAR`] grid in jobs that build their checkpoints as they go ([`stream_near`]), so that
//! the series is read from memory once for them; the far scales run on the [`SEG_FAR`] grid,
//! their chunks walked by residue class so that the lagged blocks are still cached
//! ([`stream_group`]). Each chunk goes through `chunk_run` (`simd_blocks`). The near walk is in
//! `near.rs`, the far walk in `far.rs`.

use super::cumsum::{Checkpoints, G, first_non_finite, pivot_of};
use super::segments::{NSEG, SEG_FAR, SEG_NEAR};
use crate::error::AvarError;
use crate::simd::SimdLevel;
use crate::source::io::Io;

mod far;
mod near;

use far::stream_group;
use near::{global_checkpoints, stream_near};

/// Series at least this long (rate input, overlapping estimator, no CI) are streamed from the
/// samples and checkpoints instead of a series-sized cumulative-sum buffer (whose first-touch
/// page faults then dominate; below it the buffered kernel is faster).
pub(crate) const STREAM_MIN_T: usize = 1 << 22;

/// Scales with 2m > FAR_M are "far": their lagged blocks are not in cache in plain chunk order.
/// They take the [`SEG_FAR`] grid and are walked by residue class of the chunk index modulo
/// FAR_M / (NSEG·SEG_FAR), a class step of exactly FAR_M samples (see [`stream_group`]). This
/// is the largest threshold; shorter series take a smaller one ([`far_m`]).
const FAR_M: usize = 1 << 20;
/// The smallest near/far threshold of [`far_m`].
const FAR_M_MIN: usize = 1 << 17;

const _: () = assert!(FAR_M_MIN.is_multiple_of(NSEG * SEG_FAR));

/// The near/far threshold (and class step) for T samples: T/64 rounded up to a power of two,
/// within [`FAR_M_MIN`] … [`FAR_M`]. The far walk's lane ring then holds about T/FAR_M chunk
/// copies of 16 KiB (up to 1 MiB, the L2 cache of this machine) until T reaches 64·FAR_M,
/// while the near scales' lags (2m, up to FAR_M samples back) stay nearer in the cache
/// hierarchy and the near jobs' warm-up (FAR_M samples each) stays short. Measured at 10^7
/// samples, octave τ: OADEV 17.7 ms with 2^20, 16.2 with 2^19, 15.8 with 2^18 (this rule),
/// 15.5 with 2^17; at 10^8, 181 ms with 2^20 (this rule), 175 with 2^19, 177 with 2^18, 185
/// with 2^17. A function of T only, so that results do not depend on the thread count.
pub(crate) fn far_m(t: usize) -> usize {
    (t / 64).next_power_of_two().clamp(FAR_M_MIN, FAR_M)
}

/// Σ_{k=2m}^{T} (C_k − 2C_{k−m} + C_{k−2m})² for each m in `ms`, streamed from the rate
/// samples `x` (no series-sized buffer), and the mean of the samples. Deterministic for any
/// thread count and any set of requested scales: the value for m is the Neumaier sum, in chunk
/// order, of chunk partials that depend only on (x, m, chunk); the chunk grid depends only on m
/// ([`SEG_NEAR`] for 2m ≤ [`FAR_M`], [`SEG_FAR`] above), and so do the checkpoints that start its
/// segments (see [`stream_near`]). Errors on non-finite samples (naming the first) and on
/// overflow.
pub(crate) fn overlapping_sums_stream(x: &[f64], ms: &[u64]) -> Result<(Vec<f64>, f64), AvarError> {
    overlapping_sums_stream_io(x, ms, &Io::NONE)
}

/// [`overlapping_sums_stream`] talking to a source: `release` is called on the ranges of
/// samples the near walk is done with (chunk by chunk, behind the warm-up reach) and on the
/// chunks of each residue class of the far walk when the class ends; with windows, each job of
/// the far walk reads its chunks (and their lagged blocks where the lane ring does not hold
/// them) into its own window instead of `x`. The values are those of
/// [`overlapping_sums_stream`], bit for bit (the same samples reach the same operations).
pub(crate) fn overlapping_sums_stream_io(
    x: &[f64],
    ms: &[u64],
    io: &Io<'_>,
) -> Result<(Vec<f64>, f64), AvarError> {
    let job_chunks = job_chunks(x.len());
    overlapping_sums_stream_split(x, ms, far_m(x.len()), job_chunks, crate::simd::level(), io)
        .map(|(sums, mean, _)| (sums, mean))
}

/// Near chunks per job of the near walk for T samples: jobs of equal length, about
/// [`JOB_CHUNKS`] chunks each but at least [`MIN_JOBS`] of them, so that shorter series still
/// spread over the threads. A function of T only (the checkpoint frames, hence the sums, must
/// not depend on the thread count).
fn job_chunks(t: usize) -> usize {
    let n_chunks = (t + 1).div_ceil(NSEG * SEG_NEAR);
    let jobs = n_chunks.div_ceil(JOB_CHUNKS).max(MIN_JOBS);
    n_chunks.div_ceil(jobs).max(1)
}

/// Fewest jobs of the near walk (see [`job_chunks`]).
const MIN_JOBS: usize = 8;

/// [`overlapping_sums_stream`] that also hands back the checkpoints of the far walk (the
/// global frame, pivot-centred: C_p = Σ_{i<p} (x_i − pivot)), when there were far scales; `None`
/// otherwise (the near walk keeps none of its own). TOTVAR's reflected ends read the phase
/// from them instead of summing the series once more.
pub(crate) fn overlapping_sums_stream_checkpoints(
    x: &[f64],
    ms: &[u64],
) -> Result<(Vec<f64>, Option<Checkpoints>), AvarError> {
    let (sums, _, ck) = overlapping_sums_stream_split(
        x,
        ms,
        far_m(x.len()),
        job_chunks(x.len()),
        crate::simd::level(),
        &Io::NONE,
    )?;
    Ok((sums, ck.far.is_some().then_some(ck)))
}

/// [`overlapping_sums_stream`] with the near/far threshold and the job length as parameters:
/// scales with 2m > `far_m` take the far grid and the residue-class walk of step `far_m`; the
/// near walk runs in jobs of `job_chunks` near chunks with a warm-up of `far_m` samples (tests
/// use small values to cover those paths on short series), and the vector kernel `simd`.
/// Returns the sums, the mean and the far walk's global checkpoints (see
/// [`overlapping_sums_stream_checkpoints`]).
fn overlapping_sums_stream_split(
    x: &[f64],
    ms: &[u64],
    far_m: usize,
    job_chunks: usize,
    simd: SimdLevel,
    io: &Io<'_>,
) -> Result<(Vec<f64>, f64, Checkpoints), AvarError> {
    // never above the process's level (the vector paths' safety rests on it)
    let simd = simd.min(crate::simd::level());
    crate::simd::note(SimdLevel::Scalar);
    let release = io.release;
    let mut out = vec![0.0f64; ms.len()];
    let (near, far): (Vec<usize>, Vec<usize>) =
        (0..ms.len()).partition(|&s| 2 * ms[s] as usize <= far_m);
    let pivot = pivot_of(x);
    // the far walk's checkpoints, filled by the near jobs as they end
    let mut loc = if far.is_empty() {
        Vec::new()
    } else {
        vec![(0.0f64, 0.0f64); (x.len().div_ceil(G) + 1).div_ceil(2)]
    };
    let jobs = stream_near(
        x, pivot, ms, &near, far_m, job_chunks, simd, release, &mut loc, &mut out,
    );
    if !pivot.is_finite() || jobs.iter().any(|j| j.bad) {
        if let Some((index, value)) = first_non_finite(x) {
            return Err(AvarError::NonFinite { index, value });
        }
        return Err(AvarError::Overflow);
    }
    let (ck, total) = global_checkpoints(x, pivot, jobs, job_chunks * NSEG * SEG_NEAR, loc);
    if !total.is_finite() {
        return Err(AvarError::Overflow);
    }
    stream_group::<SEG_FAR>(x, &ck, ms, &far, far_m, simd, io, &mut out);
    release(0, x.len());
    Ok((out, pivot + total / x.len() as f64, ck))
}

/// Target near chunks per job of the near walk ([`stream_near`], [`job_chunks`]): 480 chunks of
/// 17 408 samples, 8.4 M samples (12 jobs at T = 10^8), so that the warm-up of [`FAR_M`] samples
/// adds 12.5 % to the checkpoint sums and the jobs still balance over the threads.
const JOB_CHUNKS: usize = 480;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::buffered::overlapping_sums;
    use crate::kernel::cumsum::centred_prefix_into;
    use crate::kernel::tests::series;

    const SCHUNK: usize = NSEG * SEG_NEAR;

    /// The streamed kernel (full chunks through the SIMD path, partial chunks and the portable
    /// path through `seg_sum`) agrees with the buffered kernel, is bit-identical between the
    /// SIMD and portable paths, does not depend on the other requested scales, and is offset
    /// invariant.
    #[test]
    fn streamed_sums_match_buffered_and_are_path_independent() {
        let n = 3 * SCHUNK + 12_345;
        let ms: Vec<u64> = vec![
            1, 2, 3, 7, 8, 64, 1000, 1024, 5000, 8192, 16_384, 20_000, 30_000,
        ];
        let x = series(n, 0.0);
        let (streamed, mean) = overlapping_sums_stream(&x, &ms).unwrap();
        let mut c = Vec::new();
        let mean_buffered = centred_prefix_into(&x, &mut c).unwrap();
        assert!((mean - mean_buffered).abs() <= 1e-15 * mean_buffered.abs().max(1.0));
        let buffered = overlapping_sums(&c, &ms);
        for (a, b) in streamed.iter().zip(&buffered) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "{a} vs {b}");
        }
        // the far grid and its residue-class walk (threshold lowered so that m > 2048 are far
        // here), with one job per near chunk (local checkpoint frames with a warm-up of
        // 4096 samples): same sums as the buffered kernel
        let far_m = 4096;
        let split =
            overlapping_sums_stream_split(&x, &ms, far_m, 1, crate::simd::level(), &Io::NONE)
                .unwrap()
                .0;
        for ((a, b), &m) in split.iter().zip(&buffered).zip(&ms) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "m {m}: {a} vs {b}");
        }
        // every vector path gives the same bits as the portable one, near and far (the far
        // scales 8192 and 16 384 are whole class steps here and read the ring of lane copies)
        for (far_m, jobs) in [(FAR_M, JOB_CHUNKS), (far_m, 1)] {
            let best = overlapping_sums_stream_split(
                &x,
                &ms,
                far_m,
                jobs,
                crate::simd::level(),
                &Io::NONE,
            )
            .unwrap();
            for simd in crate::simd::levels() {
                let p =
                    overlapping_sums_stream_split(&x, &ms, far_m, jobs, simd, &Io::NONE).unwrap();
                for ((a, b), &m) in p.0.iter().zip(&best.0).zip(&ms) {
                    assert_eq!(a.to_bits(), b.to_bits(), "far_m {far_m} {simd:?} m {m}");
                }
                assert_eq!(p.1.to_bits(), best.1.to_bits());
            }
        }
        // one job instead of the default grid (here four one-chunk jobs): the checkpoint frames
        // differ, the sums only by rounding
        let one_job = overlapping_sums_stream_split(
            &x,
            &ms,
            far_m,
            JOB_CHUNKS,
            crate::simd::level(),
            &Io::NONE,
        )
        .unwrap()
        .0;
        assert_eq!(job_chunks(n), 1);
        for ((a, d), &m) in one_job.iter().zip(&streamed).zip(&ms) {
            assert!((a - d).abs() <= 1e-13 * d.abs(), "m {m}: {a} vs {d}");
        }
        // the value for m does not depend on the other requested scales
        let single_far =
            overlapping_sums_stream_split(&x, &[20_000], far_m, 1, crate::simd::level(), &Io::NONE)
                .unwrap()
                .0;
        assert_eq!(single_far[0].to_bits(), split[11].to_bits());
        let single_near =
            overlapping_sums_stream_split(&x, &[1000], far_m, 1, crate::simd::level(), &Io::NONE)
                .unwrap()
                .0;
        assert_eq!(single_near[0].to_bits(), split[6].to_bits());
        let single = overlapping_sums_stream(&x, &[5000]).unwrap().0;
        assert_eq!(single[0].to_bits(), streamed[8].to_bits());
        // offset invariance
        let std = 0.3;
        let y: Vec<f64> = x.iter().map(|v| v + 1e4 * std).collect();
        let off = overlapping_sums_stream(&y, &ms).unwrap().0;
        for (a, b) in off.iter().zip(&streamed) {
            assert!((a - b).abs() <= 1e-10 * b.abs(), "{a} vs {b}");
        }
        let off_split =
            overlapping_sums_stream_split(&y, &ms, far_m, 1, crate::simd::level(), &Io::NONE)
                .unwrap()
                .0;
        for (a, b) in off_split.iter().zip(&split) {
            assert!((a - b).abs() <= 1e-10 * b.abs(), "{a} vs {b}");
        }
    }

    /// More near scales than one batch ([`SCALE_BATCH`]): the later batches reuse the jobs'
    /// checkpoints, and each value is the one the scale gets when requested alone.
    #[test]
    fn streamed_sums_span_several_scale_batches() {
        let n = 3 * SCHUNK + 12_345;
        let x = series(n, 0.0);
        let ms: Vec<u64> = (1..=300).map(|k| 7 * k).collect();
        let (sums, ..) =
            overlapping_sums_stream_split(&x, &ms, FAR_M, 1, crate::simd::level(), &Io::NONE)
                .unwrap();
        let mut c = Vec::new();
        centred_prefix_into(&x, &mut c).unwrap();
        let buffered = overlapping_sums(&c, &ms);
        for ((a, b), &m) in sums.iter().zip(&buffered).zip(&ms) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "m {m}: {a} vs {b}");
        }
        for k in [0, 150, 299] {
            let one = overlapping_sums_stream_split(
                &x,
                &ms[k..=k],
                FAR_M,
                1,
                crate::simd::level(),
                &Io::NONE,
            );
            assert_eq!(
                one.unwrap().0[0].to_bits(),
                sums[k].to_bits(),
                "m {}",
                ms[k]
            );
        }
    }

    /// The streamed kernel names the first non-finite sample, in whichever job it lies, and
    /// reports overflow of finite samples.
    #[test]
    fn streamed_sums_reject_non_finite_and_overflow() {
        let n = 3 * SCHUNK + 12_345;
        for (index, value) in [
            (0, f64::NAN),
            (SCHUNK + 5, f64::INFINITY),
            (n - 1, f64::NAN),
        ] {
            let mut x = series(n, 0.0);
            x[index] = value;
            for job_chunks in [1, JOB_CHUNKS] {
                match overlapping_sums_stream_split(
                    &x,
                    &[2, 8192],
                    4096,
                    job_chunks,
                    crate::simd::level(),
                    &Io::NONE,
                ) {
                    Err(AvarError::NonFinite { index: i, .. }) => assert_eq!(i, index),
                    other => panic!("index {index}: {:?}", other.map(|r| r.0)),
                }
            }
        }
        // the pivot overflows; then only the block sums do (alternating signs, pivot 0)
        let x = vec![1.7e308; n];
        assert!(matches!(
            overlapping_sums_stream(&x, &[2]),
            Err(AvarError::Overflow)
        ));
        let x: Vec<f64> = (0..n)
            .map(|i| if i % 2 == 0 { 1.7e308 } else { -1.7e308 })
            .collect();
        assert!(matches!(
            overlapping_sums_stream_split(&x, &[2], 4096, 1, crate::simd::level(), &Io::NONE),
            Err(AvarError::Overflow)
        ));
    }
}
