//! What `navigate --gnss` draws: the map (the track, the fixes, the truth
//! when there is one; one scale on both axes), the north and east errors
//! against the truth (or the fixes) in the filter's +-3 sigma band with the
//! spans without a fix shaded, and the filter's consistency
//! over time (NEES and NIS per degree of freedom).

use super::{AidedRow, AidedRun};
use crate::plot::{Chart, Dash, Figure, Series};
use anyhow::Result;
use recording::Recording;
use std::path::{Path, PathBuf};

/// Rows between two plotted points (a 100 Hz run: 2 Hz).
const STEP: usize = 50;

/// The antenna fixes of `rec` as (east, north) m from its site point.
pub fn fixes_en(rec: &Recording) -> Vec<(f64, f64)> {
    super::summary::receiver_reference(rec, 0.0)
        .iter()
        .map(|r| (r.p_n_m[1], r.p_n_m[0]))
        .collect()
}

fn map(rec: &Recording, run: &AidedRun) -> Chart {
    let mut c = Chart {
        title: "the track, the GNSS fixes and the truth (when known)".into(),
        x_label: "east [m]".into(),
        y_label: "north [m]".into(),
        equal_scale: true,
        ..Chart::default()
    };
    let truth = truth(rec);
    if !truth.is_empty() {
        c.series.push(
            Series::line(
                "truth",
                truth
                    .iter()
                    .step_by(STEP)
                    .map(|r| (r.p_n_m[1], r.p_n_m[0]))
                    .collect(),
            )
            .with_dash(Dash::Dashed),
        );
    }
    c.series.push(Series::points("GNSS fixes", fixes_en(rec)));
    c.series.push(
        Series::line(
            "navigation",
            run.rows
                .iter()
                .step_by(STEP)
                .map(|r| (r.traj.ned_m[1], r.traj.ned_m[0]))
                .collect(),
        )
        .with_dash(Dash::Solid),
    );
    c
}

/// The recording's truth, when it has one.
fn truth(rec: &Recording) -> &[recording::moving::TruthRow] {
    rec.moving
        .as_ref()
        .and_then(|m| m.truth.as_deref())
        .unwrap_or(&[])
}

/// Intervals without a fix the filter used, longer than three times the
/// usual interval between fixes (and 1 s): outages cut in, and the
/// receiver's own gaps.
pub fn fixless(run: &AidedRun) -> Vec<(f64, f64)> {
    let t: Vec<f64> = run.nis.iter().map(|(t, ..)| *t).collect();
    let mut gaps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let usual: f64 = if gaps.is_empty() {
        1.0
    } else {
        core_nav::stats::median(&mut gaps)
    };
    t.windows(2)
        .filter(|w| w[1] - w[0] > (3.0 * usual).max(1.0))
        .map(|w| (w[0], w[1]))
        .collect()
}

/// The north (`k` = 0) or east (1) error with the filter's +-3 sigma as a
/// band: against the truth each half second, or, without one, against
/// each GNSS fix (the fixes' own error included).
fn axis_error(rec: &Recording, run: &AidedRun, k: usize) -> Series {
    let truth = truth(rec);
    let at = |r: &AidedRow, p: [f64; 3]| (r.traj.t_s, r.traj.ned_m[k] - p[k], 3.0 * r.sigma_p_m[k]);
    let pts: Vec<(f64, f64, f64)> = if truth.is_empty() {
        let rows = &run.rows;
        super::summary::receiver_reference(rec, run.time_offset_s)
            .iter()
            .filter_map(|f| {
                let i = rows.partition_point(|r| r.traj.t_s < f.t_s);
                let r = rows.get(i)?;
                ((r.traj.t_s - f.t_s).abs() < 0.05).then(|| at(r, f.p_n_m))
            })
            .collect()
    } else {
        run.rows
            .iter()
            .step_by(STEP)
            .filter_map(|r| Some(at(r, recording::moving::truth_at(truth, r.traj.t_s)?.p_n_m)))
            .collect()
    };
    let what = if truth.is_empty() {
        "navigation - GNSS fix"
    } else {
        "error against the truth"
    };
    let mut s = Series::line(
        format!("{what} (band: the filter's +-3 sigma)"),
        pts.iter().map(|(t, e, _)| (*t, *e)).collect(),
    );
    s.markers = truth.is_empty();
    s.band = Some(pts.iter().map(|(_, _, b)| (-b, *b)).collect());
    s
}

fn error(rec: &Recording, run: &AidedRun) -> Vec<Chart> {
    ["north", "east"]
        .iter()
        .enumerate()
        .map(|(k, axis)| Chart {
            title: format!("{axis} position error and the filter's 3-sigma"),
            x_label: "time [s]".into(),
            y_label: format!("{axis} error [m]"),
            shaded: fixless(run),
            shaded_label: "no GNSS fix used".into(),
            series: vec![axis_error(rec, run, k)],
            ..Chart::default()
        })
        .collect()
}

fn consistency(run: &AidedRun) -> Chart {
    let mut c = Chart {
        title: "consistency per degree of freedom: 1 is honest".into(),
        x_label: "time [s]".into(),
        y_label: "NEES or NIS per degree of freedom [1]".into(),
        log_y: true,
        // A filter that starts pessimistic has a NEES of 1e-5 at first;
        // the two decades either side of 1 are what a reader judges.
        y_floor: Some(1e-2),
        shaded: fixless(run),
        shaded_label: "no GNSS fix used".into(),
        ..Chart::default()
    };
    let mut nis = Series::line(
        "NIS (each fix used)",
        run.nis
            .iter()
            .filter(|(_, _, n)| *n > 0)
            .map(|(t, v, n)| (*t, v / f64::from(*n)))
            .collect(),
    );
    nis.markers = true;
    c.series.push(nis);
    if !run.nees.is_empty() {
        c.series.push(Series::line(
            "NEES (against the truth, each second)",
            run.nees
                .iter()
                .map(|(t, v, n)| (*t, v / *n as f64))
                .collect(),
        ));
    }
    c
}

/// Writes `map`, `position_error` and `consistency` (SVG and PNG) into
/// `dir`; returns the files.
///
/// # Errors
/// A plot that cannot be drawn or written.
pub fn plots(rec: &Recording, run: &AidedRun, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Figure::one(map(rec, run)).write(&dir.join("map"))?;
    let errors = Figure {
        charts: error(rec, run),
    };
    out.extend(errors.write(&dir.join("position_error"))?);
    out.extend(Figure::one(consistency(run)).write(&dir.join("consistency"))?);
    Ok(out)
}
