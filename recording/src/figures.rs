//! Figures as a person reads them: a value printed with its significant
//! digits, never rounded to a zero it is not.

/// `x` with `digits` significant digits: fixed notation from 1e-3 to
/// 1e6, scientific outside (so 0.0000628 prints as 6.28e-5, never 0); a
/// zero prints as 0, a non-finite value as "unknown".
pub fn sig(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return "unknown".into();
    }
    if x == 0.0 {
        return "0".into();
    }
    let digits = digits.max(1);
    let mag = x.abs().log10().floor() as i32;
    if !(-3..6).contains(&mag) {
        return format!("{:.*e}", digits - 1, x);
    }
    let decimals = (digits as i32 - 1 - mag).max(0) as usize;
    format!("{x:.decimals$}")
}

/// A duration `s` (seconds) with `digits` significant digits in the unit
/// that shows it: "480 ms" under a second, "1.5 s" from one.
pub fn duration(s: f64, digits: usize) -> String {
    match s.is_finite() && s.abs() < 1.0 && s != 0.0 {
        true => format!("{} ms", sig(s * 1e3, digits)),
        false => format!("{} s", sig(s, digits)),
    }
}

#[cfg(test)]
mod tests {
    use super::{duration, sig};

    #[test]
    fn a_duration_under_a_second_prints_in_milliseconds() {
        assert_eq!(duration(0.48, 2), "480 ms");
        assert_eq!(duration(0.0036, 2), "3.6 ms");
        assert_eq!(duration(1.5, 2), "1.5 s");
        assert_eq!(duration(114.0, 2), "114 s");
        assert_eq!(duration(f64::NAN, 2), "unknown s");
    }

    #[test]
    fn small_values_keep_their_digits_and_zero_is_only_zero() {
        assert_eq!(sig(0.000_062_8, 3), "6.28e-5");
        assert_eq!(sig(0.0036, 2), "0.0036");
        assert_eq!(sig(0.4, 2), "0.40");
        assert_eq!(sig(4.8, 2), "4.8");
        assert_eq!(sig(163.84, 3), "164");
        assert_eq!(sig(-2.5e7, 2), "-2.5e7");
        assert_eq!(sig(0.0, 3), "0");
        assert_eq!(sig(f64::NAN, 3), "unknown");
    }
}
