//! comma2k19 segments (comma.ai's driving dataset, MIT): the processed
//! log's NumPy arrays (files without the `.npy` extension) of one
//! segment directory, `processed_log/...` and `global_pose/...`.
//!
//! - IMU: `IMU/accelerometer` (m/s^2) and `IMU/gyro` (rad/s, the
//!   device's own running bias estimate taken out: the raw
//!   `gyro_uncalibrated` carries biases of degrees a second, beyond any
//!   phone-class profile's turn-on), axes forward, right, down of the
//!   device, turned by the sensor file's mounting into `b`.
//! - Fixes: `GNSS/live_gnss_ublox` rows `[lat deg, lon deg, speed m/s, UTC
//!   ms, height m, bearing deg]`, position-only (no vertical velocity is
//!   given), at their epoch put on the pose's clock: first through the
//!   pose's GPS/boot pairs, then moved by the shift at which the fixes fit
//!   the pose best ([`against_reference`]: 0.12 s on the bundled minute,
//!   which the IMU's own NIS confirms); each with the 1-sigma the user
//!   states or, by default, the one measured there (the receiver logs
//!   none): UTC to GPS time (18 leap seconds, 2017 on) and GPS time
//!   to the boot clock through `global_pose`'s pairs of `frame_gps_times`
//!   and `frame_times` (their median difference); the arrival stamps lag
//!   the epochs by about 0.2 s.
//! - `odometer.csv`: `CAN/speed` (m/s).
//! - `truth.csv`: `global_pose`, the camera's pose from comma's INS/GNSS/
//!   vision optimiser (ECEF position, velocity, and a quaternion `w x y
//!   z`, ECEF from the device frame): a reference, not independent of
//!   this IMU; its first row at or after the first sample gives `[base]`
//!   and `[site]` (the car moves from its first sample: there is no still
//!   start to align on).
//!
//! Every time is the device's boot clock, shifted so the first IMU sample
//! is `t_s = 0`.

use super::fixcheck::{against_reference, FixesAgainstReference};
use super::npy;
use anyhow::{anyhow, bail, Result};
use core_nav::attitude::{dcm_to_euler, quat_to_dcm};
use core_nav::earth::GeoPoint;
use nalgebra::{Quaternion, Vector3};
use recording::moving::{GnssMeta, GnssRow, MovingBase, OdometerRow, TruthRow};
use recording::{ImuRow, Meta, Recording, SampleKind, TableSource};
use std::path::{Path, PathBuf};

/// What `rins import comma2k19` takes.
#[derive(Clone, Debug)]
pub struct CommaInput {
    /// The segment directory (holding `processed_log` and `global_pose`).
    pub dir: PathBuf,
    /// The fixes' horizontal 1-sigma, m (vertical: twice it); `None`:
    /// measured against the pose ([`against_reference`]).
    pub fix_sigma_h_m: Option<f64>,
    /// The sensor (model name, mounting into `b`, antenna).
    pub sensor: hal_sim::imu::ImuSpec,
}

/// GPS time minus UTC from 2017-01-01 (Unix 1483228800) on, s.
const LEAP_S: f64 = 18.0;
/// Unix time of the GPS epoch, 1980-01-06, s.
const GPS_EPOCH_UNIX_S: f64 = 315_964_800.0;
const WEEK_S: f64 = 604_800.0;

fn array(dir: &Path, rel: &str) -> Result<npy::Array> {
    let p = dir.join(rel);
    if !p.exists() {
        bail!(
            "{}: missing (a comma2k19 segment has processed_log/ and global_pose/)",
            p.display()
        );
    }
    npy::read(&p)
}

/// `t` and `value` of a processed-log signal, checked to match.
fn signal(dir: &Path, rel: &str, cols: usize) -> Result<(Vec<f64>, npy::Array)> {
    let t = array(dir, &format!("{rel}/t"))?.column0();
    let v = array(dir, &format!("{rel}/value"))?;
    if v.rows != t.len() || v.cols != cols {
        bail!(
            "{}: {} x {} values for {} times ({cols} columns expected)",
            dir.join(rel).display(),
            v.rows,
            v.cols,
            t.len()
        );
    }
    Ok((t, v))
}

