//! The report: typed findings from the selection (parameters with their
//! 1-sigma, significance, fit figures), bias instability on the final
//! residual, what the run cannot see, and the per-sample re-simulation.

use super::design::{Design, Fit, Key};
use super::effects::Kind;
use super::noise::{self, Noise};
use super::select::{Judged, Selection};
use super::{
    dt_of, locate, Details, Diagnosis, Finding, FitFigures, Parameter, Prediction, BIC_MARGIN,
};
use hal_sim::catalogue::EffectId;
use rayon::prelude::*;

/// Lags of the dispersion estimate: 50 blocks (10 s at 0.2 s), the time
/// over which the slow regressors change and the encoder grid's beat with
/// the block rate builds its sawtooth.
const DISPERSION_LAGS: usize = 50;

/// The samples the model `fit` re-simulates, per channel: the ideal sensor,
/// the nominal terms, every effect of `fit` and the model's known effects
/// (channel unit, per IMU sample).
pub(super) fn model_samples(p: &Prediction, d: &Design, fit: &Fit) -> [Vec<f64>; 6] {
    let n = p.t_s.len();
    let mut out: [Vec<f64>; 6] =
        std::array::from_fn(|ch| (0..n).map(|r| p.truth(ch, r) + p.known(ch, r)).collect());
    for (key, i) in &fit.index {
        let b = fit.beta[*i];
        if let Key::Nominal { ch, j } = *key {
            for (r, v) in out[ch].iter_mut().enumerate() {
                *v += b * p.nominal(ch, j, r);
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
                    *v += b * x;
                }
            }
        }
    }
    out
}

/// The recording minus the model's samples, per channel and sample.
fn residuals(p: &Prediction, model: &[Vec<f64>; 6]) -> [Vec<f64>; 6] {
    std::array::from_fn(|ch| {
        model[ch]
            .iter()
            .enumerate()
            .map(|(r, m)| p.meas(ch, r) + p.known(ch, r) - m)
            .collect()
    })
}

