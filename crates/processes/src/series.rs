//! Time-series types: a single channel ([`TimeSeries`], the book's `gts`) and a
//! multi-channel IMU record ([`ImuRecord`], simts' `imu`).

use crate::error::{ProcessError, Result};
use serde::{Deserialize, Serialize};
use std::fmt;

/// Physical unit of a channel. Inertial units drive the IEEE 952 conversions downstream.
///
/// ```
/// use processes::Unit;
/// assert_eq!("deg/s".parse::<Unit>()?, Unit::DegPerSec);
/// assert_eq!("m/s^2".parse::<Unit>()?, Unit::MetrePerSec2);
/// assert!(Unit::RadPerSec.is_angular_rate());
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
pub enum Unit {
    /// Degrees per second (gyroscope).
    #[serde(rename = "deg/s")]
    DegPerSec,
    /// Radians per second (gyroscope).
    #[serde(rename = "rad/s")]
    RadPerSec,
    /// Standard gravity, 9.80665 m/s² (accelerometer).
    #[serde(rename = "g")]
    G,
    /// Metres per second squared (accelerometer).
    #[serde(rename = "m/s^2")]
    MetrePerSec2,
    /// No unit stated.
    #[default]
    #[serde(rename = "unitless")]
    Unitless,
    /// Any other unit, by name.
    #[serde(untagged)]
    Other(String),
}

impl Unit {
    /// True for gyroscope units (°/s, rad/s).
    ///
    /// ```
    /// use processes::Unit;
    /// assert!(Unit::DegPerSec.is_angular_rate() && !Unit::G.is_angular_rate());
    /// ```
    pub fn is_angular_rate(&self) -> bool {
        matches!(self, Unit::DegPerSec | Unit::RadPerSec)
    }
    /// True for accelerometer units (g, m/s²).
    ///
    /// ```
    /// use processes::Unit;
    /// assert!(Unit::MetrePerSec2.is_acceleration() && !Unit::RadPerSec.is_acceleration());
    /// ```
    pub fn is_acceleration(&self) -> bool {
        matches!(self, Unit::G | Unit::MetrePerSec2)
    }
    /// The unit's symbol as printed, e.g. `"°/s"`.
    ///
    /// ```
    /// use processes::Unit;
    /// assert_eq!(Unit::MetrePerSec2.symbol(), "m/s²");
    /// assert_eq!(Unit::Other("V".into()).symbol(), "V");
    /// ```
    pub fn symbol(&self) -> &str {
        match self {
            Unit::DegPerSec => "°/s",
            Unit::RadPerSec => "rad/s",
            Unit::G => "g",
            Unit::MetrePerSec2 => "m/s²",
            Unit::Unitless => "",
            Unit::Other(s) => s,
        }
    }
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.symbol())
    }
}

impl std::str::FromStr for Unit {
    type Err = ProcessError;
    /// Accepts `deg/s dps °/s rad/s rps g m/s^2 m/s2 m/s² mps2` (any case); `""`/`none`
    /// is unitless. Anything else is an error (use [`Unit::Other`] explicitly).
    fn from_str(s: &str) -> Result<Self> {
        let t = s.trim().to_ascii_lowercase();
        Ok(match t.as_str() {
            "deg/s" | "dps" | "°/s" | "degps" | "deg/sec" => Unit::DegPerSec,
            "rad/s" | "rps" | "radps" | "rad/sec" => Unit::RadPerSec,
            "g" => Unit::G,
            "m/s^2" | "m/s2" | "m/s²" | "mps2" | "m/s/s" => Unit::MetrePerSec2,
            "" | "none" | "unitless" | "1" => Unit::Unitless,
            _ => {
                return Err(ProcessError::InvalidArgument(format!(
                    "unknown unit {s:?}; expected deg/s, rad/s, g, m/s^2 or none"
                )));
            }
        })
    }
}

/// A regularly sampled single-channel time series (book Definition 2.1).
///
/// Values are finite; `rate_hz` is the sampling rate in Hz (Δt = 1/rate); `start` is the
/// time of the first sample in seconds.
///
/// ```
/// use processes::{TimeSeries, Unit};
/// let ts = TimeSeries::new(vec![0.1, -0.2, 0.05], 100.0)?
///     .with_name("gyro_x")
///     .with_unit(Unit::DegPerSec);
/// assert_eq!(ts.len(), 3);
/// assert_eq!(ts.dt(), 0.01);
/// assert_eq!(ts.time(2), 0.02);
/// let err = TimeSeries::new(vec![1.0, f64::NAN], 100.0).unwrap_err();
/// assert!(err.to_string().contains("index 1"));
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimeSeries {
    values: Vec<f64>,
    rate_hz: f64,
    start: f64,
    unit: Unit,
    name: String,
}

