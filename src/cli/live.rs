//! `imunoise live`: the Allan deviation and N, K, B of samples as they are recorded.

use super::{Ui, parse_rate, parse_scales};
use crate::error::{Error, Result};
use crate::logs::GapPolicy;
use crate::pipeline::live::TimeStamps;
pub use crate::pipeline::live::{Event, Live, LiveSettings, OnError, Snapshot, Target, adev_near};
use crate::pipeline::read::TimeUnit;
use avar::{CiMethod, Scales};
use std::io::{Read, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Examples shown by `imunoise live --help`.
pub const EXAMPLES: &str = "Examples:
  ros2 topic echo /imu/data_raw sensor_msgs/msg/Imu --csv | imunoise live - --time-column 1+2 --columns 17-19 --unit rad/s
  imunoise live /dev/ttyUSB0 --rate 100 --every 30
  imunoise live imu.csv --follow --rate 400 --json > progress.jsonl
  my_logger | imunoise live - --binary f32 --channels 6 --rate 1000 --columns 1-3 --unit deg/s
  imunoise live - --rate 100 --model \"WN + RW + AR1\" --until K=10%
  imunoise live imu.csv --follow --time-column t --time-unit ns --gaps longest

Every --every seconds of input time a snapshot: on a terminal a view redrawn in place (at
most every --refresh s), else one JSON line (--json forces it, --lines gives one text line
per channel): the Allan deviation at a few tau with its CI, and N, K and B with their CIs,
from the fitted --model, or read off the curve without one (N at tau = 1 s, K at tau = 3 s,
B the flat minimum, or an upper bound while the curve shows no such region). With --until,
the precision reached and the time left (from the fitted model, with a 95 % interval).
At the end of the input (or at Ctrl-C) the final snapshot (marked final) is printed; it equals
`imunoise avar` on the same rows at the scales up to --tau-max. A malformed line is reported
with its line number; --on-error skip leaves it out and goes on, stop (default) prints the
final snapshot of the rows before it and exits with code 2.

Time stamps (--time-column, text only) follow the rules of `imunoise avar --time-column`,
applied as rows arrive: the rate is 1 / median of the first 1024 time differences (of fewer
if the input ends sooner; rows wait until then), and a --rate more than 1 % away from it is
an error. Rows wait in a reorder window of 64 rows and leave it in time order, so a record
whose rows arrive at most 64 rows late gives exactly the `avar` result; a row older than one
already analysed is reported with its line number and --on-error skips it or stops. A row
with the stamp of the row before it is a duplicate: dropped and counted. A gap is a time
difference over 1.5 nominal ones; its missing samples count round(dt/nominal) - 1 (at least
1). --gaps refuse (default) stops as soon as the missing samples exceed 0.1 % of the samples
so far (the final snapshot of the rows before the gap, the --out report, exit code 2);
--gaps longest starts anew after each gap and reports the longest gap-free segment so far
(memory per segment kept, not per sample); --gaps ignore goes on across gaps. Each snapshot
carries the counts as \"timing\" (null without stamps).

JSON line shape: {\"t_s\",\"n\",\"final\",\"channels\":[{\"name\",\"unit\",\"rate_hz\",\"n\",
\"points\":[as imunoise avar --format json],\"n_term\",\"k_term\",\"b_term\",\"model\"}],
\"reached\",\"progress\":[{\"channel\",\"symbol\",\"target\",\"rel_halfwidth\",\"reached\",
\"time_left_s\",\"time_left_lo_s\",\"time_left_hi_s\",\"basis\"}],\"timing\":{\"messages\",
\"samples_used\",\"rate_hz\",\"rate_source\",\"rate_from_stamps_hz\",\"median_dt_s\",\"span_s\",
\"reordered\",\"duplicates\",\"gaps\",\"missing_samples\",\"longest_gap_s\",\"gap_policy\",
\"segment\",\"truncated\"} as in results.json, or null}, each term
{\"symbol\",\"value\",\"unit\",\"ci_lo\",\"ci_hi\",\"source\",\"basis\",…} or null.";

/// Arguments of `imunoise live`.
#[derive(Debug, Clone, clap::Args)]
pub struct LiveArgs {
    /// Text input (CSV, TSV or whitespace-separated, with or without a header line), or raw
    /// binary rows with --binary: a file, a FIFO or serial device, or `-` for standard input.
    #[arg(default_value = "-")]
    pub file: PathBuf,
    /// Sampling rate in Hz (> 0). Required without --time-column; with it the rate comes
    /// from the stamps (median of the first 1024 Δt) and a --rate more than 1 % away from
    /// it is an error.
    #[arg(long, short = 'r', value_name = "HZ", value_parser = parse_rate, allow_negative_numbers = true,
          required_unless_present = "time_column")]
    pub rate: Option<f64>,
    /// Columns to analyse: header names or 1-based indices and ranges, e.g. `gyro_x,acc_z` or `1-3`.
    #[arg(long, value_name = "LIST")]
    pub columns: Option<String>,
    /// Raw little-endian binary rows of this type (f64, f32, i16, i32) instead of text, as
    /// `imunoise avar --binary` reads them; the channels are named ch1, ch2, …
    #[arg(long, value_name = "TYPE")]
    pub binary: Option<crate::io::BinaryType>,
    /// Values per row of binary input (default 1).
    #[arg(long, value_name = "K")]
    pub channels: Option<usize>,
    /// Text input: the column (name or 1-based index) holding time stamps. The rate, the
    /// order of the rows, duplicates and gaps then come from the stamps, with the rules of
    /// `imunoise avar --time-column` applied as rows arrive (see below).
    /// `SEC+NSEC` names two columns, whole seconds and nanoseconds, as ROS headers carry
    /// stamps (`--time-column 1+2` for `ros2 topic echo --csv`): exact, where one column of
    /// nanoseconds since 1970 is read as a number to about 0.25 µs.
    #[arg(long, value_name = "COLUMN")]
    pub time_column: Option<String>,
    /// Unit of --time-column: s, ms, us or ns.
    #[arg(long, value_name = "UNIT", default_value = "s")]
    pub time_unit: TimeUnit,
    /// With --time-column, gaps (Δt > 1.5 nominal Δt): refuse (default: stop as soon as
    /// the missing samples exceed 0.1 % of the samples so far, exit code 2), longest
    /// (analyse the longest gap-free segment so far) or ignore (go on across gaps).
    #[arg(long, value_name = "POLICY", value_enum, default_value = "refuse")]
    pub gaps: GapPolicy,
    /// Units: one for all channels or a comma list (deg/s, rad/s, g, m/s^2, none).
    /// Default: inferred from name suffixes (_dps, _rads, _g, _mps2), else none.
    #[arg(long, value_name = "UNIT")]
    pub unit: Option<String>,
    /// Input time between snapshots (seconds of samples, not of the wall clock).
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    pub every: f64,
    /// Largest averaging time tracked (s). Memory: 32 bytes per sample of this τ and channel
    /// (1000 s at 100 Hz: 3.2 MB per channel).
    #[arg(long, value_name = "SECONDS", default_value_t = 1000.0)]
    pub tau_max: f64,
    /// Cluster sizes: dyadic (book default, m = 2^j), dyadic1, octave, decade, logN, or a
    /// list m1,m2,… (up to --tau-max).
    #[arg(long, default_value = "dyadic", value_parser = parse_scales)]
    pub scales: Scales,
    /// Confidence intervals: chi-square with equivalent degrees of freedom, or none.
    #[arg(long, value_enum, default_value = "chi2")]
    pub ci: CiArgLive,
    /// CI level: intervals cover 1 − alpha.
    #[arg(long, default_value_t = 0.05)]
    pub alpha: f64,
    /// A malformed line: stop (print the final snapshot of the rows before it, exit code 2)
    /// or skip it and go on. Either way it is reported with its line number.
    #[arg(long, value_enum, default_value = "stop")]
    pub on_error: OnError,
    /// Keep reading a file that is still being written (like `tail -f`): at its end wait for
    /// more, until it has not grown for --idle seconds.
    #[arg(long)]
    pub follow: bool,
    /// With --follow: the end of the input is this many seconds without new data.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    pub idle: f64,
    /// Stop when the 95 % (1 − alpha) interval of N, K or B (from --model, else read off the
    /// curve), or of a model parameter such as RW.gamma2 or AR1.phi, has at most this relative
    /// half-width on every channel, e.g. `K=10%` (repeatable: all must hold). Checked at each
    /// snapshot; each snapshot also prints the precision reached and the input time still
    /// needed: with --model predicted by the fitted model, with a 95 % interval; without it a
    /// rough 1/√T rule.
    #[arg(long, value_name = "TERM=PRECISION")]
    pub until: Vec<Target>,
    /// A noise model template fitted (GMWM) at each snapshot, e.g. `WN + RW + AR1`: N, K, B
    /// then come from the fitted model with delta-method CIs, as in `imunoise analyze`, and
    /// the --until time left is predicted from it. Without it N, K, B are read off the curve.
    #[arg(long, value_name = "TEMPLATE")]
    pub model: Option<String>,
    /// At the end (of the input, or at the --until target, or at a malformed line with
    /// --on-error stop) also write the report folder of `imunoise analyze` on all the rows
    /// read. Memory: every row is then kept (8 bytes per sample and channel).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// One JSON object per snapshot and line (for other programs). This is the default when
    /// standard output is not a terminal; on a terminal the default is a view refreshed in
    /// place.
    #[arg(long, conflicts_with = "lines")]
    pub json: bool,
    /// One text line per channel and snapshot (for people, e.g. in a log file), on a terminal
    /// or not.
    #[arg(long)]
    pub lines: bool,
    /// On a terminal: the least wall-clock time between two refreshes of the view (s); the
    /// snapshots in between are computed (for --until) but not drawn. The last one is
    /// always drawn.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0)]
    pub refresh: f64,
}

/// How snapshots are shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// One JSON object per line.
    Json,
    /// One text line per channel and snapshot.
    Lines,
    /// A block redrawn in place on a terminal.
    Screen,
}

