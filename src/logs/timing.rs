//! Time stamps: the rate from the median Δt, ordering by stamp, and the gap, duplicate
//! and reorder counts.
//!
//! - Messages are sorted by stamp (stable); `reordered` counts the messages whose stamp
//!   is earlier than the one recorded before them.
//! - A message with the same stamp as the one before it (after sorting) is a duplicate: the
//!   later one is removed and counted in `duplicates`.
//! - The rate is 1 / median Δt unless `--rate` is given; a given rate more than 1 % away
//!   from the stamps' rate is an error that prints both.
//! - A gap is a Δt > 1.5 nominal Δt; `missing_samples` adds round(Δt / nominal) − 1 (at
//!   least 1) per gap. When the missing samples exceed 0.1 % of the samples the record is
//!   refused, unless `--gaps longest` (analyse the longest gap-free segment) or
//!   `--gaps ignore` (go on with the whole record).

use crate::error::{Error, Result};
use serde::Serialize;

/// What to do with a record whose gaps exceed 0.1 % of its samples (`--gaps`).
///
/// ```
/// use imunoise::logs::timing::{GapPolicy, prepare};
/// // 1000 stamps at 200 Hz with samples 300..310 missing: 1 % of the record
/// let mut stamps: Vec<i64> = (0..1000).map(|i| 5_000_000 * i).collect();
/// stamps.drain(300..310);
/// let x = vec![0.0; stamps.len()];
/// let run = |p| prepare(stamps.clone(), vec![x.clone()], None, p, "run.mcap (/imu0)");
/// let e = run(GapPolicy::Refuse).unwrap_err();
/// assert!(e.to_string().contains("use --gaps longest"));
/// // the longest gap-free segment: the 690 samples after the gap
/// let (cols, t) = run(GapPolicy::Longest)?;
/// assert_eq!((t.segment, cols[0].len()), (Some([300, 990]), 690));
/// let (cols, t) = run(GapPolicy::Ignore)?;
/// assert_eq!((cols[0].len(), t.gaps, t.missing_samples), (990, 1, 10));
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GapPolicy {
    /// Refuse the record (exit 2) with a message that says why.
    #[default]
    Refuse,
    /// Analyse the longest gap-free segment.
    Longest,
    /// Analyse the whole record anyway.
    Ignore,
}

/// The fraction of missing samples above which a record is refused (0.1 %).
pub const MAX_MISSING_FRACTION: f64 = 1e-3;

/// A gap is a Δt larger than this many nominal Δt.
pub const GAP_FACTOR: f64 = 1.5;

/// What the stamps of a record say (written to `results.json` as `timing`).
///
/// ```
/// use imunoise::logs::timing::{GapPolicy, prepare};
/// // 400 Hz stamps from t = 2 s, the 100th message recorded twice
/// let mut stamps: Vec<i64> = (0..1000).map(|i| 2_000_000_000 + 2_500_000 * i).collect();
/// stamps.insert(100, stamps[99]);
/// let x = vec![0.0; stamps.len()];
/// let (cols, t) = prepare(stamps, vec![x], None, GapPolicy::Refuse, "imu.csv")?;
/// assert_eq!((t.messages, t.samples_used, t.duplicates), (1001, 1000, 1));
/// assert_eq!((t.rate_hz, t.rate_source), (400.0, "stamps"));
/// assert_eq!(t.median_dt_s, 1.0 / 400.0);
/// assert_eq!(t.span_s, [2.0, 2.0 + 999.0 / 400.0]);
/// assert_eq!((t.gaps, t.longest_gap_s, t.segment), (0, 0.0, None));
/// assert_eq!(cols[0].len(), t.samples_used);
/// // as written to results.json
/// let json = serde_json::to_value(&t).unwrap();
/// assert_eq!(json["gap_policy"], "refuse");
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Timing {
    /// Messages read.
    pub messages: usize,
    /// Samples analysed (after removing duplicates and, with `--gaps longest`, outside the
    /// longest gap-free segment).
    pub samples_used: usize,
    /// The rate used for the analysis (Hz).
    pub rate_hz: f64,
    /// Where the rate comes from: `"stamps"` or `"--rate"`.
    pub rate_source: &'static str,
    /// 1 / median Δt of the sorted, de-duplicated stamps (Hz).
    pub rate_from_stamps_hz: f64,
    /// Median Δt (s).
    pub median_dt_s: f64,
    /// First and last stamp (s since the epoch of the log).
    pub span_s: [f64; 2],
    /// Messages whose stamp is earlier than the previous message's (recording order).
    pub reordered: usize,
    /// Messages with the same stamp as another one (removed; the first is kept).
    pub duplicates: usize,
    /// Intervals with Δt > 1.5 nominal Δt.
    pub gaps: usize,
    /// Samples missing in the gaps: Σ max(1, round(Δt / nominal) − 1).
    pub missing_samples: usize,
    /// The longest gap (s); 0 when there is none.
    pub longest_gap_s: f64,
    /// The `--gaps` policy in force.
    pub gap_policy: GapPolicy,
    /// With `--gaps longest`: the analysed segment, first and one-past-last sample index
    /// (after sorting and de-duplication).
    pub segment: Option<[usize; 2]>,
    /// Logs: where the file is cut off, when it is (its complete messages were read).
    pub truncated: Option<super::Truncation>,
}

