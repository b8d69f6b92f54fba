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
//! ```
//! use imunoise::pipeline::{analyze, read::Input, simulate};
//! let ui = imunoise::Ui::quiet();
//! // a gyro channel in °/s at 100 Hz: white noise plus a rate random walk, as CSV
//! let model: imunoise::processes::Model = "WN(sigma2=1e-4) + RW(gamma2=1e-9)".parse()?;
//! let cols = simulate::simulate_channels(&model, 1 << 14, 100.0, 1, 1)?;
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("gyro.csv");
//! simulate::write_csv(&mut std::fs::File::create(&path)?, &["gyro_x_dps".into()], &cols)?;
//! // read, analyse, and get results.json as a value
//! let input = Input { rate: Some(100.0), ..Input::new(&path) };
//! let table = input.read(&ui)?;
//! let units = input.units(&table)?;
//! let a = analyze::analyze(table, units, &analyze::AnalyzeSettings::default(), &ui)?;
//! let json = a.results_json()?;
//! assert_eq!(json["channels"][0]["unit"], "deg/s");
//! assert!(json["channels"][0]["fit"]["model"].as_str().unwrap().contains("WN"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod analyze;
pub mod curve;
pub mod estimate;
pub mod fit;
pub mod live;
pub mod precision;
pub mod read;
pub mod report;
pub mod simulate;
pub mod theory;
