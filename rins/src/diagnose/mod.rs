//! `rins diagnose`: compare a recording with what the simulator predicts for
//! the same run, locate the mismatch, name the physics the nominal model left
//! out (`shared/spec/diagnose-v1.md`), model it and show the fit improve.
//!
//! 1. Predict: the ideal sensor for the recorded table motion (the encoder's
//!    angle, its rate and acceleration by local quadratic fits, at the IMU
//!    times), the site's gravity and earth rate, the base attitude; minus the
//!    effects the given model already contains ([`Model`]).
//! 2. Nominal fit, per triad: `y = b + (I + M) x` (bias, scale,
//!    misalignment); only the terms the run excites (the others are
//!    collinear and are left out).
//! 3. Noise model, per channel: white + Gauss-Markov on block means
//!    ([`noise`]), fitted by maximum likelihood to the nominal residual. Its
//!    Kalman filter whitens the residual and every regressor: the fit is
//!    generalised least squares, so a wandering bias is not taken for
//!    signal.
//! 4. Explain: every candidate of the library ([`effects`]) is fitted
//!    jointly with the nominal terms (shared parameters across channels,
//!    e.g. one lever arm for three accelerometers). Selection is greedy by
//!    BIC (lower by at least 10: strong evidence) with five contiguous
//!    held-out segments (the whitened held-out residual must fall). Each
//!    finding is then judged against the final model (drop-one BIC), and
//!    checked for a look-alike: a candidate that explains the same signal
//!    as well is named with the experiment that would tell them apart.
//! 5. Model: nonlinear terms are refined (a time offset by re-predicting
//!    with it, a warm-up constant on a grid); the model with every finding
//!    is re-simulated per sample and the residual's rms, harmonics and Allan
//!    deviation before and after are reported and plotted.
//! 6. Bias instability: white + Gauss-Markov against white only (likelihood
//!    ratio, BIC), on the final residual; its one-step-ahead prediction (each
//!    block from the blocks before it) is the held-out check.
//! 7. Unexplained: table-angle harmonics and direction / ramp offsets left in
//!    the whitened final residual.
//!
//! Gram matrices (per channel, per held-out segment) hold everything a fit
//! needs, so each candidate costs a small linear solve; one hour at 100 Hz
//! is diagnosed in about a second.

pub mod effects;
pub mod locate;
pub mod noise;
pub mod show;

use effects::{Candidate, Kind};
use hal_sim::catalogue::EffectId;
use hal_sim::recording::Recording;
use nalgebra::{DMatrix, DVector, Matrix3, Rotation3, Unit, Vector3};
use noise::{Gains, Noise};
use std::collections::BTreeMap;

/// The six channels' names (recording-v1 columns).
pub const CHANNELS: [&str; 6] = crate::allan::CHANNELS;

/// BIC margin for a finding: lower by 10 is "very strong" evidence (Kass &
/// Raftery 1995).
pub const BIC_MARGIN: f64 = 10.0;

/// Prior 1-sigma of the nominal scale-factor and misalignment terms
/// (dimensionless): the nominal fit is physically bounded. MEMS datasheets
/// give scale errors and misalignments of 0.5-3 %; 5 % bounds them all, and
/// stops a gyro's scale from being "fitted" on the earth rate alone (a
/// horizontal gyro on a vertical-axis run sees nothing else).
pub const NOMINAL_PRIOR: f64 = 0.05;

/// The nominal model: the spec's (gravity, earth rate, table motion, bias,
/// scale, misalignment, white noise) plus effects it already contains.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The site's earth rate is in the model.
    pub earth_rate: bool,
    /// Effects the model contains, with their parameters (names as in the
    /// report; parameters not given are 0).
    pub known: BTreeMap<String, BTreeMap<String, f64>>,
}

impl Default for Model {
    fn default() -> Self {
        Self {
            earth_rate: true,
            known: BTreeMap::new(),
        }
    }
}

impl Model {
    /// Parses a model file:
    ///
    /// ```toml
    /// earth_rate = true                # default
    /// [known.lever_arm]                # effects the model already has
    /// lever_x_m = 0.02
    /// [known.time_offset]
    /// time_offset_s = 0.002
    /// ```
    ///
    /// # Errors
    /// Bad TOML, an unknown key, effect id or parameter, a non-number.
    pub fn from_toml(text: &str) -> Result<Self, String> {
        let t: toml::Table = text.parse().map_err(|e| format!("{e}"))?;
        let mut m = Self::default();
        for (k, v) in &t {
            match k.as_str() {
                "earth_rate" => {
                    m.earth_rate = v.as_bool().ok_or("earth_rate: expected true or false")?;
                }
                "known" => {
                    let tab = v.as_table().ok_or("known: expected a table of effects")?;
                    for (id, params) in tab {
                        if !EffectId::parse(id).is_some_and(EffectId::is_deterministic) {
                            return Err(format!(
                                "known.{id}: not an effect id with parameters; known: {}",
                                EffectId::ALL
                                    .iter()
                                    .filter(|e| e.is_deterministic())
                                    .map(|e| e.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ));
                        }
                        let pt = params
                            .as_table()
                            .ok_or_else(|| format!("known.{id}: expected parameters"))?;
                        let mut ps = BTreeMap::new();
                        for (pn, pv) in pt {
                            let x = pv
                                .as_float()
                                .or_else(|| pv.as_integer().map(|i| i as f64))
                                .filter(|x| x.is_finite())
                                .ok_or_else(|| format!("known.{id}.{pn}: expected a number"))?;
                            ps.insert(pn.clone(), x);
                        }
                        m.known.insert(id.clone(), ps);
                    }
                }
                other => {
                    return Err(format!(
                        "unknown key {other:?} (expected earth_rate, known)"
                    ))
                }
            }
        }
        Ok(m)
    }
}

/// How to diagnose.
#[derive(Clone, Debug)]
pub struct Options {
    /// The nominal model.
    pub model: Model,
    /// Block length for the regression, s (the residual is averaged over
    /// blocks; the noise model is fitted to the block means).
    pub block_s: f64,
    /// Contiguous held-out segments.
    pub folds: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            model: Model::default(),
            block_s: 0.2,
            folds: 5,
        }
    }
}

/// The ideal sensor and the table motion at each IMU sample.
#[derive(Clone, Debug, Default)]
pub struct Prediction {
    /// Time, s.
    pub t_s: Vec<f64>,
    /// Ideal rate in s (earth rate as the model has it + table rate), rad/s.
    pub w: Vec<Vector3<f64>>,
    /// Ideal specific force in s, m/s^2.
    pub f: Vec<Vector3<f64>>,
    /// Table angle, rate, acceleration (rad, rad/s, rad/s^2).
    pub theta: Vec<(f64, f64, f64)>,
    /// Temperature change from the first sample, deg C (0 if not recorded).
    pub dtemp: Vec<f64>,
    /// The recording has temperatures.
    pub temp_recorded: bool,
    /// The table axis `k` (same in `b` and `s`).
    pub k: Vector3<f64>,
    /// Specific force of gravity in the base frame `b`, m/s^2.
    pub f_b: Vector3<f64>,
    /// The site's full earth rate in `b`, rad/s.
    pub w_e_b: Vector3<f64>,
    /// Earth rate the prediction includes, rad/s (0 if the model has none).
    pub earth_in_model_radps: f64,
    /// Earth-rate part of `w` (as the model has it), rad/s in s.
    pub w_earth: Vec<Vector3<f64>>,
    /// Encoder read times, s, and angles, rad (as recorded).
    pub enc: (Vec<f64>, Vec<f64>),
    /// IMU samples are this late relative to their stamps, s.
    pub time_offset_s: f64,
    /// Measured samples minus the model's known effects: gyro (rad/s).
    pub y_w: Vec<Vector3<f64>>,
    /// See `y_w`: accel (m/s^2).
    pub y_f: Vec<Vector3<f64>>,
}