impl Timing {
    /// One line for people: rate, counts and what was done.
    ///
    /// ```
    /// use imunoise::logs::timing::{GapPolicy, prepare};
    /// let stamps: Vec<i64> = (0..100).map(|i| 10_000_000 * i).collect();
    /// let (_, t) = prepare(stamps, vec![vec![0.0; 100]], Some(100.0), GapPolicy::Refuse, "x")?;
    /// assert_eq!(
    ///     t.summary(),
    ///     "100 messages, rate 100.000000 Hz (--rate; stamps say 100.000000 Hz), 0 reordered, \
    ///      0 duplicates (removed), 0 gaps (0 samples missing, longest 0.000000 s)"
    /// );
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{} messages, rate {:.6} Hz ({}; stamps say {:.6} Hz), {} reordered, {} duplicates (removed), {} gaps ({} samples missing, longest {:.6} s)",
            self.messages,
            self.rate_hz,
            self.rate_source,
            self.rate_from_stamps_hz,
            self.reordered,
            self.duplicates,
            self.gaps,
            self.missing_samples,
            self.longest_gap_s
        );
        match (self.gap_policy, self.segment) {
            (GapPolicy::Longest, Some([a, b])) => s.push_str(&format!(
                "; --gaps longest: analysing samples {a}..{b} ({} samples), the longest gap-free segment",
                b - a
            )),
            (GapPolicy::Ignore, _) if self.gaps > 0 => {
                s.push_str("; --gaps ignore: analysing the whole record across its gaps")
            }
            _ => {}
        }
        s
    }
}

/// The median of the L = len − 1 differences of `stamps` (ns; the mean of the two middle ones
/// for even L; a difference beyond i64, between stamps ±292 years apart, counts as i64::MAX). A recording's Δt mostly takes one value: the median of every 64th difference
/// is checked by counting the differences below and equal to it (one pass, no buffer), and
/// only when it is not the median are all differences selected (`select_nth_unstable`).
fn median_dt_ns(stamps: &[i64]) -> f64 {
    let len = stamps.len() - 1;
    let mid = len / 2;
    // the ranks the median takes: mid, and mid − 1 too for even L
    let lo_rank = if len % 2 == 1 { mid } else { mid - 1 };
    let mut sub: Vec<i64> = stamps
        .windows(2)
        .step_by(64)
        .map(|w| w[1].saturating_sub(w[0]))
        .collect();
    let k = sub.len() / 2;
    let c = *sub.select_nth_unstable(k).1;
    let (mut below, mut equal) = (0usize, 0usize);
    for w in stamps.windows(2) {
        let d = w[1].saturating_sub(w[0]);
        below += usize::from(d < c);
        equal += usize::from(d == c);
    }
    if below <= lo_rank && mid < below + equal {
        return c as f64;
    }
    let mut dts: Vec<i64> = stamps
        .windows(2)
        .map(|w| w[1].saturating_sub(w[0]))
        .collect();
    if len % 2 == 1 {
        *dts.select_nth_unstable(mid).1 as f64
    } else {
        let hi = *dts.select_nth_unstable(mid).1;
        let lo = *dts[..mid].iter().max().expect("non-empty");
        (lo as f64 + hi as f64) / 2.0
    }
}

