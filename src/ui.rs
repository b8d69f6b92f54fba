//! Progress bars and notes on stderr, shared by the command and the library pipeline
//! ([`crate::pipeline`]): a caller that wants silence passes [`Ui::quiet`].

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;

/// Progress and notes on stderr: shown only when stderr is a terminal and not `--quiet`.
///
/// ```
/// use imunoise::Ui;
/// // what the library faces pass: silent
/// let ui = Ui::quiet();
/// let pb = ui.bar(3, "fitting");
/// assert!(pb.is_hidden());
/// ui.note("note: not printed");
/// // the command's: notes unless --quiet, bars on a terminal only
/// assert!(!Ui::new(true).notes);
/// assert!(Ui::new(false).notes);
/// ```
#[derive(Debug, Clone, Copy)]
pub struct Ui {
    /// Whether progress bars are drawn.
    pub progress: bool,
    /// Whether notes are printed.
    pub notes: bool,
}

impl Ui {
    /// No progress bars and no notes: what the library faces (Python, tests) use.
    ///
    /// ```
    /// let ui = imunoise::Ui::quiet();
    /// assert!(!ui.progress && !ui.notes);
    /// ```
    pub fn quiet() -> Self {
        Ui {
            progress: false,
            notes: false,
        }
    }

    /// Decides from `--quiet` and whether stderr is a terminal.
    ///
    /// ```
    /// use imunoise::Ui;
    /// use std::io::IsTerminal;
    /// let ui = Ui::new(false);
    /// assert!(ui.notes);
    /// assert_eq!(ui.progress, std::io::stderr().is_terminal());
    /// let quiet = Ui::new(true);
    /// assert!(!quiet.notes && !quiet.progress);
    /// ```
    pub fn new(quiet: bool) -> Self {
        Ui {
            progress: !quiet && std::io::stderr().is_terminal(),
            notes: !quiet,
        }
    }

    /// A spinner with a message (hidden when progress is off).
    ///
    /// ```
    /// let pb = imunoise::Ui::quiet().spinner("reading imu.csv");
    /// assert!(pb.is_hidden());
    /// pb.finish_and_clear();
    /// ```
    pub fn spinner(&self, msg: impl Into<String>) -> ProgressBar {
        if !self.progress {
            return ProgressBar::hidden();
        }
        let pb = ProgressBar::new_spinner();
        if let Ok(style) = ProgressStyle::with_template("{spinner} {msg} {elapsed}") {
            pb.set_style(style);
        }
        pb.set_message(msg.into());
        pb.enable_steady_tick(std::time::Duration::from_millis(120));
        pb
    }

    /// A bar of `len` steps with a message (hidden when progress is off).
    ///
    /// ```
    /// use imunoise::Ui;
    /// assert!(Ui::quiet().bar(6, "Allan var.").is_hidden());
    /// // with progress on: a bar of 6 steps (drawn on a terminal only), one per channel done
    /// let pb = Ui { progress: true, notes: false }.bar(6, "Allan var.");
    /// assert_eq!(pb.length(), Some(6));
    /// pb.inc(6);
    /// assert_eq!(pb.position(), 6);
    /// pb.finish_and_clear();
    /// ```
    pub fn bar(&self, len: u64, msg: impl Into<String>) -> ProgressBar {
        if !self.progress {
            return ProgressBar::hidden();
        }
        let pb = ProgressBar::new(len);
        if let Ok(style) =
            ProgressStyle::with_template("{msg:>12} [{bar:30}] {pos}/{len} {elapsed}")
        {
            pb.set_style(style.progress_chars("=> "));
        }
        pb.set_message(msg.into());
        pb
    }

    /// Prints a note on stderr unless quiet.
    ///
    /// ```
    /// use imunoise::Ui;
    /// // notes without progress bars (what a non-terminal stderr gets)
    /// let ui = Ui { progress: false, notes: true };
    /// ui.note("note: channel \"gx\": 2 spikes"); // printed on stderr
    /// Ui::quiet().note("not printed");
    /// ```
    pub fn note(&self, msg: impl AsRef<str>) {
        if self.notes {
            eprintln!("{}", msg.as_ref());
        }
    }
}
