//! Selection: greedy BIC with held-out segments and a backward check, then
//! each finding judged against the final model (drop-one BIC, held-out
//! figures, look-alikes).

use super::design::{Design, Fit, Key, Owner};
use super::{effects, noise, FitFigures, BIC_MARGIN};
use hal_sim::catalogue::EffectId;

/// Selected model: candidates (library indices), each finding's drop-one
/// statistics.
pub(super) struct Selection {
    pub(super) set: Vec<usize>,
    pub(super) fit: Fit,
}

/// A finding whose size moves with the encoder's quantisation.
#[derive(Clone, Debug)]
pub(super) struct Moved {
    /// The candidate.
    pub(super) cand: usize,
    /// Its parameter that moved most: name, value, value on the re-rounded
    /// encoder.
    pub(super) param: (String, f64, f64),
    /// Its whitened evidence on the recording.
    pub(super) snr: f64,
}

/// The selected candidates whose physics rides on the table's measured rate
/// (rate-squared, asymmetry, time offset, the mount's wobble; not the
/// encoder error, which lives in the angles themselves and which coarser
/// rounding changes for real) and whose fitted parameters, refitted with the same selection on
/// the recording re-read by a coarser encoder (`requantised`: each a design
/// of the same candidates), move by more than 3 sigma (the larger of the two
/// fits'): a real sensor term stays within its sigma when the encoder's
/// rounding changes, the rounding's own pattern does not.
pub(super) fn quantisation_moved(
    d: &Design,
    sel: &Selection,
    requantised: &[Design],
) -> Vec<Moved> {
    let mut out = vec![];
    // Only designs with the same candidates, index for index (a re-rounded
    // angle can take a run's span under a whole turn).
    let fits: Vec<Fit> = requantised
        .iter()
        .filter(|r| {
            r.cands.len() == d.cands.len()
                && r.cands.iter().zip(&d.cands).all(|(a, b)| a.kind == b.kind)
        })
        .map(|r| r.fit(&sel.set))
        .collect();
    for &ci in &sel.set {
        if !d.cands.get(ci).is_some_and(|c| c.rides_on_rate()) {
            continue;
        }
        let mut worst: Option<(f64, Moved)> = None;
        for f2 in &fits {
            for (k, _) in &sel.fit.index {
                let Key::Effect { cand, param } = *k else {
                    continue;
                };
                if cand != ci {
                    continue;
                }
                let (Some((v, s1)), Some((v2, s2))) = (sel.fit.value(*k), f2.value(*k)) else {
                    continue;
                };
                let z = (v2 - v).abs() / s1.max(s2).max(1e-300);
                if z > 3.0 && worst.as_ref().is_none_or(|w| z > w.0) {
                    let name = d.param_name(ci, param);
                    let rest: Vec<usize> = sel.set.iter().copied().filter(|x| *x != ci).collect();
                    let snr = (d.fit(&rest).rss_w - sel.fit.rss_w).max(0.0).sqrt();
                    worst = Some((
                        z,
                        Moved {
                            cand: ci,
                            param: (name, v, v2),
                            snr,
                        },
                    ));
                }
            }
        }
        if let Some((_, m)) = worst {
            out.push(m);
        }
    }
    out
}

/// A candidate the data would take, but only at a size no sensor, table or
/// site can have (beyond its catalogue bound): not a finding, reported
/// among the unexplained mismatches with its size and the reason.
#[derive(Clone, Debug)]
pub(super) struct Implausible {
    /// The candidate.
    pub(super) cand: usize,
    /// Its parameter furthest beyond the bound: name, fitted value, sigma.
    pub(super) param: (String, f64, f64),
    /// How many times the bound the value is.
    pub(super) ratio: f64,
    /// Whitened evidence (amplitude over its standard error).
    pub(super) snr: f64,
}

