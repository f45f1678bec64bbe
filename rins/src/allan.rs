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

/// The terms of `f` its curve cannot support (null in the JSON: unknown,
/// never zero).
pub fn not_measured(f: &NoiseFit) -> Vec<&'static str> {
    let mut v = vec![];
    if f.white <= 0.0 {
        v.push("white_noise_density");
    }
    if !f.floor_seen {
        v.push("bias_instability");
    }
    // Terms the fit's chosen model left out (the curve did not need
    // them): not zero, unresolved.
    if f.rrw <= 0.0 {
        v.push("rate_random_walk");
    }
    if f.gm_sigma <= 0.0 {
        v.push("gauss_markov");
    }
    v
}

/// The `rins-allan/1` JSON: a term the curve cannot support is null and
/// named in the channel's `not_measured`.
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
                "white_noise_density": (c.fit.white > 0.0).then_some(c.fit.white),
                "white_noise_density_sigma": (c.fit.white > 0.0).then_some(c.fit.white_sigma),
                "bias_instability": c.fit.floor_seen.then_some(c.fit.bias_instability),
                "bias_instability_upper_bound": (!c.fit.floor_seen).then_some(c.fit.bias_instability),
                "not_measured": not_measured(&c.fit),
                "rate_random_walk": (c.fit.rrw > 0.0).then_some(c.fit.rrw),
                "gauss_markov_sigma": (c.fit.gm_sigma > 0.0).then_some(c.fit.gm_sigma),
                "gauss_markov_tau_s": (c.fit.gm_sigma > 0.0).then_some(c.fit.gm_tau_s),
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

/// The least number of fitted averaging times (from [`FIT_MIN_M`]
/// periods on) an Allan fit is reported from.
pub const MIN_FIT_POINTS: usize = 3;

/// Refuses a curve too short to fit: fewer than [`MIN_FIT_POINTS`]
/// averaging times from [`FIT_MIN_M`] periods on (the first octaves are
/// the sensor's own filter), with the longest gap-free span and the taus
/// it allows.
///
/// # Errors
/// The figures, in words.
pub fn supported(chs: &[ChannelAllan], rec: &Recording) -> Result<(), String> {
    let fitted = chs
        .first()
        .map_or(0, |c| c.points.iter().filter(|p| p.m >= FIT_MIN_M).count());
    if fitted >= MIN_FIT_POINTS {
        return Ok(());
    }
    let t: Vec<f64> = rec.imu.iter().map(|r| r.t_s).collect();
    let [a, b] = recording::clock::longest_gap_free(&t, rec.dt_s());
    let tau_max = chs
        .first()
        .and_then(|c| c.points.last())
        .map_or(0.0, |p| p.tau_s);
    Err(format!(
        "the longest gap-free span is {:.2} s ({a:.2}-{b:.2} s of {} pieces): it allows averaging times up to {tau_max:.3} s, {fitted} of them from {FIT_MIN_M} sample periods on, and a noise fit needs {MIN_FIT_POINTS}; no term is reported",
        b - a,
        rec.segments().len()
    ))
}

/// A text table.
pub fn report(chs: &[ChannelAllan]) -> String {
    let mut s = String::new();
    for (ch, c) in chs.iter().enumerate() {
        s += &format!("{:<14} {}\n", c.name, describe(ch, &c.fit));
    }
    s
}

/// A sensor file (`rins-sensor/2`) with the noise the curves measured
/// and the resolution and full scale the samples show
/// ([`crate::sensor_file::Written`]: per triad the RMS over its axes of
/// what every axis's curve supports); the rest from `base`, or unknown
/// without one.
pub fn sensor_file(
    chs: &[ChannelAllan],
    rec: &Recording,
    base: Option<crate::sensor_file::Base>,
    what: &str,
) -> String {
    let mut w = crate::sensor_file::Written::start(base, "allan", what);
    let fits: Vec<NoiseFit> = chs.iter().map(|c| c.fit).collect();
    w.noise(&fits, None, crate::sensor_file::Combine::Rms);
    w.seen_in_data(rec);
    w.text()
}
