//! `rins allan`: Allan deviation of the six IMU channels, noise fit, JSON
//! (`rins-allan/1`) and a plot.

use crate::plot::{Chart, Dash, Figure, Series};
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

/// Two charts (gyro above, accel below) in one figure, in the book's
/// units (deg/h, ug).
pub fn figure(chs: &[ChannelAllan], title: &str) -> Figure {
    let chart = |range: std::ops::Range<usize>, what: &str| {
        let mut series = vec![];
        let (k, unit) = core_nav::units::level(range.start < 3);
        for c in &chs[range] {
            let axis = c.name.rsplit_once('_').map_or(c.name, |(a, _)| a);
            let mut s = Series::line(
                format!("{axis} (bars: 68 % confidence)"),
                c.points.iter().map(|p| (p.tau_s, p.adev * k)).collect(),
            );
            s.bars = Some(c.points.iter().map(|p| (p.lo * k, p.hi * k)).collect());
            series.push(s);
            series.push(
                Series::line(
                    format!("{axis} noise fit"),
                    c.points
                        .iter()
                        .map(|p| (p.tau_s, c.fit.adev_at(p.tau_s) * k))
                        .collect(),
                )
                .with_dash(Dash::Dashed),
            );
        }
        Chart::allan(format!("{title}: {what}"), unit, series)
    };
    Figure {
        charts: vec![chart(0..3, "gyroscopes"), chart(3..6, "accelerometers")],
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

/// A sensor file (`rins-sensor/1`) with the noise the curves measured:
/// per triad the RMS over its axes of the white noise, the rate random
/// walk and the Allan floor (the fit's bias instability B times
/// [`core_nav::allan::FLOOR_OVER_B`]), and the correlation time of the
/// fitted Gauss-Markov bias (else the floor's tau over 1.89, where a
/// Gauss-Markov process's Allan deviation peaks). Everything Allan cannot
/// see comes from `base` (zero without one).
pub fn sensor_file(
    chs: &[ChannelAllan],
    base: Option<hal_sim::imu::ImuSpec>,
    what: &str,
) -> String {
    let mut spec = base.unwrap_or_else(|| hal_sim::imu::ImuSpec {
        name: "measured".into(),
        model: "measured".into(),
        ..hal_sim::imu::ImuSpec::ideal()
    });
    let from = spec.name.clone();
    spec.name = format!("{from}-measured");
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let mut notes = vec![
        format!("Written by rins allan from {what}: the noise terms below are measured"),
        format!("(the RMS over the axes); the rest is {from:?}'s."),
    ];
    for (k, triad) in [(0usize, &mut spec.gyro), (3, &mut spec.accel)] {
        let axes: Vec<&ChannelAllan> = chs.iter().skip(k).take(3).collect();
        if axes.len() < 3 {
            continue;
        }
        let fits: Vec<&NoiseFit> = axes.iter().map(|c| &c.fit).collect();
        triad.white = rms(&fits.iter().map(|f| f.white).collect::<Vec<_>>());
        triad.rrw = rms(&fits.iter().map(|f| f.rrw).collect::<Vec<_>>());
        let floor = core_nav::allan::FLOOR_OVER_B
            * rms(&fits.iter().map(|f| f.bias_instability).collect::<Vec<_>>());
        triad.bias_instability = floor / hal_sim::sensor::ALLAN_PEAK_PER_GM_SIGMA;
        let taus: Vec<f64> = axes
            .iter()
            .map(|c| match c.fit.gm_tau_s {
                t if t > 0.0 => t,
                _ => c
                    .points
                    .iter()
                    .min_by(|a, b| a.adev.total_cmp(&b.adev))
                    .map_or(100.0, |p| p.tau_s / 1.89),
            })
            .collect();
        triad.bi_tau_s = taus.iter().sum::<f64>() / 3.0;
        for c in &axes {
            notes.push(format!(
                "{}: white {:.4e}, bias instability B {:.4e}, rrw {:.4e} (SI)",
                c.name, c.fit.white, c.fit.bias_instability, c.fit.rrw
            ));
        }
    }
    hal_sim::sensor::write(&spec, &notes)
}