impl Prediction {
    /// Encoder angle at stamp `t` (rad): the read itself when one is stamped
    /// there (to 1 us), else the quadratic through the three nearest reads
    /// (exact on the constant-acceleration pieces of a table profile).
    pub fn angle_at(&self, t: f64) -> f64 {
        let (te, ae) = (&self.enc.0, &self.enc.1);
        let n = te.len();
        if n == 0 {
            return 0.0;
        }
        let j = te.partition_point(|x| *x < t);
        for c in [j.saturating_sub(1), j.min(n - 1)] {
            if (te[c] - t).abs() < 1e-6 {
                return ae[c];
            }
        }
        if n < 3 {
            return ae[j.min(n - 1)];
        }
        // Three nearest reads.
        let lo = if j == 0 {
            0
        } else if j >= n {
            n - 3
        } else if j + 1 < n && (te[j + 1] - t) < (t - te[j - 1]) {
            j - 1
        } else {
            j.saturating_sub(2)
        }
        .min(n - 3);
        let (t0, t1, t2) = (te[lo], te[lo + 1], te[lo + 2]);
        let (a0, a1, a2) = (ae[lo], ae[lo + 1], ae[lo + 2]);
        let l0 = (t - t1) * (t - t2) / ((t0 - t1) * (t0 - t2));
        let l1 = (t - t0) * (t - t2) / ((t1 - t0) * (t1 - t2));
        let l2 = (t - t0) * (t - t1) / ((t2 - t0) * (t2 - t1));
        a0 * l0 + a1 * l1 + a2 * l2
    }

    /// Ideal value of channel `ch` at sample `r`.
    pub fn truth(&self, ch: usize, r: usize) -> f64 {
        if ch < 3 {
            self.w[r][ch]
        } else {
            self.f[r][ch - 3]
        }
    }

    /// Measured value of channel `ch` at sample `r`.
    pub fn meas(&self, ch: usize, r: usize) -> f64 {
        if ch < 3 {
            self.y_w[r][ch]
        } else {
            self.y_f[r][ch - 3]
        }
    }

    /// The nominal regressor `j` (0 intercept, 1-3 the triad's truth) of
    /// channel `ch` at sample `r`.
    pub fn nominal(&self, ch: usize, j: usize, r: usize) -> f64 {
        if j == 0 {
            1.0
        } else if ch < 3 {
            self.w[r][j - 1]
        } else {
            self.f[r][j - 1]
        }
    }
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
    // 3x3 normal equations of the quadratic in (t - tq).
    let mut ata = Matrix3::<f64>::zeros();
    let mut aty = Vector3::<f64>::zeros();
    for r in lo..hi {
        let d = t[r] - tq;
        let row = Vector3::new(1.0, d, d * d);
        ata += row * row.transpose();
        aty += row * a[r];
    }
    match ata.cholesky() {
        Some(c) => {
            let s = c.solve(&aty);
            (s[0], s[1], 2.0 * s[2])
        }
        None => (a.get(i0).copied().unwrap_or(0.0), 0.0, 0.0),
    }
}

/// Predicts the ideal sensor for `rec` (the nominal world: earth rate scaled
/// by `earth_scale`, gravity, the table's motion about its nominal axis),
/// with the IMU samples `time_offset_s` late relative to their stamps.
pub fn predict(rec: &Recording, earth_scale: f64, time_offset_s: f64) -> Prediction {
    let m = &rec.meta;
    let site = m.site();
    let c_b_n = core_nav::site::c_b_n(&m.base());
    let k = Unit::new_normalize(m.axis.unit::<f64>());
    let te: Vec<f64> = rec.table.iter().map(|r| r.t_s).collect();
    let ae: Vec<f64> = rec.table.iter().map(|r| r.angle_rad).collect();
    let temp_recorded = rec.imu.iter().all(|r| r.temp_c.is_some()) && !rec.imu.is_empty();
    let temp0 = rec.imu.first().and_then(|r| r.temp_c).unwrap_or(25.0);
    // The ideal sensor in the base frame (the table at angle 0): the site's
    // one model (core-nav), here with the full earth rate.
    let (w_e_b, f_b) = site.ideal_imu(&c_b_n.transpose(), &Vector3::zeros());
    // The site as the model has it (its earth rate scaled).
    let model_site = core_nav::site::Site {
        earth_rate_scale: earth_scale,
        ..site
    };
    let mut p = Prediction {
        k: k.into_inner(),
        f_b,
        w_e_b,
        earth_in_model_radps: earth_scale * w_e_b.norm(),
        temp_recorded,
        enc: (te.clone(), ae.clone()),
        time_offset_s,
        ..Prediction::default()
    };
    let mut j = 0usize;
    for r in &rec.imu {
        let tq = r.t_s - time_offset_s;
        while j + 1 < te.len() && te[j + 1] <= tq {
            j += 1;
        }
        let (th, rate, acc) = table_at(&te, &ae, j, tq);
        let c_s_b: Matrix3<f64> = *Rotation3::from_axis_angle(&k, th).matrix();
        let c_n_s = (c_b_n * c_s_b).transpose();
        let (w, f) = model_site.ideal_imu(&c_n_s, &(k.into_inner() * rate));
        p.t_s.push(r.t_s);
        p.w_earth.push(w - k.into_inner() * rate);
        p.w.push(w);
        p.f.push(f);
        p.theta.push((th, rate, acc));
        p.dtemp.push(r.temp_c.map_or(0.0, |t| t - temp0));
        p.y_w.push(Vector3::from(r.gyro_radps));
        p.y_f.push(Vector3::from(r.accel_mps2));
    }
    p
}

/// Residual rms.
pub fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
}

/// Block means of `v` over `len` sample intervals: block `b` is the
/// trapezoid integral over samples `b len ..= (b + 1) len` (neighbours share
/// their edge sample) over its length, so a block is the mean over an
/// interval that starts and ends on a sample (where the encoder angle is
/// known), not over the samples' centres. A partial last block is dropped.
pub fn blocks(v: &[f64], len: usize) -> Vec<f64> {
    let len = len.max(1);
    let nb = v.len().saturating_sub(1) / len;
    (0..nb)
        .map(|b| {
            let s = &v[b * len..=(b + 1) * len];
            let inner: f64 = s[1..len].iter().sum();
            (inner + 0.5 * (s[0] + s[len])) / len as f64
        })
        .collect()
}

