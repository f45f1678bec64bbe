//! `rins reproduce`: the paper's experiment (Sec. 4) in simulation, beside
//! our best scheme and the white-noise floor.
//!
//! Protocol (the paper's): conventional INS static test, 6 min still, the
//! first minute's gyro mean as the bias, 5 min of navigation. Rotary INS
//! static tests: 2 min calibration (60 s still, 60 s rotating about z at the
//! test's rate), then 5 min of navigation rotating at 10, 20, ..., 100 deg/s,
//! processed with the biases only (`rotary-partial`) or with biases, z scale
//! factor and installation errors (`rotary-full`, the paper's least
//! squares). Navigation starts from the known attitude, position and
//! velocity (the lab's initialisation). Errors are RMS over the 5 min.

use crate::calibrate::{calibrate, Method};
use crate::nav::{navigate, static_errors, NavOptions, StaticErrors};
use crate::shard::Shard;
use anyhow::anyhow;
use anyhow::Result;
use core_nav::calib::GyroCalibration;
use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig};
use rayon::prelude::*;
use recording::Recording;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The paper's mean RMS over all rates: (imu, mode, horizontal position m,
/// horizontal velocity m/s), Sec. 4.2.1-4.2.2.
pub const PAPER: [(&str, &str, f64, f64); 4] = [
    ("mtig", "rotary-partial", 1525.8, 14.6),
    ("mtig", "rotary-full", 1057.2, 10.4),
    ("nav440", "rotary-partial", 544.8, 4.9),
    ("nav440", "rotary-full", 213.8, 2.2),
];

/// Rates of the paper's rotary tests, deg/s.
pub const RATES_DPS: [f64; 10] = [10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0];

/// How one run is made and processed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Plan {
    /// 6 min still, bias = first minute's mean.
    Conventional,
    /// 60 s still + 60 s at the rate, then 5 min at the rate; paper's
    /// calibration, biases only (`full = false`) or all terms.
    Paper {
        /// Apply scale and installation errors too.
        full: bool,
    },
    /// Our best: the paper's timeline with the earth rate taken into
    /// account in the calibration (continuous rotation modulates bias-type
    /// errors fully; reciprocating does not: a constant bias sees the same
    /// unequal time-at-angle both ways and adds up, 2.7x worse on NAV440 at
    /// 100 deg/s in our runs).
    Best,
    /// White noise only (the profile's ARW and VRW), same table motion, no
    /// calibration needed: the limit.
    NoiseFloor,
    /// The paper's calibration window (earth-aware), then a dual-axis
    /// sequence of `positions` (8 or 16) on a tri-axial table (simulation
    /// only), 180 deg moves at the rate, no dwell.
    DualAxis {
        /// 8 or 16.
        positions: u8,
    },
}

/// One table row: a mode at a rate, averaged over runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// `conventional`, `rotary-partial`, `rotary-full`, `rotary-best`, `noise-floor`.
    pub mode: String,
    /// Table rate, deg/s (0 for conventional).
    pub rate_dps: f64,
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
    /// Each run's seed, ascending.
    pub seeds: Vec<u64>,
    /// Each run's errors, in seed order (the means above are theirs).
    pub runs: Vec<StaticErrors>,
}

impl Row {
    /// The runs' mean errors.
    pub fn mean(&self) -> StaticErrors {
        mean(&self.runs)
    }
}

const CAL_S: f64 = 120.0;
const NAV_S: f64 = 300.0;

/// Simulates and processes one run of `plan` at `rate_dps` (deg/s) for
/// any spec (ablations: one error term at a time); returns the navigation
/// errors.
///
/// # Errors
/// A simulation or calibration failure (with its reason).
pub fn run_one(spec: &ImuSpec, plan: Plan, rate_dps: f64, seed: u64) -> Result<StaticErrors> {
    let rate = rate_dps.to_radians();
    let (imu, scheme, static_s) = match plan {
        Plan::DualAxis { positions } => return run_dual(spec, positions, rate, seed),
        Plan::Conventional => (spec.clone(), Scheme::Still, 0.0),
        Plan::Paper { .. } | Plan::Best => (spec.clone(), Scheme::Continuous { rate }, 60.0),
        Plan::NoiseFloor => {
            let mut w = ImuSpec::ideal();
            w.gyro.white = spec.gyro.white;
            w.accel.white = spec.accel.white;
            (w, Scheme::Continuous { rate }, 60.0)
        }
    };
    let mut cfg = SimConfig::new(imu, Axis::Z, CAL_S + NAV_S);
    cfg.scheme = scheme;
    cfg.static_s = static_s;
    cfg.seed = seed;
    let rec = simulate(&cfg, &mut |_| {})?;
    let cal = calibration(&rec, plan)?;
    let start_s = if plan == Plan::Conventional {
        60.0
    } else {
        CAL_S
    };
    let opt = NavOptions {
        start_s,
        end_s: Some(start_s + NAV_S),
        calibration: cal,
        ..NavOptions::default()
    };
    let rows = navigate(&rec, &opt, &mut |_| {})?;
    let m = &rec.meta;
    Ok(static_errors(
        &rows,
        [m.roll_deg, m.pitch_deg, m.heading_deg],
    ))
}

