//! Alignment of a still base (`rins navigate` without GNSS): levelling from
//! the accelerometers and gyrocompassing from the gyros over the
//! recording's still start, each with its 1-sigma, and the heading taken
//! from `meta.toml` (and said so) where the gyros cannot resolve the
//! earth's rate. A moving base is aligned by the aided navigator
//! ([`crate::aided::align`]).
//!
//! The samples are taken into the base's frame `b` through the encoder
//! (`f_b = c_s_b f_s`, `w_b = c_s_b (w_s - theta_dot k)`) and averaged over
//! whole table turns when the table turns: a sensor bias across the table
//! axis then averages out in `b` (the rotation's point), so a MEMS gyro
//! whose turn-on bias is a hundred times the earth's rate can still find
//! north on a turning table, and cannot on a still one.

use anyhow::{bail, Result};
use core_nav::align::{coarse_level, gyrocompass};
use core_nav::attitude::{quat_to_dcm, Euler};
use core_nav::table::q_s_b;
use hal_sim::imu::ImuSpec;
use nalgebra::Vector3;
use recording::track::EncoderTrack;
use recording::Recording;

/// The still start averaged, s (at most).
pub const ALIGN_S: f64 = 60.0;
/// Shorter than this, no alignment, s.
pub const MIN_ALIGN_S: f64 = 10.0;
/// A gyrocompass heading with a larger 1-sigma is not used, deg.
pub const MAX_HEADING_SIGMA_DEG: f64 = 10.0;

/// The alignment of a still base.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StaticAlignment {
    /// The samples averaged: first and last time, s.
    pub window_s: [f64; 2],
    /// Whole table turns averaged over (0: under one turn).
    pub turns: f64,
    /// The table angle's range over the window, deg (0: the table still).
    pub swing_deg: f64,
    /// Roll, pitch, heading of `b` in `n`, deg (heading in [0, 360)).
    pub euler_deg: [f64; 3],
    /// Their 1-sigma, deg (NaN: not known without a sensor profile; the
    /// heading's NaN when it is `meta.toml`'s).
    pub sigma_deg: [f64; 3],
    /// The heading is the gyrocompass's (else `meta.toml`'s).
    pub gyrocompassed: bool,
    /// Why the heading is `meta.toml`'s, when it is.
    pub heading_note: Option<String>,
}

/// The samples of the still start in `b`: their mean specific force and
/// rate, the turns, and the window.
struct Means {
    f_b: Vector3<f64>,
    w_b: Vector3<f64>,
    turns: f64,
    swing_deg: f64,
    window_s: [f64; 2],
}

/// Averages the base's specific force and rate from the first sample at or
/// after `start_s` over [`ALIGN_S`], cut to whole turns when the table
/// turns at least one.
fn means(rec: &Recording, start_s: f64) -> Result<Means> {
    let Some(first) = rec.imu.iter().position(|r| r.t_s >= start_s) else {
        bail!("no IMU sample at or after {start_s} s");
    };
    let t0 = rec.imu[first].t_s;
    let rows: Vec<_> = rec.imu[first..]
        .iter()
        .take_while(|r| r.t_s < t0 + ALIGN_S)
        .collect();
    let track = (!rec.table.is_empty()).then(|| EncoderTrack::of(rec));
    let at = |t: f64| {
        track
            .as_ref()
            .map_or((0.0, 0.0), |tr| (tr.at(t).theta, tr.at(t).rate))
    };
    let theta0 = at(t0).0;
    let swept = rows.last().map_or(0.0, |r| (at(r.t_s).0 - theta0).abs());
    let whole = (swept / core::f64::consts::TAU).floor();
    let k = rec.meta.axis.unit::<f64>();
    let (mut f_b, mut w_b, mut n, mut last) = (Vector3::zeros(), Vector3::zeros(), 0usize, t0);
    let (mut lo, mut hi) = (theta0, theta0);
    for r in rows {
        let (theta, rate) = at(r.t_s);
        lo = lo.min(theta);
        hi = hi.max(theta);
        if whole >= 1.0 && (theta - theta0).abs() > whole * core::f64::consts::TAU {
            break;
        }
        let c_s_b = quat_to_dcm(&q_s_b(rec.meta.axis, theta));
        f_b += c_s_b * Vector3::from(r.accel_mps2);
        w_b += c_s_b * (Vector3::from(r.gyro_radps) - k * rate);
        n += 1;
        last = r.t_s;
    }
    if last - t0 < MIN_ALIGN_S {
        bail!(
            "the run from {t0} s is {:.1} s long; alignment needs {MIN_ALIGN_S} s",
            last - t0
        );
    }
    let nf = n as f64;
    Ok(Means {
        f_b: f_b / nf,
        w_b: w_b / nf,
        turns: whole,
        swing_deg: (hi - lo).to_degrees(),
        window_s: [t0, last],
    })
}