/// The mean of the device's gyro bias estimate (`IMU/gyro_bias`, the
/// one `IMU/gyro` has had taken out), turned into `b` by `c_s_b`, deg/s;
/// `None` when the segment does not keep it (it is only reported).
fn device_gyro_bias(dir: &Path, c_s_b: &nalgebra::Matrix3<f64>) -> Option<[f64; 3]> {
    let (_, b) = signal(dir, "processed_log/IMU/gyro_bias", 3).ok()?;
    let mut sum = Vector3::zeros();
    for i in 0..b.rows {
        sum += Vector3::from_column_slice(b.row(i));
    }
    let mean = c_s_b * sum / (b.rows.max(1) as f64);
    (b.rows > 0).then(|| mean.map(f64::to_degrees).into())
}

/// The boot clock's offset from GPS seconds of week (GPS sow minus boot),
/// s, and the GPS week: the median of `global_pose`'s pairs.
fn gps_offset(dir: &Path) -> Result<(f64, f64)> {
    let gps = array(dir, "global_pose/frame_gps_times")?;
    let boot = array(dir, "global_pose/frame_times")?.column0();
    let mut d: Vec<f64> = boot
        .iter()
        .enumerate()
        .map(|(i, b)| gps.row(i).get(1).copied().unwrap_or(f64::NAN) - b)
        .collect();
    let week = gps.row(0).first().copied().unwrap_or(f64::NAN);
    let m = core_nav::stats::median(&mut d);
    if !(m.is_finite() && week.is_finite()) {
        bail!("global_pose: no GPS/boot time pairs");
    }
    Ok((m, week))
}

/// Imports a comma2k19 segment.
///
/// # Errors
/// A missing or unreadable array (naming it), arrays of mismatched
/// lengths, times not increasing, a fix before 2017 (another leap second
/// count) or in another GPS week than the pose's, no fix or reference row
/// inside the IMU's span, a non-positive sigma.
pub fn import(input: &CommaInput) -> Result<(Recording, super::ImportReport)> {
    if input.fix_sigma_h_m.is_some_and(|s| s.is_nan() || s <= 0.0) {
        bail!("the fixes' sigma must be positive");
    }
    let dir = &input.dir;
    let (t_imu, acc) = signal(dir, "processed_log/IMU/accelerometer", 3)?;
    let (t_gyro, gyr) = signal(dir, "processed_log/IMU/gyro", 3)?;
    if t_gyro != t_imu {
        bail!(
            "{}: the gyro's and the accelerometer's times differ",
            dir.display()
        );
    }
    let t0 = *t_imu.first().ok_or_else(|| anyhow!("no IMU sample"))?;
    let t_end = *t_imu.last().unwrap_or(&t0);
    let c = input.sensor.mounting.c_s_b();
    let mut imu = Vec::with_capacity(t_imu.len());
    for (i, t) in t_imu.iter().enumerate() {
        if imu.last().is_some_and(|p: &ImuRow| t - t0 <= p.t_s) {
            bail!(
                "{}: IMU time {t} does not increase (sample {i})",
                dir.display()
            );
        }
        let v3 = |a: &npy::Array| Vector3::from_column_slice(a.row(i));
        let (w, f) = (c * v3(&gyr), c * v3(&acc));
        imu.push(ImuRow {
            t_s: t - t0,
            gyro_radps: w.into(),
            accel_mps2: f.into(),
            temp_c: None,
        });
    }
    let mut rep = super::ImportReport {
        imu_samples: imu.len(),
        imu_rate_found_hz: (imu.len() - 1) as f64 / (t_end - t0),
        ..super::ImportReport::default()
    };
    rep.device_gyro_bias_dps = device_gyro_bias(dir, &c);
    let (gps_minus_boot, week) = gps_offset(dir)?;
    // The fixes' sigmas are set below, once the pose is read.
    rep.t0_gpst = t0 + gps_minus_boot;
    let gnss = fixes(input, t0, t_end, gps_minus_boot, week, &mut rep)?;
    let truth = reference(dir, t0, t_end)?;
    let first = truth
        .first()
        .ok_or_else(|| anyhow!("global_pose: no row inside the IMU's span"))?;
    let (origin, start) = (first.0, first.1);
    let tangent = origin.tangent();
    let truth: Vec<TruthRow> = truth
        .iter()
        .map(|(p, r)| {
            let d = tangent.ned_to(p);
            TruthRow {
                p_n_m: d.into(),
                ..*r
            }
        })
        .collect();
    let (gnss, check) = on_the_pose_clock(input, gnss, &truth, &tangent, t_end - t0, &mut rep)?;
    rep.fixes_against_reference = check;
    let odometer = odometer(dir, t0, t_end)?;
    let rate = rep.imu_rate_found_hz.round();
    let meta = Meta {
        description: Some(format!(
            "imported by rins import comma2k19: {}",
            dir.display()
        )),
        latitude_deg: origin.lat_rad.to_degrees(),
        height_m: origin.height_m,
        gravity_mps2: None,
        roll_deg: start.euler_deg[0],
        heading_sigma_deg: None,
        level_sigma_deg: None,
        pitch_deg: start.euler_deg[1],
        heading_deg: start.euler_deg[2],
        imu_model: Some(input.sensor.model.clone()),
        imu_rate_hz: rate,
        imu_sample: SampleKind::Instantaneous,
        axis: core_nav::table::Axis::Z,
        encoder_rate_hz: rate,
        table_source: TableSource::None,
    };
    let moving = MovingBase {
        longitude_deg: origin.lon_rad.to_degrees(),
        gnss_meta: Some(GnssMeta {
            antenna_b_m: input.sensor.mounting.antenna_b_m.unwrap_or([0.0; 3]),
            rate_hz: 10.0,
        }),
        gnss: Some(gnss),
        truth: Some(truth),
        odometer: Some(odometer),
        heading_unknown: false,
    };
    Ok((Recording::fixed_imu(meta, imu, Some(moving)), rep))
}

