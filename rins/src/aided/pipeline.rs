//! One run of `navigate --gnss` as a pipeline, data flowing one way:
//! [`start`] (the recording checked, the fixes prepared, the start
//! attitude, the navigator built), then per IMU sample the fixes due
//! handed over ([`FixFeed`]), the navigator's step, each [`Aid`] after it
//! (the vehicle's constraints, the learnt noise: each with one
//! interface), the filter's solution as an output row ([`solution_row`])
//! and, against a truth, the NEES ([`nees_against`]); at the end each
//! aid's report into the run.

use super::{
    aided_config, align, gnss_corr_sigma, learn, lever_b_m, prepared_fixes, vehicle, AidedOptions,
    AidedRow, AidedRun, INITIAL_SIGMA,
};
use crate::aided::{HostNav, HOST_M};
use crate::nav::TrajRow;
use anyhow::{bail, Result};
use core_nav::aided::{AidedStep, GnssFix, OriginE7};
use core_nav::attitude::{euler_to_quat, quat_to_dcm, Euler};
use core_nav::earth::{LocalEarth, Tangent};
use core_nav::eskf::{Eskf, InitialSigma, I_P, I_PHI, I_V};
use core_nav::real::Real;
use core_nav::strapdown::ImuSample;
use core_nav::table::TableAngle;
use nalgebra::{Matrix3, Quaternion, Vector3};
use recording::moving::{GnssRow, TruthRow};
use recording::track::EncoderTrack;
use recording::Recording;

/// What an aid sees after the navigator's step at one sample.
pub struct StepView<'a, T: Real> {
    /// The sample's time, s.
    pub t_s: f64,
    /// The sample (raw, as the navigator took it).
    pub sample: &'a ImuSample<T>,
    /// The table's angle there.
    pub table: &'a TableAngle<T>,
    /// The table's rate there, rad/s.
    pub table_rate: T,
    /// The fix handed over before this step, if any, and its time of
    /// validity on the mechanization's clock (µs).
    pub handed: Option<&'a (GnssFix, u64)>,
    /// What the step did.
    pub step: &'a AidedStep<T>,
    /// A fix was used within the last two seconds.
    pub aided: bool,
}

/// An aid made between the navigator's steps: its own updates, its own
/// report.
pub trait Aid<T: Real> {
    /// After the navigator's step (`at`): its updates on `an`.
    fn after_step(&mut self, an: &mut HostNav<T>, at: &StepView<'_, T>);
    /// What it did, into the run.
    fn report(self: Box<Self>, run: &mut AidedRun);
}

impl<T: Real> Aid<T> for vehicle::VehicleAid {
    fn after_step(&mut self, an: &mut HostNav<T>, at: &StepView<'_, T>) {
        vehicle::VehicleAid::after_step(self, an, at.t_s, at.table, at.aided);
    }
    fn report(self: Box<Self>, run: &mut AidedRun) {
        run.vehicle = Some(self.report);
    }
}

impl<T: Real> Aid<T> for learn::NoiseLearner<T> {
    fn after_step(&mut self, an: &mut HostNav<T>, at: &StepView<'_, T>) {
        learn::NoiseLearner::after_step(
            self,
            an,
            at.t_s,
            at.sample,
            at.table,
            at.table_rate,
            at.handed,
        );
    }
    fn report(self: Box<Self>, run: &mut AidedRun) {
        run.learnt = Some(self.report);
    }
}

/// The run's fixed inputs, made once by [`start`].
pub struct Inputs<'a> {
    rec: &'a Recording,
    track: EncoderTrack,
    to_us: Box<dyn Fn(f64) -> u64>,
    /// The fixes the filter gets ([`prepared_fixes`]).
    pub fixes: Vec<GnssRow>,
    truth: &'a [TruthRow],
}