/// Who a design column belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Owner {
    /// Nominal term `j` of the channel (0 bias, 1-3 scale / misalignment).
    Nominal(usize),
    /// Parameter `param` of library candidate `cand`.
    Effect { cand: usize, param: usize },
}

/// One channel's design: columns, whitened and physical Grams per held-out
/// segment (`[X y]^T [X y]`, y last), the noise model.
struct ChannelDesign {
    owners: Vec<Owner>,
    gram_w: Vec<DMatrix<f64>>,
    gram_p: Vec<DMatrix<f64>>,
    rows: Vec<usize>,
    noise: Noise,
    /// Physical block means: columns, then y.
    zp: DMatrix<f64>,
}

/// Everything a fit needs.
struct Design {
    ch: Vec<ChannelDesign>,
    /// Encoder quantisation variance at a block edge per channel, unit^2.
    quant: [f64; 6],
    cands: Vec<Candidate>,
    names: Vec<Vec<String>>,
    folds: usize,
}

/// A solved model.
#[derive(Clone, Debug)]
struct Fit {
    /// Parameters: (owner channel for nominal / candidate, index) -> value.
    index: Vec<(Key, usize)>,
    beta: DVector<f64>,
    cov: DMatrix<f64>,
    /// Whitened residual sum of squares, all rows.
    rss_w: f64,
    /// Whitened held-out residual sum of squares.
    ho_w: f64,
    /// Physical rss per channel (all rows) and held-out rss per channel.
    rss_p: [f64; 6],
    ho_p: [f64; 6],
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Key {
    Nominal { ch: usize, j: usize },
    Effect { cand: usize, param: usize },
}

impl Fit {
    fn value(&self, key: Key) -> Option<(f64, f64)> {
        self.index
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, i)| (self.beta[*i], self.cov[(*i, *i)].max(0.0).sqrt()))
    }
}

fn key_of(ch: usize, o: Owner) -> Key {
    match o {
        Owner::Nominal(j) => Key::Nominal { ch, j },
        Owner::Effect { cand, param } => Key::Effect { cand, param },
    }
}

impl Design {
    fn build(
        p: &Prediction,
        cands: Vec<Candidate>,
        opts: &Options,
        noise: Option<&[Noise; 6]>,
    ) -> Self {
        let n = p.t_s.len();
        let dt = if n > 1 {
            (p.t_s[n - 1] - p.t_s[0]) / (n - 1) as f64
        } else {
            0.01
        };
        let len = ((opts.block_s / dt).round() as usize).max(1);
        let block_s = len as f64 * dt;
        let names = cands.iter().map(|c| c.params(p)).collect();
        // The truth's block means. Gyros: the earth rate's by the trapezoid,
        // the table's from the encoder angles at the block's edges (the
        // angle domain: encoder quantisation and the knots of the rate
        // profile are not differentiated into the rate).
        let nb = n.saturating_sub(1) / len;
        let table_mean: Vec<f64> = (0..nb)
            .map(|b| {
                let (ta, tb) = (p.t_s[b * len], p.t_s[(b + 1) * len]);
                let sh = p.time_offset_s;
                (p.angle_at(tb - sh) - p.angle_at(ta - sh)) / (tb - ta)
            })
            .collect();
        let truth_b: Vec<Vec<f64>> = (0..6)
            .map(|ch| {
                if ch < 3 {
                    let e = blocks(&p.w_earth.iter().map(|v| v[ch]).collect::<Vec<_>>(), len);
                    e.iter()
                        .zip(&table_mean)
                        .map(|(e, t)| e + p.k[ch] * t)
                        .collect()
                } else {
                    blocks(&p.f.iter().map(|v| v[ch - 3]).collect::<Vec<_>>(), len)
                }
            })
            .collect();
        // The encoder's quantisation at a block edge, per channel: the
        // quantum is the smallest step between reads; its error is uniform
        // (q^2 / 12), seen through the table axis over the block length.
        let q_enc = encoder_quantum(&p.enc.1);
        let quant: [f64; 6] = std::array::from_fn(|ch| {
            if ch < 3 {
                (p.k[ch] / block_s).powi(2) * q_enc * q_enc / 12.0
            } else {
                0.0
            }
        });
        // Columns per channel, block means.
        let mut cols: Vec<Vec<(Owner, Vec<f64>)>> = (0..6).map(|_| vec![]).collect();
        for (ch, v) in cols.iter_mut().enumerate() {
            v.push((Owner::Nominal(0), vec![1.0; nb]));
            for j in 1..4 {
                let src = if ch < 3 { j - 1 } else { j + 2 };
                v.push((Owner::Nominal(j), truth_b[src].clone()));
            }
        }
        for (ci, c) in cands.iter().enumerate() {
            for t in c.terms(p) {
                cols[t.ch].push((
                    Owner::Effect {
                        cand: ci,
                        param: t.param,
                    },
                    blocks(&t.col, len),
                ));
            }
        }
        let make = |ch: usize, cc: &Vec<(Owner, Vec<f64>)>| -> ChannelDesign {
            let y: Vec<f64> = blocks(&(0..n).map(|r| p.meas(ch, r)).collect::<Vec<_>>(), len)
                .iter()
                .zip(&truth_b[ch])
                .map(|(m, t)| m - t)
                .collect();
            // First pass: the noise model from the residual of the fullest
            // model (nominal + every candidate, OLS), so a slow effect
            // (warm-up) is not taken into the noise as a wandering bias
            // before it has been tried as physics.
            let nm = match noise {
                Some(ns) => ns[ch],
                None => {
                    let x = DMatrix::from_fn(nb, cc.len(), |r, c| cc[c].1[r]);
                    let res = ols_residual(&x, &DVector::from_vec(y.clone()));
                    noise::fit(res.as_slice(), block_s, quant[ch])
                }
            };
            let g: Gains = nm.gains(nb);
            let m = cc.len() + 1;
            let mut zw = DMatrix::<f64>::zeros(nb, m);
            let mut zp = DMatrix::<f64>::zeros(nb, m);
            let mut buf = vec![];
            let scale = 1.0 / nm.r.max(1e-300).sqrt();
            // Columns, then y last.
            for (c, col) in cc
                .iter()
                .map(|(_, v)| v.as_slice())
                .chain([y.as_slice()])
                .enumerate()
            {
                g.whiten_into(col, &mut buf);
                for r in 0..nb {
                    zw[(r, c)] = buf[r] * scale;
                    zp[(r, c)] = col[r];
                }
            }
            let folds = opts.folds.max(2);
            let mut gram_w = vec![];
            let mut gram_p = vec![];
            let mut rows = vec![];
            for f in 0..folds {
                let (a, b) = (f * nb / folds, (f + 1) * nb / folds);
                let sw = zw.rows(a, b - a);
                let sp = zp.rows(a, b - a);
                gram_w.push(sw.transpose() * sw);
                gram_p.push(sp.transpose() * sp);
                rows.push(b - a);
            }
            ChannelDesign {
                owners: cc.iter().map(|(o, _)| *o).collect(),
                gram_w,
                gram_p,
                rows,
                noise: nm,
                zp,
            }
        };
        // The six channels are independent: one thread each (the noise
        // fit is the larger part of a diagnosis).
        let chans: Vec<ChannelDesign> = std::thread::scope(|sc| {
            let handles: Vec<_> = cols
                .iter()
                .enumerate()
                .map(|(ch, cc)| sc.spawn(move || make(ch, cc)))
                .collect();
            handles
                .into_iter()
                .enumerate()
                .map(|(ch, h)| h.join().unwrap_or_else(|_| make(ch, &cols[ch])))
                .collect()
        });
        Self {
            ch: chans,
            cands,
            names,
            folds: opts.folds.max(2),
            quant,
        }
    }

