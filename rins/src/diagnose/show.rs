//! Show: the text report a person reads in a minute, and the plots
//! (residuals before / after, the table-angle harmonic spectrum, Allan
//! deviation before / after).

use crate::plot::{Chart, Figure, PlotError, Series};
use ::diagnose::{Blocks, Diagnosis, CHANNELS};
use core_nav::units;
use std::fmt::Write as _;
use std::path::Path;

/// Engineering units of a channel's values: (scale from SI, unit).
fn eng(ch: usize) -> (f64, &'static str) {
    units::level(ch < 3)
}

/// A parameter in engineering units where the name says what it is and
/// a conversion says more than the SI value (`None`: the SI value is the
/// one to read: seconds, a ratio). One unit per quantity, as in the
/// book's units table: rates deg/h, angle random walk deg/sqrt(h),
/// forces ug, angles deg and arcsec, lengths mm, times ms.
fn eng_param(name: &str, v: f64) -> Option<String> {
    let (deg, ug, g) = (units::DEG_PER_RAD, units::UG_PER_MPS2, units::G0_MPS2);
    Some(if name.ends_with("_per_radps") {
        // A rate-squared coefficient (1/(rad/s)): per deg/s.
        format!("{:.4e} per deg/s", v / deg)
    } else if name.ends_with("_per_mps2") && !name.ends_with("radps_per_mps2") {
        // An accelerometer's squared term (1/(m/s^2)): ug per g^2.
        format!("{:.3} ug/g^2", v * g * ug)
    } else if name.ends_with("radps_per_mps2") {
        format!("{:.4} deg/h per g", v * units::DPH_PER_RADPS * g)
    } else if name.ends_with("radps_per_degc") {
        format!("{:.4} deg/h per degC", v * units::DPH_PER_RADPS)
    } else if name.ends_with("mps2_per_degc") {
        format!("{:.2} ug per degC", v * ug)
    } else if name.ends_with("_rad_per_sqrt_s") {
        format!("{:.3} deg/sqrt(h)", v * units::DEG_SQRTH_PER_RAD_SQRTS)
    } else if name.ends_with("_mps_per_sqrt_s") {
        format!("{:.2} ug/sqrt(Hz)", v * ug)
    } else if name.ends_with("_rad") {
        format!("{:.4} deg ({:.1} arcsec)", v * deg, v * deg * 3600.0)
    } else if name.ends_with("_radps") {
        format!("{:.3} deg/h", v * units::DPH_PER_RADPS)
    } else if name.ends_with("_mps2") {
        format!("{:.1} ug", v * ug)
    } else if name.ends_with("_m") {
        format!("{:.2} mm", v * 1e3)
    } else if name.ends_with("_s") && name.contains("time_offset") {
        format!("{:.3} ms", v * 1e3)
    } else {
        return None;
    })
}

/// `   [the value in engineering units]`, or nothing when there is no
/// conversion to show.
fn bracket(name: &str, v: f64) -> String {
    eng_param(name, v).map_or(String::new(), |e| format!("   [{e}]"))
}

