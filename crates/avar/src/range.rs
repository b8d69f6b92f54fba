//! Huge and tiny magnitudes: exact power-of-two rescaling around the estimators.
//!
//! Every estimator of the family is homogeneous of degree two: AV(c·x) = c²·AV(x), and for
//! c = 2^k every operation of the kernel (sums, differences, products, divisions by counts) is
//! exact under the scaling as long as no intermediate leaves the normal range of f64. Samples
//! near 1e300 (a unit mix-up, a corrupt column) overflow the squares, and samples near 1e-300
//! underflow them to zero, so the estimate is computed on x·2^−e, with 2^e the magnitude of the
//! largest sample, and scaled back by 2^2e. Results are therefore exactly scale-equivariant:
//! AV(2^k·x) = 4^k·AV(x) bit for bit, for every k whose values are representable.
//!
//! The common case pays nothing: the estimate is first computed as is, and only when its values
//! lie outside [2^−300, 2^300] (or overflowed) is the magnitude of the data looked at.

use crate::AvarError;

/// Values of the AV inside this range (and no overflow) prove that no intermediate of the
/// estimate (squares, fourth powers in the Gaussian CI) left the normal range of f64.
const TRUST_LO: f64 = f64::from_bits((1023 - 300) << 52); // 2^-300
const TRUST_HI: f64 = f64::from_bits((1023 + 300) << 52); // 2^300

/// Data whose largest magnitude lies in [2^−128, 2^128] are estimated as they are.
const SAFE_EXP: i32 = 128;

/// x·2^n, exact whenever the result is a normal number (n may exceed the exponent range of a
/// single power of two: the factor is applied in steps that are each representable).
pub(crate) fn ldexp(mut x: f64, mut n: i32) -> f64 {
    while n != 0 {
        let step = n.clamp(-1000, 1000);
        x *= f64::from_bits(((1023 + step) as u64) << 52);
        n -= step;
    }
    x
}

/// Binary exponent e of the largest |x| (so that max|x|·2^−e lies in [1, 2)), or `None` when
/// every sample is zero.
fn max_exponent(data: &[f64]) -> Option<i32> {
    let max = data.iter().fold(0.0_f64, |a, &x| a.max(x.abs()));
    if max == 0.0 || !max.is_finite() {
        return None;
    }
    // exponent of a subnormal: scale it into the normal range first (exact)
    let (v, shift) = if max < f64::MIN_POSITIVE {
        (max * 2f64.powi(64), 64)
    } else {
        (max, 0)
    };
    Some(((v.to_bits() >> 52) & 0x7ff) as i32 - 1023 - shift)
}

/// The scaled parts of a point: the bounds of the variance, the variance, the bounds of the
/// deviation, the deviation.
pub(crate) type Parts<'a> = (
    [&'a mut Option<f64>; 2],
    &'a mut f64,
    [&'a mut Option<f64>; 2],
    &'a mut f64,
);

/// A point of an estimate whose values are quadratic in the data (a variance, its bounds) or
/// linear (the deviation and its bounds): the AV and every member of the stability family
/// (each implements it with [`quadratic_point!`], naming its fields).
pub(crate) trait Quadratic {
    /// Cluster size (samples).
    fn m(&self) -> u64;
    /// The variance and its bounds.
    fn variances(&self) -> [Option<f64>; 3];
    /// The variance and its bounds, and the deviation and its bounds, to scale.
    fn parts(&mut self) -> Parts<'_>;
}

/// Implements [`Quadratic`] for a point type from the names of its fields:
/// `quadratic_point!(Type: var, var_lo, var_hi; dev, dev_lo, dev_hi)` (and a field `m`).
macro_rules! quadratic_point {
    ($ty:ty: $var:ident, $lo:ident, $hi:ident; $dev:ident, $dev_lo:ident, $dev_hi:ident) => {
        impl $crate::range::Quadratic for $ty {
            fn m(&self) -> u64 {
                self.m
            }
            fn variances(&self) -> [Option<f64>; 3] {
                [Some(self.$var), self.$lo, self.$hi]
            }
            fn parts(&mut self) -> $crate::range::Parts<'_> {
                (
                    [&mut self.$lo, &mut self.$hi],
                    &mut self.$var,
                    [&mut self.$dev_lo, &mut self.$dev_hi],
                    &mut self.$dev,
                )
            }
        }
    };
}
pub(crate) use quadratic_point;

