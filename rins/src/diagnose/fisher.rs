//! Detection limits: the Fisher information of an effect in a run and the
//! noncentrality the rule detects half the time (the minimum detectable
//! effect), and the Allan-deviation excess of a residual.

use super::design::{quad, solve, Design};
use super::effects;
use super::select::{params_of, select};
use super::{check, final_noise, predict, DiagnoseError, Options, BIC_MARGIN, NOMINAL_PRIOR};
use hal_sim::catalogue::EffectId;
use hal_sim::recording::Recording;
use nalgebra::{DMatrix, DVector};

/// Does the residual's Allan deviation show more than white noise? Returns
/// the fitted (white, bias instability) and the ratio of the long-tau ADEV
/// to the white-noise extrapolation.
pub fn allan_excess(res: &[f64], tau0: f64) -> (f64, f64, f64) {
    use core_nav::allan::{fit_noise, oadev, octave_factors};
    let pts: Vec<_> = octave_factors(res.len(), 20)
        .filter_map(|m| oadev(res, tau0, m))
        .filter(|p| p.m >= 10)
        .collect();
    let fit = fit_noise(&pts).unwrap_or_default();
    let last = pts.iter().rev().find(|p| p.terms >= 20);
    let ratio = last.map_or(1.0, |p| p.adev / (fit.white / p.tau_s.sqrt()).max(1e-300));
    (fit.white, fit.bias_instability, ratio)
}

/// The Fisher information of an effect in a run: the noncentrality
/// `lambda = s' W' P W s` of the effect's signature `s` (the change it makes
/// to the residual `y - truth` between `sig_null` and `sig_with`, two runs on
/// the same seed that differ only by the effect; best without quantisation,
/// whose changed rounding would pass for signal), whitened by the noise model
/// fitted to `null` (the run as recorded) and with the nominal terms
/// projected out. The detection statistic of [`super::run`] for that effect is
/// noncentral chi^2 with `k` degrees of freedom and this `lambda`. Returns
/// `(lambda, k, N)` with `k` the effect's parameters the run excites and `N`
/// the regression's rows (the BIC's sample size).
///
/// # Errors
/// As [`super::run`]; runs of different lengths.
pub fn fisher(
    null: &Recording,
    sig_null: &Recording,
    sig_with: &Recording,
    effect: EffectId,
    opts: &Options,
) -> Result<(f64, usize, usize), DiagnoseError> {
    for r in [null, sig_null, sig_with] {
        check(r)?;
    }
    if null.imu.len() != sig_with.imu.len() || sig_null.imu.len() != sig_with.imu.len() {
        return Err(DiagnoseError::DifferentLengths);
    }
    let pn = predict(null, 1.0, 0.0);
    let first = Design::build(&pn, effects::library(&pn), opts, None);
    let sel = select(&first);
    let noise = final_noise(&first, &sel);
    let p0 = predict(sig_null, 1.0, 0.0);
    let p1 = predict(sig_with, 1.0, 0.0);
    let d0 = Design::build(&p0, effects::library(&p0), opts, Some(&noise));
    let d1 = Design::build(&p1, effects::library(&p1), opts, Some(&noise));
    let k = (0..d0.cands.len())
        .filter(|ci| d0.cands[*ci].id == effect)
        .map(|ci| params_of(&d0.fit(&[ci]), ci))
        .max()
        .unwrap_or(0);
    let mut lambda = 0.0;
    for ch in 0..6 {
        let (c0, c1) = (&d0.ch[ch], &d1.ch[ch]);
        let m = c0.owners.len();
        let nb = c0.zp.nrows().min(c1.zp.nrows());
        let s: Vec<f64> = (0..nb)
            .map(|r| c1.zp[(r, c1.owners.len())] - c0.zp[(r, m)])
            .collect();
        let g = c0.noise.gains(nb);
        let sc = 1.0 / c0.noise.r.max(1e-300).sqrt();
        let mut buf = vec![];
        g.whiten_into(&s, &mut buf);
        let y = DVector::from_iterator(nb, buf.iter().map(|v| v * sc));
        let mut x = DMatrix::zeros(nb, 4);
        for j in 0..4 {
            let col: Vec<f64> = (0..nb).map(|r| c0.zp[(r, j)]).collect();
            g.whiten_into(&col, &mut buf);
            for r in 0..nb {
                x[(r, j)] = buf[r] * sc;
            }
        }
        let mut a = x.transpose() * &x;
        for j in 1..4 {
            a[(j, j)] += 1.0 / (NOMINAL_PRIOR * NOMINAL_PRIOR);
        }
        let b = x.transpose() * &y;
        let (beta, _) = solve(&a, &b);
        lambda += quad(y.norm_squared(), &b, &a, &beta);
    }
    Ok((lambda, k, d0.rows()))
}

/// The noncentrality at which the detection rule (chi^2 with `k` degrees
/// of freedom above `k ln N + BIC_MARGIN`) fires half the time: the
/// minimum detectable effect's lambda. By bisection on a Monte Carlo of
/// the noncentral chi^2 (20,001 fixed draws: the median to ~1 %).
pub fn lambda_50(k: usize, n_rows: usize) -> f64 {
    let thr = k as f64 * (n_rows.max(2) as f64).ln() + BIC_MARGIN;
    let mut rng = hal_sim::rng::Rng::new(0x2545_F491, 0);
    let draws = 20_001;
    let z: Vec<Vec<f64>> = (0..draws)
        .map(|_| (0..k.max(1)).map(|_| rng.normal()).collect())
        .collect();
    let frac_above = |lam: f64| {
        let s = lam.sqrt();
        z.iter()
            .filter(|zi| {
                let c: f64 = zi
                    .iter()
                    .enumerate()
                    .map(|(i, v)| if i == 0 { (v + s).powi(2) } else { v * v })
                    .sum();
                c > thr
            })
            .count() as f64
            / draws as f64
    };
    let (mut lo, mut hi) = (0.0f64, 4.0 * thr + 100.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if frac_above(mid) < 0.5 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}
