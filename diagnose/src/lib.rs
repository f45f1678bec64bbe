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
//!
//! Where each step lives: [`model`] (the nominal model, options, known
//! effects), [`mod@predict`] (1), `design` (the whitened regression, 2-4),
//! [`noise`] (3), [`effects`] (the candidates' physics), `select` (4),
//! `report` (5-6, typed findings), [`finding`] (the report's types and its
//! JSON), [`locate`] (7), [`mod@fisher`] (detection limits for the study),
//! [`show`] (text and plots). [`run`] below strings them together.

mod design;
pub mod effects;
mod error;
pub mod finding;
pub mod fisher;
pub mod locate;
pub mod model;
pub mod motion;
pub mod noise;
pub mod noise_terms;
pub mod predict;
pub mod realnoise;
mod report;
mod select;
pub mod study;
pub mod twin;
pub mod untracked;

pub use error::DiagnoseError;
pub use finding::{Details, Diagnosis, Finding, FitFigures, Observability, Parameter, Unexplained};
pub use fisher::{allan_excess, fisher, lambda_50};
pub use model::{Model, Options};
pub use predict::{encoder_quantum, predict, rms, Blocks, Prediction};

use design::Design;
use design::Key;
use effects::{Candidate, Kind};
use model::apply_known;
use noise::Noise;
use predict::{check, dt_of};
use rayon::prelude::*;
use recording::Recording;
use report::report;
use select::{confirm_slow, report_stats, select, strongest_p, Selection};

/// The six channels' names (recording-v1 columns).
pub const CHANNELS: [&str; 6] = noise_terms::CHANNELS;

/// BIC margin for a finding: lower by 10 is "very strong" evidence (Kass &
/// Raftery 1995).
pub const BIC_MARGIN: f64 = 10.0;

/// Block length on which slow findings (temperature, warm-up) are
/// confirmed, s: ten seconds average a sensor's short-time colouring (its
/// own filter: the ADIS16405's reaches ~8 s) and leave 60 blocks in a
/// 10-minute run.
pub const COARSE_BLOCK_S: f64 = 10.0;

/// Prior 1-sigma of the nominal scale-factor and misalignment terms
/// (dimensionless): the nominal fit is physically bounded. MEMS datasheets
/// give scale errors and misalignments of 0.5-3 %; 5 % bounds them all, and
/// stops a gyro's scale from being "fitted" on the earth rate alone (a
/// horizontal gyro on a vertical-axis run sees nothing else).
pub const NOMINAL_PRIOR: f64 = 0.05;

