//! Channel units (`--unit`) and sensor kinds, given or inferred from channel names.

use crate::error::{Error, Result};
use processes::{Sensor, Unit};

/// Parses one unit as `--unit` accepts it: `deg/s`, `rad/s`, `g`, `m/s^2` (and the
/// spellings [`Unit`]'s parser knows), or `none`.
///
/// ```
/// use imunoise::processes::Unit;
/// use imunoise::units::parse_unit;
/// assert_eq!(parse_unit("deg/s")?, Unit::DegPerSec);
/// assert_eq!(parse_unit("m/s^2")?, Unit::MetrePerSec2);
/// assert_eq!(parse_unit("none")?, Unit::Unitless);
/// let e = parse_unit("furlong").unwrap_err();
/// assert!(e.to_string().starts_with("--unit: "));
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn parse_unit(s: &str) -> Result<Unit> {
    s.parse::<Unit>()
        .map_err(|e| Error::Usage(format!("--unit: {e}")))
}

/// Infers a unit from a channel name's suffix: `_dps`/`_deg_s` → °/s, `_rads`/`_rad_s`/
/// `_radps` → rad/s, `_g` → g, `_mps2`/`_ms2`/`_m_s2` → m/s²; otherwise unitless.
///
/// ```
/// use imunoise::units::infer_unit;
/// use imunoise::processes::Unit;
/// assert_eq!(infer_unit("gyro_x_dps"), Unit::DegPerSec);
/// assert_eq!(infer_unit("acc_z_g"), Unit::G);
/// assert_eq!(infer_unit("temperature"), Unit::Unitless);
/// ```
pub fn infer_unit(name: &str) -> Unit {
    let n = name.to_ascii_lowercase();
    let ends = |s: &[&str]| s.iter().any(|x| n.ends_with(x));
    if ends(&["_dps", "_deg_s", "_degps", "[deg/s]", "(deg/s)"]) {
        Unit::DegPerSec
    } else if ends(&["_rads", "_rad_s", "_radps", "[rad/s]", "(rad/s)"]) {
        Unit::RadPerSec
    } else if ends(&["_mps2", "_ms2", "_m_s2", "[m/s^2]", "(m/s^2)", "[m/s2]"]) {
        Unit::MetrePerSec2
    } else if ends(&["_g", "[g]", "(g)"]) {
        Unit::G
    } else {
        Unit::Unitless
    }
}

/// The units of `names`: from `--unit` (one unit for all channels, or a comma list with
/// one per channel), else inferred from the names ([`infer_unit`]).
///
/// ```
/// use imunoise::processes::Unit;
/// use imunoise::units::channel_units;
/// let names: Vec<String> = ["gyro_x_dps", "acc_z_g"].map(String::from).to_vec();
/// assert_eq!(channel_units(&names, None)?, [Unit::DegPerSec, Unit::G]);
/// // one unit for all, or one per channel
/// assert_eq!(channel_units(&names, Some("rad/s"))?, [Unit::RadPerSec, Unit::RadPerSec]);
/// assert_eq!(channel_units(&names, Some("rad/s,m/s^2"))?, [Unit::RadPerSec, Unit::MetrePerSec2]);
/// assert!(channel_units(&names, Some("g,g,g")).is_err());
/// # Ok::<(), imunoise::Error>(())
/// ```
pub fn channel_units(names: &[String], arg: Option<&str>) -> Result<Vec<Unit>> {
    match arg {
        None => Ok(names.iter().map(|n| infer_unit(n)).collect()),
        Some(list) => {
            let units: Vec<Unit> = list.split(',').map(parse_unit).collect::<Result<_>>()?;
            match units.len() {
                1 => Ok(vec![units[0].clone(); names.len()]),
                k if k == names.len() => Ok(units),
                k => Err(Error::Usage(format!(
                    "--unit gives {k} units for {} channels (give one for all, or one per channel)",
                    names.len()
                ))),
            }
        }
    }
}

/// The sensor kind of a channel: from its unit, else from its name (`gyro…`, `acc…`).
///
/// ```
/// use imunoise::processes::{Sensor, Unit};
/// use imunoise::units::sensor_of;
/// assert_eq!(sensor_of("x", &Unit::G), Sensor::Accelerometer); // the unit decides
/// assert_eq!(sensor_of("gyro_x", &Unit::Unitless), Sensor::Gyroscope);
/// assert_eq!(sensor_of("ax", &Unit::Unitless), Sensor::Accelerometer);
/// assert_eq!(sensor_of("temperature", &Unit::Unitless), Sensor::Other);
/// ```
pub fn sensor_of(name: &str, unit: &Unit) -> Sensor {
    if unit.is_angular_rate() {
        return Sensor::Gyroscope;
    }
    if unit.is_acceleration() {
        return Sensor::Accelerometer;
    }
    let n = name.to_ascii_lowercase();
    if n.starts_with("gyr") || n.starts_with('g') && n.len() == 2 {
        Sensor::Gyroscope
    } else if n.starts_with("acc") || n.starts_with('a') && n.len() == 2 {
        Sensor::Accelerometer
    } else {
        Sensor::Other
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_given_or_inferred() {
        let names: Vec<String> = ["gyro_x_dps", "acc_z_g"].map(String::from).to_vec();
        assert_eq!(
            channel_units(&names, None).unwrap(),
            [Unit::DegPerSec, Unit::G]
        );
        assert_eq!(
            channel_units(&names, Some("rad/s")).unwrap(),
            [Unit::RadPerSec, Unit::RadPerSec]
        );
        assert_eq!(
            channel_units(&names, Some("rad/s,m/s^2")).unwrap(),
            [Unit::RadPerSec, Unit::MetrePerSec2]
        );
        assert!(channel_units(&names, Some("g,g,g")).is_err());
        assert!(channel_units(&names, Some("furlong")).is_err());
        assert_eq!(sensor_of("gx", &Unit::Unitless), Sensor::Gyroscope);
        assert_eq!(sensor_of("x", &Unit::G), Sensor::Accelerometer);
    }
}
