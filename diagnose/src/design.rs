//! The regression: block means of the nominal terms and every candidate's
//! regressors, whitened by each channel's noise model, held as Gram
//! matrices per held-out segment so a fit is a small linear solve.

use super::effects::Candidate;
use super::noise::{self, Gains, Noise};
use super::{encoder_quantum, Options, Prediction, NOMINAL_PRIOR};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// Who a design column belongs to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Owner {
    /// Nominal term `j` of the channel (0 bias, 1-3 scale / misalignment).
    Nominal(usize),
    /// Parameter `param` of library candidate `cand`.
    Effect { cand: usize, param: usize },
}

/// One channel's design: columns, whitened and physical Grams per held-out
/// segment (`[X y]^T [X y]`, y last), the noise model.
#[derive(Clone)]
pub(super) struct ChannelDesign {
    pub(super) owners: Vec<Owner>,
    pub(super) gram_w: Vec<DMatrix<f64>>,
    pub(super) gram_p: Vec<DMatrix<f64>>,
    pub(super) rows: Vec<usize>,
    pub(super) noise: Noise,
    /// Physical block means: columns, then y.
    pub(super) zp: DMatrix<f64>,
}

impl ChannelDesign {
    /// A channel the recording does not have (gyro-only: the
    /// accelerometers): no columns, no rows, nothing to fit.
    fn not_recorded(nb: usize, folds: usize, block_s: f64) -> Self {
        Self {
            owners: vec![],
            gram_w: vec![DMatrix::zeros(1, 1); folds],
            gram_p: vec![DMatrix::zeros(1, 1); folds],
            rows: vec![0; folds],
            noise: Noise::none(block_s),
            zp: DMatrix::zeros(nb, 1),
        }
    }

    /// A recorded channel's design from its physical block means `zp`
    /// (columns of `owners`, then y) under the noise model `nm`: whitened
    /// and physical Grams per held-out segment.
    fn whitened(owners: Vec<Owner>, zp: DMatrix<f64>, nm: Noise, folds: usize) -> Self {
        let (nb, m) = zp.shape();
        let g: Gains = nm.gains(nb);
        let mut zw = DMatrix::<f64>::zeros(nb, m);
        let mut buf = vec![];
        let scale = 1.0 / nm.r.max(1e-300).sqrt();
        // Column-major storage: one column a chunk.
        for (c, col) in zp.as_slice().chunks(nb.max(1)).enumerate() {
            g.whiten_into(col, &mut buf);
            for (r, b) in buf.iter().enumerate().take(nb) {
                zw[(r, c)] = b * scale;
            }
        }
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
        Self {
            owners,
            gram_w,
            gram_p,
            rows,
            noise: nm,
            zp,
        }
    }
}

/// Everything a fit needs.
pub(super) struct Design {
    pub(super) ch: Vec<ChannelDesign>,
    /// Encoder quantisation variance at a block edge per channel, unit^2.
    pub(super) quant: [f64; 6],
    pub(super) cands: Vec<Candidate>,
    pub(super) names: Vec<Vec<String>>,
    pub(super) folds: usize,
    /// Candidate parameters this run cannot see at any physically possible
    /// size ([`unseen`]): never fitted.
    pub(super) unseen: Vec<Key>,
}

