//! Numbers for people: a fixed count of significant digits, in plain or exponent form,
//! whichever reads better. Full precision stays in JSON and CSV; everything a person reads
//! (the console, the report, comments in config files, model strings) goes through
//! [`sig`].

/// `x` rounded to `digits` significant digits (at least 1), trailing zeros dropped: plain
/// notation for 1e-3 ≤ |x| < 1e5, exponent notation (`1.235e-7`) outside, `0` for zero and
/// `NaN`/`inf`/`-inf` as Rust prints them.
///
/// ```
/// use processes::number::sig;
/// assert_eq!(sig(0.5999999999999754, 4), "0.6");
/// assert_eq!(sig(0.14956357938941936, 4), "0.1496");
/// assert_eq!(sig(1234.56, 4), "1235");
/// assert_eq!(sig(123456.0, 4), "1.235e5");
/// assert_eq!(sig(-2.5e-7, 4), "-2.5e-7");
/// assert_eq!(sig(0.0, 4), "0");
/// assert_eq!(sig(99.996, 4), "100"); // rounding carries into a new digit
/// assert_eq!(sig(f64::NAN, 4), "NaN");
/// ```
pub fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == 0.0 {
        return "0".into();
    }
    let d = digits.max(1);
    // the exponent after rounding to d digits (rounding can carry 9.9995 into 10.00)
    let e = {
        let s = format!("{:.*e}", d - 1, x);
        let exp: i32 = s
            .split('e')
            .nth(1)
            .and_then(|t| t.parse().ok())
            .unwrap_or(0);
        exp
    };
    if (-3..5).contains(&e) {
        let decimals = (d as i32 - 1 - e).max(0) as usize;
        trim_zeros(format!("{x:.decimals$}"))
    } else {
        let s = format!("{:.*e}", d - 1, x);
        let (mant, exp) = s.split_once('e').unwrap_or((&s, "0"));
        format!("{}e{exp}", trim_zeros(mant.to_string()))
    }
}

/// Drops trailing zeros after a decimal point, and the point itself when nothing follows.
fn trim_zeros(s: String) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::sig;

    /// Round trip: the printed value is within half a unit of the d-th digit of x.
    #[test]
    fn rounding_error_is_within_half_a_unit_of_the_last_digit() {
        let mut x = 1.234_567_891e-12;
        while x < 1e12 {
            for d in 1..=8 {
                let back: f64 = sig(x, d).parse().unwrap();
                let ulp = 10f64.powi(x.log10().floor() as i32 - d as i32 + 1);
                assert!(
                    (back - x).abs() <= 0.5 * ulp * (1.0 + 1e-12),
                    "{x} {d}: {back}"
                );
                assert!(!sig(-x, d).is_empty() && sig(-x, d).starts_with('-'));
            }
            x *= 7.3;
        }
    }
}
