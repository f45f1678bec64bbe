//! `rins study`: the blind study of diagnose ([`rins::study`]).

use super::write_file;
use anyhow::Result;
use rins::progress_bar;
use std::path::PathBuf;

/// `rins study`.
#[derive(clap::Args)]
pub struct Args {
    /// Seeds per cell.
    #[arg(long, default_value_t = 10)]
    pub runs: usize,
    /// Null runs per grade.
    #[arg(long, default_value_t = 100)]
    pub nulls: usize,
    /// Sensor grades (nav440, mtig, adis16405, icm42688).
    #[arg(long, value_delimiter = ',', default_value = "nav440,mtig")]
    pub grades: Vec<String>,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Threads (default: the machine's cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write the JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the Markdown table here.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
}

/// Runs `rins study`.
pub fn run(a: &Args) -> Result<()> {
    let pb = progress_bar("study");
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let grades: Vec<&str> = a.grades.iter().map(String::as_str).collect();
    let s = rins::study::run(
        &grades,
        &rins::study::effects(),
        a.runs,
        a.nulls,
        a.seed,
        threads,
        &|f| pb.set_position((f * 1000.0) as u64),
    )?;
    pb.finish_and_clear();
    let md = rins::study::markdown(&s);
    print!("{md}");
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string_pretty(&s)?)?;
    }
    if let Some(p) = &a.markdown {
        write_file(p, &md)?;
    }
    Ok(())
}
