//! Alignment of an aided run whose start attitude is not given (an
//! imported log, `[base] heading_known = false`): level from the still
//! start, heading from the fixes' velocity once the vehicle moves.
//!
//! **Level**: the mean specific force over the still start (the fixes'
//! speed under [`STILL_SPEED_MPS`], up to the first gap in them; each
//! axis's interquartile mean) is `-g` in `b` ([`coarse_level`]); the mean
//! rate there is the gyros' bias (and the earth's rate), taken out of the
//! heading's track below.
//!
//! **Heading** (in-motion, closed form): from the end of the still start
//! (through an outage, if one cuts it) the gyros carry the attitude in a
//! level frame `l` whose heading is 0, and the specific force is integrated into a velocity in `l`. The
//! vehicle's true velocity is that velocity turned about down by the
//! start heading `psi`, so the velocity changes over each
//! [`DV_SPAN_S`] between fixes satisfy `dv_n = Rz(psi) dv_l`; the
//! least-squares `psi` is `atan2(sum dv_l x dv_n, sum dv_l . dv_n)`
//! (horizontal components) over the first [`HEADING_WINDOW_S`] of motion
//! the fixes show (pairs across a gap left out).
//! Velocity changes, not velocities: the start velocity's error cancels,
//! and an accelerometer bias `b` adds only `b DV_SPAN_S` to each. The
//! spread of the per-pair angles, weighted as the sums are, gives the
//! fit's 1-sigma.
//!
//! **The filter's start** is the fit's heading with a sigma of at least
//! [`START_HEADING_SIGMA_DEG`], not the fit's: the fixes of the window are
//! the filter's first fixes too, and started at the fit's sigma it took
//! their heading twice.

use core_nav::align::coarse_level;
use core_nav::attitude::{euler_to_quat, quat_to_dcm, rotvec_to_quat, Euler};
use nalgebra::{UnitQuaternion, Vector3};
use recording::moving::GnssRow;
use recording::Recording;

/// Fix speed under which the vehicle counts as still, m/s.
pub const STILL_SPEED_MPS: f64 = 0.2;
/// The span of each velocity change compared, s.
pub const DV_SPAN_S: f64 = 1.0;
/// The motion the heading is found over, s.
pub const HEADING_WINDOW_S: f64 = 10.0;
/// The least velocity change the window's sums must hold, m/s (their
/// magnitude is this squared; below it the heading is not observable).
pub const MIN_DV_SUM_MPS: f64 = 2.0;

/// The least heading 1-sigma an aligned run's filter starts with, deg.
/// The alignment's fixes enter the filter again, so its start should
/// carry next to nothing of them: as wide as the error state's
/// small-angle model still holds (at 30 deg the rotation's first-order
/// form is off by 1 - cos 30 = 13 % of the angle). On the bundled walk's
/// shifted copies (`tools/pyins-peer/shifts`, the book) the mean 10 s
/// outage's end fell from 0.62 m at the fit's 2.9 deg to 0.58 m, and no
/// further at 70 deg.
pub const START_HEADING_SIGMA_DEG: f64 = 30.0;

/// An alignment: the base's attitude at the first sample and its 1-sigma.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// Roll, pitch, heading, rad.
    pub euler_rad: [f64; 3],
    /// Level 1-sigma, rad.
    pub level_sigma_rad: f64,
    /// The heading fit's 1-sigma, rad (the filter starts wider:
    /// [`START_HEADING_SIGMA_DEG`]).
    pub heading_sigma_rad: f64,
    /// The still start's end, s.
    pub still_end_s: f64,
    /// Velocity pairs the heading came from.
    pub pairs: usize,
}

/// The median interval between the fixes, s (infinite for fewer than
/// two).
fn median_interval(fixes: &[GnssRow]) -> f64 {
    let mut dt: Vec<f64> = fixes.windows(2).map(|w| w[1].t_s - w[0].t_s).collect();
    dt.sort_by(f64::total_cmp);
    dt.get(dt.len() / 2).copied().unwrap_or(f64::INFINITY)
}