    fn rows(&self) -> usize {
        self.ch.iter().map(|c| c.rows.iter().sum::<usize>()).sum()
    }

    /// Fits the nominal terms plus candidates `set`.
    fn fit(&self, set: &[usize]) -> Fit {
        // Parameter index.
        let mut index: Vec<(Key, usize)> = vec![];
        for (ch, cd) in self.ch.iter().enumerate() {
            for o in &cd.owners {
                let inc = match o {
                    Owner::Nominal(_) => true,
                    Owner::Effect { cand, .. } => set.contains(cand),
                };
                let k = key_of(ch, *o);
                if inc && !index.iter().any(|(x, _)| *x == k) {
                    let i = index.len();
                    index.push((k, i));
                }
            }
        }
        let mut active: Vec<bool> = vec![true; index.len()];
        loop {
            let ((mut a0, b0), _) = self.normal(&index, &active, None);
            add_prior(&mut a0, &index, &active);
            let full = (a0, b0);
            // Prune parameters the run does not excite (collinear with the
            // others to 1 part in 1e6, or no signal at all).
            let (a, _) = &full;
            let idx: Vec<usize> = (0..index.len()).filter(|i| active[*i]).collect();
            let sub = DMatrix::from_fn(idx.len(), idx.len(), |r, c| a[(idx[r], idx[c])]);
            let d: Vec<f64> = (0..idx.len())
                .map(|i| sub[(i, i)].max(0.0).sqrt())
                .collect();
            let sc = DMatrix::from_fn(idx.len(), idx.len(), |r, c| {
                if d[r] > 0.0 && d[c] > 0.0 {
                    sub[(r, c)] / (d[r] * d[c])
                } else if r == c {
                    1.0
                } else {
                    0.0
                }
            });
            let inv = (sc + DMatrix::identity(idx.len(), idx.len()) * 1e-12)
                .cholesky()
                .map(|c| c.inverse());
            let mut worst: Option<(usize, f64)> = None;
            for (i, &gi) in idx.iter().enumerate() {
                // 1 / (A^-1)_ii in scaled units: the share of the column
                // not explained by the others.
                let share = match &inv {
                    Some(m) if d[i] > 0.0 => 1.0 / m[(i, i)],
                    _ => 0.0,
                };
                if share < 1e-6 && worst.is_none_or(|(_, s)| share < s) {
                    worst = Some((gi, share));
                }
            }
            match worst {
                Some((gi, _)) => active[gi] = false,
                None => break,
            }
        }
        // Keep the active parameters, renumbered.
        let mut idx2 = vec![];
        for (k, i) in &index {
            if active[*i] {
                let j = idx2.len();
                idx2.push((*k, j));
            }
        }
        let all = vec![true; idx2.len()];
        let ((mut a, b), yy) = self.normal(&idx2, &all, None);
        add_prior(&mut a, &idx2, &all);
        let (beta, cov) = solve(&a, &b);
        let rss_w = quad(yy, &b, &a, &beta);
        let mut ho_w = 0.0;
        let mut ho_p = [0.0; 6];
        for f in 0..self.folds {
            let ((af, bf), yf) = self.normal(&idx2, &all, Some(f));
            let (bt, _) = solve(&(&a - &af), &(&b - &bf));
            ho_w += quad(yf, &bf, &af, &bt);
            for (ch, hp) in ho_p.iter_mut().enumerate() {
                *hp += self.phys(&idx2, ch, &bt, Some(f));
            }
        }
        let mut rss_p = [0.0; 6];
        for (ch, rp) in rss_p.iter_mut().enumerate() {
            *rp = self.phys(&idx2, ch, &beta, None);
        }
        Fit {
            index: idx2,
            beta,
            cov,
            rss_w,
            ho_w,
            rss_p,
            ho_p,
        }
    }

    /// Whitened normal equations over all rows (`fold` None) or one fold.
    #[allow(clippy::type_complexity)]
    fn normal(
        &self,
        index: &[(Key, usize)],
        active: &[bool],
        fold: Option<usize>,
    ) -> ((DMatrix<f64>, DVector<f64>), f64) {
        let np = index.len();
        let mut a = DMatrix::zeros(np, np);
        let mut b = DVector::zeros(np);
        let mut yy = 0.0;
        for (ch, cd) in self.ch.iter().enumerate() {
            let g = gram_sum(&cd.gram_w, fold);
            let m = cd.owners.len();
            let map: Vec<Option<usize>> = cd
                .owners
                .iter()
                .map(|o| {
                    let k = key_of(ch, *o);
                    index
                        .iter()
                        .find(|(x, i)| *x == k && active[*i])
                        .map(|(_, i)| *i)
                })
                .collect();
            for (r, mr) in map.iter().enumerate() {
                let Some(gr) = mr else { continue };
                b[*gr] += g[(r, m)];
                for (c, mc) in map.iter().enumerate() {
                    if let Some(gc) = mc {
                        a[(*gr, *gc)] += g[(r, c)];
                    }
                }
            }
            yy += g[(m, m)];
        }
        ((a, b), yy)
    }

    /// Physical residual sum of squares of channel `ch` under `beta`.
    fn phys(
        &self,
        index: &[(Key, usize)],
        ch: usize,
        beta: &DVector<f64>,
        fold: Option<usize>,
    ) -> f64 {
        let cd = &self.ch[ch];
        let g = gram_sum(&cd.gram_p, fold);
        let m = cd.owners.len();
        let mut coef = DVector::zeros(m + 1);
        coef[m] = -1.0;
        for (r, o) in cd.owners.iter().enumerate() {
            let k = key_of(ch, *o);
            if let Some((_, i)) = index.iter().find(|(x, _)| *x == k) {
                coef[r] = beta[*i];
            }
        }
        (coef.transpose() * g * &coef)[(0, 0)].max(0.0)
    }

    /// Block residual (physical) of channel `ch` under `fit`.
    fn block_residual(&self, fit: &Fit, ch: usize) -> Vec<f64> {
        let cd = &self.ch[ch];
        let m = cd.owners.len();
        let mut coef = DVector::zeros(m + 1);
        coef[m] = 1.0;
        for (r, o) in cd.owners.iter().enumerate() {
            let k = key_of(ch, *o);
            if let Some((_, i)) = fit.index.iter().find(|(x, _)| *x == k) {
                coef[r] = -fit.beta[*i];
            }
        }
        (&cd.zp * coef).iter().copied().collect()
    }

