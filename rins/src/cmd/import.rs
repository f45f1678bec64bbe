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
    /// Any logger's IMU-only CSV described by a column map
    /// (rins-columns/1, time source "log" or "rate"): a static-base
    /// recording; arrival stamps put on the sensor's regular clock.
    #[command(
        override_usage = "rins import csv --imu-file <IMU_FILE> --columns <COLUMNS> \\
         --sensor <SENSOR> --lat-deg <LAT_DEG> --out <OUT> [OPTIONS]"
    )]
    Csv(CsvArgs),
    /// An RTKLIB `.pos` solution plus an IMU CSV described by a column map
    /// (rins-columns/1), its clock through an RTKLIB `.tag` file or GPST.
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
    /// A comma2k19 segment (NumPy arrays): the IMU, the u-blox fixes at
    /// their epochs, CAN speed as odometer.csv, the pose as a reference.
    #[command(
        override_usage = "rins import comma2k19 --dir <DIR> --sensor <SENSOR> \\
         --out <OUT> [OPTIONS]"
    )]
    Comma2k19(CommaArgs),
}

/// `rins import comma2k19`.
#[derive(clap::Args)]
pub struct CommaArgs {
    /// The segment directory (holding processed_log/ and global_pose/).
    #[arg(long)]
    pub dir: PathBuf,
    /// The fixes' horizontal 1-sigma, m (vertical twice it). Default: the
    /// fixes' rms against the pose once their clock is lined up (the log
    /// has none of the receiver's)
    #[arg(long)]
    pub fix_sigma_m: Option<f64>,
    /// The sensor, where to write, the counts.
    #[command(flatten)]
    pub to: Written,
}

/// `rins import csv`.
#[derive(clap::Args)]
pub struct CsvArgs {
    /// The IMU CSV.
    #[arg(long)]
    pub imu_file: PathBuf,
    /// Its column map (rins-columns/1, TOML; time.source "log" or "rate").
    #[arg(long)]
    pub columns: PathBuf,
    /// The site's latitude, deg (north positive).
    #[arg(long, allow_negative_numbers = true)]
    pub lat_deg: f64,
    /// The site's height above the ellipsoid, m.
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
    pub height_m: f64,
    /// The base's attitude as known from outside: roll, pitch, heading,
    /// deg (without it: level from the data, any heading).
    #[arg(
        long,
        value_name = "ROLL,PITCH,HEADING",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub base_deg: Option<Vec<f64>>,
    /// The stated heading's 1-sigma, deg (with --base-deg).
    #[arg(long, requires = "base_deg")]
    pub heading_sigma_deg: Option<f64>,
    /// The stated roll's and pitch's 1-sigma, deg (with --base-deg).
    #[arg(long, requires = "base_deg")]
    pub level_sigma_deg: Option<f64>,
    /// The sensor, where to write, the counts.
    #[command(flatten)]
    pub to: Written,
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
    /// The sensor, where to write, the counts.
    #[command(flatten)]
    pub to: Written,
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
    /// The geoid's height above the ellipsoid, m, when the solution's
    /// heights are above mean sea level (added to them); 0: ellipsoidal.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub geoid_m: f64,
    /// The sensor, where to write, the counts.
    #[command(flatten)]
    pub to: Written,
}

/// What every importer takes besides its files: the sensor, the
/// recording to write, the counts' JSON.
#[derive(clap::Args)]
pub struct Written {
    /// The sensor: a shipped name or a sensor file (its model name goes to
    /// meta.toml, its mounting turns the samples into the base frame, its
    /// antenna lever arm goes to meta).
    #[arg(long)]
    pub sensor: String,
    /// The recording directory to write (must not exist).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write what was counted as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

impl Written {
    /// The sensor, once `--out` is known not to exist (a recording is
    /// never rewritten in place).
    fn sensor(&self) -> Result<hal_sim::imu::ImuSpec> {
        if self.out.exists() {
            bail!(
                "{} exists: a recording is never rewritten in place",
                self.out.display()
            );
        }
        Ok(hal_sim::sensor::resolve(&self.sensor)?)
    }

    /// What was written: the IMU samples and their rate, the fixes and
    /// those outside the IMU's span.
    fn counts(&self, rep: &import::ImportReport) -> String {
        format!(
            "wrote {}: {} IMU samples ({:.1} Hz), {} fixes ({} outside the IMU's span)",
            self.out.display(),
            rep.imu_samples,
            rep.imu_rate_found_hz,
            rep.fixes,
            rep.fixes_outside
        )
    }

