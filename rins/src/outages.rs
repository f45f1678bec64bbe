//! The aided rotary INS through GNSS outages, Monte Carlo (`rins outages`):
//! simulated drives (hal-sim) with outages of 10, 30, 60 and 120 s, each
//! navigated with GNSS and zero-velocity aiding ([`crate::aided`]), rotary
//! (`continuous` at 30 deg/s) against conventional (the table still), per
//! sensor. The figure is the horizontal error at each outage's end.

use crate::aided::{self, AidedOptions};
use crate::shard::Shard;
use anyhow::{anyhow, Result};
use core_nav::scheme::Scheme;
use core_nav::stats::{mean, median};
use core_nav::table::Axis;
use hal_sim::drive::{DriveKind, GnssSpec};
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, DriveSpec, SimConfig};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Outages of each drive: (start s, length s). Starts are spread so each
/// outage begins at a different point of the drive (moving or stopped).
pub const OUTAGES: [(f64, f64); 4] = [(150.0, 10.0), (280.0, 30.0), (420.0, 60.0), (600.0, 120.0)];
/// Drive length, s.
pub const DRIVE_S: f64 = 900.0;
/// Table rate of the rotary runs, deg/s.
pub const TABLE_DPS: f64 = 30.0;

/// One drive navigated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DriveResult {
    /// Sensor profile.
    pub imu: String,
    /// Rotary (true) or conventional.
    pub rotary: bool,
    /// Seed.
    pub seed: u64,
    /// Horizontal error at the end of each outage of [`OUTAGES`], m.
    pub end_error_m: Vec<f64>,
    /// The filter's horizontal 1-sigma there, m.
    pub end_sigma_m: Vec<f64>,
    /// Mean NEES per degree of freedom over the drive.
    pub nees_per_dof: f64,
    /// Fraction of seconds with the NEES inside its 95 % bounds.
    pub nees_in_95: f64,
}

/// The study (or one shard of it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OutageStudy {
    /// `rins-outages/1`.
    pub format: String,
    /// Drive kind.
    pub drive: String,
    /// The sensors, in order.
    pub imus: Vec<String>,
    /// The first drive's seed.
    pub first_seed: u64,
    /// Drives per sensor and scheme.
    pub drives: u64,
    /// The shard these runs are (0/1: the whole study).
    pub shard: Shard,
    /// Outages (start, length), s.
    pub outages: Vec<(f64, f64)>,
    /// Every drive run, in the study's order (sensor, rotary first, seed).
    pub runs: Vec<DriveResult>,
}

/// The format of the study's JSON.
pub const FORMAT: &str = "rins-outages/1";

/// The simulation of one drive with the study's outages.
pub fn config(kind: DriveKind, imu: &ImuSpec, rotary: bool, seed: u64) -> SimConfig {
    config_with(kind, imu, rotary, seed, &OUTAGES)
}

/// The simulation of one drive with `outages` (start s, length s).
pub fn config_with(
    kind: DriveKind,
    imu: &ImuSpec,
    rotary: bool,
    seed: u64,
    outages: &[(f64, f64)],
) -> SimConfig {
    config_mounted(kind, imu, rotary, seed, outages, [0.0; 3])
}

/// [`config_with`] with the base mounted in the vehicle at roll, pitch,
/// yaw `mounting_deg` (deg).
pub fn config_mounted(
    kind: DriveKind,
    imu: &ImuSpec,
    rotary: bool,
    seed: u64,
    outages: &[(f64, f64)],
    mounting_deg: [f64; 3],
) -> SimConfig {
    let mut c = SimConfig::new(imu.clone(), Axis::Z, DRIVE_S);
    c.scheme = if rotary {
        Scheme::Continuous {
            rate: TABLE_DPS.to_radians(),
        }
    } else {
        Scheme::Still
    };
    c.seed = seed;
    c.drive = Some(DriveSpec {
        kind,
        gnss: GnssSpec {
            outages: outages.to_vec(),
            ..GnssSpec::default()
        },
        longitude_deg: 114.35,
        mounting_deg,
        imu_ahead_m: 0.0,
    });
    c
}