/// The fixes with a velocity each: their own, or (position-only fixes)
/// the central difference of their neighbours' positions; a position-only
/// fix next to a gap (an outage) is left out: a difference across it is
/// the outage's mean speed, not the fix's (before, the fix before an
/// outage from 10 s on the bundled walk moved at 0.5 m/s, and the still
/// start ended there).
fn with_velocity(fixes: &[GnssRow]) -> Vec<GnssRow> {
    let p = |f: &GnssRow| core_nav::earth::GeoPoint::from_deg(f.lat_deg, f.lon_deg, f.height_m);
    let span = 2.0 * GAP_INTERVALS * median_interval(fixes);
    (0..fixes.len())
        .filter_map(|k| {
            let f = fixes.get(k)?;
            if f.has_velocity() {
                return Some(*f);
            }
            let (a, b) = (fixes.get(k.checked_sub(1)?)?, fixes.get(k + 1)?);
            if b.t_s - a.t_s > span {
                return None;
            }
            let d = p(a).ned_to(&p(b)) / (b.t_s - a.t_s);
            Some(GnssRow {
                v_n_mps: [d.x, d.y, d.z],
                sigma_vel_mps: f.sigma_h_m * std::f64::consts::SQRT_2 / (b.t_s - a.t_s),
                ..*f
            })
        })
        .collect()
}

/// The still start and the motion's first fix, s.
#[derive(Clone, Copy, Debug, PartialEq)]
struct StillSpan {
    /// The IMU's samples before this are still.
    still_to_s: f64,
    /// The first fix faster than [`STILL_SPEED_MPS`].
    moving_s: f64,
}

/// A gap between fixes longer than this many of their median intervals
/// ends the still start (an outage: what the base did in it is not known).
const GAP_INTERVALS: f64 = 2.5;

/// Where the still start ends: half a second before the first fix faster
/// than [`STILL_SPEED_MPS`] (the motion began between it and the one
/// before), or at the last slow fix before a gap in the fixes, whichever
/// comes first. A gap is not stillness: before, an outage from 10 s took
/// the still start to the first fix after it and levelled on 10 s of
/// walking.
fn still_span(fixes: &[GnssRow]) -> anyhow::Result<StillSpan> {
    let speed = |f: &GnssRow| f.v_n_mps[0].hypot(f.v_n_mps[1]);
    let moving = fixes.iter().position(|f| speed(f) > STILL_SPEED_MPS);
    let moving = moving.and_then(|k| fixes.get(k).map(|f| (k, f.t_s)));
    let Some((k_move, moving_s)) = moving else {
        anyhow::bail!("the fixes never move: the heading cannot be found from them");
    };
    let median = median_interval(fixes);
    let gap = fixes
        .windows(2)
        .take(k_move)
        .find(|w| w[1].t_s - w[0].t_s > GAP_INTERVALS * median)
        .map(|w| w[0].t_s);
    Ok(StillSpan {
        still_to_s: gap.unwrap_or(moving_s - 0.5),
        moving_s,
    })
}

/// The still start's specific force and angular rate, `b`: each axis's
/// interquartile mean (the mean of the samples between its quartiles).
/// A hand's still start is bumped and its last second holds the first
/// steps: a plain mean took them in (on the bundled walk 0.4 deg/s off
/// the bias the filter converges to, which tilts the level track by 4 deg
/// in 10 s); the middle half is robust to them as a median is, without a
/// median's hold on the quantisation step.
fn still_means(rec: &Recording, still_to_s: f64) -> anyhow::Result<(Vector3<f64>, Vector3<f64>)> {
    let still: Vec<&recording::ImuRow> =
        rec.imu.iter().take_while(|r| r.t_s < still_to_s).collect();
    if still.len() < 50 {
        anyhow::bail!("no still start (under {STILL_SPEED_MPS} m/s, fixes without a gap) of at least 0.5 s: it ends at {still_to_s:.1} s");
    }
    Ok((
        iq_means(&still, |r| r.accel_mps2),
        iq_means(&still, |r| r.gyro_radps),
    ))
}

