//! Importers (`rins import`): real logs into recording-v1 with its
//! moving-base files. An IMU fixed to the vehicle is a recording with no
//! table; its samples are written in the base frame `b` through the
//! sensor file's mounting (`C_s^b`), and the antenna's lever arm goes to
//! `[gnss] antenna_b_m`.
//!
//! - [`rtklib`]: an RTKLIB `.pos` solution plus an IMU CSV described by a
//!   column map ([`columns`]), its clock put on GPST through an RTKLIB
//!   `.tag` file ([`tag`]) or already GPST.
//! - [`csv`]: an IMU-only log by the same column map, its stamps put on
//!   the sensor's regular clock when they are arrival times.
//! - [`kfgins`]: KF-GINS text files (IMU increments, GNSS with sigmas, a
//!   reference).
//! - [`comma`]: a comma2k19 segment's NumPy arrays (IMU, u-blox fixes,
//!   CAN speed, the pose as a reference).

pub mod columns;
pub mod comma;
pub mod csv;
pub mod fixcheck;
pub mod kfgins;
pub mod npy;
pub mod rtklib;
pub mod tag;

use anyhow::{anyhow, bail, Result};
use hal_sim::imu::ImuSpec;
use nalgebra::Vector3;
use recording::moving::{GnssMeta, GnssRow, MovingBase};
use recording::{ImuRow, Meta, Recording, SampleKind, TableSource};
use std::path::PathBuf;

/// What `rins import rtklib` takes.
#[derive(Clone, Debug)]
pub struct RtklibInput {
    /// The solution file.
    pub pos: PathBuf,
    /// The IMU CSV.
    pub imu: PathBuf,
    /// Its column map.
    pub columns: PathBuf,
    /// Its RTKLIB tag file (default: the IMU file's name + `.tag`).
    pub imu_tag: Option<PathBuf>,
    /// Added to the solution's heights, m (the geoid's height above the
    /// ellipsoid when they are above mean sea level).
    pub geoid_m: f64,
    /// The sensor (its model name, mounting and antenna lever arm).
    pub sensor: ImuSpec,
}

/// What an import counted and found.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ImportReport {
    /// IMU samples written.
    pub imu_samples: usize,
    /// Rows that repeated the previous one (a logger polling faster than
    /// its sensor), dropped.
    pub imu_repeats: usize,
    /// The log's cut first / last line, dropped.
    pub cut_first: bool,
    /// See `cut_first`.
    pub cut_last: bool,
    /// The sensor's rate on the log's clock, Hz.
    pub imu_rate_found_hz: f64,
    /// The logger clock's drift against GPST, ppm (tag files).
    pub clock_drift_ppm: Option<f64>,
    /// The logger clock's offset floor's RMS about its line, ms.
    pub clock_floor_rms_ms: Option<f64>,
    /// With a regular clock: the sightings' largest lag behind it and
    /// their mean lag, ms.
    pub sighting_lag_ms: Option<(f64, f64)>,
    /// Fixes written.
    pub fixes: usize,
    /// Fixes outside the IMU's span, dropped.
    pub fixes_outside: usize,
    /// Fixes per solution type (RTKLIB's Q 1..6).
    pub fixes_by_q: [usize; 6],
    /// GPST (Unix-epoch scale) of the recording's `t_s = 0`.
    pub t0_gpst: f64,
    /// The fixes against the log's reference solution, when it has one
    /// (comma2k19's pose), and the sigmas they were written with.
    pub fixes_against_reference: Option<fixcheck::FixesAgainstReference>,
    /// The device's own gyro bias estimate that the log's calibrated
    /// stream has had taken out, deg/s in `b` (its mean over the span),
    /// when the log keeps it (comma2k19's `IMU/gyro_bias`): the chip's
    /// turn-on bias is then the device's to remove, and what is left is
    /// its estimate's error, which no sensor file states.
    pub device_gyro_bias_dps: Option<[f64; 3]>,
}

