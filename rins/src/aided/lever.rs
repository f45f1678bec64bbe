//! The antenna's lever arm, estimated by a pre-pass on the data, as the
//! time offset is ([`super::offset`]): the run is navigated with the
//! fixes' positions (ungated) for lever arms along each axis of `b` in
//! turn, and the fixes' NIS, the `-2 log` likelihood of the arm, is least
//! at the arm the motion says. Where the base turns, an arm `l` moves the
//! antenna by `c_b_n l` about the IMU: a receiver with centimetre fixes
//! sees centimetres of arm. An axis the motion does not turn about leaves
//! the NIS flat along it: that component is kept as given and said to be
//! unresolved.

use super::curvature::with_held;
use super::joint::{descend, CONVERGED_SIGMAS, ITERATIONS};
use super::offset::{fixes_nis, least, FixesNis};
use super::AidedOptions;
use anyhow::{bail, Result};
use recording::Recording;

/// How far from the given arm the first search looks, m (each axis): a
/// car's roof antenna sits about a metre from a console IMU.
pub const SPAN_M: f64 = 1.0;
/// How far a first search whose least NIS is at its edge walks on, m
/// from the given arm (each axis): an arm this far from where the
/// recording puts it is a wrong recording, not a lever arm to find.
pub const MAX_SPAN_M: f64 = 3.0;
/// The first search's step, m.
const COARSE_M: f64 = 0.1;
/// The second search's step, m (about the first's least point, +-5
/// steps).
const FINE_M: f64 = 0.02;

/// A lever-arm estimate.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LeverEstimate {
    /// The arm the search started from (the sensor file's or
    /// meta.toml's), `b`, m.
    pub given_b_m: [f64; 3],
    /// The antenna's position from the IMU in `b`, m.
    pub b_m: [f64; 3],
    /// Each component's 1-sigma, m (`None`: not resolved by the motion,
    /// kept as given, or at a first pass's least a second found flat).
    pub sigma_m: [Option<f64>; 3],
    /// The fixes' NIS per degree of freedom with the given arm and with
    /// the estimate.
    pub nis_per_dof: [f64; 2],
    /// The covariance of the arm's errors, `b`, m^2: an unresolved
    /// component known to [`UNRESOLVED_SIGMA_M`] and what it moves the
    /// resolved ones by (`None` when none is resolved or the NIS is no
    /// bowl: the arm's error is then not known).
    pub covariance_m2: Option<[[f64; 3]; 3]>,
}

/// The passes: each axis coarse then fine; then each fine again about the
/// others' new values (the axes' NIS is not quite separable).
const PASSES: [(usize, bool); 6] = [
    (0, true),
    (1, true),
    (2, true),
    (0, false),
    (1, false),
    (2, false),
];

