//! Confidence intervals of the Allan variance.

use crate::Cumulative;
use crate::config::AvarConfig;
use crate::error::AvarError;
use crate::result::AvarPoint;

/// Fills the CI fields of `points` according to `config.ci`.
pub(crate) fn apply(
    _cum: &Cumulative<'_>,
    _config: &AvarConfig,
    _points: &mut [AvarPoint],
) -> Result<(), AvarError> {
    Ok(())
}
