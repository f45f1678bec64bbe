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
//! Noise fit (IEEE Std 952-1997 Annex C, with a Gauss-Markov bias):
//! `sigma^2(tau) = N^2 / tau + (2 ln 2 / pi) F^2 + K^2 tau / 3 + s^2
//! gm(tau, T)`, fitted to the curve by least squares on `sigma^2` weighted
//! by its variance `2 sigma^4 / edf` (edf capped at [`FIT_EDF_CAP`] so every
//! octave counts), each coefficient kept non-negative (every subset of the
//! four terms is tried, `T` on a grid, the subset by AIC). `N` is the
//! white-noise density (ARW in rad/sqrt(s), VRW in m/s/sqrt(s)), `F` the
//! flicker coefficient, `K` the rate random walk, `s` and `T` a
//! Gauss-Markov bias ([`gm_avar`]). The bias instability is defined once:
//! the fitted curve's floor over 0.664 ([`FLOOR_OVER_B`]).

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
    oadev_segments(y, tau0_s, m, core::slice::from_ref(&(0..y.len())))
}

/// [`oadev`] of a series with gaps: `segments` are the index ranges of `y`
/// sampled without a gap; no difference straddles one. Each segment long
/// enough (`2m` samples) adds its squared second differences and its
/// equivalent degrees of freedom; `None` when none is, when `m == 0`, or
/// when a sample is not finite. One segment over all of `y` is [`oadev`].
pub fn oadev_segments<T: Real>(
    y: &[T],
    tau0_s: f64,
    m: usize,
    segments: &[core::ops::Range<usize>],
) -> Option<AdevPoint> {
    if m == 0 {
        return None;
    }
    let mean = finite_mean(y)?;
    let (mut acc, mut terms, mut edf) = (0.0, 0usize, 0.0);
    for sg in segments {
        let Some(part) = y.get(sg.clone()) else {
            continue;
        };
        if let Some((a, t)) = second_differences(part, m, mean) {
            acc += a;
            terms += t;
            edf += oadev_edf(part.len(), m);
        }
    }
    if terms == 0 {
        return None;
    }
    let m_f = m as f64;
    let var = acc / (2.0 * m_f * m_f * terms as f64);
    Some(with_interval(AdevPoint {
        m,
        tau_s: m_f * tau0_s,
        adev: libm::sqrt(var),
        terms,
        edf: edf.max(1.0),
        lo: 0.0,
        hi: 0.0,
    }))
}

/// The sum of squared overlapping second differences of `y`'s `m`-sums
/// (about `mean`) and their count; `None` when `2m > N`. The `m`-sums are
/// sliding sums, recomputed every 4096 steps (or every `16 m`, so that a
/// recompute's `2m` additions stay an eighth of the steps between them)
/// so that rounding does not build up.
fn second_differences<T: Real>(y: &[T], m: usize, mean: f64) -> Option<(f64, usize)> {
    let n = y.len();
    if m == 0 || 2 * m > n {
        return None;
    }
    let at = |i: usize| y.get(i).map_or(0.0, |v| v.to_f64() - mean);
    let window = |start: usize| (start..start + m).map(at).sum::<f64>();
    let terms = n - 2 * m + 1;
    let mut s1 = window(0);
    let mut s2 = window(m);
    let mut acc = 0.0;
    // The three samples each step adds and drops, as slices: no bounds
    // test in the loop (`terms + 2m - 1 = n`).
    let (lo, mid, hi) = (
        y.get(..terms)?,
        y.get(m..m + terms)?,
        y.get(2 * m..2 * m + terms - 1)?,
    );
    let every = 4096usize.max(16 * m);
    for i in 0..terms {
        if i > 0 {
            if i % every == 0 {
                s1 = window(i);
                s2 = window(i + m);
            } else {
                let (out1, mid1, in2) = (
                    lo.get(i - 1).map_or(0.0, |v| v.to_f64()),
                    mid.get(i - 1).map_or(0.0, |v| v.to_f64()),
                    hi.get(i - 1).map_or(0.0, |v| v.to_f64()),
                );
                s1 += (mid1 - mean) - (out1 - mean);
                s2 += (in2 - mean) - (mid1 - mean);
            }
        }
        let d = s2 - s1;
        acc += d * d;
    }
    Some((acc, terms))
}