/// The text report.
pub fn text(d: &Diagnosis, name: &str) -> String {
    let mut o = String::new();
    let det = &d.details;
    let dur = det.t_s.last().copied().unwrap_or(0.0) - det.t_s.first().copied().unwrap_or(0.0);
    let _ = writeln!(
        o,
        "{name}: {:.0} s at {:.0} Hz ([imu] rate_hz); nominal model fitted (bias, scale, misalignment), residual in {:.1} s blocks",
        dur,
        det.rate_hz,
        det.block_s
    );
    if det.segments.len() > 1 {
        let n: usize = det.segments.iter().map(|s| s.2).sum();
        let _ = writeln!(
            o,
            "  {} segments between gaps (over 2.5 sample periods; no block straddles one), {n} samples:",
            det.segments.len()
        );
        let show = 4;
        for (a, b, k) in det.segments.iter().take(show) {
            let _ = writeln!(o, "    {a:.3} .. {b:.3} s, {k} samples");
        }
        if det.segments.len() > show {
            let _ = writeln!(
                o,
                "    ... ({} more; all in the JSON)",
                det.segments.len() - show
            );
        }
    }
    if !det.unfollowed.is_empty() {
        let secs: f64 = det.unfollowed.iter().map(|(a, b)| b - a).sum();
        let _ = writeln!(
            o,
            "  the encoder track cannot follow the table over {} intervals between reads ({secs:.1} s in all; the JSON's track_unfollowed lists them)",
            det.unfollowed.len()
        );
    }
    if !det.accel_recorded {
        let _ = writeln!(
            o,
            "  gyro-only: no accelerometer columns, accelerometer terms not offered"
        );
    }
    if !det.ruled_out.is_empty() {
        let _ = writeln!(o, "\nruled out by the recording itself:");
        for (id, why) in &det.ruled_out {
            let _ = writeln!(o, "  {id}: {why}");
        }
    }
    let _ = writeln!(
        o,
        "\nnoise of the final residual (the Allan fit `rins allan` prints; its Gauss-Markov whitening model checked by Ljung-Box):"
    );
    for (ch, name) in CHANNELS.iter().enumerate() {
        if ch >= 3 && !det.accel_recorded {
            let _ = writeln!(o, "  {name:<14} not recorded");
            continue;
        }
        let a = det.allan.get(ch).copied().unwrap_or_default();
        let (q, lags) = det.whiteness.get(ch).copied().unwrap_or((0.0, 20));
        // Q is chi^2 with `lags` degrees of freedom when white: beyond 5
        // sigma the model leaves structure in this channel.
        let sd = (2.0 * lags as f64).sqrt();
        let verdict = if q > lags as f64 + 5.0 * sd {
            "NOT white: structure the model does not hold"
        } else {
            "white"
        };
        let _ = writeln!(
            o,
            "  {name:<14} {}; whitened Q({lags}) = {q:.0} ({verdict}; white is {lags} +- {sd:.0})",
            crate::allan::describe(ch, &a),
        );
        if let Some(i) = d.findings.iter().position(|f| {
            f.effect == hal_sim::catalogue::EffectId::UntrackedTableMotion
                && f.channels.contains(&ch)
        }) {
            let _ = writeln!(
                o,
                "  {:<14} (white: the sensor's own, as the quieter cross axis reads; the table's untracked motion is taken out of it: finding {})",
                "",
                i + 1
            );
        }
    }
    let _ = writeln!(o, "\nwhere the nominal residual is (rms, deg/h and ug):");
    let _ = write!(o, "  {:<14}", "");
    for c in CHANNELS {
        let _ = write!(o, " {:>9}", &c[..c.rfind('_').unwrap_or(c.len())]);
    }
    let _ = writeln!(o);
    for (label, v, n) in &det.locate.splits {
        let _ = write!(o, "  {label:<14}");
        for (ch, x) in v.iter().enumerate() {
            let _ = write!(o, " {:>9.1}", x * eng(ch).0);
        }
        let _ = writeln!(o, "   ({n} samples)");
    }
    if !det.locate.harmonics.is_empty() {
        let _ = writeln!(
            o,
            "  table-angle harmonics of the nominal residual (amplitude):"
        );
        for (k, v) in det.locate.harmonics.iter().enumerate().take(4) {
            let _ = write!(o, "  {:>2}x/rev       ", k + 1);
            for (ch, x) in v.iter().enumerate() {
                let _ = write!(o, " {:>9.1}", x * eng(ch).0);
            }
            let _ = writeln!(o);
        }
    }
    if let Some((r, h1)) = det.locate.angle_domain {
        let _ = writeln!(
            o,
            "  table-axis gyro against the encoder, angle domain: rms {:.1} arcsec, 1x/rev {:.1} arcsec",
            r.to_degrees() * 3600.0,
            h1.to_degrees() * 3600.0
        );
    }
    let _ = writeln!(o);
    if d.findings.is_empty() {
        let _ = writeln!(
            o,
            "no finding: the nominal model explains the recording down to its noise"
        );
    }
    for (i, f) in d.findings.iter().enumerate() {
        let _ = writeln!(
            o,
            "{}. {} on {}",
            i + 1,
            f.effect,
            f.channel_names().join(", ")
        );
        let _ = writeln!(o, "   {}", f.explanation);
        let _ = writeln!(o, "   where: {}", f.where_);
        for p in &f.parameters {
            let (k, x) = (&p.name, p.value);
            match p.sigma {
                Some(s) => {
                    let _ = writeln!(o, "   {k} = {x:.4e} +- {s:.1e}{}", bracket(k, x));
                }
                None => {
                    let _ = writeln!(o, "   {k} = {x:.4e}{}", bracket(k, x));
                }
            }
        }
        for k in &f.not_measured {
            let _ = writeln!(o, "   {k}: not measured here");
        }
        let _ = writeln!(
            o,
            "   how sure: delta BIC {:.0} (lower by 10 is very strong), SNR {:.1}, confidence {} (noise alone: p = {}, times the effects tried); held-out rms {:.3e} -> {:.3e}",
            f.delta_bic,
            f.snr,
            if f.confidence >= 0.9999 {
                "> 0.9999".to_string()
            } else {
                format!("{:.4}", f.confidence)
            },
            PValue(f.p_noise),
            f.fit.heldout_rms_before,
            f.fit.heldout_rms_after
        );
    }
    if !d.unexplained.is_empty() {
        let _ = writeln!(
            o,
            "\nlocated but not explained by any effect in the library:"
        );
        for u in &d.unexplained {
            let _ = writeln!(
                o,
                "  {} : {} (SNR {:.1})",
                u.channels.join(", "),
                u.where_,
                u.snr
            );
        }
    }
    if !det.not_observable.is_empty() {
        let _ = writeln!(
            o,
            "\nnot observable in this run (and the experiment that would show them):"
        );
        for (id, how) in &det.not_observable {
            let _ = writeln!(o, "  {id}: {how}");
        }
    }
    let _ = writeln!(
        o,
        "\nresidual rms per sample, before -> after the findings (deg/h, ug):"
    );
    let mut rose = vec![];
    for (ch, name) in CHANNELS.iter().enumerate() {
        let (s, _) = eng(ch);
        let (b, a) = (
            super::rms(&det.res_before[ch]) * s,
            super::rms(&det.res_after[ch]) * s,
        );
        let up = a > b * 1.0005;
        let _ = writeln!(
            o,
            "  {name:<14} {b:>10.1} -> {a:>10.1}{}",
            if up { "  (rises: see below)" } else { "" }
        );
        if up {
            rose.push((ch, *name, 100.0 * (a / b - 1.0)));
        }
    }
    for (ch, name, pct) in rose {
        let claims: Vec<String> = d
            .findings
            .iter()
            .filter(|f| f.channels.contains(&ch))
            .map(|f| f.effect.to_string())
            .collect();
        let _ = writeln!(
            o,
            "  {name} rises {pct:.1} %: the findings are fitted to 0.2 s block means weighted by the noise model, not to this per-sample figure{}",
            match claims.is_empty() {
                true => "; no finding claims this channel (its nominal terms were refitted with the others')".to_string(),
                false => format!(
                    "; {} claim it: each claims a channel only where it does not make the held-out blocks worse against the noise model (a finding that does is named in its text as not claimed there)",
                    claims.join(", ")
                ),
            }
        );
    }
    let next = next_steps(d, name);
    if !next.is_empty() {
        let _ = writeln!(o, "\nnext:");
        for n in next {
            let _ = writeln!(o, "  - {n}");
        }
    }
    o
}

