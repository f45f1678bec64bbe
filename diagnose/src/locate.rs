//! Locate: where the residual is, by motion (still, turning each way, rate
//! changes), by time, by table angle (rotation harmonics), in the angle
//! domain for the table-axis gyro (so encoder quantisation is not
//! differentiated into rate noise), and what is left unexplained.

use super::noise::Noise;
use super::{rms, Prediction, Unexplained, BIC_MARGIN, CHANNELS};
use nalgebra::{DMatrix, DVector};

/// Highest table-angle harmonic looked at.
pub const HARMONICS: usize = 8;

/// Table acceleration above which a sample is in a rate change, rad/s^2
/// (5 deg/s^2: well above the encoder-derived acceleration's noise at a
/// steady rate once averaged over a block).
pub const RAMP_RADPS2: f64 = 0.087;

/// The nominal residual, located.
#[derive(Clone, Debug, Default)]
pub struct Locate {
    /// (label, rms per channel, samples) for each part of the run.
    pub splits: Vec<(String, [f64; 6], usize)>,
    /// Amplitude of the residual at table-angle harmonics 1..=HARMONICS,
    /// per channel (channel unit); empty if the table did not turn a whole
    /// revolution.
    pub harmonics: Vec<[f64; 6]>,
    /// Table-axis gyro against the encoder in the angle domain: the
    /// integrated residual (rad), detrended; (rms, 1x-revolution amplitude).
    pub angle_domain: Option<(f64, f64)>,
}

/// Which part of the run each sample is in (0 still, 1 turning +, 2
/// turning -, 3 rate changing). The rate and acceleration come from encoder
/// angles 0.2 s apart, so quantisation does not pass for a ramp.
pub fn parts(p: &Prediction) -> Vec<usize> {
    const H: f64 = 0.2;
    (0..p.t_s.len())
        .map(|r| {
            let t = p.t_s[r] - p.time_offset_s;
            let (a0, a1, a2) = (p.angle_at(t - H), p.angle_at(t), p.angle_at(t + H));
            part_of((a2 - a0) / (2.0 * H), (a2 - 2.0 * a1 + a0) / (H * H))
        })
        .collect()
}

/// Which part of the run a table rate `w` (rad/s) and acceleration `a`
/// (rad/s^2) are in: 0 still, 1 turning +, 2 turning -, 3 rate changing.
pub fn part_of(w: f64, a: f64) -> usize {
    if a.abs() > RAMP_RADPS2 {
        3
    } else if core_nav::table::is_still(w) {
        0
    } else if w > 0.0 {
        1
    } else {
        2
    }
}

/// Amplitudes of harmonics 1..=kmax of `res` against the angle `theta`
/// (least squares on cos / sin, with an intercept).
pub fn harmonics(res: &[f64], theta: &[f64], kmax: usize) -> Vec<f64> {
    harmonics_all(&[res], theta, kmax).pop().unwrap_or_default()
}

/// [`harmonics`] of several series against one angle (one normal matrix).
pub fn harmonics_all(res: &[&[f64]], theta: &[f64], kmax: usize) -> Vec<Vec<f64>> {
    let n = res
        .iter()
        .map(|r| r.len())
        .min()
        .unwrap_or(0)
        .min(theta.len());
    let m = 1 + 2 * kmax;
    let mut ata = DMatrix::<f64>::zeros(m, m);
    let mut aty = DMatrix::<f64>::zeros(m, res.len());
    let mut row = vec![0.0; m];
    // At most ~100,000 rows: the amplitudes are a locating measure, and a
    // stride of a few samples keeps every revolution densely covered.
    let stride = (n / 100_000).max(1);
    for r in (0..n).step_by(stride) {
        row[0] = 1.0;
        // cos / sin of k theta by the angle-addition recurrence.
        let (s1, c1) = theta[r].sin_cos();
        let (mut s, mut c) = (s1, c1);
        for k in 1..=kmax {
            row[2 * k - 1] = c;
            row[2 * k] = s;
            let (sn, cn) = (s * c1 + c * s1, c * c1 - s * s1);
            s = sn;
            c = cn;
        }
        for i in 0..m {
            let ri = row[i];
            for j in i..m {
                ata[(i, j)] += ri * row[j];
            }
            for (q, x) in res.iter().enumerate() {
                aty[(i, q)] += ri * x[r];
            }
        }
    }
    for i in 0..m {
        for j in 0..i {
            ata[(i, j)] = ata[(j, i)];
        }
    }
    let sol = (ata + DMatrix::identity(m, m) * 1e-9)
        .cholesky()
        .map(|c| c.solve(&aty))
        .unwrap_or_else(|| DMatrix::zeros(m, res.len()));
    (0..res.len())
        .map(|q| {
            (1..=kmax)
                .map(|k| sol[(2 * k - 1, q)].hypot(sol[(2 * k, q)]))
                .collect()
        })
        .collect()
}