/// Estimates the arm, starting from `opt.lever_b_m` (or the recording's).
/// The 1-sigmas are the marginal ones: the inverse of the NIS's curvature
/// over the resolved axes together (a central-difference Hessian), not
/// each axis's own curvature, which holds the others fixed.
///
/// # Errors
/// A run that fails, no fix used, a least NIS still falling at
/// [`MAX_SPAN_M`] from the given arm (the first search looks
/// [`SPAN_M`] each way and walks on while the NIS falls). Whether the
/// runs fit the fixes at the arm found is [`LeverEstimate::fits`].
pub fn estimate(
    rec: &Recording,
    opt: &AidedOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<LeverEstimate> {
    let trials = opt.for_trials();
    let opt = &trials;
    let given = super::lever_b_m(rec, opt);
    let mut at = |l: &[f64; 3]| {
        let o = AidedOptions {
            lever_b_m: Some(*l),
            ..opt.clone()
        };
        fixes_nis(rec, &o)
    };
    search(given, &mut at, progress)
}

/// [`estimate`]'s search from `given` over an NIS of the arm.
fn search(
    given: [f64; 3],
    at: &mut dyn FnMut(&[f64; 3]) -> Result<FixesNis>,
    progress: &mut dyn FnMut(f64),
) -> Result<LeverEstimate> {
    let coarse = (SPAN_M / COARSE_M).round() as i64;
    let runs = 3 * (2 * coarse + 1) + 6 * 11 + 21;
    let mut nis = Nis {
        nis: at,
        done: 0,
        runs,
        progress,
    };
    let mut arm = given;
    let mut resolved = [false; 3];
    for (axis, first) in PASSES {
        let rough = match first {
            true => {
                let (rough, _, mut grid) = nis.line(&arm, axis, given[axis], COARSE_M, coarse)?;
                if !rough.is_nan() {
                    rough
                } else if edge_evidence(&grid, coarse) < EDGE_SIGMAS * EDGE_SIGMAS {
                    // Least at an edge but not 3 sigma below the given
                    // arm's: the axis is flat there, unresolved.
                    continue;
                } else {
                    // The NIS says the arm lies beyond the span: follow
                    // it out (the other axes still wrong bend it there).
                    nis.walk_out(&arm, axis, given[axis], &mut grid)?
                }
            }
            false if resolved[axis] => arm[axis],
            false => continue,
        };
        let (fine, s) = nis.fine(&arm, axis, rough, given[axis])?;
        resolved[axis] = fine.is_finite() && s < SPAN_M;
        if resolved[axis] {
            arm[axis] = fine;
        }
    }
    let (arm, covariance_m2) = nis.polished(arm, resolved)?;
    let nis_per_dof = [nis.at(&given)?.per_dof, nis.at(&arm)?.per_dof];
    let sigma_m: [Option<f64>; 3] = std::array::from_fn(|i| {
        covariance_m2
            .filter(|_| resolved[i])
            .and_then(|c| c.get(i).and_then(|r| r.get(i)).map(|v| v.sqrt()))
    });
    Ok(LeverEstimate {
        given_b_m: given,
        b_m: arm,
        sigma_m,
        nis_per_dof,
        covariance_m2,
    })
}

impl LeverEstimate {
    /// The pre-pass's runs fit the fixes at the least arm: their NIS per
    /// degree of freedom at most [`super::offset::HINT_NIS_PER_DOF`]. A
    /// run that is lost (an outage over the fixes the heading is aligned
    /// on) fits no arm, and the least of its NIS is an arm bent to absorb
    /// the lost run's errors, with a curvature as sharp as the loss (the
    /// book's walk with an outage over its alignment). A clock off by a
    /// tenth of a second fits no arm either, yet its least is the start
    /// the joint estimate ([`super::joint`]) refines: `navigate` refuses
    /// an arm that does not fit only where no offset is estimated with it.
    ///
    /// # Errors
    /// The runs fit no arm: why, with the figures.
    pub fn fits(&self) -> Result<()> {
        let bound = super::offset::HINT_NIS_PER_DOF;
        let least = self.nis_per_dof[1];
        // NaN (no fix) fails too: no arm is found from nothing.
        if least <= bound {
            return Ok(());
        }
        bail!(
            "the fixes fit no arm: their NIS per degree of freedom is {least:.1} at the least (their sigmas allow about 1, {bound} at most): the pre-pass's runs are lost, not the arm (an outage over the fixes the heading is aligned on? a clock?)"
        )
    }
}

/// A line search's grid: (value, total NIS, NIS per degree of freedom).
type Grid = Vec<(f64, f64, f64)>;

/// How many sigmas below the given arm's the NIS at a search's edge must
/// be for the arm to be beyond the span (else the axis is unresolved).
const EDGE_SIGMAS: f64 = 3.0;

/// How far the least NIS of `grid` lies below that at its centre (index
/// `centre`, the given arm), in units of a change of 1 in the
/// likelihood's `-2 log` (scaled by the NIS per degree of freedom when
/// above 1, as [`least`] scales its sigma).
fn edge_evidence(grid: &Grid, centre: i64) -> f64 {
    let at_given = usize::try_from(centre).ok().and_then(|i| grid.get(i));
    let best = grid.iter().min_by(|a, b| a.1.total_cmp(&b.1));
    match (at_given, best) {
        (Some(g), Some(b)) => (g.1 - b.1) / b.2.max(1.0),
        _ => 0.0,
    }
}

/// The pre-pass's runs, counted for the progress.
struct Nis<'a> {
    /// The fixes' NIS with an arm.
    nis: &'a mut dyn FnMut(&[f64; 3]) -> Result<FixesNis>,
    done: usize,
    runs: i64,
    progress: &'a mut dyn FnMut(f64),
}

