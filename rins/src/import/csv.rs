//! `rins import csv`: an IMU-only log (any logger's CSV, described by a
//! column map) into a static-base recording: no table, no GNSS.
//!
//! Times come from the map (`[time] source`): the log's own time column
//! ("log", its first row at 0) or the sensor's nominal clock ("rate":
//! sample `k` at `k / rate_hz`). Stamps taken on arrival (a logger that
//! receives samples in bursts, or polls them late) are put back on the
//! sensor's regular clock when no sample was lost
//! ([`recording::clock::regular`]: always with `[time] regular = true`,
//! which refuses a log it cannot; otherwise whenever the stamps break into
//! pieces), else kept with their gaps and said. The samples go into the
//! base frame through the sensor's mounting, as every importer does.

use super::columns::{ColumnMap, TimeSource};
use anyhow::{anyhow, bail, Result};
use hal_sim::imu::ImuSpec;
use recording::{Meta, Recording, SampleKind, TableSource};
use std::path::PathBuf;

/// What `rins import csv` takes.
#[derive(Clone, Debug)]
pub struct CsvInput {
    /// The IMU CSV.
    pub imu: PathBuf,
    /// Its column map.
    pub columns: PathBuf,
    /// The sensor (its model name and mounting).
    pub sensor: ImuSpec,
    /// The site: latitude, deg, and height above the ellipsoid, m.
    pub lat_deg: f64,
    /// See `lat_deg`.
    pub height_m: f64,
    /// The base's roll, pitch and heading, deg, and their 1-sigma (level,
    /// heading), deg, where known; an unknown heading is written with a
    /// 1-sigma of 180 deg (any heading), the level from the data's own
    /// alignment.
    pub base: Option<[f64; 3]>,
    /// See `base`.
    pub base_sigma_deg: [Option<f64>; 2],
}

/// What the import counted and did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct CsvReport {
    /// IMU samples written.
    pub imu_samples: usize,
    /// Rows that repeated the previous one (dropped; time-stamped logs).
    pub imu_repeats: usize,
    /// A cut first or last line, dropped.
    pub cut_first: bool,
    /// See `cut_first`.
    pub cut_last: bool,
    /// The stamps' pieces without a gap, before any re-stamping.
    pub pieces: usize,
    /// The stamps were put on the sensor's regular clock: the mean and
    /// largest lag of the stamps behind it, ms.
    pub restamped_lag_ms: Option<(f64, f64)>,
    /// Why they were not, when they break into pieces.
    pub kept_gaps: Option<String>,
    /// The sample rate the stamps show, Hz.
    pub rate_found_hz: f64,
}

/// The samples' times (s from the first) and what was done to them.
fn times(map: &ColumnMap, stamps: &[f64], rep: &mut CsvReport) -> Result<Vec<f64>> {
    let t0 = stamps.first().copied().unwrap_or(0.0);
    let t: Vec<f64> = stamps.iter().map(|s| s - t0).collect();
    let dt = 1.0 / map.rate_hz;
    rep.pieces = recording::segments(&t, dt).len();
    let shared = super::shared_stamps(&t);
    if !map.regular && rep.pieces <= 1 && shared == 0 {
        return Ok(t);
    }
    match recording::clock::regular(&t) {
        Ok(r) => {
            rep.restamped_lag_ms = Some((r.mean_lag_s * 1e3, r.max_lag_s * 1e3));
            let first = r.t_s.first().copied().unwrap_or(0.0);
            Ok(r.t_s.iter().map(|x| x - first).collect())
        }
        Err(e) if map.regular => bail!("[time] regular: {e}"),
        Err(e) if shared > 0 => bail!("{}", super::shared_refused(shared, &e)),
        Err(e) => {
            rep.kept_gaps = Some(e.to_string());
            Ok(t)
        }
    }
}

/// Imports an IMU-only CSV.
///
/// # Errors
/// What the column map and the CSV reader refuse (naming file and line);
/// a map whose times are GPST or through a tag file (`rins import
/// rtklib` reads those); stamps that `[time] regular` cannot put on one
/// clock.
pub fn import(input: &CsvInput) -> Result<(Recording, CsvReport)> {
    let map = ColumnMap::read(&input.columns)?;
    if matches!(map.source, TimeSource::Tag | TimeSource::Gpst) {
        bail!(
            "{}: time.source {:?} puts the log on GPST for its fixes: that is `rins import rtklib`; an IMU-only log takes \"log\" (its time column) or \"rate\" (no time column)",
            input.columns.display(),
            map.source
        );
    }
    if !(-90.0..=90.0).contains(&input.lat_deg) {
        bail!("--lat-deg {} is outside [-90, 90]", input.lat_deg);
    }
    let csv = map.read_csv(&input.imu)?;
    let mut rep = CsvReport {
        imu_repeats: csv.repeats,
        cut_first: csv.cut_first,
        cut_last: csv.cut_last,
        ..CsvReport::default()
    };
    let stamps: Vec<f64> = csv.samples.iter().map(|s| s.stamp_s).collect();
    let t = times(&map, &stamps, &mut rep)?;
    let span = t.last().copied().unwrap_or(0.0);
    rep.rate_found_hz = (t.len().saturating_sub(1)) as f64 / span.max(f64::MIN_POSITIVE);
    let imu = super::in_base_frame(&csv.samples, &t, &input.sensor);
    rep.imu_samples = imu.len();
    let [roll, pitch, heading] = input.base.unwrap_or([0.0; 3]);
    let [level_sigma, heading_sigma] = input.base_sigma_deg;
    let meta = Meta {
        description: Some(format!(
            "imported by rins import csv: {} ({}){}",
            input.imu.display(),
            input.columns.display(),
            if input.base.is_none() {
                "; the base's attitude was not given: its heading is any (1-sigma 180 deg), its level the data's own"
            } else {
                ""
            }
        )),
        latitude_deg: input.lat_deg,
        height_m: input.height_m,
        gravity_mps2: None,
        heading_deg: heading,
        pitch_deg: pitch,
        roll_deg: roll,
        heading_sigma_deg: match input.base {
            None => Some(180.0),
            Some(_) => heading_sigma,
        },
        level_sigma_deg: level_sigma,
        imu_model: Some(input.sensor.model.clone()),
        imu_rate_hz: map.rate_hz,
        imu_sample: SampleKind::Instantaneous,
        axis: core_nav::table::Axis::Z,
        encoder_rate_hz: map.rate_hz,
        table_source: TableSource::None,
    };
    let rec = Recording::fixed_imu(meta, imu, None);
    if rec.imu.len() < 2 {
        return Err(anyhow!("{}: fewer than two samples", input.imu.display()));
    }
    Ok((rec, rep))
}

/// What the import did, for a person.
pub fn report_text(r: &CsvReport, out: &std::path::Path) -> String {
    let mut s = format!(
        "wrote {}: {} IMU samples ({:.2} Hz on the log's clock); dropped {} repeated rows, cut first line: {}, cut last line: {}\n",
        out.display(),
        r.imu_samples,
        r.rate_found_hz,
        r.imu_repeats,
        r.cut_first,
        r.cut_last
    );
    if let Some((mean, max)) = r.restamped_lag_ms {
        s += &format!(
            "the stamps ({} gap-free pieces) are arrival times: the samples are on the sensor's regular clock, the stamps {mean:.1} ms late on average ({max:.1} ms at most)\n",
            r.pieces
        );
    }
    if let Some(why) = &r.kept_gaps {
        s += &format!(
            "the stamps break into {} gap-free pieces, kept as gaps: {why}\n",
            r.pieces
        );
    }
    s
}
