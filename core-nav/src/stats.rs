//! Sample statistics, one home for every tool: mean, root mean square,
//! median and percentiles (linear interpolation between order statistics,
//! Hyndman & Fan's definition 7, the default of numpy, R and Julia).
//! `no_std`, no heap: the order statistics sort the caller's slice in place.

/// Mean of `v` (NaN for an empty slice).
pub fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.iter().sum::<f64>() / v.len() as f64
}

/// Root mean square of `v` (NaN for an empty slice).
pub fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    libm::sqrt(v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64)
}

/// The `p`-th percentile (`p` in [0, 100]) of `v`, sorted in place: the
/// order statistics at ranks `floor(h)` and `floor(h) + 1`, `h = (n - 1) p
/// / 100`, interpolated. NaN for an empty slice, a `p` outside [0, 100]
/// or a NaN in `v`.
pub fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() || !(0.0..=100.0).contains(&p) || v.iter().any(|x| x.is_nan()) {
        return f64::NAN;
    }
    v.sort_unstable_by(f64::total_cmp);
    let h = (v.len() - 1) as f64 * p / 100.0;
    let lo = libm::floor(h);
    let i = lo as usize;
    match (v.get(i), v.get(i + 1)) {
        (Some(a), Some(b)) => a + (h - lo) * (b - a),
        (Some(a), None) => *a,
        _ => f64::NAN,
    }
}

/// The median of `v`, sorted in place: the middle value, or the mean of
/// the two middle ones for an even count (NaN for an empty slice).
pub fn median(v: &mut [f64]) -> f64 {
    percentile(v, 50.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_an_even_count_is_the_mean_of_the_middle_two() {
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut [5.0, 1.0, 3.0]), 3.0);
        assert!(median(&mut []).is_nan());
    }

    #[test]
    fn percentiles_match_numpys_default() {
        // numpy.percentile([1, 2, 3, 4, 10], [0, 25, 90, 100]) with its
        // default linear method: 1, 2, 7.6, 10.
        let mut v = [10.0, 1.0, 4.0, 2.0, 3.0];
        for (p, want) in [(0.0, 1.0), (25.0, 2.0), (90.0, 7.6), (100.0, 10.0)] {
            assert!((percentile(&mut v, p) - want).abs() < 1e-12, "{p}");
        }
        assert!(percentile(&mut v, 101.0).is_nan());
        assert!(percentile(&mut [1.0, f64::NAN], 50.0).is_nan());
    }

    #[test]
    fn mean_and_rms() {
        assert_eq!(mean(&[1.0, 2.0, 6.0]), 3.0);
        assert_eq!(rms(&[3.0, 4.0, 0.0, 0.0]), 2.5);
        assert!(mean(&[]).is_nan() && rms(&[]).is_nan());
    }
}