/// Each axis's interquartile mean of `f` over `rows`.
fn iq_means(rows: &[&recording::ImuRow], f: fn(&recording::ImuRow) -> [f64; 3]) -> Vector3<f64> {
    let axis = |i: usize| {
        let mut v: Vec<f64> = rows
            .iter()
            .map(|r| f(r).get(i).copied().unwrap_or(f64::NAN))
            .collect();
        v.sort_by(f64::total_cmp);
        let (a, b) = (v.len() / 4, v.len() - v.len() / 4);
        let mid = v.get(a..b).unwrap_or(&[]);
        mid.iter().sum::<f64>() / mid.len().max(1) as f64
    };
    Vector3::new(axis(0), axis(1), axis(2))
}

/// The velocity in the level frame `l` (heading 0 at the start), from
/// `from_s` on, at each sample up to `to_s`: the gyros, less the still
/// start's mean rate (the bias, and the earth's rate the frame does not
/// turn with), carry the attitude; the specific force plus gravity is
/// integrated.
fn level_track(
    rec: &Recording,
    level: &Euler<f64>,
    w_still: &Vector3<f64>,
    (from_s, to_s): (f64, f64),
    g: f64,
) -> Vec<(f64, Vector3<f64>)> {
    let mut q = euler_to_quat(&Euler {
        heading: 0.0,
        ..*level
    });
    let mut v_l = Vector3::<f64>::zeros();
    let mut track = vec![];
    let mut prev: Option<&recording::ImuRow> = None;
    for r in rec.imu.iter().take_while(|r| r.t_s <= to_s) {
        if let Some(p) = prev {
            let dt = r.t_s - p.t_s;
            let w = (Vector3::from(p.gyro_radps) + Vector3::from(r.gyro_radps)) * 0.5 - w_still;
            if p.t_s >= from_s {
                v_l += (quat_to_dcm(&q) * Vector3::from(p.accel_mps2) + Vector3::new(0.0, 0.0, g))
                    * dt;
            }
            q = UnitQuaternion::from_quaternion(q * rotvec_to_quat(&(w * dt))).into_inner();
        }
        track.push((r.t_s, v_l));
        prev = Some(r);
    }
    track
}

/// Aligns `rec` (samples in `b`) with its `fixes`.
///
/// # Errors
/// No still start before the first motion, or too little motion in the window to see the heading.
pub fn align(rec: &Recording, fixes: &[GnssRow], g: f64) -> anyhow::Result<Alignment> {
    let fixes = &with_velocity(fixes);
    let span = still_span(fixes)?;
    let (f_mean, w_still) = still_means(rec, span.still_to_s)?;
    let level = coarse_level(&f_mean, g, 0.0).map_err(|e| anyhow::anyhow!("levelling: {e:?}"))?;
    let window = heading_window(fixes, span.moving_s);
    let track = level_track(
        rec,
        &level,
        &w_still,
        (span.still_to_s.min(window.0), window.1 + DV_SPAN_S),
        g,
    );
    let (psi, heading_sigma_rad, pairs) = heading_fit(fixes, &track, window)?;
    Ok(Alignment {
        euler_rad: [level.roll, level.pitch, psi],
        level_sigma_rad: 0.5f64.to_radians(),
        heading_sigma_rad,
        still_end_s: span.still_to_s,
        pairs,
    })
}

/// The span the heading is found over, s: from a second before the
/// first moving fix, [`HEADING_WINDOW_S`] of it covered by fixes (each
/// gap in them, an outage, adds its length: before, a pair across an
/// outage compared 10 s of velocity change as if it were one second's).
fn heading_window(fixes: &[GnssRow], moving_s: f64) -> (f64, f64) {
    let gap = GAP_INTERVALS * median_interval(fixes);
    let start = moving_s - 1.0;
    let mut end = moving_s + HEADING_WINDOW_S;
    for w in fixes.windows(2) {
        let dt = w[1].t_s - w[0].t_s;
        if w[0].t_s >= start && w[0].t_s < end && dt > gap {
            end += dt;
        }
    }
    (start, end)
}

