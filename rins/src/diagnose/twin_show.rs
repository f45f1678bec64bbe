//! The twin report for a person: the closeness table and the residual by
//! motion as text, the Allan deviation of the recording minus each twin as
//! plots.

use crate::diagnose::CHANNELS;
use ::diagnose::twin::{TwinReport, CLOSENESS_BLOCK_S, GOOD_RATIO, TWIN_SEEDS};

/// The twin report as text.
pub fn text(r: &TwinReport) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "\nThe twin (hal-sim re-simulating this run with the fitted model; {} seeds, {:.0} s block means):\n",
        TWIN_SEEDS, CLOSENESS_BLOCK_S
    ));
    s.push_str(&format!(
        "  {:<34} {}  worst  verdict\n",
        "twin",
        CHANNELS.map(|c| format!("{c:>13}")).join("")
    ));
    for run in &r.runs {
        let ratio = run.closeness.ratio();
        let (wc, w) = run.closeness.worst();
        s.push_str(&format!(
            "  {:<34} {}  {:>5.2}  {}\n",
            run.label,
            ratio.map(|x| format!("{x:>13.2}")).join(""),
            w,
            if w <= GOOD_RATIO {
                let (lc, lo) = ratio
                    .iter()
                    .enumerate()
                    .fold(
                        (0, f64::INFINITY),
                        |a, (c, r)| if *r < a.1 { (c, *r) } else { a },
                    );
                if lo < 1.0 / GOOD_RATIO {
                    format!(
                        "good (the twin is noisier than the recording on {})",
                        CHANNELS[lc]
                    )
                } else {
                    "good".to_string()
                }
            } else {
                format!("{} farther than a twin", CHANNELS[wc])
            }
        ));
    }
    s.push_str(&format!(
        "  (recording-to-twin over twin-to-twin rms of 1 s means; good at <= {GOOD_RATIO})\n"
    ));
    s.push_str("  the recording minus the noise-free twin, rms of 0.2 s means by motion (deg/h gyro, ug accel):\n");
    let eng = |ch: usize, v: f64| {
        if ch < 3 {
            v.to_degrees() * 3600.0
        } else {
            v / 9.806_65e-6
        }
    };
    for run in &r.runs {
        for (k, (label, v, n)) in run.residuals.by_part.iter().enumerate() {
            s.push_str(&format!(
                "    {:<34} {:<14} {} ({n} blocks)\n",
                if k == 0 { run.label.as_str() } else { "" },
                label,
                (0..6)
                    .map(|ch| format!("{:>9.1}", eng(ch, v[ch])))
                    .collect::<String>()
            ));
        }
        if let Some(h1) = run.residuals.harmonics.first() {
            s.push_str(&format!(
                "    {:<34} {:<14} {}\n",
                "",
                "1x harmonic",
                (0..6)
                    .map(|ch| format!("{:>9.1}", eng(ch, h1[ch])))
                    .collect::<String>()
            ));
        }
    }
    s
}

/// Plots: the recording's residual against each twin, Allan deviation per
/// triad (`twin_allan_gyro`, `twin_allan_accel`).
///
/// # Errors
/// Writing the files.
pub fn plots(
    r: &TwinReport,
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>, crate::plot::PlotError> {
    use crate::plot::{Chart, Series};
    let mut out = vec![];
    for (triad, label, unit, scale) in [
        (
            0usize,
            "gyro",
            "deg/h",
            180.0 / std::f64::consts::PI * 3600.0,
        ),
        (1, "accel", "ug", 1.0 / 9.806_65e-6),
    ] {
        let mut c = Chart {
            title: format!(
                "{label}: recording minus its twin, Allan deviation (with / without each finding)"
            ),
            x_label: "tau (s)".into(),
            y_label: unit.into(),
            log_x: true,
            log_y: true,
            ..Chart::default()
        };
        for i in 0..3 {
            let ch = 3 * triad + i;
            for (k, run) in r.runs.iter().enumerate() {
                let pts: Vec<(f64, f64)> = run
                    .residuals
                    .allan
                    .get(ch)
                    .map(|v| v.iter().map(|(t, a)| (*t, a * scale)).collect())
                    .unwrap_or_default();
                if pts.is_empty() {
                    continue;
                }
                let mut se = Series::line(format!("{} {}", CHANNELS[ch], run.label), pts);
                se.dashed = k > 0;
                c.series.push(se);
            }
        }
        out.extend(c.write(&dir.join(format!("twin_allan_{label}")))?);
    }
    Ok(out)
}
