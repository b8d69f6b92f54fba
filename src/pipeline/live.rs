//! Calibrate while recording: the Allan variance and N, K, B of text samples as they arrive.
//!
//! A [`Live`] is fed the bytes of a text stream (CSV, TSV or whitespace-separated, one or
//! more numeric columns, an optional header line; the rows `imunoise avar` reads) in pieces
//! of any size, as they come from a pipe or a growing file. Complete lines are parsed with the
//! same parser as `imunoise avar` ([`crate::io::parse_text`]), their values go into an
//! [`avar::OnlineChannels`] (memory O(largest cluster size), not O(samples)), and every
//! `every_s` seconds of input time a [`Snapshot`] is due: per channel the Allan variance of all
//! the samples so far (equal to `imunoise avar` on them, at the scales up to `tau_max_s`)
//! with CIs, and N, K, B with their CIs. Without a model they are read off the curve
//! ([`gmwm_prep::noise_terms`] without a model: the IEEE 952 read-off, N at τ = 1 s and K at
//! τ = 3 s, else an upper bound); with `model` (a template such as `WN + RW + AR1`) each
//! snapshot fits it to the curve so far (GMWM, the model covariance of the AV, the delta
//! method) and N, K, B come from the fitted model as in `imunoise analyze`.
//!
//! With `until` targets each snapshot says how far each channel is from each one and how much
//! longer to record: from the fitted model, the half-width predicted at longer records and the
//! length where it reaches the target, with an interval ([`crate::pipeline::precision`]);
//! without a model (or for a term the model does not have) a rough 1/√T rule.
//!
//! With [`LiveSettings::binary`] the stream is raw little-endian rows instead (as `imunoise avar
//! --binary` reads them), fed in pieces cut anywhere; rows count as lines below.
//!
//! With [`LiveSettings::time`] (text only) a column holds time stamps: the rate comes from the
//! median of the first 1024 Δt, rows are put back in time order within a reorder window of
//! 64 rows, duplicates are dropped, and gaps are refused, cut (the longest gap-free segment)
//! or ignored as `imunoise avar --gaps` says, as rows arrive ([`TimeStamps`] has the rules);
//! each snapshot carries the counts ([`Snapshot::timing`]).
//!
//! A malformed line is an [`Event::BadLine`] with its line number in the whole stream; with
//! [`OnError::Skip`] the line is left out and reading goes on, with [`OnError::Stop`] the
//! stream stops there ([`Live::stopped`]); what was accumulated before it is kept either way.
//!
//! ```
//! use imunoise::pipeline::live::{Event, Live, LiveSettings};
//! let settings = LiveSettings { rate_hz: 10.0, every_s: 50.0, ..LiveSettings::default() };
//! let mut live = Live::new(settings, "<stdin>")?;
//! // a header, then 1000 rows of a deterministic sequence, fed in two pieces cut mid-line
//! let mut text = String::from("gx,gy\n");
//! for i in 0..1000 {
//!     text += &format!("{},{}\n", (i * 37 % 11) as f64, (i * 7 % 5) as f64);
//! }
//! let (a, b) = text.as_bytes().split_at(3001);
//! let mut snaps = 0;
//! for e in live.feed(a)?.into_iter().chain(live.feed(b)?) {
//!     if let Event::Snapshot(_) = e { snaps += 1; }
//! }
//! assert_eq!(snaps, 2); // 50 s = 500 rows at 10 Hz
//! let last = live.finish()?;
//! assert_eq!(last.n, 1000);
//! assert_eq!(last.channels[1].name, "gy");
//! # Ok::<(), imunoise::Error>(())
//! ```

use crate::error::{Error, Result};
use crate::io::{BinaryType, ColumnSpec, parse_binary, parse_columns, parse_text, resolve_columns};
use crate::logs::timing::{GapPolicy, Release, StampStream, Timing};
use crate::pipeline::estimate::{PointJson, to_json};
use crate::pipeline::precision::{Predictor, Quantity, model_halfwidth};
use crate::pipeline::read::{TimeColumns, TimeUnit};
use avar::{AllanVariance, AvarConfig, CiMethod, OnlineChannels, Scales};
use gmwm_prep::AvCurve;
use gmwm_prep::gmwm::{GmwmFit, GmwmOptions};
use gmwm_prep::inference::{Inference, delta_method, fit_covariance};
use gmwm_prep::noise_terms::{NoiseTerm, NoiseTerms, noise_terms, noise_terms_of};
use processes::{Model, Unit};
use serde::Serialize;

/// What to do with a malformed line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum OnError {
    /// Report it, print the last snapshot and stop (exit code 2).
    #[default]
    Stop,
    /// Report it, leave the line out and go on.
    Skip,
}

/// How to read and when to report.
#[derive(Debug, Clone)]
pub struct LiveSettings {
    /// Sampling rate (Hz, > 0).
    pub rate_hz: f64,
    /// Columns to use (header names or 1-based indices and ranges, as `--columns`); all when None.
    pub columns: Option<String>,
    /// Units, as `--unit` (one for all or a comma list); else inferred from the names.
    pub unit: Option<String>,
    /// Cluster sizes (the batch estimator's grid), up to `tau_max_s`.
    pub scales: Scales,
    /// Chi-square interval or none (the Gaussian interval needs the whole series).
    pub ci: CiMethod,
    /// CI level: intervals cover 1 − alpha.
    pub alpha: f64,
    /// Largest averaging time τ tracked (s); the largest cluster size is ⌊τ·rate⌋ (at least 1).
    /// Memory: 32 bytes per sample of that cluster size and channel.
    pub tau_max_s: f64,
    /// Input time between snapshots (s, > 0).
    pub every_s: f64,
    /// What a malformed line does.
    pub on_error: OnError,
    /// Stop once every channel reaches each of these precisions (checked at each snapshot).
    pub until: Vec<Target>,
    /// A model template (e.g. `WN + RW + AR1`) fitted at each snapshot: N, K, B and the
    /// time-left estimates then come from the fitted model. None: the IEEE read-off.
    pub model: Option<String>,
    /// Keep every row (8 bytes per sample and channel) for [`Live::into_table`], e.g. to
    /// write the `analyze` report at the end.
    pub keep_rows: bool,
    /// Raw little-endian binary rows of this many values of this type (`--binary TYPE
    /// --channels K`, as `imunoise avar` reads them) instead of text; the channels are named
    /// ch1, ch2, … as there, and `columns` selects among them.
    pub binary: Option<(BinaryType, usize)>,
    /// Text rows with a time stamp column (`--time-column`): the rate, the order of the
    /// rows, duplicates and gaps then come from the stamps ([`TimeStamps`]), and
    /// `rate_hz` is not used. None: rows are equally spaced at `rate_hz`.
    pub time: Option<TimeStamps>,
}