impl View {
    /// The view for the flags and whether standard output is a terminal: `--json` and
    /// `--lines` as asked, else the screen on a terminal and JSON lines otherwise.
    ///
    /// ```
    /// use imunoise::cli::live::View;
    /// assert_eq!(View::choose(false, false, true), View::Screen);
    /// assert_eq!(View::choose(false, false, false), View::Json);
    /// assert_eq!(View::choose(false, true, false), View::Lines);
    /// assert_eq!(View::choose(true, false, true), View::Json);
    /// ```
    pub fn choose(json: bool, lines: bool, terminal: bool) -> View {
        match (json, lines, terminal) {
            (true, _, _) => View::Json,
            (_, true, _) => View::Lines,
            (_, _, true) => View::Screen,
            _ => View::Json,
        }
    }
}

/// `--ci` values of `imunoise live`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CiArgLive {
    /// Chi-square with equivalent degrees of freedom.
    Chi2,
    /// No interval.
    None,
}

/// Set by SIGINT/SIGTERM: stop reading, print the final snapshot (and write --out).
static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

#[cfg(unix)]
extern "C" fn on_signal(_: libc::c_int) {
    INTERRUPTED.store(true, std::sync::atomic::Ordering::SeqCst);
}

/// Ctrl-C (and SIGTERM) end the input like EOF: the handler only sets a flag, and without
/// SA_RESTART a blocked read returns EINTR, so the loop sees it at once.
#[cfg(unix)]
fn catch_interrupts() {
    for sig in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: a zeroed sigaction is valid; the handler is async-signal-safe (one atomic
        // store); the old action is not needed.
        unsafe {
            let mut sa: libc::sigaction = std::mem::zeroed();
            sa.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
            sa.sa_flags = 0;
            libc::sigemptyset(&mut sa.sa_mask);
            libc::sigaction(sig, &sa, std::ptr::null_mut());
        }
    }
}