/// Runs `drives` seeds per (sensor, scheme) from `first_seed`, the drives
/// of `shard` only (drive `d`, seed `first_seed + d`, when `d mod N = K`),
/// in parallel on rayon's pool.
///
/// # Errors
/// A simulation or navigation failure.
pub fn run(
    kind: DriveKind,
    imus: &[ImuSpec],
    first_seed: u64,
    drives: u64,
    shard: Shard,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<OutageStudy> {
    let jobs: Vec<(usize, bool, u64)> = (0..imus.len())
        .flat_map(|i| {
            [true, false].into_iter().flat_map(move |r| {
                (0..drives)
                    .filter(move |d| shard.has(*d as usize))
                    .map(move |d| (i, r, first_seed + d))
            })
        })
        .collect();
    let done = AtomicUsize::new(0);
    let runs = jobs
        .par_iter()
        .map(|&(i, rotary, seed)| {
            let r = one(kind, &imus[i], rotary, seed);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(d as f64 / jobs.len().max(1) as f64);
            r
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(OutageStudy {
        format: FORMAT.into(),
        drive: kind.name().into(),
        imus: imus.iter().map(|m| m.name.clone()).collect(),
        first_seed,
        drives,
        shard,
        outages: OUTAGES.to_vec(),
        runs,
    })
}

/// The shards of one study put back together: the study one run would
/// have given, bit for bit.
///
/// # Errors
/// Shards of different studies, or not every shard once.
pub fn merge(parts: Vec<OutageStudy>) -> Result<OutageStudy> {
    let first = parts.first().ok_or_else(|| anyhow!("no shard to merge"))?;
    let same = |p: &OutageStudy| {
        (
            &p.format,
            &p.drive,
            &p.imus,
            p.first_seed,
            p.drives,
            &p.outages,
        ) == (
            &first.format,
            &first.drive,
            &first.imus,
            first.first_seed,
            first.drives,
            &first.outages,
        )
    };
    if let Some(p) = parts.iter().find(|p| !same(p)) {
        return Err(anyhow!(
            "shard {}/{} is of another study (drive, sensors, seeds or outages differ)",
            p.shard.k,
            p.shard.n
        ));
    }
    let shards: Vec<Shard> = parts.iter().map(|p| p.shard).collect();
    crate::shard::complete(&shards).map_err(|e| anyhow!(e))?;
    let mut merged = first.clone();
    merged.shard = Shard::ALL;
    merged.runs = parts.into_iter().flat_map(|p| p.runs).collect();
    let imus = merged.imus.clone();
    let pos = |r: &DriveResult| imus.iter().position(|m| *m == r.imu).unwrap_or(usize::MAX);
    merged.runs.sort_by_key(|r| (pos(r), !r.rotary, r.seed));
    Ok(merged)
}

fn one(kind: DriveKind, imu: &ImuSpec, rotary: bool, seed: u64) -> Result<DriveResult> {
    let rec =
        simulate(&config(kind, imu, rotary, seed), &mut |_| {}).map_err(|e| anyhow!("{e}"))?;
    let opt = AidedOptions::new(imu.clone());
    let run = aided::navigate(&rec, &opt, &mut |_| {})?;
    let s = aided::summary(&rec, &run);
    // Match each planned outage to the gap that contains its start.
    let mut end_error_m = vec![];
    let mut end_sigma_m = vec![];
    for (start, len) in OUTAGES {
        let g = s
            .outages
            .iter()
            .find(|g| g.start_s <= start + 1e-6 && g.start_s + g.len_s >= start + len - 1e-6);
        end_error_m.push(g.and_then(|g| g.end_error_m).unwrap_or(f64::NAN));
        end_sigma_m.push(g.map_or(f64::NAN, |g| g.end_sigma_m));
    }
    Ok(DriveResult {
        imu: imu.name.clone(),
        rotary,
        seed,
        end_error_m,
        end_sigma_m,
        nees_per_dof: s.nees_mean_per_dof.unwrap_or(f64::NAN),
        nees_in_95: s.nees_in_95.unwrap_or(f64::NAN),
    })
}

/// A markdown table's header row and its rule, `cols` in order.
pub(crate) fn table_head(cols: &[String]) -> String {
    format!(
        "| {} |\n|{}\n",
        cols.join(" | "),
        " --- |".repeat(cols.len())
    )
}

impl OutageStudy {
    /// Mean end error per (sensor, rotary, outage index), m.
    pub fn mean_error(&self, imu: &str, rotary: bool, k: usize) -> f64 {
        let v: Vec<f64> = self
            .runs
            .iter()
            .filter(|r| r.imu == imu && r.rotary == rotary)
            .filter_map(|r| r.end_error_m.get(k).copied())
            .filter(|x| x.is_finite())
            .collect();
        mean(&v)
    }

    /// The table as markdown.
    pub fn markdown(&self) -> String {
        let mut imus: Vec<&str> = self.runs.iter().map(|r| r.imu.as_str()).collect();
        imus.dedup();
        let n = self
            .runs
            .iter()
            .filter(|r| r.imu == imus.first().copied().unwrap_or("") && r.rotary)
            .count();
        let mut cols = vec!["sensor".to_string(), "scheme".into()];
        cols.extend(self.outages.iter().map(|(_, l)| format!("{l:.0} s")));
        cols.extend(["NEES / dof".into(), "NEES in 95 %".into()]);
        let mut o = format!(
            "Horizontal error at the end of each GNSS outage, mean (median) over {n} {} drives of {DRIVE_S:.0} s (m):\n\n{}",
            self.drive,
            table_head(&cols)
        );
        for imu in &imus {
            for rotary in [false, true] {
                let rs: Vec<&DriveResult> = self
                    .runs
                    .iter()
                    .filter(|r| r.imu == *imu && r.rotary == rotary)
                    .collect();
                o += &format!(
                    "| {imu} | {} |",
                    if rotary {
                        "rotary 30 deg/s"
                    } else {
                        "conventional"
                    }
                );
                for k in 0..self.outages.len() {
                    let mut v: Vec<f64> = rs
                        .iter()
                        .filter_map(|r| r.end_error_m.get(k).copied())
                        .filter(|x| x.is_finite())
                        .collect();
                    let med = median(&mut v);
                    o += &format!(" {:.1} ({med:.1}) |", mean(&v));
                }
                let nees: Vec<f64> = rs
                    .iter()
                    .map(|r| r.nees_per_dof)
                    .filter(|x| x.is_finite())
                    .collect();
                let inb: Vec<f64> = rs
                    .iter()
                    .map(|r| r.nees_in_95)
                    .filter(|x| x.is_finite())
                    .collect();
                o += &format!(" {:.2} | {:.0} % |\n", mean(&nees), 100.0 * mean(&inb));
            }
        }
        o
    }
}

/// The drive demo's plots for one drive (`seed`) of `imu`: a map (east vs
/// north) of the truth, the GNSS fixes, the conventional and the rotary
/// tracks (`drive_map`, one scale on both axes), and the horizontal error
/// of both against time, each over its filter's 3-sigma band, the outages
/// shaded (`drive_error`).
///
/// # Errors
/// A simulation, navigation or plotting failure.
pub fn plots(
    kind: DriveKind,
    imu: &ImuSpec,
    seed: u64,
    dir: &std::path::Path,
) -> Result<Vec<std::path::PathBuf>> {
    use crate::plot::{Chart, Dash, Series};
    let mut map = Chart {
        title: format!(
            "{} drive, {} (seed {seed}): truth, GNSS fixes, conventional and rotary tracks",
            kind.name(),
            imu.name
        ),
        x_label: "east [m]".into(),
        y_label: "north [m]".into(),
        equal_scale: true,
        ..Chart::default()
    };
    let mut err = Chart {
        title: "horizontal error against the truth through GNSS outages of 10, 30, 60 and 120 s"
            .into(),
        x_label: "time [s]".into(),
        y_label: "horizontal position error [m]".into(),
        shaded_label: "GNSS outage".into(),
        ..Chart::default()
    };
    for rotary in [false, true] {
        let rec =
            simulate(&config(kind, imu, rotary, seed), &mut |_| {}).map_err(|e| anyhow!("{e}"))?;
        let run = aided::navigate(&rec, &AidedOptions::new(imu.clone()), &mut |_| {})?;
        let truth = rec
            .moving
            .as_ref()
            .and_then(|m| m.truth.clone())
            .unwrap_or_default();
        if !rotary {
            map.series.push(
                Series::line(
                    "truth",
                    truth
                        .iter()
                        .step_by(50)
                        .map(|r| (r.p_n_m[1], r.p_n_m[0]))
                        .collect(),
                )
                .with_dash(Dash::Solid),
            );
            map.series
                .push(Series::points("GNSS fixes", aided::fixes_en(&rec)));
            err.shaded = aided::fixless(&run);
        }
        let name = if rotary { "rotary" } else { "conventional" };
        map.series.push(Series::line(
            name,
            run.rows
                .iter()
                .step_by(50)
                .map(|r| (r.traj.ned_m[1], r.traj.ned_m[0]))
                .collect(),
        ));
        let pts: Vec<(f64, f64)> = run
            .rows
            .iter()
            .zip(&truth)
            .step_by(50)
            .map(|(r, t)| {
                (
                    r.traj.t_s,
                    (r.traj.ned_m[0] - t.p_n_m[0]).hypot(r.traj.ned_m[1] - t.p_n_m[1]),
                )
            })
            .collect();
        let mut e = Series::line(format!("{name} (band: its filter's 3-sigma)"), pts);
        e.band = Some(
            run.rows
                .iter()
                .step_by(50)
                .map(|r| (0.0, 3.0 * r.sigma_p_m[0].hypot(r.sigma_p_m[1])))
                .collect(),
        );
        err.series.push(e);
    }
    let mut out = map.write(&dir.join("drive_map"))?;
    out.extend(err.write(&dir.join("drive_error"))?);
    Ok(out)
}
