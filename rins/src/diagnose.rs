//! `rins diagnose`: compare a recording with what the simulator predicts for
//! the same run, locate the mismatch, name the physics the nominal model left
//! out (`shared/spec/diagnose-v1.md`), model it and show the fit improve.
//!
//! 1. Predict: the ideal sensor for the recorded table motion (the encoder's
//!    angle, its rate and acceleration by local quadratic fits, at the IMU
//!    times), the site's gravity and earth rate, the base attitude.
//! 2. Nominal fit, per triad: `y = b + (I + M) x` (bias, scale, misalignment)
//!    by least squares, keeping only the columns the run excites.
//! 3. Residuals are averaged into blocks (1 s): white noise averages down,
//!    and the blocks' noise is estimated from the residual itself, so
//!    coloured noise does not pass for signal as readily as with raw samples
//!    (the block length is the whitening).
//! 4. Candidates: each effect id contributes regressors on some channels;
//!    each is fitted to the residual blocks of even seconds and judged on the
//!    odd ones (held out), with the BIC on all blocks. Accepted effects (BIC
//!    lower by 10 and held-out rms lower) are kept, most significant first,
//!    greedily.
//! 5. Bias instability is judged on the Allan deviation of the residual: a
//!    curve that stops falling as white noise does.

use core_nav::allan::{fit_noise, oadev, octave_factors};
use core_nav::attitude::{euler_to_quat, quat_to_dcm, Euler};
use core_nav::earth::{earth_rate_n, normal_gravity};
use hal_sim::recording::Recording;
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Unit, Vector3};

/// The six channels' names (recording-v1 columns).
pub const CHANNELS: [&str; 6] = crate::allan::CHANNELS;

/// The ideal sensor and the table motion at each IMU sample.
#[derive(Clone, Debug, Default)]
pub struct Prediction {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Ideal rate in s, rad/s.
    pub w: Vec<Vector3<f64>>,
    /// Ideal specific force in s, m/s^2.
    pub f: Vec<Vector3<f64>>,
    /// Table angle, rate, acceleration (rad, rad/s, rad/s^2).
    pub theta: Vec<(f64, f64, f64)>,
    /// Temperature change from the first sample, deg C.
    pub dtemp: Vec<f64>,
    /// The table axis `k` (same in `b` and `s`).
    pub k: Vector3<f64>,
    /// Measured samples: gyro (rad/s), accel (m/s^2).
    pub y_w: Vec<Vector3<f64>>,
    /// See `y_w`.
    pub y_f: Vec<Vector3<f64>>,
}

/// Local quadratic fit of the encoder angle around `t` (the 5 nearest
/// reads): angle, rate, acceleration.
fn table_at(t: &[f64], a: &[f64], i0: usize, tq: f64) -> (f64, f64, f64) {
    let n = t.len();
    let lo = i0.saturating_sub(2).min(n.saturating_sub(5));
    let hi = (lo + 5).min(n);
    let m = hi - lo;
    if m < 3 {
        return (a.get(i0).copied().unwrap_or(0.0), 0.0, 0.0);
    }
    let x = DMatrix::from_fn(m, 3, |r, c| (t[lo + r] - tq).powi(c as i32));
    let y = DVector::from_fn(m, |r, _| a[lo + r]);
    let sol = (x.transpose() * &x)
        .cholesky()
        .map(|c| c.solve(&(x.transpose() * y)));
    match sol {
        Some(s) => (s[0], s[1], 2.0 * s[2]),
        None => (a[i0], 0.0, 0.0),
    }
}

