//! `rins calibrate`: the gyro errors table rotation excites, from a
//! recording's phases.

use super::{read_recording, write_file};
use anyhow::{Context, Result};
use rins::calibrate::{self, Method};
use std::path::PathBuf;

/// `rins calibrate`.
#[derive(clap::Args)]
pub struct Args {
    /// The recording directory.
    pub rec: PathBuf,
    /// Use readings the sensor cannot have given (beyond its full scale,
    /// lone spikes, stuck runs) as they are, instead of excluding them.
    #[arg(long)]
    pub keep_implausible: bool,
    /// Write the calibration (rins-calibration/1) here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Method.
    #[arg(long, value_enum, default_value = "auto")]
    pub method: Method,
    /// Use data from this time on, s.
    #[arg(long, default_value_t = 0.0)]
    pub from_s: f64,
    /// Use data up to this time, s (default: 120 s, the power-up calibration).
    #[arg(long, default_value_t = 120.0)]
    pub to_s: f64,
    /// The commanded table rate, deg/s: steady phases must reach it within 2 %.
    #[arg(long)]
    pub rate_dps: Option<f64>,
    /// The sensor (a shipped profile's name or a sensor file) whose drift
    /// between phases the sigmas count (default: the recording's
    /// `[imu] model`; unknown, white noise only).
    #[arg(long)]
    pub sensor: Option<String>,
}

/// Runs `rins calibrate`.
pub fn run(a: &Args) -> Result<()> {
    let rec = super::plausible(read_recording(&a.rec)?, None, a.keep_implausible);
    rec.require_accel("rins calibrate")
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let sensor = match &a.sensor {
        Some(n) => Some(hal_sim::sensor::resolve(n)?),
        None => None,
    };
    let r = calibrate::calibrate_with(
        &rec,
        (a.from_s, a.to_s),
        a.method,
        a.rate_dps.map(f64::to_radians),
        sensor.as_ref(),
    )
    .with_context(|| format!("calibrating {}", a.rec.display()))?;
    print!("{}", calibrate::report(&r));
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string_pretty(&calibrate::to_json(&r))?)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