impl Nis<'_> {
    /// The fixes' NIS (total, per degree of freedom) with arm `l`.
    fn at(&mut self, l: &[f64; 3]) -> Result<FixesNis> {
        let r = (self.nis)(l)?;
        self.done += 1;
        (self.progress)((self.done as f64 / self.runs as f64).min(1.0));
        Ok(r)
    }

    /// The least NIS along `axis` from `arm`, `centre +- n step` ([`least`]),
    /// and the grid.
    fn line(
        &mut self,
        arm: &[f64; 3],
        axis: usize,
        centre: f64,
        step: f64,
        n: i64,
    ) -> Result<(f64, f64, Grid)> {
        let mut grid = vec![];
        for k in -n..=n {
            let mut l = *arm;
            l[axis] = centre + k as f64 * step;
            let f = self.at(&l)?;
            grid.push((l[axis], f.total, f.per_dof));
        }
        let (x, s) = least(&grid, step).unwrap_or((f64::NAN, f64::INFINITY));
        Ok((x, s, grid))
    }

    /// The fine search along `axis` about `rough`, re-centred on its
    /// edge while its least lies there: a second pass's least moves when
    /// the other axes' values move (the axes' NIS is not quite
    /// separable), and may move farther than the fine grid's half-width.
    /// It follows the least up to [`MAX_SPAN_M`] from `given`; beyond,
    /// the least is still at an edge (NaN).
    fn fine(&mut self, arm: &[f64; 3], axis: usize, rough: f64, given: f64) -> Result<(f64, f64)> {
        // Each re-centring moves 5 fine steps one way; the bound also
        // ends a flat NIS's rounding walking to and fro.
        let most = (2.0 * MAX_SPAN_M / (5.0 * FINE_M)).ceil() as usize;
        let mut centre = rough;
        let mut found = (f64::NAN, f64::INFINITY);
        for _ in 0..=most {
            let (x, s, grid) = self.line(arm, axis, centre, FINE_M, 5)?;
            found = (x, s);
            let best = grid.iter().min_by(|a, b| a.1.total_cmp(&b.1)).map(|g| g.0);
            match best {
                Some(edge) if x.is_nan() && (edge - given).abs() < MAX_SPAN_M => centre = edge,
                _ => break,
            }
        }
        Ok(found)
    }

    /// Extends a coarse `grid` along `axis` (sorted, its least NIS at an
    /// edge) outwards a step at a time until the NIS rises again; the
    /// least point ([`least`]).
    ///
    /// # Errors
    /// A run that fails, or still falling at [`MAX_SPAN_M`] from `given`.
    fn walk_out(
        &mut self,
        arm: &[f64; 3],
        axis: usize,
        given: f64,
        grid: &mut Grid,
    ) -> Result<f64> {
        let down = grid.first().map(|g| g.1) <= grid.last().map(|g| g.1);
        let max_steps = ((MAX_SPAN_M - SPAN_M) / COARSE_M).round() as usize;
        for _ in 0..max_steps {
            let edge = if down { grid.first() } else { grid.last() };
            let Some(&(x, y, _)) = edge else { break };
            let mut l = *arm;
            l[axis] = x + if down { -COARSE_M } else { COARSE_M };
            let f = self.at(&l)?;
            if down {
                grid.insert(0, (l[axis], f.total, f.per_dof));
            } else {
                grid.push((l[axis], f.total, f.per_dof));
            }
            if f.total > y {
                let (v, _) = least(grid, COARSE_M).unwrap_or((f64::NAN, f64::INFINITY));
                if v.is_finite() {
                    return Ok(v);
                }
            }
        }
        bail!(
            "the fixes' NIS is least at the search's edge along {}: the lever arm is beyond +-{MAX_SPAN_M} m of {given} m",
            ["x", "y", "z"][axis],
        )
    }

    /// The arm moved from the passes' `arm` to the NIS's least over the
    /// resolved axes together, and its covariance, `b`, m^2. The passes
    /// are a coordinate descent: where the axes' NIS is coupled, two
    /// passes end short of the least (a bowl whose axes trade 3 to 4
    /// against each other: 3 of its sigmas short), so damped Newton steps
    /// follow ([`super::joint`]'s, the held axes where the passes left
    /// them) until each is within a fifth of its sigma.
    ///
    /// The covariance is [`super::curvature`]'s at the least: the total
    /// NIS's Hessian over all three axes by central differences of two
    /// fine steps; the model's `2 H^-1` over the resolved ones, widened by
    /// the fixes' correlated scores, and what the unresolved ones, held as
    /// the search left them to [`UNRESOLVED_SIGMA_M`], bend them by
    /// ([`super::curvature::consider`]: an antenna height held 1.6 m
    /// wrong put a city drive's y 3.1 of its sigmas off without it); the
    /// unresolved ones' own variance theirs. `None` when none is resolved
    /// or the resolved block is not positive definite (the NIS is not a
    /// bowl there): the arm is then the passes'.
    fn polished(&mut self, arm: [f64; 3], resolved: [bool; 3]) -> Result<Polished> {
        let axes: Vec<usize> = (0..3).filter(|i| resolved[*i]).collect();
        let mut arm = arm;
        if axes.is_empty() {
            return Ok((arm, None));
        }
        let h = vec![2.0 * FINE_M; 3];
        for it in 0..=ITERATIONS {
            let f0 = self.at(&arm)?;
            let c = {
                let mut nis = |y: &[f64]| self.at(&with(&arm, &[0, 1, 2], y));
                super::curvature::curvature(&arm, &h, &f0, &mut nis)?
            };
            let Some((cov, _)) = with_held(&c, f0.per_dof, &resolved, UNRESOLVED_SIGMA_M) else {
                return Ok((arm, None));
            };
            let g = c.grad.select_rows(&axes);
            let newton = -c
                .hess
                .select_rows(&axes)
                .select_columns(&axes)
                .cholesky()
                .map_or(g.clone(), |ch| ch.solve(&g));
            let sigma = |k: usize| axes.get(k).map_or(0.0, |&i| cov[(i, i)].sqrt());
            let converged = (0..axes.len()).all(|k| newton[k].abs() < CONVERGED_SIGMAS * sigma(k));
            let x: Vec<f64> = axes.iter().map(|&i| arm[i]).collect();
            let step = match converged || it == ITERATIONS {
                true => None,
                false => {
                    let hr = vec![2.0 * FINE_M; axes.len()];
                    let mut nis = |y: &[f64]| self.at(&with(&arm, &axes, y));
                    descend(&x, &newton, &hr, f0.total, &mut nis)?
                }
            };
            match step {
                Some(to) => arm = with(&arm, &axes, &to),
                None => {
                    let cov = std::array::from_fn(|i| std::array::from_fn(|j| cov[(i, j)]));
                    return Ok((arm, Some(cov)));
                }
            }
        }
        Ok((arm, None))
    }
}

