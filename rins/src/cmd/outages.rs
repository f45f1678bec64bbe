//! `rins outages`: the aided rotary INS through GNSS outages, Monte Carlo
//! ([`rins::outages`]).

use super::write_file;
use anyhow::{anyhow, Result};
use hal_sim::drive::DriveKind;
use rins::progress_bar;
use std::path::PathBuf;

/// `rins outages`.
#[derive(clap::Args)]
pub struct Args {
    /// Drive kind: city or highway.
    #[arg(long, default_value = "city")]
    pub drive: String,
    /// Sensors, comma-separated: shipped profiles' names or sensor files.
    #[arg(long = "sensor", alias = "imus", default_value = "nav440,icm42688")]
    pub sensor: String,
    /// Drives (seeds) per sensor and scheme.
    #[arg(long, default_value_t = 20)]
    pub drives: u64,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Write every run as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the table as markdown here.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
    /// Write the drive demo's plots (map of the tracks, errors through the
    /// outages; the first sensor's first drive) into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

/// Runs `rins outages`.
pub fn run(a: &Args) -> Result<()> {
    let kind = DriveKind::parse(&a.drive)
        .ok_or_else(|| anyhow!("--drive {:?}: city or highway", a.drive))?;
    let imus = a
        .sensor
        .split(',')
        .map(|n| Ok(hal_sim::sensor::resolve(n.trim())?))
        .collect::<Result<Vec<_>>>()?;
    let pb = progress_bar("outages");
    let s = rins::outages::run(kind, &imus, a.drives, a.threads, &|f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    let md = s.markdown();
    print!("{md}");
    if let Some(p) = &a.markdown {
        write_file(p, &md)?;
    }
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string_pretty(&s)?)?;
    }
    if let (Some(dir), Some(first)) = (&a.plots, imus.first()) {
        for p in rins::outages::plots(kind, first, 1, dir)? {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