#[cfg(not(unix))]
fn catch_interrupts() {}

fn interrupted() -> bool {
    INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst)
}

/// Runs `imunoise live`.
pub fn run(args: &LiveArgs, ui: &Ui) -> Result<()> {
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return Err(Error::Usage(format!(
            "--alpha must lie in (0, 1), got {}",
            args.alpha
        )));
    }
    if !(args.idle.is_finite() && args.idle >= 0.0) {
        return Err(Error::Usage(format!(
            "--idle must be >= 0, got {}",
            args.idle
        )));
    }
    let time = args.time_column.as_ref().map(|c| TimeStamps {
        column: c.clone(),
        unit: args.time_unit,
        gaps: args.gaps,
        rate_hz: args.rate,
    });
    let settings = LiveSettings {
        rate_hz: match (args.rate, &time) {
            (Some(r), _) => r,
            (None, Some(_)) => 0.0, // not used: the stamps give the rate
            (None, None) => {
                return Err(Error::Usage(
                    "--rate is required without --time-column".to_string(),
                ));
            }
        },
        time,
        columns: args.columns.clone(),
        unit: args.unit.clone(),
        scales: args.scales.clone(),
        ci: match args.ci {
            CiArgLive::Chi2 => CiMethod::ChiSquare,
            CiArgLive::None => CiMethod::None,
        },
        alpha: args.alpha,
        tau_max_s: args.tau_max,
        every_s: args.every,
        on_error: args.on_error,
        until: args.until.clone(),
        model: args.model.clone(),
        keep_rows: args.out.is_some(),
        binary: match (args.binary, args.channels) {
            (Some(kind), k) => Some((kind, k.unwrap_or(1))),
            (None, Some(_)) => {
                return Err(Error::Usage(
                    "--channels is for binary input: give --binary TYPE too".to_string(),
                ));
            }
            (None, None) => None,
        },
    };
    if let Some(dir) = &args.out {
        // a bad --out fails before the work, not after it
        crate::output::create_dir(dir, "--out")?;
    }
    let stdin = args.file.as_os_str() == "-";
    let name = if stdin {
        "<stdin>".to_string()
    } else {
        args.file.display().to_string()
    };
    let mut live = Live::new(settings, &name)?;
    let mut input: Box<dyn Read> = if stdin {
        Box::new(std::io::stdin().lock())
    } else {
        Box::new(std::fs::File::open(&args.file).map_err(|e| Error::io(&name, e))?)
    };
    if !(args.refresh.is_finite() && args.refresh >= 0.0) {
        return Err(Error::Usage(format!(
            "--refresh must be >= 0 seconds, got {}",
            args.refresh
        )));
    }
    let stdout = std::io::stdout();
    let view = {
        use std::io::IsTerminal;
        View::choose(args.json, args.lines, stdout.is_terminal())
    };
    let mut out = stdout.lock();
    let mut screen = Screen::new(&name, Duration::from_secs_f64(args.refresh));
    let mut buf = vec![0u8; 1 << 16];
    let mut last_data = Instant::now();
    catch_interrupts();
    loop {
        if interrupted() {
            break;
        }
        let n = match input.read(&mut buf) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Error::io(&name, e)),
        };
        if n == 0 {
            if args.follow && !stdin && last_data.elapsed().as_secs_f64() < args.idle {
                std::thread::sleep(Duration::from_millis(100));
                continue;
            }
            break;
        }
        last_data = Instant::now();
        for event in live.feed(&buf[..n])? {
            match event {
                Event::Snapshot(s) => show(&mut out, &s, view, &mut screen)?,
                // reported even with --quiet, as errors are
                Event::BadLine(e) => eprintln!("malformed line: {e}"),
                Event::Refused(e) => eprintln!("gaps: {e}"),
            }
        }
        if live.stopped().is_some() || live.reached() {
            break;
        }
    }
    let fin = live.finish();
    if let Some(e) = live.partial_row()
        && live.stopped().is_none()
    {
        eprintln!("malformed line: {e}");
    }
    match fin {
        Ok(s) => show(&mut out, &s, view, &mut screen)?,
        Err(e) if live.stopped().is_none() => return Err(e),
        Err(e) => ui.note(format!("no snapshot: {e}")),
    }
    let stopped = live.stopped().map(crate::pipeline::live::clone_error);
    let why = if live.refused() {
        "--gaps refuse"
    } else {
        "--on-error stop"
    };
    let rows = live.len();
    if let Some(dir) = &args.out
        && let Some((table, units)) = live.into_table()
    {
        let settings = crate::pipeline::analyze::AnalyzeSettings::default();
        let a = crate::pipeline::analyze::analyze(table, units, &settings, ui)?;
        a.write_report(dir, ui)?;
        ui.note(format!(
            "report written to {}",
            dir.join("report.html").display()
        ));
    }
    if let Some(e) = &stopped {
        return Err(Error::Located {
            file: name,
            line: match e {
                Error::Located { line, .. } => *line,
                _ => 0,
            },
            column: match e {
                Error::Located { column, .. } => *column,
                _ => 0,
            },
            message: format!(
                "{} ({why}: stopped after the {} rows before it)",
                match e {
                    Error::Located { message, .. } => message.clone(),
                    other => other.to_string(),
                },
                rows
            ),
        });
    }
    Ok(())
}