/// Predicts the ideal sensor for `rec` (the nominal world: earth rate,
/// gravity, the table's motion about its nominal axis).
pub fn predict(rec: &Recording, earth_rate: bool) -> Prediction {
    let m = &rec.meta;
    let lat = m.latitude_deg.to_radians();
    let s = lat.sin();
    let g = m
        .gravity_mps2
        .unwrap_or_else(|| normal_gravity(s * s, m.height_m));
    let w_ie_n = if earth_rate {
        earth_rate_n(lat.sin(), lat.cos())
    } else {
        Vector3::zeros()
    };
    let c_b_n = quat_to_dcm(&euler_to_quat(&Euler::<f64>::from_deg(
        m.roll_deg,
        m.pitch_deg,
        m.heading_deg,
    )));
    let k = Unit::new_normalize(m.axis.unit::<f64>());
    let te: Vec<f64> = rec.table.iter().map(|r| r.t_s).collect();
    let ae: Vec<f64> = rec.table.iter().map(|r| r.angle_rad).collect();
    let temp0 = rec.imu.first().and_then(|r| r.temp_c).unwrap_or(25.0);
    let mut p = Prediction {
        k: k.into_inner(),
        ..Prediction::default()
    };
    let mut j = 0usize;
    for r in &rec.imu {
        while j + 1 < te.len() && te[j + 1] <= r.t_s {
            j += 1;
        }
        let (th, rate, acc) = table_at(&te, &ae, j, r.t_s);
        let c_s_b: Matrix3<f64> = *Rotation3::from_axis_angle(&k, th).matrix();
        let c_n_s = (c_b_n * c_s_b).transpose();
        p.t_s.push(r.t_s);
        p.w.push(c_n_s * w_ie_n + k.into_inner() * rate);
        p.f.push(c_n_s * Vector3::new(0.0, 0.0, -g));
        p.theta.push((th, rate, acc));
        p.dtemp.push(r.temp_c.unwrap_or(temp0) - temp0);
        p.y_w.push(Vector3::from(r.gyro_radps));
        p.y_f.push(Vector3::from(r.accel_mps2));
    }
    p
}

/// Least squares `y ~ X b`; returns (b, residual). Columns with no spread
/// (not excited) are left out (coefficient 0).
pub fn lstsq(x: &DMatrix<f64>, y: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
    let n = x.ncols();
    let keep: Vec<usize> = (0..n)
        .filter(|&c| {
            let col = x.column(c);
            let mean = col.mean();
            let var = col.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / col.len().max(1) as f64;
            // A constant column is the intercept (kept) or not excited.
            c == 0 || var.sqrt() > 1e-9 * (1.0 + mean.abs())
        })
        .collect();
    let xs = DMatrix::from_fn(x.nrows(), keep.len(), |r, c| x[(r, keep[c])]);
    let xtx = xs.transpose() * &xs;
    let reg = DMatrix::identity(keep.len(), keep.len()) * (xtx.diagonal().max() * 1e-12);
    let sol = (xtx + reg)
        .cholesky()
        .map(|c| c.solve(&(xs.transpose() * y)))
        .unwrap_or_else(|| DVector::zeros(keep.len()));
    let mut b = DVector::zeros(n);
    for (i, &c) in keep.iter().enumerate() {
        b[c] = sol[i];
    }
    let res = y - x * &b;
    (b, res)
}

/// The nominal model's residuals per channel (bias, scale, misalignment
/// fitted), and the fitted values.
pub fn nominal_residuals(p: &Prediction) -> [Vec<f64>; 6] {
    let n = p.t_s.len();
    let mut out: [Vec<f64>; 6] = Default::default();
    for (ch, slot) in out.iter_mut().enumerate() {
        let truth = if ch < 3 { &p.w } else { &p.f };
        let meas = if ch < 3 { &p.y_w } else { &p.y_f };
        let i = ch % 3;
        // y_i - x_i = b + sum_j M_ij x_j
        let x = DMatrix::from_fn(n, 4, |r, c| if c == 0 { 1.0 } else { truth[r][c - 1] });
        let y = DVector::from_fn(n, |r, _| meas[r][i] - truth[r][i]);
        let (_, res) = lstsq(&x, &y);
        *slot = res.iter().copied().collect();
    }
    out
}