/// Time stamps in a column of text rows (`imunoise live --time-column`), read with the
/// rules of `imunoise avar --time-column` ([`crate::logs::timing`]) applied as rows arrive
/// ([`StampStream`]):
///
/// - the rate is 1 / median of the first [`RATE_DTS`](crate::logs::timing::RATE_DTS) Δt
///   (or of fewer, when the input ends sooner); rows wait until it is known. A `rate_hz`
///   (`--rate`) more than 1 % away from it is an error, as in the batch.
/// - rows wait in a window of [`REORDER_WINDOW`](crate::logs::timing::REORDER_WINDOW) rows
///   and leave it in stamp order: a record whose rows arrive at most that many rows late gives
///   exactly the batch result. A row older than one already analysed is an
///   [`Event::BadLine`] at its line ([`OnError`] decides: skip it or stop).
/// - a row with the stamp of the row before it (in stamp order) is dropped and counted.
/// - gaps (Δt > 1.5 nominal Δt): [`GapPolicy::Refuse`] stops the stream ([`Event::Refused`])
///   as soon as the missing samples exceed 0.1 % of the samples so far;
///   [`GapPolicy::Longest`] starts a new accumulator after each gap and reports the longest
///   gap-free segment so far; [`GapPolicy::Ignore`] goes on across gaps.
///
/// Each [`Snapshot`] carries the counts as [`Snapshot::timing`].
///
/// ```
/// use imunoise::logs::GapPolicy;
/// use imunoise::pipeline::live::{Live, LiveSettings, TimeStamps};
/// use imunoise::pipeline::read::TimeUnit;
/// let time = TimeStamps { column: "t".into(), unit: TimeUnit::Ms, gaps: GapPolicy::Ignore, rate_hz: None };
/// let s = LiveSettings { time: Some(time), every_s: 1e9, ..LiveSettings::default() };
/// let mut live = Live::new(s, "imu.csv")?;
/// // 50 Hz stamps in ms; the 3rd and 4th rows swapped, the 6th row twice
/// let mut text = String::from("t,gx\n");
/// let mut order: Vec<i64> = (0..300).collect();
/// order.swap(2, 3);
/// order.insert(6, 5);
/// for i in order {
///     text += &format!("{},{}\n", 20 * i, (i * 7 % 5) as f64);
/// }
/// live.feed(text.as_bytes())?;
/// let last = live.finish()?;
/// assert_eq!((last.n, last.channels[0].rate_hz), (300, 50.0));
/// let t = last.timing.unwrap();
/// assert_eq!((t.messages, t.reordered, t.duplicates, t.gaps), (301, 1, 1, 0));
/// # Ok::<(), imunoise::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct TimeStamps {
    /// The stamp column: a header name or a 1-based index (as `--time-column`).
    pub column: String,
    /// Unit of the stamps (`--time-unit`).
    pub unit: TimeUnit,
    /// What gaps do (`--gaps`).
    pub gaps: GapPolicy,
    /// `--rate` (Hz), checked against the stamps' rate; None: the stamps' rate.
    pub rate_hz: Option<f64>,
}

/// A stopping rule: the 95 % (1 − alpha) interval of N, K or B (from the fitted model, or
/// read off the curve without one), or of a model parameter `CODE.name` (e.g. `RW.gamma2`,
/// `AR1.phi`: the first component of that kind in the model), has a relative half-width
/// (hi − lo) / (2·value) of at most `rel_halfwidth` on every channel.
///
/// ```
/// use imunoise::pipeline::live::Target;
/// let t: Target = "K=10%".parse()?;
/// assert_eq!((t.symbol.as_str(), t.rel_halfwidth), ("K", 0.1));
/// assert_eq!("n=0.05".parse::<Target>()?.symbol, "N");
/// assert_eq!("ar1.Phi=20%".parse::<Target>()?.symbol, "AR1.phi");
/// assert!("Q=10%".parse::<Target>().is_err());
/// assert!("AR1.rho=10%".parse::<Target>().is_err());
/// assert!("K=0%".parse::<Target>().is_err());
/// # Ok::<(), String>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Target {
    /// `N`, `K`, `B`, or a parameter `CODE.name` (code upper-case, name as the model has it).
    pub symbol: String,
    /// The largest relative half-width accepted (0.1 for 10 %).
    pub rel_halfwidth: f64,
}

impl std::str::FromStr for Target {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Target, String> {
        let bad = || {
            format!(
                "--until {s:?}: expected TERM=PRECISION with TERM N, K, B or a model parameter \
                 such as RW.gamma2 or AR1.phi, and PRECISION like 10% or 0.1"
            )
        };
        let (term, value) = s.split_once('=').ok_or_else(bad)?;
        let symbol = match term.trim().split_once('.') {
            None => term.trim().to_ascii_uppercase(),
            Some((code, name)) => {
                let code = code.trim().to_ascii_uppercase();
                let name = name.trim();
                let kind = param_kinds()
                    .into_iter()
                    .find(|k| k.code() == code)
                    .ok_or_else(bad)?;
                let name = kind
                    .param_names()
                    .iter()
                    .find(|n| n.eq_ignore_ascii_case(name))
                    .ok_or_else(bad)?;
                format!("{code}.{name}")
            }
        };
        if !(matches!(symbol.as_str(), "N" | "K" | "B") || symbol.contains('.')) {
            return Err(bad());
        }
        let v = value.trim();
        let x = match v.strip_suffix('%') {
            Some(p) => p.trim().parse::<f64>().map(|p| p / 100.0),
            None => v.parse::<f64>(),
        }
        .map_err(|_| bad())?;
        if !(x.is_finite() && x > 0.0) {
            return Err(bad());
        }
        Ok(Target {
            symbol,
            rel_halfwidth: x,
        })
    }
}

/// The kinds whose parameters a target may name (every kind the model strings know).
fn param_kinds() -> Vec<processes::ProcessKind> {
    use processes::ProcessKind as K;
    vec![
        K::WhiteNoise,
        K::QuantizationNoise,
        K::Drift,
        K::RandomWalk,
        K::Ar1,
        K::GaussMarkov,
        K::Ma1,
        K::Sinusoid,
    ]
}

/// Where a channel stands against a [`Target`].
#[derive(Debug, Clone, Serialize)]
pub struct TargetProgress {
    /// Channel name.
    pub channel: String,
    /// `N`, `K`, `B` or `CODE.name`.
    pub symbol: String,
    /// The precision asked for (relative half-width).
    pub target: f64,
    /// The current relative half-width of the term's interval (None while it has none: a
    /// read-off while the curve shows no region of the term's slope is only bounded; a model
    /// parameter before the first fit).
    pub rel_halfwidth: Option<f64>,
    /// Reached.
    pub reached: bool,
    /// Estimated input time still needed (s); None while not measurable. With a fitted model
    /// (`basis` "model"): the time where the half-width the model predicts reaches the target
    /// ([`crate::pipeline::precision`]); else (`basis` "sqrt_t") the half-width taken to
    /// shrink as 1/√T, T_needed ≈ T·(h/target)² (rough: the region read may move).
    pub time_left_s: Option<f64>,
    /// Lower bound of the 1 − alpha interval of `time_left_s` (s; model basis only).
    pub time_left_lo_s: Option<f64>,
    /// Upper bound (s; may be infinite: a parameter at a CI bound never reaches the target).
    pub time_left_hi_s: Option<f64>,
    /// How `time_left_s` was estimated: "model", "sqrt_t", or "" when it was not.
    pub basis: &'static str,
}

