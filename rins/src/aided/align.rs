//! Alignment of an aided run whose start attitude is not given (an
//! imported log, `[base] heading_known = false`): level from the still
//! start, heading from the fixes' velocity once the vehicle moves.
//!
//! **Level**: the mean specific force over the still start (the fixes'
//! speed under [`STILL_SPEED_MPS`]) is `-g` in `b` ([`coarse_level`]).
//!
//! **Heading** (in-motion, closed form): from the end of the still start
//! the gyros carry the attitude in a level frame `l` whose heading is 0,
//! and the specific force is integrated into a velocity in `l`. The
//! vehicle's true velocity is that velocity turned about down by the
//! start heading `psi`, so the velocity changes over each
//! [`DV_SPAN_S`] between fixes satisfy `dv_n = Rz(psi) dv_l`; the
//! least-squares `psi` is `atan2(sum dv_l x dv_n, sum dv_l . dv_n)`
//! (horizontal components) over the first [`HEADING_WINDOW_S`] of motion.
//! Velocity changes, not velocities: the start velocity's error cancels,
//! and an accelerometer bias `b` adds only `b DV_SPAN_S` to each. The
//! spread of the per-pair angles, weighted as the sums are, gives the
//! heading's 1-sigma.

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

/// An alignment: the base's attitude at the first sample and its 1-sigma.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// Roll, pitch, heading, rad.
    pub euler_rad: [f64; 3],
    /// Level 1-sigma, rad.
    pub level_sigma_rad: f64,
    /// Heading 1-sigma, rad.
    pub heading_sigma_rad: f64,
    /// The still start's end, s.
    pub still_end_s: f64,
    /// Velocity pairs the heading came from.
    pub pairs: usize,
}

/// The fixes with a velocity each: their own, or (position-only fixes)
/// the central difference of their neighbours' positions.
fn with_velocity(fixes: &[GnssRow]) -> Vec<GnssRow> {
    let p = |f: &GnssRow| core_nav::earth::GeoPoint::from_deg(f.lat_deg, f.lon_deg, f.height_m);
    (0..fixes.len())
        .filter_map(|k| {
            let f = fixes.get(k)?;
            if f.has_velocity() {
                return Some(*f);
            }
            let (a, b) = (fixes.get(k.checked_sub(1)?)?, fixes.get(k + 1)?);
            let d = p(a).ned_to(&p(b)) / (b.t_s - a.t_s);
            Some(GnssRow {
                v_n_mps: [d.x, d.y, d.z],
                sigma_vel_mps: f.sigma_h_m * std::f64::consts::SQRT_2 / (b.t_s - a.t_s),
                ..*f
            })
        })
        .collect()
}

/// Aligns `rec` (samples in `b`) with its `fixes`.
///
/// # Errors
/// No still start before the first motion, or too little motion in the window to see the heading.
pub fn align(rec: &Recording, fixes: &[GnssRow], g: f64) -> anyhow::Result<Alignment> {
    let fixes = &with_velocity(fixes);
    let speed = |f: &GnssRow| f.v_n_mps[0].hypot(f.v_n_mps[1]);
    let still_end_s = fixes
        .iter()
        .find(|f| speed(f) > STILL_SPEED_MPS)
        .map(|f| f.t_s)
        .ok_or_else(|| {
            anyhow::anyhow!("the fixes never move: the heading cannot be found from them")
        })?;
    let still: Vec<&recording::ImuRow> = rec
        .imu
        .iter()
        .take_while(|r| r.t_s < still_end_s - 0.5)
        .collect();
    if still.len() < 50 {
        anyhow::bail!("no still start (under {STILL_SPEED_MPS} m/s) of at least 0.5 s before the motion at {still_end_s:.1} s");
    }
    let n = still.len() as f64;
    let f_mean = still
        .iter()
        .fold(Vector3::zeros(), |a, r| a + Vector3::from(r.accel_mps2))
        / n;
    let level = coarse_level(&f_mean, g, 0.0).map_err(|e| anyhow::anyhow!("levelling: {e:?}"))?;
    // The level frame from the start of motion, carried by the gyros.
    let mut q = euler_to_quat(&Euler {
        roll: level.roll,
        pitch: level.pitch,
        heading: 0.0,
    });
    let mut v_l = Vector3::<f64>::zeros();
    let mut track: Vec<(f64, Vector3<f64>)> = vec![];
    let mut prev: Option<&recording::ImuRow> = None;
    for r in rec
        .imu
        .iter()
        .take_while(|r| r.t_s <= still_end_s + HEADING_WINDOW_S + DV_SPAN_S)
    {
        if let Some(p) = prev {
            let dt = r.t_s - p.t_s;
            let w = (Vector3::from(p.gyro_radps) + Vector3::from(r.gyro_radps)) * 0.5;
            let f = Vector3::from(p.accel_mps2);
            let c = quat_to_dcm(&q);
            if p.t_s >= still_end_s - 1.0 {
                v_l += (c * f + Vector3::new(0.0, 0.0, g)) * dt;
            }
            q = UnitQuaternion::from_quaternion(q * rotvec_to_quat(&(w * dt))).into_inner();
        }
        track.push((r.t_s, v_l));
        prev = Some(r);
    }
    let v_at = |t: f64| {
        let k = track.partition_point(|x| x.0 < t);
        track.get(k).map(|x| x.1)
    };
    let (mut cross, mut dot, mut angles) = (0.0, 0.0, vec![]);
    for a in fixes
        .iter()
        .filter(|f| f.t_s >= still_end_s - 1.0 && f.t_s <= still_end_s + HEADING_WINDOW_S)
    {
        let Some(b) = fixes.iter().find(|f| f.t_s >= a.t_s + DV_SPAN_S - 1e-6) else {
            break;
        };
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
            "too little motion in the {HEADING_WINDOW_S} s after {still_end_s:.1} s to find the heading from the fixes ({} fix pairs there; a --gnss-outage cut there withholds them)",
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
    let interval = (still_end_s + HEADING_WINDOW_S - (still_end_s - 1.0)) / angles.len() as f64;
    let n_eff = weight * weight
        / angles.iter().map(|a| a.1 * a.1).sum::<f64>()
        / (DV_SPAN_S / interval).max(1.0);
    Ok(Alignment {
        euler_rad: [level.roll, level.pitch, wrap(psi)],
        level_sigma_rad: 0.5f64.to_radians(),
        heading_sigma_rad: (var / n_eff.max(1.0)).sqrt().max(1f64.to_radians()),
        still_end_s,
        pairs: angles.len(),
    })
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