fn calibration(rec: &Recording, plan: Plan) -> Result<Option<GyroCalibration>> {
    Ok(match plan {
        Plan::NoiseFloor | Plan::DualAxis { .. } => None,
        Plan::Conventional => {
            // The paper: the first minute's mean is the bias (earth rate and all).
            let n = rec.imu.iter().take_while(|r| r.t_s < 60.0).count().max(1);
            let mut b = nalgebra::Vector3::zeros();
            for r in rec.imu.iter().take(n) {
                b += nalgebra::Vector3::from(r.gyro_radps);
            }
            Some(GyroCalibration {
                bias: b / n as f64,
                axis: rec.meta.axis,
                ..GyroCalibration::default()
            })
        }
        Plan::Paper { full } => {
            let r = calibrate(rec, (0.0, CAL_S), Method::Paper, None)?;
            let mut g = r.gyro;
            if !full {
                g.m_k = nalgebra::Vector3::zeros();
            }
            Some(g)
        }
        Plan::Best => Some(calibrate(rec, (0.0, CAL_S), Method::Earth, None)?.gyro),
    })
}

/// A dual-axis run: 40 s still, one reciprocating cycle about z, one about
/// x (each column of the gyro errors from its own +-turns, earth-aware),
/// then 5 min of the dual-axis sequence at the rate.
fn run_dual(spec: &ImuSpec, positions: u8, rate: f64, seed: u64) -> Result<StaticErrors> {
    use core_nav::scheme::{DualAxisProfile, Limits, Profile};
    let limits = Limits::default();
    let recip = Profile::new(Scheme::Reciprocating { rate, turns: 1 }, limits)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let cycle = recip.period_s();
    let dual =
        DualAxisProfile::new(positions, rate, 0.0, limits).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (kin, start) = hal_sim::dual::calibrate_then_dual(recip, 40.0, dual);
    let run = hal_sim::dual::simulate_gimbals(
        spec.clone(),
        hal_sim::world::Site::new(30.53, 20.0),
        &kin,
        start + NAV_S,
        seed,
    );
    let cz = calibrate(
        &run.recording,
        (40.0 - 1.0, 40.0 + cycle + 0.5),
        Method::Reciprocating,
        None,
    )?
    .gyro;
    let mut rx = run.recording.clone();
    rx.meta.axis = Axis::X;
    for (row, (_, outer)) in rx.table.iter_mut().zip(&run.angles) {
        row.angle_rad = *outer;
    }
    let cx = calibrate(
        &rx,
        (40.0 + cycle - 0.5, start + 0.5),
        Method::Reciprocating,
        None,
    )?
    .gyro;
    let cal = GyroCalibration {
        bias: (cz.bias + cx.bias) * 0.5,
        second: Some((Axis::X, cx.m_k)),
        ..cz
    };
    let opt = NavOptions {
        start_s: start,
        end_s: Some(start + NAV_S),
        calibration: Some(cal),
        gimbals: Some(run.angles),
        ..NavOptions::default()
    };
    let rows = navigate(&run.recording, &opt, &mut |_| {})?;
    Ok(static_errors(&rows, [0.0, 0.0, 0.0]))
}

/// Averages error sets.
pub fn mean(e: &[StaticErrors]) -> StaticErrors {
    let n = e.len().max(1) as f64;
    let mut m = StaticErrors::default();
    for x in e {
        m.h_pos_rms_m += x.h_pos_rms_m / n;
        m.h_vel_rms_mps += x.h_vel_rms_mps / n;
        m.roll_rms_deg += x.roll_rms_deg / n;
        m.pitch_rms_deg += x.pitch_rms_deg / n;
        m.heading_rms_deg += x.heading_rms_deg / n;
        m.h_pos_end_m += x.h_pos_end_m / n;
    }
    m
}

