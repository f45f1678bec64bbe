//! `rins allan`: Allan deviation of the six IMU channels, noise fit, JSON
//! (`rins-allan/1`) and a plot.

use crate::plot::{Chart, Figure, Series};
use core_nav::allan::{fit_noise, oadev, octave_factors, AdevPoint, NoiseFit};
use recording::Recording;
use serde_json::{json, Map, Value};

/// The channel names, in the recording's column order (recording-v1).
pub const CHANNELS: [&str; 6] = {
    let c = recording::IMU_COLS;
    [c[1], c[2], c[3], c[4], c[5], c[6]]
};

/// Octaves need at least this many second differences to be shown.
pub const MIN_TERMS: usize = 10;
/// The fit starts at this many sample periods: the first octaves are shaped
/// by the sensor's own anti-alias / decimation filter (seen on the ADIS16405).
pub const FIT_MIN_M: usize = 10;

/// One channel's curve and fit.
#[derive(Clone, Debug)]
pub struct ChannelAllan {
    /// Channel name.
    pub name: &'static str,
    /// Points at octave taus.
    pub points: Vec<AdevPoint>,
    /// Fitted noise terms.
    pub fit: NoiseFit,
}

/// The Allan curve of one channel's samples `y` (period `tau0_s`) and its
/// noise fit: the one noise estimator `rins allan` and diagnose both print.
pub fn fit_channel(y: &[f64], tau0_s: f64) -> (Vec<AdevPoint>, NoiseFit) {
    let points: Vec<AdevPoint> = octave_factors(y.len(), MIN_TERMS)
        .filter_map(|m| oadev(y, tau0_s, m))
        .collect();
    let fitted: Vec<AdevPoint> = points
        .iter()
        .copied()
        .filter(|p| p.m >= FIT_MIN_M)
        .collect();
    let fit = fit_noise(if fitted.len() >= 3 { &fitted } else { &points }).unwrap_or_default();
    (points, fit)
}

/// Computes all six channels of `rec` (the accelerometers of a gyro-only
/// recording are left out).
pub fn compute(rec: &Recording) -> Vec<ChannelAllan> {
    let tau0 = rec.dt_s();
    (0..if rec.gyro_only { 3 } else { 6 })
        .map(|c| {
            let (points, fit) = fit_channel(&rec.channel(c), tau0);
            ChannelAllan {
                name: CHANNELS[c],
                points,
                fit,
            }
        })
        .collect()
}

/// One channel's noise terms as a person reads them, in the book's units
/// (gyro: deg/sqrt(h), deg/h; accelerometer: ug/sqrt(Hz), ug).
pub fn describe(channel: usize, f: &NoiseFit) -> String {
    let gyro = channel < 3;
    let (dens, level) = if gyro {
        (
            180.0 / core::f64::consts::PI * 60.0,
            180.0 / core::f64::consts::PI * 3600.0,
        )
    } else {
        (1e6 / G0, 1e6 / G0)
    };
    let (du, lu) = if gyro {
        ("deg/sqrt(h)", "deg/h")
    } else {
        ("ug/sqrt(Hz)", "ug")
    };
    let mut s = format!(
        "white {:.3} +- {:.3} {du}, bias instability {:.2} {lu}",
        f.white * dens,
        f.white_sigma * dens,
        f.bias_instability * level
    );
    if f.gm_sigma > 0.0 {
        s += &format!(
            ", Gauss-Markov {:.2} {lu} over {:.0} s",
            f.gm_sigma * level,
            f.gm_tau_s
        );
    }
    if f.rrw > 0.0 {
        s += &format!(", rate random walk {:.3e} {lu}/sqrt(s)", f.rrw * level);
    }
    s
}

/// Standard gravity, m/s^2 (the unit g of ug).
const G0: f64 = 9.806_65;

/// The `rins-allan/1` JSON.
pub fn to_json(chs: &[ChannelAllan]) -> Value {
    let mut m = Map::new();
    for c in chs {
        m.insert(
            c.name.to_string(),
            json!({
                "tau_s": c.points.iter().map(|p| p.tau_s).collect::<Vec<_>>(),
                "adev": c.points.iter().map(|p| p.adev).collect::<Vec<_>>(),
                "adev_lo": c.points.iter().map(|p| p.lo).collect::<Vec<_>>(),
                "adev_hi": c.points.iter().map(|p| p.hi).collect::<Vec<_>>(),
                "white_noise_density": c.fit.white,
                "white_noise_density_sigma": c.fit.white_sigma,
                "bias_instability": c.fit.bias_instability,
                "rate_random_walk": c.fit.rrw,
                "gauss_markov_sigma": c.fit.gm_sigma,
                "gauss_markov_tau_s": c.fit.gm_tau_s,
            }),
        );
    }
    json!({ "format": "rins-allan/1", "channels": Value::Object(m) })
}

/// Two charts (gyro above, accel below) in one figure.
pub fn figure(chs: &[ChannelAllan], title: &str) -> Figure {
    let chart = |range: std::ops::Range<usize>, unit: &str, what: &str| {
        let mut series = vec![];
        for c in &chs[range] {
            let mut s = Series::line(c.name, c.points.iter().map(|p| (p.tau_s, p.adev)).collect());
            s.bars = Some(c.points.iter().map(|p| (p.lo, p.hi)).collect());
            series.push(s);
            let mut f = Series::line(
                format!("fit {}", c.name.rsplit_once('_').map_or(c.name, |(a, _)| a)),
                c.points
                    .iter()
                    .map(|p| (p.tau_s, c.fit.adev_at(p.tau_s)))
                    .collect(),
            );
            f.dashed = true;
            series.push(f);
        }
        Chart {
            title: format!("{title}: {what}"),
            x_label: "averaging time tau [s]".into(),
            y_label: format!("Allan deviation [{unit}]"),
            log_x: true,
            log_y: true,
            series,
        }
    };
    Figure {
        charts: vec![
            chart(0..3, "rad/s", "gyroscopes"),
            chart(3..6, "m/s^2", "accelerometers"),
        ],
    }
}

/// A text table.
pub fn report(chs: &[ChannelAllan]) -> String {
    let mut s = String::new();
    for (ch, c) in chs.iter().enumerate() {
        s += &format!("{:<14} {}\n", c.name, describe(ch, &c.fit));
    }
    s
}