impl TimeSeries {
    /// Builds a series, checking the rate is finite and > 0 and that every value is finite
    /// (the error names the first bad index). Name `"x"`, start 0 s, unitless.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![0.5, 0.25], 10.0)?; // 10 Hz
    /// assert_eq!((ts.name(), ts.start()), ("x", 0.0));
    /// assert!(TimeSeries::new(vec![1.0], 0.0).is_err()); // rate must be > 0
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(values: Vec<f64>, rate_hz: f64) -> Result<Self> {
        Self::named(values, rate_hz, "x")
    }

    /// As [`Self::new`] with a name (used in error messages too).
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let err = TimeSeries::named(vec![1.0, 2.0, f64::INFINITY], 10.0, "acc_z").unwrap_err();
    /// assert!(err.to_string().contains("\"acc_z\"") && err.to_string().contains("index 2"));
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn named(values: Vec<f64>, rate_hz: f64, name: &str) -> Result<Self> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(ProcessError::InvalidRate(rate_hz));
        }
        if let Some(index) = values.iter().position(|v| !v.is_finite()) {
            return Err(ProcessError::NonFiniteValue {
                name: name.to_string(),
                index,
                value: values[index],
            });
        }
        Ok(Self {
            values,
            rate_hz,
            start: 0.0,
            unit: Unit::Unitless,
            name: name.to_string(),
        })
    }

    /// A series from values already known to be finite (e.g. checked while simulating),
    /// with a rate already validated. Not public: every public constructor checks.
    pub(crate) fn from_checked(values: Vec<f64>, rate_hz: f64, name: &str) -> Self {
        debug_assert!(rate_hz.is_finite() && rate_hz > 0.0);
        Self {
            values,
            rate_hz,
            start: 0.0,
            unit: Unit::Unitless,
            name: name.to_string(),
        }
    }

    /// Sets the name.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.with_name("gyro_y").name(), "gyro_y");
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn with_name(mut self, name: &str) -> Self {
        self.name = name.to_string();
        self
    }
    /// Sets the unit.
    ///
    /// ```
    /// use processes::{TimeSeries, Unit};
    /// let ts = TimeSeries::new(vec![0.0], 1.0)?.with_unit(Unit::RadPerSec);
    /// assert_eq!(ts.unit(), &Unit::RadPerSec);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn with_unit(mut self, unit: Unit) -> Self {
        self.unit = unit;
        self
    }
    /// Sets the start time in seconds (must be finite).
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// let ts = ts.with_start(10.0)?; // seconds
    /// assert_eq!(ts.time(1), 10.02);
    /// assert!(ts.with_start(f64::NAN).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn with_start(mut self, start: f64) -> Result<Self> {
        if !start.is_finite() {
            return Err(ProcessError::InvalidArgument(format!(
                "start time must be finite, got {start}"
            )));
        }
        self.start = start;
        Ok(self)
    }
    /// The samples.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.values()[3], 4.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn values(&self) -> &[f64] {
        &self.values
    }
    /// Takes the samples out.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.into_values(), [1.0, 2.0, 3.0, 4.0]);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn into_values(self) -> Vec<f64> {
        self.values
    }
    /// Number of samples T.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.len(), 4);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn len(&self) -> usize {
        self.values.len()
    }
    /// True when there are no samples.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// assert!(TimeSeries::new(vec![], 1.0)?.is_empty());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }
    /// Sampling rate in Hz.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.rate_hz(), 50.0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn rate_hz(&self) -> f64 {
        self.rate_hz
    }
    /// Sampling interval Δt = 1/rate in seconds.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.dt(), 0.02); // seconds
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn dt(&self) -> f64 {
        1.0 / self.rate_hz
    }
    /// Time of the first sample in seconds.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.with_start(-1.5)?.start(), -1.5); // seconds
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn start(&self) -> f64 {
        self.start
    }
    /// Time in seconds of sample `i` (zero-based): start + i Δt.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.time(3), 0.06); // seconds
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn time(&self, i: usize) -> f64 {
        self.start + i as f64 / self.rate_hz
    }
    /// Duration T Δt in seconds.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// let ts = TimeSeries::new(vec![1.0, 2.0, 3.0, 4.0], 50.0)?; // 50 Hz
    /// assert_eq!(ts.duration(), 0.08); // 4 samples × 0.02 s
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn duration(&self) -> f64 {
        self.values.len() as f64 / self.rate_hz
    }
    /// The unit.
    ///
    /// ```
    /// use processes::{TimeSeries, Unit};
    /// assert_eq!(TimeSeries::new(vec![0.0], 1.0)?.unit(), &Unit::Unitless);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn unit(&self) -> &Unit {
        &self.unit
    }
    /// The name.
    ///
    /// ```
    /// use processes::TimeSeries;
    /// assert_eq!(TimeSeries::named(vec![0.0], 1.0, "gyro_z")?.name(), "gyro_z");
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// The kind of sensor a channel of an IMU record comes from.
///
/// ```
/// use processes::{ImuRecord, Sensor, TimeSeries};
/// let g = TimeSeries::new(vec![0.0; 5], 200.0)?;
/// let a = TimeSeries::new(vec![1.0; 5], 200.0)?;
/// let imu = ImuRecord::new(vec![(Sensor::Gyroscope, g), (Sensor::Accelerometer, a)])?;
/// assert_eq!(imu.channels()[1].0, Sensor::Accelerometer);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Sensor {
    /// Gyroscope (angular rate).
    Gyroscope,
    /// Accelerometer (specific force).
    Accelerometer,
    /// Anything else.
    Other,
}

