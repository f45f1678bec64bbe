//! `rins reproduce`: the paper's experiment in simulation (Monte Carlo per
//! mode and table rate), beside our best and the white-noise floor.

use super::write_file;
use anyhow::{anyhow, bail, Result};
use hal_sim::imu::ImuSpec;
use rins::{progress_bar, report, reproduce as repro};
use std::path::PathBuf;

/// `rins reproduce`.
#[derive(clap::Args)]
pub struct Args {
    /// The sensor: mtig or nav440 (the paper's two, whose published
    /// figures the report sets beside).
    #[arg(long = "sensor", alias = "imu")]
    pub sensor: String,
    /// Monte Carlo runs per mode and rate.
    #[arg(long, default_value_t = 5)]
    pub runs: usize,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the rins-reproduce/1 JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the plots (SVG and PNG) into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

/// Runs `rins reproduce`.
pub fn run(a: &Args) -> Result<()> {
    if !["mtig", "nav440"].contains(&a.sensor.as_str()) {
        bail!(
            "--sensor must be mtig or nav440 (the paper's sensors), got {:?}",
            a.sensor
        );
    }
    if a.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let spec = ImuSpec::by_name(&a.sensor).ok_or_else(|| anyhow!("unknown imu"))?;
    let pb = progress_bar("reproduce");
    let rows = repro::reproduce(&spec, a.runs, a.seed, &repro::RATES_DPS, &mut |f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    print!("{}", repro::text_report(&rows, &a.sensor, a.runs));
    if let Some(p) = &a.json {
        let v = serde_json::json!({"format": "rins-reproduce/1", "imu": a.sensor, "rows": rows});
        write_file(p, &serde_json::to_string_pretty(&v)?)?;
        println!("wrote {}", p.display());
    }
    if let Some(d) = &a.plots {
        for chart in report::reproduce_charts(&rows, &a.sensor) {
            chart.write(d)?;
        }
        println!("plots in {}", d.display());
    }
    Ok(())
}
