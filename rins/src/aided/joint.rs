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
//! point and the marginal sigmas: each includes what the other absorbs.

use super::lever::LeverEstimate;
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

/// The fixes' NIS (total, per degree of freedom) at a parameter vector.
type NisAt<'a> = dyn FnMut(&[f64]) -> Result<(f64, f64)> + 'a;

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
    /// Its 1-sigma with the arm held at its value, s (its own curvature:
    /// what the offset's pre-pass alone states).
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
const CONVERGED_SIGMAS: f64 = 0.2;

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
        let (f0, per) = nis(&x)?;
        let (hess, grad) = curvature(&x, &p.h, f0, &mut nis)?;
        let Some(ch) = hess.clone().cholesky() else {
            bail!("the fixes' NIS is not a bowl over the offset and the arm together: they are not resolved together");
        };
        let inv = ch.inverse();
        let cov = &inv * (2.0 * per.max(1.0));
        let newton = -&inv * &grad;
        let converged =
            (0..x.len()).all(|k| newton[k].abs() < CONVERGED_SIGMAS * cov[(k, k)].sqrt());
        let step = match converged || it == ITERATIONS {
            true => None,
            false => descend(&x, &newton, &p.h, f0, &mut nis)?,
        };
        match step {
            Some(s) => x = s,
            None => {
                progress(1.0);
                return Ok(report(&p, lever, &x, &start, &cov, &hess, per, it));
            }
        }
    }
    bail!("no Newton iteration was made")
}

/// The damped step from `x` along `newton` (each component clamped to
/// [`MAX_STEP`] stencil steps, halved while the NIS is not below `f0`, up
/// to [`BACKTRACKS`] times); `None` when no halving lowers it.
fn descend(
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
        if nis(&to)?.0 < f0 {
            return Ok(Some(to));
        }
        scale *= 0.5;
    }
    Ok(None)
}

/// The estimate at the least point `x` (moved from `start`), with the
/// NIS's covariance `cov` and Hessian `hess` there.
#[allow(clippy::too_many_arguments)]
fn report(
    p: &Params,
    lever: &LeverEstimate,
    x: &[f64],
    start: &[f64],
    cov: &DMatrix<f64>,
    hess: &DMatrix<f64>,
    per: f64,
    iterations: usize,
) -> JointEstimate {
    let sd = |k: usize| cov[(k, k)].sqrt();
    let mut out = JointEstimate {
        offset_s: x[0],
        sigma_s: sd(0),
        sigma_s_arm_held: (2.0 * per.max(1.0) / hess[(0, 0)]).sqrt(),
        lever_b_m: lever.b_m,
        sigma_lever_m: [None; 3],
        correlation: [None; 3],
        moved: [x[0] - start[0], 0.0, 0.0, 0.0],
        iterations,
    };
    for (a, &i) in p.axes.iter().enumerate() {
        let k = a + 1;
        out.lever_b_m[i] = x[k];
        out.sigma_lever_m[i] = Some(sd(k));
        out.correlation[i] = Some(cov[(0, k)] / (sd(0) * sd(k)));
        out.moved[i + 1] = x[k] - start[k];
    }
    out
}

/// The Hessian and gradient of the total NIS at `x` (value `f0`) by
/// central differences of steps `h` (`nis` at a parameter vector).
pub(crate) fn curvature(
    x: &[f64],
    h: &[f64],
    f0: f64,
    nis: &mut NisAt,
) -> Result<(DMatrix<f64>, DVector<f64>)> {
    let n = x.len();
    let mut f = |d: &[(usize, f64)]| -> Result<f64> {
        let mut y = x.to_vec();
        for (i, s) in d {
            if let (Some(v), Some(hi)) = (y.get_mut(*i), h.get(*i)) {
                *v += s * hi;
            }
        }
        Ok(nis(&y)?.0)
    };
    let mut hess = DMatrix::<f64>::zeros(n, n);
    let mut grad = DVector::<f64>::zeros(n);
    for (i, &hi) in h.iter().enumerate() {
        let (up, down) = (f(&[(i, 1.0)])?, f(&[(i, -1.0)])?);
        hess[(i, i)] = (up + down - 2.0 * f0) / (hi * hi);
        grad[i] = (up - down) / (2.0 * hi);
        for (j, &hj) in h.iter().enumerate().skip(i + 1) {
            let pp = f(&[(i, 1.0), (j, 1.0)])?;
            let pm = f(&[(i, 1.0), (j, -1.0)])?;
            let mp = f(&[(i, -1.0), (j, 1.0)])?;
            let mm = f(&[(i, -1.0), (j, -1.0)])?;
            hess[(i, j)] = (pp - pm - mp + mm) / (4.0 * hi * hj);
            hess[(j, i)] = hess[(i, j)];
        }
    }
    Ok((hess, grad))
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
            "estimated together: time offset {:+.3} +- {:.3} s ({:.3} s with the arm held), lever arm {arm} m in b\n  the offset's correlation with the arm: {}\n",
            self.offset_s,
            self.sigma_s,
            self.sigma_s_arm_held,
            if corr.is_empty() { "none resolved".into() } else { corr },
        )
    }
}
