//! The umbrella's error type: input problems located by file, line and column, bad
//! command-line values, and the errors of the library layers.

use thiserror::Error;

/// Everything the `imunoise` command and its input layer can report.
///
/// Input and usage errors ([`Error::is_user_error`]) make the command exit with code 2;
/// anything else with code 1. No input ever makes it panic.
#[derive(Debug, Error)]
pub enum Error {
    /// An input file could not be opened or read.
    #[error("{path}: {}", plain(source))]
    Io {
        /// The file as the user named it.
        path: String,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// An output (a file, a report directory, standard output) could not be created or
    /// written: the machine's doing (disk full, permissions, a read-only file system), exit 1.
    #[error("cannot write {path}: {}", plain(source))]
    Write {
        /// The output as the user named it (`<stdout>` for standard output).
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
    ///
    /// ```
    /// use imunoise::Error;
    /// use std::io::ErrorKind;
    /// assert!(Error::Usage("--rate must be positive".into()).is_user_error());
    /// assert!(Error::io("imu.csv", ErrorKind::NotFound.into()).is_user_error());
    /// // the machine's doing: a full disk
    /// assert!(!Error::write("report", ErrorKind::StorageFull.into()).is_user_error());
    /// ```
    pub fn is_user_error(&self) -> bool {
        match self {
            Error::Located { .. } | Error::File { .. } | Error::Usage(_) => true,
            // A missing, unreadable or malformed input file is the user's doing too; a read
            // error of the device is the machine's.
            Error::Io { source, .. } => {
                use std::io::ErrorKind as K;
                matches!(
                    source.kind(),
                    K::NotFound
                        | K::PermissionDenied
                        | K::IsADirectory
                        | K::NotADirectory
                        | K::InvalidData
                        | K::InvalidInput
                        | K::UnexpectedEof
                        | K::InvalidFilename
                )
            }
            Error::Process(_) | Error::Avar(_) => true,
            Error::Write { .. } | Error::Json(_) => false,
        }
    }

    /// The process exit code for this error: 2 for user errors, 1 otherwise.
    ///
    /// ```
    /// use imunoise::Error;
    /// let e = Error::File { file: "imu.csv".into(), message: "the file is empty".into() };
    /// assert_eq!(e.exit_code(), 2);
    /// let w = Error::write("<stdout>", std::io::ErrorKind::PermissionDenied.into());
    /// assert_eq!(w.exit_code(), 1);
    /// ```
    pub fn exit_code(&self) -> i32 {
        if self.is_user_error() { 2 } else { 1 }
    }

    /// Shorthand for an [`Error::Io`] (reading an input).
    ///
    /// ```
    /// use imunoise::Error;
    /// let e = Error::io("imu.csv", std::io::ErrorKind::NotFound.into());
    /// assert!(matches!(&e, Error::Io { path, .. } if path == "imu.csv"));
    /// assert_eq!(e.to_string(), "imu.csv: no such file or directory");
    /// ```
    pub fn io(path: impl Into<String>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.into(),
            source,
        }
    }

    /// Shorthand for an [`Error::Write`] (writing an output).
    ///
    /// ```
    /// use imunoise::Error;
    /// let e = Error::write("report/imu.yaml", std::io::ErrorKind::StorageFull.into());
    /// assert!(matches!(&e, Error::Write { path, .. } if path == "report/imu.yaml"));
    /// assert_eq!(e.to_string(), "cannot write report/imu.yaml: no space left on the device");
    /// ```
    pub fn write(path: impl Into<String>, source: std::io::Error) -> Self {
        Error::Write {
            path: path.into(),
            source,
        }
    }

    /// True when standard output was closed by its reader (`imunoise avar … | head`): not an
    /// error of ours, the command stops quietly.
    ///
    /// ```
    /// use imunoise::Error;
    /// use std::io::ErrorKind;
    /// assert!(Error::write("<stdout>", ErrorKind::BrokenPipe.into()).is_broken_pipe());
    /// assert!(!Error::write("<stdout>", ErrorKind::StorageFull.into()).is_broken_pipe());
    /// assert!(!Error::Usage("x".into()).is_broken_pipe());
    /// ```
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, Error::Io { source, .. } | Error::Write { source, .. }
            if source.kind() == std::io::ErrorKind::BrokenPipe)
    }
}

/// An operating-system error in plain words, without the "(os error N)" suffix.
///
/// ```
/// use std::io::{Error, ErrorKind};
/// assert_eq!(imunoise::error::plain(&Error::from(ErrorKind::StorageFull)), "no space left on the device");
/// ```
pub fn plain(e: &std::io::Error) -> String {
    use std::io::ErrorKind as K;
    let words = match e.kind() {
        K::NotFound => "no such file or directory",
        K::PermissionDenied => "permission denied",
        K::StorageFull => "no space left on the device",
        K::QuotaExceeded => "disk quota exceeded",
        K::ReadOnlyFilesystem => "the file system is read-only",
        K::IsADirectory => "is a directory",
        K::NotADirectory => "a part of the path is a file, not a directory",
        K::AlreadyExists => "already exists",
        K::FileTooLarge => "the file is too large for the file system",
        K::InvalidFilename => "the file name is invalid (too long?)",
        _ => {
            let s = e.to_string();
            return match s.rfind(" (os error ") {
                Some(i) => s[..i].to_string(),
                None => s,
            };
        }
    };
    words.to_string()
}

/// Shorthand for results of the umbrella crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;