impl Default for LiveSettings {
    fn default() -> Self {
        LiveSettings {
            rate_hz: 1.0,
            columns: None,
            unit: None,
            scales: Scales::Dyadic,
            ci: CiMethod::ChiSquare,
            alpha: 0.05,
            tau_max_s: 1000.0,
            every_s: 10.0,
            on_error: OnError::Stop,
            until: Vec::new(),
            model: None,
            keep_rows: false,
            binary: None,
            time: None,
        }
    }
}

/// One channel of a [`Snapshot`].
#[derive(Debug, Serialize)]
pub struct ChannelSnapshot {
    /// Channel name (header, or col1, col2, … without one).
    pub name: String,
    /// Unit of the samples.
    pub unit: String,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Samples so far.
    pub n: usize,
    /// The Allan variance so far, as `imunoise avar --format json` gives it.
    pub points: Vec<PointJson>,
    /// N (white noise), read off at τ = 1 s, with its CI (None while the curve is too short).
    pub n_term: Option<NoiseTerm>,
    /// K (rate random walk), read off at τ = 3 s.
    pub k_term: Option<NoiseTerm>,
    /// B (bias instability), from the flat region's minimum.
    pub b_term: Option<NoiseTerm>,
    /// The model fitted to the curve so far (per-sample values), with `model` set and once
    /// the curve has more scales than the model parameters; None otherwise.
    pub model: Option<String>,
}

/// The state after some input: per channel the AV so far and N, K, B.
#[derive(Debug, Serialize)]
pub struct Snapshot {
    /// Input time so far: samples / rate (s); of the samples analysed (see `n`).
    pub t_s: f64,
    /// Samples (rows) so far; with time stamps the samples analysed: after removing
    /// duplicates, and with `--gaps longest` those of the longest gap-free segment so far.
    pub n: usize,
    /// True for the snapshot at the end of the input.
    #[serde(rename = "final")]
    pub is_final: bool,
    /// True when the `until` targets are all reached (the stream stops here).
    pub reached: bool,
    /// Each channel against each `until` target.
    pub progress: Vec<TargetProgress>,
    /// One entry per channel.
    pub channels: Vec<ChannelSnapshot>,
    /// With time stamps ([`LiveSettings::time`]): the rate from the stamps and the counts
    /// of reordered and duplicate rows, gaps and missing samples so far, and with
    /// `--gaps longest` the segment analysed (sample indices after ordering and
    /// de-duplication), as `results.json` writes them for `imunoise analyze`. `n` (and
    /// `timing.samples_used`) and the channels are then those of the samples analysed (the
    /// longest gap-free segment so far with `--gaps longest`); the other counts are as of
    /// the last row read (the rows held in the reorder window included). None (null)
    /// without time stamps.
    pub timing: Option<Timing>,
}

/// What feeding bytes brought.
#[derive(Debug)]
pub enum Event {
    /// A snapshot was due (every `every_s` seconds of input).
    Snapshot(Snapshot),
    /// A malformed line: the error names the file, the line in the whole stream and the column.
    /// With time stamps also a row older than one already analysed (it came more than the
    /// reorder window late).
    BadLine(Error),
    /// With time stamps and [`GapPolicy::Refuse`]: a gap brought the missing samples above
    /// 0.1 % of the samples so far; the error names the line after the gap and the counts.
    /// The stream stops there ([`Live::stopped`], [`Live::refused`]); what was accumulated
    /// before the gap is kept.
    Refused(Error),
}

/// The layout of the stream, known once its first line is in.
struct Layout {
    /// The header line (the file's, or col1,col2,… with the file's delimiter).
    header: Vec<u8>,
    names: Vec<String>,
    units: Vec<Unit>,
    /// The accumulators (of the current segment), once the rate is known.
    online: Option<OnlineChannels>,
}

/// Reading the stamps of a text stream.
struct Stamped {
    stream: StampStream,
    /// The stamp column(s) as asked for, and their indices among the parsed columns.
    cols: TimeColumns,
    idx: Vec<usize>,
    /// The columns are selected (`--columns`): the stamp column is read first.
    first: bool,
}

/// The online analysis of a text stream (see the [module](self) docs).
pub struct Live {
    settings: LiveSettings,
    /// The parsed model template, with its parameter targets' indices in θ.
    template: Option<Model>,
    quantities: Vec<Option<Quantity>>,
    select: Option<Vec<ColumnSpec>>,
    file: String,
    max_m: u64,
    layout: Option<Layout>,
    /// Bytes of an incomplete last line.
    pending: Vec<u8>,
    /// Lines consumed so far (complete lines, any kind).
    lines: usize,
    n: u64,
    every_n: u64,
    next_at: u64,
    stopped: Option<Error>,
    reached: bool,
    /// Every row so far, per channel (with `keep_rows`).
    rows: Vec<Vec<f64>>,
    /// Binary input: the channels `columns` selects (0-based), in their order.
    pick: Vec<usize>,
    /// Binary input: the partial row the stream ended inside, as [`Live::finish`] found it.
    partial_row: Option<Error>,
    /// The rate in force (Hz): `rate_hz`, or with time stamps once they tell it.
    rate: Option<f64>,
    /// Time stamps (text with [`LiveSettings::time`]).
    time: Option<Stamped>,
    /// With `--gaps longest`: the longest closed segment (its accumulators and kept rows).
    best: Option<(OnlineChannels, Vec<Vec<f64>>)>,
    /// Stopped by a gap under `--gaps refuse`.
    refused: bool,
}

impl Live {
    /// A new analysis; `file` names the stream in messages. Errors: a bad rate, α, τ_max,
    /// interval, `every_s` or `--columns` list.
    pub fn new(settings: LiveSettings, file: &str) -> Result<Live> {
        let given = match &settings.time {
            None => Some(settings.rate_hz),
            Some(t) => t.rate_hz,
        };
        if let Some(r) = given
            && !(r.is_finite() && r > 0.0)
        {
            return Err(Error::Usage(format!("--rate must be > 0, got {r}")));
        }
        if settings.time.is_some() && settings.binary.is_some() {
            return Err(Error::Usage("--time-column is for text input".to_string()));
        }
        // the rate-dependent parts are validated at the given rate (or 1 Hz) here, and made
        // at the rate in force once it is known
        let r = given.unwrap_or(1.0);
        if !(settings.every_s.is_finite() && settings.every_s > 0.0) {
            return Err(Error::Usage(format!(
                "--every must be > 0 seconds, got {}",
                settings.every_s
            )));
        }
        if !(settings.tau_max_s.is_finite() && settings.tau_max_s > 0.0) {
            return Err(Error::Usage(format!(
                "--tau-max must be > 0 seconds, got {}",
                settings.tau_max_s
            )));
        }
        if settings.ci == CiMethod::Gaussian {
            return Err(Error::Usage(
                "live: the Gaussian interval needs the whole series; use --ci chi2 or none".into(),
            ));
        }
        let template = settings
            .model
            .as_deref()
            .map(|m| Model::parse_at_rate(m, r).map(|m| m.template()))
            .transpose()?;
        let quantities = settings
            .until
            .iter()
            .map(|t| quantity_of(&t.symbol, template.as_ref()))
            .collect::<Result<Vec<_>>>()?;
        let max_m = ((settings.tau_max_s * r).floor() as u64).max(1);
        // validates the configuration (alpha, grid) once
        avar::Online::new(r, max_m, &config(&settings))?;
        let mut select = settings.columns.as_deref().map(parse_columns).transpose()?;
        let time = match &settings.time {
            None => None,
            Some(t) => {
                let cols = TimeColumns::parse(&t.column, t.unit)?;
                if let Some(sel) = select.as_mut() {
                    // read the stamp columns too, first (as `imunoise avar`)
                    sel.splice(0..0, cols.specs.iter().cloned());
                }
                Some(Stamped {
                    stream: StampStream::new(t.rate_hz, t.gaps, file),
                    cols,
                    idx: Vec::new(),
                    first: select.is_some(),
                })
            }
        };
        if let Some((_, k)) = settings.binary
            && k == 0
        {
            return Err(Error::Usage("--channels must be at least 1".to_string()));
        }
        let mut live = Live {
            template: None,
            quantities,
            select,
            file: file.to_string(),
            max_m,
            layout: None,
            pending: Vec::new(),
            lines: 0,
            n: 0,
            every_n: 1,
            next_at: 1,
            stopped: None,
            reached: false,
            rows: Vec::new(),
            pick: Vec::new(),
            partial_row: None,
            rate: None,
            best: None,
            refused: false,
            settings,
            time,
        };
        if live.time.is_none() {
            live.start(r)?;
        }
        Ok(live)
    }