fn row(mode: &str, rate_dps: f64, seeds: Vec<u64>, runs: Vec<StaticErrors>) -> Row {
    let e = mean(&runs);
    Row {
        mode: mode.to_string(),
        rate_dps,
        h_pos_rms_m: e.h_pos_rms_m,
        h_vel_rms_mps: e.h_vel_rms_mps,
        roll_rms_deg: e.roll_rms_deg,
        pitch_rms_deg: e.pitch_rms_deg,
        heading_rms_deg: e.heading_rms_deg,
        seeds,
        runs,
    }
}

/// The format of `rins reproduce --json`.
pub const FORMAT: &str = "rins-reproduce/1";

/// What `rins reproduce --json` writes (a whole run or one shard).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Output {
    /// [`FORMAT`].
    pub format: String,
    /// The sensor.
    pub imu: String,
    /// Runs per mode and rate (of the whole study).
    pub runs: usize,
    /// The first seed.
    pub seed: u64,
    /// The shard these rows hold (0/1: all).
    pub shard: Shard,
    /// The rows.
    pub rows: Vec<Row>,
}

/// Every mode of the experiment, in the tables' order.
pub const MODES: [&str; 5] = [
    "conventional",
    "rotary-partial",
    "rotary-full",
    "rotary-best",
    "noise-floor",
];

/// The modes of the experiment after the conventional run, in order.
const PLANS: [(&str, Plan); 4] = [
    ("rotary-partial", Plan::Paper { full: false }),
    ("rotary-full", Plan::Paper { full: true }),
    ("rotary-best", Plan::Best),
    ("noise-floor", Plan::NoiseFloor),
];