/// The IMU samples' GPST (s) and how the clock was found.
fn sample_times(
    map: &columns::ColumnMap,
    csv: &columns::ImuCsv,
    input: &RtklibInput,
    rep: &mut ImportReport,
) -> Result<Vec<f64>> {
    let stamps = || csv.samples.iter().map(|s| s.stamp_s);
    if map.source == columns::TimeSource::Gpst {
        if let Some(t) = &input.imu_tag {
            bail!(
                "--imu-tag {}: the column map's time source is \"gpst\" (the time column is GPST already); a tag file is read only with source \"tag\"",
                t.display()
            );
        }
        return Ok(stamps().collect());
    }
    let tag_path = input.imu_tag.clone().unwrap_or_else(|| {
        let mut p = input.imu.clone().into_os_string();
        p.push(".tag");
        PathBuf::from(p)
    });
    let tag = tag::TagFile::read(&tag_path)?;
    let crlf = match tag.stream_len() {
        n if n == csv.len_crlf => true,
        n if n == csv.len_lf => false,
        n => bail!(
            "{}: the tags count {n} bytes; {} holds {} (or {} with CRLF line ends): not its tag file",
            tag_path.display(),
            input.imu.display(),
            csv.len_lf,
            csv.len_crlf
        ),
    };
    let ends: Vec<u64> = csv
        .rows
        .iter()
        .map(|r| if crlf { r.2 } else { r.1 })
        .collect();
    let received = tag.receive_times(&ends);
    let row_stamps: Vec<f64> = csv.rows.iter().map(|r| r.0).collect();
    let clock = tag::ClockMap::fit(&row_stamps, &received)?;
    rep.clock_drift_ppm = Some(clock.drift * 1e6);
    rep.clock_floor_rms_ms = Some(clock.floor_rms_s * 1e3);
    Ok(stamps().map(|s| clock.gpst(s)).collect())
}

/// The samples at times `t_s` (s) as recording rows in the base frame:
/// turned by the sensor's mounting (`C_s^b`), the one place every
/// importer does it.
pub fn in_base_frame(samples: &[columns::RawSample], t_s: &[f64], sensor: &ImuSpec) -> Vec<ImuRow> {
    let c_s_b = sensor.mounting.c_s_b();
    samples
        .iter()
        .zip(t_s)
        .map(|(s, t)| {
            let g = c_s_b * Vector3::from(s.gyro_radps);
            let a = c_s_b * Vector3::from(s.accel_mps2);
            ImuRow {
                t_s: *t,
                gyro_radps: [g.x, g.y, g.z],
                accel_mps2: [a.x, a.y, a.z],
                temp_c: None,
            }
        })
        .collect()
}

/// How many samples share their stamp with the one before (a logger that
/// stamps a burst at once).
pub fn shared_stamps(t_s: &[f64]) -> usize {
    t_s.windows(2).filter(|w| w[1] <= w[0]).count()
}

/// Why samples that share stamps cannot be imported, and what to do.
fn shared_refused(shared: usize, e: &recording::clock::Irregular) -> String {
    format!(
        "{shared} samples share their stamp with the one before (a logger stamping bursts as they arrive): they are put on the sensor's regular clock, which these stamps do not allow: {e}; cut the log at its gaps, or give a time column the sensor made"
    )
}

/// A regular sensor clock through the first sightings of its samples
/// (`[time] regular = true`): a logger sees each sample some time after
/// it was made, never before: polled faster than the sensor, or delivered
/// in bursts ([`recording::clock::regular`], the one home of the rule; a
/// lost sample is refused).
fn regular_clock(t: &[f64], rep: &mut ImportReport) -> Result<Vec<f64>> {
    let r = recording::clock::regular(t).map_err(|e| anyhow!("[time] regular: {e}"))?;
    rep.sighting_lag_ms = Some((r.max_lag_s * 1e3, r.mean_lag_s * 1e3));
    Ok(r.t_s)
}