/// Aligns the still base of `rec` from `start_s` on; `profile` gives the
/// sensor's noise and turn-on biases for the sigmas (without one, the
/// sigmas the biases set are unknown and the heading is gyrocompassed
/// only on a table turning about a vertical axis).
///
/// # Errors
/// A moving base, a gyro-only recording, a start too short to align on, a
/// mean specific force that is not gravity (the base was not still).
pub fn align(rec: &Recording, start_s: f64, profile: Option<&ImuSpec>) -> Result<StaticAlignment> {
    let m = &rec.meta;
    if rec.moving.is_some() {
        bail!("a moving base is aligned by navigate --gnss");
    }
    rec.require_accel("alignment")
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mm = means(rec, start_s)?;
    let site = m.site();
    let g = site.gravity_mps2;
    let meta_heading = m.heading_deg.to_radians();
    let level = coarse_level(&mm.f_b, g, meta_heading).map_err(|_| {
        anyhow::anyhow!(
            "the mean specific force from {} to {} s is {:.3} m/s^2, not gravity ({g:.3}): the base was not still",
            mm.window_s[0],
            mm.window_s[1],
            mm.f_b.norm()
        )
    })?;
    let s = sigmas(rec, &mm, &level, profile, g);
    let psi = gyrocompass(&mm.w_b, &level);
    let resolved = s.heading_rad.is_finite() && s.heading_rad.to_degrees() <= MAX_HEADING_SIGMA_DEG;
    let heading_note = (!resolved).then(|| {
        format!(
            "the gyros do not resolve the earth's rate here ({}, against its horizontal {:.1} deg/h): heading from meta.toml",
            if s.rate_radps.is_finite() {
                format!("{:.1} deg/h of error", s.rate_radps.to_degrees() * 3600.0)
            } else {
                "their bias or noise unknown: no sensor profile, or its file does not know them".to_string()
            },
            s.earth_h_radps.to_degrees() * 3600.0
        )
    });
    let heading = if resolved { psi } else { meta_heading };
    Ok(StaticAlignment {
        window_s: mm.window_s,
        turns: mm.turns,
        swing_deg: mm.swing_deg,
        euler_deg: [
            level.roll.to_degrees(),
            level.pitch.to_degrees(),
            heading.to_degrees().rem_euclid(360.0),
        ],
        sigma_deg: [
            s.level_rad.to_degrees(),
            s.level_rad.to_degrees(),
            if resolved {
                s.heading_rad.to_degrees()
            } else {
                f64::NAN
            },
        ],
        gyrocompassed: resolved,
        heading_note,
    })
}

/// The alignment's 1-sigma: level and heading (rad), the rate error and
/// the earth's horizontal rate (rad/s).
struct Sigmas {
    level_rad: f64,
    heading_rad: f64,
    rate_radps: f64,
    earth_h_radps: f64,
}