/// A solved model.
#[derive(Clone, Debug)]
pub(super) struct Fit {
    /// Parameters: (owner channel for nominal / candidate, index) -> value.
    pub(super) index: Vec<(Key, usize)>,
    pub(super) beta: DVector<f64>,
    pub(super) cov: DMatrix<f64>,
    /// Whitened residual sum of squares, all rows.
    pub(super) rss_w: f64,
    /// Whitened held-out residual sum of squares.
    pub(super) ho_w: f64,
    /// Physical rss per channel (all rows) and held-out rss per channel.
    pub(super) rss_p: [f64; 6],
    pub(super) ho_p: [f64; 6],
    /// Whitened held-out rss per channel (each block's residual over the
    /// noise model's prediction of it: a drift between folds counts as
    /// the noise it is, not as misfit).
    pub(super) ho_wc: [f64; 6],
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Key {
    Nominal { ch: usize, j: usize },
    Effect { cand: usize, param: usize },
}

impl Fit {
    pub(super) fn value(&self, key: Key) -> Option<(f64, f64)> {
        self.index
            .iter()
            .find(|(k, _)| *k == key)
            .map(|(_, i)| (self.beta[*i], self.cov[(*i, *i)].max(0.0).sqrt()))
    }
}

pub(super) fn key_of(ch: usize, o: Owner) -> Key {
    match o {
        Owner::Nominal(j) => Key::Nominal { ch, j },
        Owner::Effect { cand, param } => Key::Effect { cand, param },
    }
}

impl Design {
    pub(super) fn build(
        p: &Prediction,
        cands: Vec<Candidate>,
        opts: &Options,
        noise: Option<&[Noise; 6]>,
    ) -> Self {
        let n = p.t_s.len();
        let dt = p.dt_s;
        let len = ((opts.block_s / dt).round() as usize).max(1);
        let block_s = len as f64 * dt;
        let bl = p.blocks(len);
        let blocks = |v: &[f64]| bl.mean(v);
        let names = cands.iter().map(|c| c.params(p)).collect();
        // The truth's block means. Gyros: the earth rate's by the trapezoid,
        // the table's from the encoder angles at the block's edges (the
        // angle domain: encoder quantisation and the knots of the rate
        // profile are not differentiated into the rate).
        let nb = bl.count();
        let table_mean: Vec<f64> = bl
            .starts
            .iter()
            .map(|a| {
                let (ta, tb) = (p.t_s[*a], p.t_s[a + len]);
                let sh = p.time_offset_s;
                (p.angle_at(tb - sh) - p.angle_at(ta - sh)) / (tb - ta)
            })
            .collect();
        let truth_b: Vec<Vec<f64>> = (0..6)
            .map(|ch| {
                if ch < 3 {
                    let e = blocks(&p.w_earth.iter().map(|v| v[ch]).collect::<Vec<_>>());
                    e.iter()
                        .zip(&table_mean)
                        .map(|(e, t)| e + p.k[ch] * t)
                        .collect()
                } else {
                    blocks(&p.f.iter().map(|v| v[ch - 3]).collect::<Vec<_>>())
                }
            })
            .collect();
        // The encoder track's error at a block edge, per channel: the
        // encoder's quantisation (the quantum is the smallest step between
        // reads; its error uniform, q^2 / 12) or, where the track's pieces
        // miss the reads by more (motion their shapes cannot follow), the
        // track's own misfit; seen through the table axis over the block.
        let q_enc = encoder_quantum(p.track.angles());
        let edge_var = (q_enc * q_enc / 12.0).max(p.track.misfit_var());
        let quant: [f64; 6] = std::array::from_fn(|ch| {
            if ch < 3 {
                (p.k[ch] / block_s).powi(2) * edge_var
            } else {
                0.0
            }
        });
        // Columns per channel, block means.
        let mut cols: Vec<Vec<(Owner, Vec<f64>)>> = (0..6).map(|_| vec![]).collect();
        for (ch, v) in cols.iter_mut().enumerate() {
            if !p.recorded(ch) {
                continue;
            }
            v.push((Owner::Nominal(0), vec![1.0; nb]));
            for j in 1..4 {
                let src = if ch < 3 { j - 1 } else { j + 2 };
                v.push((Owner::Nominal(j), truth_b[src].clone()));
            }
        }
        // Each candidate's regressors and their block means in parallel (the
        // full-rate columns are the larger part of a design), then in the
        // library's order.
        let per_cand: Vec<Vec<(usize, Owner, Vec<f64>)>> = cands
            .par_iter()
            .enumerate()
            .map(|(ci, c)| {
                // A column of exact zeros is no regressor (a wobble's
                // parts on the table-axis gyro): the channel is not the
                // candidate's to claim.
                c.terms(p)
                    .into_iter()
                    .filter(|t| p.recorded(t.ch) && t.col.iter().any(|x| *x != 0.0))
                    .map(|t| {
                        let owner = Owner::Effect {
                            cand: ci,
                            param: t.param,
                        };
                        (t.ch, owner, blocks(&t.col))
                    })
                    .collect()
            })
            .collect();
        for (ch, owner, col) in per_cand.into_iter().flatten() {
            if let Some(v) = cols.get_mut(ch) {
                v.push((owner, col));
            }
        }
        let folds = opts.folds.max(2);
        let make = |ch: usize, cc: &Vec<(Owner, Vec<f64>)>| -> ChannelDesign {
            if !p.recorded(ch) {
                return ChannelDesign::not_recorded(nb, folds, block_s);
            }
            let y: Vec<f64> = blocks(&(0..n).map(|r| p.meas(ch, r)).collect::<Vec<_>>())
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
            // Columns, then y last.
            let zp = DMatrix::from_fn(nb, cc.len() + 1, |r, c| {
                cc.get(c).map_or(y[r], |col| col.1[r])
            });
            ChannelDesign::whitened(cc.iter().map(|(o, _)| *o).collect(), zp, nm, folds)
        };
        // The six channels are independent: in parallel (the noise fit is
        // the larger part of a diagnosis).
        let chans: Vec<ChannelDesign> = cols
            .par_iter()
            .enumerate()
            .map(|(ch, cc)| make(ch, cc))
            .collect();
        let unseen = unseen(&chans, &cands);
        Self {
            ch: chans,
            cands,
            names,
            folds: opts.folds.max(2),
            quant,
            unseen,
        }
    }