/// Equivalent degrees of freedom of an overlapping ADEV over `n` samples
/// at factor `m` (SP 1065 Table 5, white FM, N phase points = samples + 1).
fn oadev_edf(n: usize, m: usize) -> f64 {
    let m_f = m as f64;
    let n_ph = n as f64 + 1.0;
    ((3.0 * (n_ph - 1.0) / (2.0 * m_f) - 2.0 * (n_ph - 2.0) / n_ph) * 4.0 * m_f * m_f
        / (4.0 * m_f * m_f + 5.0))
        .max(1.0)
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

/// The noise model fitted to an Allan curve.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct NoiseFit {
    /// White-noise density N, unit x sqrt(s) (ARW rad/sqrt(s), VRW m/s/sqrt(s)).
    pub white: f64,
    /// 1-sigma of `white` (same unit), from the fit.
    pub white_sigma: f64,
    /// Flicker coefficient, unit (its Allan floor is `0.664` times it).
    pub flicker: f64,
    /// Rate random walk K, unit / sqrt(s).
    pub rrw: f64,
    /// Gauss-Markov bias: its standard deviation, unit (0: none fitted).
    pub gm_sigma: f64,
    /// Gauss-Markov correlation time, s (0 when `gm_sigma` is 0).
    pub gm_tau_s: f64,
    /// Bias instability, unit: the fitted curve's floor (where it first
    /// stops falling over the points' taus) over 0.664 (IEEE Std 952: the floor of a flicker
    /// bias is 0.664 B), the one definition every tool reports.
    pub bias_instability: f64,
    /// Whether the points show the floor `bias_instability` comes from:
    /// the fitted curve's minimum lies before the longest tau, or the fit
    /// holds a flicker term (a flat stretch). Otherwise the curve still
    /// falls at the longest tau and `bias_instability` is only an upper
    /// bound: a term the data cannot support, never to be reported as
    /// measured.
    pub floor_seen: bool,
    /// The longest averaging time the points reach, s.
    pub tau_max_s: f64,
    /// The averaging time where the fitted curve is lowest, s.
    pub floor_tau_s: f64,
}

/// `(2 ln 2 / pi)`: a flicker coefficient's Allan variance.
const FLICKER_AVAR: f64 = 2.0 * core::f64::consts::LN_2 / core::f64::consts::PI;

/// The Allan floor of a flicker bias over its coefficient (IEEE Std 952).
pub const FLOOR_OVER_B: f64 = 0.664;

/// Allan variance of a unit-variance first-order Gauss-Markov bias with
/// correlation time `t` (s) at `tau` (s): `(t / tau)^2 (2 tau / t - 3 + 4
/// e^(-tau/t) - e^(-2 tau/t))` (a rate random walk `2 tau / (3 t)` for
/// `tau << t`, white noise `2 t / tau` for `tau >> t`).
pub fn gm_avar(tau: f64, t: f64) -> f64 {
    let x = tau / t;
    if x < 1e-3 {
        // The series: the closed form cancels to rounding there.
        return 2.0 * x / 3.0 - x * x / 6.0;
    }
    (2.0 * x - 3.0 + 4.0 * libm::exp(-x) - libm::exp(-2.0 * x)) / (x * x)
}

impl NoiseFit {
    /// The model's ADEV at `tau_s`.
    pub fn adev_at(&self, tau_s: f64) -> f64 {
        let gm = if self.gm_tau_s > 0.0 {
            self.gm_sigma * self.gm_sigma * gm_avar(tau_s, self.gm_tau_s)
        } else {
            0.0
        };
        libm::sqrt(
            self.white * self.white / tau_s
                + FLICKER_AVAR * self.flicker * self.flicker
                + self.rrw * self.rrw * tau_s / 3.0
                + gm,
        )
    }
}

/// Correlation times tried for a Gauss-Markov bias, per decade of tau.
const GM_PER_DECADE: usize = 8;