/// Orders `columns` by `stamps_ns`, removes duplicates, estimates the rate, counts gaps
/// and applies `policy`. Returns the columns to analyse and the [`Timing`].
///
/// `rate_arg` is `--rate`; `what` names the record in messages (file and topic).
///
/// ```
/// use imunoise::logs::timing::{prepare, GapPolicy};
/// // 200 Hz stamps, the third message recorded before the second.
/// let stamps = vec![0, 10_000_000, 5_000_000, 15_000_000, 20_000_000];
/// let x = vec![0.0, 2.0, 1.0, 3.0, 4.0];
/// let (cols, t) = prepare(stamps, vec![x], None, GapPolicy::Refuse, "f").unwrap();
/// assert_eq!(cols[0], [0.0, 1.0, 2.0, 3.0, 4.0]);
/// assert_eq!((t.rate_hz, t.reordered, t.gaps), (200.0, 1, 0));
/// ```
pub fn prepare(
    stamps_ns: Vec<i64>,
    columns: Vec<Vec<f64>>,
    rate_arg: Option<f64>,
    policy: GapPolicy,
    what: &str,
) -> Result<(Vec<Vec<f64>>, Timing)> {
    let n = stamps_ns.len();
    let err = |message: String| Error::File {
        file: what.to_string(),
        message,
    };
    if n < 2 {
        return Err(err(format!(
            "{n} time-stamped samples; at least 2 are needed"
        )));
    }
    let reordered = stamps_ns.windows(2).filter(|w| w[1] < w[0]).count();
    let (mut stamps, mut columns) = if reordered > 0 {
        let mut idx: Vec<u32> = (0..n as u32).collect();
        idx.sort_by_key(|&i| stamps_ns[i as usize]);
        let s: Vec<i64> = idx.iter().map(|&i| stamps_ns[i as usize]).collect();
        let c: Vec<Vec<f64>> = columns
            .iter()
            .map(|c| idx.iter().map(|&i| c[i as usize]).collect())
            .collect();
        (s, c)
    } else {
        (stamps_ns, columns)
    };
    let duplicates = stamps.windows(2).filter(|w| w[1] == w[0]).count();
    if duplicates > 0 {
        let keep: Vec<bool> = (0..stamps.len())
            .map(|i| i == 0 || stamps[i] != stamps[i - 1])
            .collect();
        let filt = |v: &mut Vec<f64>| {
            let mut k = 0;
            v.retain(|_| {
                k += 1;
                keep[k - 1]
            });
        };
        columns.iter_mut().for_each(filt);
        let mut k = 0;
        stamps.retain(|_| {
            k += 1;
            keep[k - 1]
        });
    }
    if stamps.len() < 2 {
        return Err(err(format!(
            "all {n} messages have the same time stamp; the rate cannot be estimated"
        )));
    }
    let median_dt_s = median_dt_ns(&stamps) * 1e-9;
    let rate_from_stamps = 1.0 / median_dt_s;
    let (rate, rate_source) = match rate_arg {
        Some(r) => {
            let rel = (r - rate_from_stamps).abs() / rate_from_stamps;
            if rel > 0.01 {
                return Err(err(format!(
                    "--rate {r} Hz disagrees with the rate from the time stamps, {rate_from_stamps:.6} Hz \
                     (median Δt {:.6} ms), by {:.2} % (more than 1 %); drop --rate to use the stamps",
                    median_dt_s * 1e3,
                    rel * 100.0
                )));
            }
            (r, "--rate")
        }
        None => (rate_from_stamps, "stamps"),
    };
    let nominal_ns = 1e9 / rate;
    let mut gaps = 0usize;
    let mut missing = 0usize;
    let mut longest_gap = 0i64;
    let (mut best, mut seg_start) = ((0usize, 0usize), 0usize);
    for i in 1..stamps.len() {
        let dt = stamps[i].saturating_sub(stamps[i - 1]);
        if dt as f64 > GAP_FACTOR * nominal_ns {
            gaps += 1;
            missing += ((dt as f64 / nominal_ns).round() as usize)
                .saturating_sub(1)
                .max(1);
            longest_gap = longest_gap.max(dt);
            if i - seg_start > best.1 - best.0 {
                best = (seg_start, i);
            }
            seg_start = i;
        }
    }
    if stamps.len() - seg_start > best.1 - best.0 {
        best = (seg_start, stamps.len());
    }
    let used_n = stamps.len();
    let mut t = Timing {
        messages: n,
        samples_used: used_n,
        rate_hz: rate,
        rate_source,
        rate_from_stamps_hz: rate_from_stamps,
        median_dt_s,
        span_s: [stamps[0] as f64 * 1e-9, stamps[used_n - 1] as f64 * 1e-9],
        reordered,
        duplicates,
        gaps,
        missing_samples: missing,
        longest_gap_s: longest_gap as f64 * 1e-9,
        gap_policy: policy,
        segment: None,
        truncated: None,
    };
    let too_many = missing as f64 > MAX_MISSING_FRACTION * used_n as f64;
    match policy {
        GapPolicy::Refuse if too_many => Err(err(format!(
            "{gaps} gaps (Δt > {GAP_FACTOR} × {:.6} ms) with about {missing} missing samples, \
             {:.3} % of {used_n} samples (more than {} %; longest gap {:.6} s); \
             use --gaps longest to analyse the longest gap-free segment ({} samples) \
             or --gaps ignore to go on anyway",
            nominal_ns * 1e-6,
            100.0 * missing as f64 / used_n as f64,
            MAX_MISSING_FRACTION * 100.0,
            t.longest_gap_s,
            best.1 - best.0
        ))),
        GapPolicy::Longest if gaps > 0 => {
            let (a, b) = best;
            for c in &mut columns {
                c.truncate(b);
                c.drain(..a);
            }
            t.segment = Some([a, b]);
            t.samples_used = b - a;
            Ok((columns, t))
        }
        _ => Ok((columns, t)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stamps(n: usize, dt: i64) -> Vec<i64> {
        (0..n as i64).map(|i| 1_000_000_000 + i * dt).collect()
    }

    /// The median by selection over all differences, as `prepare` computed it before.
    fn median_by_selection(stamps: &[i64]) -> f64 {
        let mut dts: Vec<i64> = stamps.windows(2).map(|w| w[1] - w[0]).collect();
        let mid = dts.len() / 2;
        if dts.len() % 2 == 1 {
            *dts.select_nth_unstable(mid).1 as f64
        } else {
            let hi = *dts.select_nth_unstable(mid).1;
            let lo = *dts[..mid].iter().max().unwrap();
            (lo as f64 + hi as f64) / 2.0
        }
    }

    /// The counting check gives the median by selection on clean, gapped, two-valued and
    /// jittered stamps, odd and even numbers of differences, including the two-valued cases
    /// where the two middle differences differ (the mean of the two).
    #[test]
    fn median_dt_equals_selection() {
        let mut h = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = |m: i64| {
            h ^= h << 13;
            h ^= h >> 7;
            h ^= h << 17;
            (h % m as u64) as i64
        };
        let mut cases: Vec<Vec<i64>> = Vec::new();
        for n in [2, 3, 4, 5, 64, 65, 1000, 1001, 10_000] {
            cases.push(stamps(n, 1_000_000));
            let mut g = stamps(n, 5_000_000);
            if n > 10 {
                g.drain(3..6);
            }
            cases.push(g);
            // jitter of ±2 µs: rarely the same Δt twice, so the check fails and selection runs
            let mut t = 0i64;
            cases.push(
                (0..n)
                    .map(|_| {
                        t += 1_000_000 + rnd(4001) - 2000;
                        t
                    })
                    .collect(),
            );
            // two values, 1 and 3 ms, in proportions near one half (the middle pair can differ)
            for p in [499, 500, 501] {
                let mut t = 0i64;
                cases.push(
                    (0..n)
                        .map(|_| {
                            t += if rnd(1000) < p { 1_000_000 } else { 3_000_000 };
                            t
                        })
                        .collect(),
                );
            }
        }
        // exactly half 1 ms and half 3 ms differences, in both orders: the median is 2 ms
        for first in [1_000_000i64, 3_000_000] {
            let mut t = 0i64;
            cases.push(
                (0..201)
                    .map(|i| {
                        t += if (i <= 100) == (first == 1_000_000) {
                            1_000_000
                        } else {
                            3_000_000
                        };
                        t
                    })
                    .collect(),
            );
        }
        for s in &cases {
            assert_eq!(
                median_dt_ns(s),
                median_by_selection(s),
                "{} stamps",
                s.len()
            );
        }
        assert_eq!(median_dt_ns(&cases[cases.len() - 1]), 2_000_000.0);
        assert_eq!(median_dt_ns(&cases[cases.len() - 2]), 2_000_000.0);
    }

    #[test]
    fn counts_on_injected_faults() {
        // 10000 samples at 1 kHz; 2 swaps (2 reordered), 3 duplicates, 1 gap of 3 samples.
        let mut s = stamps(10_000, 1_000_000);
        s.swap(100, 101);
        s.swap(5000, 5001);
        s.insert(2000, s[1999]);
        s.insert(3000, s[2999]);
        s.insert(3001, s[2999]);
        s.drain(7000..7003);
        let n = s.len();
        let x: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let (c, t) = prepare(s, vec![x], None, GapPolicy::Refuse, "t").unwrap();
        assert_eq!(t.messages, 10_000);
        assert_eq!((t.reordered, t.duplicates, t.gaps), (2, 3, 1));
        assert_eq!(t.missing_samples, 3);
        assert_eq!(t.rate_hz, 1000.0);
        assert_eq!(c[0].len(), 10_000 - 3);
        assert!((t.longest_gap_s - 0.004).abs() < 1e-12);
    }

    #[test]
    fn rate_check_and_gap_policies() {
        let s = stamps(1000, 5_000_000);
        let x = vec![0.0; 1000];
        assert!(
            prepare(
                s.clone(),
                vec![x.clone()],
                Some(201.9),
                GapPolicy::Refuse,
                "t"
            )
            .is_ok()
        );
        let e = prepare(
            s.clone(),
            vec![x.clone()],
            Some(100.0),
            GapPolicy::Refuse,
            "t",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("--rate 100 Hz") && e.contains("200.000000 Hz"),
            "{e}"
        );
        // One gap of 10 missing samples in 1000: 1 % > 0.1 %.
        let mut g = s.clone();
        g.drain(300..310);
        let x = vec![0.0; g.len()];
        let e = prepare(g.clone(), vec![x.clone()], None, GapPolicy::Refuse, "t").unwrap_err();
        assert!(e.to_string().contains("--gaps longest"), "{e}");
        let (c, t) = prepare(g.clone(), vec![x.clone()], None, GapPolicy::Longest, "t").unwrap();
        assert_eq!(t.segment, Some([300, 990]));
        assert_eq!(c[0].len(), 690);
        let (c, t) = prepare(g, vec![x], None, GapPolicy::Ignore, "t").unwrap();
        assert_eq!((c[0].len(), t.gaps, t.missing_samples), (990, 1, 10));
    }
}