    /// The same columns under other noise models (`noise`, per channel):
    /// what [`Design::build`] with `Some(noise)` on the same prediction,
    /// candidates and blocks gives, without re-making the columns.
    pub(super) fn with_noise(&self, noise: &[Noise; 6]) -> Self {
        let chans: Vec<ChannelDesign> = self
            .ch
            .par_iter()
            .zip(noise.par_iter())
            .map(|(cd, nm)| match cd.owners.is_empty() {
                true => cd.clone(), // not recorded: no columns, no noise
                false => ChannelDesign::whitened(cd.owners.clone(), cd.zp.clone(), *nm, self.folds),
            })
            .collect();
        let unseen = unseen(&chans, &self.cands);
        Self {
            ch: chans,
            cands: self.cands.clone(),
            names: self.names.clone(),
            folds: self.folds,
            quant: self.quant,
            unseen,
        }
    }

    /// The name of parameter `param` of candidate `ci` (empty if none).
    pub(super) fn param_name(&self, ci: usize, param: usize) -> String {
        self.names
            .get(ci)
            .and_then(|n| n.get(param))
            .cloned()
            .unwrap_or_default()
    }

    pub(super) fn rows(&self) -> usize {
        self.ch.iter().map(|c| c.rows.iter().sum::<usize>()).sum()
    }

