//! A car's constraints through GNSS outages, Monte Carlo (`rins outages
//! --vehicle car`): simulated drives with the base mounted in the car at a
//! rotation the filter is not told (drawn per drive), each navigated with
//! and without the constraints ([`crate::aided::vehicle`]). The figures:
//! the horizontal error at each outage's end, the NEES, and the forward
//! axis found against the one simulated, in its own sigmas.
//!
//! Simulated only: hal-sim's car does not slide or bounce (its cross
//! velocities are zero), so the constraints here are at least as true as
//! on a road; their sigma is the road's ([`core_nav::vehicle`]).

use crate::aided::{self, vehicle::Vehicle, AidedOptions};
use crate::outages::{config_mounted, table_head, TABLE_DPS};
use anyhow::{anyhow, Result};
use core_nav::stats::mean;
use hal_sim::drive::DriveKind;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::simulate;
use nalgebra::Vector3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The outages of each drive (start s, length s): a minute and two.
pub const OUTAGES: [(f64, f64); 2] = [(300.0, 60.0), (600.0, 120.0)];

/// The format of the study's JSON.
pub const FORMAT: &str = "rins-vehicle-outages/1";

/// One drive, navigated both ways.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VehicleRun {
    /// Sensor profile.
    pub imu: String,
    /// Seed.
    pub seed: u64,
    /// The base's mounting in the car: roll, pitch, yaw, deg.
    pub mounting_deg: [f64; 3],
    /// Horizontal error at each outage's end without the constraints, m.
    pub end_error_off_m: Vec<f64>,
    /// ... with them, m.
    pub end_error_on_m: Vec<f64>,
    /// Fraction of seconds with the NEES inside its 95 % bounds, off and
    /// on.
    pub nees_in_95: [f64; 2],
    /// The forward axis's error in its own sigma: yaw, pitch (`None`: not
    /// found).
    pub forward_sigmas: Option<[f64; 2]>,
}

/// The study.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VehicleStudy {
    /// [`FORMAT`].
    pub format: String,
    /// Drive kind.
    pub drive: String,
    /// The outages (start s, length s).
    pub outages: Vec<(f64, f64)>,
    /// Every run, by sensor then seed.
    pub runs: Vec<VehicleRun>,
}

/// The mounting of drive `seed` (roll, pitch, yaw, deg): upright or upside
/// down (as the held-back real drive's) within 5 deg of roll and pitch,
/// any yaw.
pub fn mounting_deg(seed: u64) -> [f64; 3] {
    let mut r = hal_sim::rng::Rng::new(seed, 77);
    let mut u = |a: f64| (2.0 * r.uniform() - 1.0) * a;
    let flip = if u(1.0) < 0.0 { 180.0 } else { 0.0 };
    [flip + u(5.0), u(5.0), u(180.0)]
}

/// The vehicle's forward axis in `b` for a base mounted at `mounting_deg`
/// (`c_v_b x_v`) as [`crate::aided::vehicle::ForwardReport`] gives it:
/// its yaw and its pitch up from `b`'s x-y plane, deg.
pub fn forward_truth_deg(mounting_deg: [f64; 3]) -> [f64; 2] {
    let x = hal_sim::drive::mounting(mounting_deg).transpose() * Vector3::x();
    [x.y.atan2(x.x).to_degrees(), (-x.z).asin().to_degrees()]
}

/// An angle's difference wrapped to +-180 deg.
pub fn wrap_deg(d: f64) -> f64 {
    (d + 540.0).rem_euclid(360.0) - 180.0
}

