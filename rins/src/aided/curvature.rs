//! The fixes' NIS about a least point: its Hessian and gradient by
//! central differences, and the covariance of the parameters found there.
//! `2 H^-1` is that covariance only when every fix's innovation is
//! independent of the others' and as large as the filter says. A real or
//! simulated ride's are neither: what the filter models loosely (the
//! vibration, the warm-up, a slip) moves many fixes' innovations together,
//! and the NIS's curvature counts each as new evidence. The sandwich
//! `H^-1 B H^-1` does not assume it: `B` is the long-run covariance of
//! the fixes' own scores (each fix's NIS differentiated by the
//! parameters), which sums their correlation over a window of the slow
//! errors' time (Newey and West 1987; White 1982, Econometrica 50(1), for
//! the misspecified likelihood). The covariance stated is never tighter
//! than the model's own along any direction.

use super::offset::FixesNis;
use anyhow::Result;
use nalgebra::{DMatrix, DVector};
use std::collections::HashMap;

/// The window over which the fixes' scores are taken as correlated, s:
/// the lags of their long-run covariance (Bartlett weights) span it.
/// The time the loosely modelled errors take to change: a warm-up's
/// drift and a car's turns and stops, seconds to tens of seconds.
pub const SCORE_WINDOW_S: f64 = 10.0;

/// The fixes' NIS at a parameter vector.
pub type NisAt<'a> = dyn FnMut(&[f64]) -> Result<FixesNis> + 'a;

/// The NIS's shape about a point.
#[derive(Clone, Debug)]
pub struct Curvature {
    /// The total NIS's Hessian.
    pub hess: DMatrix<f64>,
    /// Its gradient.
    pub grad: DVector<f64>,
    /// The long-run covariance of the fixes' scores, summed over them
    /// (`B`); `None` when fewer than two fixes are in every run.
    pub scores: Option<DMatrix<f64>>,
}

/// The Hessian and gradient of the total NIS at `x` (`f0` there) by
/// central differences of steps `h` (`nis` at a parameter vector), and
/// the fixes' scores' long-run covariance from the same runs.
pub fn curvature(x: &[f64], h: &[f64], f0: &FixesNis, nis: &mut NisAt) -> Result<Curvature> {
    let n = x.len();
    let mut f = |d: &[(usize, f64)]| -> Result<FixesNis> {
        let mut y = x.to_vec();
        for (i, s) in d {
            if let (Some(v), Some(hi)) = (y.get_mut(*i), h.get(*i)) {
                *v += s * hi;
            }
        }
        nis(&y)
    };
    let mut hess = DMatrix::<f64>::zeros(n, n);
    let mut grad = DVector::<f64>::zeros(n);
    let mut sides = vec![];
    for (i, &hi) in h.iter().enumerate() {
        let (up, down) = (f(&[(i, 1.0)])?, f(&[(i, -1.0)])?);
        hess[(i, i)] = (up.total + down.total - 2.0 * f0.total) / (hi * hi);
        grad[i] = (up.total - down.total) / (2.0 * hi);
        for (j, &hj) in h.iter().enumerate().skip(i + 1) {
            let pp = f(&[(i, 1.0), (j, 1.0)])?.total;
            let pm = f(&[(i, 1.0), (j, -1.0)])?.total;
            let mp = f(&[(i, -1.0), (j, 1.0)])?.total;
            let mm = f(&[(i, -1.0), (j, -1.0)])?.total;
            hess[(i, j)] = (pp - pm - mp + mm) / (4.0 * hi * hj);
            hess[(j, i)] = hess[(i, j)];
        }
        sides.push((up, down));
    }
    let scores =
        scores(f0, &sides, h).map(|(g, lags)| diagnose::locate::long_run_covariance(&g, lags));
    Ok(Curvature { hess, grad, scores })
}

impl Curvature {
    /// Along one parameter, from three runs `step` apart (`down`, `f0`,
    /// `up`): a line search's least point and its neighbours.
    pub fn along_line(down: &FixesNis, f0: &FixesNis, up: &FixesNis, step: f64) -> Self {
        let sides = [(up.clone(), down.clone())];
        Self {
            hess: DMatrix::from_element(
                1,
                1,
                (up.total + down.total - 2.0 * f0.total) / (step * step),
            ),
            grad: DVector::from_element(1, (up.total - down.total) / (2.0 * step)),
            scores: scores(f0, &sides, &[step])
                .map(|(g, lags)| diagnose::locate::long_run_covariance(&g, lags)),
        }
    }
}

