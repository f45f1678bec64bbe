//! The part of a moving-base recording that `rins navigate --gnss
//! --start-s S --end-s E` navigates: the IMU samples, encoder reads and
//! fixes inside `[S, E]`, and a start state for `S`.
//!
//! The aided navigator starts at rest ([`core_nav::aided::AidedNav::new`])
//! at the recording's site with `[base]`'s attitude, both of which are the
//! first sample's. A later start therefore needs:
//! - the vehicle still at `S` (the fixes' speed under
//!   [`super::align::STILL_SPEED_MPS`]); else it is refused with the
//!   still moments the fixes show;
//! - a position at `S`: the truth's there when `truth.csv` covers `S`,
//!   else the fix nearest `S`; the site moves to it, and `truth.csv` is
//!   re-expressed about the new site (trajectory-v1: positions are
//!   offsets from the start point);
//! - an attitude at `S`: the truth's when it covers `S`; else the
//!   alignment on the fixes when `[base] heading_known = false`; else it
//!   is refused (meta.toml's attitude is the first sample's).

use super::align::STILL_SPEED_MPS;
use anyhow::{bail, Result};
use core_nav::earth::{GeoPoint, LocalEarth};
use nalgebra::Vector3;
use recording::moving::{truth_at, GnssRow, TruthRow};
use recording::Recording;

/// Encoder reads kept beyond each end of the span, s (the track
/// interpolates across the ends).
const TABLE_MARGIN_S: f64 = 1.0;

/// `rec` cut to `[start_s, end_s]` with the start state of `start_s` (the
/// module's rules); `rec` itself when the span is the whole run.
///
/// # Errors
/// A start past the first sample where the vehicle moves, or whose
/// attitude nothing in the recording gives.
pub fn cut(rec: &Recording, start_s: f64, end_s: Option<f64>) -> Result<Recording> {
    let first = rec.imu.first().map_or(0.0, |r| r.t_s);
    let late_start = start_s > first;
    let end = end_s.unwrap_or(f64::INFINITY);
    let mut out = rec.clone();
    out.imu.retain(|r| r.t_s >= start_s && r.t_s <= end);
    out.table
        .retain(|r| r.t_s >= start_s - TABLE_MARGIN_S && r.t_s <= end + TABLE_MARGIN_S);
    if let Some(g) = out.moving.as_mut().and_then(|m| m.gnss.as_mut()) {
        g.retain(|f| f.t_s >= start_s && f.t_s <= end);
    }
    if late_start {
        start_state(rec, &mut out, start_s)?;
    }
    Ok(out)
}

/// The fix nearest `t_s`.
fn nearest(fixes: &[GnssRow], t_s: f64) -> Option<&GnssRow> {
    fixes
        .iter()
        .min_by(|a, b| (a.t_s - t_s).abs().total_cmp(&(b.t_s - t_s).abs()))
}

/// Moves `out`'s site and `[base]` to `start_s`.
fn start_state(rec: &Recording, out: &mut Recording, start_s: f64) -> Result<()> {
    let Some(mv) = rec.moving.as_ref() else {
        bail!("--start-s with --gnss needs a moving-base recording");
    };
    let fixes = mv.gnss.as_deref().unwrap_or(&[]);
    let speed = |f: &GnssRow| f.v_n_mps[0].hypot(f.v_n_mps[1]);
    if let Some(f) = nearest(fixes, start_s).filter(|f| speed(f) > STILL_SPEED_MPS) {
        bail!(
            "--start-s {start_s}: the aided filter starts at rest, and the fix at {:.1} s says {:.2} m/s; start where the vehicle stands ({})",
            f.t_s,
            speed(f),
            still_moments(fixes)
        );
    }
    let m = &rec.meta;
    let site = GeoPoint::from_deg(m.latitude_deg, mv.longitude_deg, m.height_m);
    let truth = mv.truth.as_deref().and_then(|t| truth_at(t, start_s));
    let (point, rph) = match (&truth, nearest(fixes, start_s)) {
        (Some(tr), _) => (
            LocalEarth::<f64>::new(site, None).point_at(&Vector3::from(tr.p_n_m)),
            Some(tr.euler_deg),
        ),
        (None, Some(f)) => (GeoPoint::from_deg(f.lat_deg, f.lon_deg, f.height_m), None),
        (None, None) => bail!("--start-s {start_s}: no fix and no truth to start from"),
    };
    let Some(omv) = out.moving.as_mut() else {
        bail!("--start-s with --gnss needs a moving-base recording");
    };
    match rph {
        Some([r, p, h]) => {
            (out.meta.roll_deg, out.meta.pitch_deg, out.meta.heading_deg) = (r, p, h);
            omv.heading_unknown = false;
        }
        None if mv.heading_unknown => {}
        None => bail!(
            "--start-s {start_s}: meta.toml's attitude is the first sample's; a later start needs truth.csv covering it, or [base] heading_known = false (aligned on the fixes)"
        ),
    }
    out.meta.latitude_deg = point.lat_rad.to_degrees();
    omv.longitude_deg = point.lon_rad.to_degrees();
    out.meta.height_m = point.height_m;
    if let Some(t) = omv.truth.as_mut() {
        re_site(t, site, point);
    }
    Ok(())
}

/// Truth rows about `from` re-expressed about `to` (NED offsets, m).
fn re_site(rows: &mut [TruthRow], from: GeoPoint, to: GeoPoint) {
    let old = LocalEarth::<f64>::new(from, None);
    let tangent = to.tangent();
    for r in rows {
        let d = tangent.ned_to(&old.point_at(&Vector3::from(r.p_n_m)));
        r.p_n_m = [d.x, d.y, d.z];
    }
}

/// The stretches of at least 2 s where the fixes are still, in words.
fn still_moments(fixes: &[GnssRow]) -> String {
    let mut spans: Vec<(f64, f64)> = vec![];
    let mut open: Option<f64> = None;
    for f in fixes {
        let still = f.v_n_mps[0].hypot(f.v_n_mps[1]) <= STILL_SPEED_MPS;
        match (still, open) {
            (true, None) => open = Some(f.t_s),
            (false, Some(a)) => {
                spans.push((a, f.t_s));
                open = None;
            }
            _ => {}
        }
    }
    if let (Some(a), Some(l)) = (open, fixes.last()) {
        spans.push((a, l.t_s));
    }
    let shown: Vec<String> = spans
        .iter()
        .filter(|(a, b)| b - a >= 2.0)
        .take(5)
        .map(|(a, b)| format!("{a:.0}-{b:.0} s"))
        .collect();
    match shown.is_empty() {
        true => "the fixes show no still stretch of 2 s".into(),
        false => format!("still: {}", shown.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_re_sited_keeps_each_point() {
        let from = GeoPoint::from_deg(30.0, 114.0, 20.0);
        let to = LocalEarth::<f64>::new(from, None).point_at(&Vector3::new(500.0, -300.0, 2.0));
        let mut rows = vec![TruthRow {
            t_s: 0.0,
            p_n_m: [500.0, -300.0, 2.0],
            v_n_mps: [0.0; 3],
            euler_deg: [0.0; 3],
        }];
        re_site(&mut rows, from, to);
        // The start point itself becomes the origin (to the curvilinear
        // offset's mm over 600 m).
        let p = Vector3::from(rows[0].p_n_m);
        assert!(p.norm() < 1e-3, "{p}");
    }
}
