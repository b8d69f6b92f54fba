//! Minimal double-double arithmetic (value = hi + lo, ~32 significant digits), used where
//! a sum is ill-conditioned in f64 (the Lemma 4.2 sum of an AR1 with φ near −1).
//! Algorithms: Knuth's TwoSum and an FMA-based TwoProd (Dekker/Shewchuk).

use std::ops::{Add, Mul, Neg, Sub};

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Dd {
    pub hi: f64,
    pub lo: f64,
}

fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

fn fast_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    (p, a.mul_add(b, -p))
}

impl Dd {
    pub(crate) fn from(x: f64) -> Dd {
        Dd { hi: x, lo: 0.0 }
    }
    pub(crate) fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
    /// self / other, one Newton correction (relative error ~1e-31).
    pub(crate) fn div(self, other: Dd) -> Dd {
        let q1 = self.hi / other.hi;
        let r = self - other * Dd::from(q1);
        let q2 = r.hi / other.hi;
        let r2 = r - other * Dd::from(q2);
        let q3 = r2.hi / other.hi;
        let (s, e) = fast_two_sum(q1, q2);
        Dd { hi: s, lo: e } + Dd::from(q3)
    }
}

impl Add for Dd {
    type Output = Dd;
    fn add(self, o: Dd) -> Dd {
        let (s, e) = two_sum(self.hi, o.hi);
        let (t, f) = two_sum(self.lo, o.lo);
        let (s, e) = fast_two_sum(s, e + t);
        let (hi, lo) = fast_two_sum(s, e + f);
        Dd { hi, lo }
    }
}

impl Neg for Dd {
    type Output = Dd;
    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

impl Sub for Dd {
    type Output = Dd;
    fn sub(self, o: Dd) -> Dd {
        self + (-o)
    }
}

impl Mul for Dd {
    type Output = Dd;
    fn mul(self, o: Dd) -> Dd {
        let (p, e) = two_prod(self.hi, o.hi);
        let e = e + (self.hi * o.lo + self.lo * o.hi);
        let (hi, lo) = fast_two_sum(p, e);
        Dd { hi, lo }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dd_keeps_digits_that_f64_loses() {
        // (1 + 2^-60) − 1 = 2^-60 exactly in dd, 0 in f64.
        let x = Dd::from(1.0) + Dd::from(2f64.powi(-60));
        assert_eq!((x - Dd::from(1.0)).to_f64(), 2f64.powi(-60));
        // (1/3)·3 = 1 to ~1e-31.
        let third = Dd::from(1.0).div(Dd::from(3.0));
        let one = third * Dd::from(3.0) - Dd::from(1.0);
        assert!(one.to_f64().abs() < 1e-31); // ~2^-104 relative: double-double precision
        // (1 + ε)² − 1 − 2ε = ε² with ε = 2^-40: needs the product's low part.
        let e = 2f64.powi(-40);
        let y = (Dd::from(1.0) + Dd::from(e)) * (Dd::from(1.0) + Dd::from(e));
        let r = y - Dd::from(1.0) - Dd::from(2.0 * e);
        assert_eq!(r.to_f64(), e * e);
    }
}