/// Residual rms of each channel.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Does the residual's Allan deviation show more than white noise? Returns
/// the fitted (white, bias instability) and the ratio of the long-tau ADEV
/// to the white-noise extrapolation.
pub fn allan_excess(res: &[f64], tau0: f64) -> (f64, f64, f64) {
    let pts: Vec<_> = octave_factors(res.len(), 20)
        .filter_map(|m| oadev(res, tau0, m))
        .filter(|p| p.m >= 10)
        .collect();
    let fit = fit_noise(&pts).unwrap_or_default();
    let last = pts.iter().rev().find(|p| p.terms >= 20);
    let ratio = last.map_or(1.0, |p| p.adev / (fit.white / p.tau_s.sqrt()).max(1e-300));
    (fit.white, fit.bias_instability, ratio)
}

/// A candidate physical effect: its id, the channels it acts on and its
/// regressors there (functions of the prediction at sample `r`).
struct Candidate {
    id: &'static str,
    channels: &'static [usize],
    /// Regressor columns for channel `ch` at sample `r`.
    cols: fn(&Prediction, usize, usize) -> Vec<f64>,
    /// Parameter names per column (SI units in the name).
    names: &'static [&'static str],
    explain: &'static str,
    where_: &'static str,
}

fn deriv(v: &[Vector3<f64>], t: &[f64], r: usize, i: usize) -> f64 {
    let a = r.saturating_sub(1);
    let b = (r + 1).min(v.len() - 1);
    if b == a {
        return 0.0;
    }
    (v[b][i] - v[a][i]) / (t[b] - t[a])
}

const CANDIDATES: &[Candidate] = &[
    Candidate {
        id: "gyro_g_sensitivity",
        channels: &[0, 1, 2],
        cols: |p, _, r| vec![p.f[r].x, p.f[r].y, p.f[r].z],
        names: &["g_sens_x_radps_per_mps2", "g_sens_y_radps_per_mps2", "g_sens_z_radps_per_mps2"],
        explain: "the gyro output follows the specific force (g-sensitivity): the bias changes as gravity turns through the sensor axes",
        where_: "phase-locked to the accelerometer channels",
    },
    Candidate {
        id: "gyro_scale_nonlinearity",
        channels: &[0, 1, 2],
        cols: |p, ch, r| vec![p.w[r][ch] * p.w[r][ch]],
        names: &["k2_per_radps"],
        explain: "the gyro output is not linear in rate: a rate-squared term grows with the table rate",
        where_: "grows with the square of the table rate, same sign both ways",
    },
    Candidate {
        id: "gyro_scale_asymmetry",
        channels: &[0, 1, 2],
        cols: |p, ch, r| vec![p.w[r][ch].abs()],
        names: &["asymmetry"],
        explain: "the gyro scale differs between positive and negative rates",
        where_: "changes sign with the direction of rotation",
    },
    Candidate {
        id: "lever_arm",
        channels: &[3, 4, 5],
        cols: |p, ch, r| {
            // a = theta_ddot k x r + theta_dot^2 k x (k x r), linear in r.
            let k = p.k;
            let (_, w, a) = p.theta[r];
            (0..3)
                .map(|j| {
                    let e = Vector3::ith(j, 1.0);
                    (k.cross(&e) * a + k.cross(&k.cross(&e)) * (w * w))[ch - 3]
                })
                .collect()
        },
        names: &["lever_x_m", "lever_y_m", "lever_z_m"],
        explain: "the IMU sits off the table axis: centripetal and tangential acceleration add to the specific force",
        where_: "accelerometers, with the square of the table rate and with its acceleration",
    },
    Candidate {
        id: "axis_tilt",
        channels: &[3, 4],
        cols: |p, _, r| {
            let (th, _, _) = p.theta[r];
            let g = p.f[r].norm();
            vec![g * th.cos(), g * th.sin()]
        },
        names: &["tilt_cos_rad", "tilt_sin_rad"],
        explain: "the table axis is not where the model puts it: gravity turns through the horizontal accelerometers once per revolution",
        where_: "1x table revolution harmonic on the horizontal accelerometers",
    },
    Candidate {
        id: "time_offset",
        channels: &[0, 1, 2],
        cols: |p, ch, r| vec![-deriv(&p.w, &p.t_s, r, ch)],
        names: &["time_offset_s"],
        explain: "the IMU samples lag their time stamps relative to the encoder: the error follows the rate's changes",
        where_: "only where the table rate changes (ramps, reversals)",
    },
    Candidate {
        id: "temperature_bias",
        channels: &[0, 1, 2, 3, 4, 5],
        cols: |p, _, r| vec![p.dtemp[r]],
        names: &["bias_per_degc"],
        explain: "the bias follows the recorded temperature",
        where_: "slow, with the temperature",
    },
    Candidate {
        id: "encoder_error",
        channels: &[0, 1, 2],
        cols: |p, _, r| {
            let (th, w, _) = p.theta[r];
            vec![w * th.cos(), w * th.sin()]
        },
        names: &["encoder_cos_rad", "encoder_sin_rad"],
        explain: "the encoder angle carries an error that repeats each revolution (eccentricity): the rate derived from it is wrong once per turn",
        where_: "1x table revolution harmonic on the table-axis gyro, scaled by the rate",
    },
    Candidate {
        id: "accel_scale_nonlinearity",
        channels: &[3, 4, 5],
        cols: |p, ch, r| vec![p.f[r][ch - 3] * p.f[r][ch - 3]],
        names: &["k2_per_mps2"],
        explain: "the accelerometer output is not linear in specific force",
        where_: "grows with the square of the specific force",
    },
];

