//! `rins study`: the blind study of `rins diagnose`. For each effect id,
//! recordings with the effect hidden at magnitudes from below to well above
//! what the run can show, on a realistic background (the NAV440's nominal
//! errors, white noise and bias instability), many seeds per cell, plus null
//! recordings (background only). The tool is not told what is inside.
//! Scored: detection (the effect named) against magnitude, false alarms on
//! the nulls (any effect other than the background's bias instability), and
//! the confusion matrix (injected vs first named).

use crate::diagnose::diagnose;
use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig};
use serde::Serialize;

/// Effects studied and their reference magnitudes (SI, the `--effect` units).
pub const EFFECTS: &[(&str, f64)] = &[
    ("lever_arm", 0.02),
    ("time_offset", 0.002),
    ("gyro_scale_nonlinearity", 0.003),
    ("gyro_scale_asymmetry", 1e-3),
    ("axis_tilt", 2e-3),
    ("encoder_error", 2e-4),
    ("accel_scale_nonlinearity", 2e-4),
    ("temperature_bias", 2e-5),
    ("gyro_g_sensitivity", 2e-4),
];

/// Multiples of the reference magnitude.
pub const SCALES: [f64; 3] = [0.25, 1.0, 4.0];

/// One run's background: NAV440 nominal errors, white noise and bias
/// instability; a reciprocating run about z (both directions, two rates'
/// worth of ramps), 400 s.
pub fn background(seed: u64) -> SimConfig {
    let nav = ImuSpec::nav440();
    let mut s = ImuSpec::ideal();
    s.gyro.bias = nav.gyro.bias;
    s.gyro.scale = nav.gyro.scale;
    s.gyro.misalignment = nav.gyro.misalignment;
    s.gyro.white = nav.gyro.white;
    s.gyro.bias_instability = nav.gyro.bias_instability;
    s.gyro.bi_tau_s = nav.gyro.bi_tau_s;
    s.accel.bias = nav.accel.bias;
    s.accel.white = nav.accel.white;
    s.temp = nav.temp;
    let mut c = SimConfig::new(s, Axis::Z, 400.0);
    c.scheme = Scheme::Reciprocating {
        rate: 60f64.to_radians(),
        turns: 2,
    };
    c.seed = seed;
    c
}

/// One cell of the table.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    /// Effect id.
    pub effect: String,
    /// Injected magnitude (the effect's unit).
    pub magnitude: f64,
    /// Runs.
    pub runs: usize,
    /// Runs where the effect was named.
    pub detected: usize,
    /// Runs where it was named first (the background excepted).
    pub first: usize,
}

/// The study's result.
#[derive(Clone, Debug, Serialize)]
pub struct Study {
    /// Detection per effect and magnitude.
    pub cells: Vec<Cell>,
    /// Null runs.
    pub null_runs: usize,
    /// Null runs with a finding other than the background's.
    pub false_alarms: usize,
    /// Injected effect -> first effect named (or "none") -> count.
    pub confusion: std::collections::BTreeMap<String, std::collections::BTreeMap<String, usize>>,
}

/// Effects named in a run, background excluded, most significant first.
fn named(c: &SimConfig) -> Result<Vec<String>, String> {
    let rec = simulate(c, &mut |_| {})?;
    let r = diagnose(&rec, "study");
    Ok(r["findings"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|f| f["effect"].as_str())
                .filter(|e| *e != "bias_instability")
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default())
}

/// Runs the study: `runs` seeds per cell and `runs` x 2 nulls.
///
/// # Errors
/// A simulation failure.
pub fn run(
    effects: &[(&str, f64)],
    scales: &[f64],
    runs: usize,
    seed: u64,
    progress: &mut dyn FnMut(f64),
) -> Result<Study, String> {
    let total = (effects.len() * scales.len() * runs + 2 * runs).max(1) as f64;
    let mut done = 0.0;
    let mut cells = vec![];
    let mut confusion: std::collections::BTreeMap<
        String,
        std::collections::BTreeMap<String, usize>,
    > = Default::default();
    for (name, base) in effects {
        for s in scales {
            let mag = base * s;
            let (mut det, mut first) = (0, 0);
            for k in 0..runs {
                let mut c = background(seed + 1000 * k as u64 + 17);
                c.set_effect(name, mag)?;
                let found = named(&c)?;
                det += usize::from(found.iter().any(|e| e == name));
                first += usize::from(found.first().map(String::as_str) == Some(*name));
                if *s == 1.0 || scales.len() == 1 {
                    let top = found.first().cloned().unwrap_or_else(|| "none".into());
                    *confusion
                        .entry((*name).into())
                        .or_default()
                        .entry(top)
                        .or_default() += 1;
                }
                done += 1.0;
                progress(done / total);
            }
            cells.push(Cell {
                effect: (*name).into(),
                magnitude: mag,
                runs,
                detected: det,
                first,
            });
        }
    }
    let mut false_alarms = 0;
    for k in 0..2 * runs {
        let found = named(&background(seed + 7919 * k as u64 + 3))?;
        if !found.is_empty() {
            false_alarms += 1;
            *confusion
                .entry("none".into())
                .or_default()
                .entry(found[0].clone())
                .or_default() += 1;
        } else {
            *confusion
                .entry("none".into())
                .or_default()
                .entry("none".into())
                .or_default() += 1;
        }
        done += 1.0;
        progress(done / total);
    }
    Ok(Study {
        cells,
        null_runs: 2 * runs,
        false_alarms,
        confusion,
    })
}

/// The study as a Markdown table.
pub fn markdown(s: &Study, scales: &[f64]) -> String {
    let mut out = String::from("| effect |");
    for x in scales {
        out += &format!(" x{x} |");
    }
    out += "\n| --- |";
    for _ in scales {
        out += " --- |";
    }
    out += "\n";
    let mut effects: Vec<&str> = s.cells.iter().map(|c| c.effect.as_str()).collect();
    effects.dedup();
    for e in effects {
        out += &format!("| {e} |");
        for c in s.cells.iter().filter(|c| c.effect == e) {
            out += &format!(
                " {:.0} % ({:.2e}) |",
                100.0 * c.detected as f64 / c.runs.max(1) as f64,
                c.magnitude
            );
        }
        out += "\n";
    }
    out += &format!(
        "\nfalse alarms on {} null runs: {} ({:.0} %)\n",
        s.null_runs,
        s.false_alarms,
        100.0 * s.false_alarms as f64 / s.null_runs.max(1) as f64
    );
    out += "\nconfusion (injected at the reference magnitude -> first named):\n\n";
    for (inj, row) in &s.confusion {
        out += &format!(
            "- {inj}: {}\n",
            row.iter()
                .map(|(k, v)| format!("{k} {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    out
}