/// The heading (rad, wrapped to +-pi), its 1-sigma (rad) and the pairs it
/// came from: the fixes' velocity changes over the `window` against the
/// level `track`'s (the closed form in the module's docs).
fn heading_fit(
    fixes: &[GnssRow],
    track: &[(f64, Vector3<f64>)],
    window: (f64, f64),
) -> anyhow::Result<(f64, f64, usize)> {
    let v_at = |t: f64| {
        let k = track.partition_point(|x| x.0 < t);
        track.get(k).map(|x| x.1)
    };
    let (mut cross, mut dot, mut angles) = (0.0, 0.0, vec![]);
    for a in fixes
        .iter()
        .filter(|f| f.t_s >= window.0 && f.t_s <= window.1)
    {
        let Some(b) = fixes.iter().find(|f| f.t_s >= a.t_s + DV_SPAN_S - 1e-6) else {
            break;
        };
        if b.t_s > a.t_s + 1.5 * DV_SPAN_S {
            continue; // a gap in the fixes (an outage) between them
        }
        let (Some(la), Some(lb)) = (v_at(a.t_s), v_at(b.t_s)) else {
            break;
        };
        let dl = lb - la;
        let dn = Vector3::from(b.v_n_mps) - Vector3::from(a.v_n_mps);
        let (c, d) = (dl.x * dn.y - dl.y * dn.x, dl.x * dn.x + dl.y * dn.y);
        cross += c;
        dot += d;
        angles.push((c.atan2(d), dl.xy().norm() * dn.xy().norm()));
    }
    let weight: f64 = angles.iter().map(|a| a.1).sum();
    if dot.hypot(cross) < MIN_DV_SUM_MPS * MIN_DV_SUM_MPS || angles.len() < 4 {
        anyhow::bail!(
            "too little motion in the {HEADING_WINDOW_S} s of fixes after {:.1} s to find the heading from them ({} fix pairs there)",
            window.0 + 1.0,
            angles.len()
        );
    }
    let psi = cross.atan2(dot);
    let wrap = |x: f64| {
        (x + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI) - std::f64::consts::PI
    };
    let var = angles
        .iter()
        .map(|(a, w)| w * wrap(a - psi).powi(2))
        .sum::<f64>()
        / weight;
    // Pairs a quarter of their span apart share most of it: the
    // independent ones are fewer by the span over the fix interval.
    let interval = (HEADING_WINDOW_S + 1.0) / angles.len() as f64;
    let n_eff = weight * weight
        / angles.iter().map(|a| a.1 * a.1).sum::<f64>()
        / (DV_SPAN_S / interval).max(1.0);
    Ok((
        wrap(psi),
        (var / n_eff.max(1.0)).sqrt().max(1f64.to_radians()),
        angles.len(),
    ))
}

/// A run that starts moving: the velocity the first fixes give.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct MovingStart {
    /// Velocity, NED, m/s.
    pub v_n_mps: [f64; 3],
    /// Its 1-sigma per axis, m/s.
    pub sigma_mps: f64,
}

/// The start's velocity when the vehicle is already moving: the first
/// fix's own velocity, or the first two position fixes at least
/// [`DV_SPAN_S`] apart differenced (1-sigma `sqrt(2)` times their
/// horizontal sigma over the interval); `None` when the horizontal speed
/// is within [`STILL_SPEED_MPS`] plus 3 sigma of rest (a still start).
pub fn moving_start(fixes: &[GnssRow], origin: core_nav::earth::GeoPoint) -> Option<MovingStart> {
    let f0 = fixes.first()?;
    let (v, sigma) = if f0.has_velocity() {
        (f0.v_n_mps, f0.sigma_vel_mps)
    } else {
        let f1 = fixes.iter().find(|f| f.t_s >= f0.t_s + DV_SPAN_S)?;
        let dt = f1.t_s - f0.t_s;
        let at = |f: &GnssRow| {
            origin.ned_to(&core_nav::earth::GeoPoint::from_deg(
                f.lat_deg, f.lon_deg, f.height_m,
            ))
        };
        let v = (at(f1) - at(f0)) / dt;
        let s = std::f64::consts::SQRT_2 * f0.sigma_h_m.max(f1.sigma_h_m) / dt;
        ([v.x, v.y, v.z], s)
    };
    let moving = v[0].hypot(v[1]) > STILL_SPEED_MPS + 3.0 * sigma;
    moving.then_some(MovingStart {
        v_n_mps: v,
        sigma_mps: sigma,
    })
}