/// Block means of `v` over `len` samples.
fn blocks(v: &[f64], len: usize) -> Vec<f64> {
    v.chunks(len)
        .filter(|c| c.len() == len)
        .map(|c| c.iter().sum::<f64>() / len as f64)
        .collect()
}

/// A channel's design in blocks: nominal columns, extra columns, target.
struct Design {
    x: DMatrix<f64>,
    y: DVector<f64>,
}

fn design(p: &Prediction, ch: usize, extra: &[&Candidate], block: usize) -> Design {
    let n = p.t_s.len();
    let truth = |r: usize| if ch < 3 { p.w[r] } else { p.f[r] };
    let meas = |r: usize| {
        if ch < 3 {
            p.y_w[r][ch]
        } else {
            p.y_f[r][ch - 3]
        }
    };
    let i = ch % 3;
    let mut cols: Vec<Vec<f64>> = vec![
        vec![1.0; n],
        (0..n).map(|r| truth(r).x).collect(),
        (0..n).map(|r| truth(r).y).collect(),
        (0..n).map(|r| truth(r).z).collect(),
    ];
    for c in extra {
        if !c.channels.contains(&ch) {
            continue;
        }
        let per: Vec<Vec<f64>> = (0..n).map(|r| (c.cols)(p, ch, r)).collect();
        for j in 0..per.first().map_or(0, Vec::len) {
            cols.push(per.iter().map(|v| v[j]).collect());
        }
    }
    let yb = blocks(
        &(0..n).map(|r| meas(r) - truth(r)[i]).collect::<Vec<_>>(),
        block,
    );
    let cb: Vec<Vec<f64>> = cols.iter().map(|c| blocks(c, block)).collect();
    let m = yb.len();
    Design {
        x: DMatrix::from_fn(m, cb.len(), |r, c| cb[c][r]),
        y: DVector::from_vec(yb),
    }
}

/// Fit on the even blocks, rms on the odd ones; and the residual on all.
fn fit_eval(d: &Design) -> (f64, f64, DVector<f64>) {
    let (_, res_all) = lstsq(&d.x, &d.y);
    let even: Vec<usize> = (0..d.y.len()).step_by(2).collect();
    let odd: Vec<usize> = (1..d.y.len()).step_by(2).collect();
    let sub = |rows: &[usize]| {
        (
            DMatrix::from_fn(rows.len(), d.x.ncols(), |r, c| d.x[(rows[r], c)]),
            DVector::from_fn(rows.len(), |r, _| d.y[rows[r]]),
        )
    };
    let (xe, ye) = sub(&even);
    let (b, _) = lstsq(&xe, &ye);
    let (xo, yo) = sub(&odd);
    let held = yo - xo * b;
    (
        res_all.norm_squared(),
        (held.norm_squared() / held.len().max(1) as f64).sqrt(),
        res_all,
    )
}