/// An arm and its covariance, `b`: m, m^2.
type Polished = ([f64; 3], Option<[[f64; 3]; 3]>);

/// `arm` with its components `axes` set to `values`.
fn with(arm: &[f64; 3], axes: &[usize], values: &[f64]) -> [f64; 3] {
    let mut l = *arm;
    for (&i, v) in axes.iter().zip(values) {
        if let Some(c) = l.get_mut(i) {
            *c = *v;
        }
    }
    l
}

/// How far an unresolved arm component may be from where it is held, m
/// (1-sigma): the first search's span, within which the recording is
/// taken to place its antenna ([`SPAN_M`]).
pub const UNRESOLVED_SIGMA_M: f64 = SPAN_M;

/// The arm the fixes' NIS finds for a run that showed a symptom its clocks
/// were cleared of ([`super::offset::hint`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct LeverHint {
    /// The estimate (`None`: not found, see `error`).
    pub estimate: Option<LeverEstimate>,
    /// Why it was not found.
    pub error: Option<String>,
    /// A resolved component lies more than 3 of its sigmas and
    /// [`FINE_M`] from the given arm: re-run with the estimate.
    pub recommended: bool,
    /// The run was navigated again with the estimate (`navigate` does
    /// unless told `--keep-given-arm`).
    pub applied: bool,
    /// Why a recommended estimate was navigated with but not kept.
    pub kept_given_because: Option<String>,
}

impl LeverHint {
    /// Estimates the arm of `rec` navigated with `opt`.
    pub fn find(rec: &Recording, opt: &AidedOptions, progress: &mut dyn FnMut(f64)) -> Self {
        let fitting = |e: LeverEstimate| e.fits().map(|()| e);
        match estimate(rec, opt, progress).and_then(fitting) {
            Ok(e) => {
                let off = |i: usize| {
                    let d = (e.b_m[i] - e.given_b_m[i]).abs();
                    e.sigma_m[i].is_some_and(|s| d > 3.0 * s && d > FINE_M)
                };
                let recommended = (0..3).any(off);
                Self {
                    estimate: Some(e),
                    error: None,
                    recommended,
                    applied: false,
                    kept_given_because: None,
                }
            }
            Err(e) => Self {
                estimate: None,
                error: Some(format!("{e:#}")),
                recommended: false,
                applied: false,
                kept_given_because: None,
            },
        }
    }