/// What is left of a bias in `b` after the average (all of it on a still
/// table; on a turning one its part along the axis, of which only the
/// horizontal share `|k_h|` tilts or turns the solution), the white noise
/// over the window, the encoder's rate error over it (across a
/// non-vertical axis), and a level error's share of the vertical earth
/// rate (`tan(lat)` of it in heading).
fn sigmas(
    rec: &Recording,
    mm: &Means,
    level: &Euler<f64>,
    profile: Option<&ImuSpec>,
    g: f64,
) -> Sigmas {
    let m = &rec.meta;
    let t = (mm.window_s[1] - mm.window_s[0]).max(1e-3);
    let k_l = quat_to_dcm(&core_nav::attitude::euler_to_quat(&Euler {
        heading: 0.0,
        ..*level
    })) * m.axis.unit::<f64>();
    let k_h = k_l.x.hypot(k_l.y);
    let share = if mm.turns >= 1.0 { k_h } else { 1.0 };
    // A term the sensor file does not know is NaN here: the sigma it
    // feeds is unknown, never a zero.
    let known = |p: &ImuSpec, key: &str, v: f64| {
        if p.unknown.iter().any(|u| u == key) {
            f64::NAN
        } else {
            v
        }
    };
    let (ba, bg, vrw, arw) = profile.map_or((f64::NAN, f64::NAN, f64::NAN, f64::NAN), |p| {
        use hal_sim::sensor::terms as k;
        (
            known(p, k::ACCEL_BIAS, p.accel.bias),
            known(p, k::GYRO_BIAS, p.gyro.bias),
            known(p, k::ACCEL_NOISE, p.accel.white),
            known(p, k::GYRO_NOISE, p.gyro.white),
        )
    });
    // A bias that the turns average away counts for nothing, known or not.
    let left = |b: f64| if share < 1e-3 { 0.0 } else { share * b };
    let enc = if rec.table.is_empty() || mm.turns < 1.0 {
        0.0
    } else {
        k_h * core::f64::consts::SQRT_2 * EncoderTrack::of(rec).read_sigma_rad() / t
    };
    let white = |d: f64| d / t.sqrt();
    let level_rad = left(ba).hypot(white(vrw)) / g;
    let rate = left(bg).hypot(white(arw)).hypot(enc);
    let lat = m.latitude_deg.to_radians();
    let earth_h = core_nav::earth::EARTH_RATE_RADPS * lat.cos();
    let heading_rad = (rate / earth_h).hypot(level_rad * lat.tan());
    Sigmas {
        level_rad,
        heading_rad,
        rate_radps: rate,
        earth_h_radps: earth_h,
    }
}

/// Where each part of the start attitude came from.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Picked {
    /// Roll, pitch, heading, deg.
    pub euler_deg: [f64; 3],
    /// The level is `meta.toml`'s (else the alignment's).
    pub level_from_meta: bool,
    /// The heading is `meta.toml`'s (else the alignment's).
    pub heading_from_meta: bool,
    /// How many combined sigmas the alignment's level lies from
    /// `meta.toml`'s stated one when more than [`REFUTED_SIGMAS`] (the
    /// statement refuted: the alignment's is taken, said aloud), else
    /// `None` (agreeing, or a sigma unknown: nothing to weigh).
    pub level_refuted_sigmas: Option<f64>,
    /// The same for the heading (when the alignment gyrocompassed).
    pub heading_refuted_sigmas: Option<f64>,
    /// Why, in words.
    pub why: String,
}

/// A stated attitude this many combined sigmas from the alignment's is
/// refuted by the data (a 3-sigma test: a true statement fails it 0.3 %
/// of the time).
pub const REFUTED_SIGMAS: f64 = 3.0;

/// How many combined sigmas apart `stated` and `aligned` angles are (the
/// largest over the components), when more than [`REFUTED_SIGMAS`] and
/// both sigmas are known.
fn refuted(stated: &[f64], aligned: &[f64], s_stated: Option<f64>, s_aligned: f64) -> Option<f64> {
    let s = s_stated?.hypot(s_aligned);
    let d = stated
        .iter()
        .zip(aligned)
        .map(|(a, b)| wrap_deg(a - b).abs())
        .fold(0.0, f64::max);
    let k = d / s;
    (s_aligned.is_finite() && k > REFUTED_SIGMAS).then_some(k)
}

/// An angle difference in (-180, 180] deg.
pub fn wrap_deg(d: f64) -> f64 {
    let w = d.rem_euclid(360.0);
    if w > 180.0 {
        w - 360.0
    } else {
        w
    }
}