/// The parts of a run [`parts`] returns, by index.
pub const PART_LABELS: [&str; 4] = ["table still", "turning +", "turning -", "rate changing"];

/// Locates the nominal residual.
pub fn locate(p: &Prediction, parts: &[usize], res: &[Vec<f64>; 6], dt: f64) -> Locate {
    let n = p.t_s.len();
    let labels = [
        PART_LABELS[0],
        PART_LABELS[1],
        PART_LABELS[2],
        PART_LABELS[3],
        "first half",
        "second half",
    ];
    let mut splits = vec![];
    for (li, label) in labels.iter().enumerate() {
        let sel: Vec<usize> = (0..n)
            .filter(|&r| match li {
                4 => r < n / 2,
                5 => r >= n / 2,
                _ => parts[r] == li,
            })
            .collect();
        if sel.is_empty() {
            continue;
        }
        let v: [f64; 6] =
            std::array::from_fn(|ch| rms(&sel.iter().map(|&r| res[ch][r]).collect::<Vec<_>>()));
        splits.push(((*label).to_string(), v, sel.len()));
    }
    // By rate: thirds of the turning samples' |rate|, when the run has
    // more than one rate (its 5th and 95th percentiles differ: the
    // spin-up's few samples do not make a one-rate run a many-rate one).
    let mut rates: Vec<f64> = (0..n)
        .filter(|r| matches!(parts[*r], 1 | 2))
        .map(|r| p.theta[r].1.abs())
        .collect();
    rates.sort_by(f64::total_cmp);
    if let (Some(lo), Some(hi)) = (
        rates.get(rates.len() / 20),
        rates.get(rates.len() * 19 / 20),
    ) {
        if *hi > 1.2 * lo.max(1e-9) {
            let q1 = rates[rates.len() / 3];
            let q2 = rates[2 * rates.len() / 3];
            for (a, b) in [(0.0, q1), (q1, q2), (q2, f64::INFINITY)] {
                let sel: Vec<usize> = (0..n)
                    .filter(|r| matches!(parts[*r], 1 | 2))
                    .filter(|r| (a..b).contains(&p.theta[*r].1.abs()))
                    .collect();
                if sel.is_empty() {
                    continue;
                }
                let v: [f64; 6] = std::array::from_fn(|ch| {
                    rms(&sel.iter().map(|&r| res[ch][r]).collect::<Vec<_>>())
                });
                let label = if b.is_finite() {
                    format!("|rate| {:.0}-{:.0} d/s", a.to_degrees(), b.to_degrees())
                } else {
                    format!("|rate| >{:.0} d/s", a.to_degrees())
                };
                splits.push((label, v, sel.len()));
            }
        }
    }
    let theta: Vec<f64> = p.theta.iter().map(|t| t.0).collect();
    let span = theta.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - theta.iter().copied().fold(f64::INFINITY, f64::min);
    let mut harm = vec![];
    let mut angle_domain = None;
    if span >= 0.999 * core::f64::consts::TAU {
        let per: Vec<Vec<f64>> = (0..6)
            .map(|ch| harmonics(&res[ch], &theta, HARMONICS))
            .collect();
        harm = (0..HARMONICS)
            .map(|k| std::array::from_fn(|ch| per[ch][k]))
            .collect();
        // Angle domain: integrate the table-axis gyro's residual; the
        // encoder enters as an angle, its quantisation as +-half a count.
        let i = p.k.iamax();
        let mut acc = 0.0;
        let ang: Vec<f64> = res[i]
            .iter()
            .map(|v| {
                acc += v * dt;
                acc
            })
            .collect();
        // Detrend (a bias left in the residual integrates to a ramp).
        let t = &p.t_s;
        let tm = t.iter().sum::<f64>() / n as f64;
        let am = ang.iter().sum::<f64>() / n as f64;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for r in 0..n {
            sxy += (t[r] - tm) * (ang[r] - am);
            sxx += (t[r] - tm).powi(2);
        }
        let slope = sxy / sxx.max(1e-300);
        let det: Vec<f64> = (0..n).map(|r| ang[r] - am - slope * (t[r] - tm)).collect();
        let h1 = harmonics(&det, &theta, 1).first().copied().unwrap_or(0.0);
        angle_domain = Some((rms(&det), h1));
    }
    Locate {
        splits,
        harmonics: harm,
        angle_domain,
    }
}

