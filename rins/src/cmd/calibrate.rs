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
    /// Use data up to this time, s (default: 120 s, the power-up
    /// calibration; multiposition: the whole session).
    #[arg(long)]
    pub to_s: Option<f64>,
    /// The commanded table rate, deg/s: steady phases must reach it within 2 %.
    #[arg(long)]
    pub rate_dps: Option<f64>,
    /// The sensor (a shipped profile's name or a sensor file) whose drift
    /// between phases the sigmas count (default: the recording's
    /// `[imu] model`; unknown, white noise only).
    #[arg(long)]
    pub sensor: Option<String>,
    /// How long a multi-position session rests at its start, s (the
    /// reference the rests are found against; multiposition only,
    /// default 30).
    #[arg(long)]
    pub rest_s: Option<f64>,
}

/// Runs `rins calibrate`.
pub fn run(a: &Args) -> Result<()> {
    let rec = super::plausible(read_recording(&a.rec)?, None, a.keep_implausible);
    rec.require_accel("rins calibrate")
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    if a.method == Method::Multiposition {
        return multiposition(a, &rec);
    }
    if a.rest_s.is_some() {
        anyhow::bail!("--rest-s is for --method multiposition (the session's first rest)");
    }
    let sensor = match &a.sensor {
        Some(n) => Some(hal_sim::sensor::resolve(n)?),
        None => None,
    };
    let r = calibrate::calibrate_with(
        &rec,
        (a.from_s, a.to_s.unwrap_or(120.0)),
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

/// `rins calibrate --method multiposition`.
fn multiposition(a: &Args, rec: &recording::Recording) -> Result<()> {
    for (given, flag) in [
        (a.sensor.is_some(), "--sensor"),
        (a.rate_dps.is_some(), "--rate-dps"),
    ] {
        if given {
            anyhow::bail!("{flag} does not apply to --method multiposition (a session of rests, no table rate)");
        }
    }
    let to = a.to_s.unwrap_or(f64::INFINITY);
    let m = rins::multipos::calibrate(rec, (a.from_s, to), a.rest_s.unwrap_or(30.0))
        .with_context(|| format!("calibrating {}", a.rec.display()))?;
    print!("{}", rins::multipos::report(&m));
    if let Some(p) = &a.json {
        write_file(
            p,
            &serde_json::to_string_pretty(&rins::multipos::to_json(&m))?,
        )?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
