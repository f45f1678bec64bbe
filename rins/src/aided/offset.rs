//! The IMU-to-GNSS time offset, estimated by a pre-pass on the data: the
//! run is navigated with the fixes' positions (ungated) shifted by each
//! offset of a grid, and the fixes' NIS (their innovations' chi-square, which is `-2 log` of
//! their likelihood up to a term that barely moves with the offset)
//! traces a parabola whose minimum is the offset and whose curvature its
//! 1-sigma (a change of 1 in the chi-square), scaled by the NIS's own
//! mean per degree of freedom when the filter is overconfident (a
//! likelihood that is too sharp gives too small a sigma), and widened
//! where the fixes' innovations are correlated ([`super::curvature`]).

use super::curvature::{covariance, Curvature};
use super::{navigate, AidedOptions};
use anyhow::{bail, Result};
use recording::Recording;

/// The gate of the pre-pass's runs, sigmas: none in effect.
const UNGATED: f64 = 1e6;

/// An offset estimate.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OffsetEstimate {
    /// The IMU's lateness behind the receiver, s.
    pub offset_s: f64,
    /// Its 1-sigma, s.
    pub sigma_s: f64,
    /// The grid: (offset s, total NIS over the fixes, per degree of freedom).
    pub grid: Vec<(f64, f64, f64)>,
}

/// Finds the offset within `+-span_s` of `opt.time_offset_s` in steps of
/// `step_s`.
///
/// # Errors
/// A run that fails, no fixes used, or a minimum at the grid's edge (the
/// offset lies beyond the span).
pub fn estimate(
    rec: &Recording,
    opt: &AidedOptions,
    span_s: f64,
    step_s: f64,
    progress: &mut dyn FnMut(f64),
) -> Result<OffsetEstimate> {
    let trials = opt.for_trials();
    let opt = &trials;
    let n = (span_s / step_s).round() as i64;
    let mut runs = vec![];
    for k in -n..=n {
        let o = AidedOptions {
            time_offset_s: opt.time_offset_s + k as f64 * step_s,
            ..opt.clone()
        };
        runs.push((o.time_offset_s, fixes_nis(rec, &o)?));
        progress((k + n + 1) as f64 / (2 * n + 1) as f64);
    }
    let grid: Vec<(f64, f64, f64)> = runs.iter().map(|(t, f)| (*t, f.total, f.per_dof)).collect();
    let Some((offset_s, sigma_s)) = least(&grid, step_s) else {
        bail!("no offset estimated: an empty grid");
    };
    if offset_s.is_nan() {
        bail!("the fixes' NIS is least at the grid's edge: the offset is beyond +-{span_s} s");
    }
    Ok(OffsetEstimate {
        offset_s,
        sigma_s: widened(&runs, step_s).map_or(sigma_s, |v| v.sqrt().max(sigma_s)),
        grid,
    })
}

/// The offset's variance at the grid's least run with its neighbours'
/// ([`Curvature::along_line`]: the model's, widened by the fixes'
/// correlated scores); `None` at an edge or where the NIS does not curve.
fn widened(runs: &[(f64, FixesNis)], step_s: f64) -> Option<f64> {
    let best = (0..runs.len()).min_by(|a, b| runs[*a].1.total.total_cmp(&runs[*b].1.total))?;
    let (down, f0, up) = (
        &runs.get(best.checked_sub(1)?)?.1,
        &runs[best].1,
        &runs.get(best + 1)?.1,
    );
    let c = Curvature::along_line(down, f0, up, step_s);
    covariance(&c, f0.per_dof).map(|(v, _)| v[(0, 0)])
}

/// The fixes' NIS over a pre-pass run of `opt` (total, per degree of
/// freedom): positions only (a receiver's velocity may lag its own
/// positions: a filter inside it), every fix ungated (a gate would drop
/// the worst ones and lower the sum where the tried value is wrong), no
/// zero-velocity updates (they do not depend on the fixes and only blur
/// their residuals). The outages cut in stay cut: their fixes are the
/// reference, which nothing the run uses may have seen.
///
/// # Errors
/// A run that fails, or no fix used.
pub fn fixes_nis(rec: &Recording, opt: &AidedOptions) -> Result<FixesNis> {
    let o = AidedOptions {
        gate_sigma: UNGATED,
        gnss_velocity: false,
        zupt: false,
        ..opt.for_trials()
    };
    let run = navigate(rec, &o, &mut |_| {})?;
    let used: Vec<&(f64, f64, u8)> = run.nis.iter().filter(|x| x.2 > 0).collect();
    let dof: f64 = used.iter().map(|x| f64::from(x.2)).sum();
    if dof == 0.0 {
        bail!("no fix was used: nothing can be estimated from the fixes");
    }
    let total = used.iter().map(|x| x.1).sum::<f64>();
    let stamp_us = |t: f64| ((t - o.time_offset_s) * 1e6).round() as i64;
    Ok(FixesNis {
        total,
        per_dof: total / dof,
        each: used.iter().map(|x| (stamp_us(x.0), x.1)).collect(),
    })
}