/// Ljung-Box statistic of a whitened series over `lags` lags (chi^2 with
/// `lags` degrees of freedom when white): (Q, lags).
pub fn ljung_box(w: &[f64], lags: usize) -> (f64, usize) {
    let n = w.len();
    if n <= lags + 1 {
        return (0.0, lags);
    }
    let mean = w.iter().sum::<f64>() / n as f64;
    let c0: f64 = w.iter().map(|x| (x - mean).powi(2)).sum();
    let mut q = 0.0;
    for h in 1..=lags {
        let ch: f64 = (h..n).map(|i| (w[i] - mean) * (w[i - h] - mean)).sum();
        let rho = ch / c0.max(1e-300);
        q += rho * rho / (n - h) as f64;
    }
    (n as f64 * (n as f64 + 2.0) * q, lags)
}

/// Dispersion of a whitened series: its long-run variance over its
/// variance ([`long_run_covariance`] with `L` lags), at least 1. A white
/// series gives 1; a series the noise model leaves coloured gives more,
/// and the evidence of a slow regressor fitted on it is worth that many
/// times less (quasi-likelihood).
pub fn dispersion(w: &[f64], lags: usize) -> f64 {
    let n = w.len();
    if n <= lags + 1 {
        return 1.0;
    }
    let x = DMatrix::from_column_slice(n, 1, w);
    let c0 = long_run_covariance(&x, 0)[(0, 0)];
    (long_run_covariance(&x, lags)[(0, 0)] / c0.max(1e-300)).max(1.0)
}

/// The long-run covariance of a vector series about its mean (one sample
/// a row of `x`), summed over its samples: `sum_h w_h (C_h + C_h^T)`,
/// `C_h` the lag-`h` cross-products, `w_0 = 1/2` and `w_h = 1 - h / (L +
/// 1)` (Bartlett weights, `L` lags; Newey and West 1987, Econometrica
/// 55(3)). The covariance of the series' sum: for white samples the sum
/// of their outer products; for samples correlated over a few lags, that
/// many times more. Positive semi-definite for any data.
pub fn long_run_covariance(x: &DMatrix<f64>, lags: usize) -> DMatrix<f64> {
    let (n, m) = x.shape();
    let mut d = x.clone();
    for mut c in d.column_iter_mut() {
        let mean = c.mean();
        c.add_scalar_mut(-mean);
    }
    let mut s = DMatrix::<f64>::zeros(m, m);
    for h in 0..=lags.min(n.saturating_sub(1)) {
        let w = match h {
            0 => 0.5,
            _ => 1.0 - h as f64 / (lags as f64 + 1.0),
        };
        let c = d.rows(h, n - h).transpose() * d.rows(0, n - h);
        s += (&c + c.transpose()) * w;
    }
    s
}

/// Residual sum of squares of `y` on the columns `x` (least squares).
fn resid_ss(x: &[DVector<f64>], y: &DVector<f64>) -> f64 {
    let m = x.len();
    let xtx = DMatrix::from_fn(m, m, |i, j| x[i].dot(&x[j]));
    let xty = DVector::from_fn(m, |i, _| x[i].dot(y));
    match (xtx + DMatrix::identity(m, m) * 1e-9).cholesky() {
        Some(c) => {
            let beta = c.solve(&xty);
            (y.norm_squared() - beta.dot(&xty)).max(0.0)
        }
        None => y.norm_squared(),
    }
}