/// The fixes put on the pose's clock (the IMU's: one boot clock) at the
/// shift that fits them to it best ([`against_reference`]), those that
/// then leave the IMU's span (`span_s` long from 0) dropped and counted,
/// and each given the stated 1-sigma or, without one, the one measured
/// there. Without a fix inside the pose: as they are, with the stated
/// sigma (none stated: an error).
fn on_the_pose_clock(
    input: &CommaInput,
    gnss: Vec<GnssRow>,
    truth: &[TruthRow],
    tangent: &core_nav::earth::Tangent,
    span_s: f64,
    rep: &mut super::ImportReport,
) -> Result<(Vec<GnssRow>, Option<FixesAgainstReference>)> {
    let Some(check) = against_reference(&gnss, truth, tangent) else {
        let s = input.fix_sigma_h_m.ok_or_else(|| {
            anyhow!("global_pose: no fix lies inside it, so their sigma cannot be measured: give --fix-sigma-m")
        })?;
        let rows = gnss
            .into_iter()
            .map(|f| GnssRow {
                sigma_h_m: s,
                sigma_v_m: 2.0 * s,
                ..f
            })
            .collect();
        return Ok((rows, None));
    };
    let [h, v] = match input.fix_sigma_h_m {
        Some(s) => [s, 2.0 * s],
        None => check.sigma_m(),
    };
    let n = gnss.len();
    let rows: Vec<GnssRow> = gnss
        .into_iter()
        .map(|f| GnssRow {
            t_s: f.t_s + check.shift_s,
            sigma_h_m: h,
            sigma_v_m: v,
            ..f
        })
        .filter(|f| f.t_s >= 0.0 && f.t_s <= span_s)
        .collect();
    rep.fixes_outside += n - rows.len();
    rep.fixes = rows.len();
    if rows.is_empty() {
        bail!("live_gnss_ublox: no fix inside the IMU's span on the pose's clock");
    }
    Ok((
        rows,
        Some(FixesAgainstReference {
            sigma_h_m: h,
            sigma_v_m: v,
            sigma_measured: input.fix_sigma_h_m.is_none(),
            ..check
        }),
    ))
}