/// How far from a model its most outlying point lies, in standard normal
/// deviates (either side: a term dropped can leave points above the model,
/// or below where the others, refitted, overshoot): each point's variance
/// times its degrees of freedom over the model's is chi-square with those
/// degrees of freedom under the model; its z by Wilson-Hilferty (a point
/// with 3 degrees of freedom lies 7 times above its mean once in 1e5).
fn excess(pts: &[AdevPoint], m: &Model) -> f64 {
    pts.iter()
        .map(|p| {
            let k = p.edf.max(1.0);
            let model = m.var_at(p.tau_s);
            let x = p.adev * p.adev * k / model;
            let a = 2.0 / (9.0 * k);
            libm::fabs((libm::cbrt(x / k) - (1.0 - a)) / libm::sqrt(a))
        })
        .filter(|z| z.is_finite())
        .fold(f64::NEG_INFINITY, f64::max)
}

/// The deviate a point must reach from white noise's model for any other
/// term to be named: 1e-5 per point and side, so that white noise's ten
/// points per curve, six curves per recording, name a term in fewer than
/// one recording in a thousand.
pub const TERM_Z: f64 = 4.26;

/// A fitted model: its coefficients (white, flicker, rate random walk,
/// Gauss-Markov variances), AIC, Gauss-Markov time, and what its last pass
/// weighed with (the terms, the prior, the edf cap) for [`Model::var_w`].
#[derive(Clone, Copy)]
struct Model {
    aic: f64,
    x: [f64; 4],
    t: f64,
    on: [bool; 4],
    prior: [f64; 4],
    cap: f64,
}

impl Model {
    /// The model's Allan variance at `tau`.
    fn var_at(&self, tau: f64) -> f64 {
        let [w, f, r, g] = self.x;
        let gm = if self.t > 0.0 {
            g * gm_avar(tau, self.t)
        } else {
            0.0
        };
        w / tau + FLICKER_AVAR * f + r * tau / 3.0 + gm
    }

    /// The variance of the white variance, from the last pass's sandwich
    /// (computed once, for the model chosen: its meat is quadratic in the
    /// points).
    fn var_w(&self, pts: &[AdevPoint]) -> f64 {
        // Without the Gauss-Markov term its time is any positive value
        // (the term is masked; 0 would make its basis NaN).
        let t = if self.on[3] { self.t } else { 1.0 };
        fit_weighted(pts, self.on, t, Some(self.prior), self.cap, true).map_or(0.0, |f| f.2)
    }
}

/// The best model (least AIC) among those whose terms lie in `allowed`.
fn best_model(pts: &[AdevPoint], allowed: u8, lo: f64, hi: f64, cap: f64) -> Option<Model> {
    let decades = libm::log10(hi / lo).max(0.0) + 1.0;
    let steps = (decades * GM_PER_DECADE as f64) as usize + 1;
    let mut best: Option<Model> = None;
    for mask in (1u8..16).filter(|m| m & !allowed == 0) {
        let on = [mask & 1 != 0, mask & 2 != 0, mask & 4 != 0, mask & 8 != 0];
        let k = on.iter().filter(|x| **x).count() + usize::from(on[3]);
        let grid = if on[3] { steps } else { 1 };
        for g in 0..grid {
            // From three times the shortest tau (shorter, a Gauss-Markov
            // bias is white noise by another name over the points) to ten
            // times the longest.
            let t = 3.0 * lo * libm::pow(10.0, g as f64 / GM_PER_DECADE as f64);
            let Some((x, cost, prior)) = fit_terms(pts, on, t, cap) else {
                continue;
            };
            // AIC with the capped-edf chi-square (cost / 2).
            let aic = 0.5 * cost + 2.0 * k as f64;
            if best.is_none_or(|b| aic < b.aic) {
                best = Some(Model {
                    aic,
                    x,
                    t: if on[3] { t } else { 0.0 },
                    on,
                    prior,
                    cap,
                });
            }
        }
    }
    best
}

/// One weighted least-squares fit of the terms in `on` (white, flicker, rate
/// random walk, Gauss-Markov with correlation time `t`): the coefficients
/// (variances), the fit's cost, and the prior its last pass weighed with.
fn fit_terms(
    points: &[AdevPoint],
    on: [bool; 4],
    t: f64,
    cap: f64,
) -> Option<([f64; 4], f64, [f64; 4])> {
    // Weights from the model, not from the measured points (iteratively
    // reweighted): weights 1 / measured^2 favour the points that scattered
    // low and bias the fit down (by 4 % on an hour of white noise).
    let mut fit = fit_weighted(points, on, t, None, cap, false)?;
    let mut prior = fit.0;
    for _ in 0..3 {
        prior = fit.0;
        fit = fit_weighted(points, on, t, Some(prior), cap, false)?;
    }
    Some((fit.0, fit.1, prior))
}