/// A probability as printed: an underflow is a bound, not zero.
struct PValue(f64);

impl core::fmt::Display for PValue {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        if self.0 < 1e-300 {
            f.write_str("< 1e-300")
        } else {
            write!(f, "{:.1e}", self.0)
        }
    }
}

/// What to do next with this diagnosis of `name`: the sensor file it can
/// write, the runs that would show what this one cannot, what to check on
/// the rig for each finding that is the rig's.
fn next_steps(d: &Diagnosis, name: &str) -> Vec<String> {
    use hal_sim::catalogue::EffectId as E;
    let mut v = vec![format!(
        "write what was measured of the sensor as a sensor file: rins diagnose {name} --sensor-out my.toml (its noise, resolution, latency; the rest unknown or --sensor's)"
    )];
    for (id, how) in &d.details.not_observable {
        v.push(format!("to see {id}: {how}"));
    }
    for f in &d.findings {
        let check = match f.effect {
            E::LeverArm => "measure the sensor's offset from the table axis on the rig: the finding is that offset",
            E::AxisTilt => "check the table axis against the sensor's (a shim, or the mount's flatness)",
            E::TimeOffset => "check how the IMU and the encoder are time-stamped (a latency is a constant delay between them)",
            E::UntrackedTableMotion => "the table moves between encoder reads: read the encoder faster, or smooth the motor (microstepping, damping)",
            E::EncoderError => "check the encoder's disc and its mounting (an error repeating each turn)",
            E::TableAngleHarmonic => "check the table's bearing and drive for a once- or twice-per-turn error",
            E::TemperatureBias => "record the temperature through a warm-up: a longer run shows the coefficient better",
            _ => continue,
        };
        let line = format!("{}: {check}", f.effect);
        if !v.contains(&line) {
            v.push(line);
        }
    }
    v
}