/// Each fix's score (its NIS's central difference along each parameter),
/// a row per fix in every run, in time order; and the lags that span
/// [`SCORE_WINDOW_S`] at their median spacing. `None` for fewer than two.
fn scores(
    f0: &FixesNis,
    sides: &[(FixesNis, FixesNis)],
    h: &[f64],
) -> Option<(DMatrix<f64>, usize)> {
    let maps: Vec<(HashMap<i64, f64>, HashMap<i64, f64>)> = sides
        .iter()
        .map(|(u, d)| {
            (
                u.each.iter().copied().collect(),
                d.each.iter().copied().collect(),
            )
        })
        .collect();
    let mut rows: Vec<(i64, Vec<f64>)> = vec![];
    for (stamp, _) in &f0.each {
        let row: Option<Vec<f64>> = maps
            .iter()
            .zip(h)
            .map(|((u, d), hi)| Some((u.get(stamp)? - d.get(stamp)?) / (2.0 * hi)))
            .collect();
        if let Some(r) = row {
            rows.push((*stamp, r));
        }
    }
    if rows.len() < 2 {
        return None;
    }
    rows.sort_by_key(|r| r.0);
    let mut gaps: Vec<i64> = rows.windows(2).map(|w| w[1].0 - w[0].0).collect();
    gaps.sort_unstable();
    let spacing_s = gaps
        .get(gaps.len() / 2)
        .map_or(1.0, |g| (*g).max(1) as f64 * 1e-6);
    let lags = (SCORE_WINDOW_S / spacing_s).round() as usize;
    let g = DMatrix::from_fn(rows.len(), h.len(), |r, c| rows[r].1[c]);
    Some((g, lags))
}

/// The covariance of the parameters at the NIS's least point, and how
/// many times the model's variance the widest direction was widened (1:
/// the fixes' scores are no more correlated than the model says). The
/// model's is `2 H^-1`, scaled by the NIS per degree of freedom `per`
/// when above 1 (an overconfident filter's likelihood is too sharp); the
/// sandwich's is `H^-1 B H^-1`; stated is the least matrix above both
/// along each of the model's directions. `None` when the Hessian is not
/// positive definite (the NIS is not a bowl there).
pub fn covariance(c: &Curvature, per: f64) -> Option<(DMatrix<f64>, f64)> {
    let inv = c.hess.clone().cholesky()?.inverse();
    let model = &inv * (2.0 * per.max(1.0));
    let Some(b) = &c.scores else {
        return Some((model, 1.0));
    };
    let sandwich = &inv * b * &inv;
    let l = model.clone().cholesky()?.l();
    let li = l.clone().try_inverse()?;
    let s = &li * sandwich * li.transpose();
    let eig = nalgebra::SymmetricEigen::new((&s + s.transpose()) * 0.5);
    let widened = eig.eigenvalues.iter().fold(1.0_f64, |a, e| a.max(*e));
    let d = DMatrix::from_diagonal(&eig.eigenvalues.map(|e| e.max(1.0)));
    let v = &eig.eigenvectors;
    Some((&l * v * d * v.transpose() * l.transpose(), widened))
}

/// The covariance of the parameters `estimated` (a flag per parameter of
/// `c`) found with the others held at values known to `held_sigma` each
/// (Schmidt's consider covariance): [`covariance`] of their own block,
/// plus what the held ones' errors move them by, `A P Aᵀ` with `A =
/// H_ee^-1 H_eh` and `P` the held ones' variance. An antenna height the
/// motion does not resolve, held where the recording puts it, still bends
/// the arm's other components and the clock found with it. `None` as
/// [`covariance`].
pub fn consider(
    c: &Curvature,
    per: f64,
    estimated: &[bool],
    held_sigma: f64,
) -> Option<(DMatrix<f64>, f64)> {
    let e: Vec<usize> = (0..estimated.len()).filter(|i| estimated[*i]).collect();
    let (all, widened) = with_held(c, per, estimated, held_sigma)?;
    Some((all.select_rows(&e).select_columns(&e), widened))
}

