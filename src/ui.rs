//! Progress bars and notes on stderr, shared by the command and the library pipeline
//! ([`crate::pipeline`]): a caller that wants silence passes [`Ui::quiet`].

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;

/// Progress and notes on stderr: shown only when stderr is a terminal and not `--quiet`.
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
    pub fn new(quiet: bool) -> Self {
        Ui {
            progress: !quiet && std::io::stderr().is_terminal(),
            notes: !quiet,
        }
    }

    /// A spinner with a message (hidden when progress is off).
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
    pub fn note(&self, msg: impl AsRef<str>) {
        if self.notes {
            eprintln!("{}", msg.as_ref());
        }
    }
}
