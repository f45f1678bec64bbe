//! The ride's vertical noise, learnt from the fixes before the run that
//! uses it (`navigate --gnss`, on unless `--vertical-noise file`).
//!
//! A local-level filter's horizontal channel has a partner for a force
//! error it does not model: the tilt, which the fixes set so that the two
//! cancel, and an outage starts from that balance. The vertical channel
//! has none but the accelerometer's bias, whose model (a sensor file's
//! instability and warm-up) is far slower than what a hand, a road or a
//! roof does to the vertical force. On the real walk (the book: Aided
//! navigation, the height in the outages) the heights at the ends of
//! outages were many times their stated sigma off, the sign changing
//! from one start to the next, and an independent filter drifted alike:
//! an error of the ride, not of the integration.
//!
//! The model is a vertical velocity random walk of the ride, `q` (m/s per
//! sqrt(s)), added to the filter's vertical velocity error: over an
//! outage of `T` s it adds `q^2 T^3 / 3` to the height's variance (the
//! walk's heights grew about so from 10 s to 20 s). `q^2` is found by
//! covariance matching (Mehra 1972) over shadows: every
//! [`SPACING_S`] while fixes arrive a copy of the navigator goes on
//! without fixes for [`HORIZON_S`]; at its end its height less the aided
//! navigator's is its return `e`, whose variance the two filters predict
//! as `v` (the shadow's height variance plus the aided one's). First
//! the sensor file's model is tested: the returns' score against it
//! (`sum (e^2 - v) / v^2` over its chi-square sigma) more than
//! [`SIGNIFICANT`] sigmas refutes it; then `q^2` is the density whose
//! own returns show nothing above it ([`learn`]). The returns are taken
//! over the whole recording in passes before the run (the host has it
//! all; the outages cut in are outages there too), so the first outage
//! has it. A shadow whose span held a zero-velocity update is not free
//! and is dropped.

use super::pipeline::{self, Aid, StepView};
use super::{AidedOptions, AidedRun, HostNav};
use anyhow::Result;
use core_nav::eskf::{I_P, I_V};
use core_nav::real::Real;
use recording::Recording;
use serde::Serialize;

/// A shadow's run without fixes, s (the shortest outage the book's tables
/// cut).
pub const HORIZON_S: f64 = 10.0;
/// A new shadow every this many seconds while fixes arrive, s (two run at
/// once: neighbours share half their span, counted in the spread).
pub const SPACING_S: f64 = 5.0;
/// The sensor file's model is refuted when the returns' score against
/// it is this many of its sigmas above 0 (one-sided).
pub const SIGNIFICANT: f64 = 3.0;
/// The aided navigator's last fix at a return at most this old, s (else
/// its own height is not the reference the return needs).
const FIX_AGE_MAX_S: f64 = 1.0;
/// The least returns to learn from.
pub const MIN_RETURNS: u32 = 4;

/// What the first pass found, and whether the run used it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct VerticalReport {
    /// Shadow returns seen.
    pub returns: u32,
    /// Their median height error (its size), m.
    pub median_return_m: f64,
    /// The median height sigma predicted for them, m (the pass's own
    /// noise: the sensor file's in the first).
    pub median_predicted_m: f64,
    /// The vertical velocity random walk found, m/s/sqrt(s) (`None`: too
    /// few returns).
    pub q_mps_rts: Option<f64>,
    /// Its 1-sigma, m/s/sqrt(s) (of `q^2`, carried to `q`).
    pub q_sigma_mps_rts: Option<f64>,
    /// The returns' score against the sensor file's model (the first
    /// pass's), in its sigmas (`None`: too few returns).
    pub file_refuted_sigmas: Option<f64>,
    /// The run used it (the file's model refuted).
    pub used: bool,
    /// The sensor file's accelerometer white noise, m/s/sqrt(s), to say
    /// how far above it the ride is.
    pub file_vrw_mps_rts: f64,
}

impl VerticalReport {
    /// The variance density the run adds to the vertical velocity,
    /// (m/s)^2/s (0 when not used).
    pub fn q2_used(&self) -> f64 {
        match (self.used, self.q_mps_rts) {
            (true, Some(q)) => q * q,
            _ => 0.0,
        }
    }

