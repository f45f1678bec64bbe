//! `rins record`: the board's telemetry (a serial port or a captured file)
//! decoded into a recording, with the link's losses counted and the
//! board's calibration frames kept (`calibration.json` in the recording).

use super::{write_file, SiteArgs};
use anyhow::{anyhow, bail, Context, Result};
use rins::progress_bar;
use std::io::Read;
use std::path::PathBuf;

/// `rins record`.
#[derive(clap::Args)]
pub struct Args {
    /// Serial port of the board's telemetry UART (e.g. /dev/ttyUSB0).
    #[arg(
        long,
        conflicts_with = "from_file",
        required_unless_present = "from_file"
    )]
    pub port: Option<String>,
    /// Baud rate.
    #[arg(long, default_value_t = 921_600)]
    pub baud: u32,
    /// Record this long from the port, s.
    #[arg(long, default_value_t = 600.0)]
    pub duration_s: f64,
    /// Decode a captured byte stream instead of a port.
    #[arg(long)]
    pub from_file: Option<PathBuf>,
    /// Output recording directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Site and base (the board does not send them).
    #[command(flatten)]
    pub site: SiteArgs,
    /// Also write the link statistics as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `rins record`.
pub fn run(a: &Args) -> Result<()> {
    let meta = recording::Meta {
        description: Some("rins record: board telemetry".into()),
        latitude_deg: a.site.lat_deg,
        height_m: a.site.height_m,
        heading_deg: a.site.heading_deg,
        pitch_deg: a.site.pitch_deg,
        roll_deg: a.site.roll_deg,
        imu_model: Some("TDK ICM-42688-P (board)".into()),
        ..recording::Meta::default()
    };
    let bytes: Vec<u8> = if let Some(f) = &a.from_file {
        std::fs::read(f).with_context(|| format!("reading {}", f.display()))?
    } else {
        let port = a
            .port
            .as_deref()
            .ok_or_else(|| anyhow!("--port or --from-file"))?;
        let mut p = serialport::new(port, a.baud)
            .timeout(std::time::Duration::from_millis(200))
            .open()
            .with_context(|| format!("opening {port}"))?;
        let pb = progress_bar("record");
        let start = std::time::Instant::now();
        let mut all = vec![];
        let mut buf = [0u8; 4096];
        while start.elapsed().as_secs_f64() < a.duration_s {
            match p.read(&mut buf) {
                Ok(n) => all.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => return Err(e).with_context(|| format!("reading {port}")),
            }
            pb.set_position((start.elapsed().as_secs_f64() / a.duration_s * 1000.0) as u64);
        }
        pb.finish_and_clear();
        all
    };
    let d = rins::record::decode(bytes, meta);
    println!("{}", rins::record::link_report(&d));
    if d.recording.imu.is_empty() {
        bail!("no IMU frame in the stream");
    }
    d.recording.write(&a.out).map_err(|e| anyhow!("{e}"))?;
    println!("wrote {}", a.out.display());
    match rins::record::calibration_json(&d, d.recording.meta.axis) {
        Some(c) => {
            let p = a.out.join("calibration.json");
            write_file(&p, &serde_json::to_string_pretty(&c)?)?;
            println!(
                "wrote {} ({} calibration frames{})",
                p.display(),
                d.calibrations.len(),
                if d.calibration_changes.is_empty() {
                    ""
                } else {
                    ", with the change from the stored record"
                }
            );
        }
        None => println!("no calibration frame in the stream"),
    }
    if let Some(p) = &a.json {
        write_file(
            p,
            &serde_json::to_string_pretty(&rins::record::link_json(&d))?,
        )?;
    }
    Ok(())
}