/// Imports an RTKLIB solution and an IMU CSV.
///
/// # Errors
/// What the readers refuse (naming file and line); a tag file that does
/// not belong to the IMU file; no fix inside the IMU's span.
pub fn rtklib(input: &RtklibInput) -> Result<(Recording, ImportReport)> {
    let map = columns::ColumnMap::read(&input.columns)?;
    if matches!(
        map.source,
        columns::TimeSource::Log | columns::TimeSource::Rate
    ) {
        bail!(
            "{}: time.source {:?} leaves the log off GPST, where its fixes are: give \"tag\" or \"gpst\" (an IMU-only log: rins import csv)",
            input.columns.display(),
            map.source
        );
    }
    let csv = map.read_csv(&input.imu)?;
    let epochs = rtklib::read_pos(&input.pos, input.geoid_m)?;
    let mut rep = ImportReport {
        imu_repeats: csv.repeats,
        cut_first: csv.cut_first,
        cut_last: csv.cut_last,
        ..ImportReport::default()
    };
    let mut t_gpst = sample_times(&map, &csv, input, &mut rep)?;
    let shared = shared_stamps(&t_gpst);
    if map.regular {
        t_gpst = regular_clock(&t_gpst, &mut rep)?;
    } else if shared > 0 {
        t_gpst = match recording::clock::regular(&t_gpst) {
            Ok(_) => regular_clock(&t_gpst, &mut rep)?,
            Err(e) => bail!("{}", shared_refused(shared, &e)),
        };
    }
    let (t0, t_end) = match (t_gpst.first(), t_gpst.last()) {
        (Some(a), Some(b)) => (*a, *b),
        _ => bail!("{}: no IMU samples", input.imu.display()),
    };
    rep.t0_gpst = t0;
    rep.imu_rate_found_hz = (t_gpst.len() - 1) as f64 / (t_end - t0);
    let t_s: Vec<f64> = t_gpst.iter().map(|t| t - t0).collect();
    let imu = in_base_frame(&csv.samples, &t_s, &input.sensor);
    rep.imu_samples = imu.len();
    let mut gnss: Vec<GnssRow> = vec![];
    for e in &epochs {
        if e.t_gpst < t0 || e.t_gpst > t_end {
            rep.fixes_outside += 1;
            continue;
        }
        if let Some(q) = e.row.quality {
            if let Some(c) = rep.fixes_by_q.get_mut(usize::from(q.q()) - 1) {
                *c += 1;
            }
        }
        gnss.push(GnssRow {
            t_s: e.t_gpst - t0,
            ..e.row
        });
    }
    rep.fixes = gnss.len();
    let first = gnss
        .first()
        .ok_or_else(|| anyhow!("{}: no fix inside the IMU's span", input.pos.display()))?;
    let rate_hz = match (gnss.len(), gnss.last()) {
        (n, Some(l)) if n > 1 && l.t_s > first.t_s => {
            ((n - 1) as f64 / (l.t_s - first.t_s)).round().max(1.0)
        }
        _ => 1.0,
    };
    let meta = Meta {
        description: Some(format!(
            "imported by rins import rtklib: {} + {} ({})",
            input.pos.display(),
            input.imu.display(),
            input.columns.display()
        )),
        latitude_deg: first.lat_deg,
        height_m: first.height_m,
        gravity_mps2: None,
        heading_deg: 0.0,
        pitch_deg: 0.0,
        roll_deg: 0.0,
        heading_sigma_deg: None,
        level_sigma_deg: None,
        imu_model: Some(input.sensor.model.clone()),
        imu_rate_hz: map.rate_hz,
        imu_sample: SampleKind::Instantaneous,
        axis: core_nav::table::Axis::Z,
        encoder_rate_hz: map.rate_hz,
        table_source: TableSource::None,
    };
    let moving = MovingBase {
        odometer: None,
        longitude_deg: first.lon_deg,
        gnss_meta: Some(GnssMeta {
            antenna_b_m: input.sensor.mounting.antenna_b_m.unwrap_or([0.0; 3]),
            rate_hz,
        }),
        gnss: Some(gnss),
        truth: None,
        heading_unknown: true,
    };
    let rec = Recording::fixed_imu(meta, imu, Some(moving));
    Ok((rec, rep))
}

/// What an import did, for a person.
pub fn report_text(r: &ImportReport, out: &std::path::Path) -> String {
    let q = ["fixed", "float", "SBAS", "DGNSS", "single", "PPP"];
    let by_q: Vec<String> = r
        .fixes_by_q
        .iter()
        .zip(q)
        .filter(|(n, _)| **n > 0)
        .map(|(n, name)| format!("{n} {name}"))
        .collect();
    let mut s = format!(
        "wrote {}: {} IMU samples ({:.2} Hz on the log's clock), {} fixes ({})\n",
        out.display(),
        r.imu_samples,
        r.imu_rate_found_hz,
        r.fixes,
        by_q.join(", ")
    );
    s.push_str(&format!(
        "dropped: {} repeated IMU rows (the logger polled faster than the sensor), cut first line: {}, cut last line: {}, {} fixes outside the IMU's span\n",
        r.imu_repeats, r.cut_first, r.cut_last, r.fixes_outside
    ));
    if let (Some(d), Some(f)) = (r.clock_drift_ppm, r.clock_floor_rms_ms) {
        s.push_str(&format!(
            "logger clock on GPST through the time tags: drift {d:+.1} ppm, delivery floor RMS {f:.2} ms\n"
        ));
    }
    if let Some((spread, lag)) = r.sighting_lag_ms {
        s.push_str(&format!(
            "samples on the sensor's regular clock: the logger saw them {lag:.1} ms late on average ({spread:.1} ms at most)\n"
        ));
    }
    s.push_str("the base's heading at the start is not known: navigate --gnss finds it from the fixes' velocity");
    s
}
