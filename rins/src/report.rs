//! Plots of navigation runs (the paper's Fig. 7-12 kinds): position and
//! velocity errors, roll / pitch / heading errors over time, and errors
//! against the table rate.

use crate::nav::{StaticErrors, TrajRow};
use crate::plot::{Chart, Dash, PlotError, Series};
use crate::reproduce::{Row, PAPER, RATES_DPS};
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
    let chart =
        |stem: &str, title: &str, y_label: &str, log_y: bool, series: Vec<Series>| NamedChart {
            stem: stem.into(),
            chart: Chart {
                title: title.into(),
                x_label: "time [s]".into(),
                y_label: y_label.into(),
                log_y,
                series,
                ..Chart::default()
            },
        };
    let mut att = series(&|r| angle_error_deg(r.rph_deg[0], base_rph_deg[0]), " roll");
    att.extend(series(
        &|r| angle_error_deg(r.rph_deg[1], base_rph_deg[1]),
        " pitch",
    ));
    // Position and velocity errors grow by decades: log axes, so that the
    // smaller run is not a flat line under the larger.
    vec![
        chart(
            "position_error",
            "Horizontal position error",
            "horizontal position error [m]",
            true,
            series(&|r| r.ned_m[0].hypot(r.ned_m[1]), ""),
        ),
        chart(
            "velocity_error",
            "Horizontal velocity error",
            "horizontal velocity error [m/s]",
            true,
            series(&|r| r.v_mps[0].hypot(r.v_mps[1]), ""),
        ),
        chart(
            "roll_pitch_error",
            "Roll and pitch errors (against the base)",
            "angle error [deg]",
            false,
            att,
        ),
        chart(
            "heading_error",
            "Heading error (against the base)",
            "heading error [deg]",
            false,
            series(&|r| angle_error_deg(r.rph_deg[2], base_rph_deg[2]), ""),
        ),
    ]
}

/// RMS errors against the table rate per mode (Fig. 8/9/11/12 kinds):
/// each mode's mean over the runs with the runs' spread (lowest to
/// highest) as bars, the conventional run's mean as a level, and the
/// paper's published means over all rates as dashed levels where it gives
/// them (position and velocity).
pub fn reproduce_charts(rows: &[Row], imu: &str) -> Vec<NamedChart> {
    let modes = [
        "rotary-partial",
        "rotary-full",
        "rotary-best",
        "noise-floor",
    ];
    let (r0, r1) = (RATES_DPS[0], RATES_DPS[RATES_DPS.len() - 1]);
    let by = |f: &dyn Fn(&StaticErrors) -> f64, paper: Option<usize>| -> Vec<Series> {
        let mut v: Vec<Series> = modes
            .iter()
            .map(|m| {
                let mine: Vec<&Row> = rows.iter().filter(|r| r.mode == *m).collect();
                let mut s = Series::line(
                    *m,
                    mine.iter().map(|r| (r.rate_dps, f(&r.mean()))).collect(),
                );
                s.bars = Some(mine.iter().map(|r| spread(&r.runs, f)).collect());
                s
            })
            .collect();
        if let Some(c) = rows.iter().find(|r| r.mode == "conventional") {
            let y = f(&c.mean());
            v.push(
                Series::line("conventional (still)", vec![(r0, y), (r1, y)])
                    .with_dash(Dash::LongDash),
            );
        }
        for (_, mode, pos, vel) in PAPER.iter().filter(|(i, ..)| *i == imu) {
            if let Some(k) = paper {
                let y = [*pos, *vel][k];
                v.push(
                    Series::line(
                        format!("paper: {mode}, mean over rates"),
                        vec![(r0, y), (r1, y)],
                    )
                    .with_dash(Dash::Dashed),
                );
            }
        }
        v
    };
    let chart = |stem: &str,
                 title: &str,
                 unit: &str,
                 f: &dyn Fn(&StaticErrors) -> f64,
                 paper: Option<usize>| NamedChart {
        stem: stem.into(),
        chart: Chart {
            title: format!("{imu}: {title} (bars: the runs' spread)"),
            x_label: "table rate [deg/s]".into(),
            y_label: unit.into(),
            log_y: true,
            series: by(f, paper),
            ..Chart::default()
        },
    };
    vec![
        chart(
            "rms_position",
            "RMS horizontal position error over 5 min",
            "RMS horizontal position error [m]",
            &|e| e.h_pos_rms_m,
            Some(0),
        ),
        chart(
            "rms_velocity",
            "RMS horizontal velocity error over 5 min",
            "RMS horizontal velocity error [m/s]",
            &|e| e.h_vel_rms_mps,
            Some(1),
        ),
        chart(
            "rms_roll_pitch",
            "RMS level error (roll and pitch) over 5 min",
            "RMS level error [deg]",
            &|e| e.roll_rms_deg.hypot(e.pitch_rms_deg) / 2f64.sqrt(),
            None,
        ),
        chart(
            "rms_heading",
            "RMS heading error over 5 min",
            "RMS heading error [deg]",
            &|e| e.heading_rms_deg,
            None,
        ),
    ]
}

/// The lowest and highest of `f` over `runs`.
fn spread(runs: &[StaticErrors], f: &dyn Fn(&StaticErrors) -> f64) -> (f64, f64) {
    runs.iter()
        .map(f)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        })
}
