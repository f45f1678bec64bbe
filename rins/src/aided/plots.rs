//! What `navigate --gnss` draws: the map (the track, the fixes, the truth
//! when there is one), the horizontal error against the truth with the
//! filter's 3-sigma (or the 3-sigma alone), and the filter's consistency
//! over time (NEES and NIS per degree of freedom).

use super::AidedRun;
use crate::plot::{Chart, Figure, Series};
use anyhow::Result;
use recording::Recording;
use std::path::{Path, PathBuf};

/// Rows between two plotted points (a 100 Hz run: 2 Hz).
const STEP: usize = 50;

/// The antenna fixes of `rec` as (east, north) m from its site point.
pub fn fixes_en(rec: &Recording) -> Vec<(f64, f64)> {
    super::summary::receiver_reference(rec)
        .iter()
        .map(|r| (r.p_n_m[1], r.p_n_m[0]))
        .collect()
}

fn map(rec: &Recording, run: &AidedRun) -> Chart {
    let mut c = Chart {
        title: "the track, the GNSS fixes (points) and the truth (dashed, when known)".into(),
        x_label: "east (m)".into(),
        y_label: "north (m)".into(),
        ..Chart::default()
    };
    let truth = rec
        .moving
        .as_ref()
        .and_then(|m| m.truth.as_deref())
        .unwrap_or(&[]);
    if !truth.is_empty() {
        let mut t = Series::line(
            "truth",
            truth
                .iter()
                .step_by(STEP)
                .map(|r| (r.p_n_m[1], r.p_n_m[0]))
                .collect(),
        );
        t.dashed = true;
        c.series.push(t);
    }
    let mut g = Series::line("GNSS fixes", fixes_en(rec));
    g.markers = true;
    c.series.push(g);
    c.series.push(Series::line(
        "navigation",
        run.rows
            .iter()
            .step_by(STEP)
            .map(|r| (r.traj.ned_m[1], r.traj.ned_m[0]))
            .collect(),
    ));
    c
}

fn error(rec: &Recording, run: &AidedRun) -> Chart {
    let truth = rec
        .moving
        .as_ref()
        .and_then(|m| m.truth.as_deref())
        .unwrap_or(&[]);
    let mut c = Chart {
        title: "horizontal error against the truth and the filter's 3-sigma (m)".into(),
        x_label: "time (s)".into(),
        y_label: "m".into(),
        log_y: true,
        ..Chart::default()
    };
    let err: Vec<(f64, f64)> = run
        .rows
        .iter()
        .step_by(STEP)
        .filter_map(|r| {
            let t = recording::moving::truth_at(truth, r.traj.t_s)?;
            Some((
                r.traj.t_s,
                (r.traj.ned_m[0] - t.p_n_m[0]).hypot(r.traj.ned_m[1] - t.p_n_m[1]),
            ))
        })
        .collect();
    if !err.is_empty() {
        c.series.push(Series::line("error", err));
    }
    let mut sig = Series::line(
        "3-sigma",
        run.rows
            .iter()
            .step_by(STEP)
            .map(|r| (r.traj.t_s, 3.0 * r.sigma_p_m[0].hypot(r.sigma_p_m[1])))
            .collect(),
    );
    sig.dashed = true;
    c.series.push(sig);
    c
}

fn consistency(run: &AidedRun) -> Chart {
    let mut c = Chart {
        title: "consistency: NEES (against the truth, each second) and NIS (each fix) per degree of freedom; 1 is honest".into(),
        x_label: "time (s)".into(),
        y_label: "per degree of freedom".into(),
        log_y: true,
        ..Chart::default()
    };
    let mut nis = Series::line(
        "NIS",
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
            "NEES",
            run.nees
                .iter()
                .map(|(t, v, n)| (*t, v / *n as f64))
                .collect(),
        ));
    }
    c
}

/// Writes `map`, `horizontal_error` and `consistency` (SVG and PNG) into
/// `dir`; returns the files.
///
/// # Errors
/// A plot that cannot be drawn or written.
pub fn plots(rec: &Recording, run: &AidedRun, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Figure::one(map(rec, run)).write(&dir.join("map"))?;
    out.extend(Figure::one(error(rec, run)).write(&dir.join("horizontal_error"))?);
    out.extend(Figure::one(consistency(run)).write(&dir.join("consistency"))?);
    Ok(out)
}