impl Inputs<'_> {
    /// Sample `k` as the navigator takes it.
    fn sample<T: Real>(&self, k: usize) -> Option<ImuSample<T>> {
        let r = self.rec.imu.get(k)?;
        Some(ImuSample::<T> {
            t_us: (self.to_us)(r.t_s),
            w_is_s: Vector3::from(r.gyro_radps).map(T::lit),
            f_s: Vector3::from(r.accel_mps2).map(T::lit),
        })
    }

    /// The table's angle at `t_s`.
    fn table<T: Real>(&self, t_s: f64) -> TableAngle<T> {
        TableAngle::<T>::from_rad_f64(self.track.angle(t_s))
    }
}

/// The recording checked, its fixes prepared, the start attitude (given
/// or aligned), the navigator built (moving at the start when the fixes
/// say so) and the run begun.
///
/// # Errors
/// Not a moving-base recording, no `gnss.csv`, too few samples, an
/// alignment or a start the mechanization refuses.
pub fn start<'a, T: Real>(
    rec: &'a Recording,
    opt: &AidedOptions,
) -> Result<(HostNav<T>, AidedRun, Inputs<'a>)> {
    let m = &rec.meta;
    let Some(mv) = &rec.moving else {
        bail!("not a moving-base recording ([base] moving = true in meta.toml): --gnss needs one")
    };
    let Some(fixes) = &mv.gnss else {
        bail!("gnss.csv is missing: --gnss needs the receiver's fixes")
    };
    if rec.table.len() < 3 || rec.imu.len() < 2 {
        bail!("the recording has too few IMU samples or encoder reads");
    }
    let input = Inputs {
        rec,
        track: EncoderTrack::of(rec),
        to_us: Box::new(crate::nav::clock_us(m)),
        fixes: prepared_fixes(fixes, opt),
        truth: mv.truth.as_deref().unwrap_or(&[]),
    };
    let (euler, initial, start, aligned) = start_attitude(rec, &input.fixes)?;
    let lever_b = lever_b_m(rec, opt);
    let origin = OriginE7::from_deg(m.latitude_deg, mv.longitude_deg, m.height_m);
    let moving = align::moving_start(&input.fixes, origin.point());
    let mut cfg = aided_config(
        m.axis,
        lever_b,
        opt,
        m.imu_rate_hz,
        input.track.read_sigma_rad(),
    );
    // The zero-velocity detector learns its threshold from a still start:
    // a car already moving has none (uniform motion reads as stillness).
    cfg.zupt &= moving.is_none();
    cfg.initial = initial;
    cfg.eskf.gnss_corr_sigma_m = gnss_corr_sigma(&input.fixes);
    cfg.receiver_from_fixes = false;
    // The navigator looks back at most its stored states, less the two a
    // fix between samples may need.
    let stored_s = (core_nav::aided::HISTORY - 2) as f64 / m.imu_rate_hz;
    let velocity_lag = super::fixvel::velocity_lag(&input.fixes, stored_s);
    cfg.velocity_lag_s = velocity_lag.map_or([0.0; 2], |l| l.taken_s());
    let q_b_n0 = Quaternion::from(euler_to_quat(&euler).coords.map(T::lit));
    let t0 = rec.imu.first().map_or(0.0, |r| r.t_s);
    let Some(first) = input.sample::<T>(0) else {
        bail!("the recording has no IMU sample");
    };
    let mut an = HostNav::<T>::new(
        crate::nav::strapdown_config(m, false),
        origin,
        &q_b_n0,
        &input.table(t0),
        &first,
        cfg,
    )
    .map_err(|e| anyhow::anyhow!("cannot start navigation: {e}"))?;
    if let Some(ms) = &moving {
        an.start_moving(&Vector3::from(ms.v_n_mps).map(T::lit), T::lit(ms.sigma_mps));
    }
    let run = AidedRun {
        aligned,
        start,
        moving_start: moving,
        time_offset_s: opt.time_offset_s,
        process_noise: an.kf.config().into(),
        outages_cut: opt.outages.clone(),
        velocity_lag,
        ..AidedRun::default()
    };
    Ok((an, run, input))
}