    /// Writes `rec`, prints `text`, and the counts `rep` with --json.
    fn save(
        &self,
        rec: &recording::Recording,
        text: &str,
        rep: &impl serde::Serialize,
    ) -> Result<()> {
        rec.write(&self.out).map_err(|e| anyhow::anyhow!("{e}"))?;
        println!("{}", text.trim_end());
        if let Some(j) = &self.json {
            write_file(j, &serde_json::to_string_pretty(rep)?)?;
        }
        Ok(())
    }
}

/// Runs `rins import`.
pub fn run(a: &Args) -> Result<()> {
    match &a.from {
        From::Csv(c) => csv(c),
        From::Rtklib(r) => rtklib(r),
        From::KfGins(k) => kf_gins(k),
        From::Comma2k19(c) => comma(c),
    }
}

fn comma(a: &CommaArgs) -> Result<()> {
    let input = import::comma::CommaInput {
        dir: a.dir.clone(),
        fix_sigma_h_m: a.fix_sigma_m,
        sensor: a.to.sensor()?,
    };
    let (rec, rep) = import::comma::import(&input)?;
    let odo = rec
        .moving
        .as_ref()
        .and_then(|m| m.odometer.as_ref())
        .map_or(0, Vec::len);
    let check = rep
        .fixes_against_reference
        .as_ref()
        .map(|c| format!("\n{}", c.text("global_pose")))
        .unwrap_or_default();
    let gyro = rep.device_gyro_bias_dps.map_or_else(
        || "\nthe gyro: IMU/gyro as the segment gives it (the device's bias estimate is not in it: not known how much was taken out)".to_string(),
        |[x, y, z]| format!(
            "\nthe gyro: the device's calibrated stream (its own bias estimate {x:+.2}, {y:+.2}, {z:+.2} deg/s in b taken out); the filter's prior stays the sensor file's turn-on bias ({:.2} deg/s): the chip is not known, nor how well the device calibrated it (a sensor file stating that narrows it)",
            input.sensor.gyro.bias.to_degrees()
        ),
    );
    let text = format!(
        "{}, the fixes at their epochs, {odo} odometer speeds, truth.csv from global_pose (not independent of the IMU or the receiver){check}{gyro}",
        a.to.counts(&rep)
    );
    a.to.save(&rec, &text, &rep)
}

fn kf_gins(a: &KfGinsArgs) -> Result<()> {
    let input = import::kfgins::KfGinsInput {
        imu: a.imu_file.clone(),
        gnss: a.gnss.clone(),
        truth: a.truth.clone(),
        sensor: a.to.sensor()?,
    };
    let (rec, rep) = import::kfgins::import(&input)?;
    let reference = if a.truth.is_some() {
        ", truth.csv from the reference"
    } else {
        ""
    };
    let text = format!("{}{reference}", a.to.counts(&rep));
    a.to.save(&rec, &text, &rep)
}

fn rtklib(a: &RtklibArgs) -> Result<()> {
    let input = RtklibInput {
        pos: a.pos.clone(),
        imu: a.imu_file.clone(),
        columns: a.columns.clone(),
        imu_tag: a.imu_tag.clone(),
        geoid_m: a.geoid_m,
        sensor: a.to.sensor()?,
    };
    let (rec, rep) = import::rtklib(&input)?;
    a.to.save(&rec, &import::report_text(&rep, &a.to.out), &rep)
}

fn csv(a: &CsvArgs) -> Result<()> {
    let base = match a.base_deg.as_deref() {
        None => None,
        Some(&[r, p, h]) => Some([r, p, h]),
        Some(v) => bail!(
            "--base-deg takes roll,pitch,heading (three values), got {}",
            v.len()
        ),
    };
    let input = import::csv::CsvInput {
        imu: a.imu_file.clone(),
        columns: a.columns.clone(),
        sensor: a.to.sensor()?,
        lat_deg: a.lat_deg,
        height_m: a.height_m,
        base,
        base_sigma_deg: [a.level_sigma_deg, a.heading_sigma_deg],
    };
    let (rec, rep) = import::csv::import(&input)?;
    a.to.save(&rec, &import::csv::report_text(&rep, &a.to.out), &rep)
}