/// [`consider`]'s covariance over every parameter of `c`, in its order:
/// the estimated ones' block, the held ones' own variance `held_sigma^2`
/// each, and between them `-A P` (an estimate moves against the held
/// error it absorbs). What a user of both, the estimated values and the
/// held ones, knows them to.
pub fn with_held(
    c: &Curvature,
    per: f64,
    estimated: &[bool],
    held_sigma: f64,
) -> Option<(DMatrix<f64>, f64)> {
    let n = estimated.len();
    let e: Vec<usize> = (0..n).filter(|i| estimated[*i]).collect();
    let h: Vec<usize> = (0..n).filter(|i| !estimated[*i]).collect();
    let own = Curvature {
        hess: c.hess.select_rows(&e).select_columns(&e),
        grad: c.grad.select_rows(&e),
        scores: c
            .scores
            .as_ref()
            .map(|b| b.select_rows(&e).select_columns(&e)),
    };
    let (cov, widened) = covariance(&own, per)?;
    let p = held_sigma * held_sigma;
    let a = own
        .hess
        .clone()
        .cholesky()?
        .solve(&c.hess.select_rows(&e).select_columns(&h));
    let ee = cov + &a * a.transpose() * p;
    let eh = -&a * p;
    let mut all = DMatrix::zeros(n, n);
    for (r, &i) in e.iter().enumerate() {
        for (q, &j) in e.iter().enumerate() {
            all[(i, j)] = ee[(r, q)];
        }
        for (q, &j) in h.iter().enumerate() {
            all[(i, j)] = eh[(r, q)];
            all[(j, i)] = eh[(r, q)];
        }
    }
    for &j in &h {
        all[(j, j)] = p;
    }
    Some((all, widened))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A parameter's least-squares fit on `n` samples `y_k = theta + e_k`
    /// with `e` an AR(1) of coefficient `rho`: the NIS `sum (y_k -
    /// theta)^2` (unit variance stated), its Hessian `2n`, the model's
    /// variance `1/n`; the mean's true variance is the long-run one,
    /// `sigma^2 / (1 - rho)^2 / n` with `sigma^2 = 1 - rho^2` the
    /// innovations' (a closed form).
    fn ar1_fit(rho: f64, n: usize, seed: u64) -> (f64, f64) {
        let mut s = seed;
        let mut gauss = || {
            // Box-Muller on a 64-bit LCG (Knuth's MMIX constants).
            let mut u = || {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let mut e = gauss();
        let y: Vec<f64> = (0..n)
            .map(|_| {
                e = rho * e + (1.0 - rho * rho).sqrt() * gauss();
                e
            })
            .collect();
        let at = |theta: f64| FixesNis {
            total: y.iter().map(|v| (v - theta).powi(2)).sum(),
            per_dof: 1.0,
            each: y
                .iter()
                .enumerate()
                .map(|(k, v)| (k as i64 * 100_000, (v - theta).powi(2)))
                .collect(),
        };
        let mean = y.iter().sum::<f64>() / n as f64;
        let mut nis = |x: &[f64]| Ok(at(x[0]));
        let c = curvature(&[mean], &[0.1], &at(mean), &mut nis).unwrap();
        let (cov, widened) = covariance(&c, 1.0).unwrap();
        (cov[(0, 0)], widened)
    }

    #[test]
    fn white_fixes_keep_the_model_s_variance() {
        // 20,000 white samples: the long-run variance's estimate has a
        // relative sigma of sqrt(4 L / 3 n) = 0.08 at L = 100 lags (10 s
        // at 0.1 s); 4 of those.
        let (var, widened) = ar1_fit(0.0, 20_000, 1);
        assert!((var * 20_000.0 - 1.0).abs() < 0.33, "{var}");
        assert!(widened < 1.33, "{widened}");
    }

    #[test]
    fn correlated_fixes_widen_it_to_the_long_run_variance() {
        // rho 0.8 (a 0.45 s correlation time at 0.1 s): the long-run
        // variance is (1 + rho) / (1 - rho) = 9 times the white one; the
        // Bartlett window's bias at L = 100 is 2 rho / (1 - rho)^2 / L,
        // 4 % of it; the estimate's sigma as above, larger by the
        // correlation.
        let n = 20_000.0;
        let (var, widened) = ar1_fit(0.8, 20_000, 2);
        assert!((var * n / 9.0 - 1.0).abs() < 0.33, "{var}");
        assert!((widened / 9.0 - 1.0).abs() < 0.33, "{widened}");
    }
    #[test]
    fn a_held_parameter_s_error_moves_the_estimate_against_it() {
        // Least squares of y = a + 0.5 b on 1000 unit-variance samples,
        // b held at a value known to 2: the NIS's Hessian is 2 [[n,
        // n/2], [n/2, n/4]]; a's own variance 1/n, and a absorbs -0.5 of
        // b's error: its variance 1/n + 0.25 * 4, its covariance with
        // b's error -0.5 * 4 (a closed form).
        let n = 1000.0;
        let c = Curvature {
            hess: DMatrix::from_row_slice(2, 2, &[2.0 * n, n, n, 0.5 * n]),
            grad: DVector::zeros(2),
            scores: None,
        };
        let (all, _) = with_held(&c, 1.0, &[true, false], 2.0).unwrap();
        let want = [1.0 / n + 1.0, -2.0, 4.0];
        for (got, want) in [all[(0, 0)], all[(0, 1)], all[(1, 1)]].iter().zip(want) {
            assert!((got - want).abs() < 1e-12, "{all}");
        }
        assert_eq!(all[(0, 1)], all[(1, 0)]);
        let (own, _) = consider(&c, 1.0, &[true, false], 2.0).unwrap();
        assert_eq!(own[(0, 0)], all[(0, 0)]);
    }
}
