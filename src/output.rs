//! Writing outputs (report directories, files, standard output) with errors that name the output
//! in plain words: a bad output argument (an existing file where a directory is wanted, a path
//! through a file) exits with code 2, a failure of the machine (disk full, permissions, a
//! read-only file system) with code 1.

use crate::error::{Error, Result};
use std::path::Path;

/// Creates the output directory `dir` (and its parents) named by the option `option` (e.g.
/// `--out`); an existing directory is fine.
///
/// ```
/// let tmp = tempfile::tempdir().unwrap();
/// let f = tmp.path().join("a-file");
/// std::fs::write(&f, b"x").unwrap();
/// let e = imunoise::output::create_dir(&f, "--out").unwrap_err();
/// assert_eq!(e.exit_code(), 2);
/// assert!(e.to_string().contains("is an existing file, not a directory"));
/// imunoise::output::create_dir(&tmp.path().join("report"), "--out").unwrap();
/// ```
pub fn create_dir(dir: &Path, option: &str) -> Result<()> {
    let name = dir.display();
    if let Ok(md) = std::fs::metadata(dir)
        && !md.is_dir()
    {
        return Err(Error::Usage(format!(
            "{option} {name}: is an existing file, not a directory; name a new or existing directory"
        )));
    }
    std::fs::create_dir_all(dir).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotADirectory | std::io::ErrorKind::AlreadyExists => Error::Usage(
            format!("{option} {name}: a part of the path is a file, not a directory"),
        ),
        _ => Error::write(name.to_string(), e),
    })
}

/// Checks that `path`, named by the option `option`, can be an output file: not a directory.
///
/// ```
/// use imunoise::output::check_file;
/// let tmp = tempfile::tempdir().unwrap();
/// check_file(&tmp.path().join("fit.json"), "--output")?; // need not exist
/// let e = check_file(tmp.path(), "--output").unwrap_err();
/// assert!(e.to_string().ends_with("is a directory; name a file to write"));
/// assert_eq!(e.exit_code(), 2);
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn check_file(path: &Path, option: &str) -> Result<()> {
    if path.is_dir() {
        return Err(Error::Usage(format!(
            "{option} {}: is a directory; name a file to write",
            path.display()
        )));
    }
    Ok(())
}

/// Writes `bytes` to the file `path` (created or replaced).
///
/// ```
/// use imunoise::output::write_file;
/// let tmp = tempfile::tempdir().unwrap();
/// let p = tmp.path().join("out.txt");
/// write_file(&p, b"first")?;
/// write_file(&p, b"second")?; // replaced
/// assert_eq!(std::fs::read(&p).unwrap(), b"second");
/// // a path through a missing folder: a write error naming the file
/// let e = write_file(&tmp.path().join("no/such/dir/out.txt"), b"x").unwrap_err();
/// assert!(e.to_string().starts_with("cannot write "));
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    std::fs::write(path, bytes).map_err(|e| Error::write(path.display().to_string(), e))
}
