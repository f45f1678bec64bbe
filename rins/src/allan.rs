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

/// Computes all six channels of `rec`.
pub fn compute(rec: &Recording) -> Vec<ChannelAllan> {
    let tau0 = 1.0 / rec.meta.imu_rate_hz;
    (0..6)
        .map(|c| {
            let y = rec.channel(c);
            let points: Vec<AdevPoint> = octave_factors(y.len(), MIN_TERMS)
                .filter_map(|m| oadev(&y, tau0, m))
                .collect();
            let fitted: Vec<AdevPoint> = points
                .iter()
                .copied()
                .filter(|p| p.m >= FIT_MIN_M)
                .collect();
            let fit =
                fit_noise(if fitted.len() >= 3 { &fitted } else { &points }).unwrap_or_default();
            ChannelAllan {
                name: CHANNELS[c],
                points,
                fit,
            }
        })
        .collect()
}

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
                "bias_instability": c.fit.bias_instability,
                "rate_random_walk": c.fit.rrw,
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
    let mut s = String::from(
        "channel          white noise          bias instability     rate random walk\n",
    );
    for c in chs {
        let (w, b, k) = if c.name.starts_with("gyro") {
            (
                format!("{:.3} deg/sqrt(h)", c.fit.white.to_degrees() * 60.0),
                format!("{:.2} deg/h", c.fit.bias_instability.to_degrees() * 3600.0),
                format!(
                    "{:.3} deg/h/sqrt(h)",
                    c.fit.rrw.to_degrees() * 3600.0 * 60.0
                ),
            )
        } else {
            (
                format!("{:.4} m/s/sqrt(h)", c.fit.white * 60.0),
                format!("{:.1} ug", c.fit.bias_instability / 9.80665e-6),
                format!("{:.3e} m/s^2/sqrt(s)", c.fit.rrw),
            )
        };
        s += &format!("{:<16} {w:<20} {b:<20} {k}\n", c.name);
    }
    s
}
