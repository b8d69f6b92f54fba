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
pub(crate) fn median_dt_ns(stamps: &[i64]) -> f64 {
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

/// The rate in force and where it comes from, given `--rate` (`rate_arg`) and the median Δt
/// of the stamps (s): the stamps' rate 1 / median Δt, or `--rate` when it is within 1 % of
/// it. Err: the message saying both rates (`--rate` more than 1 % away).
fn rate_in_force(
    rate_arg: Option<f64>,
    median_dt_s: f64,
) -> std::result::Result<(f64, &'static str), String> {
    let rate_from_stamps = 1.0 / median_dt_s;
    match rate_arg {
        Some(r) => {
            let rel = (r - rate_from_stamps).abs() / rate_from_stamps;
            if rel > 0.01 {
                return Err(format!(
                    "--rate {r} Hz disagrees with the rate from the time stamps, {rate_from_stamps:.6} Hz \
                     (median Δt {:.6} ms), by {:.2} % (more than 1 %); drop --rate to use the stamps",
                    median_dt_s * 1e3,
                    rel * 100.0
                ));
            }
            Ok((r, "--rate"))
        }
        None => Ok((rate_from_stamps, "stamps")),
    }
}

/// The samples missing in an interval of `dt_ns` between two stamps at the nominal Δt
/// `nominal_ns`: None when it is no gap (Δt ≤ [`GAP_FACTOR`] nominal), else
/// max(1, round(Δt / nominal) − 1).
fn gap_missing(dt_ns: i64, nominal_ns: f64) -> Option<usize> {
    (dt_ns as f64 > GAP_FACTOR * nominal_ns).then(|| {
        ((dt_ns as f64 / nominal_ns).round() as usize)
            .saturating_sub(1)
            .max(1)
    })
}

/// The counts of a refusal: gaps, missing samples and their share of `used_n` samples.
fn gap_counts(
    gaps: usize,
    missing: usize,
    nominal_ns: f64,
    used_n: usize,
    longest_gap_s: f64,
) -> String {
    format!(
        "{gaps} gaps (Δt > {GAP_FACTOR} × {:.6} ms) with about {missing} missing samples, \
         {:.3} % of {used_n} samples (more than {} %; longest gap {:.6} s)",
        nominal_ns * 1e-6,
        100.0 * missing as f64 / used_n as f64,
        MAX_MISSING_FRACTION * 100.0,
        longest_gap_s,
    )
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
    let (rate, rate_source) = rate_in_force(rate_arg, median_dt_s).map_err(err)?;
    let nominal_ns = 1e9 / rate;
    let mut gaps = 0usize;
    let mut missing = 0usize;
    let mut longest_gap = 0i64;
    let (mut best, mut seg_start) = ((0usize, 0usize), 0usize);
    for i in 1..stamps.len() {
        let dt = stamps[i].saturating_sub(stamps[i - 1]);
        if let Some(m) = gap_missing(dt, nominal_ns) {
            gaps += 1;
            missing += m;
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
            "{}; use --gaps longest to analyse the longest gap-free segment ({} samples) \
             or --gaps ignore to go on anyway",
            gap_counts(gaps, missing, nominal_ns, used_n, t.longest_gap_s),
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

/// Rows [`StampStream`] holds to put rows that arrive out of order back in stamp order: a
/// row may arrive up to this many rows after its place in stamp order and still be analysed
/// exactly as the batch [`prepare`] analyses the whole record.
pub const REORDER_WINDOW: usize = 64;

/// The Δt a stream's rate is estimated from: the rate is 1 / median of the first this many
/// Δt (after ordering and de-duplication), or of fewer when the stream ends sooner.
pub const RATE_DTS: usize = 1024;

/// What a [`StampStream`] releases, in order.
#[derive(Debug)]
pub enum Release {
    /// The rate is known (Hz, the one in force: `--rate` or the stamps'): released once,
    /// before the first sample.
    Rate(f64),
    /// The next sample in stamp order (duplicates removed): the line it was read from and
    /// its values.
    Sample {
        /// Line of the stream (from 1).
        line: usize,
        /// The row's values, without its stamp.
        values: Vec<f64>,
    },
    /// `--gaps longest`: a gap ends the segment; the next sample starts a new one.
    NewSegment,
    /// A row whose stamp is older than a sample already released (it came more than
    /// [`REORDER_WINDOW`] rows late): an error at its line; the row is left out.
    TooOld(Error),
    /// `--gaps refuse`: a gap brought the missing samples above [`MAX_MISSING_FRACTION`] of
    /// the samples so far; the error says where and the counts. Nothing more is released.
    Refused(Error),
}

/// One row held in the reorder window or before the rate is known.
#[derive(Debug)]
struct Held {
    stamp: i64,
    line: usize,
    values: Vec<f64>,
}

/// The rules of [`prepare`] applied to rows as they arrive (for `imunoise live`).
///
/// - Reordering: rows wait in a window of [`REORDER_WINDOW`] rows and leave it in stamp
///   order (ties in arrival order, as the batch's stable sort); a row whose stamp is older
///   than a sample already released is [`Release::TooOld`]; `reordered` counts the rows whose
///   stamp is earlier than the previous row's, as the batch does.
/// - Duplicates: a row with the stamp of the sample released before it is dropped and
///   counted (the first one is kept).
/// - Rate: 1 / median of the first [`RATE_DTS`] Δt (fewer when the stream ends sooner);
///   samples wait until then. A `--rate` more than 1 % away is the batch's error.
/// - Gaps (Δt > [`GAP_FACTOR`] nominal Δt, missing = Σ max(1, round(Δt/nominal) − 1)):
///   [`GapPolicy::Refuse`] stops (once) as soon as the missing samples exceed
///   [`MAX_MISSING_FRACTION`] of the samples so far (the row after the gap included);
///   [`GapPolicy::Longest`] releases [`Release::NewSegment`] at each gap;
///   [`GapPolicy::Ignore`] goes on across gaps.
///
/// On a record whose rows arrive at most [`REORDER_WINDOW`] rows late and whose first
/// [`RATE_DTS`] Δt have the median of all its Δt, the samples released (per segment) and the
/// final [`StampStream::timing`] are those of [`prepare`] (with `--gaps refuse`: when the
/// stream is not refused, which needs the missing share under 0.1 % at every gap).
///
/// ```
/// use imunoise::logs::timing::{GapPolicy, Release, StampStream};
/// // 2000 rows at 100 Hz; rows 10 and 11 swapped, row 20 twice, 3 samples missing at 1500
/// let mut stamps: Vec<i64> = (0..2000).map(|i| 10_000_000 * i).collect();
/// stamps.drain(1500..1503);
/// stamps.swap(10, 11);
/// stamps.insert(20, stamps[20]);
/// let mut s = StampStream::new(None, GapPolicy::Longest, "imu.csv");
/// let mut out = Vec::new();
/// for (i, &t) in stamps.iter().enumerate() {
///     s.push(t, i + 2, vec![t as f64], &mut out)?;
/// }
/// s.finish(&mut out)?;
/// let samples: Vec<f64> = out.iter().filter_map(|r| match r {
///     Release::Sample { values, .. } => Some(values[0]),
///     _ => None,
/// }).collect();
/// assert_eq!(samples.len(), 1997);
/// assert!(samples.windows(2).all(|w| w[0] < w[1])); // in stamp order, no duplicate
/// assert!(matches!(out[0], Release::Rate(r) if r == 100.0));
/// let t = s.timing().unwrap();
/// assert_eq!((t.messages, t.reordered, t.duplicates, t.gaps, t.missing_samples), (1998, 1, 1, 1, 3));
/// assert_eq!(t.segment, Some([0, 1500])); // the longest gap-free segment
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug)]
pub struct StampStream {
    what: String,
    rate_arg: Option<f64>,
    policy: GapPolicy,
    /// The reorder window, in (stamp, arrival) order.
    window: std::collections::VecDeque<Held>,
    /// Released samples waiting for the rate.
    warm: Vec<Held>,
    /// The stamp of the previous row read (for `reordered`).
    last_in: Option<i64>,
    /// The stamp of the last row released from the window (for duplicates and late rows).
    last_out: Option<i64>,
    /// (rate in force, its source, median Δt in s), once known.
    rate: Option<(f64, &'static str, f64)>,
    messages: usize,
    reordered: usize,
    duplicates: usize,
    gaps: usize,
    missing: usize,
    longest_gap_ns: i64,
    /// First and last stamp of the samples released after the rate.
    span: Option<(i64, i64)>,
    /// Samples released after the rate (their index after ordering and de-duplication).
    samples: usize,
    /// Start of the current gap-free segment, and the longest closed one.
    seg_start: usize,
    best: (usize, usize),
    refused: bool,
}

impl StampStream {
    /// A stream of `what` (named in messages) with `--rate` `rate_arg` (checked against the
    /// stamps; None: the stamps' rate) and the `--gaps` policy.
    pub fn new(rate_arg: Option<f64>, policy: GapPolicy, what: &str) -> StampStream {
        StampStream {
            what: what.to_string(),
            rate_arg,
            policy,
            window: std::collections::VecDeque::with_capacity(REORDER_WINDOW + 1),
            warm: Vec::new(),
            last_in: None,
            last_out: None,
            rate: None,
            messages: 0,
            reordered: 0,
            duplicates: 0,
            gaps: 0,
            missing: 0,
            longest_gap_ns: 0,
            span: None,
            samples: 0,
            seg_start: 0,
            best: (0, 0),
            refused: false,
        }
    }

    /// The rate in force (Hz), once known.
    pub fn rate_hz(&self) -> Option<f64> {
        self.rate.map(|r| r.0)
    }

    /// True once [`Release::Refused`] was released: later rows are ignored.
    pub fn refused(&self) -> bool {
        self.refused
    }

    /// The next row read: its stamp (ns), the line it was read from and its values. What it
    /// releases is appended to `out`. Errors: a `--rate` more than 1 % away from the stamps'
    /// rate (once the rate is estimated).
    pub fn push(
        &mut self,
        stamp: i64,
        line: usize,
        values: Vec<f64>,
        out: &mut Vec<Release>,
    ) -> Result<()> {
        if self.refused {
            return Ok(());
        }
        if let Some(last) = self.last_out
            && stamp < last
        {
            out.push(Release::TooOld(Error::Located {
                file: self.what.clone(),
                line,
                column: 1,
                message: format!(
                    "time stamp {:.9} s is older than {:.9} s of a row already analysed: the row \
                     arrives more than {REORDER_WINDOW} rows (the reorder window) after its place \
                     in time order",
                    stamp as f64 * 1e-9,
                    last as f64 * 1e-9
                ),
            }));
            return Ok(());
        }
        self.messages += 1;
        if self.last_in.is_some_and(|p| stamp < p) {
            self.reordered += 1;
        }
        self.last_in = Some(stamp);
        // after the rows of the same stamp: ties stay in arrival order
        let at = self.window.partition_point(|h| h.stamp <= stamp);
        self.window.insert(
            at,
            Held {
                stamp,
                line,
                values,
            },
        );
        if self.window.len() > REORDER_WINDOW {
            let h = self.window.pop_front().expect("non-empty");
            self.release(h, out)?;
        }
        Ok(())
    }

    /// The end of the stream: releases the rows held. Errors: fewer than 2 distinct stamps,
    /// a `--rate` more than 1 % away from the stamps' rate.
    pub fn finish(&mut self, out: &mut Vec<Release>) -> Result<()> {
        while let Some(h) = self.window.pop_front() {
            if self.refused {
                break;
            }
            self.release(h, out)?;
        }
        self.window.clear();
        if self.rate.is_none() && !self.refused {
            if self.warm.len() < 2 {
                return Err(Error::File {
                    file: self.what.clone(),
                    message: format!(
                        "{} time-stamped samples with distinct stamps; at least 2 are needed",
                        self.warm.len()
                    ),
                });
            }
            self.start(out)?;
        }
        Ok(())
    }

    /// A row leaving the window, in stamp order.
    fn release(&mut self, h: Held, out: &mut Vec<Release>) -> Result<()> {
        if self.last_out == Some(h.stamp) {
            self.duplicates += 1;
            return Ok(());
        }
        self.last_out = Some(h.stamp);
        if self.rate.is_some() {
            self.emit(h, out);
        } else {
            self.warm.push(h);
            if self.warm.len() > RATE_DTS {
                self.start(out)?;
            }
        }
        Ok(())
    }

    /// The rate from the samples waiting for it, then those samples.
    fn start(&mut self, out: &mut Vec<Release>) -> Result<()> {
        let stamps: Vec<i64> = self.warm.iter().map(|h| h.stamp).collect();
        let median_dt_s = median_dt_ns(&stamps) * 1e-9;
        let (rate, source) =
            rate_in_force(self.rate_arg, median_dt_s).map_err(|message| Error::File {
                file: self.what.clone(),
                message: format!(
                    "{message} (the rate from the median of the first {} Δt)",
                    stamps.len() - 1
                ),
            })?;
        self.rate = Some((rate, source, median_dt_s));
        out.push(Release::Rate(rate));
        for h in std::mem::take(&mut self.warm) {
            if self.refused {
                break;
            }
            self.emit(h, out);
        }
        Ok(())
    }

    /// A sample in stamp order, after the rate: gaps, then the sample.
    fn emit(&mut self, h: Held, out: &mut Vec<Release>) {
        let (rate, _, _) = self.rate.expect("rate known");
        let nominal_ns = 1e9 / rate;
        if let Some((_, prev)) = self.span
            && let Some(m) = gap_missing(h.stamp.saturating_sub(prev), nominal_ns)
        {
            let dt = h.stamp.saturating_sub(prev);
            self.gaps += 1;
            self.missing += m;
            self.longest_gap_ns = self.longest_gap_ns.max(dt);
            match self.policy {
                GapPolicy::Refuse
                    if self.missing as f64 > MAX_MISSING_FRACTION * (self.samples + 1) as f64 =>
                {
                    self.refused = true;
                    self.window.clear();
                    self.warm.clear();
                    out.push(Release::Refused(Error::Located {
                        file: self.what.clone(),
                        line: h.line,
                        column: 1,
                        message: format!(
                            "a gap of {:.6} s before this row brings the record so far to {}; \
                             use --gaps longest or --gaps ignore",
                            dt as f64 * 1e-9,
                            gap_counts(
                                self.gaps,
                                self.missing,
                                nominal_ns,
                                self.samples + 1,
                                self.longest_gap_ns as f64 * 1e-9
                            )
                        ),
                    }));
                    return;
                }
                GapPolicy::Longest => {
                    if self.samples - self.seg_start > self.best.1 - self.best.0 {
                        self.best = (self.seg_start, self.samples);
                    }
                    self.seg_start = self.samples;
                    out.push(Release::NewSegment);
                }
                _ => {}
            }
        }
        let first = self.span.map_or(h.stamp, |s| s.0);
        self.span = Some((first, h.stamp));
        self.samples += 1;
        out.push(Release::Sample {
            line: h.line,
            values: h.values,
        });
    }

    /// The longest gap-free segment so far (first and one-past-last sample index; the
    /// earlier one of equal length, as [`prepare`] chooses).
    fn longest(&self) -> (usize, usize) {
        if self.samples - self.seg_start > self.best.1 - self.best.0 {
            (self.seg_start, self.samples)
        } else {
            self.best
        }
    }

    /// The counts so far as [`prepare`]'s [`Timing`] (None before the rate is known):
    /// `samples_used` and `segment` are those analysed so far (with `--gaps longest` the
    /// longest gap-free segment so far), `span_s` the first and last stamp released;
    /// `messages`, `reordered` and `duplicates` count the rows read, those still held in the
    /// reorder window (or waiting for the rate) included.
    pub fn timing(&self) -> Option<Timing> {
        let (rate, source, median_dt_s) = self.rate?;
        let (a, b) = self.span.unwrap_or((0, 0));
        let segment = (self.policy == GapPolicy::Longest && self.gaps > 0).then(|| {
            let (a, b) = self.longest();
            [a, b]
        });
        Some(Timing {
            messages: self.messages,
            samples_used: segment.map_or(self.samples, |[a, b]| b - a),
            rate_hz: rate,
            rate_source: source,
            rate_from_stamps_hz: 1.0 / median_dt_s,
            median_dt_s,
            span_s: [a as f64 * 1e-9, b as f64 * 1e-9],
            reordered: self.reordered,
            duplicates: self.duplicates,
            gaps: self.gaps,
            missing_samples: self.missing,
            longest_gap_s: self.longest_gap_ns as f64 * 1e-9,
            gap_policy: self.policy,
            segment,
            truncated: None,
        })
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

#[cfg(test)]
mod stream_tests {
    use super::*;

    /// Rows through a [`StampStream`] (line = index + 1): the samples of each segment (first
    /// value of each row), the errors' lines, and the final timing.
    type Streamed = (Vec<Vec<f64>>, Vec<usize>, Option<usize>, Option<Timing>);

    fn stream(stamps: &[i64], rate: Option<f64>, policy: GapPolicy) -> Result<Streamed> {
        let mut s = StampStream::new(rate, policy, "t");
        let mut out = Vec::new();
        for (i, &t) in stamps.iter().enumerate() {
            s.push(t, i + 1, vec![i as f64], &mut out)?;
        }
        s.finish(&mut out)?;
        let (mut segs, mut late, mut refused) = (vec![Vec::new()], Vec::new(), None);
        for r in out {
            match r {
                Release::Sample { values, line } => {
                    assert_eq!(values[0], (line - 1) as f64);
                    segs.last_mut().unwrap().push(values[0]);
                }
                Release::NewSegment => segs.push(Vec::new()),
                Release::TooOld(Error::Located { line, .. }) => late.push(line),
                Release::Refused(Error::Located { line, .. }) => refused = Some(line),
                Release::Rate(_) => {}
                other => panic!("{other:?}"),
            }
        }
        Ok((segs, late, refused, s.timing()))
    }

    /// A record of `n` stamps at 1 kHz from t = 3 s with rows up to REORDER_WINDOW / 2 rows
    /// late (20 such moves, so that overlapping moves stay within the window), 10 duplicates
    /// and three gaps (2, 4 and 40 missing samples with `big`, else 1 each).
    fn faulty(n: usize, seed: u64, big: bool) -> Vec<i64> {
        let mut h = seed;
        let mut rnd = |m: u64| {
            h ^= h << 13;
            h ^= h >> 7;
            h ^= h << 17;
            (h % m) as usize
        };
        let mut s: Vec<i64> = (0..n as i64)
            .map(|i| 3_000_000_000 + i * 1_000_000)
            .collect();
        for _ in 0..20 {
            // a row moved up to REORDER_WINDOW rows later
            let i = 10 + rnd(n as u64 - 200);
            let d = 1 + rnd(REORDER_WINDOW as u64 / 2);
            let v = s.remove(i);
            s.insert(i + d, v);
        }
        for _ in 0..10 {
            let i = 1 + rnd(n as u64 - 2);
            s.insert(i, s[i - 1]);
        }
        let lens = if big { [40, 4, 2] } else { [1, 1, 1] };
        for (at, len) in [(n - 600, lens[0]), (n / 2 + 300, lens[1]), (n / 2, lens[2])] {
            s.drain(at..at + len);
        }
        s
    }

    /// The second implementation: on rows at most REORDER_WINDOW rows late, the samples
    /// released and the final timing are those of the batch `prepare`, for each policy.
    #[test]
    fn stream_equals_prepare_on_faulty_records() {
        let cases = [(1u64, 5_000usize), (7, 20_000), (99, 1_500)];
        for ((seed, n), big) in cases.into_iter().flat_map(|c| [(c, true), (c, false)]) {
            let s = faulty(n, 0x9E37_79B9_7F4A_7C15 ^ seed, big);
            let x: Vec<f64> = (0..s.len()).map(|i| i as f64).collect();
            for policy in [GapPolicy::Ignore, GapPolicy::Longest, GapPolicy::Refuse] {
                let batch = prepare(s.clone(), vec![x.clone()], None, policy, "t");
                let (segs, late, refused, t) = stream(&s, None, policy).unwrap();
                assert!(late.is_empty());
                let t = t.unwrap();
                match batch {
                    Ok((cols, bt)) => {
                        assert_eq!(t, bt, "seed {seed} {policy:?}");
                        assert_eq!(refused, None, "seed {seed} big {big}");
                        let got = match policy {
                            GapPolicy::Longest => {
                                let [a, b] = t.segment.unwrap();
                                let all: Vec<f64> = segs.concat();
                                all[a..b].to_vec()
                            }
                            _ => segs.concat(),
                        };
                        assert_eq!(got, cols[0], "seed {seed} {policy:?}");
                        if policy == GapPolicy::Longest {
                            assert_eq!(segs.len(), 4);
                            assert!(segs.contains(&cols[0]));
                        } else {
                            assert_eq!(segs.len(), 1);
                        }
                    }
                    // refused by both (the stream at the first gap over the share so far)
                    Err(_) => {
                        assert_eq!(policy, GapPolicy::Refuse);
                        assert!(refused.is_some(), "seed {seed} big {big}");
                    }
                }
            }
        }
    }

    /// A row delayed by REORDER_WINDOW rows is put back in order; by one more it is too old,
    /// reported at its line and left out, and the rest goes on.
    #[test]
    fn the_reorder_window_bound() {
        let base: Vec<i64> = (0..3000).map(|i| i * 5_000_000).collect();
        for (d, ok) in [(REORDER_WINDOW, true), (REORDER_WINDOW + 1, false)] {
            let mut s = base.clone();
            let v = s.remove(1000);
            s.insert(1000 + d, v);
            let (segs, late, _, t) = stream(&s, None, GapPolicy::Refuse).unwrap();
            let t = t.unwrap();
            if ok {
                assert!(late.is_empty());
                assert_eq!(segs[0].len(), 3000);
                assert_eq!(t.reordered, 1);
            } else {
                // the row at index 1000 + d is line 1001 + d
                assert_eq!(late, [1001 + d]);
                assert_eq!(segs[0].len(), 2999);
                assert_eq!((t.messages, t.reordered, t.gaps), (2999, 0, 1));
            }
        }
    }

    /// Refuse stops at the first gap that takes the missing share above 0.1 % of the samples
    /// so far (here 2 missing before the 1001st sample: 2 > 1.001), at the row after it, and
    /// releases nothing more; a gap as large later in the record passes (2 ≤ 0.001 × 3001).
    #[test]
    fn refuse_stops_at_the_first_gap_over_the_share_so_far() {
        let mut s: Vec<i64> = (0..5000).map(|i| i * 10_000_000).collect();
        s.drain(1000..1002);
        let (segs, _, refused, t) = stream(&s, None, GapPolicy::Refuse).unwrap();
        assert_eq!(refused, Some(1001));
        assert_eq!(segs[0].len(), 1000);
        let t = t.unwrap();
        assert_eq!((t.gaps, t.missing_samples, t.samples_used), (1, 2, 1000));
        let mut s: Vec<i64> = (0..5000).map(|i| i * 10_000_000).collect();
        s.drain(3000..3002);
        let (segs, _, refused, _) = stream(&s, None, GapPolicy::Refuse).unwrap();
        assert_eq!((refused, segs[0].len()), (None, 4998));
    }

    /// The rate is the median of the first RATE_DTS Δt: 200 Hz stamps, then 100 Hz ones;
    /// --rate within 1 % of it is used, beyond it is the batch's error; a stream that ends
    /// before RATE_DTS Δt takes the median of those it has; one stamp is too few.
    #[test]
    fn rate_from_the_first_dts() {
        let mut s: Vec<i64> = (0..=RATE_DTS as i64).map(|i| i * 5_000_000).collect();
        let last = *s.last().unwrap();
        s.extend((1..5000).map(|i| last + i * 10_000_000));
        let (_, _, _, t) = stream(&s, None, GapPolicy::Ignore).unwrap();
        let t = t.unwrap();
        assert_eq!((t.rate_hz, t.rate_source), (200.0, "stamps"));
        // every 100 Hz Δt is a gap at 200 Hz: 1 missing each
        assert_eq!((t.gaps, t.missing_samples), (4999, 4999));
        let (_, _, _, t) = stream(&s, Some(201.0), GapPolicy::Ignore).unwrap();
        assert_eq!(t.unwrap().rate_hz, 201.0);
        let e = stream(&s, Some(100.0), GapPolicy::Ignore)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("--rate 100 Hz disagrees") && e.contains("200.000000 Hz"),
            "{e}"
        );
        let (segs, _, _, t) = stream(&s[..10], None, GapPolicy::Refuse).unwrap();
        assert_eq!((segs[0].len(), t.unwrap().rate_hz), (10, 200.0));
        assert!(stream(&s[..1], None, GapPolicy::Refuse).is_err());
        assert!(stream(&[7, 7, 7], None, GapPolicy::Refuse).is_err());
    }
}