    /// For a person: one line.
    pub fn text(&self) -> String {
        let n = self.returns;
        let (Some(q), Some(s)) = (self.q_mps_rts, self.q_sigma_mps_rts) else {
            return format!(
                "vertical ride noise: not learnt ({n} {HORIZON_S:.0}-s shadow returns, {MIN_RETURNS} needed): the height's sigma is the sensor file's\n"
            );
        };
        let seen = format!(
            "{n} {HORIZON_S:.0}-s shadow returns ended a median {:.2} m off in height against a predicted {:.2} m",
            self.median_return_m, self.median_predicted_m
        );
        if self.used {
            format!(
                "vertical ride noise learnt from the fixes: {seen} (the sensor file's noise refuted by {:.0} sigmas); a vertical velocity random walk of {q:.3} +- {s:.3} m/s/sqrt(s) ({:.0}x the file's accelerometer white noise) added in the run, outages included\n",
                self.file_refuted_sigmas.unwrap_or(0.0),
                q / self.file_vrw_mps_rts.max(f64::MIN_POSITIVE)
            )
        } else {
            format!(
                "vertical ride noise: {seen}; nothing added (the sensor file's noise not refuted: {:.1} sigmas, {SIGNIFICANT:.0} needed)\n",
                self.file_refuted_sigmas.unwrap_or(0.0)
            )
        }
    }
}

/// A shadow: its start time and the navigator going on without fixes.
struct Shadow<T: Real> {
    t0_s: f64,
    nav: Box<HostNav<T>>,
}

/// One return: its error (m), the predicted variance (m^2), its span (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Return {
    /// The shadow's height less the aided navigator's, m.
    pub e_m: f64,
    /// The variance the two filters predict for it, m^2.
    pub v_m2: f64,
    /// The shadow's span, s.
    pub t_s: f64,
}

/// The first pass's aid: shadows and their returns.
pub struct VerticalLearner<T: Real> {
    /// The density the pass adds (to the aided navigator and its
    /// shadows alike), (m/s)^2/s.
    q2: f64,
    add: AddNoise,
    shadows: Vec<Shadow<T>>,
    last_start_s: f64,
    last_fix_s: f64,
    returns: Vec<Return>,
    file_vrw: f64,
}

impl<T: Real> VerticalLearner<T> {
    /// No shadow yet; the pass adds `q2` ((m/s)^2/s); `file_vrw` the
    /// sensor file's accelerometer white noise, m/s/sqrt(s).
    pub fn new(q2: f64, file_vrw: f64) -> Self {
        Self {
            q2,
            add: AddNoise::default(),
            shadows: vec![],
            last_start_s: f64::NEG_INFINITY,
            last_fix_s: f64::NEG_INFINITY,
            returns: vec![],
            file_vrw,
        }
    }
}

/// The height (down, m) and its variance (m^2) of a navigator.
fn height<T: Real>(an: &HostNav<T>) -> (f64, f64) {
    let s = an.kf.sigma(I_P + 2).to_f64();
    (an.nav().state().p_n.z.to_f64(), s * s)
}

impl<T: Real> Aid<T> for VerticalLearner<T> {
    fn after_step(&mut self, an: &mut HostNav<T>, at: &StepView<'_, T>) {
        let dt = self.add.dt(at.t_s);
        add_vertical(an, self.q2 * dt);
        if at.step.fix.is_some() {
            self.last_fix_s = at.t_s;
        }
        let (h_main, v_main) = height(an);
        let fresh = at.t_s - self.last_fix_s <= FIX_AGE_MAX_S;
        let mut kept = Vec::with_capacity(self.shadows.len());
        for mut sh in self.shadows.drain(..) {
            let Ok(st) = sh.nav.step(at.sample, at.table, at.table_rate) else {
                continue;
            };
            if st.zupt {
                continue;
            }
            add_vertical(&mut sh.nav, self.q2 * dt);
            let span = at.t_s - sh.t0_s;
            if span < HORIZON_S {
                kept.push(sh);
            } else if fresh {
                let (h, v) = height(&sh.nav);
                self.returns.push(Return {
                    e_m: h - h_main,
                    v_m2: v + v_main,
                    t_s: span,
                });
            }
        }
        self.shadows = kept;
        if at.step.fix.is_some() && at.t_s - self.last_start_s >= SPACING_S {
            self.last_start_s = at.t_s;
            self.shadows.push(Shadow {
                t0_s: at.t_s,
                nav: Box::new(an.clone()),
            });
        }
    }

    fn report(self: Box<Self>, run: &mut AidedRun) {
        run.vertical = Some(learnt(&self.returns, self.q2, self.file_vrw));
    }
}