    fn nrows_ch(&self, ch: usize, fold: Option<usize>) -> usize {
        match fold {
            Some(f) => self.ch[ch].rows[f],
            None => self.ch[ch].rows.iter().sum(),
        }
    }
}

/// Adds the nominal prior's precision (scale and misalignment) to `a`.
fn add_prior(a: &mut DMatrix<f64>, index: &[(Key, usize)], active: &[bool]) {
    for (k, i) in index {
        if let Key::Nominal { j, .. } = k {
            if *j > 0 && active[*i] {
                a[(*i, *i)] += 1.0 / (NOMINAL_PRIOR * NOMINAL_PRIOR);
            }
        }
    }
}

/// The encoder's quantum, rad: the smallest non-zero step between
/// consecutive reads, if the steps are whole multiples of it (a quantised
/// encoder); 0 for an encoder whose angles are not on a grid.
pub fn encoder_quantum(a: &[f64]) -> f64 {
    let steps: Vec<f64> = a
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|d| *d > 1e-12)
        .collect();
    let q = steps.iter().copied().fold(f64::INFINITY, f64::min);
    if !q.is_finite() {
        return 0.0;
    }
    let on_grid = steps
        .iter()
        .take(2000)
        .all(|d| ((d / q) - (d / q).round()).abs() < 1e-3);
    if on_grid {
        q
    } else {
        0.0
    }
}

fn gram_sum(g: &[DMatrix<f64>], fold: Option<usize>) -> DMatrix<f64> {
    match fold {
        Some(f) => g[f].clone(),
        None => {
            let mut s = g[0].clone();
            for x in &g[1..] {
                s += x;
            }
            s
        }
    }
}

/// `y'y - 2 beta'b + beta'A beta`.
fn quad(yy: f64, b: &DVector<f64>, a: &DMatrix<f64>, beta: &DVector<f64>) -> f64 {
    (yy - 2.0 * beta.dot(b) + (beta.transpose() * a * beta)[(0, 0)]).max(0.0)
}

/// Solves `A beta = b` with diagonal scaling and a tiny ridge; returns beta
/// and `A^-1` (the covariance in whitened units).
fn solve(a: &DMatrix<f64>, b: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
    let n = a.nrows();
    let d: Vec<f64> = (0..n)
        .map(|i| {
            let v = a[(i, i)];
            if v > 0.0 {
                1.0 / v.sqrt()
            } else {
                0.0
            }
        })
        .collect();
    let s =
        DMatrix::from_fn(n, n, |r, c| a[(r, c)] * d[r] * d[c]) + DMatrix::identity(n, n) * 1e-12;
    match s.cholesky() {
        Some(ch) => {
            let inv = ch.inverse();
            let cov = DMatrix::from_fn(n, n, |r, c| inv[(r, c)] * d[r] * d[c]);
            let beta = &cov * b;
            (beta, cov)
        }
        None => (DVector::zeros(n), DMatrix::zeros(n, n)),
    }
}

/// Ordinary least-squares residual.
fn ols_residual(x: &DMatrix<f64>, y: &DVector<f64>) -> DVector<f64> {
    let (beta, _) = solve(&(x.transpose() * x), &(x.transpose() * y));
    y - x * beta
}

/// One finding of the report (diagnose-v1).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Finding {
    /// Effect id.
    #[serde(serialize_with = "effect_id")]
    pub effect: EffectId,
    /// Channels.
    pub channels: Vec<String>,
    /// Where the mismatch shows.
    #[serde(rename = "where")]
    pub where_: String,
    /// For a person.
    pub explanation: String,
    /// Fitted parameters (SI names), each with its 1-sigma as `sigma_<name>`.
    pub parameters: serde_json::Map<String, serde_json::Value>,
    /// delta_bic, snr.
    pub significance: serde_json::Value,
    /// Before / after rms.
    pub fit: serde_json::Value,
    /// The effect this one cannot be told apart from in this run, if any
    /// (also in `explanation`; not part of the spec's JSON).
    #[serde(skip)]
    pub lookalike: Option<EffectId>,
}

fn effect_id<S: serde::Serializer>(e: &EffectId, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(e.as_str())
}

/// A mismatch no effect explains.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Unexplained {
    /// Channels.
    pub channels: Vec<String>,
    /// Where.
    #[serde(rename = "where")]
    pub where_: String,
    /// Amplitude over its standard error.
    pub snr: f64,
}

/// What a person reads beyond the JSON, and what the plots draw.
#[derive(Clone, Debug, Default)]
pub struct Details {
    /// Noise model per channel (fitted to the final residual).
    pub noise: Vec<Noise>,
    /// Candidates not excited by this run, with the experiment that would.
    pub not_observable: Vec<(String, String)>,
    /// Locate: the nominal residual split by motion and time.
    pub locate: locate::Locate,
    /// Block length, s.
    pub block_s: f64,
    /// Sample time, s.
    pub dt_s: f64,
    /// Per-sample residual before (nominal) and after (every finding), per
    /// channel.
    pub res_before: [Vec<f64>; 6],
    /// See `res_before`.
    pub res_after: [Vec<f64>; 6],
    /// Table angle per sample, rad.
    pub theta: Vec<f64>,
    /// Time per sample, s.
    pub t_s: Vec<f64>,
    /// Ljung-Box whiteness of the whitened final residual per channel:
    /// (statistic, lags).
    pub whiteness: Vec<(f64, usize)>,
}

/// The report.
#[derive(Clone, Debug)]
pub struct Diagnosis {
    /// The `rins-diagnose/1` JSON.
    pub json: serde_json::Value,
    /// Findings, most significant first.
    pub findings: Vec<Finding>,
    /// Unexplained mismatches.
    pub unexplained: Vec<Unexplained>,
    /// For the text report and the plots.
    pub details: Details,
}

/// The known effects' contribution, subtracted from the measurements.
fn apply_known(p: &mut Prediction, model: &Model) -> Result<(), String> {
    for (id, params) in &model.known {
        if id == "time_offset" || id == "earth_rate" {
            continue; // in the prediction itself
        }
        let cands: Vec<Candidate> = effects::library(p)
            .into_iter()
            .filter(|c| c.id == id.as_str())
            .collect();
        for c in &cands {
            let names = c.params(p);
            let terms = c.terms(p);
            for (pi, pname) in names.iter().enumerate() {
                let Some(v) = params.get(pname) else { continue };
                for t in terms.iter().filter(|t| t.param == pi) {
                    for (r, x) in t.col.iter().enumerate() {
                        if t.ch < 3 {
                            p.y_w[r][t.ch] -= v * x;
                        } else {
                            p.y_f[r][t.ch - 3] -= v * x;
                        }
                    }
                }
            }
        }
        let all: Vec<String> = cands.iter().flat_map(|c| c.params(p)).collect();
        if let Some(bad) = params.keys().find(|k| !all.contains(k)) {
            return Err(format!(
                "model: known.{id}.{bad} is not a parameter of {id} in this run; its parameters: {}",
                all.join(", ")
            ));
        }
    }
    Ok(())
}

