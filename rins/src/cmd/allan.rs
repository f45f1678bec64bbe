//! `rins allan`: Allan deviation of the six channels (the longest still
//! stretch of a rotating recording), noise fit, JSON and plot.

use super::{read_recording, write_file};
use anyhow::{bail, Result};
use rins::{allan as allan_mod, calibrate, progress_bar};
use std::path::PathBuf;

/// `rins allan`.
#[derive(clap::Args)]
pub struct Args {
    /// The recording directory.
    pub rec: PathBuf,
    /// Write the rins-allan/1 JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the plot (`allan.svg` and `allan.png`) into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Write a sensor file (rins-sensor/2) with the measured noise: white
    /// noise, bias instability and its correlation time, rate random walk
    /// (the axes' RMS, where the curves support them), the resolution and
    /// full scale the samples show; the rest from --sensor, else unknown.
    #[arg(long)]
    pub sensor_out: Option<PathBuf>,
    /// The sensor the file starts from (a shipped name or a file; default:
    /// the recording's `[imu] model` when it names a shipped one, else
    /// nothing but the noise).
    #[arg(long, requires = "sensor_out")]
    pub sensor: Option<String>,
}

/// Runs `rins allan`.
pub fn run(a: &Args) -> Result<()> {
    let mut rec = read_recording(&a.rec)?;
    // Allan deviation characterises a still sensor: when the table turned,
    // use the longest static stretch and say so.
    let moved = rec
        .table
        .windows(2)
        .any(|w| (w[1].angle_rad - w[0].angle_rad).abs() > 1e-9);
    if moved {
        let segs = calibrate::segments(&rec, 10.0, 0.5);
        let longest = segs
            .iter()
            .filter(|s| s.rate_radps == 0.0)
            .max_by(|a, b| (a.t1_s - a.t0_s).total_cmp(&(b.t1_s - b.t0_s)));
        let Some(s) = longest else {
            bail!(
                "{}: the table turns throughout; Allan deviation needs a still sensor: `rins diagnose {}` fits the table's motion and gives the noise of what it leaves (its report's noise lines, and --sensor-out)",
                a.rec.display(),
                a.rec.display()
            );
        };
        println!(
            "the table turns in this recording: using its longest still stretch, {:.1}-{:.1} s",
            s.t0_s, s.t1_s
        );
        let (t0, t1) = (s.t0_s, s.t1_s);
        rec.imu.retain(|r| r.t_s >= t0 && r.t_s <= t1);
    }
    if rec.imu.len() < 100 {
        bail!(
            "{}: {} IMU samples are too few for an Allan deviation",
            a.rec.display(),
            rec.imu.len()
        );
    }
    on_the_sensors_clock(&mut rec);
    if rec.gyro_only {
        println!("gyro-only recording (no accel_x_mps2, accel_y_mps2, accel_z_mps2 columns): the accelerometers are not analysed");
    }
    let pb = progress_bar("allan");
    let chs = allan_mod::compute(&rec);
    pb.finish_and_clear();
    allan_mod::supported(&chs, &rec).map_err(|e| anyhow::anyhow!("{}: {e}", a.rec.display()))?;
    print!("{}", allan_mod::report(&chs));
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string(&allan_mod::to_json(&chs))?)?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &a.sensor_out {
        let base = super::base_sensor(a.sensor.as_deref(), &rec)?;
        let text = allan_mod::sensor_file(&chs, &rec, base, &a.rec.display().to_string());
        write_file(p, &text)?;
        println!(
            "wrote {} (rins-sensor/2: the measured noise; what was not measured is the base's or unknown)",
            p.display()
        );
    }
    if let Some(d) = &a.plots {
        let figure = allan_mod::figure(&chs, &a.rec.display().to_string());
        for f in figure.write(&d.join("allan"))? {
            println!("wrote {}", f.display());
        }
    }
    Ok(())
}

/// Stamps that break into pieces (arrival times: a logger that stamps
/// samples as they come, in bursts) put back on the sensor's regular
/// clock when no sample was lost ([`recording::clock::regular`]), and
/// said; else left in their gap-free pieces, and said.
fn on_the_sensors_clock(rec: &mut recording::Recording) {
    let t: Vec<f64> = rec.imu.iter().map(|r| r.t_s).collect();
    if recording::clock::is_gap_free(&t, rec.dt_s()) {
        return;
    }
    let pieces = rec.segments().len();
    match recording::clock::regular(&t) {
        Ok(r) => {
            println!(
                "the time stamps break into {pieces} pieces at {} Hz but no sample is missing: arrival times ({:.1} ms late on average, {:.1} ms at most); the samples are put on the sensor's regular clock ({:.4} ms a sample)",
                rec.meta.imu_rate_hz,
                r.mean_lag_s * 1e3,
                r.max_lag_s * 1e3,
                r.period_s * 1e3
            );
            for (row, t) in rec.imu.iter_mut().zip(r.t_s) {
                row.t_s = t;
            }
        }
        Err(e) => println!(
            "the time stamps break into {pieces} pieces, and cannot be put on one regular clock ({e}); no Allan difference straddles a gap"
        ),
    }
}