/// Runs the diagnosis.
///
/// # Errors
/// A recording too short, without encoder reads, or with non-finite
/// samples; a model that names parameters the library does not have.
pub fn run(
    rec: &Recording,
    recording_name: &str,
    opts: &Options,
) -> Result<Diagnosis, DiagnoseError> {
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
    let blocks_n = p
        .blocks(((opts.block_s / dt_of(&p)).round() as usize).max(1))
        .count();
    if !(opts.block_s.is_finite() && opts.block_s > 0.0) || blocks_n < 50 {
        return Err(DiagnoseError::TooFewBlocks {
            blocks: blocks_n,
            block_s: opts.block_s,
        });
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
    let (s1, _) = select(&d1);
    let noise2 = final_noise(&d1, &s1);
    // The same columns: only the noise model is new.
    let mut d = d1.with_noise(&noise2);
    let (mut sel, implausible) = select(&d);
    let mut unconfirmed = vec![];
    // A slow finding is confirmed on long blocks (select::confirm_slow):
    // COARSE_BLOCK_S, or shorter so that the run still makes 50 blocks.
    if sel.set.iter().any(|c| d.cands[*c].is_slow()) {
        let span = p.t_s.last().copied().unwrap_or(0.0) - p.t_s.first().copied().unwrap_or(0.0);
        let coarse = Options {
            block_s: (span / 50.0).min(COARSE_BLOCK_S).max(opts.block_s),
            ..opts.clone()
        };
        if coarse.block_s > opts.block_s {
            let dc = Design::build(&p, lib(&p), &coarse, None);
            (sel, unconfirmed) = confirm_slow(&d, &dc, sel);
        }
    }
    // Findings that move with the encoder's quantisation are its pattern,
    // not the sensor (select::quantisation_moved).
    // Built only when the selection holds a rate-shaped finding (two
    // designs: the dearest step of a diagnosis).
    let rate_shaped = sel.set.iter().any(|c| d.cands[*c].rides_on_rate());
    let offsets: &[f64] = if rate_shaped { &[0.25, -0.25] } else { &[] };
    let requantised: Vec<Design> = offsets
        .iter()
        .filter_map(|off| predict::requantised(rec, 2.0, *off))
        .map(|r| {
            let mut p2 = predict(&r, earth_scale, dt_known);
            // Known effects on the measurements, as on the recording's own.
            p2.y_w.clone_from(&p.y_w);
            p2.y_f.clone_from(&p.y_f);
            // The coarser grid's quantisation in the noise model: twice
            // the quantum, four times its variance.
            let mut n2 = noise2;
            for n in &mut n2 {
                n.quant *= 4.0;
            }
            Design::build(&p2, lib(&p2), opts, Some(&n2))
        })
        .collect();
    let moved = select::quantisation_moved(&d, &sel, &requantised);
    if !moved.is_empty() {
        let set: Vec<usize> = sel
            .set
            .iter()
            .copied()
            .filter(|c| !moved.iter().any(|m| m.cand == *c))
            .collect();
        sel = Selection {
            fit: d.fit(&set),
            set,
        };
    }
    // Significance, look-alikes and held-out checks come from the design the
    // selection was made on; the refinement below only sharpens values.
    let judged = report_stats(&d, &sel);
    let ids_tried = effects_tried(&d);

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
        // The same encoder reads: the same track.
        p = predict::predict_on(rec, p.track.clone(), earth_scale, time_offset);
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
    motion_spread(&p, lib(&p), opts, &noise2, &mut sel);
    let mut dg = report(
        recording_name,
        &p,
        &d,
        &sel,
        &judged,
        time_offset - dt_known,
    );
    // Confidences: the evidence over the dispersion the final residual
    // shows on the finding's channels (quasi-likelihood), x the ids tried.
    let disp = dg.details.dispersion.clone();
    let phi_of = |chans: &[usize]| {
        chans
            .iter()
            .filter_map(|c| disp.get(*c).copied())
            .fold(1.0, f64::max)
    };
    for f in &mut dg.findings {
        f.p_noise = fisher::chi2_sf(f.snr * f.snr / phi_of(&f.channels), f.dof);
        f.confidence = (1.0 - ids_tried as f64 * f.p_noise).max(0.0);
    }
    let (p_min, which) = strongest_p(&d, &sel, &disp);
    dg.details.strongest_p_adjusted = (ids_tried as f64 * p_min).min(1.0);
    dg.details.strongest_effect = which;
    for imp in &implausible {
        dg.unexplained.push(implausible_line(&d, &p, imp));
    }
    for m in &moved {
        let c = &d.cands[m.cand];
        let (name, v, v2) = &m.param;
        dg.unexplained.push(Unexplained {
            channels: select::channels_of(&d, m.cand)
                .iter()
                .filter_map(|ch| CHANNELS.get(*ch))
                .map(|c| (*c).to_string())
                .collect(),
            where_: format!(
                "looks like {} ({name} = {v:.3e}) but moves with the encoder's quantisation: {v2:.3e} with the reads' grid doubled, beyond 3 sigma: the encoder's deterministic rounding along this run's motion, not the sensor; a still start, both directions at several rates or a finer encoder would tell; {}",
                c.id,
                c.where_()
            ),
            snr: m.snr,
            may_be: Some(c.id),
        });
    }
    for u in &unconfirmed {
        dg.unexplained.push(Unexplained {
            channels: u.channels.iter().filter_map(|c| CHANNELS.get(*c)).map(|c| (*c).to_string()).collect(),
            where_: format!(
                "slow, over minutes ({}): delta BIC {:.0} on {:.1} s blocks, not confirmed on {:.0} s blocks ({:+.0}); this run cannot tell it from the sensor's own drift; to separate them, {}",
                d.cands[u.cand].explain(),
                u.dbic_fine,
                opts.block_s,
                COARSE_BLOCK_S,
                u.dbic_coarse,
                d.cands[u.cand].excite()
            ),
            snr: u.snr,
            may_be: Some(d.cands[u.cand].id),
        });
    }
    Ok(dg)
}

/// A refused candidate as a person reads it: what it looks like, the size
/// it would need and why no sensor has it.
/// The motion model's error in every sigma: where the encoder's track
/// cannot follow the table, the selected model refitted with the gyro's
/// centred differences and with the encoder's differences as the motion
/// instead of the gyro's band-limited derivative
/// ([`motion::MotionSource`]); each parameter's change between them goes
/// into its variance (defensible measures of one motion: their spread is
/// what the choice between them is worth).
fn motion_spread(
    p: &Prediction,
    cands: Vec<Candidate>,
    opts: &Options,
    noise: &[Noise; 6],
    sel: &mut Selection,
) {
    if p.track.unfollowed().is_empty() || sel.set.is_empty() {
        return;
    }
    use motion::MotionSource::{Encoder, GyroCentred};
    for source in [GyroCentred, Encoder] {
        let mut alt = p.clone();
        motion::fill(&mut alt, source);
        let other = Design::build(&alt, cands.clone(), opts, Some(noise)).fit(&sel.set);
        for (key, i) in sel.fit.index.clone() {
            if let Some((v, _)) = other.value(key) {
                let spread = sel.fit.beta[i] - v;
                sel.fit.cov[(i, i)] += spread * spread;
            }
        }
    }
}

fn implausible_line(d: &Design, p: &Prediction, imp: &select::Implausible) -> Unexplained {
    let c = &d.cands[imp.cand];
    let b = c.bound();
    let (name, v, sd) = &imp.param;
    let mut what = format!(
        "looks like {} but {name} = {v:.3e} +- {sd:.1e} {} is {:.1}x the largest physically possible ({:.3e}: {})",
        c.id, b.unit, imp.ratio, b.max_abs, b.source
    );
    if c.kind == Kind::EarthRate {
        what += &format!(
            "; that is {:.1}x the earth's rate: a signal locked to the table angle, not the earth",
            (v + p.earth_in_model_radps).abs() / core_nav::earth::EARTH_RATE_RADPS
        );
    }
    Unexplained {
        channels: select::channels_of(d, imp.cand)
            .iter()
            .filter_map(|ch| CHANNELS.get(*ch))
            .map(|c| (*c).to_string())
            .collect(),
        where_: format!("{what}; {}", c.where_()),
        snr: imp.snr,
        may_be: Some(c.id),
    }
}

/// The effect ids the library tried on this run, bias instability
/// included (the multiplicity of the confidences).
fn effects_tried(d: &Design) -> usize {
    let mut ids: Vec<hal_sim::catalogue::EffectId> = d.cands.iter().map(|c| c.id).collect();
    ids.push(hal_sim::catalogue::EffectId::BiasInstability);
    ids.push(hal_sim::catalogue::EffectId::UntrackedTableMotion);
    ids.sort_by_key(|e| e.as_str());
    ids.dedup();
    ids.len()
}

/// Noise models re-fitted to the residual of a selection.
fn final_noise(d: &Design, s: &Selection) -> [Noise; 6] {
    let block_s = d.ch[0].noise.block_s;
    let fit = |ch: usize| match d.ch[ch].owners.is_empty() {
        true => Noise::none(block_s),
        false => noise::fit(&d.block_residual(&s.fit, ch), block_s, d.quant[ch]),
    };
    let v: Vec<Noise> = (0..6).into_par_iter().map(fit).collect();
    std::array::from_fn(|ch| v[ch])
}