/// One pass of [`fit_terms`], weighting each point by the variance of the
/// model `prior` (coefficients as returned) or, without one, of the point:
/// the coefficients, the cost and (with `cov`, else 0) the white
/// variance's variance.
fn fit_weighted(
    points: &[AdevPoint],
    on: [bool; 4],
    t: f64,
    prior: Option<[f64; 4]>,
    cap: f64,
    cov: bool,
) -> Option<([f64; 4], f64, f64)> {
    use nalgebra::{Matrix4, Vector4};
    let [o0, o1, o2, o3] = on.map(|x| f64::from(u8::from(x)));
    let mask = Vector4::new(o0, o1, o2, o3);
    let basis = |tau: f64| {
        Vector4::new(1.0 / tau, FLICKER_AVAR, tau / 3.0, gm_avar(tau, t)).component_mul(&mask)
    };
    // Weights: 1/var(sigma^2) = edf / (2 sigma^4), edf capped so the
    // thousands of degrees of freedom at short tau cannot drown the floor
    // and the slope at long tau (the model only approximates a sensor);
    // the capped weights' covariance is the sandwich with the true ones.
    // The points come from the same samples: their errors correlate
    // (`white_avar_correlation`), which the sandwich's meat carries.
    let mut a = Matrix4::from_diagonal(&mask.map(|x| 1.0 - x));
    let mut meat = Matrix4::zeros();
    let mut rhs = Vector4::zeros();
    let weighed = |p: &AdevPoint| {
        let f = basis(p.tau_s);
        let s2 = prior
            .map(|c| f.dot(&Vector4::from(c)))
            .filter(|m| *m > 0.0)
            .unwrap_or(p.adev * p.adev);
        // The weight, and the point's own sigma of sigma^2.
        let w = p.edf.clamp(1.0, cap) / (s2 * s2);
        (f, w, s2 * libm::sqrt(2.0 / p.edf.max(1.0)))
    };
    for p in points {
        let (f, w, sd) = weighed(p);
        a += f * f.transpose() * w;
        rhs += f * (w * p.adev * p.adev);
        for q in points.iter().filter(|_| cov) {
            let (g, wq, sdq) = weighed(q);
            let c = white_avar_correlation(p.tau_s, q.tau_s) * sd * sdq;
            meat += f * g.transpose() * (w * wq * c);
        }
    }
    let inv = a.try_inverse()?;
    let x = inv * rhs;
    if x.iter().any(|c| *c < 0.0 || !c.is_finite()) {
        return None;
    }
    let cost: f64 = points
        .iter()
        .map(|p| {
            let v = p.adev * p.adev;
            let model = basis(p.tau_s).dot(&x);
            let s2 = if model > 0.0 { model } else { v };
            p.edf.clamp(1.0, cap) * (model - v) * (model - v) / (s2 * s2)
        })
        .sum();
    let cov = inv * meat * inv;
    Some((x.into(), cost, cov.m11.max(0.0)))
}

/// The correlation of two overlapping Allan variance estimates of the
/// same long record of white noise at averaging times `a` and `b` s
/// (Gaussian: their covariance is `2/T` times the integral of the squared
/// cross-correlation of the two second-difference filters; the filters
/// are boxes, so the cross-correlation is piecewise linear between the
/// differences of their edges and Simpson's rule is exact on each piece).
pub fn white_avar_correlation(a: f64, b: f64) -> f64 {
    if !(a > 0.0 && b > 0.0) {
        return 0.0;
    }
    let cross = |x: f64, y: f64| integral_of_squared_cross(x, y);
    let (ab, aa, bb) = (cross(a, b), cross(a, a), cross(b, b));
    if aa > 0.0 && bb > 0.0 {
        ab / libm::sqrt(aa * bb)
    } else {
        0.0
    }
}

