//! Navigation of a recording (`rins navigate`): strapdown in the sensor
//! frame, body attitude from the encoder, output per `rins-trajectory/1`
//! (`shared/spec/trajectory-v1.md`).

use anyhow::{bail, Result};
use core_nav::attitude::{euler_to_quat, quat_to_euler, Euler};
use core_nav::calib::GyroCalibration;
use core_nav::earth::GeoPoint;
use core_nav::real::{wrap_pi, Real};
use core_nav::strapdown::{ImuSample, Strapdown, StrapdownConfig, VerticalChannel};
use core_nav::table::{q_b_n, q_s_b, EncoderInterpolator, TableAngle};
use nalgebra::{Quaternion, Vector3};
use recording::{Meta, Recording, SampleKind};

/// How to navigate.
#[derive(Clone, Debug, Default)]
pub struct NavOptions {
    /// Start at the first IMU sample at or after this time, s.
    pub start_s: f64,
    /// Stop after this time, s (None: the end).
    pub end_s: Option<f64>,
    /// Gyro corrections.
    pub calibration: Option<GyroCalibration>,
    /// Run in f32 (as on the MCU) instead of f64.
    pub f32: bool,
    /// Hold the height (long static runs).
    pub hold_height: bool,
    /// The base's attitude at the start (roll, pitch, heading, rad): an
    /// alignment's ([`crate::align`]); `None`: `meta.toml`'s.
    pub base: Option<Euler<f64>>,
    /// A tri-axial table's gimbal angles (inner about sensor z, outer about
    /// base x), rad, one per IMU sample: replaces the single-axis encoder
    /// angle for the initial and the output attitude (`c_s_b = Rx(outer)
    /// Rz(inner)`; simulation only).
    pub gimbals: Option<Vec<(f64, f64)>>,
}

/// `q_s_b` of a tri-axial table's gimbals: `Rx(outer) Rz(inner)`.
pub fn q_s_b_gimbals(inner: f64, outer: f64) -> Quaternion<f64> {
    q_s_b(core_nav::table::Axis::X, outer) * q_s_b(core_nav::table::Axis::Z, inner)
}

/// One output row: trajectory-v1 columns in SI / degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrajRow {
    /// s, the recording's clock.
    pub t_s: f64,
    /// Tangent-plane NED offset from the start point, m.
    pub ned_m: [f64; 3],
    /// Velocity relative to the earth, NED, m/s.
    pub v_mps: [f64; 3],
    /// Base roll, pitch, heading (heading in [0, 360)), deg.
    pub rph_deg: [f64; 3],
    /// Steps refused by the mechanization so far (non-finite samples, gaps).
    pub faults: u32,
}

/// A recording's clock on the mechanization's: sample time (s) to µs, an
/// averaged sample (`[imu] sample = "average"`) moved to its interval's
/// middle.
pub fn clock_us(m: &Meta) -> impl Fn(f64) -> u64 {
    let shift_us = match m.imu_sample {
        SampleKind::Instantaneous => 0,
        SampleKind::Average => (0.5e6 / m.imu_rate_hz).round() as u64,
    };
    move |t: f64| ((t * 1e6).round().max(0.0) as u64).saturating_sub(shift_us)
}

/// The mechanization's settings for a recording: up to 5 missed samples,
/// its measured gravity, the vertical channel free or held.
pub fn strapdown_config(m: &Meta, hold_height: bool) -> StrapdownConfig {
    StrapdownConfig {
        max_dt_us: (6e6 / m.imu_rate_hz) as u64,
        vertical: if hold_height {
            VerticalChannel::HoldHeight
        } else {
            VerticalChannel::Free
        },
        gravity_mps2: m.gravity_mps2,
    }
}