pub(super) fn report(
    name: &str,
    p: &Prediction,
    d: &Design,
    sel: &Selection,
    judged: &[(usize, Judged)],
    time_offset_fitted: f64,
) -> Diagnosis {
    let ln_n = (d.rows().max(2) as f64).ln();
    let nominal_fit = d.fit(&[]);
    let res_before = residuals(p, &model_samples(p, d, &nominal_fit));
    let model = model_samples(p, d, &sel.fit);
    let res_after = residuals(p, &model);
    let mut findings: Vec<(f64, Finding)> = vec![];
    let mut demoted = vec![];
    for (ci, j) in judged {
        let c = &d.cands[*ci];
        if j.channels.is_empty() {
            // It lowers no channel's held-out rms: a located mismatch,
            // not a finding.
            demoted.push(super::Unexplained {
                channels: j
                    .rising
                    .iter()
                    .filter_map(|ch| super::CHANNELS.get(*ch).map(|s| s.to_string()))
                    .collect(),
                where_: format!(
                    "{}: selected by the fit, but it makes the held-out residual of every channel it touches worse (a wrong fit of it, or not this physics)",
                    c.id
                ),
                snr: j.snr,
                may_be: Some(c.id),
            });
            continue;
        }
        let f1 = &sel.fit;
        let mut params = vec![];
        for (pi, pn) in d.names[*ci].iter().enumerate() {
            if let Some((mut v, s)) = f1.value(Key::Effect {
                cand: *ci,
                param: pi,
            }) {
                // The bound is on the fitted size; the earth rate is reported
                // with the model's own added back.
                let mut max_abs = c.bound().max_abs;
                if c.kind == Kind::EarthRate {
                    v += p.earth_in_model_radps;
                    max_abs += p.earth_in_model_radps;
                }
                if c.kind == Kind::TimeOffset {
                    // The gyros' offset was refined into the prediction; the
                    // accelerometers' is fitted relative to it.
                    v = time_offset_fitted + if pi == 0 { 0.0 } else { v };
                }
                params.push(Parameter {
                    name: pn.clone(),
                    value: v,
                    sigma: Some(s),
                    max_abs: Some(max_abs),
                });
            }
        }
        for (pn, v) in c.fixed() {
            params.push(Parameter {
                name: pn,
                value: v,
                sigma: None,
                max_abs: None,
            });
        }
        findings.push((
            j.dbic,
            Finding {
                effect: c.id,
                channels: j.channels.clone(),
                where_: c.where_().into(),
                explanation: j.explanation.clone(),
                lookalike: j.lookalike,
                parameters: params,
                not_measured: vec![],
                delta_bic: j.dbic,
                snr: j.snr,
                dof: j.k,
                p_noise: 1.0,
                confidence: 0.0,
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
    let mut dispersion = vec![];
    let segs = recording::segment_ranges(&p.t_s, p.dt_s);
    let segs = &segs;
    // Per channel, in parallel: the block means' ML models (white +
    // Gauss-Markov, white only) and the one noise estimator's Allan fit.
    let one = |ch: usize| {
        let z = d.block_residual(&sel.fit, ch);
        if !p.recorded(ch) {
            let none = Noise::none(block_s);
            return (z, none, none, core_nav::allan::NoiseFit::default());
        }
        let gm = noise::fit(&z, block_s, d.quant[ch]);
        let wn = noise::fit_white(&z, block_s, d.quant[ch]);
        let a = crate::noise_terms::fit_channel(&res_after[ch], dt, segs).1;
        (z, gm, wn, a)
    };
    #[allow(clippy::type_complexity)]
    let per_ch: Vec<(Vec<f64>, Noise, Noise, core_nav::allan::NoiseFit)> =
        (0..6).into_par_iter().map(one).collect();
    let mut allan: Vec<core_nav::allan::NoiseFit> = per_ch.iter().map(|f| f.3).collect();
    let fits: Vec<(Vec<f64>, Noise, Noise)> = per_ch
        .into_iter()
        .map(|(z, gm, wn, _)| (z, gm, wn))
        .collect();
    for triad in 0..2 {
        let (mut params, mut not_measured) = (vec![], vec![]);
        let (mut chans, mut dbic_sum, mut chi) = (vec![], 0.0, 0.0f64);
        let (mut before, mut after) = (vec![], vec![]);
        let (mut hb, mut ha, mut nr) = (0.0, 0.0, 0.0);
        for i in 0..3 {
            let ch = 3 * triad + i;
            let (z, gm, wn) = (&fits[ch].0, fits[ch].1, fits[ch].2);
            noise_final.push(gm);
            let mut wz = vec![];
            gm.gains(z.len()).whiten_into(z, &mut wz);
            whiteness.push(locate::ljung_box(&wz, 20));
            dispersion.push(locate::dispersion(&wz, DISPERSION_LAGS));
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
            before.push((ch, (b2 / nz).sqrt()));
            after.push((ch, (a2 / nz).sqrt()));
            let (ax, unit, wunit) = (
                ["x", "y", "z"][i],
                ["radps", "mps2"][triad],
                ["rad_per_sqrt_s", "mps_per_sqrt_s"][triad],
            );
            // White noise and bias instability are the one noise
            // estimator's (the Allan fit `rins allan` prints) on the final
            // residual; the Gauss-Markov terms are the ML model's that
            // decided this finding and whitens the fit (on a run of a few
            // correlation times the Allan curve cannot tell a wander from
            // flicker, the likelihood can).
            let a = allan.get(ch).copied().unwrap_or_default();
            for (name, value, measured) in [
                (
                    format!("bias_instability_{ax}_{unit}"),
                    a.bias_instability,
                    a.floor_seen,
                ),
                (
                    format!("gm_sigma_{ax}_{unit}"),
                    gm.gm_sigma(),
                    gm.gm_sigma() > 0.0,
                ),
                (
                    format!("gm_tau_{ax}_s"),
                    gm.tau_s().min(1e12),
                    gm.gm_sigma() > 0.0,
                ),
                (format!("white_noise_{ax}_{wunit}"), a.white, a.white > 0.0),
            ] {
                if !measured {
                    not_measured.push(name);
                    continue;
                }
                params.push(Parameter {
                    name,
                    value,
                    sigma: None,
                    max_abs: None,
                });
            }
        }
        if !chans.is_empty() {
            findings.push((
                dbic_sum,
                Finding {
                    effect: EffectId::BiasInstability,
                    channels: chans,
                    where_: "long averaging times: the residual's Allan deviation stops falling as white noise does; block means correlated over minutes".into(),
                    explanation: format!(
                        "a constant bias and white noise do not explain the {}: the bias wanders (Gauss-Markov / flicker); modelled, each {:.1} s mean is predicted from the ones before it",
                        ["gyros", "accelerometers"][triad],
                        block_s
                    ),
                    parameters: params,
                    not_measured,
                    delta_bic: dbic_sum,
                    snr: chi,
                    dof: 2,
                    p_noise: 1.0,
                    confidence: 0.0,
                    fit: FitFigures {
                        residual_rms_before: before,
                        residual_rms_after: after,
                        heldout_rms_before: (hb / nr.max(1.0)).sqrt(),
                        heldout_rms_after: (ha / nr.max(1.0)).sqrt(),
                        heldout_whitened: vec![],
                    },
                    lookalike: None,
                },
            ));
        }
    }
    if let Some(u) = super::untracked::detect(p, &res_after) {
        let blocks = fits.get(u.ch).map_or(0, |f| f.0.len());
        let f = super::untracked::finding(&u, &allan, blocks);
        super::untracked::take_out(&u, &mut allan);
        findings.push((f.delta_bic, f));
    }
    findings.sort_by(|a, b| a.0.total_cmp(&b.0));
    let findings: Vec<Finding> = findings.into_iter().map(|(_, f)| f).collect();
    // Not excited by this run: no parameter of it left in a fit beside
    // the final model, or none the run would show at a physically possible
    // size.
    let lam1 = super::fisher::lambda_50(1, d.rows()).sqrt();
    let (mut not_observable, mut observability) = (vec![], vec![]);
    let mut seen: Vec<EffectId> = vec![];
    for (ci, c) in d.cands.iter().enumerate() {
        if seen.contains(&c.id) {
            continue;
        }
        seen.push(c.id);
        let mut power = vec![];
        for (i, x) in d.cands.iter().enumerate().filter(|(_, x)| x.id == c.id) {
            let mut s: Vec<usize> = sel
                .set
                .iter()
                .copied()
                .filter(|y| d.cands[*y].id != c.id)
                .collect();
            s.push(i);
            let f = d.fit(&s);
            for (pi, pn) in d.names[i].iter().enumerate() {
                let sigma = f.value(Key::Effect { cand: i, param: pi }).map(|(_, s)| s);
                power.push(super::Observability {
                    effect: c.id,
                    parameter: pn.clone(),
                    min_detectable: sigma
                        .filter(|s| s.is_finite() && *s > 0.0)
                        .map(|s| s * lam1),
                    bound: x.bound().max_abs,
                });
            }
        }
        if !power.iter().any(super::Observability::observable) {
            let best = power
                .iter()
                .filter_map(|o| Some((o.min_detectable? / o.bound, o)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let why = match best {
                Some((_, o)) => format!(
                    "{} (this run would show {} only from {:.3e}, beyond its physical bound {:.3e})",
                    d.cands[ci].excite(),
                    o.parameter,
                    o.min_detectable.unwrap_or(f64::INFINITY),
                    o.bound
                ),
                None => d.cands[ci].excite().to_string(),
            };
            not_observable.push((c.id, why));
        }
        observability.extend(power);
    }
    let part = locate::parts(p);
    let locate = locate::locate(p, &part, &res_before, dt);
    let block_res: Vec<Vec<f64>> = (0..6).map(|ch| d.block_residual(&sel.fit, ch)).collect();
    let mut unexplained = locate::unexplained(p, &part, &block_res, &noise_final, len, ln_n);
    unexplained.extend(demoted);

    Diagnosis {
        recording: name.to_string(),
        findings,
        unexplained,
        details: Details {
            noise: noise_final,
            not_observable,
            observability,
            ruled_out: super::effects::ruled_out(p),
            allan,
            segments: recording::segments(&p.t_s, p.dt_s)
                .iter()
                .map(|s| {
                    let t = |i: usize| p.t_s.get(i).copied().unwrap_or(0.0);
                    (t(s.start), t(s.end.saturating_sub(1)), s.len())
                })
                .collect(),
            rate_hz: 1.0 / p.dt_s,
            axis_index: p.k.iamax(),
            accel_recorded: p.accel_recorded,
            locate,
            block_s,
            dt_s: dt,
            res_before,
            res_after,
            model,
            theta: p.theta.iter().map(|t| t.0).collect(),
            t_s: p.t_s.clone(),
            whiteness,
            nominal: std::array::from_fn(|ch| {
                std::array::from_fn(|j| sel.fit.value(Key::Nominal { ch, j }).map(|v| v.0))
            }),
            earth_scale: p.earth_in_model_radps / p.w_e_b.norm().max(1e-300),
            unfollowed: p.track.unfollowed().to_vec(),
            strongest_p_adjusted: 1.0,
            strongest_effect: None,
            dispersion,
        },
    }
}
