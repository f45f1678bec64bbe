//! `rins merge`: the shards of a study (`--shard K/N --json`) put back
//! together into the tables one run gives, bit for bit
//! ([`rins::shard`]).

use anyhow::{anyhow, bail, Context, Result};
use rins::shard::{complete, Shard};
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// `rins merge`.
#[derive(clap::Args)]
pub struct Args {
    /// The shards' JSON files (`rins study|outages|reproduce --shard K/N
    /// --json FILE`): every K of one N, each once, in any order.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Write the merged study's JSON here (the one run's JSON).
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write its table as markdown here.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
    /// Write its plots (reproduce) into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

fn read<T: DeserializeOwned>(p: &Path) -> Result<T> {
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    serde_json::from_str(&text)
        .with_context(|| format!("{}: not a shard of this kind", p.display()))
}

/// Runs `rins merge`.
pub fn run(a: &Args) -> Result<()> {
    let first: serde_json::Value = read(&a.shards[0])?;
    let format = first["format"].as_str().unwrap_or("").to_string();
    if a.plots.is_some() && format != rins::reproduce::FORMAT {
        bail!("--plots: only the paper's experiment (rins-reproduce/1 shards) has plots to merge; `rins outages --plots` draws its drive without --shard");
    }
    match format.as_str() {
        rins::outages::FORMAT => {
            let parts = a.shards.iter().map(|p| read(p)).collect::<Result<Vec<_>>>()?;
            let s = rins::outages::merge(parts)?;
            super::outages::show(&s, a.json.as_deref(), a.markdown.as_deref())
        }
        rins::reproduce::FORMAT => {
            let parts: Vec<rins::reproduce::Output> =
                a.shards.iter().map(|p| read(p)).collect::<Result<_>>()?;
            let out = merge_reproduce(parts)?;
            super::reproduce::show(
                &out,
                a.json.as_deref(),
                a.markdown.as_deref(),
                a.plots.as_deref(),
            )
        }
        rins::study::SHARD_FORMAT => {
            let parts: Vec<rins::study::StudyShard> =
                a.shards.iter().map(|p| read(p)).collect::<Result<_>>()?;
            let plan = parts[0].plan.clone();
            if parts.iter().any(|p| p.plan != plan) {
                bail!("the shards are of different studies (their plans differ)");
            }
            let shards: Vec<Shard> = parts.iter().map(|p| Shard { k: p.k, n: p.n }).collect();
            complete(&shards).map_err(|e| anyhow!(e))?;
            let results = parts.into_iter().flat_map(|p| p.results).collect();
            let s = rins::study::aggregate(&plan, results)?;
            super::study::show(&s, a.json.as_deref(), a.markdown.as_deref())
        }
        f => bail!(
            "{}: format {f:?} is not a shard (rins-outages/1, rins-reproduce/1 or rins-study-shard/1)",
            a.shards[0].display()
        ),
    }
}

fn merge_reproduce(parts: Vec<rins::reproduce::Output>) -> Result<rins::reproduce::Output> {
    let p0 = parts.first().ok_or_else(|| anyhow!("no shard"))?;
    if parts
        .iter()
        .any(|p| (&p.imu, p.runs, p.seed) != (&p0.imu, p0.runs, p0.seed))
    {
        bail!("the shards are of different runs (sensor, --runs or --seed differ)");
    }
    let shards: Vec<Shard> = parts.iter().map(|p| p.shard).collect();
    complete(&shards).map_err(|e| anyhow!(e))?;
    let mut out = p0.clone();
    out.shard = Shard::ALL;
    out.rows = rins::reproduce::merge(parts.into_iter().map(|p| p.rows).collect())?;
    Ok(out)
}