fn check(rec: &Recording) -> Result<(), String> {
    if rec.imu.len() < 200 {
        return Err(format!(
            "{} IMU samples: too short to diagnose (need at least 200)",
            rec.imu.len()
        ));
    }
    if rec.table.len() < 5 {
        return Err(format!(
            "{} encoder reads: need at least 5",
            rec.table.len()
        ));
    }
    for (i, r) in rec.imu.iter().enumerate() {
        if !(r.t_s.is_finite()
            && r.gyro_radps.iter().all(|v| v.is_finite())
            && r.accel_mps2.iter().all(|v| v.is_finite()))
        {
            return Err(format!("imu sample {i} (t = {} s) is not finite", r.t_s));
        }
    }
    if let Some(i) = rec
        .table
        .iter()
        .position(|r| !(r.t_s.is_finite() && r.angle_rad.is_finite()))
    {
        return Err(format!("encoder read {i} is not finite"));
    }
    Ok(())
}

/// Selected model: candidates (library indices), each finding's drop-one
/// statistics.
struct Selection {
    set: Vec<usize>,
    fit: Fit,
}

fn select(d: &Design) -> Selection {
    let ln_n = (d.rows().max(2) as f64).ln();
    let mut set: Vec<usize> = vec![];
    let mut cur = d.fit(&set);
    loop {
        let mut best: Option<(f64, usize, Fit)> = None;
        for ci in 0..d.cands.len() {
            let id = d.cands[ci].id;
            if set.iter().any(|s| d.cands[*s].id == id) {
                continue;
            }
            let mut with = set.clone();
            with.push(ci);
            let f = d.fit(&with);
            let k = params_of(&f, ci);
            if k == 0 {
                continue;
            }
            let dbic = (f.rss_w - cur.rss_w) + k as f64 * ln_n;
            if dbic < -BIC_MARGIN
                && f.ho_w < cur.ho_w
                && best.as_ref().is_none_or(|(b, _, _)| dbic < *b)
            {
                best = Some((dbic, ci, f));
            }
        }
        match best {
            Some((_, ci, f)) => {
                set.push(ci);
                cur = f;
            }
            None => break,
        }
    }
    // Backward check: every member must still earn its place.
    loop {
        let mut drop = None;
        for (pos, &ci) in set.iter().enumerate() {
            let rest: Vec<usize> = set.iter().copied().filter(|x| *x != ci).collect();
            let f0 = d.fit(&rest);
            let k = params_of(&cur, ci);
            let dbic = (cur.rss_w - f0.rss_w) + k as f64 * ln_n;
            if dbic >= -BIC_MARGIN {
                drop = Some((pos, f0));
                break;
            }
        }
        match drop {
            Some((pos, f0)) => {
                set.remove(pos);
                cur = f0;
            }
            None => break,
        }
    }
    Selection { set, fit: cur }
}

fn params_of(f: &Fit, ci: usize) -> usize {
    f.index
        .iter()
        .filter(|(k, _)| matches!(k, Key::Effect { cand, .. } if *cand == ci))
        .count()
}

/// Runs the diagnosis.
///
/// # Errors
/// A recording too short, without encoder reads, or with non-finite
/// samples; a model that names parameters the library does not have.
pub fn run(rec: &Recording, recording_name: &str, opts: &Options) -> Result<Diagnosis, String> {
    check(rec)?;
    let model = &opts.model;
    let earth_scale = if model.earth_rate { 1.0 } else { 0.0 };
    let earth_known = model
        .known
        .get("earth_rate")
        .and_then(|m| m.get("earth_rate_radps"))
        .copied();
    let dt_known = model
        .known
        .get("time_offset")
        .and_then(|m| m.get("time_offset_s"))
        .copied()
        .unwrap_or(0.0);
    let omega = core_nav::earth::EARTH_RATE_RADPS;
    let earth_scale = earth_known.map_or(earth_scale, |w| w / omega);
    let mut p = predict(rec, earth_scale, dt_known);
    apply_known(&mut p, model)?;
    let blocks_n = (p.t_s.len() - 1) / ((opts.block_s / dt_of(&p)).round() as usize).max(1);
    if !(opts.block_s.is_finite() && opts.block_s > 0.0) || blocks_n < 50 {
        return Err(format!(
            "{blocks_n} blocks of {} s: the regression needs at least 50 (a shorter block or a longer recording)",
            opts.block_s
        ));
    }
    let lib = |p: &Prediction| -> Vec<Candidate> {
        effects::library(p)
            .into_iter()
            .filter(|c| !model.known.contains_key(c.id.as_str()))
            .collect()
    };
    // Pass 1: noise from the nominal residual; pass 2: from the residual of
    // the selected model (more power once the found effects are out of it).
    let d1 = Design::build(&p, lib(&p), opts, None);
    let s1 = select(&d1);
    let noise2 = final_noise(&d1, &s1);
    let mut d = Design::build(&p, lib(&p), opts, Some(&noise2));
    let mut sel = select(&d);
    // Significance, look-alikes and held-out checks come from the design the
    // selection was made on; the refinement below only sharpens values.
    let judged = report_stats(&d, &sel);
    // Nonlinear refinement: a time offset by re-predicting with it.
    let mut time_offset = dt_known;
    for _ in 0..3 {
        let Some(ci) = sel
            .set
            .iter()
            .copied()
            .find(|c| d.cands[*c].kind == Kind::TimeOffset)
        else {
            break;
        };
        let Some((dt, sd)) = sel.fit.value(Key::Effect { cand: ci, param: 0 }) else {
            break;
        };
        time_offset += dt;
        p = predict(rec, earth_scale, time_offset);
        apply_known(&mut p, model)?;
        d = Design::build(&p, lib(&p), opts, Some(&noise2));
        let set = sel.set.clone();
        sel = Selection {
            fit: d.fit(&set),
            set,
        };
        if dt.abs() < 0.01 * sd {
            break;
        }
    }
    report(
        recording_name,
        &p,
        &d,
        &sel,
        &judged,
        time_offset - dt_known,
    )
}

/// Noise models re-fitted to the residual of a selection.
fn final_noise(d: &Design, s: &Selection) -> [Noise; 6] {
    let block_s = d.ch[0].noise.block_s;
    let fit = |ch: usize| noise::fit(&d.block_residual(&s.fit, ch), block_s, d.quant[ch]);
    let v: Vec<Noise> = std::thread::scope(|sc| {
        let hs: Vec<_> = (0..6).map(|ch| sc.spawn(move || fit(ch))).collect();
        hs.into_iter()
            .enumerate()
            .map(|(ch, h)| h.join().unwrap_or_else(|_| fit(ch)))
            .collect()
    });
    std::array::from_fn(|ch| v[ch])
}

