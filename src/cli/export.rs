//! `imunoise export`: the noise values of a `results.json` into estimators' config files.

use super::Ui;
use crate::error::Result;
use crate::export::{ExportOptions, Target, write_all};
use std::path::PathBuf;

/// Examples shown by `imunoise export --help`.
pub const EXAMPLES: &str = "Examples:
  imunoise export report/results.json --to all --out config/
  imunoise export report/ --to kalibr,vins --aggregate rms --inflate-noise 2 --inflate-walk 10

Files: imu.yaml (Kalibr), kalibr_imu_chain.yaml (OpenVINS imu0 block), orbslam3_imu.yaml
(IMU.NoiseGyro, IMU.NoiseAcc, IMU.GyroWalk, IMU.AccWalk, IMU.Frequency), vins_imu.yaml
(acc_n, gyr_n, acc_w, gyr_w) and basalt_imu.json (per-axis accel/gyro noise and bias std).
All values are continuous-time densities in SI units; each file states the per-axis values,
the aggregate, the discrete equivalents (N*sqrt(f), K/sqrt(f)) and the inflation factors.
The same files come out of `imunoise analyze --export LIST`.";

/// Arguments of `imunoise export`.
#[derive(Debug, Clone, clap::Args)]
pub struct ExportArgs {
    /// results.json written by `imunoise analyze`, or its folder.
    pub results: PathBuf,
    /// Which files: a comma list of kalibr, openvins, orbslam3, vins, basalt, or all.
    #[arg(long, value_name = "LIST", default_value = "all")]
    pub to: String,
    /// Output folder (default: the folder of results.json).
    #[arg(long, short, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Aggregation and inflation.
    #[command(flatten)]
    pub options: ExportOptions,
}

pub use crate::export::load;

/// Runs `imunoise export`.
pub fn run(args: &ExportArgs, ui: &Ui) -> Result<()> {
    let targets = Target::parse_list(&args.to)?;
    let noise = load(&args.results)?;
    // an explicit export of nothing: say so instead of writing files of "not estimated"
    if noise.gyro.is_empty() && noise.acc.is_empty() {
        return Err(crate::error::Error::Usage(format!(
            "{}: nothing to export, as no channel is an angular rate or an acceleration ({}); \
             analyze with the channels' unit (--unit, or a name suffix such as _rads or _mps2)",
            args.results.display(),
            noise.skipped.join("; ")
        )));
    }
    let dir = args.out.clone().unwrap_or_else(|| {
        if args.results.is_dir() {
            args.results.clone()
        } else {
            args.results
                .parent()
                .map(|p| p.to_path_buf())
                .unwrap_or_default()
        }
    });
    for p in write_all(&noise, &targets, &args.options, &dir)? {
        ui.note(format!("wrote {}", p.display()));
    }
    Ok(())
}