    /// The rate in force is known (Hz): the largest cluster size, the snapshot interval,
    /// the model template and the accumulators follow from it.
    fn start(&mut self, r: f64) -> Result<()> {
        let s = &self.settings;
        self.rate = Some(r);
        self.max_m = ((s.tau_max_s * r).floor() as u64).max(1);
        self.every_n = ((s.every_s * r).round() as u64).max(1);
        self.next_at = self.n + self.every_n;
        self.template = s
            .model
            .as_deref()
            .map(|m| Model::parse_at_rate(m, r).map(|m| m.template()))
            .transpose()?;
        if let Some(layout) = &mut self.layout
            && layout.online.is_none()
        {
            layout.online = Some(OnlineChannels::new(
                layout.names.len(),
                r,
                self.max_m,
                &config(&self.settings),
            )?);
        }
        Ok(())
    }

    /// Stopped by a gap under [`GapPolicy::Refuse`] (the error is [`Live::stopped`]).
    pub fn refused(&self) -> bool {
        self.refused
    }

    /// Samples (rows) fed to the accumulators so far (with `--gaps longest`, of all the
    /// segments).
    pub fn len(&self) -> u64 {
        self.n
    }

    /// True before the first row.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The malformed line that stopped the stream ([`OnError::Stop`]), if any: later input
    /// is ignored.
    pub fn stopped(&self) -> Option<&Error> {
        self.stopped.as_ref()
    }

    /// Binary input: the partial last row [`Live::finish`] met (the stream ended inside a
    /// row), as an error locating it; with [`OnError::Stop`] it is also [`Live::stopped`].
    ///
    /// ```
    /// use imunoise::io::BinaryType;
    /// use imunoise::pipeline::live::{Live, LiveSettings};
    /// let s = LiveSettings {
    ///     rate_hz: 10.0,
    ///     binary: Some((BinaryType::I16, 2)),
    ///     ..LiveSettings::default()
    /// };
    /// let mut live = Live::new(s, "<stdin>")?;
    /// // 100 rows of two i16 counts (4 bytes each), then 3 bytes of a 101st row
    /// let mut bytes: Vec<u8> = (0..100i16).flat_map(|i| [i % 7, -(i % 5)])
    ///     .flat_map(|v| v.to_le_bytes()).collect();
    /// bytes.extend_from_slice(&[1, 2, 3]);
    /// let (a, b) = bytes.split_at(201); // cut inside row 51
    /// live.feed(a)?;
    /// live.feed(b)?;
    /// let last = live.finish()?;
    /// assert_eq!(last.n, 100);
    /// assert!(live.partial_row().unwrap().to_string().contains("inside row 101"));
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn partial_row(&self) -> Option<&Error> {
        self.partial_row.as_ref()
    }

    /// True once the `until` targets are reached: later input is ignored.
    pub fn reached(&self) -> bool {
        self.reached
    }

    /// Feeds the next bytes of the stream (cut anywhere, even inside a line or a UTF-8
    /// character). Returns the snapshots that fell due and the malformed lines met, in order.
    /// Errors (not line errors): an unknown `--columns` name, a bad `--unit` list.
    pub fn feed(&mut self, bytes: &[u8]) -> Result<Vec<Event>> {
        let mut events = Vec::new();
        if self.stopped.is_some() || self.reached {
            return Ok(events);
        }
        self.pending.extend_from_slice(bytes);
        if let Some((kind, k)) = self.settings.binary {
            // whole rows only; the bytes of a partial row wait for the next piece
            let whole = self.pending.len() / (kind.size() * k) * (kind.size() * k);
            let rest = self.pending.split_off(whole);
            let complete = std::mem::replace(&mut self.pending, rest);
            self.frames_in(&complete, kind, k, &mut events)?;
            return Ok(events);
        }
        let Some(last_nl) = self.pending.iter().rposition(|&b| b == b'\n') else {
            return Ok(events);
        };
        let rest = self.pending.split_off(last_nl + 1);
        let complete = std::mem::replace(&mut self.pending, rest);
        self.lines_in(&complete, &mut events)?;
        Ok(events)
    }

    /// Feeds samples that are already numbers, one slice per channel (equal lengths), after
    /// the channels are known from a header line fed with [`Live::feed`]: the same
    /// accumulation, snapshots and targets as rows of text, without formatting and parsing
    /// them (e.g. for simulations). Errors: no header yet, a wrong number of channels or
    /// unequal lengths, a non-finite sample.
    ///
    /// ```
    /// use imunoise::pipeline::live::{Live, LiveSettings};
    /// let s = LiveSettings { rate_hz: 10.0, every_s: 1e9, ..LiveSettings::default() };
    /// let (mut a, mut b) = (Live::new(s.clone(), "a")?, Live::new(s, "b")?);
    /// let x: Vec<f64> = (0..400).map(|i| ((i * 37 % 11) as f64).sin()).collect();
    /// a.feed(b"gx\n")?;
    /// a.feed_values(&[&x])?;
    /// let text: String = x.iter().map(|v| format!("{v:?}\n")).collect();
    /// b.feed(format!("gx\n{text}").as_bytes())?;
    /// let (sa, sb) = (a.finish()?, b.finish()?);
    /// for (p, q) in sa.channels[0].points.iter().zip(&sb.channels[0].points) {
    ///     assert!((p.avar - q.avar).abs() <= 1e-12 * q.avar); // the same sums
    /// }
    /// assert!(Live::new(LiveSettings::default(), "c")?.feed_values(&[&x]).is_err());
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn feed_values(&mut self, channels: &[&[f64]]) -> Result<Vec<Event>> {
        let mut events = Vec::new();
        if self.time.is_some() {
            return Err(Error::Usage(
                "live: with time stamps, feed text rows (values have no stamps)".into(),
            ));
        }
        let Some(layout) = &self.layout else {
            return Err(Error::Usage(
                "live: feed a header line before the values".into(),
            ));
        };
        let len = channels.first().map_or(0, |c| c.len());
        if channels.len() != layout.names.len() || channels.iter().any(|c| c.len() != len) {
            return Err(Error::Usage(format!(
                "live: {} channels of equal length expected, got lengths {:?}",
                layout.names.len(),
                channels.iter().map(|c| c.len()).collect::<Vec<_>>()
            )));
        }
        if self.stopped.is_some() || self.reached {
            return Ok(events);
        }
        let cols: Vec<Vec<f64>> = channels.iter().map(|c| c.to_vec()).collect();
        self.push_rows(&cols, &mut events)?;
        Ok(events)
    }

