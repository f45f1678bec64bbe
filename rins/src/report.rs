//! Plots of navigation runs (the paper's Fig. 7-12 kinds): position and
//! velocity errors, roll / pitch / heading errors over time, and errors
//! against the table rate.

use crate::nav::TrajRow;
use crate::plot::{Chart, PlotError, Series};
use crate::reproduce::Row;
use core_nav::real::wrap_pi;

/// The angle error `a - b` wrapped to (-180, 180], deg.
fn angle_error_deg(a: f64, b: f64) -> f64 {
    wrap_pi((a - b).to_radians()).to_degrees()
}

/// A chart and the file stem it is written under (`<stem>.svg`,
/// `<stem>.png`).
pub struct NamedChart {
    /// File stem.
    pub stem: String,
    /// The chart.
    pub chart: Chart,
}

impl NamedChart {
    /// Writes `<dir>/<stem>.svg` and `.png`; returns the paths.
    ///
    /// # Errors
    /// A drawing failure or a file that cannot be written.
    pub fn write(&self, dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>, PlotError> {
        self.chart.write(&dir.join(&self.stem))
    }
}

/// The charts of one or more runs of a static base with attitude
/// `base_rph_deg` (deg), each named.
pub fn nav_charts(runs: &[(&str, &[TrajRow])], base_rph_deg: [f64; 3]) -> Vec<NamedChart> {
    let t0 = |r: &[TrajRow]| r.first().map_or(0.0, |x| x.t_s);
    let series = |f: &dyn Fn(&TrajRow) -> f64, suffix: &str| -> Vec<Series> {
        runs.iter()
            .map(|(name, rows)| {
                let s0 = t0(rows);
                Series::line(
                    format!("{name}{suffix}"),
                    rows.iter()
                        .step_by(10)
                        .map(|r| (r.t_s - s0, f(r)))
                        .collect(),
                )
            })
            .collect()
    };
    let mut out = vec![];
    let mut pos = series(&|r| r.ned_m[0].hypot(r.ned_m[1]), "");
    pos.iter_mut()
        .for_each(|s| s.label = format!("{} horizontal", s.label));
    out.push(NamedChart {
        stem: "position_error".into(),
        chart: Chart {
            title: "Horizontal position error".into(),
            x_label: "time [s]".into(),
            y_label: "m".into(),
            series: pos,
            ..Chart::default()
        },
    });
    let vel = series(&|r| r.v_mps[0].hypot(r.v_mps[1]), " horizontal");
    out.push(NamedChart {
        stem: "velocity_error".into(),
        chart: Chart {
            title: "Horizontal velocity error".into(),
            x_label: "time [s]".into(),
            y_label: "m/s".into(),
            series: vel,
            ..Chart::default()
        },
    });
    let mut att = series(&|r| angle_error_deg(r.rph_deg[0], base_rph_deg[0]), " roll");
    att.extend(series(
        &|r| angle_error_deg(r.rph_deg[1], base_rph_deg[1]),
        " pitch",
    ));
    out.push(NamedChart {
        stem: "roll_pitch_error".into(),
        chart: Chart {
            title: "Roll and pitch errors (base)".into(),
            x_label: "time [s]".into(),
            y_label: "deg".into(),
            series: att,
            ..Chart::default()
        },
    });
    let hdg = series(
        &|r| angle_error_deg(r.rph_deg[2], base_rph_deg[2]),
        " heading",
    );
    out.push(NamedChart {
        stem: "heading_error".into(),
        chart: Chart {
            title: "Heading error (base)".into(),
            x_label: "time [s]".into(),
            y_label: "deg".into(),
            series: hdg,
            ..Chart::default()
        },
    });
    out
}

/// RMS errors against the table rate per mode (Fig. 8/9/11/12 kinds).
pub fn reproduce_charts(rows: &[Row], imu: &str) -> Vec<NamedChart> {
    let modes = [
        "rotary-partial",
        "rotary-full",
        "rotary-best",
        "noise-floor",
    ];
    let by = |f: &dyn Fn(&Row) -> f64| -> Vec<Series> {
        let mut v: Vec<Series> = modes
            .iter()
            .map(|m| {
                Series::line(
                    *m,
                    rows.iter()
                        .filter(|r| r.mode == *m)
                        .map(|r| (r.rate_dps, f(r)))
                        .collect(),
                )
            })
            .collect();
        if let Some(c) = rows.iter().find(|r| r.mode == "conventional") {
            let mut s = Series::line("conventional", vec![(10.0, f(c)), (100.0, f(c))]);
            s.dashed = true;
            v.push(s);
        }
        v
    };
    let chart = |title: &str, unit: &str, f: &dyn Fn(&Row) -> f64, log: bool| Chart {
        title: format!("{imu}: {title}"),
        x_label: "table rate [deg/s]".into(),
        y_label: unit.into(),
        log_y: log,
        series: by(f),
        ..Chart::default()
    };
    let named = |stem: &str, chart: Chart| NamedChart {
        stem: stem.into(),
        chart,
    };
    vec![
        named(
            "rms_position",
            chart(
                "RMS horizontal position error",
                "m",
                &|r| r.h_pos_rms_m,
                true,
            ),
        ),
        named(
            "rms_velocity",
            chart(
                "RMS horizontal velocity error",
                "m/s",
                &|r| r.h_vel_rms_mps,
                true,
            ),
        ),
        named(
            "rms_roll_pitch",
            chart("RMS roll error", "deg", &|r| r.roll_rms_deg, true),
        ),
        named(
            "rms_heading",
            chart("RMS heading error", "deg", &|r| r.heading_rms_deg, true),
        ),
    ]
}