fn dt_of(p: &Prediction) -> f64 {
    let n = p.t_s.len();
    if n > 1 {
        (p.t_s[n - 1] - p.t_s[0]) / (n - 1) as f64
    } else {
        0.01
    }
}

/// Per-sample residual of the model `fit` (its nominal terms and effects):
/// the re-simulation. `extra_shift` is a time offset already applied.
fn sample_residuals(p: &Prediction, d: &Design, fit: &Fit) -> [Vec<f64>; 6] {
    let n = p.t_s.len();
    let mut out: [Vec<f64>; 6] =
        std::array::from_fn(|ch| (0..n).map(|r| p.meas(ch, r) - p.truth(ch, r)).collect());
    for (key, i) in &fit.index {
        let b = fit.beta[*i];
        if let Key::Nominal { ch, j } = key {
            for (r, v) in out[*ch].iter_mut().enumerate() {
                *v -= b * p.nominal(*ch, *j, r);
            }
        }
    }
    let mut cands: Vec<usize> = fit
        .index
        .iter()
        .filter_map(|(k, _)| match k {
            Key::Effect { cand, .. } => Some(*cand),
            Key::Nominal { .. } => None,
        })
        .collect();
    cands.dedup();
    for ci in cands {
        for t in d.cands[ci].terms(p) {
            if let Some((b, _)) = fit.value(Key::Effect {
                cand: ci,
                param: t.param,
            }) {
                for (v, x) in out[t.ch].iter_mut().zip(&t.col) {
                    *v -= b * x;
                }
            }
        }
    }
    out
}

/// A finding's statistics, judged on the design it was selected on.
struct Judged {
    dbic: f64,
    snr: f64,
    channels: Vec<usize>,
    explanation: String,
    lookalike: Option<EffectId>,
    fit: serde_json::Value,
}

/// Drop-one BIC, held-out figures and look-alikes of every selected
/// candidate.
fn report_stats(d: &Design, sel: &Selection) -> Vec<(usize, Judged)> {
    let ln_n = (d.rows().max(2) as f64).ln();
    let mut out = vec![];
    for &ci in &sel.set {
        let c = &d.cands[ci];
        let rest: Vec<usize> = sel.set.iter().copied().filter(|x| *x != ci).collect();
        let f0 = d.fit(&rest);
        let f1 = &sel.fit;
        let k = params_of(f1, ci);
        let dchi = (f0.rss_w - f1.rss_w).max(0.0);
        let dbic = -dchi + k as f64 * ln_n;
        let chans: Vec<usize> = (0..6)
            .filter(|ch| {
                d.ch[*ch].owners.iter().any(|o| match o {
                    Owner::Effect { cand, param } => {
                        *cand == ci
                            && f1
                                .value(Key::Effect {
                                    cand: ci,
                                    param: *param,
                                })
                                .is_some()
                    }
                    Owner::Nominal(_) => false,
                })
            })
            .filter(|ch| (f0.rss_p[*ch] - f1.rss_p[*ch]).abs() > 1e-9 * f0.rss_p[*ch])
            .collect();
        let (mut before, mut after) = (serde_json::Map::new(), serde_json::Map::new());
        let (mut hb, mut ha, mut nr) = (0.0, 0.0, 0usize);
        for &ch in &chans {
            let nrow = d.nrows_ch(ch, None).max(1) as f64;
            before.insert(CHANNELS[ch].into(), (f0.rss_p[ch] / nrow).sqrt().into());
            after.insert(CHANNELS[ch].into(), (f1.rss_p[ch] / nrow).sqrt().into());
            hb += f0.ho_p[ch];
            ha += f1.ho_p[ch];
            nr += d.nrows_ch(ch, None);
        }
        let nr = nr.max(1) as f64;
        // Look-alikes: a candidate not chosen that, in place of this one,
        // explains as much (within the BIC margin).
        let mut explanation = c.explain().to_string();
        let mut lookalike = None;
        for (di, dc) in d.cands.iter().enumerate() {
            if dc.id == c.id || sel.set.iter().any(|s| d.cands[*s].id == dc.id) {
                continue;
            }
            let mut alt = rest.clone();
            alt.push(di);
            let fa = d.fit(&alt);
            let ka = params_of(&fa, di);
            if ka == 0 {
                continue;
            }
            let dbic_alt = -(f0.rss_w - fa.rss_w).max(0.0) + ka as f64 * ln_n;
            if dbic_alt < -BIC_MARGIN && dbic_alt - dbic < BIC_MARGIN {
                explanation += &format!(
                    ". In this run it cannot be told apart from {} (delta BIC {:.0} against {:.0}): to separate them, {}",
                    dc.id,
                    dbic_alt,
                    dbic,
                    effects::separate(c.id, dc.id)
                );
                lookalike = Some(dc.id);
                break;
            }
        }
        out.push((
            ci,
            Judged {
                dbic,
                snr: dchi.sqrt(),
                channels: chans,
                explanation,
                lookalike,
                fit: serde_json::json!({
                    "residual_rms_before": before,
                    "residual_rms_after": after,
                    "heldout_rms_before": (hb / nr).sqrt(),
                    "heldout_rms_after": (ha / nr).sqrt(),
                }),
            },
        ));
    }
    out
}

