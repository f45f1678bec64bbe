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
//!
//! Confidence intervals: chi-square with the equivalent degrees of freedom
//! of white FM noise (the white rate noise of a gyro or accelerometer;
//! NIST SP 1065 Table 5 for the overlapping ADEV, `M - 1` for the
//! non-overlapping one), 68.3 % two-sided, chi-square quantiles by
//! Wilson-Hilferty (good to ~1 % of the bound for edf >= 3).
//!
//! Noise fit (IEEE Std 952-1997 Annex C): `sigma^2(tau) = N^2 / tau +
//! (2 ln 2 / pi) B^2 + K^2 tau / 3`, fitted to the curve by least squares on
//! `sigma^2` weighted by its variance `2 sigma^4 / edf` (edf capped at
//! [`FIT_EDF_CAP`] so every octave counts), each coefficient
//! kept non-negative (every subset of the three terms is tried). `N` is the
//! white-noise density (ARW in rad/sqrt(s), VRW in m/s/sqrt(s)), `B` the
//! bias-instability coefficient (the Allan floor is `0.664 B`), `K` the
//! rate random walk.

use crate::real::Real;

/// One point of an Allan deviation curve.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct AdevPoint {
    /// Averaging factor m.
    pub m: usize,
    /// Averaging time, s.
    pub tau_s: f64,
    /// Allan deviation, in the samples' unit.
    pub adev: f64,
    /// Number of second differences averaged.
    pub terms: usize,
    /// Equivalent degrees of freedom (white FM).
    pub edf: f64,
    /// Lower end of the 68.3 % confidence interval.
    pub lo: f64,
    /// Upper end of the 68.3 % confidence interval.
    pub hi: f64,
}

/// Chi-square quantile for probability `p` (lower tail) with `nu` degrees
/// of freedom, Wilson-Hilferty: `nu (1 - 2/(9 nu) + z sqrt(2/(9 nu)))^3`.
fn chi2_quantile(z_p: f64, nu: f64) -> f64 {
    let a = 2.0 / (9.0 * nu);
    let c = 1.0 - a + z_p * libm::sqrt(a);
    nu * c * c * c
}

/// Fills the confidence interval of `p` from its `edf`.
fn with_interval(mut p: AdevPoint) -> AdevPoint {
    // z for 15.87 % / 84.13 %: +-1 (68.3 % two-sided).
    let nu = p.edf.max(1.0);
    let lo_q = chi2_quantile(1.0, nu);
    let hi_q = chi2_quantile(-1.0, nu).max(1e-12);
    p.lo = p.adev * libm::sqrt(nu / lo_q);
    p.hi = p.adev * libm::sqrt(nu / hi_q);
    p
}

/// The mean of `y` in f64; `None` if a sample is not finite or `y` is empty.
fn finite_mean<T: Real>(y: &[T]) -> Option<f64> {
    let mut sum = 0.0;
    for v in y {
        let v = v.to_f64();
        if !v.is_finite() {
            return None;
        }
        sum += v;
    }
    (!y.is_empty()).then(|| sum / y.len() as f64)
}

/// Overlapping ADEV of `y` (period `tau0_s`) at averaging factor `m`.
/// `None` when `m == 0` or `2m > N` (no second difference fits), or when
/// a sample is not finite.
pub fn oadev<T: Real>(y: &[T], tau0_s: f64, m: usize) -> Option<AdevPoint> {
    let n = y.len();
    if m == 0 || 2 * m > n {
        return None;
    }
    let mean = finite_mean(y)?;
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
    // SP 1065 Table 5, white FM, N phase points = samples + 1.
    let n_ph = n as f64 + 1.0;
    let edf = ((3.0 * (n_ph - 1.0) / (2.0 * m_f) - 2.0 * (n_ph - 2.0) / n_ph) * 4.0 * m_f * m_f
        / (4.0 * m_f * m_f + 5.0))
        .max(1.0);
    Some(with_interval(AdevPoint {
        m,
        tau_s: m_f * tau0_s,
        adev: libm::sqrt(var),
        terms,
        edf,
        lo: 0.0,
        hi: 0.0,
    }))
}

