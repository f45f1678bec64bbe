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
    let eng = |ch: usize, v: f64| v * core_nav::units::level(ch < 3).0;
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
    use crate::plot::{Chart, Figure, Series};
    let mut out = vec![];
    for (triad, label) in [(0usize, "gyro"), (1, "accel")] {
        let (scale, unit) = core_nav::units::level(triad == 0);
        // One chart per axis, one series per twin (with / without each
        // finding): a handful of lines a chart, not fifteen.
        let charts = (0..3)
            .map(|i| {
                let ch = 3 * triad + i;
                let series = r
                    .runs
                    .iter()
                    .filter_map(|run| {
                        let v = run.residuals.allan.get(ch).filter(|v| !v.is_empty())?;
                        Some(Series::line(
                            run.label.clone(),
                            v.iter().map(|(t, a)| (*t, a * scale)).collect(),
                        ))
                    })
                    .collect();
                Chart::allan(
                    format!(
                        "{}: recording minus its twin, Allan deviation (with / without each finding)",
                        CHANNELS[ch]
                    ),
                    unit,
                    series,
                )
            })
            .collect();
        out.extend(Figure { charts }.write(&dir.join(format!("twin_allan_{label}")))?);
    }
    Ok(out)
}