fn report(
    name: &str,
    p: &Prediction,
    d: &Design,
    sel: &Selection,
    judged: &[(usize, Judged)],
    time_offset_fitted: f64,
) -> Result<Diagnosis, String> {
    let ln_n = (d.rows().max(2) as f64).ln();
    let nominal_fit = d.fit(&[]);
    let res_before = sample_residuals(p, d, &nominal_fit);
    let res_after = sample_residuals(p, d, &sel.fit);
    let mut resid_rms = serde_json::Map::new();
    for (ch, nm) in CHANNELS.iter().enumerate() {
        resid_rms.insert((*nm).into(), rms(&res_before[ch]).into());
    }
    let mut findings: Vec<(f64, Finding)> = vec![];
    for (ci, j) in judged {
        let c = &d.cands[*ci];
        let f1 = &sel.fit;
        let mut params = serde_json::Map::new();
        for (pi, pn) in d.names[*ci].iter().enumerate() {
            if let Some((mut v, s)) = f1.value(Key::Effect {
                cand: *ci,
                param: pi,
            }) {
                if c.kind == Kind::EarthRate {
                    v += p.earth_in_model_radps;
                }
                if c.kind == Kind::TimeOffset {
                    v = time_offset_fitted;
                }
                params.insert(pn.clone(), v.into());
                params.insert(format!("sigma_{pn}"), s.into());
            }
        }
        for (pn, v) in c.fixed() {
            params.insert(pn, v.into());
        }
        findings.push((
            j.dbic,
            Finding {
                effect: c.id,
                channels: j
                    .channels
                    .iter()
                    .map(|c| CHANNELS[*c].to_string())
                    .collect(),
                where_: c.where_().into(),
                explanation: j.explanation.clone(),
                lookalike: j.lookalike.clone(),
                parameters: params,
                significance: serde_json::json!({"delta_bic": j.dbic, "snr": j.snr}),
                fit: j.fit.clone(),
            },
        ));
    }
    // Bias instability: white + Gauss-Markov against white only, on the
    // final residual's block means.
    let dt = dt_of(p);
    let block_s = d.ch[0].noise.block_s;
    let len = ((block_s / dt).round() as usize).max(1);
    let mut noise_final = vec![];
    let mut whiteness = vec![];
    let fits: Vec<(Vec<f64>, Noise, Noise)> = std::thread::scope(|sc| {
        let one = |ch: usize| {
            let z = d.block_residual(&sel.fit, ch);
            let gm = noise::fit(&z, block_s, d.quant[ch]);
            let wn = noise::fit_white(&z, block_s, d.quant[ch]);
            (z, gm, wn)
        };
        let hs: Vec<_> = (0..6).map(|ch| sc.spawn(move || one(ch))).collect();
        hs.into_iter()
            .enumerate()
            .map(|(ch, h)| h.join().unwrap_or_else(|_| one(ch)))
            .collect()
    });
    for triad in 0..2 {
        let mut params = serde_json::Map::new();
        let (mut chans, mut dbic_sum, mut chi) = (vec![], 0.0, 0.0f64);
        let (mut before, mut after) = (serde_json::Map::new(), serde_json::Map::new());
        let (mut hb, mut ha, mut nr) = (0.0, 0.0, 0.0);
        for i in 0..3 {
            let ch = 3 * triad + i;
            let (z, gm, wn) = (&fits[ch].0, fits[ch].1, fits[ch].2);
            noise_final.push(gm);
            let mut wz = vec![];
            gm.gains(z.len()).whiten_into(z, &mut wz);
            whiteness.push(locate::ljung_box(&wz, 20));
            let dll = gm.loglik - wn.loglik;
            let dbic = -2.0 * dll + 2.0 * (z.len().max(2) as f64).ln();
            if dbic >= -BIC_MARGIN || gm.lambda <= 0.0 {
                continue;
            }
            // Held out: each block predicted from the blocks before it.
            let innov = gm.gains(z.len()).innovations(z);
            let mean = z.iter().sum::<f64>() / z.len().max(1) as f64;
            let b2: f64 = z.iter().map(|v| (v - mean).powi(2)).sum();
            let a2: f64 = innov.iter().map(|v| v * v).sum();
            if a2 >= b2 {
                continue;
            }
            let nz = z.len() as f64;
            hb += b2;
            ha += a2;
            nr += nz;
            chans.push(ch);
            dbic_sum += dbic;
            chi = chi.max((2.0 * dll).max(0.0).sqrt());
            before.insert(CHANNELS[ch].into(), (b2 / nz).sqrt().into());
            after.insert(CHANNELS[ch].into(), (a2 / nz).sqrt().into());
            let (ax, unit, wunit) = (
                ["x", "y", "z"][i],
                ["radps", "mps2"][triad],
                ["rad_per_sqrt_s", "mps_per_sqrt_s"][triad],
            );
            let (_, b_allan, _) = allan_excess(&res_after[ch], dt);
            params.insert(format!("bias_instability_{ax}_{unit}"), b_allan.into());
            params.insert(format!("gm_sigma_{ax}_{unit}"), gm.gm_sigma().into());
            params.insert(format!("gm_tau_{ax}_s"), gm.tau_s().min(1e12).into());
            params.insert(
                format!("white_noise_{ax}_{wunit}"),
                gm.white_density().into(),
            );
        }
        if !chans.is_empty() {
            findings.push((
                dbic_sum,
                Finding {
                    effect: EffectId::BiasInstability,
                    channels: chans.iter().map(|c| CHANNELS[*c].to_string()).collect(),
                    where_: "long averaging times: the residual's Allan deviation stops falling as white noise does; block means correlated over minutes".into(),
                    explanation: format!(
                        "a constant bias and white noise do not explain the {}: the bias wanders (Gauss-Markov / flicker); modelled, each {:.1} s mean is predicted from the ones before it",
                        ["gyros", "accelerometers"][triad],
                        block_s
                    ),
                    parameters: params,
                    significance: serde_json::json!({"delta_bic": dbic_sum, "snr": chi}),
                    fit: serde_json::json!({
                        "residual_rms_before": before,
                        "residual_rms_after": after,
                        "heldout_rms_before": (hb / nr.max(1.0)).sqrt(),
                        "heldout_rms_after": (ha / nr.max(1.0)).sqrt(),
                    }),
                    lookalike: None,
                },
            ));
        }
    }
    findings.sort_by(|a, b| a.0.total_cmp(&b.0));
    let findings: Vec<Finding> = findings.into_iter().map(|(_, f)| f).collect();
    // Not excited by this run.
    let mut not_observable = vec![];
    let mut seen: Vec<EffectId> = vec![];
    for (ci, c) in d.cands.iter().enumerate() {
        if seen.contains(&c.id) {
            continue;
        }
        let same: Vec<usize> = d
            .cands
            .iter()
            .enumerate()
            .filter(|(_, x)| x.id == c.id)
            .map(|(i, _)| i)
            .collect();
        let excited = same.iter().any(|&i| {
            let mut s: Vec<usize> = sel
                .set
                .iter()
                .copied()
                .filter(|x| d.cands[*x].id != c.id)
                .collect();
            s.push(i);
            params_of(&d.fit(&s), i) > 0
        });
        if !excited {
            not_observable.push((c.id.as_str().to_string(), d.cands[ci].excite().to_string()));
        }
        seen.push(c.id);
    }
    let locate = locate::locate(p, &res_before, dt);
    let block_res: Vec<Vec<f64>> = (0..6).map(|ch| d.block_residual(&sel.fit, ch)).collect();
    let unexplained = locate::unexplained(p, &block_res, &noise_final, len, ln_n);
    let json = serde_json::json!({
        "format": "rins-diagnose/1",
        "recording": name,
        "nominal": {"residual_rms": resid_rms},
        "findings": findings,
        "unexplained": unexplained,
    });
    Ok(Diagnosis {
        json,
        findings,
        unexplained,
        details: Details {
            noise: noise_final,
            not_observable,
            locate,
            block_s,
            dt_s: dt,
            res_before,
            res_after,
            theta: p.theta.iter().map(|t| t.0).collect(),
            t_s: p.t_s.clone(),
            whiteness,
        },
    })
}

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
/// projected out. The detection statistic of [`run`] for that effect is
/// noncentral chi^2 with `k` degrees of freedom and this `lambda`. Returns
/// `(lambda, k, N)` with `k` the effect's parameters the run excites and `N`
/// the regression's rows (the BIC's sample size).
///
/// # Errors
/// As [`run`]; runs of different lengths.
pub fn fisher(
    null: &Recording,
    sig_null: &Recording,
    sig_with: &Recording,
    effect: EffectId,
    opts: &Options,
) -> Result<(f64, usize, usize), String> {
    for r in [null, sig_null, sig_with] {
        check(r)?;
    }
    if null.imu.len() != sig_with.imu.len() || sig_null.imu.len() != sig_with.imu.len() {
        return Err("the runs have different lengths".into());
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
