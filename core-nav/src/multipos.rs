//! Multi-position calibration for a tri-axial table or a hand-turned box
//! (Tedaldi, Pretto, Menegatti, ICRA 2014; Ferraris et al. 1995):
//!
//! - static intervals found by the accelerometer's variance against the
//!   initial rest;
//! - accelerometer: `a = T K (a_raw - b)`, `T` upper unit-triangular (3
//!   misalignments: the frame's absolute rotation is unobservable from
//!   norms), `K` diagonal scale, `b` bias: 9 parameters fitted so every
//!   static mean has the norm `g` (Levenberg-Marquardt);
//! - gyroscope: `w = M (w_raw - b)`, `b` from the initial rest, `M` a full
//!   3x3 (scale and six misalignments): 9 parameters fitted so the rotation
//!   integrated between consecutive static intervals carries the
//!   (calibrated) gravity direction of one interval onto the next.
//!
//! `no_std`, no heap: the caller passes the samples; the solver's work
//! arrays (~40 KiB) live on the stack, so this is for the host or a lab
//! fixture, not the flight loop. The Jacobian is by central differences.

use crate::attitude::{quat_to_dcm, rotvec_to_delta};
use crate::calib::CalibError;
use nalgebra::{Matrix3, Quaternion, SMatrix, SVector, Vector3};

/// A triad correction `x = matrix (raw - bias)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriadCorrection {
    /// Correction matrix (scale and misalignment; units of the output per
    /// raw unit).
    pub matrix: Matrix3<f64>,
    /// Bias, raw units.
    pub bias: Vector3<f64>,
}

impl TriadCorrection {
    /// Applies the correction.
    pub fn apply(&self, raw: &Vector3<f64>) -> Vector3<f64> {
        self.matrix * (raw - self.bias)
    }
}

/// Finds static intervals: samples whose accelerometer variance over a
/// centred window of `half` samples each side stays below `factor` times
/// `ref_var` (the initial rest's variance, summed over the axes); runs of at
/// least `min_len` samples are written to `out` as `[start, end)`.
/// Returns how many were found (more than `out` holds are counted but not
/// written).
pub fn static_intervals(
    acc: &[Vector3<f64>],
    half: usize,
    ref_var: f64,
    factor: f64,
    min_len: usize,
    out: &mut [(usize, usize)],
) -> usize {
    let n = acc.len();
    let mut count = 0;
    let mut run_start: Option<usize> = None;
    // Running sums over the window [i - half, i + half].
    let (mut s, mut s2, mut w) = (Vector3::zeros(), Vector3::zeros(), 0usize);
    let push = |v: &Vector3<f64>, s: &mut Vector3<f64>, s2: &mut Vector3<f64>, sign: f64| {
        *s += v * sign;
        *s2 += v.component_mul(v) * sign;
    };
    for j in 0..half.min(n) {
        if let Some(v) = acc.get(j) {
            push(v, &mut s, &mut s2, 1.0);
            w += 1;
        }
    }
    for i in 0..=n {
        let quiet = if i < n {
            if let Some(v) = acc.get(i + half) {
                push(v, &mut s, &mut s2, 1.0);
                w += 1;
            }
            if i > half {
                if let Some(v) = acc.get(i - half - 1) {
                    push(v, &mut s, &mut s2, -1.0);
                    w -= 1;
                }
            }
            let wf = w.max(1) as f64;
            let m = s / wf;
            let var = (s2 / wf - m.component_mul(&m)).sum();
            var < factor * ref_var
        } else {
            false
        };
        match (quiet, run_start) {
            (true, None) => run_start = Some(i),
            (false, Some(a)) => {
                if i - a >= min_len {
                    if let Some(slot) = out.get_mut(count) {
                        *slot = (a, i);
                    }
                    count += 1;
                }
                run_start = None;
            }
            _ => {}
        }
    }
    count
}

