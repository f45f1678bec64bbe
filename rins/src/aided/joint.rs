//! The time offset and the antenna's arm estimated together
//! (`navigate --estimate-time-offset --estimate-lever-arm`): each
//! pre-pass alone ([`super::offset`], [`super::lever`]) finds its value
//! with the other held, and its sigma is its own curvature of the fixes'
//! NIS, conditional on the other being right. They are not independent:
//! an arm along the direction of travel moves the antenna along the track
//! as a clock offset does (by `v dt`), and only the speed's changes and
//! the turns tell them apart. Here the NIS's Hessian over the offset and
//! the resolved arm components together (central differences about the
//! separate estimates) gives one Newton step toward the joint least
//! point and the marginal sigmas: each includes what the other absorbs,
//! what an unresolved component held as given bends them by (within a
//! metre, [`super::lever::UNRESOLVED_SIGMA_M`]), and what the fixes'
//! correlated innovations take from the evidence
//! ([`super::curvature::with_held`]).

use super::curvature::{covariance, curvature, with_held, NisAt};
use super::lever::{LeverEstimate, UNRESOLVED_SIGMA_M};
use super::offset::{fixes_nis, OffsetEstimate};
use super::AidedOptions;
use anyhow::{bail, Result};
use nalgebra::{DMatrix, DVector};
use recording::Recording;

/// The stencil's step in the offset, s (two of the offset grid's steps).
pub const STEP_S: f64 = 0.04;
/// The stencil's step in each arm component, m (two of the arm's fine
/// steps).
pub const STEP_M: f64 = 0.04;

/// How many times a Newton step that does not lower the NIS is halved
/// before the separate estimates are kept.
const BACKTRACKS: usize = 4;

/// The offset and the arm, found together.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct JointEstimate {
    /// The IMU's lateness behind the receiver, s.
    pub offset_s: f64,
    /// Its marginal 1-sigma, s (what the arm absorbs included).
    pub sigma_s: f64,
    /// Its 1-sigma with the arm held at its value, s (the conditional
    /// one of the same covariance: what the offset's pre-pass alone
    /// states, less its own widening).
    pub sigma_s_arm_held: f64,
    /// The antenna from the IMU in `b`, m.
    pub lever_b_m: [f64; 3],
    /// Each resolved component's marginal 1-sigma, m (`None`: not resolved
    /// by the motion, kept as the arm's pre-pass left it).
    pub sigma_lever_m: [Option<f64>; 3],
    /// The offset's correlation with each resolved component.
    pub correlation: [Option<f64>; 3],
    /// How far the joint least point lies from the separate estimates:
    /// offset s, then the arm's components in `b`, m.
    pub moved: [f64; 4],
    /// Newton iterations made.
    pub iterations: usize,
    /// How many times the model's variance (`2 H^-1`) the fixes'
    /// correlated scores widened the widest direction
    /// ([`super::curvature::covariance`]; 1: not at all).
    pub widened: f64,
    /// The covariance of the offset's and the arm's errors: the offset
    /// (s), then the arm's components in `b` (m), an unresolved one known
    /// to [`UNRESOLVED_SIGMA_M`] (what a run navigated with both carries:
    /// [`super::AidedOptions::consider`]).
    pub covariance: [[f64; 4]; 4],
}

/// The parameters (the offset, then the resolved arm components) and
/// their stencil steps.
struct Params {
    axes: Vec<usize>,
    h: Vec<f64>,
}

impl Params {
    fn options(&self, opt: &AidedOptions, x: &[f64]) -> AidedOptions {
        let mut o = opt.clone();
        let mut arm = opt.lever_b_m.unwrap_or([0.0; 3]);
        for (k, v) in x.iter().enumerate() {
            match k.checked_sub(1).and_then(|a| self.axes.get(a)) {
                None => o.time_offset_s = *v,
                Some(&i) => {
                    if let Some(c) = arm.get_mut(i) {
                        *c = *v;
                    }
                }
            }
        }
        o.lever_b_m = Some(arm);
        o
    }
}

/// Newton iterations at most (each a Hessian: `1 + 2 n^2` runs for `n`
/// parameters).
pub const ITERATIONS: usize = 8;
/// The largest step of one iteration, in stencil steps (1 s, 1 m): the
/// separate estimates can sit far along the ridge where one absorbed the
/// other (an arm found at a wrong clock takes `v dt` of it).
const MAX_STEP: f64 = 25.0;
/// Converged when every component of the next Newton step is within this
/// share of its marginal sigma.
pub(super) const CONVERGED_SIGMAS: f64 = 0.2;