/// The live fixes at their epochs on the recording's clock.
fn fixes(
    input: &CommaInput,
    t0: f64,
    t_end: f64,
    gps_minus_boot: f64,
    week: f64,
    rep: &mut super::ImportReport,
) -> Result<Vec<GnssRow>> {
    let (_, g) = signal(&input.dir, "processed_log/GNSS/live_gnss_ublox", 6)?;
    let mut out: Vec<GnssRow> = vec![];
    for i in 0..g.rows {
        let r = g.row(i);
        let (lat, lon, utc_ms, h) = (r[0], r[1], r[3], r[4]);
        let unix = utc_ms * 1e-3;
        if unix < 1_483_228_800.0 {
            bail!("live_gnss_ublox row {i}: a fix before 2017 (GPS-UTC was not {LEAP_S} s then)");
        }
        let gps = unix - GPS_EPOCH_UNIX_S + LEAP_S;
        if (gps / WEEK_S).floor() != week {
            bail!(
                "live_gnss_ublox row {i}: GPS week {} but global_pose's is {week}",
                (gps / WEEK_S).floor()
            );
        }
        let t = gps.rem_euclid(WEEK_S) - gps_minus_boot;
        if t < t0 || t > t_end || !(lat.is_finite() && lon.is_finite() && h.is_finite()) {
            rep.fixes_outside += 1;
            continue;
        }
        if out.last().is_some_and(|p| t - t0 <= p.t_s) {
            bail!("live_gnss_ublox row {i}: epoch {t} does not increase");
        }
        out.push(GnssRow {
            t_s: t - t0,
            lat_deg: lat,
            lon_deg: lon,
            height_m: h,
            v_n_mps: [f64::NAN; 3],
            sigma_h_m: f64::NAN,
            sigma_v_m: f64::NAN,
            sigma_vel_mps: f64::NAN,
            quality: None,
        });
    }
    if out.is_empty() {
        bail!("live_gnss_ublox: no fix inside the IMU's span");
    }
    rep.fixes = out.len();
    Ok(out)
}

/// `global_pose` inside the IMU's span: each row's point and its truth
/// row (position left for the caller to put on the tangent plane).
fn reference(dir: &Path, t0: f64, t_end: f64) -> Result<Vec<(GeoPoint, TruthRow)>> {
    let t = array(dir, "global_pose/frame_times")?.column0();
    let p = array(dir, "global_pose/frame_positions")?;
    let v = array(dir, "global_pose/frame_velocities")?;
    let q = array(dir, "global_pose/frame_orientations")?;
    if [p.rows, v.rows, q.rows] != [t.len(); 3] || [p.cols, v.cols, q.cols] != [3, 3, 4] {
        bail!(
            "{}: global_pose's arrays do not match in length or width",
            dir.display()
        );
    }
    let mut out = vec![];
    for (i, ti) in t
        .iter()
        .enumerate()
        .filter(|(_, ti)| **ti >= t0 && **ti <= t_end)
    {
        let r_e = Vector3::from_column_slice(p.row(i));
        let pt = GeoPoint::from_ecef(&r_e)
            .ok_or_else(|| anyhow!("global_pose row {i}: not a position"))?;
        let c_e_n = pt.c_e_n();
        let qi = q.row(i);
        let c_b_e = quat_to_dcm(&Quaternion::new(qi[0], qi[1], qi[2], qi[3]).normalize());
        let e = dcm_to_euler(&(c_e_n * c_b_e));
        let v_n = c_e_n * Vector3::from_column_slice(v.row(i));
        out.push((
            pt,
            TruthRow {
                t_s: ti - t0,
                p_n_m: [0.0; 3],
                v_n_mps: v_n.into(),
                euler_deg: [
                    e.roll.to_degrees(),
                    e.pitch.to_degrees(),
                    e.heading.to_degrees().rem_euclid(360.0),
                ],
            },
        ));
    }
    Ok(out)
}

/// `CAN/speed` inside the IMU's span.
fn odometer(dir: &Path, t0: f64, t_end: f64) -> Result<Vec<OdometerRow>> {
    let (t, v) = signal(dir, "processed_log/CAN/speed", 1)?;
    Ok(t.iter()
        .zip(v.column0())
        .filter(|(t, s)| **t >= t0 && **t <= t_end && s.is_finite())
        .map(|(t, s)| OdometerRow {
            t_s: t - t0,
            speed_mps: s,
            sigma_mps: None,
        })
        .collect())
}
