// Double-double arithmetic for extended-precision references in tests (a copy of the
// crate-private `dd` module: TwoSum / FMA TwoProd, ~32 digits).

use std::ops::{Add, Mul, Neg, Sub};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dd {
    pub hi: f64,
    pub lo: f64,
}

pub fn two_sum(a: f64, b: f64) -> (f64, f64) {
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
    pub const ZERO: Dd = Dd { hi: 0.0, lo: 0.0 };
    pub fn from(x: f64) -> Dd {
        Dd { hi: x, lo: 0.0 }
    }
    pub fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
    /// self / other, one Newton correction (relative error ~1e-31).
    pub fn div(self, other: Dd) -> Dd {
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

impl Dd {
    /// self^n by binary exponentiation.
    pub fn powu(self, mut n: u64) -> Dd {
        let mut base = self;
        let mut acc = Dd::from(1.0);
        while n > 0 {
            if n & 1 == 1 {
                acc = acc * base;
            }
            base = base * base;
            n >>= 1;
        }
        acc
    }
    /// e^x for |x| ≤ 1 by its Taylor series (terms down to 1e-34).
    pub fn exp_small(x: f64) -> Dd {
        assert!(x.abs() <= 1.0);
        let mut term = Dd::from(1.0);
        let mut sum = Dd::from(1.0);
        for k in 1..60 {
            term = (term * Dd::from(x)).div(Dd::from(k as f64));
            sum = sum + term;
            if term.hi.abs() < 1e-34 {
                break;
            }
        }
        sum
    }
}