/// The parameter of candidate `ci` in `f` furthest beyond its bound, if any
/// is beyond it: (param index, value, sigma, ratio to the bound).
fn beyond_bound(d: &Design, f: &Fit, ci: usize) -> Option<(usize, f64, f64, f64)> {
    let b = d.cands.get(ci)?.bound().max_abs;
    f.index
        .iter()
        .filter_map(|(k, _)| match k {
            Key::Effect { cand, param } if *cand == ci => {
                f.value(*k).map(|(v, s)| (*param, v, s, v.abs() / b))
            }
            _ => None,
        })
        .filter(|x| x.3 > 1.0)
        .max_by(|a, b| a.3.total_cmp(&b.3))
}

fn implausible(d: &Design, base: &Fit, f: &Fit, ci: usize) -> Option<Implausible> {
    let (pi, v, sd, ratio) = beyond_bound(d, f, ci)?;
    let name = d.param_name(ci, pi);
    Some(Implausible {
        cand: ci,
        param: (name, v, sd),
        ratio,
        snr: (base.rss_w - f.rss_w).max(0.0).sqrt(),
    })
}

pub(super) fn select(d: &Design) -> (Selection, Vec<Implausible>) {
    let ln_n = (d.rows().max(2) as f64).ln();
    let mut set: Vec<usize> = vec![];
    let mut cur = d.fit(&set);
    let mut refused: Vec<Implausible> = vec![];
    loop {
        let mut best: Option<(f64, usize, Fit)> = None;
        for ci in 0..d.cands.len() {
            let id = d.cands[ci].id;
            if set.iter().any(|s| d.cands[*s].id == id) || refused.iter().any(|r| r.cand == ci) {
                continue;
            }
            let Some((dbic, f)) = adding(d, &set, &cur, ci, ln_n) else {
                continue;
            };
            if dbic < -BIC_MARGIN
                && f.ho_w < cur.ho_w
                && best.as_ref().is_none_or(|(b, _, _)| dbic < *b)
            {
                best = Some((dbic, ci, f));
            }
        }
        match best {
            Some((_, ci, f)) => match implausible(d, &cur, &f, ci) {
                Some(imp) => refused.push(imp),
                None => {
                    set.push(ci);
                    cur = f;
                }
            },
            None => break,
        }
    }
    // Backward check: every member must still earn its place, at a
    // possible size.
    loop {
        let mut drop = None;
        for (pos, &ci) in set.iter().enumerate() {
            let rest: Vec<usize> = set.iter().copied().filter(|x| *x != ci).collect();
            let f0 = d.fit(&rest);
            let k = dof(d, &cur, ci);
            let dbic = (cur.rss_w - f0.rss_w) + k as f64 * ln_n;
            if let Some(imp) = implausible(d, &f0, &cur, ci) {
                refused.push(imp);
                drop = Some((pos, f0));
                break;
            }
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
    // One line per id: its strongest refusal.
    refused.sort_by(|a, b| b.snr.total_cmp(&a.snr));
    let mut seen = vec![];
    refused.retain(|r| {
        let id = d.cands[r.cand].id;
        let new = !seen.contains(&id);
        seen.push(id);
        new
    });
    (Selection { set, fit: cur }, refused)
}

/// The model `base` (fitted as `base_fit`) with candidate `ci` added: its
/// BIC change (the whitened residual's drop, at most the whole of it, and
/// the candidate's degrees of freedom) and fit; `None` when the run does
/// not excite it.
fn adding(d: &Design, base: &[usize], base_fit: &Fit, ci: usize, ln_n: f64) -> Option<(f64, Fit)> {
    let mut with = base.to_vec();
    with.push(ci);
    let f = d.fit(&with);
    let k = dof(d, &f, ci);
    if k == 0 {
        return None;
    }
    let dbic = -(base_fit.rss_w - f.rss_w).max(0.0) + k as f64 * ln_n;
    Some((dbic, f))
}

/// Slow findings judged again where their signal lives, on the `coarse`
/// design (the same candidates on long blocks), by a profile likelihood
/// ratio: the noise model (white + Gauss-Markov) is fitted anew to the
/// residual with the finding and to the residual without it, and the two
/// maximised likelihoods compared (BIC, the finding's parameters counted).
/// A sensor's noise is seldom one Gauss-Markov process: fitted to short
/// blocks the model follows the short-time colouring (the sensor's own
/// filter, quantisation) and can understate the power at periods of
/// minutes, where a warm-up or a temperature term lives; there a slow
/// regressor wins against a noise model that was never asked to explain
/// the drift. On long blocks, with the noise free to take the drift, a
/// slow finding must still explain it better than drift does. Those that do
/// not are returned (with their short-block statistics) to be reported as
/// what they are: a slow mismatch this run cannot tell from the sensor's
/// own drift.
pub(super) fn confirm_slow(
    d: &Design,
    coarse: &Design,
    sel: Selection,
) -> (Selection, Vec<Unconfirmed>) {
    let ln_fine = (d.rows().max(2) as f64).ln();
    let block_s = coarse.ch.first().map_or(1.0, |c| c.noise.block_s);
    let ln_n = (coarse.rows().max(2) as f64).ln();
    let loglik = |fit: &Fit, chans: &[usize]| -> f64 {
        chans
            .iter()
            .map(|&ch| {
                let z = coarse.block_residual(fit, ch);
                noise::fit(&z, block_s, coarse.quant[ch]).loglik
            })
            .sum()
    };
    let mut set = sel.set.clone();
    let mut dropped = vec![];
    for &ci in &sel.set {
        if !d.cands.get(ci).is_some_and(|c| c.is_slow()) {
            continue;
        }
        let rest: Vec<usize> = set.iter().copied().filter(|x| *x != ci).collect();
        let (f1, f0) = (coarse.fit(&set), coarse.fit(&rest));
        let k = dof(coarse, &f1, ci);
        let chans: Vec<usize> = (0..6)
            .filter(|ch| (f0.rss_p[*ch] - f1.rss_p[*ch]).abs() > 1e-12 * f0.rss_p[*ch])
            .collect();
        let dbic = -2.0 * (loglik(&f1, &chans) - loglik(&f0, &chans)) + k as f64 * ln_n;
        if k == 0 || dbic >= -BIC_MARGIN {
            // Its short-block evidence, for the report.
            let fine0 = d.fit(&rest);
            let dchi = (fine0.rss_w - sel.fit.rss_w).max(0.0);
            let channels = (0..6)
                .filter(|ch| {
                    (fine0.rss_p[*ch] - sel.fit.rss_p[*ch]).abs() > 1e-9 * fine0.rss_p[*ch]
                })
                .collect();
            dropped.push(Unconfirmed {
                cand: ci,
                channels,
                snr: dchi.sqrt(),
                dbic_fine: -dchi + dof(d, &sel.fit, ci) as f64 * ln_fine,
                dbic_coarse: dbic,
            });
            set = rest;
        }
    }
    if set == sel.set {
        return (sel, dropped);
    }
    (
        Selection {
            fit: d.fit(&set),
            set,
        },
        dropped,
    )
}

/// A slow finding the long blocks did not confirm.
pub(super) struct Unconfirmed {
    /// The candidate.
    pub(super) cand: usize,
    /// Channels it changed.
    pub(super) channels: Vec<usize>,
    /// Its amplitude over its standard error on the short blocks.
    pub(super) snr: f64,
    /// Its delta BIC on the short blocks and on the long ones.
    pub(super) dbic_fine: f64,
    /// See `dbic_fine`.
    pub(super) dbic_coarse: f64,
}

/// The candidate's degrees of freedom in `f` for the BIC: its fitted
/// parameters and, when any is fitted, those it searched on a grid.
pub(super) fn dof(d: &Design, f: &Fit, ci: usize) -> usize {
    match params_of(f, ci) {
        0 => 0,
        k => k + d.cands.get(ci).map_or(0, |c| c.searched_params()),
    }
}

pub(super) fn params_of(f: &Fit, ci: usize) -> usize {
    f.index
        .iter()
        .filter(|(k, _)| matches!(k, Key::Effect { cand, .. } if *cand == ci))
        .count()
}

/// A finding's statistics, judged on the design it was selected on.
pub(super) struct Judged {
    pub(super) dbic: f64,
    pub(super) snr: f64,
    /// Degrees of freedom.
    pub(super) k: usize,
    pub(super) channels: Vec<usize>,
    /// Channels it was fitted on whose held-out rms it does not lower.
    pub(super) rising: Vec<usize>,
    pub(super) explanation: String,
    pub(super) lookalike: Option<EffectId>,
    pub(super) fit: FitFigures,
}

/// Correlation between two findings' estimates above which the run is said
/// not to split the signal between them: 0.95 leaves a share uncertain by
/// over three times what either alone would be (1 / sqrt(1 - 0.95^2)).
pub const SPLIT_CORRELATION: f64 = 0.95;

/// Drop-one BIC, held-out figures and look-alikes of every selected
/// candidate.
pub(super) fn report_stats(d: &Design, sel: &Selection) -> Vec<(usize, Judged)> {
    let ln_n = (d.rows().max(2) as f64).ln();
    // The noncentrality the BIC rule detects half the time (one degree of
    // freedom): a difference between two explanations below it is one
    // this run does not show.
    let lam50 = super::fisher::lambda_50(1, d.rows());
    let mut out = vec![];
    for &ci in &sel.set {
        let c = &d.cands[ci];
        let rest: Vec<usize> = sel.set.iter().copied().filter(|x| *x != ci).collect();
        let f0 = d.fit(&rest);
        let f1 = &sel.fit;
        let k = dof(d, f1, ci);
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
        // A finding claims only the channels whose held-out residual
        // (whitened: each block against the noise model's prediction of it,
        // so the bias's wander between folds is noise, not misfit) it
        // lowers: one it does not lower there is a wrong fit of it, or not
        // this physics, or a channel it barely touches (with none left it
        // is no finding: `report` keeps it as a located mismatch).
        let worse = |ch: usize| f1.ho_wc[ch] >= f0.ho_wc[ch];
        let whitened: Vec<(usize, f64, f64)> = chans
            .iter()
            .map(|&ch| {
                let n = d.nrows_ch(ch, None).max(1) as f64;
                (ch, (f0.ho_wc[ch] / n).sqrt(), (f1.ho_wc[ch] / n).sqrt())
            })
            .collect();
        let (chans, rising): (Vec<usize>, Vec<usize>) =
            chans.into_iter().partition(|ch| !worse(*ch));
        let (mut before, mut after) = (vec![], vec![]);
        let (mut hb, mut ha, mut nr) = (0.0, 0.0, 0usize);
        for &ch in &chans {
            let nrow = d.nrows_ch(ch, None).max(1) as f64;
            before.push((ch, (f0.rss_p[ch] / nrow).sqrt()));
            after.push((ch, (f1.rss_p[ch] / nrow).sqrt()));
            hb += f0.ho_p[ch];
            ha += f1.ho_p[ch];
            nr += d.nrows_ch(ch, None);
        }
        let nr = nr.max(1) as f64;
        // Look-alikes: a candidate not chosen that, in place of this one,
        // explains as much (within the BIC margin), or whose signature
        // differs from this one's, at the fitted size, by less than the run
        // can detect (the choice between them is the noise's).
        let mut explanation = c.explain().to_string();
        let mut lookalike = None;
        for (di, dc) in d.cands.iter().enumerate() {
            if dc.id == c.id || sel.set.iter().any(|s| d.cands[*s].id == dc.id) {
                continue;
            }
            let Some((dbic_alt, _)) = adding(d, &rest, &f0, di, ln_n) else {
                continue;
            };
            let alike = dbic_alt < -BIC_MARGIN
                && (dbic_alt - dbic < BIC_MARGIN || {
                    let mut alt = rest.clone();
                    alt.push(di);
                    d.separation(f1, ci, &alt) < lam50
                });
            if alike {
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
        // Look-alikes among the findings themselves: two named together
        // whose estimates the run cannot split (a parameter of each
        // correlated beyond 0.95 in the joint fit: the data fix their sum,
        // not their shares), e.g. a g-sensitivity and an encoder error,
        // both a 1x harmonic on the table-axis gyro of a one-way run.
        if lookalike.is_none() {
            let params = |c: usize| -> Vec<usize> {
                f1.index
                    .iter()
                    .filter_map(|(k, i)| match k {
                        Key::Effect { cand, .. } if *cand == c => Some(*i),
                        _ => None,
                    })
                    .collect()
            };
            let mine = params(ci);
            'other: for &cj in &sel.set {
                if d.cands[cj].id == c.id {
                    continue;
                }
                for &i in &mine {
                    for &j in &params(cj) {
                        let den = (f1.cov[(i, i)] * f1.cov[(j, j)]).sqrt();
                        if den > 0.0 && (f1.cov[(i, j)] / den).abs() > SPLIT_CORRELATION {
                            let other = d.cands[cj].id;
                            explanation += &format!(
                                ". It is named together with {other}, and this run cannot tell how the signal splits between them (estimates correlated {:.2}): to separate them, {}",
                                f1.cov[(i, j)] / den,
                                effects::separate(c.id, other)
                            );
                            lookalike = Some(other);
                            break 'other;
                        }
                    }
                }
            }
        }
        if !rising.is_empty() {
            let names: Vec<&str> = rising
                .iter()
                .filter_map(|c| super::CHANNELS.get(*c).copied())
                .collect();
            explanation += &format!(
                ". Not claimed on {}: fitted there, it makes the held-out residual worse",
                names.join(", ")
            );
        }
        out.push((
            ci,
            Judged {
                rising,
                dbic,
                snr: dchi.sqrt(),
                k,
                channels: chans,
                explanation,
                lookalike,
                fit: FitFigures {
                    residual_rms_before: before,
                    residual_rms_after: after,
                    heldout_rms_before: (hb / nr).sqrt(),
                    heldout_rms_after: (ha / nr).sqrt(),
                    heldout_whitened: whitened,
                },
            },
        ));
    }
    out
}

/// The smallest chi-square tail probability of any candidate (slow ones
/// aside) against the final model: the selected ones by dropping them, the others by adding
/// them (the run's strongest evidence, whether or not it was named).
pub(super) fn strongest_p(
    d: &Design,
    sel: &Selection,
    dispersion: &[f64],
) -> (f64, Option<hal_sim::catalogue::EffectId>) {
    let mut p_min: f64 = 1.0;
    let mut which = None;
    for ci in 0..d.cands.len() {
        // Slow candidates are judged on long blocks (confirm_slow), not
        // by this design's tail.
        if d.cands[ci].is_slow() {
            continue;
        }
        let (f0, f1) = if sel.set.contains(&ci) {
            let rest: Vec<usize> = sel.set.iter().copied().filter(|x| *x != ci).collect();
            (d.fit(&rest), sel.fit.clone())
        } else {
            if sel.set.iter().any(|s| d.cands[*s].id == d.cands[ci].id) {
                continue;
            }
            let mut with = sel.set.clone();
            with.push(ci);
            (sel.fit.clone(), d.fit(&with))
        };
        let k = dof(d, &f1, ci);
        if k == 0 {
            continue;
        }
        let phi = channels_of(d, ci)
            .iter()
            .filter_map(|c| dispersion.get(*c).copied())
            .fold(1.0, f64::max);
        let p = super::fisher::chi2_sf((f0.rss_w - f1.rss_w).max(0.0) / phi, k);
        if p < p_min {
            p_min = p;
            which = Some(d.cands[ci].id);
        }
    }
    (p_min, which)
}

/// The channels candidate `ci` has regressors on.
pub(super) fn channels_of(d: &Design, ci: usize) -> Vec<usize> {
    (0..d.ch.len())
        .filter(|ch| {
            d.ch[*ch]
                .owners
                .iter()
                .any(|o| matches!(o, Owner::Effect { cand, .. } if *cand == ci))
        })
        .collect()
}