/// Levenberg-Marquardt over `N` parameters. `residuals(p, out)` writes the
/// residuals for `p` into `out` and returns how many (at most
/// [`MAX_RESIDUALS`]). Central-difference Jacobian with steps `step`.
/// Returns the parameters and the final rms residual.
fn levenberg_marquardt<const N: usize>(
    mut p: SVector<f64, N>,
    step: &SVector<f64, N>,
    residuals: &dyn Fn(&SVector<f64, N>, &mut [f64]) -> usize,
    iterations: usize,
) -> Result<(SVector<f64, N>, f64), CalibError> {
    let mut r0 = [0.0f64; MAX_RESIDUALS];
    let mut rp = [0.0f64; MAX_RESIDUALS];
    let mut rm = [0.0f64; MAX_RESIDUALS];
    let mut jac = [[0.0f64; MAX_RESIDUALS]; N];
    let m = residuals(&p, &mut r0);
    if m < N || m > MAX_RESIDUALS {
        return Err(CalibError::NotEnoughData);
    }
    let cost = |r: &[f64; MAX_RESIDUALS]| r.iter().take(m).map(|x| x * x).sum::<f64>();
    let mut c0 = cost(&r0);
    let mut lambda = 1e-3;
    for _ in 0..iterations {
        for (k, col) in jac.iter_mut().enumerate() {
            let h = step.get(k).copied().unwrap_or(1e-6);
            let (mut pp, mut pm) = (p, p);
            if let (Some(a), Some(b)) = (pp.get_mut(k), pm.get_mut(k)) {
                *a += h;
                *b -= h;
            }
            residuals(&pp, &mut rp);
            residuals(&pm, &mut rm);
            for ((c, a), b) in col.iter_mut().zip(rp.iter()).zip(rm.iter()).take(m) {
                *c = (a - b) / (2.0 * h);
            }
        }
        let mut jtj = SMatrix::<f64, N, N>::zeros();
        let mut jtr = SVector::<f64, N>::zeros();
        for (i, r) in r0.iter().enumerate().take(m) {
            let row = SVector::<f64, N>::from_fn(|k, _| {
                jac.get(k).and_then(|c| c.get(i)).copied().unwrap_or(0.0)
            });
            jtj += row * row.transpose();
            jtr += row * *r;
        }
        let mut improved = false;
        for _ in 0..12 {
            let damp = SMatrix::<f64, N, N>::from_diagonal(&jtj.diagonal()) * lambda;
            let Some(delta) = (jtj + damp).cholesky().map(|c| c.solve(&(-jtr))) else {
                lambda *= 10.0;
                continue;
            };
            let cand = p + delta;
            residuals(&cand, &mut rp);
            let c1 = cost(&rp);
            if c1 < c0 {
                p = cand;
                c0 = c1;
                r0 = rp;
                lambda = (lambda * 0.3).max(1e-12);
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    Ok((p, libm::sqrt(c0 / m as f64)))
}

/// Most residuals a fit may have (static intervals x 3 for the gyro).
pub const MAX_RESIDUALS: usize = 384;

/// Fits the accelerometer to static means (raw units) so their norms are
/// `g`: bias, three scales, three misalignments (Tedaldi Eq. 9-10).
/// `init` is the starting guess (bias and per-axis scale from the data).
///
/// # Errors
/// Fewer than 9 intervals, or no convergence.
pub fn fit_accelerometer(
    means: &[Vector3<f64>],
    g: f64,
    init_bias: Vector3<f64>,
    init_scale: Vector3<f64>,
) -> Result<(TriadCorrection, f64), CalibError> {
    if means.len() < 9 || means.len() > MAX_RESIDUALS {
        return Err(CalibError::NotEnoughData);
    }
    // Parameters: [alpha_yz, alpha_zy, alpha_zx, sx, sy, sz, bx, by, bz].
    let corr = |p: &SVector<f64, 9>| {
        let [a_yz, a_zy, a_zx, sx, sy, sz, bx, by, bz]: [f64; 9] = (*p).into();
        let t = Matrix3::new(1.0, -a_yz, a_zy, 0.0, 1.0, -a_zx, 0.0, 0.0, 1.0);
        TriadCorrection {
            matrix: t * Matrix3::from_diagonal(&Vector3::new(sx, sy, sz)),
            bias: Vector3::new(bx, by, bz),
        }
    };
    let res = |p: &SVector<f64, 9>, out: &mut [f64]| {
        let c = corr(p);
        let mut n = 0;
        for (o, m) in out.iter_mut().zip(means) {
            *o = c.apply(m).norm() - g;
            n += 1;
        }
        n
    };
    let p0 = SVector::<f64, 9>::from_column_slice(&[
        0.0,
        0.0,
        0.0,
        init_scale.x,
        init_scale.y,
        init_scale.z,
        init_bias.x,
        init_bias.y,
        init_bias.z,
    ]);
    let step = SVector::<f64, 9>::from_column_slice(&[
        1e-6,
        1e-6,
        1e-6,
        init_scale.x.abs() * 1e-6,
        init_scale.y.abs() * 1e-6,
        init_scale.z.abs() * 1e-6,
        1e-3 * g / init_scale.x.abs().max(1e-12),
        1e-3 * g / init_scale.y.abs().max(1e-12),
        1e-3 * g / init_scale.z.abs().max(1e-12),
    ]);
    let (p, rms) = levenberg_marquardt(p0, &step, &res, 200)?;
    Ok((corr(&p), rms))
}

/// Rotation over `samples` (raw gyro at period `dt_s`) with correction
/// `c`: the quaternion taking vectors from the end frame to the start frame.
pub fn integrate(samples: &[Vector3<f64>], dt_s: f64, c: &TriadCorrection) -> Quaternion<f64> {
    let mut q = Quaternion::identity();
    let mut prev: Option<Vector3<f64>> = None;
    for s in samples {
        let w = c.apply(s);
        if let Some(p) = prev {
            // Trapezoid + coning for rate samples (as the mechanization).
            let phi = (p + w) * (0.5 * dt_s) + p.cross(&w) * (dt_s * dt_s / 12.0);
            q *= rotvec_to_delta(&phi).to_quat();
            q /= q.norm();
        }
        prev = Some(w);
    }
    q
}

/// Fits the gyroscope correction matrix (bias given, from the rest) so that
/// the rotation between consecutive static intervals maps the measured
/// gravity direction of one onto the next. `gyro` holds all raw samples,
/// `intervals` the static `[start, end)` index ranges in order, `up` the
/// unit (calibrated) specific-force direction of each interval.
///
/// Robust: hand-made transitions can be too fast for the sample rate (a
/// flip at 900 deg/s turns 9 deg per sample at 100 Hz and cannot be
/// integrated); Cauchy weights from the median transition error (IRLS, 4
/// rounds) keep such transitions from bending the fit. Returns the
/// correction, the rms error of the inlier transitions (rad) and how many
/// transitions were outliers (error above 3 scale units).
///
/// # Errors
/// Fewer than 4 transitions, or no convergence.
pub fn fit_gyroscope(
    gyro: &[Vector3<f64>],
    dt_s: f64,
    intervals: &[(usize, usize)],
    up: &[Vector3<f64>],
    bias: Vector3<f64>,
    init: Matrix3<f64>,
) -> Result<(TriadCorrection, f64, usize), CalibError> {
    const MAX_T: usize = MAX_RESIDUALS / 3;
    if intervals.len() < 5 || intervals.len() != up.len() || intervals.len() > MAX_T {
        return Err(CalibError::NotEnoughData);
    }
    let corr = |p: &SVector<f64, 9>| TriadCorrection {
        matrix: Matrix3::from_column_slice(p.as_slice()),
        bias,
    };
    // Error vector of transition k-1 -> k under correction c.
    let err = |c: &TriadCorrection, k: usize| -> Vector3<f64> {
        let (Some(&(_, a_end)), Some(&(b_start, _)), Some(u0), Some(u1)) = (
            intervals.get(k - 1),
            intervals.get(k),
            up.get(k - 1),
            up.get(k),
        ) else {
            return Vector3::zeros();
        };
        let seg = gyro
            .get(a_end.saturating_sub(1)..(b_start + 1).min(gyro.len()))
            .unwrap_or(&[]);
        let q = integrate(seg, dt_s, c);
        // u is fixed in the world: u1 = C_end_start u0 = C(q)^T u0.
        quat_to_dcm(&q).transpose() * u0 - u1
    };
    let n_t = intervals.len() - 1;
    let mut weights = [1.0f64; MAX_T];
    let mut p = SVector::<f64, 9>::from_column_slice(init.as_slice());
    let step = SVector::<f64, 9>::repeat(init.abs().max().max(1e-12) * 1e-5);
    let mut scale = 0.0;
    // Weights from the transition errors under `c`; returns the scale.
    let reweight = |c: &TriadCorrection, weights: &mut [f64; MAX_T]| -> f64 {
        let mut e = [0.0f64; MAX_T];
        for (k, slot) in e.iter_mut().enumerate().take(n_t) {
            *slot = err(c, k + 1).norm();
        }
        let mut sorted = e;
        let part = sorted.get_mut(..n_t).unwrap_or(&mut []);
        part.sort_unstable_by(|a, b| a.total_cmp(b));
        let median = part.get(n_t / 2).copied().unwrap_or(0.0);
        // 1.4826 median: the sd of a normal; floor 0.2 deg.
        let s = (1.4826 * median).max(0.2f64.to_radians());
        for (wk, ek) in weights.iter_mut().zip(e.iter()).take(n_t) {
            *wk = 1.0 / (1.0 + (ek / s) * (ek / s));
        }
        s
    };
    // Start from the initial guess's errors, so outliers never bend round one.
    reweight(&corr(&p), &mut weights);
    for _round in 0..4 {
        let w = weights;
        let res = |q: &SVector<f64, 9>, out: &mut [f64]| {
            let c = corr(q);
            let mut n = 0;
            for k in 1..=n_t {
                let d = err(&c, k) * libm::sqrt(w.get(k - 1).copied().unwrap_or(1.0));
                for v in [d.x, d.y, d.z] {
                    if let Some(o) = out.get_mut(n) {
                        *o = v;
                    }
                    n += 1;
                }
            }
            n
        };
        p = levenberg_marquardt(p, &step, &res, 100)?.0;
        scale = reweight(&corr(&p), &mut weights);
    }
    let c = corr(&p);
    let (mut sum, mut n_in, mut outliers) = (0.0, 0usize, 0usize);
    for k in 1..=n_t {
        let e = err(&c, k).norm();
        if e > 3.0 * scale {
            outliers += 1;
        } else {
            sum += e * e;
            n_in += 1;
        }
    }
    Ok((c, libm::sqrt(sum / n_in.max(1) as f64), outliers))
}

/// Ferraris et al. (1995): the gyroscope correction from rotations of
/// known angle about (nearly) the sensor axes. `integrals` are the raw
/// integrals `sum (w_raw - b) dt` over each rotation (raw units x s),
/// `rotations` the known rotation vectors (rad) in the sensor frame; with
/// three independent rotations `M = [rotations] [integrals]^-1` exactly.
///
/// # Errors
/// [`CalibError::Degenerate`] when the integrals are not independent.
pub fn fit_gyroscope_rotations(
    integrals: &[Vector3<f64>; 3],
    rotations: &[Vector3<f64>; 3],
    bias: Vector3<f64>,
) -> Result<TriadCorrection, CalibError> {
    let [i0, i1, i2] = integrals;
    let [r0, r1, r2] = rotations;
    let b = Matrix3::from_columns(&[*i0, *i1, *i2]);
    let a = Matrix3::from_columns(&[*r0, *r1, *r2]);
    let inv = b.try_inverse().ok_or(CalibError::Degenerate)?;
    Ok(TriadCorrection {
        matrix: a * inv,
        bias,
    })
}