    /// The end of the stream: parses an unterminated last line and returns the final snapshot.
    /// Errors: no data row at all, too few rows for one scale.
    pub fn finish(&mut self) -> Result<Snapshot> {
        if let Some((kind, k)) = self.settings.binary {
            if self.stopped.is_none() && !self.reached && !self.pending.is_empty() {
                // a partial last row: reported as a malformed row (nothing dropped silently)
                let e = Error::Located {
                    file: self.file.clone(),
                    line: self.lines + 1,
                    column: 0,
                    message: format!(
                        "the input ends inside row {}: {} of its {} × {} bytes \
                         (wrong --binary type or --channels?)",
                        self.lines + 1,
                        self.pending.len(),
                        k,
                        kind.size()
                    ),
                };
                self.pending.clear();
                let mut events = Vec::new();
                self.bad_line(e, &mut events);
                if let Some(Event::BadLine(e)) = events.pop() {
                    self.partial_row = Some(e);
                }
            }
            return self.snapshot(true);
        }
        let mut events = Vec::new();
        if self.stopped.is_none() && !self.reached && !self.pending.is_empty() {
            let mut last = std::mem::take(&mut self.pending);
            last.push(b'\n');
            self.lines_in(&last, &mut events)?;
        }
        // the rows still held for their stamps' order (before a malformed line too)
        if let Some(t) = self.time.as_mut()
            && !self.reached
            && !self.refused
            && self.layout.is_some()
        {
            let mut rel = Vec::new();
            t.stream.finish(&mut rel)?;
            let k = self.layout.as_ref().map_or(0, |l| l.names.len());
            let mut batch = vec![Vec::new(); k];
            self.apply(&mut rel, &mut batch, &mut events)?;
            self.flush(&mut batch, &mut events)?;
        }
        self.snapshot(true)
    }

    /// The finishing line errors of [`Live::feed`] for complete lines in `text`.
    fn lines_in(&mut self, text: &[u8], events: &mut Vec<Event>) -> Result<()> {
        let mut at = 0;
        // the layout from the first line that is not blank or a comment
        while self.layout.is_none() && at < text.len() {
            let end = text[at..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(text.len(), |i| at + i + 1);
            let line = &text[at..end];
            let body = strip_eol(
                if self.lines == 0 && line.starts_with(&[0xEF, 0xBB, 0xBF]) {
                    &line[3..]
                } else {
                    line
                },
            );
            let trimmed = body.iter().skip_while(|b| b.is_ascii_whitespace()).count();
            if trimmed == 0 || body.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'#') {
                self.lines += 1;
                at = end;
                continue;
            }
            match parse_text(body, &self.file, self.select.as_deref()) {
                Ok(_) => {
                    // no header: name the columns as `imunoise avar` does
                    let (delim, ncols) = if body.contains(&b',') {
                        (",", body.iter().filter(|&&b| b == b',').count() + 1)
                    } else if body.contains(&b'\t') {
                        ("\t", body.iter().filter(|&&b| b == b'\t').count() + 1)
                    } else {
                        (
                            " ",
                            String::from_utf8_lossy(body).split_whitespace().count(),
                        )
                    };
                    let header = (1..=ncols)
                        .map(|c| format!("col{c}"))
                        .collect::<Vec<_>>()
                        .join(delim);
                    self.set_layout(header.into_bytes())?;
                    // the line itself is data: parsed below with the rest
                }
                Err(Error::File { .. }) => {
                    // no number in it: the header
                    self.set_layout(body.to_vec())?;
                    self.lines += 1;
                    at = end;
                }
                Err(e @ Error::Located { .. }) => {
                    // the line is line 1 of what was parsed
                    let e = self.relocate(e, self.lines + 1);
                    self.bad_line(e, events);
                    self.lines += 1;
                    at = end;
                    if self.stopped.is_some() {
                        return Ok(());
                    }
                }
                // e.g. a --columns name without a header
                Err(e) => return Err(e),
            }
        }
        if at < text.len() {
            self.rows_in(&text[at..], events)?;
        }
        Ok(())
    }

    /// Whole binary rows of `k` values of `kind` (`lines` counts rows here). A row holding a
    /// value that is not finite is a malformed row, reported with its number in the stream.
    fn frames_in(
        &mut self,
        mut bytes: &[u8],
        kind: BinaryType,
        k: usize,
        events: &mut Vec<Event>,
    ) -> Result<()> {
        if self.layout.is_none() {
            let names: Vec<String> = (1..=k).map(|c| format!("ch{c}")).collect();
            self.pick = match &self.select {
                Some(spec) => resolve_columns(spec, &names)?,
                None => (0..k).collect(),
            };
            let names: Vec<String> = self.pick.iter().map(|&i| names[i].clone()).collect();
            self.layout = Some(self.layout_of(Vec::new(), names)?);
        }
        let row = kind.size() * k;
        while !bytes.is_empty() {
            let (good, bad) = match parse_binary(bytes, &self.file, kind, k) {
                Ok(_) => (bytes.len() / row, None),
                Err(Error::Located { line, column, .. }) => (line - 1, Some(column)),
                Err(e) => return Err(e),
            };
            if good > 0 {
                let t = parse_binary(&bytes[..good * row], &self.file, kind, k)?;
                let mut cols: Vec<Option<Vec<f64>>> =
                    t.columns.into_iter().map(|c| Some(c.into_vec())).collect();
                let picked: Vec<Vec<f64>> = self
                    .pick
                    .iter()
                    .map(|&i| cols[i].take().unwrap_or_default())
                    .collect();
                self.push_rows(&picked, events)?;
                self.lines += good;
                if self.reached {
                    return Ok(());
                }
            }
            let Some(column) = bad else {
                return Ok(());
            };
            let at = self.lines as u64 * row as u64 + ((column - 1) * kind.size()) as u64;
            let e = Error::Located {
                file: self.file.clone(),
                line: self.lines + 1,
                column,
                message: format!(
                    "a value that is not finite in row {} channel {column} (byte offset {at}): \
                     values must be finite",
                    self.lines + 1
                ),
            };
            self.lines += 1;
            self.bad_line(e, events);
            if self.stopped.is_some() {
                return Ok(());
            }
            bytes = &bytes[(good + 1) * row..];
        }
        Ok(())
    }