    /// The summary's line.
    pub fn text(&self) -> String {
        let arm = |v: [f64; 3]| format!("{:+.3}, {:+.3}, {:+.3} m", v[0], v[1], v[2]);
        match (&self.estimate, self.recommended) {
            (Some(e), true) => format!(
                "antenna lever arm: the fixes' NIS puts it at {} in b, not the given {} (NIS per dof {:.2} -> {:.2}): {}\n",
                arm(e.b_m), arm(e.given_b_m), e.nis_per_dof[0], e.nis_per_dof[1],
                match (self.applied, &self.kept_given_because) {
                    (true, _) => "navigated with it, above (--keep-given-arm: with the given one)".to_string(),
                    (false, Some(why)) => format!("navigated with it, but kept the given one: {why}"),
                    (false, None) => "navigate with --estimate-lever-arm".to_string(),
                }
            ),
            (Some(e), false) => format!(
                "antenna lever arm: the fixes' NIS puts it where given ({}): not the arm\n",
                arm(e.given_b_m)
            ),
            (None, _) => format!(
                "antenna lever arm: not estimated: {}\n",
                self.error.as_deref().unwrap_or("unknown")
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed-form NIS: `n` fixes' worth, a bowl `(l - t)ᵀ A (l - t)`
    /// about `t`.
    fn bowl(a: [[f64; 3]; 3], t: [f64; 3]) -> impl FnMut(&[f64; 3]) -> Result<FixesNis> {
        let n = 1000.0;
        move |l: &[f64; 3]| {
            let d: [f64; 3] = std::array::from_fn(|i| l[i] - t[i]);
            let q: f64 = (0..3)
                .flat_map(|i| (0..3).map(move |j| (i, j)))
                .map(|(i, j)| d[i] * a[i][j] * d[j])
                .sum();
            Ok(FixesNis {
                total: n + q,
                per_dof: (n + q) / n,
                each: vec![],
            })
        }
    }

    #[test]
    fn a_coupled_bowl_s_least_is_found_with_its_sigmas() {
        // x and z coupled (a height the forward axis trades against): the
        // passes are a coordinate descent, and each axis's least given
        // the others is the bowl's closed form. x's moves 0.20 m between
        // its passes and z's 0.15 m: beyond the fine grid's 0.10 m, which
        // left both unresolved before the fine search followed its edge.
        // Two passes end 3 of x's sigmas short of the least, which the
        // Newton steps close.
        let a = [[400.0, 0.0, 300.0], [0.0, 200.0, 0.0], [300.0, 0.0, 400.0]];
        let t = [0.5, 0.3, -0.6];
        let det = a[0][0] * a[2][2] - a[0][2] * a[2][0];
        let var = [a[2][2] / det, 1.0 / a[1][1], a[0][0] / det];
        let cond = |i: usize, j: usize, l: &[f64; 3]| t[i] - a[i][j] * (l[j] - t[j]) / a[i][i];
        let mut l = [0.0; 3];
        let mut moved = [0.0_f64; 3];
        for pass in 0..2 {
            let before = l;
            l[0] = cond(0, 2, &l);
            l[1] = t[1];
            l[2] = cond(2, 0, &l);
            if pass == 1 {
                moved = std::array::from_fn(|i| (l[i] - before[i]).abs());
            }
        }
        assert!(
            moved[0] > 5.0 * FINE_M && moved[2] > 5.0 * FINE_M,
            "{moved:?}"
        );
        assert!((l[0] - t[0]).abs() > 3.0 * var[0].sqrt(), "{l:?}");
        let e = search([0.0; 3], &mut bowl(a, t), &mut |_| {}).unwrap();
        // Newton's step on a quadratic is its least, and the stencil's
        // differences are exact on it: to rounding.
        for (i, (b, t)) in e.b_m.iter().zip(t).enumerate() {
            assert!((b - t).abs() < 1e-9, "{i}: {:?}", e.b_m);
        }
        // Every axis resolved, its sigma the bowl's: 2 H^-1 with H = 2 A,
        // and the NIS per degree of freedom at the least is 1.
        for (i, (s, v)) in e.sigma_m.iter().zip(var).enumerate() {
            let s = s.unwrap_or(f64::NAN);
            assert!((s / v.sqrt() - 1.0).abs() < 1e-6, "{i}: {s}");
        }
    }
}
