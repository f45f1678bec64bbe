//! `rins reproduce`: the paper's experiment in simulation (Monte Carlo per
//! mode and table rate), beside our best and the white-noise floor.

use super::write_file;
use anyhow::{anyhow, bail, Result};
use hal_sim::imu::ImuSpec;
use rins::shard::Shard;
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
    /// Write the book's table (markdown) here.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
    /// Write the plots (SVG and PNG) into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Run only shard K of N (K from 0: the runs k with k mod N = K) and
    /// write them with --json for `rins merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
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
    let shard = a.shard.unwrap_or(Shard::ALL);
    super::shard_needs_json(
        shard,
        a.json.as_deref(),
        &[
            ("--markdown", a.markdown.is_some()),
            ("--plots", a.plots.is_some()),
        ],
    )?;
    let pb = progress_bar("reproduce");
    let rows = repro::reproduce(&spec, a.runs, a.seed, &repro::RATES_DPS, shard, &|f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    let out = repro::Output {
        format: repro::FORMAT.into(),
        imu: a.sensor.clone(),
        runs: a.runs,
        seed: a.seed,
        shard,
        rows,
    };
    show(
        &out,
        a.json.as_deref(),
        a.markdown.as_deref(),
        a.plots.as_deref(),
    )
}

/// Prints the report of `out` (a whole study) and writes what is asked:
/// the JSON, the book's markdown table, the plots. A shard is only
/// written as JSON.
pub fn show(
    out: &repro::Output,
    json: Option<&std::path::Path>,
    markdown: Option<&std::path::Path>,
    plots: Option<&std::path::Path>,
) -> Result<()> {
    if out.shard.n > 1 {
        let per_cell = out.rows.first().map_or(0, |r| r.runs.len());
        return super::write_shard(out, out.shard, json, &format!("{per_cell} runs a cell"));
    }
    if let Some(p) = json {
        write_file(p, &serde_json::to_string_pretty(out)?)?;
        println!("wrote {}", p.display());
    }
    print!("{}", repro::text_report(&out.rows, &out.imu, out.runs));
    if let Some(p) = markdown {
        write_file(p, &repro::markdown(&out.rows, &out.imu))?;
        println!("wrote {}", p.display());
    }
    if let Some(d) = plots {
        for chart in report::reproduce_charts(&out.rows, &out.imu) {
            chart.write(d)?;
        }
        println!("plots in {}", d.display());
    }
    Ok(())
}