/// A multi-channel record of one IMU at one sampling rate (simts' `imu`): e.g. three
/// gyroscope and three accelerometer axes, each with its unit.
///
/// ```
/// use processes::{ImuRecord, Sensor, TimeSeries, Unit};
/// let gx = TimeSeries::new(vec![0.0; 8], 100.0)?.with_name("gyro_x").with_unit(Unit::DegPerSec);
/// let az = TimeSeries::new(vec![-1.0; 8], 100.0)?.with_name("acc_z").with_unit(Unit::G);
/// let imu = ImuRecord::new(vec![(Sensor::Gyroscope, gx), (Sensor::Accelerometer, az)])?;
/// assert_eq!(imu.len(), 8);
/// assert_eq!(imu.channels_of(Sensor::Accelerometer).count(), 1);
/// # Ok::<(), processes::ProcessError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImuRecord {
    channels: Vec<(Sensor, TimeSeries)>,
}

impl ImuRecord {
    /// Builds a record; every channel must have the same length and rate.
    ///
    /// ```
    /// use processes::{ImuRecord, Sensor, TimeSeries};
    /// let a = TimeSeries::new(vec![0.0; 5], 100.0)?;
    /// let b = TimeSeries::new(vec![0.0; 4], 100.0)?;
    /// assert!(ImuRecord::new(vec![(Sensor::Gyroscope, a), (Sensor::Gyroscope, b)]).is_err());
    /// assert!(ImuRecord::new(vec![]).is_err());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn new(channels: Vec<(Sensor, TimeSeries)>) -> Result<Self> {
        let Some((_, first)) = channels.first() else {
            return Err(ProcessError::InvalidArgument(
                "an IMU record needs at least one channel".into(),
            ));
        };
        let (n, rate) = (first.len(), first.rate_hz());
        for (_, c) in &channels {
            if c.len() != n {
                return Err(ProcessError::LengthMismatch {
                    name: c.name().to_string(),
                    len: c.len(),
                    expected: n,
                });
            }
            if c.rate_hz() != rate {
                return Err(ProcessError::InvalidArgument(format!(
                    "channel {:?} is sampled at {} Hz but the record at {rate} Hz",
                    c.name(),
                    c.rate_hz()
                )));
            }
        }
        Ok(Self { channels })
    }
    /// All channels with their sensor kind.
    ///
    /// ```
    /// use processes::{ImuRecord, Sensor, TimeSeries};
    /// let g = TimeSeries::new(vec![0.0; 5], 200.0)?;
    /// let a = TimeSeries::new(vec![1.0; 5], 200.0)?;
    /// let imu = ImuRecord::new(vec![(Sensor::Gyroscope, g), (Sensor::Accelerometer, a)])?;
    /// assert_eq!(imu.channels().len(), 2);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn channels(&self) -> &[(Sensor, TimeSeries)] {
        &self.channels
    }
    /// The channels of one sensor kind.
    ///
    /// ```
    /// use processes::{ImuRecord, Sensor, TimeSeries};
    /// let g = TimeSeries::new(vec![0.0; 5], 200.0)?;
    /// let a = TimeSeries::new(vec![1.0; 5], 200.0)?;
    /// let imu = ImuRecord::new(vec![(Sensor::Gyroscope, g), (Sensor::Accelerometer, a)])?;
    /// assert_eq!(imu.channels_of(Sensor::Gyroscope).count(), 1);
    /// assert_eq!(imu.channels_of(Sensor::Other).count(), 0);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn channels_of(&self, sensor: Sensor) -> impl Iterator<Item = &TimeSeries> {
        self.channels
            .iter()
            .filter(move |(s, _)| *s == sensor)
            .map(|(_, c)| c)
    }
    /// Samples per channel.
    ///
    /// ```
    /// use processes::{ImuRecord, Sensor, TimeSeries};
    /// let g = TimeSeries::new(vec![0.0; 5], 200.0)?;
    /// let a = TimeSeries::new(vec![1.0; 5], 200.0)?;
    /// let imu = ImuRecord::new(vec![(Sensor::Gyroscope, g), (Sensor::Accelerometer, a)])?;
    /// assert_eq!(imu.len(), 5);
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn len(&self) -> usize {
        self.channels[0].1.len()
    }
    /// True when the channels have no samples.
    ///
    /// ```
    /// use processes::{ImuRecord, Sensor, TimeSeries};
    /// let g = TimeSeries::new(vec![0.0; 5], 200.0)?;
    /// let a = TimeSeries::new(vec![1.0; 5], 200.0)?;
    /// let imu = ImuRecord::new(vec![(Sensor::Gyroscope, g), (Sensor::Accelerometer, a)])?;
    /// assert!(!imu.is_empty());
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// The common sampling rate in Hz.
    ///
    /// ```
    /// use processes::{ImuRecord, Sensor, TimeSeries};
    /// let g = TimeSeries::new(vec![0.0; 5], 200.0)?;
    /// let a = TimeSeries::new(vec![1.0; 5], 200.0)?;
    /// let imu = ImuRecord::new(vec![(Sensor::Gyroscope, g), (Sensor::Accelerometer, a)])?;
    /// assert_eq!(imu.rate_hz(), 200.0); // Hz
    /// # Ok::<(), processes::ProcessError>(())
    /// ```
    pub fn rate_hz(&self) -> f64 {
        self.channels[0].1.rate_hz()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_series_name_the_first_bad_index() {
        let e =
            TimeSeries::named(vec![0.0, 1.0, f64::INFINITY, f64::NAN], 10.0, "acc_z").unwrap_err();
        assert_eq!(
            e,
            ProcessError::NonFiniteValue {
                name: "acc_z".into(),
                index: 2,
                value: f64::INFINITY
            }
        );
        for rate in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                TimeSeries::new(vec![1.0], rate),
                Err(ProcessError::InvalidRate(_))
            ));
        }
        assert!(
            TimeSeries::new(vec![1.0], 1.0)
                .unwrap()
                .with_start(f64::NAN)
                .is_err()
        );
    }

    #[test]
    fn records_check_lengths_and_rates() {
        let a = TimeSeries::named(vec![0.0; 4], 10.0, "a").unwrap();
        let b = TimeSeries::named(vec![0.0; 5], 10.0, "b").unwrap();
        let c = TimeSeries::named(vec![0.0; 4], 20.0, "c").unwrap();
        assert!(matches!(
            ImuRecord::new(vec![(Sensor::Gyroscope, a.clone()), (Sensor::Gyroscope, b)]),
            Err(ProcessError::LengthMismatch {
                len: 5,
                expected: 4,
                ..
            })
        ));
        assert!(ImuRecord::new(vec![(Sensor::Gyroscope, a), (Sensor::Gyroscope, c)]).is_err());
        assert!(ImuRecord::new(vec![]).is_err());
    }

    #[test]
    fn units_parse_and_reject() {
        assert_eq!("RAD/S".parse::<Unit>().unwrap(), Unit::RadPerSec);
        assert_eq!("m/s²".parse::<Unit>().unwrap(), Unit::MetrePerSec2);
        assert!("furlongs".parse::<Unit>().is_err());
    }
}