/// The start attitude: meta.toml's (with its stated 1-sigmas where it
/// states them, else [`INITIAL_SIGMA`]'s), or aligned on the fixes when
/// its heading is unknown; the filter's initial sigmas with it.
fn start_attitude(
    rec: &Recording,
    fixes: &[GnssRow],
) -> Result<(
    Euler<f64>,
    InitialSigma,
    StartAttitude,
    Option<align::Alignment>,
)> {
    let m = &rec.meta;
    if !rec.moving.as_ref().is_some_and(|mv| mv.heading_unknown) {
        let e = Euler::<f64>::from_deg(m.roll_deg, m.pitch_deg, m.heading_deg);
        let stated = |s: Option<f64>, assumed: f64| {
            s.map_or(assumed, |d| d.to_radians().max(STATED_SIGMA_FLOOR_RAD))
        };
        let initial = InitialSigma {
            level_rad: stated(m.level_sigma_deg, INITIAL_SIGMA.level_rad),
            heading_rad: stated(m.heading_sigma_deg, INITIAL_SIGMA.heading_rad),
            ..INITIAL_SIGMA
        };
        let from = StartAttitude {
            level_stated: m.level_sigma_deg.is_some(),
            heading_stated: m.heading_sigma_deg.is_some(),
            ..StartAttitude::of("meta.toml", &initial)
        };
        return Ok((e, initial, from, None));
    }
    let a = align::align(rec, fixes, m.site().gravity_mps2)?;
    let [roll, pitch, heading] = a.euler_rad;
    let initial = InitialSigma {
        level_rad: a.level_sigma_rad,
        heading_rad: a
            .heading_sigma_rad
            .max(align::START_HEADING_SIGMA_DEG.to_radians()),
        ..INITIAL_SIGMA
    };
    let e = Euler {
        roll,
        pitch,
        heading,
    };
    let from = StartAttitude {
        heading_fit_sigma_deg: Some(a.heading_sigma_rad.to_degrees()),
        ..StartAttitude::of("aligned", &initial)
    };
    Ok((e, initial, from, Some(a)))
}

/// The least start sigma a stated one is taken as, rad (a stated 0 would
/// make the attitude's covariance singular).
const STATED_SIGMA_FLOOR_RAD: f64 = 1e-6;

/// Where the start attitude and its 1-sigmas came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StartAttitude {
    /// `"meta.toml"` or `"aligned"` (on the still start and the fixes).
    pub from: &'static str,
    /// Roll's and pitch's 1-sigma the filter started with, deg.
    pub level_sigma_deg: f64,
    /// Heading's, deg.
    pub heading_sigma_deg: f64,
    /// meta.toml states the level's sigma (else assumed, or aligned's).
    pub level_stated: bool,
    /// meta.toml states the heading's sigma.
    pub heading_stated: bool,
    /// An aligned start: the heading fit's own 1-sigma, deg (the filter
    /// starts wider, `align::START_HEADING_SIGMA_DEG`).
    pub heading_fit_sigma_deg: Option<f64>,
}

impl StartAttitude {
    fn of(from: &'static str, s: &InitialSigma) -> Self {
        Self {
            from,
            level_sigma_deg: s.level_rad.to_degrees(),
            heading_sigma_deg: s.heading_rad.to_degrees(),
            level_stated: false,
            heading_stated: false,
            heading_fit_sigma_deg: None,
        }
    }

    /// For a person: one line.
    pub fn text(&self) -> String {
        let how = |stated: bool| match (self.from, stated) {
            ("meta.toml", true) => " (stated)",
            ("meta.toml", false) => " (assumed: meta.toml states none)",
            _ => "",
        };
        let from = match self.from {
            "meta.toml" => "meta.toml's",
            _ => "aligned on the still start and the fixes",
        };
        let fit = self.heading_fit_sigma_deg.map_or(String::new(), |f| {
            format!(
                " (the fit's {} deg: its fixes enter the filter again)",
                recording::figures::sig(f, 2)
            )
        });
        format!(
            "start attitude: {from}, 1-sigma level {} deg{}, heading {} deg{}{fit}\n",
            recording::figures::sig(self.level_sigma_deg, 2),
            how(self.level_stated),
            recording::figures::sig(self.heading_sigma_deg, 2),
            how(self.heading_stated),
        )
    }
}

