//! `rins allan`: Allan deviation of the six IMU channels, noise fit, JSON
//! (`rins-allan/1`) and a plot.

use crate::plot::{Chart, Figure, Series};
use core_nav::allan::{AdevPoint, NoiseFit};
pub use diagnose::noise_terms::{describe, fit_channel, CHANNELS, FIT_MIN_M, MIN_TERMS};
use recording::Recording;
use serde_json::{json, Map, Value};

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

/// Computes all six channels of `rec` (the accelerometers of a gyro-only
/// recording are left out; no Allan difference straddles a gap).
pub fn compute(rec: &Recording) -> Vec<ChannelAllan> {
    let tau0 = rec.dt_s();
    let segs: Vec<_> = rec
        .segments()
        .iter()
        .map(recording::Segment::range)
        .collect();
    (0..if rec.gyro_only { 3 } else { 6 })
        .map(|c| {
            let (points, fit) = fit_channel(&rec.channel(c), tau0, &segs);
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