/// The Allan deviation the noise model predicts at `tau` s: white
/// (`N^2 / tau`) plus first-order Gauss-Markov (sigma, correlation time
/// `T`): `2 sigma^2 T / tau [1 - T / (2 tau) (3 - 4 e^(-tau/T) + e^(-2 tau/T))]`,
/// which rises as `tau` (rate random walk) well below `T` and falls as white
/// noise well above it.
pub fn model_adev(n: &::diagnose::noise::Noise, tau: f64) -> f64 {
    let white = n.white_density().powi(2) / tau;
    let sig2 = n.gm_sigma().powi(2);
    let tc = n.tau_s();
    let gm = if n.lambda > 0.0 && tc.is_finite() {
        let x = tau / tc;
        2.0 * sig2 * tc / tau * (1.0 - (3.0 - 4.0 * (-x).exp() + (-2.0 * x).exp()) / (2.0 * x))
    } else if n.lambda > 0.0 {
        // A random walk: K^2 tau / 3 with K^2 the variance added per second.
        n.lambda * n.r / n.block_s * tau / 3.0
    } else {
        0.0
    };
    (white + gm.max(0.0)).sqrt()
}

/// Writes the plots into `dir`; returns the files written: per triad the
/// residuals' 1 s means and their Allan deviation (one chart per axis:
/// the nominal model's residual, the residual with the findings, and the
/// fitted noise model), and the harmonic spectrum against the table angle
/// (one chart per triad: each in its own unit).
///
/// # Errors
/// The directory or a file cannot be written.
pub fn plots(d: &Diagnosis, dir: &Path) -> Result<Vec<std::path::PathBuf>, PlotError> {
    let det = &d.details;
    let mut out = vec![];
    for (triad, label) in [(0usize, "gyro"), (1, "accel")] {
        let chs = 3 * triad..3 * triad + 3;
        let residuals = chs.clone().map(|ch| residual_chart(d, ch)).collect();
        out.extend(Figure { charts: residuals }.write(&dir.join(format!("residual_{label}")))?);
        let allan = chs.map(|ch| allan_chart(d, ch)).collect();
        out.extend(Figure { charts: allan }.write(&dir.join(format!("allan_{label}")))?);
    }
    let span = det.theta.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - det.theta.iter().copied().fold(f64::INFINITY, f64::min);
    if span >= 0.999 * core::f64::consts::TAU {
        let charts = harmonic_charts(d);
        out.extend(Figure { charts }.write(&dir.join("harmonics"))?);
    }
    Ok(out)
}

/// The residual of channel `ch` in 1 s means, before and after.
fn residual_chart(d: &Diagnosis, ch: usize) -> Chart {
    let det = &d.details;
    let bl = Blocks::new(
        &det.t_s,
        det.dt_s,
        ((1.0 / det.dt_s.max(1e-9)).round() as usize).max(1),
    );
    let tb: Vec<f64> = bl.mean(&det.t_s);
    let (s, unit) = eng(ch);
    let series = [
        ("nominal model", &det.res_before[ch]),
        ("with the findings", &det.res_after[ch]),
    ]
    .into_iter()
    .map(|(which, res)| {
        let b = bl.mean(res);
        Series::line(which, tb.iter().zip(&b).map(|(t, v)| (*t, v * s)).collect())
    })
    .collect();
    Chart {
        title: format!("{}: residual, 1 s means", CHANNELS[ch]),
        x_label: "time [s]".into(),
        y_label: format!("residual [{unit}]"),
        series,
        ..Chart::default()
    }
}