/// The aids `opt` asks for, in the order they act after each step.
pub fn aids<T: Real>(rec: &Recording, opt: &AidedOptions, an: &HostNav<T>) -> Vec<Box<dyn Aid<T>>> {
    let mut aids: Vec<Box<dyn Aid<T>>> = vec![];
    if opt.vehicle.is_some() {
        let odometer = rec
            .moving
            .as_ref()
            .and_then(|m| m.odometer.clone())
            .unwrap_or_default();
        aids.push(Box::new(vehicle::VehicleAid::new(odometer)));
    }
    if opt.learn_noise {
        aids.push(Box::new(learn::NoiseLearner::<T>::new(*an.kf.config())));
    }
    aids
}

/// Hands the navigator the fixes due before a step: those up to its
/// sample's time, each with its own time of validity (a logger's samples
/// need not be evenly spaced, nor its fixes fall on them).
pub struct FixFeed {
    next: usize,
}

impl FixFeed {
    /// At the first fix.
    pub fn new() -> Self {
        Self { next: 0 }
    }

    /// The fixes of `fixes` up to `upto_s` into `an` (none before the
    /// run's first step, `first`: counted refused in `run`), each valid
    /// at its own time on the mechanization's clock (`to_us`, from s); the
    /// last one handed.
    pub fn before_step<T: Real>(
        &mut self,
        an: &mut HostNav<T>,
        fixes: &[GnssRow],
        upto_s: f64,
        first: bool,
        run: &mut AidedRun,
        to_us: &dyn Fn(f64) -> u64,
    ) -> Option<(GnssFix, u64)> {
        let mut handed = None;
        while let Some(f) = fixes.get(self.next).filter(|f| f.t_s <= upto_s) {
            self.next += 1;
            if first {
                run.refused += 1;
                continue;
            }
            let (fix, t_us) = (f.to_fix(), to_us(f.t_s));
            hand_over(an, &fix, t_us);
            handed = Some((fix, t_us));
        }
        handed
    }
}

/// Hands `fix` to `an` at its own time `t_us` (µs): the navigator
/// carries the stored state nearest it there. A time it cannot hold (the
/// first steps of a run, before it has a sample interval; a sample's
/// jitter of a microsecond past the next one): at the step, as it is.
pub fn hand_over<T: Real>(an: &mut HostNav<T>, fix: &GnssFix, t_us: u64) {
    if an.gnss_at(fix, t_us).is_err() {
        an.gnss(fix);
    }
}

impl Default for FixFeed {
    fn default() -> Self {
        Self::new()
    }
}

/// The filter's own solution (the board sends the same) as an output row
/// on the tangent plane, with the attitude's DCM (`b` to `n`).
pub fn solution_row<T: Real>(
    an: &HostNav<T>,
    table: &TableAngle<T>,
    step: &AidedStep<T>,
    t_s: f64,
    earth: &LocalEarth<T>,
    tangent: &Tangent,
) -> (AidedRow, Matrix3<f64>) {
    let sol = an.solution(table);
    let c_b_n = quat_to_dcm(&sol.q_b_n).map(|x| x.to_f64());
    let ned = tangent.ned_to(&earth.point_at(&sol.p_n));
    let v_n = sol.v_n.map(|x| x.to_f64());
    let f64s = |a: [T; 3]| a.map(|x| x.to_f64());
    let [roll, pitch, heading] =
        [sol.euler.roll, sol.euler.pitch, sol.euler.heading].map(|x| x.to_f64().to_degrees());
    let row = AidedRow {
        traj: TrajRow {
            t_s,
            ned_m: [ned.x, ned.y, ned.z],
            v_mps: [v_n.x, v_n.y, v_n.z],
            rph_deg: [roll, pitch, heading.rem_euclid(360.0)],
            faults: an.counts.steps_refused,
        },
        sigma_p_m: f64s(sol.sigma_p_m),
        sigma_v_mps: f64s(sol.sigma_v_mps),
        sigma_att_deg: f64s(sol.sigma_euler_rad).map(f64::to_degrees),
        fix: step.fix.is_some(),
        fix_taken: step.fix_horizontal_taken,
        still: step.still,
        zupt: step.zupt,
        gyro_bias_radps: f64s(an.kf.bias_g.into()),
        accel_bias_mps2: f64s(an.kf.bias_a.into()),
    };
    (row, c_b_n)
}

