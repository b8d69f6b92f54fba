//! The library pipeline behind the `imunoise` command and the Python package: from a file to
//! results in plain structs, with no printing of results and no argument parsing.
//!
//! Read top-down, the way data flows:
//! 1. [`read`]: a file (text, gzip, raw binary, a log) into an [`crate::io::Table`] with its
//!    rate, as an [`read::Input`] says;
//! 2. [`estimate`]: each channel's Allan variance (or another stability statistic, or the
//!    robust AV) and the data-quality findings;
//! 3. [`fit`]: a noise model per channel (GMWM, AVLR, IEEE 952), with CIs, and joint fits of
//!    several recordings;
//! 4. [`analyze`]: everything at once (selection by WIC, contamination check), as
//!    `results.json`;
//! 5. [`report`]: the report folder (HTML, plots, JSON, CSV, Kalibr YAML); the estimators'
//!    config files are written by [`crate::export`].
//!
//! Beside them, [`simulate`] makes channels of a noise model and [`theory`] gives a model's
//! Allan variance and PSD.
//!
//! Progress bars and notes go through a [`crate::Ui`]; [`crate::Ui::quiet`] silences them.
//!
//! ```no_run
//! use imunoise::pipeline::{analyze, read::Input};
//! let ui = imunoise::Ui::quiet();
//! let input = Input { rate: Some(100.0), ..Input::new("imu.csv.gz") };
//! let table = input.read(&ui)?;
//! let units = input.units(&table)?;
//! let analysis = analyze::analyze(table, units, &analyze::AnalyzeSettings::default(), &ui)?;
//! println!("{}", analysis.results_json()?);
//! # Ok::<(), imunoise::Error>(())
//! ```

pub mod analyze;
pub mod estimate;
pub mod fit;
pub mod read;
pub mod report;
pub mod simulate;
pub mod theory;