/// Navigates `rec`.
///
/// # Errors
/// An empty recording, no encoder data, a start after the end.
pub fn navigate(
    rec: &Recording,
    opt: &NavOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<Vec<TrajRow>> {
    if opt.f32 {
        navigate_t::<f32>(rec, opt, progress)
    } else {
        navigate_t::<f64>(rec, opt, progress)
    }
}

fn navigate_t<T: Real>(
    rec: &Recording,
    opt: &NavOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<Vec<TrajRow>> {
    let m = &rec.meta;
    let first = rec.imu.iter().position(|r| r.t_s >= opt.start_s);
    let Some(first) = first else {
        bail!("no IMU sample at or after {} s", opt.start_s)
    };
    if rec.table.is_empty() {
        bail!("the recording has no encoder angles (table.csv is empty)");
    }
    let to_us = clock_us(m);
    let enc_period_us = (1e6 / m.encoder_rate_hz).round() as u64;
    let mut enc = EncoderInterpolator::<T>::new(2 * enc_period_us);
    let mut enc_rows = rec.table.iter().peekable();
    let mut angle_at = |t_us: u64, enc: &mut EncoderInterpolator<T>| -> Result<T> {
        // Offline: feed encoder rows up to the first one at or after t.
        while let Some(r) = enc_rows.peek() {
            let tr = (r.t_s * 1e6).round() as u64;
            let need = enc.latest().is_none_or(|(tl, _)| tl < t_us);
            if !need {
                break;
            }
            enc.push(tr, TableAngle::from_rad_f64(r.angle_rad))
                .map_err(|e| anyhow::anyhow!("table.csv: {e}"))?;
            enc_rows.next();
        }
        Ok(enc
            .angle_at(t_us)
            .map_err(|e| anyhow::anyhow!("at {} s: {e}", t_us as f64 * 1e-6))?
            .rad)
    };
    let sample = |k: usize| -> ImuSample<T> {
        let r = &rec.imu[k];
        let mut w = Vector3::from(r.gyro_radps).map(T::lit);
        if let Some(c) = &opt.calibration {
            w = c.apply(&w);
        }
        ImuSample {
            t_us: to_us(r.t_s),
            w_is_s: w,
            f_s: Vector3::from(r.accel_mps2).map(T::lit),
        }
    };
    let origin = GeoPoint::from_deg(m.latitude_deg, 0.0, m.height_m);
    let tangent = origin.tangent();
    let base = opt
        .base
        .unwrap_or_else(|| Euler::<f64>::from_deg(m.roll_deg, m.pitch_deg, m.heading_deg));
    let s0 = sample(first);
    let theta0 = angle_at(s0.t_us, &mut enc)?;
    let gimbal = |k: usize| {
        opt.gimbals
            .as_ref()
            .and_then(|g| g.get(k))
            .map(|&(i, o)| q_s_b_gimbals(i, o))
    };
    let q0 = euler_to_quat(&base) * gimbal(first).unwrap_or_else(|| q_s_b(m.axis, theta0.to_f64()));
    let cfg = strapdown_config(m, opt.hold_height);
    let mut nav = Strapdown::<T>::new(
        cfg,
        origin,
        Vector3::zeros(),
        Quaternion::from(q0.coords.map(T::lit)),
        &s0,
    )
    .map_err(|e| anyhow::anyhow!("cannot start navigation: {e}"))?;
    let earth = *nav.earth();
    let end = opt.end_s.unwrap_or(f64::INFINITY);
    let n_total = rec.imu.len().saturating_sub(first).max(1);
    let mut out = Vec::with_capacity(n_total);
    let mut faults = 0u32;
    let row = |s: &core_nav::strapdown::NavState<T>, theta: T, k: usize, faults: u32| {
        let t_s = rec.imu[k].t_s;
        let q = match gimbal(k) {
            Some(q_s_b) => Quaternion::from(s.q_s_n.coords.map(|x| x.to_f64())) * q_s_b.conjugate(),
            None => Quaternion::from(q_b_n(&s.q_s_n, m.axis, theta).coords.map(|x| x.to_f64())),
        };
        let e = quat_to_euler(&q);
        let ned = tangent.ned_to(&earth.point_at(&s.p_n));
        let mut hdg = e.heading.to_degrees();
        if hdg < 0.0 {
            hdg += 360.0;
        }
        if hdg >= 360.0 {
            hdg -= 360.0;
        }
        TrajRow {
            t_s,
            ned_m: [ned.x, ned.y, ned.z],
            v_mps: [s.v_n.x.to_f64(), s.v_n.y.to_f64(), s.v_n.z.to_f64()],
            rph_deg: [e.roll.to_degrees(), e.pitch.to_degrees(), hdg],
            faults,
        }
    };
    out.push(row(nav.state(), theta0, first, 0));
    for k in first + 1..rec.imu.len() {
        if rec.imu[k].t_s > end {
            break;
        }
        let s = sample(k);
        let theta = angle_at(s.t_us, &mut enc)?;
        match nav.step(&s) {
            Ok(st) => out.push(row(st, theta, k, faults)),
            Err(_) => faults += 1,
        }
        if (k - first).is_multiple_of(50_000) {
            progress((k - first) as f64 / n_total as f64);
        }
    }
    progress(1.0);
    Ok(out)
}

/// trajectory.csv text (`rins-trajectory/1`).
pub fn trajectory_csv(rows: &[TrajRow]) -> String {
    let mut s = String::with_capacity(rows.len() * 120);
    s.push_str(
        "t_s,north_m,east_m,down_m,vn_mps,ve_mps,vd_mps,roll_deg,pitch_deg,heading_deg,faults\n",
    );
    for r in rows {
        let [n, e, d] = r.ned_m;
        let [vn, ve, vd] = r.v_mps;
        let [ro, pi, he] = r.rph_deg;
        s.push_str(&format!(
            "{},{n},{e},{d},{vn},{ve},{vd},{ro},{pi},{he},{}\n",
            r.t_s, r.faults
        ));
    }
    s
}

/// Errors of a static run against its truth (rest at the start point, base
/// attitude from meta): RMS over the rows.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StaticErrors {
    /// Horizontal position RMS, m.
    pub h_pos_rms_m: f64,
    /// Horizontal velocity RMS, m/s.
    pub h_vel_rms_mps: f64,
    /// Roll RMS, deg.
    pub roll_rms_deg: f64,
    /// Pitch RMS, deg.
    pub pitch_rms_deg: f64,
    /// Heading RMS, deg.
    pub heading_rms_deg: f64,
    /// Horizontal position error at the end, m.
    pub h_pos_end_m: f64,
}

/// RMS errors of `rows` for a static base with attitude `base_rph_deg`.
pub fn static_errors(rows: &[TrajRow], base_rph_deg: [f64; 3]) -> StaticErrors {
    let n = rows.len().max(1) as f64;
    let mut e = StaticErrors::default();
    let d = |a: f64, b: f64| wrap_pi((a - b).to_radians()).to_degrees();
    for r in rows {
        e.h_pos_rms_m += r.ned_m[0].powi(2) + r.ned_m[1].powi(2);
        e.h_vel_rms_mps += r.v_mps[0].powi(2) + r.v_mps[1].powi(2);
        e.roll_rms_deg += d(r.rph_deg[0], base_rph_deg[0]).powi(2);
        e.pitch_rms_deg += d(r.rph_deg[1], base_rph_deg[1]).powi(2);
        e.heading_rms_deg += d(r.rph_deg[2], base_rph_deg[2]).powi(2);
    }
    for v in [
        &mut e.h_pos_rms_m,
        &mut e.h_vel_rms_mps,
        &mut e.roll_rms_deg,
        &mut e.pitch_rms_deg,
        &mut e.heading_rms_deg,
    ] {
        *v = (*v / n).sqrt();
    }
    e.h_pos_end_m = rows.last().map_or(0.0, |r| r.ned_m[0].hypot(r.ned_m[1]));
    e
}

/// A one-line summary.
pub fn summary(e: &StaticErrors) -> String {
    format!(
        "RMS: horizontal position {:.2} m, velocity {:.3} m/s, roll {:.4} deg, pitch {:.4} deg, heading {:.4} deg",
        e.h_pos_rms_m, e.h_vel_rms_mps, e.roll_rms_deg, e.pitch_rms_deg, e.heading_rms_deg
    )
}