/// The fixes' NIS over one pre-pass run ([`fixes_nis`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FixesNis {
    /// Summed over the fixes used.
    pub total: f64,
    /// Per degree of freedom.
    pub per_dof: f64,
    /// Each used fix's: (its stamp on the receiver's clock, us; its NIS).
    /// The stamp names the same fix in runs of different offsets.
    pub each: Vec<(i64, f64)>,
}

/// The least point of an evenly spaced grid of (value, total NIS, NIS per
/// degree of freedom), refined by the parabola through it and its
/// neighbours, and its 1-sigma: the change of 1 in the total NIS (its
/// `-2 log` likelihood), scaled by the NIS per degree of freedom there
/// when above 1 (an overconfident filter's likelihood is too sharp).
/// NaN value when the least point is at the grid's edge (the minimum lies
/// beyond it); infinite sigma when the NIS does not curve there (the
/// value is not resolved by the fixes). None for an empty grid.
pub fn least(grid: &[(f64, f64, f64)], step: f64) -> Option<(f64, f64)> {
    let best = (0..grid.len()).min_by(|a, b| grid[*a].1.total_cmp(&grid[*b].1))?;
    let (Some(lo), Some(hi)) = (
        best.checked_sub(1).and_then(|i| grid.get(i)),
        grid.get(best + 1),
    ) else {
        return Some((f64::NAN, f64::INFINITY));
    };
    let (x0, y0, per) = *grid.get(best)?;
    let c = (lo.1 + hi.1 - 2.0 * y0) / (2.0 * step * step);
    if c <= 0.0 {
        return Some((x0, f64::INFINITY));
    }
    let shift = ((lo.1 - hi.1) / (4.0 * c * step)).clamp(-step, step);
    Some((x0 + shift, (per.max(1.0) / c).sqrt()))
}

/// The share of the filter's measurement components the gate may refuse
/// before a run says its clocks may disagree: a consistent filter's
/// gate at [`super::GATE_SIGMA`] refuses far fewer (the held-back real
/// drive without its logger's 0.25 s: hundreds of rejections and 73
/// re-initialisations).
pub const HINT_REJECTED_SHARE: f64 = 0.05;

/// The fixes' NIS per component above which a run says they sit farther
/// from it than their sigmas allow: half again the variance they state.
/// Over the hundreds of fixes a run has, a consistent filter's mean is 1
/// within a few per cent (chi-square over their count); the real walk
/// with its author's antenna arm reads 1.8 (and 51 % of its fixes inside
/// their bounds), with the arm its fixes give 1.1 in the pre-pass.
pub const HINT_NIS_PER_DOF: f64 = 1.5;

/// The fixes' NIS per component above which a run shows a symptom and
/// `navigate` looks at its clocks and arm: a quarter again the variance
/// the fixes state (their sigmas 11 % too small). Lower than
/// [`HINT_NIS_PER_DOF`], the bound an arm must fit within, since a
/// symptom costs only the pre-passes: nothing found is taken unless it is
/// resolved and the fixes' NIS falls with it. A consistent run's mean is
/// 1 within a few per cent (the simulated city drives: 0.96-1.04); a
/// simulated city drive's 1.5 m fixes stamped 0.25 s early read 1.47
/// with its NEES per degree of freedom at 4.9 (`cli_walk_clock.rs`).
pub const HINT_SYMPTOM_NIS_PER_DOF: f64 = 1.25;

/// What in a finished run points at its clocks or its antenna:
/// re-initialisations with fixes arriving (not the ones an outage's error
/// caused), the gate refusing more than [`HINT_REJECTED_SHARE`] of the
/// components (of every kind of update: the fixes' are most of them), or
/// the fixes' NIS per component above [`HINT_SYMPTOM_NIS_PER_DOF`].
/// `None`: none.
pub fn symptom(s: &super::AidedSummary, run: &super::AidedRun) -> Option<String> {
    let lost = s
        .reinit_at
        .iter()
        .filter(|r| r.after_outage.is_none())
        .count();
    let used: f64 = run.nis.iter().map(|x| f64::from(x.2)).sum();
    let refused = f64::from(s.rejected);
    let share = refused / (refused + used).max(1.0);
    let nis = s.nis_mean_per_dof.filter(|n| *n > HINT_SYMPTOM_NIS_PER_DOF);
    let mut said = vec![];
    if share > HINT_REJECTED_SHARE {
        said.push(format!(
            "the gate refused {:.0} % of the components",
            100.0 * share
        ));
    }
    if lost > 0 {
        said.push(format!("{lost} re-initialisations with fixes arriving"));
    }
    if let Some(n) = nis {
        said.push(format!(
            "the fixes' NIS per component is {n:.2} (their sigmas allow about 1)"
        ));
    }
    (!said.is_empty()).then(|| said.join("; "))
}