/// Shows one snapshot in `view` (the screen at most once per refresh interval, except the
/// final snapshot and the one reaching the target).
fn show(out: &mut impl Write, s: &Snapshot, view: View, screen: &mut Screen) -> Result<()> {
    match view {
        View::Json => print_snapshot(out, s, true),
        View::Lines => print_snapshot(out, s, false),
        View::Screen => screen.draw(out, s),
    }
}

/// The view redrawn in place on a terminal: the previous block is overwritten (cursor up
/// over its lines, clear to the end of the screen), so what was printed before it stays.
pub struct Screen {
    name: String,
    every: Duration,
    last: Option<Instant>,
    /// Lines of the block on screen.
    drawn: usize,
}

impl Screen {
    /// A view of the stream `name`, redrawn at most once per `every` of wall-clock time
    /// (example at [`Screen::draw`]).
    pub fn new(name: &str, every: Duration) -> Screen {
        Screen {
            name: name.to_string(),
            every,
            last: None,
            drawn: 0,
        }
    }

    /// Redraws with `s` when the interval has passed (or `s` is final or reached the target).
    ///
    /// ```
    /// use imunoise::cli::live::{Screen, render_frame};
    /// use imunoise::pipeline::live::{Live, LiveSettings};
    /// use std::time::Duration;
    /// let s = LiveSettings { rate_hz: 10.0, every_s: 1e9, ..LiveSettings::default() };
    /// let mut live = Live::new(s, "x")?;
    /// live.feed(b"gx\n1\n2\n0\n3\n1\n2\n")?;
    /// let snap = live.snapshot(false)?;
    /// let frame = render_frame("x", &snap);
    /// let mut screen = Screen::new("x", Duration::ZERO);
    /// let mut out = Vec::new();
    /// screen.draw(&mut out, &snap)?;
    /// assert_eq!(out, frame.as_bytes()); // the first frame as it is
    /// out.clear();
    /// screen.draw(&mut out, &snap)?;
    /// // then: up over the previous frame's lines, clear below, the new frame
    /// let up = format!("\x1b[{}F\x1b[J", frame.lines().count());
    /// assert_eq!(String::from_utf8(out).unwrap(), up + &frame);
    /// // a long interval: nothing until it has passed (a non-final snapshot)
    /// let mut slow = Screen::new("x", Duration::from_secs(3600));
    /// let mut out = Vec::new();
    /// slow.draw(&mut out, &snap)?;
    /// let len = out.len();
    /// slow.draw(&mut out, &snap)?;
    /// assert_eq!(out.len(), len);
    /// # Ok::<(), imunoise::Error>(())
    /// ```
    pub fn draw(&mut self, out: &mut impl Write, s: &Snapshot) -> Result<()> {
        let due = s.is_final || s.reached || self.last.is_none_or(|t| t.elapsed() >= self.every);
        if !due {
            return Ok(());
        }
        let frame = render_frame(&self.name, s);
        let mut text = String::new();
        if self.drawn > 0 {
            // to the first column of the block's first line, then clear below
            text += &format!("\x1b[{}F\x1b[J", self.drawn);
        }
        text += &frame;
        self.drawn = frame.lines().count();
        self.last = Some(Instant::now());
        out.write_all(text.as_bytes())
            .and_then(|_| out.flush())
            .map_err(|e| Error::write("<stdout>", e))
    }
}