/// Mismatches left in the final residual that no effect explains: table
/// angle harmonics and offsets tied to the motion (one direction, rate
/// changes), each judged on the whitened block means by the same BIC margin
/// as the findings.
pub fn unexplained(
    p: &Prediction,
    parts: &[usize],
    res: &[Vec<f64>],
    noise: &[Noise],
    len: usize,
    ln_n: f64,
) -> Vec<Unexplained> {
    let n = p.t_s.len();
    let bl = p.blocks(len);
    let theta: Vec<f64> = p.theta.iter().map(|t| t.0).collect();
    let span = theta.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - theta.iter().copied().fold(f64::INFINITY, f64::min);
    // Candidate signatures: (where, columns).
    let mut groups: Vec<(String, Vec<Vec<f64>>)> = vec![];
    if span >= 0.999 * core::f64::consts::TAU {
        let mut cols: Vec<[Vec<f64>; 2]> = (0..6)
            .map(|_| [Vec::with_capacity(n), Vec::with_capacity(n)])
            .collect();
        for t in &theta {
            // cos / sin of k theta by the angle-addition recurrence.
            let (s1, c1) = t.sin_cos();
            let (mut s, mut c) = (s1, c1);
            for [cc, ss] in &mut cols {
                cc.push(c);
                ss.push(s);
                (s, c) = (s * c1 + c * s1, c * c1 - s * s1);
            }
        }
        for (k, [c, s]) in cols.into_iter().enumerate() {
            groups.push((format!("{}x table revolution harmonic", k + 1), vec![c, s]));
        }
    }
    for (pi, label) in [
        (1, "while turning +"),
        (2, "while turning -"),
        (3, "while the rate changes"),
    ] {
        let c: Vec<f64> = parts
            .iter()
            .map(|q| f64::from(u8::from(*q == pi)))
            .collect();
        let cnt = c.iter().sum::<f64>();
        if cnt > 0.0 && cnt < n as f64 {
            groups.push((format!("an offset {label}"), vec![c]));
        }
    }
    let mut out = vec![];
    for (ch, nm) in noise.iter().enumerate().take(6) {
        let z = &res[ch];
        let nb = z.len();
        if nb < 10 {
            continue;
        }
        let g = nm.gains(nb);
        let s = 1.0 / nm.r.max(1e-300).sqrt();
        let mut zw = vec![];
        g.whiten_into(z, &mut zw);
        let zw = DVector::from_iterator(nb, zw.iter().map(|v| v * s));
        let one = DVector::from_iterator(nb, {
            let mut b = vec![];
            g.whiten_into(&vec![1.0; nb], &mut b);
            b.into_iter().map(|v| v * s)
        });
        // Whitened columns of every group.
        let mut buf = vec![];
        let wcols: Vec<Vec<DVector<f64>>> = groups
            .iter()
            .map(|(_, cols)| {
                cols.iter()
                    .map(|c| {
                        g.whiten_into(&bl.mean(c), &mut buf);
                        DVector::from_iterator(nb, buf.iter().map(|v| v * s))
                    })
                    .collect()
            })
            .collect();
        // Greedy, as the findings: the strongest group first, the others
        // judged with it in the base (a harmonic must not also show up as
        // the direction offsets it leaks into).
        let mut base: Vec<DVector<f64>> = vec![one.clone()];
        let mut taken = vec![false; groups.len()];
        loop {
            let r0 = resid_ss(&base, &zw);
            let mut best: Option<(usize, f64)> = None;
            for (gi, cols) in wcols.iter().enumerate() {
                if taken[gi] {
                    continue;
                }
                let mut with = base.clone();
                with.extend(cols.iter().cloned());
                let dchi = (r0 - resid_ss(&with, &zw)).max(0.0);
                if -dchi + cols.len() as f64 * ln_n < -BIC_MARGIN
                    && best.is_none_or(|(_, d)| dchi > d)
                {
                    best = Some((gi, dchi));
                }
            }
            let Some((gi, dchi)) = best else { break };
            taken[gi] = true;
            base.extend(wcols[gi].iter().cloned());
            out.push(Unexplained {
                channels: vec![CHANNELS[ch].to_string()],
                where_: groups[gi].0.clone(),
                snr: dchi.sqrt(),
                may_be: None,
            });
        }
    }
    out.sort_by(|a, b| b.snr.total_cmp(&a.snr));
    out
}
