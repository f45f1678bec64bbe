//! Detection limits: the Fisher information of an effect in a run and the
//! noncentrality the rule detects half the time (the minimum detectable
//! effect), and the Allan-deviation excess of a residual.

use super::design::{quad, solve, Design};
use super::effects;
use super::select::{params_of, select};
use super::{check, final_noise, predict, DiagnoseError, Options, BIC_MARGIN, NOMINAL_PRIOR};
use hal_sim::catalogue::EffectId;
use nalgebra::{DMatrix, DVector};
use recording::Recording;

/// Does the residual's Allan deviation (a series without gaps) show more than white noise? Returns
/// the fitted (white, bias instability) and the ratio of the long-tau ADEV
/// to the white-noise extrapolation.
pub fn allan_excess(res: &[f64], tau0: f64) -> (f64, f64, f64) {
    let (pts, fit) =
        crate::noise_terms::fit_channel(res, tau0, std::slice::from_ref(&(0..res.len())));
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
    let (sel, _) = select(&first);
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

/// Upper tail of the chi-square distribution with `k` degrees of freedom:
/// `P(X >= x)`, the regularised upper incomplete gamma `Q(k / 2, x / 2)`
/// (series below `a + 1`, Lentz's continued fraction above; Numerical
/// Recipes 6.2), to ~1e-12 relative.
pub fn chi2_sf(x: f64, k: usize) -> f64 {
    let a = k.max(1) as f64 / 2.0;
    let x = x.max(0.0) / 2.0;
    if x == 0.0 {
        return 1.0;
    }
    let ln_pre = a * x.ln() - x - libm::lgamma(a);
    if x < a + 1.0 {
        // P(a, x) by its series; Q = 1 - P.
        let (mut sum, mut term, mut n) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * ln_pre.exp()).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (ln_pre.exp() * h).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::chi2_sf;

    #[test]
    fn chi2_tail_against_closed_forms() {
        // k = 2: exp(-x / 2) exactly; k = 1: erfc(sqrt(x / 2)) (libm's
        // erfc, an independent implementation); k = 4: exp(-x/2)(1 + x/2).
        for x in [0.1, 1.0, 3.0, 10.0, 30.0, 80.0] {
            let rel = |a: f64, b: f64| ((a - b) / b).abs();
            assert!(rel(chi2_sf(x, 2), (-x / 2.0f64).exp()) < 1e-10, "k2 {x}");
            assert!(
                rel(chi2_sf(x, 1), libm::erfc((x / 2.0f64).sqrt())) < 1e-8,
                "k1 {x}"
            );
            assert!(
                rel(chi2_sf(x, 4), (-x / 2.0f64).exp() * (1.0 + x / 2.0)) < 1e-10,
                "k4 {x}"
            );
        }
    }
}