/// The text of the view of one snapshot (plain text, one line per row, no escape codes):
/// a title, then per channel its Allan deviation at a few τ, N, K and B with their CIs, the
/// fitted model, and each target's precision and time left.
///
/// ```
/// use imunoise::cli::live::render_frame;
/// use imunoise::pipeline::live::{Event, Live, LiveSettings};
/// let s = LiveSettings { rate_hz: 10.0, every_s: 1e9, until: vec!["K=10%".parse().unwrap()],
///     ..LiveSettings::default() };
/// let mut live = Live::new(s, "<stdin>")?;
/// let mut text = String::from("gyro_x_dps\n");
/// for i in 0..2000 { text += &format!("{}\n", ((i * 37 % 11) as f64 - 5.0) / 10.0); }
/// live.feed(text.as_bytes())?;
/// let frame = render_frame("<stdin>", &live.finish()?);
/// assert!(frame.starts_with("imunoise live <stdin>: t = 200.0 s, 2000 samples (final)"));
/// assert!(frame.contains("\ngyro_x_dps ["));
/// assert!(frame.contains("  N "));
/// assert!(frame.contains("  K: "));
/// assert!(!frame.contains('\x1b'));
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn render_frame(name: &str, s: &Snapshot) -> String {
    let g = |x: f64| processes::number::sig(x, 4);
    let g3 = |x: f64| processes::number::sig(x, 3);
    let mut f = format!(
        "imunoise live {name}: t = {:.1} s, {} samples{}\n",
        s.t_s,
        s.n,
        if s.is_final { " (final)" } else { "" }
    );
    if let Some(t) = &s.timing {
        f += &format!("stamps: {}\n", t.summary());
    }
    for c in &s.channels {
        let unit = if c.unit.is_empty() {
            String::new()
        } else {
            format!(" [{}]", c.unit)
        };
        f += &format!("{}{unit}\n", c.name);
        let ad = adev_near(&c.points, &[0.01, 0.1, 1.0, 10.0, 100.0, 1000.0]);
        if !ad.is_empty() {
            f += "  τ (s) ";
            for (tau, ..) in &ad {
                f += &format!(" {:>10}", g(*tau));
            }
            f += "\n  AD    ";
            for (_, a, ..) in &ad {
                f += &format!(" {:>10}", g(*a));
            }
            f += "\n  ±95 % ";
            for (_, a, lo, hi) in &ad {
                let w = match (lo, hi) {
                    (Some(lo), Some(hi)) if *a > 0.0 => {
                        format!("{}%", g3(100.0 * (hi - lo) / (2.0 * a)))
                    }
                    _ => "-".into(),
                };
                f += &format!(" {w:>10}");
            }
            f += "\n";
        }
        for t in [&c.n_term, &c.k_term, &c.b_term].into_iter().flatten() {
            let how = match t.source {
                gmwm_prep::noise_terms::TermSource::Model => "model",
                gmwm_prep::noise_terms::TermSource::ReadOff => "read-off",
                gmwm_prep::noise_terms::TermSource::UpperBound => "bound",
            };
            f += &format!("  {} {} ({how})\n", t.symbol, t.display());
        }
        if let Some(m) = &c.model {
            // 4 significant digits for people (the JSON keeps every digit)
            match m.parse::<processes::Model>() {
                Ok(model) => f += &format!("  model {model:.4}\n"),
                Err(_) => f += &format!("  model {m}\n"),
            }
        }
        for p in s.progress.iter().filter(|p| p.channel == c.name) {
            f += &format!("  {}: ", p.symbol);
            f += &match (p.rel_halfwidth, p.time_left_s) {
                (Some(h), _) if p.reached => {
                    format!(
                        "±{}% reached (target {}%)",
                        g3(100.0 * h),
                        g3(100.0 * p.target)
                    )
                }
                (Some(h), Some(left)) => format!(
                    "±{}%, target {}%, about {} s more{}{}",
                    g3(100.0 * h),
                    g3(100.0 * p.target),
                    g3(left),
                    match (p.time_left_lo_s, p.time_left_hi_s) {
                        (Some(lo), Some(hi)) => format!(" (95 % [{}, {}] s)", g3(lo), g3(hi)),
                        _ => String::new(),
                    },
                    if p.basis == "sqrt_t" {
                        " (rough: 1/√T)"
                    } else {
                        ""
                    }
                ),
                (Some(h), None) => format!("±{}%, target {}%", g3(100.0 * h), g3(100.0 * p.target)),
                _ => format!("not measurable yet (target {}%)", g3(100.0 * p.target)),
            };
            f += "\n";
        }
    }
    if s.reached {
        f += &format!("target reached at t = {:.1} s\n", s.t_s);
    }
    f
}