    /// The layout of the channels `names` (their units, one online accumulator each).
    fn layout_of(&self, header: Vec<u8>, names: Vec<String>) -> Result<Layout> {
        let units = crate::units::channel_units(&names, self.settings.unit.as_deref())?;
        let online = self
            .rate
            .map(|r| OnlineChannels::new(names.len(), r, self.max_m, &config(&self.settings)))
            .transpose()?;
        Ok(Layout {
            header,
            names,
            units,
            online,
        })
    }

    fn set_layout(&mut self, header: Vec<u8>) -> Result<()> {
        // the names after --columns, from the header and one dummy row
        let probe_row = {
            let t = String::from_utf8_lossy(&header).into_owned();
            let delim = if t.contains(',') {
                ','
            } else if t.contains('\t') {
                '\t'
            } else {
                ' '
            };
            let n = if delim == ' ' {
                t.split_whitespace().count()
            } else {
                t.split(delim).count()
            };
            vec!["0"; n].join(&delim.to_string())
        };
        let mut probe = header.clone();
        probe.push(b'\n');
        probe.extend_from_slice(probe_row.as_bytes());
        let t = parse_text(&probe, &self.file, self.select.as_deref())?;
        let mut names = t.names;
        if let Some(time) = self.time.as_mut() {
            time.idx = if time.first {
                (0..time.cols.specs.len()).collect()
            } else {
                resolve_columns(&time.cols.specs, &names)?
            };
            if time.idx.len() == 2 && time.idx[0] == time.idx[1] {
                return Err(Error::Usage(format!(
                    "--time-column: the seconds and nanoseconds columns are the same ({})",
                    names[time.idx[0]]
                )));
            }
            let tname = TimeColumns::take(&time.idx, &mut names).join("+");
            if names.is_empty() {
                return Err(Error::Usage(format!(
                    "--time-column {tname:?} is the only column; nothing left to analyse"
                )));
            }
        }
        self.layout = Some(self.layout_of(header, names)?);
        Ok(())
    }

    /// A parse error of a batch whose line 1 stands for line `first` (from 1) of the stream,
    /// with the line number made that of the whole stream.
    fn relocate(&self, e: Error, first: usize) -> Error {
        match e {
            Error::Located {
                line,
                column,
                message,
                ..
            } => Error::Located {
                file: self.file.clone(),
                line: first + line.saturating_sub(1),
                column,
                message,
            },
            other => other,
        }
    }

    fn bad_line(&mut self, e: Error, events: &mut Vec<Event>) {
        if self.settings.on_error == OnError::Stop {
            self.stopped = Some(clone_error(&e));
        }
        events.push(Event::BadLine(e));
    }

    /// Complete data lines (after the layout is known).
    fn rows_in(&mut self, mut text: &[u8], events: &mut Vec<Event>) -> Result<()> {
        let header = self.layout.as_ref().expect("layout known").header.clone();
        let batch_of = |lines: &[u8]| {
            let mut b = header.clone();
            b.push(b'\n');
            b.extend_from_slice(lines);
            b
        };
        while !text.is_empty() {
            let e = match parse_text(&batch_of(text), &self.file, self.select.as_deref()) {
                Ok(t) => {
                    let cols: Vec<Vec<f64>> = t.columns.into_iter().map(|c| c.into_vec()).collect();
                    // rows after a reached target are left unread
                    self.push_parsed(cols, self.lines + 1, events)?;
                    self.lines += count_lines(text);
                    return Ok(());
                }
                Err(Error::File { .. }) => {
                    // only blank lines
                    self.lines += count_lines(text);
                    return Ok(());
                }
                Err(e) => e,
            };
            let bad = match &e {
                // 0-based line of `text` (line 1 of the batch is the header)
                Error::Located { line, .. } if *line >= 2 => line - 2,
                _ => return Err(e),
            };
            let (good, rest) = split_lines(text, bad);
            if !good.is_empty() {
                let t = parse_text(&batch_of(good), &self.file, self.select.as_deref())?;
                let cols: Vec<Vec<f64>> = t.columns.into_iter().map(|c| c.into_vec()).collect();
                self.push_parsed(cols, self.lines + 1, events)?;
                if self.reached || self.stopped.is_some() {
                    return Ok(());
                }
            }
            // the batch's line 2 is stream line self.lines + 1
            let e = self.relocate(e, self.lines);
            self.lines += bad + 1;
            self.bad_line(e, events);
            if self.stopped.is_some() {
                return Ok(());
            }
            // skip the bad line
            text = match rest.iter().position(|&b| b == b'\n') {
                Some(i) => &rest[i + 1..],
                None => &[],
            };
        }
        Ok(())
    }

    /// Parsed rows whose first is line `first_line` of the stream: with time stamps through
    /// the [`StampStream`] (one row at a time, so that what a stop or a reached target
    /// leaves unread is unread), else straight to the accumulators.
    fn push_parsed(
        &mut self,
        mut cols: Vec<Vec<f64>>,
        first_line: usize,
        events: &mut Vec<Event>,
    ) -> Result<()> {
        let Some(t) = &self.time else {
            return self.push_rows(&cols, events);
        };
        let time = TimeColumns::take(&t.idx, &mut cols);
        let rows = time.first().map_or(0, Vec::len);
        let mut rel = Vec::new();
        let mut batch: Vec<Vec<f64>> = vec![Vec::with_capacity(rows); cols.len()];
        let mut v = vec![0.0; time.len()];
        for i in 0..rows {
            for (vk, c) in v.iter_mut().zip(&time) {
                *vk = c[i];
            }
            let values = cols.iter().map(|c| c[i]).collect();
            let t = self.time.as_mut().expect("time stamps");
            let stamp = t.cols.stamp_ns(&v);
            t.stream.push(stamp, first_line + i, values, &mut rel)?;
            self.apply(&mut rel, &mut batch, events)?;
            if self.stopped.is_some() || self.reached {
                return Ok(());
            }
        }
        self.flush(&mut batch, events)
    }

    /// What the [`StampStream`] released: the rate, samples (gathered in `batch`, which is
    /// handed to the accumulators when a snapshot falls due, before any other release, and
    /// by the caller at the end), a new segment, a late row or a refusal.
    fn apply(
        &mut self,
        rel: &mut Vec<Release>,
        batch: &mut [Vec<f64>],
        events: &mut Vec<Event>,
    ) -> Result<()> {
        for r in rel.drain(..) {
            match r {
                Release::Rate(r) => self.start(r)?,
                Release::Sample { values, .. } => {
                    for (b, v) in batch.iter_mut().zip(values) {
                        b.push(v);
                    }
                    // a snapshot sees the counts of the row that completes it
                    if batch.first().map_or(0, Vec::len) as u64 >= self.next_at - self.n {
                        self.flush(batch, events)?;
                    }
                }
                Release::NewSegment => {
                    self.flush(batch, events)?;
                    self.new_segment()?;
                }
                Release::TooOld(e) => {
                    self.flush(batch, events)?;
                    self.bad_line(e, events);
                }
                Release::Refused(e) => {
                    self.flush(batch, events)?;
                    self.refused = true;
                    if self.stopped.is_none() {
                        self.stopped = Some(clone_error(&e));
                    }
                    events.push(Event::Refused(e));
                }
            }
        }
        Ok(())
    }