/// `integral R(s)^2 ds` with `R(s) = integral h_a(u) h_b(u + s) du`,
/// `h_x` the Allan filter at `x` (`-1/x` on `[0, x)`, `+1/x` on `[x, 2x)`).
fn integral_of_squared_cross(a: f64, b: f64) -> f64 {
    // Each filter as (start, end, height) boxes.
    let boxes = |x: f64| [(0.0, x, -1.0 / x), (x, 2.0 * x, 1.0 / x)];
    let (ha, hb) = (boxes(a), boxes(b));
    let r = |s: f64| {
        let mut sum = 0.0;
        for (a0, a1, ya) in ha {
            for (b0, b1, yb) in hb {
                // h_b(u + s) is on [b0 - s, b1 - s).
                let overlap = (a1.min(b1 - s) - a0.max(b0 - s)).max(0.0);
                sum += ya * yb * overlap;
            }
        }
        sum
    };
    let mut knots = [0.0f64; 9];
    for (k, slot) in knots.iter_mut().enumerate() {
        let ea = [0.0, a, 2.0 * a].get(k / 3).copied().unwrap_or(0.0);
        let eb = [0.0, b, 2.0 * b].get(k % 3).copied().unwrap_or(0.0);
        *slot = eb - ea;
    }
    knots.sort_unstable_by(f64::total_cmp);
    // R is nonzero for s in (-2a, 2b), the outer knots.
    let mut total = 0.0;
    for w in knots.windows(2) {
        if let [s0, s1] = *w {
            let h = s1 - s0;
            if h > 0.0 {
                let (r0, rm, r1) = (r(s0), r(0.5 * (s0 + s1)), r(s1));
                total += h / 6.0 * (r0 * r0 + 4.0 * rm * rm + r1 * r1);
            }
        }
    }
    total
}

