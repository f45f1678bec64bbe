//! `rins import`: real logs into recording-v1 (`rins::import`).

use super::write_file;
use anyhow::{bail, Result};
use rins::import::{self, RtklibInput};
use std::path::PathBuf;

/// `rins import`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    pub from: From,
}

/// The forms a log comes in.
#[derive(clap::Subcommand)]
pub enum From {
    /// An RTKLIB `.pos` solution plus an IMU CSV described by a column map
    /// (rins-columns/1), its clock through an RTKLIB `.tag` file.
    #[command(
        override_usage = "rins import rtklib --pos <POS> --imu-file <IMU_FILE> \\
         --columns <COLUMNS> --sensor <SENSOR> --out <OUT> [OPTIONS]"
    )]
    Rtklib(RtklibArgs),
    /// KF-GINS text files: IMU increments, GNSS positions with sigmas, an
    /// optional reference (its start attitude becomes [base]).
    #[command(
        override_usage = "rins import kf-gins --imu-file <IMU_FILE> --gnss <GNSS> \\
         --sensor <SENSOR> --out <OUT> [OPTIONS]"
    )]
    KfGins(KfGinsArgs),
}

/// `rins import kf-gins`.
#[derive(clap::Args)]
pub struct KfGinsArgs {
    /// The IMU file (seconds of week, dtheta xyz rad, dv xyz m/s).
    #[arg(long)]
    pub imu_file: PathBuf,
    /// The GNSS file (seconds of week, lat, lon, h, sigma n e d; or 13
    /// columns with velocity).
    #[arg(long)]
    pub gnss: PathBuf,
    /// The reference (week, sow, lat, lon, h, vn ve vd, roll pitch yaw).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// The sensor: a shipped name or a sensor file.
    #[arg(long)]
    pub sensor: String,
    /// The recording directory to write (must not exist).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write what was counted as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// `rins import rtklib`.
#[derive(clap::Args)]
pub struct RtklibArgs {
    /// The RTKLIB solution (`.pos`, GPST times).
    #[arg(long)]
    pub pos: PathBuf,
    /// The IMU CSV.
    #[arg(long)]
    pub imu_file: PathBuf,
    /// The IMU CSV's column map (rins-columns/1, TOML).
    #[arg(long)]
    pub columns: PathBuf,
    /// The IMU log's RTKLIB time-tag file (default: the IMU file + `.tag`).
    #[arg(long)]
    pub imu_tag: Option<PathBuf>,
    /// The sensor: a shipped name or a sensor file (its mounting turns the
    /// samples into the base frame; its antenna lever arm goes to meta).
    #[arg(long)]
    pub sensor: String,
    /// The geoid's height above the ellipsoid, m, when the solution's
    /// heights are above mean sea level (added to them); 0: ellipsoidal.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub geoid_m: f64,
    /// The recording directory to write (must not exist).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write what was counted as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `rins import`.
pub fn run(a: &Args) -> Result<()> {
    match &a.from {
        From::Rtklib(r) => rtklib(r),
        From::KfGins(k) => kf_gins(k),
    }
}

fn kf_gins(a: &KfGinsArgs) -> Result<()> {
    if a.out.exists() {
        bail!(
            "{} exists: a recording is never rewritten in place",
            a.out.display()
        );
    }
    let input = import::kfgins::KfGinsInput {
        imu: a.imu_file.clone(),
        gnss: a.gnss.clone(),
        truth: a.truth.clone(),
        sensor: hal_sim::sensor::resolve(&a.sensor)?,
    };
    let (rec, rep) = import::kfgins::import(&input)?;
    rec.write(&a.out).map_err(|e| anyhow::anyhow!("{e}"))?;
    println!(
        "wrote {}: {} IMU samples ({:.1} Hz), {} fixes ({} outside the IMU's span){}",
        a.out.display(),
        rep.imu_samples,
        rep.imu_rate_found_hz,
        rep.fixes,
        rep.fixes_outside,
        if a.truth.is_some() {
            ", truth.csv from the reference"
        } else {
            ""
        }
    );
    if let Some(j) = &a.json {
        write_file(j, &serde_json::to_string_pretty(&rep)?)?;
    }
    Ok(())
}

fn rtklib(a: &RtklibArgs) -> Result<()> {
    if a.out.exists() {
        bail!(
            "{} exists: a recording is never rewritten in place",
            a.out.display()
        );
    }
    let input = RtklibInput {
        pos: a.pos.clone(),
        imu: a.imu_file.clone(),
        columns: a.columns.clone(),
        imu_tag: a.imu_tag.clone(),
        geoid_m: a.geoid_m,
        sensor: hal_sim::sensor::resolve(&a.sensor)?,
    };
    let (rec, rep) = import::rtklib(&input)?;
    rec.write(&a.out).map_err(|e| anyhow::anyhow!("{e}"))?;
    println!("{}", import::report_text(&rep, &a.out));
    if let Some(j) = &a.json {
        write_file(j, &serde_json::to_string_pretty(&rep)?)?;
    }
    Ok(())
}
