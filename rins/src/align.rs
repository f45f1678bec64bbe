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
    /// Why, in words.
    pub why: String,
}

/// The better source of each part of the start attitude: `meta.toml`'s
/// stated attitude where its 1-sigma (`[base] level_sigma_deg`,
/// `heading_sigma_deg`) is smaller than the alignment's own (or the
/// alignment's is unknown), else the alignment's. A stated attitude
/// without a sigma is not preferred (its sigma is unknown): the alignment
/// stands, as before, and `--attitude-from-meta` forces `meta.toml`'s.
pub fn pick(al: &StaticAlignment, meta: &recording::Meta) -> Picked {
    let better = |stated: Option<f64>, aligned: f64| match stated {
        // An unknown (NaN) alignment sigma loses to any stated one.
        Some(s) => aligned.is_nan() || aligned > s,
        None => false,
    };
    let level = better(meta.level_sigma_deg, al.sigma_deg[0].max(al.sigma_deg[1]));
    // A heading the alignment took from meta.toml is meta.toml's anyway.
    let heading = !al.gyrocompassed || better(meta.heading_sigma_deg, al.sigma_deg[2]);
    let [r, p, h] = al.euler_deg;
    let euler_deg = [
        if level { meta.roll_deg } else { r },
        if level { meta.pitch_deg } else { p },
        if heading { meta.heading_deg } else { h },
    ];
    let say = |what: &str, from_meta: bool, stated: Option<f64>, aligned: f64| match (
        from_meta, stated,
    ) {
        (true, Some(s)) => {
            format!("{what} meta.toml's (+- {s} deg stated, the alignment's +- {aligned:.3})")
        }
        (true, None) => format!("{what} meta.toml's"),
        (false, Some(s)) => {
            format!("{what} the alignment's (+- {aligned:.3} deg, meta.toml's +- {s} stated)")
        }
        (false, None) => format!("{what} the alignment's (meta.toml states no sigma)"),
    };
    let why = format!(
        "start attitude: {}; {}",
        say(
            "level",
            level,
            meta.level_sigma_deg,
            al.sigma_deg[0].max(al.sigma_deg[1])
        ),
        say("heading", heading, meta.heading_sigma_deg, al.sigma_deg[2])
    );
    Picked {
        euler_deg,
        level_from_meta: level,
        heading_from_meta: heading,
        why,
    }
}
