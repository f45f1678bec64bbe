//! Allan deviation: overlapping ADEV of rate samples.
//!
//! For `N` samples `y_i` at period `tau0` and averaging factor `m`
//! (`tau = m tau0`), with `S1`, `S2` the sums of two adjacent windows of `m`
//! samples starting at `i` and `i + m`:
//!
//! ```text
//! sigma^2(tau) = sum_{i=0}^{N-2m} (S2_i - S1_i)^2 / (2 m^2 (N - 2m + 1))
//! ```
//!
//! which is the usual phase form `(x_{i+2m} - 2 x_{i+m} + x_i)^2 / (2 tau^2)`
//! with `x` the integrated rate (NIST SP 1065, Eq. 11). The window sums
//! slide in O(1) per `i` (recomputed every 4,096 steps so rounding cannot
//! drift) after the mean is removed (a large offset would eat the f64
//! precision of the sums: see the Stable32 reference README).
//!
//! No heap: the caller owns the samples; each tau costs O(N).

use crate::real::Real;

/// One point of an Allan deviation curve.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AdevPoint {
    /// Averaging factor m.
    pub m: usize,
    /// Averaging time, s.
    pub tau_s: f64,
    /// Overlapping Allan deviation, in the samples' unit.
    pub adev: f64,
    /// Number of second differences averaged (`N - 2m + 1`).
    pub terms: usize,
}

/// Overlapping ADEV of `y` (period `tau0_s`) at averaging factor `m`.
/// `None` when `m == 0` or `2m > N` (no second difference fits), or when
/// a sample is not finite.
pub fn oadev<T: Real>(y: &[T], tau0_s: f64, m: usize) -> Option<AdevPoint> {
    let n = y.len();
    if m == 0 || 2 * m > n {
        return None;
    }
    let mut mean = 0.0;
    for v in y {
        let v = v.to_f64();
        if !v.is_finite() {
            return None;
        }
        mean += v;
    }
    mean /= n as f64;
    let at = |i: usize| y.get(i).map_or(0.0, |v| v.to_f64() - mean);
    let window = |start: usize| (start..start + m).map(at).sum::<f64>();
    let terms = n - 2 * m + 1;
    let mut s1 = window(0);
    let mut s2 = window(m);
    let mut acc = 0.0;
    for i in 0..terms {
        if i > 0 {
            if i % 4096 == 0 {
                s1 = window(i);
                s2 = window(i + m);
            } else {
                s1 += at(i + m - 1) - at(i - 1);
                s2 += at(i + 2 * m - 1) - at(i + m - 1);
            }
        }
        let d = s2 - s1;
        acc += d * d;
    }
    let m_f = m as f64;
    let var = acc / (2.0 * m_f * m_f * terms as f64);
    Some(AdevPoint {
        m,
        tau_s: m_f * tau0_s,
        adev: libm::sqrt(var),
        terms,
    })
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    #[test]
    fn nbs14_reference_values() {
        // NIST SP 1065 / allantools NBS14 10-point set (shared data README):
        // ADEV(1) = 91.22945 (non-overlapping = overlapping at m = 1),
        // OADEV(2) = 85.95287; tolerance 1e-6 relative (the references
        // have 7 digits).
        let y = [
            892.0_f64, 809.0, 823.0, 798.0, 671.0, 644.0, 883.0, 903.0, 677.0,
        ];
        let a1 = oadev(&y, 1.0, 1).unwrap().adev;
        let a2 = oadev(&y, 1.0, 2).unwrap().adev;
        assert!((a1 / 91.229_45 - 1.0).abs() < 1e-6, "{a1}");
        assert!((a2 / 85.952_87 - 1.0).abs() < 1e-6, "{a2}");
        assert!(oadev(&y, 1.0, 5).is_none());
    }

    #[test]
    fn sliding_sums_match_direct_sums() {
        // Long enough to cross the 4,096-step recompute.
        let y: Vec<f64> = (0..20_000)
            .map(|i| libm::sin(i as f64 * 0.37) + 1e3)
            .collect();
        for m in [1, 3, 64, 1000] {
            let fast = oadev(&y, 0.01, m).unwrap().adev;
            let mean = y.iter().sum::<f64>() / y.len() as f64;
            let mut acc = 0.0;
            let terms = y.len() - 2 * m + 1;
            for i in 0..terms {
                let s1: f64 = y[i..i + m].iter().map(|v| v - mean).sum();
                let s2: f64 = y[i + m..i + 2 * m].iter().map(|v| v - mean).sum();
                acc += (s2 - s1).powi(2);
            }
            let direct = (acc / (2.0 * (m * m) as f64 * terms as f64)).sqrt();
            assert!((fast / direct - 1.0).abs() < 1e-10, "m={m}");
        }
    }
}
