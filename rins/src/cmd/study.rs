//! `rins study`: the blind study of diagnose ([`rins::study`]).

use super::write_file;
use anyhow::Result;
use rins::progress_bar;
use rins::realnoise::RealNoise;
use rins::shard::Shard;
use std::path::PathBuf;
use std::sync::Arc;

/// `rins study`.
#[derive(clap::Args)]
pub struct Args {
    /// Seeds per cell.
    #[arg(long, default_value_t = 10)]
    pub runs: usize,
    /// Null runs per grade.
    #[arg(long, default_value_t = 100)]
    pub nulls: usize,
    /// Sensors (shipped names: nav440, mtig, adis16405, icm42688,
    /// icm42605, or sensor files; `<sensor>+real`:
    /// the grade's deterministic errors on the real noise of --real-noise).
    /// Default: nav440,mtig; with --real-noise, adis16405,adis16405+real.
    #[arg(long = "sensor", alias = "grades", value_delimiter = ',')]
    pub sensor: Option<Vec<String>>,
    /// Study on real noise: the backgrounds of `adis16405+real` (next to
    /// the simulated `adis16405`) come from a real static recording (the
    /// ADIS16405 bench hours, --real-noise-file).
    #[arg(long)]
    pub real_noise: bool,
    /// The real static recording (`adis_16405_imu1_f32le_1000000x6.bin`);
    /// default `$RINS_DATA/adis16405_static/` (`RINS_DATA` default
    /// `../shared/data`).
    #[arg(long)]
    pub real_noise_file: Option<PathBuf>,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run only shard K of N (K from 0: the study's jobs i with i mod N =
    /// K) and write them with --json for `rins merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
    /// Write the JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the Markdown table here.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
}

/// Runs `rins study`.
pub fn run(a: &Args) -> Result<()> {
    let shard = a.shard.unwrap_or(Shard::ALL);
    super::shard_needs_json(
        shard,
        a.json.as_deref(),
        &[("--markdown", a.markdown.is_some())],
    )?;
    let real = if a.real_noise || a.real_noise_file.is_some() {
        let path = a.real_noise_file.clone().unwrap_or_else(|| {
            super::shared_data().join("adis16405_static/adis_16405_imu1_f32le_1000000x6.bin")
        });
        Some(Arc::new(RealNoise::adis16405(&path)?))
    } else {
        None
    };
    let names: Vec<String> = match (&a.sensor, &real) {
        (Some(g), _) => g.clone(),
        (None, Some(_)) => vec!["adis16405".into(), "adis16405+real".into()],
        (None, None) => vec!["nav440".into(), "mtig".into()],
    };
    let grades = names
        .iter()
        .map(|n| rins::study::grade(n, real.as_ref()))
        .collect::<Result<Vec<_>, _>>()?;
    let pb = progress_bar("study");
    let plan = rins::study::plan(&grades, &rins::study::effects(), a.runs, a.nulls, a.seed)?;
    let results = rins::study::run_jobs(&grades, &plan, &|i| shard.has(i), &|f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    if shard.n > 1 {
        let out = rins::study::StudyShard {
            format: rins::study::SHARD_FORMAT.into(),
            plan,
            k: shard.k,
            n: shard.n,
            results,
        };
        let what = format!("{} runs", out.results.len());
        return super::write_shard(&out, shard, a.json.as_deref(), &what);
    }
    let s = rins::study::aggregate(&plan, results)?;
    show(&s, a.json.as_deref(), a.markdown.as_deref())
}

/// Prints the study's tables and writes what is asked.
pub fn show(
    s: &rins::study::Study,
    json: Option<&std::path::Path>,
    markdown: Option<&std::path::Path>,
) -> Result<()> {
    let md = rins::study::markdown(s);
    print!("{md}");
    if let Some(p) = json {
        write_file(p, &serde_json::to_string_pretty(s)?)?;
    }
    if let Some(p) = markdown {
        write_file(p, &md)?;
    }
    Ok(())
}
