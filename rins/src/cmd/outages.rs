//! `rins outages`: the aided rotary INS through GNSS outages, Monte Carlo
//! ([`rins::outages`]).

use super::write_file;
use anyhow::{anyhow, Result};
use hal_sim::drive::DriveKind;
use rins::progress_bar;
use rins::shard::Shard;
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
    /// The first drive's seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run only shard K of N (K from 0: the drives d with d mod N = K) and
    /// write them with --json for `rins merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
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
    /// The car's constraints instead of the table's scheme: each drive
    /// spinning, its base mounted in the car at a rotation drawn per
    /// drive, navigated with and without `--vehicle car` (outages at 300
    /// s for 60 s and 600 s for 120 s).
    #[arg(long, value_name = "KIND", value_parser = ["car"],
          conflicts_with_all = ["shard", "plots"])]
    pub vehicle: Option<String>,
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
    if a.vehicle.is_some() {
        return vehicle(a, kind, &imus);
    }
    let shard = a.shard.unwrap_or(Shard::ALL);
    super::shard_needs_json(
        shard,
        a.json.as_deref(),
        &[("--markdown", a.markdown.is_some())],
    )?;
    let pb = progress_bar("outages");
    let s = rins::outages::run(kind, &imus, a.seed, a.drives, shard, &|f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    show(&s, a.json.as_deref(), a.markdown.as_deref())?;
    if let (Some(dir), Some(first)) = (&a.plots, imus.first()) {
        for p in rins::outages::plots(kind, first, a.seed, dir)? {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}

/// Prints the table of `s` (a whole study) and writes what is asked; a
/// shard is only written as JSON.
pub fn show(
    s: &rins::outages::OutageStudy,
    json: Option<&std::path::Path>,
    markdown: Option<&std::path::Path>,
) -> Result<()> {
    if s.shard.n > 1 {
        return super::write_shard(s, s.shard, json, &format!("{} drives", s.runs.len()));
    }
    if let Some(p) = json {
        write_file(p, &serde_json::to_string_pretty(s)?)?;
        println!("wrote {}", p.display());
    }
    let md = s.markdown();
    print!("{md}");
    if let Some(p) = markdown {
        write_file(p, &md)?;
    }
    Ok(())
}

/// `rins outages --vehicle car`.
fn vehicle(a: &Args, kind: DriveKind, imus: &[hal_sim::imu::ImuSpec]) -> Result<()> {
    let pb = progress_bar("outages --vehicle");
    let s = rins::vehicle_study::run(kind, imus, a.seed, a.drives, &|f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string_pretty(&s)?)?;
        println!("wrote {}", p.display());
    }
    let md = s.markdown();
    print!("{md}");
    if let Some(p) = &a.markdown {
        write_file(p, &md)?;
    }
    Ok(())
}