quadratic_point!(crate::AvarPoint: avar, avar_lo, avar_hi; adev, adev_lo, adev_hi);

/// Whether the first estimate may have lost digits to overflow or underflow.
pub(crate) fn suspicious<P: Quadratic>(first: Result<&[P], &AvarError>) -> bool {
    match first {
        Err(AvarError::Overflow) => true,
        Err(_) => false,
        Ok(points) => points.iter().any(|p| {
            let out = |v: f64| !v.is_finite() || v.abs() > TRUST_HI || v.abs() < TRUST_LO;
            let [v, lo, hi] = p.variances();
            v.is_some_and(out) || lo.is_some_and(|v| v != 0.0 && out(v)) || hi.is_some_and(out)
        }),
    }
}

/// The power-of-two exponent to take out of the data before estimating, when its magnitude is
/// outside [2^−128, 2^128]; `None` when the data can be estimated as they are.
pub(crate) fn rescale_exponent(data: &[f64]) -> Option<i32> {
    max_exponent(data).filter(|e| e.abs() > SAFE_EXP)
}

/// The data times 2^−e (exact: every result is a normal number of magnitude below 2).
pub(crate) fn scaled_copy(data: &[f64], e: i32) -> Vec<f64> {
    data.iter().map(|&x| ldexp(x, -e)).collect()
}

/// Scales the points of an estimate of the data times 2^−e back to the data's units, checking
/// that every value is representable: a variance beyond the range of f64 is an error that says
/// how large it is.
pub(crate) fn scale_back<P: Quadratic>(points: &mut [P], e: i32) -> Result<(), AvarError> {
    for p in points {
        let m = p.m();
        let check = |scaled: f64| -> Result<f64, AvarError> {
            let v = ldexp(scaled, 2 * e);
            let lost = !v.is_finite() || (scaled != 0.0 && v.abs() < f64::MIN_POSITIVE);
            if lost {
                return Err(AvarError::NotRepresentable {
                    m,
                    log10: scaled.abs().log10() + 2.0 * e as f64 * std::f64::consts::LOG10_2,
                });
            }
            Ok(v)
        };
        let (bounds, var, dev_bounds, dev) = p.parts();
        *var = check(*var)?;
        for b in bounds {
            *b = b.map(check).transpose()?;
        }
        *dev = ldexp(*dev, e);
        for b in dev_bounds {
            *b = b.map(|v| ldexp(v, e));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ldexp_is_exact_across_the_range() {
        assert_eq!(TRUST_LO, 2f64.powi(-300));
        assert_eq!(TRUST_HI, 2f64.powi(300));
        assert_eq!(ldexp(1.5, 1500), f64::INFINITY);
        assert_eq!(ldexp(ldexp(1.5, -1060), 1060), 1.5); // through a subnormal and back
        assert_eq!(ldexp(3.0, -1), 1.5);
        assert_eq!(ldexp(f64::MAX, -1023), f64::MAX / 2f64.powi(1023));
    }

    #[test]
    fn exponent_of_the_largest_sample() {
        assert_eq!(max_exponent(&[0.0, -3.0, 2.0]), Some(1));
        assert_eq!(max_exponent(&[0.0, 0.0]), None);
        assert_eq!(max_exponent(&[1e300]), Some(996));
        assert_eq!(max_exponent(&[f64::MIN_POSITIVE / 4.0]), Some(-1024));
        assert_eq!(rescale_exponent(&[1e30, -2.0]), None);
        assert_eq!(rescale_exponent(&[1e-300]), Some(-997));
    }
}