/// Non-overlapping ADEV of `y` at averaging factor `m`: the block means
/// `ybar_k` of `M = floor(N/m)` blocks, `sigma^2 = sum (ybar_{k+1} -
/// ybar_k)^2 / (2 (M - 1))`. `None` when fewer than two blocks fit or a
/// sample is not finite.
pub fn adev<T: Real>(y: &[T], tau0_s: f64, m: usize) -> Option<AdevPoint> {
    if m == 0 {
        return None;
    }
    let blocks = y.len() / m;
    if blocks < 2 {
        return None;
    }
    let mean = finite_mean(y)?;
    let block = |k: usize| {
        y.iter()
            .skip(k * m)
            .take(m)
            .map(|v| v.to_f64() - mean)
            .sum::<f64>()
            / m as f64
    };
    let mut prev = block(0);
    let mut acc = 0.0;
    for k in 1..blocks {
        let b = block(k);
        acc += (b - prev) * (b - prev);
        prev = b;
    }
    let terms = blocks - 1;
    Some(with_interval(AdevPoint {
        m,
        tau_s: m as f64 * tau0_s,
        adev: libm::sqrt(acc / (2.0 * terms as f64)),
        terms,
        edf: terms as f64,
        lo: 0.0,
        hi: 0.0,
    }))
}

/// Averaging factors 1, 2, 4, ... up to the largest with at least
/// `min_terms` second differences for `n` samples (octave taus).
pub fn octave_factors(n: usize, min_terms: usize) -> impl Iterator<Item = usize> {
    (0..usize::BITS)
        .map(|k| 1usize << k)
        .take_while(move |m| n >= 2 * m + min_terms.saturating_sub(1))
}

/// The largest edf a point weighs with in [`fit_noise`].
pub const FIT_EDF_CAP: f64 = 50.0;

/// The three-term noise model fitted to an Allan curve.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct NoiseFit {
    /// White-noise density N, unit x sqrt(s) (ARW rad/sqrt(s), VRW m/s/sqrt(s)).
    pub white: f64,
    /// Bias-instability coefficient B, unit (Allan floor 0.664 B).
    pub bias_instability: f64,
    /// Rate random walk K, unit / sqrt(s).
    pub rrw: f64,
}

impl NoiseFit {
    /// The model's ADEV at `tau_s`.
    pub fn adev_at(&self, tau_s: f64) -> f64 {
        let b2 = 2.0 * core::f64::consts::LN_2 / core::f64::consts::PI;
        libm::sqrt(
            self.white * self.white / tau_s
                + b2 * self.bias_instability * self.bias_instability
                + self.rrw * self.rrw * tau_s / 3.0,
        )
    }
}

/// Fits [`NoiseFit`] to `points` (weighted, non-negative; see module docs).
/// `None` with no usable point.
pub fn fit_noise(points: &[AdevPoint]) -> Option<NoiseFit> {
    // Relative weight of a point: its edf, capped so the thousands of
    // degrees of freedom at short tau cannot drown the floor and the slope
    // at long tau (the model is only an approximation of a real sensor).
    let weight = |p: &AdevPoint| p.edf.clamp(1.0, FIT_EDF_CAP);
    use nalgebra::{Matrix3, Vector3};
    let b2 = 2.0 * core::f64::consts::LN_2 / core::f64::consts::PI;
    let basis = |tau: f64| Vector3::new(1.0 / tau, b2, tau / 3.0);
    let usable = || {
        points
            .iter()
            .filter(|p| p.adev > 0.0 && p.adev.is_finite() && p.tau_s > 0.0)
    };
    usable().next()?;
    let mut best: Option<(f64, Vector3<f64>)> = None;
    for mask in 1u8..8 {
        // Active terms as a 0/1 vector; inactive ones get a unit diagonal.
        let on = Vector3::new(
            f64::from(mask & 1),
            f64::from((mask >> 1) & 1),
            f64::from((mask >> 2) & 1),
        );
        let mut a = Matrix3::from_diagonal(&on.map(|x| 1.0 - x));
        let mut rhs = Vector3::zeros();
        for p in usable() {
            let v = p.adev * p.adev;
            let w = weight(p) / (v * v);
            let f = basis(p.tau_s).component_mul(&on);
            a += f * f.transpose() * w;
            rhs += f * (w * v);
        }
        let Some(x) = a.cholesky().map(|c| c.solve(&rhs)) else {
            continue;
        };
        if x.iter().any(|c| *c < 0.0 || !c.is_finite()) {
            continue;
        }
        let cost: f64 = usable()
            .map(|p| {
                let v = p.adev * p.adev;
                let model = basis(p.tau_s).dot(&x);
                weight(p) * (model - v) * (model - v) / (v * v)
            })
            .sum();
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, x));
        }
    }
    best.map(|(_, x)| NoiseFit {
        white: libm::sqrt(x.x),
        bias_instability: libm::sqrt(x.y),
        rrw: libm::sqrt(x.z),
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