/// Effective sample count of a residual from its lag-1 autocorrelation
/// (AR(1): n (1 - rho) / (1 + rho)): coloured noise counts for less.
fn n_eff(res: &DVector<f64>) -> f64 {
    let n = res.len();
    if n < 3 {
        return n as f64;
    }
    let c0 = res.norm_squared();
    let c1: f64 = (1..n).map(|i| res[i] * res[i - 1]).sum();
    let rho = (c1 / c0.max(1e-300)).clamp(0.0, 0.95);
    n as f64 * (1.0 - rho) / (1.0 + rho)
}

/// The wandering-bias model's improvement on a residual: block means (1 s)
/// before, and after subtracting a centred moving average of `window`
/// blocks estimated from the even blocks only, judged on the odd ones
/// (held out). Returns (rms before, rms after) on the held-out blocks.
pub fn wander_fit(res: &[f64], block: usize, window: usize) -> (f64, f64) {
    let b = blocks(res, block);
    let n = b.len();
    let (mut before, mut after, mut cnt) = (0.0f64, 0.0f64, 0.0f64);
    for i in (1..n).step_by(2) {
        let lo = i.saturating_sub(window / 2);
        let hi = (i + window / 2 + 1).min(n);
        let even: Vec<f64> = (lo..hi).filter(|j| j % 2 == 0).map(|j| b[j]).collect();
        if even.is_empty() {
            continue;
        }
        let est = even.iter().sum::<f64>() / even.len() as f64;
        before += b[i] * b[i];
        after += (b[i] - est).powi(2);
        cnt += 1.0;
    }
    (
        (before / cnt.max(1.0)).sqrt(),
        (after / cnt.max(1.0)).sqrt(),
    )
}

/// One finding of the report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Finding {
    /// Effect id (diagnose-v1).
    pub effect: String,
    /// Channels.
    pub channels: Vec<String>,
    /// Where the mismatch shows.
    #[serde(rename = "where")]
    pub where_: String,
    /// For a person.
    pub explanation: String,
    /// Fitted parameters, SI names.
    pub parameters: serde_json::Map<String, serde_json::Value>,
    /// delta_bic, snr.
    pub significance: serde_json::Value,
    /// Before / after rms.
    pub fit: serde_json::Value,
}

