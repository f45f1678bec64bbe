//! KF-GINS text files (i2Nav-WHU's loosely coupled GNSS/INS): the IMU as
//! increments, GNSS positions with their sigmas, and a reference (truth).
//!
//! - IMU, 7 columns: GNSS seconds of week, `dtheta` x, y, z (rad), `dv`
//!   x, y, z (m/s), each the increment over the interval ending at the
//!   time, in the body frame (front, right, down). Written as rates and
//!   specific forces (increment over interval) with `[imu] sample =
//!   "average"` (recording-v1: the mean over the interval ending at
//!   `t_s`).
//! - GNSS, 7 columns: seconds of week, latitude, longitude (deg), height
//!   (m), sigma north, east, down (m); or 13 with velocity north, east,
//!   down (m/s) and their sigmas after them.
//! - Reference, 11 columns: week, seconds of week, latitude, longitude
//!   (deg), height (m), velocity north, east, down (m/s), roll, pitch, yaw
//!   (deg).

use anyhow::{anyhow, bail, Result};
use core_nav::earth::GeoPoint;
use recording::moving::{GnssMeta, GnssRow, MovingBase, TruthRow};
use recording::{ImuRow, Meta, Recording, SampleKind, TableSource};
use std::path::{Path, PathBuf};

/// What `rins import kf-gins` takes.
#[derive(Clone, Debug)]
pub struct KfGinsInput {
    /// The IMU file.
    pub imu: PathBuf,
    /// The GNSS file.
    pub gnss: PathBuf,
    /// The reference, when there is one.
    pub truth: Option<PathBuf>,
    /// The sensor (model name, mounting into the body frame, antenna).
    pub sensor: hal_sim::imu::ImuSpec,
}