/// Estimates the offset and the arm together, starting from the separate
/// estimates `offset` and `lever` (`opt` navigated with both): damped
/// Newton iterations on the fixes' total NIS, then the marginal sigmas
/// from its Hessian at the least point (`2 H^-1`, scaled by the NIS per
/// degree of freedom there when above 1, as each pre-pass scales its own).
///
/// # Errors
/// A run that fails, or a Hessian that is not positive definite (the NIS
/// is not a bowl there: the two are not resolved together).
pub fn estimate(
    rec: &Recording,
    opt: &AidedOptions,
    offset: &OffsetEstimate,
    lever: &LeverEstimate,
    progress: &mut dyn FnMut(f64),
) -> Result<JointEstimate> {
    let trials = opt.for_trials();
    let opt = &trials;
    let axes: Vec<usize> = (0..3).filter(|i| lever.sigma_m[*i].is_some()).collect();
    let mut x = vec![offset.offset_s];
    x.extend(axes.iter().map(|i| lever.b_m[*i]));
    let start = x.clone();
    let mut h = vec![STEP_S];
    h.extend(axes.iter().map(|_| STEP_M));
    let p = Params { axes, h };
    let opt = AidedOptions {
        lever_b_m: Some(lever.b_m),
        ..opt.clone()
    };
    let mut nis = |x: &[f64]| fixes_nis(rec, &p.options(&opt, x));
    for it in 0..=ITERATIONS {
        progress(it as f64 / (ITERATIONS + 1) as f64);
        let f0 = nis(&x)?;
        let c = curvature(&x, &p.h, &f0, &mut nis)?;
        let Some((cov, widened)) = covariance(&c, f0.per_dof) else {
            bail!("the fixes' NIS is not a bowl over the offset and the arm together: they are not resolved together");
        };
        let newton = -c
            .hess
            .clone()
            .cholesky()
            .map_or(c.grad.clone(), |ch| ch.solve(&c.grad));
        let converged =
            (0..x.len()).all(|k| newton[k].abs() < CONVERGED_SIGMAS * cov[(k, k)].sqrt());
        let step = match converged || it == ITERATIONS {
            true => None,
            false => descend(&x, &newton, &p.h, f0.total, &mut nis)?,
        };
        match step {
            Some(s) => x = s,
            None => {
                let (cov, widened) = match p.axes.len() {
                    3 => (cov, widened),
                    _ => held_too(rec, &opt, &p, &x, &f0)?,
                };
                progress(1.0);
                let at = Least {
                    x: &x,
                    cov: &cov,
                    widened,
                };
                return Ok(report(&p, lever, &at, &start, it));
            }
        }
    }
    bail!("no Newton iteration was made")
}

/// The covariance at the least point `x` (`f0` there) over the offset
/// and all three arm components, with what the unresolved ones, held as
/// the arm's pre-pass left them, bend the offset and the resolved ones by
/// ([`super::curvature::with_held`] over the NIS's Hessian in the four).
fn held_too(
    rec: &Recording,
    opt: &AidedOptions,
    p: &Params,
    x: &[f64],
    f0: &super::offset::FixesNis,
) -> Result<(DMatrix<f64>, f64)> {
    let all = Params {
        axes: vec![0, 1, 2],
        h: vec![STEP_S, STEP_M, STEP_M, STEP_M],
    };
    let arm = p.options(opt, x).lever_b_m.unwrap_or([0.0; 3]);
    let xa = [x[0], arm[0], arm[1], arm[2]];
    let mut nis = |y: &[f64]| fixes_nis(rec, &all.options(opt, y));
    let c = curvature(&xa, &all.h, f0, &mut nis)?;
    let mut estimated = vec![true];
    estimated.extend((0..3).map(|i| p.axes.contains(&i)));
    let Some(found) = with_held(&c, f0.per_dof, &estimated, UNRESOLVED_SIGMA_M) else {
        bail!("the fixes' NIS is not a bowl over the offset and the resolved arm together");
    };
    Ok(found)
}

/// The least point and the NIS's shape there.
struct Least<'a> {
    x: &'a [f64],
    /// Over the offset and all three components (in that order).
    cov: &'a DMatrix<f64>,
    widened: f64,
}

