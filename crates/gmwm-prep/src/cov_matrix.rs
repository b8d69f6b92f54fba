//! A dense symmetric matrix (row-major): the covariance of the AV estimates and of the
//! parameters, shared by the fit ([`crate::gmwm`]), the covariance of the AV estimator under a
//! model ([`crate::avcov`]) and the inference on a fit ([`crate::inference`]).

use crate::error::{FitError, Result};
use faer::Mat;
use serde::{Deserialize, Serialize};

/// A dense symmetric matrix (row-major), e.g. the covariance of the AV estimates.
///
/// ```
/// use gmwm_prep::gmwm::CovMatrix;
/// let c = CovMatrix::diagonal(&[1.0, 4.0]);
/// assert_eq!(c.get(1, 1), 4.0);
/// assert!(CovMatrix::new(2, vec![1.0; 3]).is_err());
/// # Ok::<(), gmwm_prep::FitError>(())
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CovMatrix {
    /// Dimension.
    pub n: usize,
    /// Entries, row-major, n².
    pub data: Vec<f64>,
}

impl CovMatrix {
    /// Checks the size and finiteness of the entries.
    ///
    /// ```
    /// use gmwm_prep::gmwm::CovMatrix;
    /// let c = CovMatrix::new(2, vec![2.0, 0.5, 0.5, 1.0])?;
    /// assert_eq!(c.get(0, 1), 0.5);
    /// assert!(CovMatrix::new(1, vec![f64::NAN]).is_err());
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn new(n: usize, data: Vec<f64>) -> Result<Self> {
        if data.len() != n * n {
            return Err(FitError::InvalidMatrix(format!(
                "{} entries for a {n}×{n} matrix",
                data.len()
            )));
        }
        if let Some(x) = data.iter().find(|x| !x.is_finite()) {
            return Err(FitError::InvalidMatrix(format!("non-finite entry {x}")));
        }
        Ok(Self { n, data })
    }
    /// A diagonal matrix.
    ///
    /// ```
    /// let c = gmwm_prep::gmwm::CovMatrix::diagonal(&[1.0, 4.0]);
    /// assert_eq!((c.n, c.data), (2, vec![1.0, 0.0, 0.0, 4.0]));
    /// ```
    pub fn diagonal(d: &[f64]) -> Self {
        let n = d.len();
        let mut data = vec![0.0; n * n];
        for i in 0..n {
            data[i * n + i] = d[i];
        }
        Self { n, data }
    }
    /// Entry (i, j).
    ///
    /// ```
    /// let c = gmwm_prep::gmwm::CovMatrix::new(2, vec![1.0, 2.0, 3.0, 4.0])?;
    /// assert_eq!((c.get(0, 1), c.get(1, 0)), (2.0, 3.0)); // row-major
    /// # Ok::<(), gmwm_prep::FitError>(())
    /// ```
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.data[i * self.n + j]
    }
    /// The diagonal.
    ///
    /// ```
    /// let c = gmwm_prep::gmwm::CovMatrix::diagonal(&[1.0, 4.0, 9.0]);
    /// assert_eq!(c.diag(), vec![1.0, 4.0, 9.0]);
    /// ```
    pub fn diag(&self) -> Vec<f64> {
        (0..self.n).map(|i| self.get(i, i)).collect()
    }
    pub(crate) fn to_mat(&self) -> Mat<f64> {
        Mat::from_fn(self.n, self.n, |i, j| self.get(i, j))
    }
    pub(crate) fn from_mat(m: &Mat<f64>) -> Self {
        let n = m.nrows();
        let mut data = Vec::with_capacity(n * n);
        for i in 0..n {
            for j in 0..n {
                data.push(m[(i, j)]);
            }
        }
        Self { n, data }
    }
}