/// The Allan deviation of channel `ch`'s residual, before and after, and
/// the noise model fitted to it.
fn allan_chart(d: &Diagnosis, ch: usize) -> Chart {
    let det = &d.details;
    let (s, unit) = eng(ch);
    let mut series = vec![];
    let mut taus = vec![];
    for (which, res) in [
        ("nominal model", &det.res_before[ch]),
        ("with the findings", &det.res_after[ch]),
    ] {
        let pts: Vec<(f64, f64)> = core_nav::allan::octave_factors(res.len(), 20)
            .filter_map(|m| core_nav::allan::oadev(res, det.dt_s, m))
            .filter(|p| p.adev > 0.0)
            .map(|p| (p.tau_s, p.adev * s))
            .collect();
        taus = pts.iter().map(|p| p.0).collect();
        series.push(Series::line(which, pts));
    }
    if let Some(n) = det.noise.get(ch) {
        series.push(Series::points(
            "fitted noise model",
            taus.iter().map(|t| (*t, model_adev(n, *t) * s)).collect(),
        ));
    }
    Chart::allan(
        format!("{}: residual's Allan deviation", CHANNELS[ch]),
        unit,
        series,
    )
}

/// The residuals' amplitude at each harmonic of the table angle, before
/// (filled) and after (hollow): one chart per triad, each in its unit.
fn harmonic_charts(d: &Diagnosis) -> Vec<Chart> {
    let det = &d.details;
    let refs: Vec<&[f64]> = det
        .res_before
        .iter()
        .chain(det.res_after.iter())
        .map(Vec::as_slice)
        .collect();
    let all = super::locate::harmonics_all(&refs, &det.theta, super::locate::HARMONICS);
    [(0usize, "gyro"), (1, "accel")]
        .into_iter()
        .map(|(triad, label)| {
            let mut series = vec![];
            for ch in 3 * triad..3 * triad + 3 {
                let (s, _) = eng(ch);
                for (which, a, hollow) in
                    [("nominal", &all[ch], false), ("after", &all[6 + ch], true)]
                {
                    let mut se = Series::points(
                        format!("{} {which}", CHANNELS[ch]),
                        a.iter()
                            .enumerate()
                            .map(|(k, v)| ((k + 1) as f64, v * s))
                            .collect(),
                    );
                    se.hollow = hollow;
                    series.push(se);
                }
            }
            Chart {
                title: format!("{label} residual against the table angle: harmonic amplitudes"),
                x_label: "harmonic [cycles per revolution]".into(),
                y_label: format!("amplitude [{}]", eng(3 * triad).1),
                log_y: true,
                series,
                ..Chart::default()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::noise::Noise;

    #[test]
    fn model_adev_limits() {
        // White only: N / sqrt(tau).
        let w = Noise {
            block_s: 1.0,
            r: 4.0,
            lambda: 0.0,
            phi: 0.0,
            loglik: 0.0,
            quant: 0.0,
        };
        assert!((model_adev(&w, 4.0) - 1.0).abs() < 1e-12);
        // Gauss-Markov sigma 1, T = 100 s, no white: at tau >> T it falls as
        // white noise of density sqrt(2 T) sigma; its peak is ~0.62 sigma
        // near tau = 1.89 T (the textbook figure, e.g. IEEE Std 952).
        let phi = (-1.0f64 / 100.0).exp();
        let g = Noise {
            block_s: 1.0,
            r: 1e-12,
            lambda: (1.0 - phi * phi) / 1e-12,
            phi,
            loglik: 0.0,
            quant: 0.0,
        };
        let far = model_adev(&g, 1e6);
        assert!((far / (200.0f64 / 1e6).sqrt() - 1.0).abs() < 1e-3, "{far}");
        let peak = (1..400)
            .map(|k| model_adev(&g, k as f64))
            .fold(0.0, f64::max);
        assert!((peak - 0.62).abs() < 0.01, "{peak}");
    }
}

#[cfg(test)]
mod units_tests {
    use super::eng_param;

    #[test]
    fn brackets_are_real_conversions_or_absent() {
        // A rate-squared coefficient is per rad/s: per deg/s is pi/180 of
        // it (it was printed as if it were a rate, "-323.006 deg/h").
        let k2 = eng_param("k2_z_per_radps", -1.57e-3).unwrap();
        assert_eq!(k2, "-2.7402e-5 per deg/s");
        assert_eq!(eng_param("gyro_bias_z_radps", 1e-5).unwrap(), "2.063 deg/h");
        assert_eq!(
            eng_param("g_sens_xz_radps_per_mps2", 1e-5).unwrap(),
            "20.2277 deg/h per g"
        );
        // Seconds and ratios: the SI value is the one to read.
        assert_eq!(eng_param("gm_tau_x_s", 400.0), None);
        assert_eq!(eng_param("scale_x", 1e-3), None);
    }
}