/// The whole report (`rins-diagnose/1`).
pub fn diagnose(rec: &Recording, recording_name: &str) -> serde_json::Value {
    let p = predict(rec, true);
    let block = (rec.meta.imu_rate_hz.round() as usize).max(1);
    let nominal = nominal_residuals(&p);
    let mut resid_rms = serde_json::Map::new();
    for (ch, name) in CHANNELS.iter().enumerate() {
        resid_rms.insert((*name).into(), rms(&nominal[ch]).into());
    }
    let mut chosen: Vec<&Candidate> = vec![];
    let mut findings: Vec<(f64, Finding)> = vec![];
    for _round in 0..5 {
        let mut best: Option<(f64, &Candidate, Finding)> = None;
        for c in CANDIDATES
            .iter()
            .filter(|c| !chosen.iter().any(|x| x.id == c.id))
        {
            let (mut dbic, mut held_b, mut held_a, mut before, mut after) = (
                0.0,
                0.0,
                0.0,
                serde_json::Map::new(),
                serde_json::Map::new(),
            );
            let mut params = serde_json::Map::new();
            let mut snr: f64 = 0.0;
            let mut k_total = 0.0;
            for &ch in c.channels {
                let d0 = design(&p, ch, &chosen, block);
                let mut with = chosen.clone();
                with.push(c);
                let d1 = design(&p, ch, &with, block);
                let k = (d1.x.ncols() - d0.x.ncols()) as f64;
                if k == 0.0 || d0.y.len() < 20 {
                    continue;
                }
                let (rss0, h0, r0) = fit_eval(&d0);
                let (rss1, h1, _) = fit_eval(&d1);
                let n = n_eff(&r0).max(k + 2.0);
                dbic += n * (rss1.max(1e-300) / rss0.max(1e-300)).ln() + k * n.ln();
                k_total += k;
                held_b += h0 * h0;
                held_a += h1 * h1;
                let name = CHANNELS[ch];
                before.insert(name.into(), (rss0 / d0.y.len() as f64).sqrt().into());
                after.insert(name.into(), (rss1 / d1.y.len() as f64).sqrt().into());
                snr = snr.max(
                    ((rss0 - rss1).max(0.0) / (rss1 / d1.y.len() as f64).max(1e-300) / k).sqrt(),
                );
                let (b, _) = lstsq(&d1.x, &d1.y);
                for (j, nm) in c.names.iter().enumerate() {
                    let idx = d0.x.ncols() + j;
                    if idx < b.len() {
                        params.insert(
                            format!("{nm}_{}", &name[..name.find('_').map_or(0, |i| i + 2)]),
                            b[idx].into(),
                        );
                    }
                }
            }
            if k_total == 0.0 {
                continue;
            }
            let (hb, ha) = (held_b.sqrt(), held_a.sqrt());
            // Strong evidence (BIC lower by 10) and better on held-out blocks.
            if dbic < -10.0 && ha < hb && best.as_ref().is_none_or(|(bb, _, _)| dbic < *bb) {
                let f = Finding {
                    effect: c.id.into(),
                    channels: c
                        .channels
                        .iter()
                        .filter(|ch| before.contains_key(CHANNELS[**ch]))
                        .map(|ch| CHANNELS[*ch].to_string())
                        .collect(),
                    where_: c.where_.into(),
                    explanation: c.explain.into(),
                    parameters: params,
                    significance: serde_json::json!({"delta_bic": dbic, "snr": snr}),
                    fit: serde_json::json!({"residual_rms_before": before, "residual_rms_after": after, "heldout_rms_before": hb, "heldout_rms_after": ha}),
                };
                best = Some((dbic, c, f));
            }
        }
        match best {
            Some((dbic, c, f)) => {
                chosen.push(c);
                findings.push((dbic, f));
            }
            None => break,
        }
    }
    // Bias instability: the residual's Allan deviation against white noise.
    let tau0 = 1.0 / rec.meta.imu_rate_hz;
    let unexplained: Vec<serde_json::Value> = vec![];
    for ch in 0..3 {
        let (white, b, ratio) = allan_excess(&nominal[ch], tau0);
        let (hb, ha) = wander_fit(&nominal[ch], block, 60);
        if ratio > 3.0 && b > 0.0 && ha < hb {
            let mut params = serde_json::Map::new();
            params.insert("bias_instability_radps".into(), b.into());
            params.insert("white_noise_rad_per_sqrt_s".into(), white.into());
            findings.push((
                -1e9 + ratio,
                Finding {
                    effect: "bias_instability".into(),
                    channels: vec![CHANNELS[ch].into()],
                    where_: "long averaging times: the Allan deviation of the residual stops falling as white noise".into(),
                    explanation: "a constant bias and white noise do not explain this sensor: its bias wanders (flicker / Gauss-Markov)".into(),
                    parameters: params,
                    significance: serde_json::json!({"delta_bic": -f64::from(10) * ratio, "snr": ratio}),
                    // Block (1 s) means of the residual, before and after
                    // the wandering bias (a 60 s moving average) is modelled.
                    fit: serde_json::json!({"residual_rms_before": {CHANNELS[ch]: hb}, "residual_rms_after": {CHANNELS[ch]: ha}, "heldout_rms_before": hb, "heldout_rms_after": ha}),
                },
            ));
        }
    }
    findings.sort_by(|a, b| a.0.total_cmp(&b.0));
    serde_json::json!({
        "format": "rins-diagnose/1",
        "recording": recording_name,
        "nominal": {"residual_rms": resid_rms},
        "findings": findings.into_iter().map(|(_, f)| f).collect::<Vec<_>>(),
        "unexplained": unexplained,
    })
}