/// What the estimated clock's and arm's errors (their covariance, the
/// offset s then the arm in `b` m: [`AidedOptions::consider`]) move the
/// IMU's position by, NED, m^2: `J P Jᵀ` with `J = [v_n, C_b^n]` (a fix
/// compared with the track `dt` late, the antenna `dl` off, puts the IMU
/// `v_n dt + C_b^n dl` off), `J` taken at the last fix the run took and
/// frozen through an outage (the error it left then is what the run
/// carries).
pub struct Consider {
    cov: nalgebra::Matrix4<f64>,
    j: Option<nalgebra::Matrix3x4<f64>>,
}

impl Consider {
    /// For the covariance `cov` (the offset, then the arm).
    pub fn new(cov: [[f64; 4]; 4]) -> Self {
        Self {
            cov: nalgebra::Matrix4::from_fn(|r, c| cov[r][c]),
            j: None,
        }
    }

    /// `row`'s position sigmas widened by the considered covariance, which
    /// is returned (NED, m^2); `c_b_n` is the row's attitude.
    pub fn add(&mut self, row: &mut AidedRow, c_b_n: &Matrix3<f64>) -> Matrix3<f64> {
        if row.fix || self.j.is_none() {
            let mut j = nalgebra::Matrix3x4::zeros();
            j.set_column(0, &nalgebra::Vector3::from(row.traj.v_mps));
            j.fixed_view_mut::<3, 3>(0, 1).copy_from(c_b_n);
            self.j = Some(j);
        }
        let e = self
            .j
            .map_or(Matrix3::zeros(), |j| j * self.cov * j.transpose());
        for (i, s) in row.sigma_p_m.iter_mut().enumerate() {
            *s = (*s * *s + e[(i, i)]).sqrt();
        }
        e
    }
}

/// The NEES of `row` (attitude `c_b_n`) against the truth `tr` over every
/// state the trajectory reports but height (north, east, the three
/// velocities, the attitude's rotation error `phi` about north, east and
/// down: `c_true = (I + [phi x]) c_est`), with the filter's covariance:
/// (8-dof NEES, the attitude's own 3-dof NEES when its block factors).
pub fn nees_against<T: Real>(
    kf: &Eskf<T, HOST_M>,
    row: &AidedRow,
    c_b_n: &Matrix3<f64>,
    tr: &TruthRow,
    considered: Option<Matrix3<f64>>,
) -> Option<(f64, Option<f64>)> {
    let [r, p, h] = tr.euler_deg;
    let c_true = quat_to_dcm(&euler_to_quat(&Euler::<f64>::from_deg(r, p, h)));
    let d = c_true * c_b_n.transpose();
    let (ned, v) = (row.traj.ned_m, row.traj.v_mps);
    let e = nalgebra::SVector::<f64, 8>::from_column_slice(&[
        tr.p_n_m[0] - ned[0],
        tr.p_n_m[1] - ned[1],
        tr.v_n_mps[0] - v[0],
        tr.v_n_mps[1] - v[1],
        tr.v_n_mps[2] - v[2],
        0.5 * (d[(2, 1)] - d[(1, 2)]),
        0.5 * (d[(0, 2)] - d[(2, 0)]),
        0.5 * (d[(1, 0)] - d[(0, 1)]),
    ]);
    let idx = [
        I_P,
        I_P + 1,
        I_V,
        I_V + 1,
        I_V + 2,
        I_PHI,
        I_PHI + 1,
        I_PHI + 2,
    ];
    let mut p8 = nalgebra::SMatrix::<f64, 8, 8>::from_fn(|r, c| {
        idx.get(r)
            .zip(idx.get(c))
            .and_then(|(i, j)| kf.p.get((*i, *j)))
            .map_or(f64::NAN, |x| x.to_f64())
    });
    if let Some(e) = considered {
        let mut ne = p8.fixed_view_mut::<2, 2>(0, 0);
        ne += e.fixed_view::<2, 2>(0, 0);
    }
    let ch = p8.cholesky()?;
    let nees = e.dot(&ch.solve(&e));
    let pa = p8.fixed_view::<3, 3>(5, 5).into_owned();
    let ea = e.fixed_rows::<3>(5).into_owned();
    let att = pa.cholesky().map(|ca| ea.dot(&ca.solve(&ea)));
    Some((nees, att))
}