/// Fits [`NoiseFit`] to `points` (weighted, non-negative; see module docs):
/// every subset of white noise, flicker, rate random walk and a
/// Gauss-Markov bias (its correlation time on a grid over the points'
/// taus), the subset chosen by AIC (a Gauss-Markov bias that the three-term
/// model cannot hold would otherwise be read as less white noise). `None`
/// with no usable point.
pub fn fit_noise(points: &[AdevPoint]) -> Option<NoiseFit> {
    let mut usable = [AdevPoint::default(); 64];
    let mut n = 0;
    for p in points
        .iter()
        .filter(|p| p.adev > 0.0 && p.adev.is_finite() && p.tau_s > 0.0)
    {
        if let Some(slot) = usable.get_mut(n) {
            *slot = *p;
            n += 1;
        }
    }
    if n == 0 {
        return None;
    }
    let pts = usable.get(..n)?;
    let (lo, hi) = pts.iter().fold((f64::INFINITY, 0.0f64), |(l, h), p| {
        (l.min(p.tau_s), h.max(p.tau_s))
    });
    // The model: the best (AIC) with the capped weights (the model only
    // approximates a sensor). Terms beyond white noise are named only when
    // the data refute white noise alone: fitted at the points' own degrees
    // of freedom (the statistic's null), some point lies from it beyond
    // chance (`excess`). Else the curve is white noise as far as it can
    // show: the other terms are not named (a floor is then a bound), the
    // white noise stays the full model's (a low floor the curve cannot
    // resolve would otherwise raise it).
    let best = best_model(pts, 0b1111, lo, hi, FIT_EDF_CAP)?;
    let white_only = best_model(pts, 0b0001, lo, hi, f64::INFINITY)?;
    let (best, var_w) = match (excess(pts, &white_only) < TERM_Z, best.x[0] > 0.0) {
        (false, _) => (best, best.var_w(pts)),
        (true, true) => (
            Model {
                x: [best.x[0], 0.0, 0.0, 0.0],
                t: 0.0,
                ..best
            },
            best.var_w(pts),
        ),
        (true, false) => {
            let m = best_model(pts, 0b0001, lo, hi, FIT_EDF_CAP)?;
            (m, m.var_w(pts))
        }
    };
    let Model {
        x: [v_white, v_flicker, v_rrw, v_gm],
        t,
        ..
    } = best;
    let white = libm::sqrt(v_white);
    let mut fit = NoiseFit {
        white,
        // d(N) = d(N^2) / (2 N); at N = 0 the bound's own scale.
        white_sigma: if white > 0.0 {
            libm::sqrt(var_w) / (2.0 * white)
        } else {
            libm::sqrt(libm::sqrt(var_w))
        },
        flicker: libm::sqrt(v_flicker),
        rrw: libm::sqrt(v_rrw),
        gm_sigma: libm::sqrt(v_gm),
        gm_tau_s: t,
        bias_instability: 0.0,
        floor_seen: false,
        tau_max_s: hi,
        floor_tau_s: hi,
    };
    // The floor: where the fitted curve first stops falling over the
    // points' taus (a Gauss-Markov bias's bump rises after it, and falls
    // again past its peak: that later fall is not the floor), else its
    // value at the longest tau, a bound.
    let mut taus = [0.0f64; 64];
    for (slot, p) in taus.iter_mut().zip(pts) {
        *slot = p.tau_s;
    }
    let taus = taus.get_mut(..n).unwrap_or(&mut []);
    taus.sort_unstable_by(f64::total_cmp);
    let mut floor = (f64::INFINITY, hi);
    for &tau in taus.iter() {
        let a = fit.adev_at(tau);
        if a > floor.0 {
            break;
        }
        floor = (a, tau);
    }
    let (floor, at) = floor;
    fit.bias_instability = if floor.is_finite() {
        floor / FLOOR_OVER_B
    } else {
        0.0
    };
    fit.floor_seen = floor.is_finite() && (at < hi || fit.flicker > 0.0);
    fit.floor_tau_s = at;
    Some(fit)
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
    fn no_difference_straddles_a_gap() {
        // Two segments of +-1 alternating samples, the second 1000 higher:
        // within a segment every first difference is +-2, so ADEV(1) is
        // sqrt(4 / 2) = sqrt(2) exactly; over the jump the contiguous
        // estimate sees a difference of ~1000 and reads far higher.
        let seg = |off: f64| (0..500).map(move |i| off + if i % 2 == 0 { 1.0 } else { -1.0 });
        let y: Vec<f64> = seg(0.0).chain(seg(1000.0)).collect();
        let two = oadev_segments(&y, 0.01, 1, &[0..500, 500..1000]).unwrap();
        assert!((two.adev - 2f64.sqrt()).abs() < 1e-9, "{two:?}");
        assert_eq!(two.terms, 998);
        assert!(oadev(&y, 0.01, 1).unwrap().adev > 10.0);
        // One segment over everything is the contiguous estimate, bit for bit.
        let one = oadev_segments(&y, 0.01, 3, core::slice::from_ref(&(0..1000))).unwrap();
        assert_eq!(one, oadev(&y, 0.01, 3).unwrap());
        // A segment shorter than 2m adds nothing; none long enough: None.
        assert_eq!(oadev_segments(&y, 0.01, 300, &[0..500, 500..1000]), None);
    }

    /// Points on a model curve at octave taus from `tau0` (edf 100 each).
    fn curve(f: &NoiseFit, tau0: f64, octaves: u32) -> Vec<AdevPoint> {
        (0..octaves)
            .map(|k| {
                let m = 1usize << k;
                let tau_s = tau0 * m as f64;
                AdevPoint {
                    m,
                    tau_s,
                    adev: f.adev_at(tau_s),
                    edf: 100.0,
                    terms: 1000,
                    lo: 0.0,
                    hi: 0.0,
                }
            })
            .collect()
    }

    #[test]
    fn a_floor_is_measured_only_where_the_taus_reach_it() {
        // White noise 1e-3 and a flicker coefficient 1e-4 (its floor
        // 0.664e-4): the white curve meets the floor near 100 s.
        let truth = NoiseFit {
            white: 1e-3,
            flicker: 1e-4,
            ..NoiseFit::default()
        };
        // 0.01-0.04 s (three octaves, a bursty log's gap-free pieces): the
        // curve still falls; the floor is not seen.
        let short = fit_noise(&curve(&truth, 0.01, 3)).unwrap();
        assert!(!short.floor_seen, "{short:?}");
        assert!((short.tau_max_s - 0.04).abs() < 1e-12);
        // 0.01 s to 0.01 x 2^19 = 5243 s: the floor, within 5 % of B.
        let long = fit_noise(&curve(&truth, 0.01, 20)).unwrap();
        assert!(long.floor_seen, "{long:?}");
        assert!(
            (long.bias_instability / 1e-4 - 1.0).abs() < 0.05,
            "{long:?}"
        );
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
