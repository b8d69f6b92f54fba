// Extended-precision helpers for the reference tests, on top of the crate's own
// double-double type (compiled into the test crate from src/dd.rs by `common::dd`).

use super::dd::Dd;

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