/// The navigator's counts and each aid's report into the run.
pub fn finish<T: Real>(an: &HostNav<T>, aids: Vec<Box<dyn Aid<T>>>, run: &mut AidedRun) {
    run.rejected = an.kf.rejected;
    run.refused += an.kf.refused + an.counts.fixes_replaced + an.counts.corrections_refused;
    run.zupts = an.counts.zupts;
    run.zarus = an.counts.zarus;
    run.still_refuted = an.counts.still_refuted;
    run.reinits = an.counts.reinits;
    run.height_reinits = an.counts.height_reinits;
    run.faults = an.counts.steps_refused;
    for a in aids {
        a.report(run);
    }
}

/// Runs the pipeline over every sample of `rec`.
///
/// # Errors
/// What [`start`] refuses.
pub fn run<T: Real>(
    rec: &Recording,
    opt: &AidedOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<AidedRun> {
    // The vertical ride noise from a first pass (its own module), then
    // the run with it.
    let (vertical, share) = if opt.vertical_learn {
        let share = super::vertical::PASSES as f64 / (super::vertical::PASSES as f64 + 1.0);
        let v = super::vertical::learn::<T>(rec, opt, &mut |f| progress(f * share))?;
        (Some(v), share)
    } else {
        (None, 0.0)
    };
    let progress = &mut |f: f64| progress(share + f * (1.0 - share));
    run_with::<T>(rec, opt, progress, |_| match vertical {
        Some(v) => vec![Box::new(super::vertical::VerticalNoise::new(v))],
        None => vec![],
    })
}

/// [`run`] with the aids `opt` asks for and then `extra`'s (made from
/// the navigator at the start).
///
/// # Errors
/// What [`start`] refuses.
pub fn run_with<T: Real>(
    rec: &Recording,
    opt: &AidedOptions,
    progress: &mut dyn FnMut(f64),
    extra: impl FnOnce(&HostNav<T>) -> Vec<Box<dyn Aid<T>>>,
) -> Result<AidedRun> {
    let (mut an, mut run, input) = start::<T>(rec, opt)?;
    let mut aids = aids(rec, opt, &an);
    aids.extend(extra(&an));
    let earth = *an.nav().earth();
    let tangent = earth.origin.tangent();
    let mut feed = FixFeed::new();
    let mut last_fix_s = f64::NEG_INFINITY;
    let mut consider = opt.consider.map(Consider::new);
    let n = rec.imu.len();
    let every_s = rec.meta.imu_rate_hz.round().max(1.0) as usize;
    for (k, r) in rec.imu.iter().enumerate() {
        let t = r.t_s;
        // Fixes up to this sample: each in the past of the step that takes
        // it, compared with the track at its own time.
        let handed = feed.before_step(&mut an, &input.fixes, t, k == 0, &mut run, &input.to_us);
        let (table, sample) = (input.table::<T>(t), input.sample::<T>(k));
        let reinits_before = an.counts.reinits;
        let mut step = AidedStep::default();
        if let (true, Some(s)) = (k > 0, sample.as_ref()) {
            let rate = T::lit(input.track.at(t).rate);
            match an.step(s, &table, rate) {
                Ok(st) => step = st,
                Err(_) => continue,
            }
            // A fix's position and velocity updates, a sample apart:
            // each its own NIS over its own components.
            for (nis, used) in [step.fix, step.fix_velocity].into_iter().flatten() {
                run.nis.push((t, nis.to_f64(), used));
            }
            if step.fix.is_some() {
                last_fix_s = t;
            }
            let at = StepView {
                t_s: t,
                sample: s,
                table: &table,
                table_rate: rate,
                handed: handed.as_ref(),
                step: &step,
                aided: t - last_fix_s <= 2.0,
            };
            for a in aids.iter_mut() {
                a.after_step(&mut an, &at);
            }
        }
        let (mut row, c_b_n) = solution_row(&an, &table, &step, t, &earth, &tangent);
        let extra = consider.as_mut().map(|c| c.add(&mut row, &c_b_n));
        if let Some(e) = extra {
            let was = run.considered_m.unwrap_or([0.0; 3]);
            run.considered_m = Some(std::array::from_fn(|i| was[i].max(e[(i, i)].sqrt())));
        }
        run.rows.push(row);
        if an.counts.reinits > reinits_before {
            run.reinit_at.push((t, super::reinit_jump_m(&run.rows)));
        }
        if k % every_s == 0 {
            if let Some(tr) = recording::moving::truth_at(input.truth, t) {
                run.nees_diag.push((t, super::diagonal_nees(&row, &tr)));
                if let Some((nees, att)) = nees_against(&an.kf, &row, &c_b_n, &tr, extra) {
                    run.nees.push((t, nees, 8));
                    if let Some(a) = att {
                        run.nees_attitude.push((t, a));
                    }
                }
            }
        }
        if k % 20_000 == 0 {
            progress(k as f64 / n as f64);
        }
    }
    finish(&an, aids, &mut run);
    progress(1.0);
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(v: [f64; 3], fix: bool) -> AidedRow {
        let mut r = AidedRow {
            sigma_p_m: [0.03, 0.04, 0.05],
            fix,
            ..AidedRow::default()
        };
        r.traj.v_mps = v;
        r
    }

    #[test]
    fn the_clock_s_and_the_arm_s_errors_widen_the_position_and_stay_through_an_outage() {
        // A clock known to 2 ms and an arm to 1, 2 and 10 cm (independent);
        // the base yawed 90 deg (b's x north-east: n = C b with C's x ->
        // east, y -> -north). At 20 m/s north the clock puts 4 cm north;
        // the arm's x goes east, its y north, z down (a closed form).
        let cov = crate::aided::consider_of(
            Some(0.002),
            Some([[1e-4, 0.0, 0.0], [0.0, 4e-4, 0.0], [0.0, 0.0, 1e-2]]),
        );
        let mut c = Consider::new(cov.unwrap());
        let yawed = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
        let mut fixed = row([20.0, 0.0, 0.0], true);
        c.add(&mut fixed, &yawed);
        let want = [
            (0.03f64.powi(2) + 0.04f64.powi(2) + 4e-4).sqrt(),
            (0.04f64.powi(2) + 1e-4).sqrt(),
            (0.05f64.powi(2) + 1e-2).sqrt(),
        ];
        for (got, want) in fixed.sigma_p_m.iter().zip(want) {
            assert!((got - want).abs() < 1e-12, "{:?}", fixed.sigma_p_m);
        }
        // In the outage that follows the car turns east and stops: what
        // the last fix left is carried, unchanged.
        let mut after = row([0.0, 0.0, 0.0], false);
        c.add(&mut after, &Matrix3::identity());
        assert_eq!(after.sigma_p_m, fixed.sigma_p_m);
    }
}
