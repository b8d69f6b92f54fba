//! Compensated and fixed-order summation: Neumaier's running sum, the exact two-sum, and the
//! fixed pairwise reduction of [`LANES`] accumulators that every kernel ends its lanes with (so
//! that no sum depends on the SIMD width or the thread count).

/// Number of independent accumulator lanes in the inner loops.
pub(crate) const LANES: usize = 16;

/// Neumaier's compensated accumulator.
#[derive(Clone, Copy, Default, Debug)]
pub(crate) struct Neumaier {
    pub(crate) hi: f64,
    pub(crate) lo: f64,
}

impl Neumaier {
    #[inline(always)]
    pub(crate) fn add(&mut self, x: f64) {
        let t = self.hi + x;
        if self.hi.abs() >= x.abs() {
            self.lo += (self.hi - t) + x;
        } else {
            self.lo += (x - t) + self.hi;
        }
        self.hi = t;
    }
    #[inline(always)]
    pub(crate) fn value(&self) -> f64 {
        self.hi + self.lo
    }
}

/// The fixed pairwise reduction of [`LANES`] accumulators.
#[inline(always)]
pub(crate) fn reduce_lanes(acc: &[f64; LANES]) -> f64 {
    // fixed pairwise tree
    let mut v = *acc;
    let mut w = LANES;
    while w > 1 {
        w /= 2;
        for i in 0..w {
            v[i] += v[i + w];
        }
    }
    v[0]
}

#[inline(always)]
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}