    /// Fits the nominal terms plus candidates `set`.
    pub(super) fn fit(&self, set: &[usize]) -> Fit {
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
        for (k, i) in &index {
            if self.unseen.contains(k) {
                active[*i] = false;
            }
        }
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
        let (mut ho_p, mut ho_wc) = ([0.0; 6], [0.0; 6]);
        for f in 0..self.folds {
            let ((af, bf), yf) = self.normal(&idx2, &all, Some(f));
            let (bt, _) = solve(&(&a - &af), &(&b - &bf));
            ho_w += quad(yf, &bf, &af, &bt);
            for ch in 0..6 {
                ho_p[ch] += self.quad_ch(&self.ch[ch].gram_p, &idx2, ch, &bt, Some(f));
                ho_wc[ch] += self.quad_ch(&self.ch[ch].gram_w, &idx2, ch, &bt, Some(f));
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
            ho_wc,
        }
    }

    /// The whitened energy of candidate `ci`'s signal as `fit` has it that
    /// the model `alt` (nominal terms and candidates, without `ci`) cannot
    /// reproduce: the noncentrality with which this run separates the two
    /// explanations. Small (below the detection rule's `lambda_50`): the
    /// run cannot tell them apart, whichever the selection chose.
    pub(super) fn separation(&self, fit: &Fit, ci: usize, alt: &[usize]) -> f64 {
        let mut u = alt.to_vec();
        u.push(ci);
        let fu = self.fit(&u);
        let all = vec![true; fu.index.len()];
        let ((a, _), _) = self.normal(&fu.index, &all, None);
        let mut v = DVector::zeros(fu.index.len());
        let mut s_rows = vec![];
        for (k, i) in &fu.index {
            match k {
                Key::Effect { cand, .. } if *cand == ci => {
                    v[*i] = fit.value(*k).map_or(0.0, |x| x.0);
                }
                _ => s_rows.push(*i),
            }
        }
        let yy = (v.transpose() * &a * &v)[(0, 0)];
        let ns = s_rows.len();
        if ns == 0 {
            return yy.max(0.0);
        }
        let av = &a * &v;
        let b_s = DVector::from_fn(ns, |r, _| av[s_rows[r]]);
        let mut a_s = DMatrix::from_fn(ns, ns, |r, c| a[(s_rows[r], s_rows[c])]);
        let sub_index: Vec<(Key, usize)> = s_rows
            .iter()
            .enumerate()
            .map(|(j, i)| (fu.index[*i].0, j))
            .collect();
        add_prior(&mut a_s, &sub_index, &vec![true; ns]);
        let (beta, _) = solve(&a_s, &b_s);
        (yy - b_s.dot(&beta)).max(0.0)
    }

    /// Whitened normal equations over all rows (`fold` None) or one fold.
    #[allow(clippy::type_complexity)]
    pub(super) fn normal(
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
    pub(super) fn phys(
        &self,
        index: &[(Key, usize)],
        ch: usize,
        beta: &DVector<f64>,
        fold: Option<usize>,
    ) -> f64 {
        self.quad_ch(&self.ch[ch].gram_p, index, ch, beta, fold)
    }

    /// Residual sum of squares of channel `ch` under `beta` from one of
    /// its grams (`gram_p` physical, `gram_w` whitened).
    fn quad_ch(
        &self,
        gram: &[DMatrix<f64>],
        index: &[(Key, usize)],
        ch: usize,
        beta: &DVector<f64>,
        fold: Option<usize>,
    ) -> f64 {
        let cd = &self.ch[ch];
        let g = gram_sum(gram, fold);
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
    pub(super) fn block_residual(&self, fit: &Fit, ch: usize) -> Vec<f64> {
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

    pub(super) fn nrows_ch(&self, ch: usize, fold: Option<usize>) -> usize {
        match fold {
            Some(f) => self.ch[ch].rows[f],
            None => self.ch[ch].rows.iter().sum(),
        }
    }
}

/// The candidate parameters that the run cannot see at any physically
/// possible size: the largest possible signal (the catalogue's bound times
/// the regressor, whitened: in units of the noise) carries less energy than
/// the BIC charges for one parameter (`ln n`), so it could never be a
/// finding. The test is relative to the noise and to the parameter's own
/// scale, never a fixed epsilon: a regressor that is the floating-point
/// residue of cos(180 deg) falls here, whatever its normalised shape.
fn unseen(chans: &[ChannelDesign], cands: &[Candidate]) -> Vec<Key> {
    let rows: usize = chans.iter().map(|c| c.rows.iter().sum::<usize>()).sum();
    let ln_n = (rows.max(2) as f64).ln();
    let mut energy: Vec<(Key, f64)> = vec![];
    for (ch, cd) in chans.iter().enumerate() {
        let g = gram_sum(&cd.gram_w, None);
        for (c, o) in cd.owners.iter().enumerate() {
            if let Owner::Effect { cand, .. } = o {
                let b = cands.get(*cand).map_or(0.0, |x| x.bound().max_abs);
                let e = g[(c, c)].max(0.0) * b * b;
                let k = key_of(ch, *o);
                match energy.iter_mut().find(|(x, _)| *x == k) {
                    Some((_, v)) => *v += e,
                    None => energy.push((k, e)),
                }
            }
        }
    }
    energy
        .into_iter()
        .filter(|(_, e)| *e < ln_n)
        .map(|(k, _)| k)
        .collect()
}

/// Adds the nominal prior's precision (scale and misalignment) to `a`.
pub(super) fn add_prior(a: &mut DMatrix<f64>, index: &[(Key, usize)], active: &[bool]) {
    for (k, i) in index {
        if let Key::Nominal { j, .. } = k {
            if *j > 0 && active[*i] {
                a[(*i, *i)] += 1.0 / (NOMINAL_PRIOR * NOMINAL_PRIOR);
            }
        }
    }
}

pub(super) fn gram_sum(g: &[DMatrix<f64>], fold: Option<usize>) -> DMatrix<f64> {
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
pub(super) fn quad(yy: f64, b: &DVector<f64>, a: &DMatrix<f64>, beta: &DVector<f64>) -> f64 {
    (yy - 2.0 * beta.dot(b) + (beta.transpose() * a * beta)[(0, 0)]).max(0.0)
}

/// Solves `A beta = b` with diagonal scaling and a tiny ridge; returns beta
/// and `A^-1` (the covariance in whitened units).
pub(super) fn solve(a: &DMatrix<f64>, b: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
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
pub(super) fn ols_residual(x: &DMatrix<f64>, y: &DVector<f64>) -> DVector<f64> {
    let (beta, _) = solve(&(x.transpose() * x), &(x.transpose() * y));
    y - x * beta
}