/// Runs the experiment for `spec`: `runs` seeds from `seed`, at `rates`,
/// the runs of `shard` only (run `k`, seed `seed + k`, when `k mod N =
/// K`), in parallel on rayon's pool. `progress` gets the fraction done.
///
/// # Errors
/// Any run's failure.
pub fn reproduce(
    spec: &ImuSpec,
    runs: usize,
    seed: u64,
    rates: &[f64],
    shard: Shard,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<Vec<Row>> {
    let seeds: Vec<u64> = (0..runs)
        .filter(|k| shard.has(*k))
        .map(|k| seed + k as u64)
        .collect();
    let mut cells: Vec<(&str, Plan, f64)> = vec![("conventional", Plan::Conventional, 0.0)];
    for (name, plan) in PLANS {
        cells.extend(rates.iter().map(|r| (name, plan, *r)));
    }
    let jobs: Vec<(usize, u64)> = (0..cells.len())
        .flat_map(|c| seeds.iter().map(move |s| (c, *s)))
        .collect();
    let done = AtomicUsize::new(0);
    let errors = jobs
        .par_iter()
        .map(|&(c, s)| {
            let (_, plan, rate) = cells[c];
            let e = run_one(spec, plan, rate, s);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(d as f64 / jobs.len().max(1) as f64);
            e
        })
        .collect::<Result<Vec<_>>>()?;
    let per_cell = |c: usize| {
        errors
            .get(c * seeds.len()..(c + 1) * seeds.len())
            .unwrap_or(&[])
    };
    Ok(cells
        .iter()
        .enumerate()
        .map(|(c, (name, _, rate))| row(name, *rate, seeds.clone(), per_cell(c).to_vec()))
        .collect())
}

/// The shards' rows put back together: per mode and rate the runs of every
/// shard in seed order, and their means, as one run gives them.
///
/// # Errors
/// Shards whose rows do not match (another sensor, rates or modes), or a
/// seed given twice.
pub fn merge(parts: Vec<Vec<Row>>) -> Result<Vec<Row>> {
    let first = parts.first().ok_or_else(|| anyhow!("no shard to merge"))?;
    let mut out = vec![];
    for (i, r0) in first.iter().enumerate() {
        let mut pairs: Vec<(u64, StaticErrors)> = vec![];
        for p in &parts {
            let r = p
                .get(i)
                .filter(|r| r.mode == r0.mode && r.rate_dps == r0.rate_dps)
                .ok_or_else(|| {
                    anyhow!(
                        "the shards' rows differ at {} {} deg/s",
                        r0.mode,
                        r0.rate_dps
                    )
                })?;
            pairs.extend(r.seeds.iter().copied().zip(r.runs.iter().copied()));
        }
        pairs.sort_by_key(|p| p.0);
        if pairs.windows(2).any(|w| w[0].0 == w[1].0) {
            return Err(anyhow!(
                "a seed is in two shards ({} {} deg/s)",
                r0.mode,
                r0.rate_dps
            ));
        }
        let (seeds, runs) = pairs.into_iter().unzip();
        out.push(row(&r0.mode, r0.rate_dps, seeds, runs));
    }
    Ok(out)
}

/// Mean over the rates of one mode: (h_pos, h_vel).
pub fn mode_mean(rows: &[Row], mode: &str) -> Option<(f64, f64)> {
    let v: Vec<&Row> = rows.iter().filter(|r| r.mode == mode).collect();
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    Some((
        v.iter().map(|r| r.h_pos_rms_m).sum::<f64>() / n,
        v.iter().map(|r| r.h_vel_rms_mps).sum::<f64>() / n,
    ))
}

/// The table a person reads: per rate and mode, then the mean over rates
/// beside the paper's figures, and how far best is from conventional and
/// from the noise floor.
pub fn text_report(rows: &[Row], imu: &str, runs: usize) -> String {
    use std::fmt::Write;
    let mut o = String::new();
    let _ = writeln!(
        o,
        "{} ({} runs per cell): RMS over 5 min of navigation",
        imu, runs
    );
    let _ = writeln!(
        o,
        "{:<15} {:>6} {:>12} {:>10} {:>9} {:>9} {:>10}",
        "mode", "deg/s", "pos [m]", "vel [m/s]", "roll [d]", "pitch [d]", "hdg [d]"
    );
    for r in rows {
        let _ = writeln!(
            o,
            "{:<15} {:>6} {:>12.1} {:>10.3} {:>9.4} {:>9.4} {:>10.4}",
            r.mode,
            r.rate_dps,
            r.h_pos_rms_m,
            r.h_vel_rms_mps,
            r.roll_rms_deg,
            r.pitch_rms_deg,
            r.heading_rms_deg
        );
    }
    let _ = writeln!(o, "\nmean over all rates (paper's figures beside ours):");
    let _ = writeln!(
        o,
        "{:<15} {:>12} {:>10} {:>14} {:>12}",
        "mode", "pos [m]", "vel [m/s]", "paper pos [m]", "paper vel"
    );
    for mode in MODES {
        if let Some((p, v)) = mode_mean(rows, mode) {
            let paper = PAPER.iter().find(|(i, m, _, _)| *i == imu && *m == mode);
            let (pp, pv) = paper.map_or(("-".to_string(), "-".to_string()), |(_, _, p, v)| {
                (format!("{p:.1}"), format!("{v:.1}"))
            });
            let note = if mode == "conventional" {
                "   (paper: several km after 5 min)"
            } else {
                ""
            };
            let _ = writeln!(o, "{mode:<15} {p:>12.1} {v:>10.3} {pp:>14} {pv:>12}{note}");
        }
    }
    if let (Some((conv, _)), Some((best, _)), Some((floor, _))) = (
        mode_mean(rows, "conventional"),
        mode_mean(rows, "rotary-best"),
        mode_mean(rows, "noise-floor"),
    ) {
        let _ = writeln!(
            o,
            "\nrotary-best is {:.1}x better than conventional and {:.2}x the noise floor",
            conv / best,
            best / floor
        );
    }
    o
}

/// The book's table for one sensor: per mode the mean over the rates of
/// the horizontal position and velocity RMS, the runs' spread (the lowest
/// and the highest single run's position RMS, any rate), and the paper's
/// figures.
pub fn markdown(rows: &[Row], imu: &str) -> String {
    use std::fmt::Write;
    let mut o = format!(
        "| {imu} | h. position [m] | h. velocity [m/s] | runs' range, position [m] | paper |\n| --- | --- | --- | --- | --- |\n"
    );
    for mode in MODES {
        let Some((p, v)) = mode_mean(rows, mode) else {
            continue;
        };
        let cells: Vec<f64> = rows
            .iter()
            .filter(|r| r.mode == mode)
            .flat_map(|r| r.runs.iter().map(|e| e.h_pos_rms_m))
            .collect();
        let (lo, hi) = cells
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(*x), b.max(*x))
            });
        let paper = match PAPER.iter().find(|(i, m, ..)| *i == imu && *m == mode) {
            Some((_, _, pp, pv)) => format!("{pp} m / {pv} m/s"),
            None if mode == "conventional" => "\"several km after 5 min\"".into(),
            None => String::new(),
        };
        let _ = writeln!(
            o,
            "| {mode} | {} | {} | {} - {} | {paper} |",
            sig(p),
            sig(v),
            sig(lo),
            sig(hi)
        );
    }
    o
}

/// Four significant figures at most, no more than one decimal above 100.
fn sig(x: f64) -> String {
    match x.abs() {
        a if a >= 100.0 => format!("{x:.0}"),
        a if a >= 10.0 => format!("{x:.1}"),
        a if a >= 1.0 => format!("{x:.2}"),
        _ => format!("{x:.3}"),
    }
}