    /// The samples gathered by [`Live::apply`] to the accumulators (none after a reached
    /// target).
    fn flush(&mut self, batch: &mut [Vec<f64>], events: &mut Vec<Event>) -> Result<()> {
        if batch.first().is_some_and(|b| !b.is_empty()) && !self.reached {
            self.push_rows(batch, events)?;
        }
        batch.iter_mut().for_each(Vec::clear);
        Ok(())
    }

    /// `--gaps longest`: a gap ends the current segment; the longest one is kept (the
    /// earlier of two of equal length, as the batch) and a new one starts.
    fn new_segment(&mut self) -> Result<()> {
        let r = self.rate.expect("rate known");
        let layout = self.layout.as_mut().expect("layout known");
        let fresh =
            OnlineChannels::new(layout.names.len(), r, self.max_m, &config(&self.settings))?;
        let cur = std::mem::replace(layout.online.as_mut().expect("rate known"), fresh);
        let rows = std::mem::take(&mut self.rows);
        let len = |o: &OnlineChannels| o.channels().first().map_or(0, |c| c.len());
        if self.best.as_ref().is_none_or(|(b, _)| len(&cur) > len(b)) {
            self.best = Some((cur, rows));
        }
        Ok(())
    }

    /// The accumulators analysed: the current segment's, or the longest closed segment's
    /// when it is longer (`--gaps longest`); with its rows. None before the rate is known.
    fn analysed(&self) -> Option<(&OnlineChannels, &Vec<Vec<f64>>)> {
        let cur = self.layout.as_ref()?.online.as_ref()?;
        let len = |o: &OnlineChannels| o.channels().first().map_or(0, |c| c.len());
        match &self.best {
            Some((b, rows)) if len(b) > len(cur) => Some((b, rows)),
            _ => Some((cur, &self.rows)),
        }
    }

    /// Adds rows (one vector per channel), cut at the snapshots that fall due.
    fn push_rows(&mut self, cols: &[Vec<f64>], events: &mut Vec<Event>) -> Result<()> {
        let rows = cols.first().map_or(0, Vec::len);
        let mut i = 0;
        while i < rows {
            let take = ((self.next_at - self.n) as usize).min(rows - i);
            let chunks: Vec<&[f64]> = cols.iter().map(|c| &c[i..i + take]).collect();
            if self.settings.keep_rows {
                self.rows.resize_with(chunks.len(), Vec::new);
                for (all, c) in self.rows.iter_mut().zip(&chunks) {
                    all.extend_from_slice(c);
                }
            }
            self.layout
                .as_mut()
                .expect("layout known")
                .online
                .as_mut()
                .expect("rate known")
                .update(&chunks)?;
            self.n += take as u64;
            i += take;
            if self.n == self.next_at {
                self.next_at += self.every_n;
                // too short for one scale yet: no snapshot
                if let Ok(s) = self.snapshot(false) {
                    self.reached = s.reached;
                    events.push(Event::Snapshot(s));
                    if self.reached {
                        return Ok(());
                    }
                }
            }
        }
        Ok(())
    }

    /// Every row accumulated (with `keep_rows`) as the [`crate::io::Table`] the `analyze`
    /// pipeline takes, with the channels' units; None without `keep_rows` or before the first
    /// row.
    ///
    /// ```
    /// use imunoise::pipeline::live::{Live, LiveSettings};
    /// let s = LiveSettings { rate_hz: 50.0, keep_rows: true, ..LiveSettings::default() };
    /// let mut live = Live::new(s, "x.csv")?;
    /// live.feed(b"gyro_x_dps\n0.5\n-0.25\n1\n")?;
    /// let (table, units) = live.into_table().unwrap();
    /// assert_eq!((table.names[0].as_str(), table.rate_hz), ("gyro_x_dps", Some(50.0)));
    /// assert_eq!(&table.columns[0][..], &[0.5, -0.25, 1.0]);
    /// assert_eq!(units, [imunoise::processes::Unit::DegPerSec]);
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn into_table(self) -> Option<(crate::io::Table, Vec<Unit>)> {
        let timing = self.time.as_ref().and_then(|t| t.stream.timing());
        let len = |o: &OnlineChannels| o.channels().first().map_or(0, |c| c.len());
        let rows = match (self.best, self.layout.as_ref()?.online.as_ref()) {
            (Some((b, rows)), Some(cur)) if len(&b) > len(cur) => rows,
            _ => self.rows,
        };
        let layout = self.layout?;
        if rows.is_empty() {
            return None;
        }
        let table = crate::io::Table {
            file: self.file,
            names: layout.names,
            columns: rows.into_iter().map(crate::io::Column::from).collect(),
            rate_hz: self.rate,
            timing,
            topic: None,
        };
        Some((table, layout.units))
    }

    /// The snapshot of everything so far (`is_final` marks the one at the end).
    /// Errors: no row yet, too few rows for one scale.
    pub fn snapshot(&self, is_final: bool) -> Result<Snapshot> {
        let no_rows = || Error::File {
            file: self.file.clone(),
            message: "no data rows".into(),
        };
        let (Some(layout), Some((online, _)), Some(rate)) =
            (&self.layout, self.analysed(), self.rate)
        else {
            return Err(no_rows());
        };
        let n = online.channels().first().map_or(0, |c| c.len());
        if n == 0 {
            return Err(no_rows());
        }
        let avs = online.snapshots()?;
        let curves: Vec<(String, AllanVariance)> = layout.names.iter().cloned().zip(avs).collect();
        let json = to_json(&curves);
        let t_s = n as f64 / rate;
        let mut channels = Vec::new();
        let mut progress = Vec::new();
        for ((c, (_, av)), unit) in json.channels.into_iter().zip(&curves).zip(&layout.units) {
            let curve = AvCurve::from_avar(av).ok();
            let fitted = match (&self.template, &curve) {
                (Some(t), Some(curve)) => fit_model(curve, t, self.settings.alpha, unit),
                _ => None,
            };
            let terms = match (&fitted, &curve) {
                (Some(f), _) => Some(f.terms.clone()),
                (None, Some(curve)) => {
                    noise_terms_of(&[], &[], av.rate_hz, av.points[0].tau, None, curve, unit).ok()
                }
                _ => None,
            };
            let snap = ChannelSnapshot {
                name: c.name,
                unit: unit.to_string(),
                rate_hz: c.rate_hz,
                n: c.n,
                points: c.points,
                n_term: terms.as_ref().map(|t| t.n.clone()),
                k_term: terms.as_ref().map(|t| t.k.clone()),
                b_term: terms.map(|t| t.b),
                model: fitted.as_ref().map(|f| f.fit.model.to_string()),
            };
            for (target, q) in self.settings.until.iter().zip(&self.quantities) {
                let predictor = match (&fitted, &curve) {
                    (Some(f), Some(curve)) => Some(Predictor {
                        fit: &f.fit,
                        inference: &f.inference,
                        curve,
                        unit,
                        scales: &self.settings.scales,
                        max_m: self.max_m,
                    }),
                    _ => None,
                };
                progress.push(progress_of(&snap, target, *q, predictor.as_ref(), t_s));
            }
            channels.push(snap);
        }
        let reached = !progress.is_empty() && progress.iter().all(|p| p.reached);
        Ok(Snapshot {
            t_s,
            n: n as usize,
            is_final,
            reached,
            progress,
            channels,
            // the counts as of the last row read; the samples those analysed here (when the
            // rate becomes known, the first 1025 samples are released at once)
            timing: self
                .time
                .as_ref()
                .and_then(|t| t.stream.timing())
                .map(|mut t| {
                    t.samples_used = n as usize;
                    t
                }),
        })
    }
}

