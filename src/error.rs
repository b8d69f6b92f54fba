//! The umbrella's error type: input problems located by file, line and column, bad
//! command-line values, and the errors of the library layers.

use thiserror::Error;

/// Everything the `imunoise` command and its input layer can report.
///
/// Input and usage errors ([`Error::is_user_error`]) make the command exit with code 2;
/// anything else with code 1. No input ever makes it panic.
#[derive(Debug, Error)]
pub enum Error {
    /// A file could not be opened, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file as the user named it.
        path: String,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// A problem at a place in an input file (non-numeric cell, ragged row, NaN or
    /// infinity). For binary input the "line" is the row (sample) and the "column" the
    /// channel, both counted from 1.
    #[error("{file}:{line}:{column}: {message}")]
    Located {
        /// The file as the user named it.
        file: String,
        /// Line number, from 1.
        line: usize,
        /// Column number (characters, or the channel for binary input), from 1.
        column: usize,
        /// What is wrong there.
        message: String,
    },
    /// A problem with a file as a whole (empty, no data rows, too few samples, size not a
    /// multiple of the row size).
    #[error("{file}: {message}")]
    File {
        /// The file as the user named it.
        file: String,
        /// What is wrong with it.
        message: String,
    },
    /// A bad command-line value (rate ≤ 0, unknown column, unknown unit, …).
    #[error("{0}")]
    Usage(String),
    /// An error of the `processes` layer (model text, parameters, simulation).
    #[error(transparent)]
    Process(#[from] processes::ProcessError),
    /// An error of the `avar` layer.
    #[error(transparent)]
    Avar(#[from] avar::AvarError),
    /// JSON serialisation failed.
    #[error("JSON output: {0}")]
    Json(#[from] serde_json::Error),
}

impl Error {
    /// True for errors caused by the user's input or flags (exit code 2).
    pub fn is_user_error(&self) -> bool {
        match self {
            Error::Located { .. } | Error::File { .. } | Error::Usage(_) => true,
            // Opening a missing input file is the user's doing too.
            Error::Io { source, .. } => matches!(
                source.kind(),
                std::io::ErrorKind::NotFound | std::io::ErrorKind::PermissionDenied
            ),
            Error::Process(_) | Error::Avar(_) => true,
            Error::Json(_) => false,
        }
    }

    /// The process exit code for this error: 2 for user errors, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        if self.is_user_error() { 2 } else { 1 }
    }

    /// Shorthand for an [`Error::Io`].
    pub fn io(path: impl Into<String>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }
}

/// Shorthand for results of the umbrella crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
