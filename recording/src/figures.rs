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
/// that shows it: "480 ms" under a second, "1.5 s" from one; a
/// non-finite one as "unknown".
pub fn duration(s: f64, digits: usize) -> String {
    if !s.is_finite() {
        return "unknown".into();
    }
    match s.abs() < 1.0 && s != 0.0 {
        true => format!("{} ms", sig(s * 1e3, digits)),
        false => format!("{} s", sig(s, digits)),
    }
}

#[cfg(test)]
mod tests {
    use super::{duration, sig};

    /// Each case: (value, digits, what `f` prints).
    fn prints(f: fn(f64, usize) -> String, cases: &[(f64, usize, &str)]) {
        for (x, d, want) in cases {
            assert_eq!(f(*x, *d), *want, "{x} to {d} digits");
        }
    }

    #[test]
    fn a_duration_under_a_second_prints_in_milliseconds() {
        prints(
            duration,
            &[
                (0.48, 2, "480 ms"),
                (0.0036, 2, "3.6 ms"),
                (1.5, 2, "1.5 s"),
                (114.0, 2, "114 s"),
                (f64::NAN, 2, "unknown"),
            ],
        );
    }

    #[test]
    fn small_values_keep_their_digits_and_zero_is_only_zero() {
        prints(
            sig,
            &[
                (0.000_062_8, 3, "6.28e-5"),
                (0.0036, 2, "0.0036"),
                (0.4, 2, "0.40"),
                (4.8, 2, "4.8"),
                (163.84, 3, "164"),
                (-2.5e7, 2, "-2.5e7"),
                (0.0, 3, "0"),
                (f64::NAN, 3, "unknown"),
            ],
        );
    }
}