/// A run's symptom and the offset the fixes' NIS then finds.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OffsetHint {
    /// What pointed at the clocks ([`symptom`]).
    pub symptom: String,
    /// The offset found around the run's own (`None`: not found, see
    /// `error`).
    pub estimate: Option<OffsetEstimate>,
    /// Why it was not found.
    pub error: Option<String>,
    /// The run's own offset, s.
    pub run_offset_s: f64,
    /// The offset found differs from the run's by more than twice its
    /// sigma and a grid step: re-run with it.
    pub recommended: bool,
    /// When recommended and the run's clock and arm were the
    /// recording's: the two found together around the offset found
    /// ([`super::joint::for_hint`]), each sigma including what the other
    /// absorbs (an arm held wrong bends the offset found alone, and the
    /// offset held leaves the arm wrong).
    pub together: Option<super::joint::JointEstimate>,
    /// Why the two were not found together.
    pub together_error: Option<String>,
    /// The run was navigated again with `together` (or, not found, the
    /// offset alone) and that run kept (`navigate` does when the fixes'
    /// NIS per component falls with it).
    pub applied: bool,
    /// Why the run with `together` (or the offset) was not kept.
    pub kept_given_because: Option<String>,
}

impl OffsetHint {
    /// What the recommended offset led to: the two found together and
    /// navigated with, or what to re-run with.
    fn then(&self, e: &OffsetEstimate) -> String {
        let found = match &self.together {
            Some(j) => {
                let arm = j.lever_b_m;
                format!(
                    "; with the antenna arm found together {:+.3} +- {:.3} s, the arm {:+.3}, {:+.3}, {:+.3} m in b",
                    j.offset_s, j.sigma_s, arm[0], arm[1], arm[2]
                )
            }
            None => self
                .together_error
                .as_deref()
                .map_or(String::new(), |w| format!(" (not found with the arm: {w})")),
        };
        let what = if self.together.is_some() {
            "both"
        } else {
            "it"
        };
        match (self.applied, &self.kept_given_because) {
            (true, _) => format!(
                "{found}: navigated with {what}, above (--time-offset-s or --keep-given-arm: as given)"
            ),
            (false, Some(why)) => format!("{found}: navigated with {what}, but kept this run: {why}"),
            (false, None) if self.together.is_some() => {
                format!("{found}: navigate with --estimate-time-offset --estimate-lever-arm")
            }
            (false, None) => format!(
                "{found}: navigate with --time-offset-s {:.3} or --estimate-time-offset --estimate-lever-arm",
                e.offset_s
            ),
        }
    }

    /// The summary's line.
    pub fn text(&self) -> String {
        match (&self.estimate, self.recommended) {
            (Some(e), true) => format!(
                "time offset: {}: a clock offset between the IMU and the receiver does that; the fixes' NIS puts the IMU {:+.3} +- {:.3} s late (this run took {:+.3} s){}\n",
                self.symptom, e.offset_s, e.sigma_s, self.run_offset_s, self.then(e)
            ),
            (Some(e), false) => format!(
                "time offset: {}; the fixes' NIS puts the IMU {:+.3} +- {:.3} s late, where this run took it: not the clocks\n",
                self.symptom, e.offset_s, e.sigma_s
            ),
            (None, _) => format!(
                "time offset: {}; the offset could not be estimated: {}\n",
                self.symptom,
                self.error.as_deref().unwrap_or("unknown")
            ),
        }
    }
}

/// When `run` (navigated with `opt`) shows a [`symptom`], the offset
/// estimated around its own over +-0.5 s in 0.02 s steps; `None` without
/// a symptom.
pub fn hint(
    rec: &Recording,
    opt: &AidedOptions,
    s: &super::AidedSummary,
    run: &super::AidedRun,
    progress: &mut dyn FnMut(f64),
) -> Option<OffsetHint> {
    Some(hint_because(rec, opt, symptom(s, run)?, progress))
}

/// The offset estimated around `opt`'s over +-0.5 s in 0.02 s steps, for
/// a run that showed `symptom` (its own, or the arm's pre-pass finding
/// no arm at the run's clock: [`super::lever::LeverEstimate::fits`]).
pub fn hint_because(
    rec: &Recording,
    opt: &AidedOptions,
    symptom: String,
    progress: &mut dyn FnMut(f64),
) -> OffsetHint {
    let step = 0.02;
    let (estimate, error) = match estimate(rec, opt, 0.5, step, progress) {
        Ok(e) => (Some(e), None),
        Err(e) => (None, Some(format!("{e:#}"))),
    };
    let recommended = estimate.as_ref().is_some_and(|e| {
        let d = (e.offset_s - opt.time_offset_s).abs();
        d > 2.0 * e.sigma_s && d > step
    });
    OffsetHint {
        symptom,
        estimate,
        error,
        run_offset_s: opt.time_offset_s,
        recommended,
        together: None,
        together_error: None,
        applied: false,
        kept_given_because: None,
    }
}