/// The damped step from `x` along `newton` (each component clamped to
/// [`MAX_STEP`] stencil steps, halved while the NIS is not below `f0`, up
/// to [`BACKTRACKS`] times); `None` when no halving lowers it.
pub(super) fn descend(
    x: &[f64],
    newton: &DVector<f64>,
    h: &[f64],
    f0: f64,
    nis: &mut NisAt,
) -> Result<Option<Vec<f64>>> {
    let mut scale = 1.0;
    for _ in 0..=BACKTRACKS {
        let to: Vec<f64> = x
            .iter()
            .zip(newton.iter().zip(h))
            .map(|(v, (s, hi))| v + scale * s.clamp(-MAX_STEP * hi, MAX_STEP * hi))
            .collect();
        if nis(&to)?.total < f0 {
            return Ok(Some(to));
        }
        scale *= 0.5;
    }
    Ok(None)
}

/// The estimate at the least point `at.x` (moved from `start`).
fn report(
    p: &Params,
    lever: &LeverEstimate,
    at: &Least,
    start: &[f64],
    iterations: usize,
) -> JointEstimate {
    let (x, cov) = (at.x, at.cov);
    let sd = |k: usize| cov[(k, k)].sqrt();
    // The conditional variance: the inverse of the stated precision's
    // diagonal (the marginal's counterpart in the same covariance).
    let held = cov
        .clone()
        .try_inverse()
        .map_or(f64::NAN, |i| 1.0 / i[(0, 0)]);
    let mut out = JointEstimate {
        offset_s: x[0],
        sigma_s: sd(0),
        sigma_s_arm_held: held.sqrt(),
        lever_b_m: lever.b_m,
        sigma_lever_m: [None; 3],
        correlation: [None; 3],
        moved: [x[0] - start[0], 0.0, 0.0, 0.0],
        iterations,
        widened: at.widened,
        covariance: [[0.0; 4]; 4],
    };
    for (a, &i) in p.axes.iter().enumerate() {
        let (k, c) = (a + 1, i + 1);
        out.lever_b_m[i] = x[k];
        out.sigma_lever_m[i] = Some(sd(c));
        out.correlation[i] = Some(cov[(0, c)] / (sd(0) * sd(c)));
        out.moved[i + 1] = x[k] - start[k];
    }
    out.covariance = std::array::from_fn(|r| std::array::from_fn(|c| cov[(r, c)]));
    out
}

/// A run without `--estimate-time-offset` whose clocks the fixes point
/// at ([`super::offset::hint`], recommended): the arm found at the
/// offset found (its pre-pass, [`super::lever::estimate`]), then the two
/// together, into `hint.together` (or why not, `hint.together_error`).
/// An arm held wrong bends the offset found alone, and a clock held
/// wrong bends the arm: re-run with the offset alone, a run keeps the
/// arm's error (the walk with its fixes 0.05 s off: 1.6-2.9 m at its 10 s
/// outages' ends).
pub fn for_hint(
    rec: &Recording,
    opt: &AidedOptions,
    hint: &mut super::offset::OffsetHint,
    progress: &mut dyn FnMut(f64),
) {
    let Some(o) = hint.estimate.as_ref().filter(|_| hint.recommended) else {
        return;
    };
    let at = AidedOptions {
        time_offset_s: o.offset_s,
        ..opt.clone()
    };
    let found = super::lever::estimate(rec, &at, &mut |f| progress(0.5 * f)).and_then(|l| {
        let with = AidedOptions {
            lever_b_m: Some(l.b_m),
            ..at.clone()
        };
        estimate(rec, &with, o, &l, &mut |f| progress(0.5 + 0.5 * f))
    });
    match found {
        Ok(j) => hint.together = Some(j),
        Err(e) => hint.together_error = Some(format!("{e:#}")),
    }
}

impl JointEstimate {
    /// For a person: two lines.
    pub fn text(&self) -> String {
        let arm = (0..3)
            .map(|i| match self.sigma_lever_m[i] {
                Some(s) => format!("{:+.3} +- {:.3}", self.lever_b_m[i], s),
                None => format!("{:+.3} (not resolved)", self.lever_b_m[i]),
            })
            .collect::<Vec<_>>()
            .join(", ");
        let corr = (0..3)
            .filter_map(|i| self.correlation[i].map(|c| format!("{} {c:+.2}", ["x", "y", "z"][i])))
            .collect::<Vec<_>>()
            .join(", ");
        format!(
            "estimated together: time offset {:+.3} +- {:.3} s ({:.3} s with the arm held), lever arm {arm} m in b\n  the offset's correlation with the arm: {}; {}\n",
            self.offset_s,
            self.sigma_s,
            self.sigma_s_arm_held,
            if corr.is_empty() { "none resolved".into() } else { corr },
            match self.widened > 1.0 {
                true => format!("the fixes' correlated innovations widen the sigmas up to {:.1}x", self.widened.sqrt()),
                false => "the fixes' innovations no more correlated than the model says".into(),
            },
        )
    }
}