/// `q^2` and its sigma from `returns` (module docs): `None` with fewer
/// than [`MIN_RETURNS`]. Each return's square has mean `s^2 = v + q^2 g`
/// (`g = T^3 / 3`) and, Gaussian, variance `2 s^4`: weighted by `g / s^4`
/// (the least-variance weights; a shadow started while the filter still
/// knew little of its height says little), iterated from `q^2 = 0`.
pub fn q2_of(returns: &[Return]) -> Option<(f64, f64)> {
    if returns.len() < MIN_RETURNS as usize {
        return None;
    }
    let g = |r: &Return| r.t_s.powi(3) / 3.0;
    let mut q2 = 0.0_f64;
    let mut info = 0.0;
    for _ in 0..4 {
        let (mut num, mut den) = (0.0, 0.0);
        for r in returns {
            let s2 = r.v_m2 + q2.max(0.0) * g(r);
            let w = g(r) / (s2 * s2);
            num += w * (r.e_m * r.e_m - r.v_m2);
            den += w * g(r);
        }
        if den <= 0.0 || !den.is_finite() {
            return None;
        }
        q2 = num / den;
        info = den;
    }
    // var(q^2) = 2 / sum(g^2 / s^4); neighbours share half their span
    // (SPACING_S = HORIZON_S / 2): half as many independent returns.
    let sigma = (2.0 * 2.0 / info).sqrt();
    Some((q2, sigma))
}

/// The returns' score against the model that predicted them (`v`
/// alone): `sum (g / v^2) (e^2 - v)` over its sigma under that model
/// (`e^2` of variance `2 v^2`; neighbours half independent), one-sided.
/// `None` with fewer than [`MIN_RETURNS`].
pub fn score_sigmas(returns: &[Return]) -> Option<f64> {
    if returns.len() < MIN_RETURNS as usize {
        return None;
    }
    let g = |r: &Return| r.t_s.powi(3) / 3.0;
    let (mut num, mut var) = (0.0, 0.0);
    for r in returns.iter().filter(|r| r.v_m2 > 0.0) {
        let w = g(r) / (r.v_m2 * r.v_m2);
        num += w * (r.e_m * r.e_m - r.v_m2);
        var += 2.0 * 2.0 * w * w * r.v_m2 * r.v_m2;
    }
    (var > 0.0).then(|| num / var.sqrt())
}

/// The report of `returns` of a pass that added `q2_applied`, against
/// the file's white noise `file_vrw`: the density is the applied one
/// plus what the returns show above it; used when the returns refute the
/// model they were predicted with.
pub fn learnt(returns: &[Return], q2_applied: f64, file_vrw: f64) -> VerticalReport {
    let median = |f: &dyn Fn(&Return) -> f64| {
        core_nav::stats::median(&mut returns.iter().map(f).collect::<Vec<f64>>())
    };
    let mut r = VerticalReport {
        returns: returns.len() as u32,
        median_return_m: median(&|r| r.e_m.abs()),
        median_predicted_m: median(&|r| r.v_m2.sqrt()),
        file_vrw_mps_rts: file_vrw,
        file_refuted_sigmas: score_sigmas(returns),
        ..VerticalReport::default()
    };
    if let Some((dq2, s)) = q2_of(returns) {
        let q2 = q2_applied + dq2;
        let q = q2.max(0.0).sqrt();
        r.q_mps_rts = Some(q);
        // d q = d q^2 / (2 q); at q = 0 the sigma of q^2's square root.
        r.q_sigma_mps_rts = Some(if q > 0.0 { s / (2.0 * q) } else { s.sqrt() });
        r.used = r.file_refuted_sigmas.is_some_and(|z| z > SIGNIFICANT) && q2 > 0.0;
    }
    r
}

/// The second pass's aid: the learnt density added to the vertical
/// velocity's variance after every step.
pub struct VerticalNoise {
    q2: f64,
    add: AddNoise,
    report: VerticalReport,
}

/// The time since the last step, s (0 at the first).
#[derive(Clone, Copy, Debug, Default)]
struct AddNoise {
    last_s: Option<f64>,
}

impl AddNoise {
    fn dt(&mut self, t_s: f64) -> f64 {
        let dt = self.last_s.map_or(0.0, |l| (t_s - l).max(0.0));
        self.last_s = Some(t_s);
        dt
    }
}

/// `var_m2s2` ((m/s)^2) added to `an`'s vertical velocity variance.
fn add_vertical<T: Real>(an: &mut HostNav<T>, var_m2s2: f64) {
    if let Some(p) = an.kf.p.get_mut((I_V + 2, I_V + 2)) {
        *p += T::lit(var_m2s2);
    }
}

impl VerticalNoise {
    /// Adding `report`'s density (nothing when it was not used).
    pub fn new(report: VerticalReport) -> Self {
        Self {
            q2: report.q2_used(),
            add: AddNoise::default(),
            report,
        }
    }
}

impl<T: Real> Aid<T> for VerticalNoise {
    fn after_step(&mut self, an: &mut HostNav<T>, at: &StepView<'_, T>) {
        let dt = self.add.dt(at.t_s);
        add_vertical(an, self.q2 * dt);
    }

    fn report(self: Box<Self>, run: &mut AidedRun) {
        run.vertical = Some(self.report);
    }
}

