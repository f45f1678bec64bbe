//! Selection: greedy BIC with held-out segments and a backward check, then
//! each finding judged against the final model (drop-one BIC, held-out
//! figures, look-alikes).

use super::design::{Design, Fit, Key, Owner};
use super::{effects, FitFigures, BIC_MARGIN};
use hal_sim::catalogue::EffectId;

/// Selected model: candidates (library indices), each finding's drop-one
/// statistics.
pub(super) struct Selection {
    pub(super) set: Vec<usize>,
    pub(super) fit: Fit,
}

pub(super) fn select(d: &Design) -> Selection {
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
    pub(super) channels: Vec<usize>,
    pub(super) explanation: String,
    pub(super) lookalike: Option<EffectId>,
    pub(super) fit: FitFigures,
}

/// Drop-one BIC, held-out figures and look-alikes of every selected
/// candidate.
pub(super) fn report_stats(d: &Design, sel: &Selection) -> Vec<(usize, Judged)> {
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
                fit: FitFigures {
                    residual_rms_before: before,
                    residual_rms_after: after,
                    heldout_rms_before: (hb / nr).sqrt(),
                    heldout_rms_after: (ha / nr).sqrt(),
                },
            },
        ));
    }
    out
}