/// Runs `drives` seeds per sensor from `first_seed`, in parallel.
///
/// # Errors
/// A simulation or navigation failure.
pub fn run(
    kind: DriveKind,
    imus: &[ImuSpec],
    first_seed: u64,
    drives: u64,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<VehicleStudy> {
    let jobs: Vec<(usize, u64)> = (0..imus.len())
        .flat_map(|i| (0..drives).map(move |d| (i, first_seed + d)))
        .collect();
    let done = AtomicUsize::new(0);
    let runs = jobs
        .par_iter()
        .map(|&(i, seed)| {
            let r = one(kind, &imus[i], seed);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(d as f64 / jobs.len().max(1) as f64);
            r
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(VehicleStudy {
        format: FORMAT.into(),
        drive: kind.name().into(),
        outages: OUTAGES.to_vec(),
        runs,
    })
}

fn one(kind: DriveKind, imu: &ImuSpec, seed: u64) -> Result<VehicleRun> {
    let m = mounting_deg(seed);
    let cfg = config_mounted(kind, imu, true, seed, &OUTAGES, m);
    let rec = simulate(&cfg, &mut |_| {}).map_err(|e| anyhow!("{e}"))?;
    let mut ends = [vec![], vec![]];
    let mut nees = [f64::NAN; 2];
    let mut forward_sigmas = None;
    for (k, vehicle) in [None, Some(Vehicle::Car)].into_iter().enumerate() {
        let opt = AidedOptions {
            vehicle,
            ..AidedOptions::new(imu.clone())
        };
        let run = aided::navigate(&rec, &opt, &mut |_| {})?;
        let s = aided::summary(&rec, &run);
        for (start, len) in OUTAGES {
            let g = s
                .outages
                .iter()
                .find(|g| g.start_s <= start + 1e-6 && g.start_s + g.len_s >= start + len - 1e-6);
            if let Some(e) = ends.get_mut(k) {
                e.push(g.and_then(|g| g.end_error_m).unwrap_or(f64::NAN));
            }
        }
        nees[k] = s.nees_in_95.unwrap_or(f64::NAN);
        if let Some(f) = s.vehicle.and_then(|v| v.forward) {
            let [yaw, pitch] = forward_truth_deg(m);
            let dyaw = wrap_deg(f.yaw_deg - yaw);
            forward_sigmas = Some([
                dyaw.abs() / f.sigma_yaw_deg,
                (f.pitch_deg - pitch).abs() / f.sigma_pitch_deg,
            ]);
        }
    }
    let [off, on] = ends;
    Ok(VehicleRun {
        imu: imu.name.clone(),
        seed,
        mounting_deg: m,
        end_error_off_m: off,
        end_error_on_m: on,
        nees_in_95: nees,
        forward_sigmas,
    })
}

impl VehicleStudy {
    /// The table as markdown: per sensor, the mean end error of each
    /// outage off and on, the NEES inside its bounds, the forward axis.
    pub fn markdown(&self) -> String {
        let mut imus: Vec<&str> = self.runs.iter().map(|r| r.imu.as_str()).collect();
        imus.dedup();
        let mut cols = vec!["sensor".to_string(), "drives".into()];
        for (_, l) in &self.outages {
            cols.extend([format!("{l:.0} s off"), format!("{l:.0} s on")]);
        }
        cols.extend([
            "NEES in 95 % off / on".into(),
            "forward axis within 3 sigma".into(),
        ]);
        let mut o = format!(
            "Horizontal error at each GNSS outage's end, mean over the {} drives (the table at {TABLE_DPS:.0} deg/s, the base mounted in the car at a rotation drawn per drive and not told), without and with the car's constraints (m):\n\n{}",
            self.drive,
            table_head(&cols)
        );
        for imu in imus {
            o += &self.row(imu);
        }
        o
    }

    fn row(&self, imu: &str) -> String {
        let runs: Vec<&VehicleRun> = self.runs.iter().filter(|r| r.imu == imu).collect();
        let col = |f: &dyn Fn(&VehicleRun) -> Option<f64>| {
            let v: Vec<f64> = runs
                .iter()
                .filter_map(|r| f(r))
                .filter(|x| x.is_finite())
                .collect();
            mean(&v)
        };
        let mut o = format!("| {imu} | {} |", runs.len());
        for k in 0..self.outages.len() {
            let off = col(&|r| r.end_error_off_m.get(k).copied());
            let on = col(&|r| r.end_error_on_m.get(k).copied());
            o += &format!(" {off:.2} | {on:.2} |");
        }
        let within = runs
            .iter()
            .filter(|r| r.forward_sigmas.is_some_and(|[y, p]| y <= 3.0 && p <= 3.0))
            .count();
        o += &format!(
            " {:.0} % / {:.0} % | {within} of {} |\n",
            100.0 * col(&|r| r.nees_in_95.first().copied()),
            100.0 * col(&|r| r.nees_in_95.get(1).copied()),
            runs.len()
        );
        o
    }
}