/// Writes one snapshot: a JSON line, or one text line per channel.
fn print_snapshot(out: &mut impl Write, s: &Snapshot, json: bool) -> Result<()> {
    let res = if json {
        serde_json::to_writer(&mut *out, s)?;
        writeln!(out)
    } else {
        let mut r = match &s.timing {
            Some(t) => writeln!(
                out,
                "{}t={:.1}s n={} stamps: {}",
                if s.is_final { "final " } else { "" },
                s.t_s,
                s.n,
                t.summary()
            ),
            None => Ok(()),
        };
        for c in &s.channels {
            let unit = if c.unit.is_empty() {
                String::new()
            } else {
                format!(" [{}]", c.unit)
            };
            let mut line = format!(
                "{}t={:.1}s n={} {}{unit}:",
                if s.is_final { "final " } else { "" },
                s.t_s,
                s.n,
                c.name,
            );
            let g = |x: f64| processes::number::sig(x, 4);
            for (tau, ad, lo, hi) in adev_near(&c.points, &[0.01, 0.1, 1.0, 10.0, 100.0, 1000.0]) {
                line += &format!(" AD({}s)={}", g(tau), g(ad));
                if let (Some(lo), Some(hi)) = (lo, hi) {
                    line += &format!(" [{}, {}]", g(lo), g(hi));
                }
            }
            for t in [&c.n_term, &c.k_term, &c.b_term].into_iter().flatten() {
                line += &format!(" {}={}", t.symbol, t.display());
            }
            for p in s.progress.iter().filter(|p| p.channel == c.name) {
                let g = |x: f64| processes::number::sig(x, 3);
                line += &match (p.rel_halfwidth, p.time_left_s) {
                    (Some(h), _) if p.reached => {
                        format!(
                            " {}: ±{}% reached (target {}%)",
                            p.symbol,
                            g(100.0 * h),
                            g(100.0 * p.target)
                        )
                    }
                    (Some(h), Some(left)) => format!(
                        " {}: ±{}% (target {}%, about {} s more{})",
                        p.symbol,
                        g(100.0 * h),
                        g(100.0 * p.target),
                        g(left),
                        match (p.time_left_lo_s, p.time_left_hi_s) {
                            (Some(lo), Some(hi)) => format!(", 95 % [{}, {}] s", g(lo), g(hi)),
                            _ => String::new(),
                        }
                    ),
                    _ => format!(
                        " {}: no {} region yet (target {}%)",
                        p.symbol,
                        p.symbol,
                        g(100.0 * p.target)
                    ),
                };
            }
            r = writeln!(out, "{line}");
            if r.is_err() {
                break;
            }
        }
        if r.is_ok() && s.reached {
            r = writeln!(out, "target reached at t={:.1}s", s.t_s);
        }
        r
    };
    res.and_then(|_| out.flush())
        .map_err(|e| Error::write("<stdout>", e))
}