/// Whitespace- or comma-separated numeric rows of a text file, each with
/// one of `widths` fields (`#` and `%` lines skipped).
fn rows(path: &Path, widths: &[usize]) -> Result<Vec<(usize, Vec<f64>)>> {
    let text = std::fs::read_to_string(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    let mut out: Vec<(usize, Vec<f64>)> = vec![];
    for (k, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.is_empty() || t.starts_with('#') || t.starts_with('%') {
            continue;
        }
        let v: Vec<f64> = t
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<_>>()
            .ok_or_else(|| anyhow!("{}:{}: not all finite numbers", path.display(), k + 1))?;
        if !widths.contains(&v.len()) {
            bail!(
                "{}:{}: {} columns, expected {:?}",
                path.display(),
                k + 1,
                v.len(),
                widths
            );
        }
        out.push((k + 1, v));
    }
    if out.len() < 2 {
        bail!("{}: fewer than two rows", path.display());
    }
    Ok(out)
}

/// Time of row `v` (its column `col`), checked to increase.
fn times(path: &Path, r: &[(usize, Vec<f64>)], col: usize) -> Result<Vec<f64>> {
    let mut prev = f64::NEG_INFINITY;
    r.iter()
        .map(|(line, v)| {
            let t = v.get(col).copied().unwrap_or(f64::NAN);
            if t.partial_cmp(&prev) != Some(std::cmp::Ordering::Greater) {
                bail!("{}:{line}: time {t} does not increase", path.display());
            }
            prev = t;
            Ok(t)
        })
        .collect()
}

/// Imports KF-GINS files.
///
/// # Errors
/// A file that does not read, a row of another width or with a
/// non-number, time going backwards (each naming file and line), a
/// non-positive sigma, no fix inside the IMU's span.
pub fn import(input: &KfGinsInput) -> Result<(Recording, super::ImportReport)> {
    let imu_rows = rows(&input.imu, &[7])?;
    let t_imu = times(&input.imu, &imu_rows, 0)?;
    let t0 = t_imu.first().copied().unwrap_or(0.0);
    let c = input.sensor.mounting.c_s_b();
    let mut imu = Vec::with_capacity(imu_rows.len());
    for (k, ((_, v), t)) in imu_rows.iter().zip(&t_imu).enumerate().skip(1) {
        let dt = t - t_imu.get(k - 1).copied().unwrap_or(*t);
        let at = |i: usize| v.get(i).copied().unwrap_or(0.0) / dt;
        let w = c * nalgebra::Vector3::new(at(1), at(2), at(3));
        let f = c * nalgebra::Vector3::new(at(4), at(5), at(6));
        imu.push(ImuRow {
            t_s: t - t0,
            gyro_radps: [w.x, w.y, w.z],
            accel_mps2: [f.x, f.y, f.z],
            temp_c: None,
        });
    }
    let t_end = t_imu.last().copied().unwrap_or(t0);
    let g_rows = rows(&input.gnss, &[7, 13])?;
    let t_g = times(&input.gnss, &g_rows, 0)?;
    let mut rep = super::ImportReport {
        imu_samples: imu.len(),
        t0_gpst: t0,
        imu_rate_found_hz: (t_imu.len() - 1) as f64 / (t_end - t0),
        ..super::ImportReport::default()
    };
    let mut gnss = vec![];
    for ((line, v), t) in g_rows.iter().zip(&t_g) {
        if *t < t0 || *t > t_end {
            rep.fixes_outside += 1;
            continue;
        }
        let g = |i: usize| v.get(i).copied().unwrap_or(f64::NAN);
        let (sn, se, sd) = (g(4), g(5), g(6));
        if !(sn > 0.0 && se > 0.0 && sd > 0.0) {
            bail!("{}:{line}: sigmas must be positive", input.gnss.display());
        }
        let vel = (v.len() == 13).then(|| {
            (
                [g(7), g(8), g(9)],
                ((g(10).powi(2) + g(11).powi(2) + g(12).powi(2)) / 3.0).sqrt(),
            )
        });
        gnss.push(GnssRow {
            t_s: t - t0,
            lat_deg: g(1),
            lon_deg: g(2),
            height_m: g(3),
            v_n_mps: vel.map_or([f64::NAN; 3], |v| v.0),
            sigma_h_m: ((sn * sn + se * se) / 2.0).sqrt(),
            sigma_v_m: sd,
            sigma_vel_mps: vel.map_or(f64::NAN, |v| v.1),
            quality: None,
        });
    }
    rep.fixes = gnss.len();
    let first = *gnss
        .first()
        .ok_or_else(|| anyhow!("{}: no fix inside the IMU's span", input.gnss.display()))?;
    let truth_rows = match &input.truth {
        None => None,
        Some(p) => {
            let r = rows(p, &[11])?;
            times(p, &r, 1)?;
            Some(r)
        }
    };
    // The site and start attitude: the reference at the first IMU sample
    // when there is one (heading known), else the first fix.
    let start = truth_rows.as_ref().and_then(|r| {
        r.iter()
            .find(|(_, v)| v.get(1).is_some_and(|t| *t >= t0))
            .map(|(_, v)| v.clone())
    });
    let (lat, lon, h) = start
        .as_ref()
        .map_or((first.lat_deg, first.lon_deg, first.height_m), |v| {
            (v[2], v[3], v[4])
        });
    let origin = GeoPoint::from_deg(lat, lon, h);
    let truth = truth_rows.map(|r| {
        r.iter()
            .filter(|(_, v)| v[1] >= t0 && v[1] <= t_end)
            .map(|(_, v)| {
                let d = origin.ned_to(&GeoPoint::from_deg(v[2], v[3], v[4]));
                TruthRow {
                    t_s: v[1] - t0,
                    p_n_m: [d.x, d.y, d.z],
                    v_n_mps: [v[5], v[6], v[7]],
                    euler_deg: [v[8], v[9], v[10].rem_euclid(360.0)],
                }
            })
            .collect::<Vec<_>>()
    });
    let rate = (rep.imu_rate_found_hz).round();
    let meta = Meta {
        description: Some(format!(
            "imported by rins import kf-gins: {} + {}",
            input.imu.display(),
            input.gnss.display()
        )),
        latitude_deg: lat,
        height_m: h,
        gravity_mps2: None,
        roll_deg: start.as_ref().map_or(0.0, |v| v[8]),
        heading_sigma_deg: None,
        level_sigma_deg: None,
        pitch_deg: start.as_ref().map_or(0.0, |v| v[9]),
        heading_deg: start.as_ref().map_or(0.0, |v| v[10].rem_euclid(360.0)),
        imu_model: Some(input.sensor.model.clone()),
        imu_rate_hz: rate,
        imu_sample: SampleKind::Average,
        axis: core_nav::table::Axis::Z,
        encoder_rate_hz: rate,
        table_source: TableSource::None,
    };
    let g_rate = ((gnss.len().max(2) - 1) as f64
        / (gnss.last().map_or(1.0, |l| l.t_s) - first.t_s).max(1e-9))
    .round()
    .max(1.0);
    let moving = MovingBase {
        odometer: None,
        longitude_deg: lon,
        gnss_meta: Some(GnssMeta {
            antenna_b_m: input.sensor.mounting.antenna_b_m.unwrap_or([0.0; 3]),
            rate_hz: g_rate,
        }),
        gnss: Some(gnss),
        heading_unknown: start.is_none(),
        truth,
    };
    Ok((Recording::fixed_imu(meta, imu, Some(moving)), rep))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn increments_become_averages_and_the_reference_truth() {
        let dir = std::env::temp_dir().join(format!("rins-kfgins-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // 200 Hz, a yaw rate of 0.01 rad/s and -g on z, level, heading 30.
        let imu: String = (0..5)
            .map(|k| {
                format!(
                    "{:.3} 0 0 0.00005 0 0 -0.04903325\n",
                    100.0 + k as f64 * 0.005
                )
            })
            .collect();
        let i = write(&dir, "imu.txt", &imu);
        let g = write(
            &dir,
            "gnss.txt",
            "100.010 30.5 114.3 20.0 0.02 0.02 0.04\n100.015 30.5 114.3 20.0 0.02 0.02 0.04\n",
        );
        let t = write(&dir, "truth.nav", "2000 100.000 30.5 114.3 20.0 0 0 0 0 0 30\n2000 100.020 30.5 114.3 20.0 0 0 0 0 0 30\n");
        let input = KfGinsInput {
            imu: i,
            gnss: g.clone(),
            truth: Some(t),
            sensor: hal_sim::sensor::resolve("ideal").unwrap(),
        };
        let (rec, rep) = import(&input).unwrap();
        assert_eq!((rep.imu_samples, rep.fixes), (4, 2));
        assert!((rec.imu[0].gyro_radps[2] - 0.01).abs() < 1e-9);
        assert!((rec.imu[0].accel_mps2[2] + 9.80665).abs() < 1e-9);
        assert_eq!(rec.meta.imu_sample, SampleKind::Average);
        assert_eq!(rec.meta.heading_deg, 30.0);
        let mv = rec.moving.as_ref().unwrap();
        assert!(!mv.heading_unknown);
        assert_eq!(mv.truth.as_ref().unwrap().len(), 2);
        // Bad input names file and line.
        write(&dir, "gnss.txt", "100.010 30.5 114.3 20.0 0.02 0.02\n");
        let e = import(&input).unwrap_err().to_string();
        assert!(e.contains("gnss.txt:1") && e.contains("columns"), "{e}");
        write(
            &dir,
            "gnss.txt",
            "100.010 30.5 114.3 20.0 0 0.02 0.04\n100.015 30.5 114.3 20.0 0.02 0.02 0.04\n",
        );
        let e = import(&input).unwrap_err().to_string();
        assert!(e.contains("gnss.txt:1") && e.contains("sigmas"), "{e}");
        write(
            &dir,
            "gnss.txt",
            "100.015 30.5 114.3 20.0 0.02 0.02 0.04\n100.010 30.5 114.3 20.0 0.02 0.02 0.04\n",
        );
        let e = import(&input).unwrap_err().to_string();
        assert!(e.contains("gnss.txt:2") && e.contains("increase"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