/// The passes before the run over `rec` with `opt` (its outages kept):
/// the first adds nothing. A filter given more vertical noise weighs the
/// fixes' heights more and comes out of an outage with a better height
/// (the first pass's shadows started just after an outage carry its
/// overconfident height), so the returns shrink as the density grows:
/// the density sought is the one whose own returns show nothing above
/// it. Between none and the first pass's estimate, the passes bisect (in
/// log, [`PASSES`] in all) for where what the returns show above the
/// density added changes sign. `progress` gets the share done.
///
/// # Errors
/// What [`pipeline::start`] refuses.
pub fn learn<T: Real>(
    rec: &Recording,
    opt: &AidedOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<VerticalReport> {
    let first = AidedOptions {
        vertical_learn: false,
        ..opt.clone()
    };
    let mut done = 0.0;
    let mut pass = |q2: f64| -> Result<VerticalReport> {
        let run = pipeline::run_with::<T>(
            rec,
            &first,
            &mut |f| progress((done + f) / PASSES as f64),
            |an| {
                vec![Box::new(VerticalLearner::<T>::new(
                    q2,
                    an.kf.config().accel_vrw,
                ))]
            },
        )?;
        done += 1.0;
        Ok(run.vertical.unwrap_or_default())
    };
    let r = pass(0.0)?;
    if !r.used {
        return Ok(r);
    }
    // ln q^2 between the first estimate's and a hundredth of it.
    let (mut hi, mut lo) = (r.q2_used().ln(), (r.q2_used() / 100.0).ln());
    let mut last = None;
    for _ in 1..PASSES {
        let mid = 0.5 * (hi + lo);
        let r = pass(mid.exp())?;
        // The returns' score against what this pass added: above 0,
        // more is needed.
        match r.file_refuted_sigmas {
            Some(z) if z > 0.0 => lo = mid,
            Some(_) => hi = mid,
            None => break,
        }
        last = Some((r, mid.exp()));
    }
    Ok(match last {
        Some((last, q2)) => settled(last, q2, &r),
        None => r,
    })
}

/// The passes [`learn`] makes at most.
pub const PASSES: usize = 6;

/// `last` (a pass's report) with the density settled on, `q2`, used as
/// the first pass (`first`, against the sensor file's model) decided.
fn settled(last: VerticalReport, q2: f64, first: &VerticalReport) -> VerticalReport {
    let q = q2.max(0.0).sqrt();
    let sigma_q2 = match (last.q_mps_rts, last.q_sigma_mps_rts) {
        (Some(a), Some(s)) if a > 0.0 => 2.0 * a * s,
        (_, Some(s)) => s * s,
        _ => f64::INFINITY,
    };
    VerticalReport {
        q_mps_rts: Some(q),
        q_sigma_mps_rts: Some(if q > 0.0 {
            sigma_q2 / (2.0 * q)
        } else {
            sigma_q2.sqrt()
        }),
        used: first.used,
        file_refuted_sigmas: first.file_refuted_sigmas,
        ..last
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn returns(e: f64, v: f64, n: usize) -> Vec<Return> {
        (0..n)
            .map(|k| Return {
                e_m: if k % 2 == 0 { e } else { -e },
                v_m2: v,
                t_s: HORIZON_S,
            })
            .collect()
    }

    #[test]
    fn q2_is_the_excess_over_the_growth_of_a_random_walk() {
        // 20 returns 1 m off, 0.01 m^2 predicted: equal weights, q^2 =
        // (1 - 0.01) / (1000 / 3).
        let (q2, s) = q2_of(&returns(1.0, 0.01, 20)).unwrap();
        assert!((q2 - 0.99 * 3.0 / 1000.0).abs() < 1e-12);
        // sigma: s^2 = 1 m^2, sqrt(2 * 2 / (20 g^2)), g = 1000 / 3.
        assert!((s - (4.0_f64 / 20.0).sqrt() / (1000.0 / 3.0)).abs() < 1e-12);
        // A return whose predicted variance is a hundred times its
        // neighbours' barely moves it.
        let mut rs = returns(1.0, 0.01, 20);
        rs.push(Return {
            e_m: 10.0,
            v_m2: 100.0,
            t_s: HORIZON_S,
        });
        let (q2b, _) = q2_of(&rs).unwrap();
        assert!((q2b / q2 - 1.0).abs() < 0.01, "{q2b} vs {q2}");
        let r = learnt(&returns(1.0, 0.01, 20), 0.0, 7e-4);
        assert!(r.used);
        // As predicted: nothing added.
        let r = learnt(&returns(0.1, 0.01, 20), 0.0, 7e-4);
        assert!(!r.used && r.q2_used() == 0.0);
        // Too few.
        assert_eq!(q2_of(&returns(1.0, 0.01, 3)), None);
    }
}