/// The better source of each part of the start attitude: `meta.toml`'s
/// stated attitude where its 1-sigma (`[base] level_sigma_deg`,
/// `heading_sigma_deg`) is smaller than the alignment's own (or the
/// alignment's is unknown), else the alignment's. A stated attitude
/// without a sigma is not preferred (its sigma is unknown): the alignment
/// stands, as before, and `--attitude-from-meta` forces `meta.toml`'s. A
/// stated attitude the alignment refutes (more than [`REFUTED_SIGMAS`]
/// combined sigmas apart) is not taken, and the words say so.
pub fn pick(al: &StaticAlignment, meta: &recording::Meta) -> Picked {
    let better = |stated: Option<f64>, aligned: f64| match stated {
        // An unknown (NaN) alignment sigma loses to any stated one.
        Some(s) => aligned.is_nan() || aligned > s,
        None => false,
    };
    let [r, p, h] = al.euler_deg;
    let level_sigma = al.sigma_deg[0].max(al.sigma_deg[1]);
    let level_refuted = refuted(
        &[meta.roll_deg, meta.pitch_deg],
        &[r, p],
        meta.level_sigma_deg,
        level_sigma,
    );
    let heading_refuted = al
        .gyrocompassed
        .then(|| {
            refuted(
                &[meta.heading_deg],
                &[h],
                meta.heading_sigma_deg,
                al.sigma_deg[2],
            )
        })
        .flatten();
    let level = better(meta.level_sigma_deg, level_sigma) && level_refuted.is_none();
    // A heading the alignment took from meta.toml is meta.toml's anyway.
    let heading = !al.gyrocompassed
        || (better(meta.heading_sigma_deg, al.sigma_deg[2]) && heading_refuted.is_none());
    let euler_deg = [
        if level { meta.roll_deg } else { r },
        if level { meta.pitch_deg } else { p },
        if heading { meta.heading_deg } else { h },
    ];
    let known = |s: f64| match s.is_finite() {
        true => format!("+- {s:.3}"),
        false => "sigma unknown".into(),
    };
    let say = |what: &str, from_meta: bool, stated: Option<f64>, aligned: f64, off: Option<f64>| {
        match (from_meta, stated, off) {
            (false, Some(s), Some(k)) => format!(
                "{what} the alignment's ({} deg): meta.toml's (+- {s} deg stated) is {k:.0} sigma from it, refuted by the data (--attitude-from-meta forces it)",
                known(aligned)
            ),
            (true, Some(s), _) => {
                format!("{what} meta.toml's (+- {s} deg stated, the alignment's {})", known(aligned))
            }
            (true, None, _) => format!("{what} meta.toml's"),
            (false, Some(s), None) => format!(
                "{what} the alignment's ({} deg, meta.toml's +- {s} stated)",
                known(aligned)
            ),
            (false, None, _) => format!("{what} the alignment's (meta.toml states no sigma)"),
        }
    };
    let why = format!(
        "start attitude: {}; {}",
        say(
            "level",
            level,
            meta.level_sigma_deg,
            level_sigma,
            level_refuted
        ),
        say(
            "heading",
            heading,
            meta.heading_sigma_deg,
            al.sigma_deg[2],
            heading_refuted
        )
    );
    Picked {
        euler_deg,
        level_from_meta: level,
        heading_from_meta: heading,
        level_refuted_sigmas: level_refuted,
        heading_refuted_sigmas: heading_refuted,
        why,
    }
}

#[cfg(test)]
mod pick_tests {
    use super::*;

    fn aligned(roll: f64, pitch: f64, sigma: f64) -> StaticAlignment {
        StaticAlignment {
            window_s: [0.0, 60.0],
            turns: 0.0,
            swing_deg: 0.0,
            euler_deg: [roll, pitch, 0.0],
            sigma_deg: [sigma, sigma, f64::NAN],
            gyrocompassed: false,
            heading_note: None,
        }
    }

    #[test]
    fn a_stated_level_300_sigma_from_the_alignment_is_refuted_aloud() {
        // The new user's case: meta.toml states a level base to 0.0 deg,
        // the alignment finds roll 0.297 +- 0.001, pitch -0.199 +- 0.001.
        let meta = recording::Meta {
            level_sigma_deg: Some(0.0),
            ..recording::Meta::default()
        };
        let p = pick(&aligned(0.297, -0.199, 0.001), &meta);
        assert!(!p.level_from_meta, "{p:?}");
        assert_eq!(&p.euler_deg[..2], &[0.297, -0.199]);
        let k = p.level_refuted_sigmas.unwrap();
        assert!((k - 297.0).abs() < 1.0, "{k}");
        assert!(p.why.contains("297 sigma from it, refuted"), "{}", p.why);
        // Agreeing within 3 sigma: the stated, better one stands, quietly.
        let p = pick(&aligned(0.002, -0.001, 0.001), &meta);
        assert!(
            p.level_from_meta && p.level_refuted_sigmas.is_none(),
            "{p:?}"
        );
        // An alignment whose sigma is unknown cannot refute anything, and
        // its sigma is said to be unknown, never NaN.
        let p = pick(&aligned(0.297, -0.199, f64::NAN), &meta);
        assert!(p.level_from_meta && p.level_refuted_sigmas.is_none());
        assert!(
            !p.why.contains("NaN") && p.why.contains("sigma unknown"),
            "{}",
            p.why
        );
    }
}