/// A model fitted at a snapshot.
struct Fitted {
    fit: GmwmFit,
    inference: Inference,
    terms: NoiseTerms,
}

/// The GMWM fit of `template` to `curve` with its delta-method inference (the model
/// covariance of the AV at θ̂) and N, K, B; None when it fails (too few scales for the
/// parameters, a singular fit): the snapshot then reads N, K, B off the curve.
fn fit_model(curve: &AvCurve, template: &Model, alpha: f64, unit: &Unit) -> Option<Fitted> {
    if curve.len() <= template.n_params() {
        return None;
    }
    let fit = gmwm_prep::gmwm::fit(curve, template, &GmwmOptions::default()).ok()?;
    let inference = delta_method(&fit, &fit_covariance(&fit).ok()?, alpha).ok()?;
    let terms = noise_terms(&fit, Some(&inference), curve, unit).ok()?;
    Some(Fitted {
        fit,
        inference,
        terms,
    })
}

/// What a target's symbol measures: N, K, B, or the index in θ of the parameter `CODE.name`
/// of the first component of that kind in `template` (errors: a parameter without a model,
/// or of a kind the model lacks).
fn quantity_of(symbol: &str, template: Option<&Model>) -> Result<Option<Quantity>> {
    Ok(match symbol {
        "N" => Some(Quantity::N),
        "K" => Some(Quantity::K),
        "B" => Some(Quantity::B),
        s => {
            let (code, name) = s.split_once('.').unwrap_or((s, ""));
            let Some(t) = template else {
                return Err(Error::Usage(format!(
                    "--until {s}: a model parameter needs --model"
                )));
            };
            let mut at = 0;
            let mut found = None;
            for k in t.kinds() {
                if found.is_none() && k.code() == code {
                    found = k
                        .param_names()
                        .iter()
                        .position(|n| *n == name)
                        .map(|i| at + i);
                }
                at += k.n_params();
            }
            match found {
                Some(i) => Some(Quantity::Param(i)),
                None => {
                    return Err(Error::Usage(format!(
                        "--until {s}: the model {t} has no {code} component with a parameter {name}"
                    )));
                }
            }
        }
    })
}

/// Channel `c` against `target` (measuring `q`) at input time `t_s`, with the fitted model's
/// predictor when there is one.
fn progress_of(
    c: &ChannelSnapshot,
    target: &Target,
    q: Option<Quantity>,
    predictor: Option<&Predictor<'_>>,
    t_s: f64,
) -> TargetProgress {
    let term = match q {
        Some(Quantity::N) => c.n_term.as_ref(),
        Some(Quantity::K) => c.k_term.as_ref(),
        Some(Quantity::B) => c.b_term.as_ref(),
        _ => None,
    };
    // the current half-width: the model's CI when the term comes from the model (or a
    // parameter's), else the read-off's CI
    let h = match (q, predictor) {
        (Some(Quantity::Param(_)), Some(p)) => q.and_then(|q| p.current(q)),
        (Some(Quantity::Param(_)), None) => None,
        _ => term.and_then(|t| {
            model_halfwidth(t).or(match (t.source, t.ci_lo, t.ci_hi) {
                (gmwm_prep::noise_terms::TermSource::ReadOff, Some(lo), Some(hi))
                    if t.value > 0.0 =>
                {
                    Some((hi - lo) / (2.0 * t.value))
                }
                _ => None,
            })
        }),
    };
    let reached = h.is_some_and(|h| h <= target.rel_halfwidth);
    let by_model = match (q, predictor) {
        (Some(q), Some(p))
            if matches!(q, Quantity::Param(_)) || term.and_then(model_halfwidth).is_some() =>
        {
            p.needed(q, target.rel_halfwidth)
        }
        _ => None,
    };
    let rate = c.rate_hz;
    let (time_left_s, lo, hi, basis) = match (by_model, h) {
        (Some(need), _) => (
            Some((need.n / rate - t_s).max(0.0)),
            Some((need.lo / rate - t_s).max(0.0)),
            Some((need.hi / rate - t_s).max(0.0)),
            "model",
        ),
        (None, Some(h)) => {
            let r = h / target.rel_halfwidth;
            (Some((t_s * (r * r - 1.0)).max(0.0)), None, None, "sqrt_t")
        }
        (None, None) => (None, None, None, ""),
    };
    TargetProgress {
        channel: c.name.clone(),
        symbol: target.symbol.clone(),
        target: target.rel_halfwidth,
        rel_halfwidth: h,
        reached,
        time_left_s,
        time_left_lo_s: lo,
        time_left_hi_s: hi,
        basis,
    }
}

fn config(s: &LiveSettings) -> AvarConfig {
    AvarConfig {
        scales: s.scales.clone(),
        ci: s.ci,
        alpha: s.alpha,
        ..AvarConfig::default()
    }
}

fn strip_eol(line: &[u8]) -> &[u8] {
    let mut l = line;
    while let [rest @ .., b'\n' | b'\r'] = l {
        l = rest;
    }
    l
}

fn count_lines(text: &[u8]) -> usize {
    text.iter().filter(|&&b| b == b'\n').count()
}

/// (the first `k` lines, the rest) of `text`.
fn split_lines(text: &[u8], k: usize) -> (&[u8], &[u8]) {
    let mut at = 0;
    for _ in 0..k {
        match text[at..].iter().position(|&b| b == b'\n') {
            Some(i) => at += i + 1,
            None => return (text, &[]),
        }
    }
    text.split_at(at)
}

/// A copy of a line error (the only kind kept by [`Live::stopped`]).
pub(crate) fn clone_error(e: &Error) -> Error {
    match e {
        Error::Located {
            file,
            line,
            column,
            message,
        } => Error::Located {
            file: file.clone(),
            line: *line,
            column: *column,
            message: message.clone(),
        },
        other => Error::Usage(other.to_string()),
    }
}

/// The AD at the τ of the snapshot nearest each of `taus` (s, on a log scale), as
/// (τ, AD, AD lower, AD upper) with the CI bounds when there are some.
pub fn adev_near(points: &[PointJson], taus: &[f64]) -> Vec<(f64, f64, Option<f64>, Option<f64>)> {
    let mut out: Vec<(f64, f64, Option<f64>, Option<f64>)> = Vec::new();
    for &t in taus {
        let Some(p) = points
            .iter()
            .min_by(|a, b| (a.tau / t).ln().abs().total_cmp(&(b.tau / t).ln().abs()))
        else {
            continue;
        };
        if out.last().is_some_and(|q| q.0 == p.tau) {
            continue;
        }
        out.push((
            p.tau,
            p.adev,
            p.avar_lo.map(|v| v.max(0.0).sqrt()),
            p.avar_hi.map(f64::sqrt),
        ));
    }
    out
}
