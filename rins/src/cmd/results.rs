//! `rins results`: regenerate the book's result tables ([`rins::results`]).

use super::write_file;
use anyhow::{anyhow, Result};
use hal_sim::drive::DriveKind;
use rins::realnoise::RealNoise;
use rins::results::{self, Setting};
use rins::shard::Shard;
use rins::{progress_bar, reproduce as repro};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// `rins results`.
#[derive(clap::Args)]
pub struct Args {
    /// Write the tables (markdown, one file each) into this directory.
    #[arg(long, default_value = "docs/src/results")]
    pub out: PathBuf,
    /// The small setting: every table made in minutes, with too few runs
    /// for its figures (CI's check that the command still works).
    #[arg(long)]
    pub small: bool,
    /// Only these tables (comma-separated: reproduce, outages, study,
    /// study-real-noise, coverage, coverage-aided); default: all.
    #[arg(long, value_delimiter = ',')]
    pub only: Option<Vec<String>>,
}

/// The tables, by the names `--only` takes.
const TABLES: [&str; 6] = [
    "reproduce",
    "outages",
    "study",
    "study-real-noise",
    "coverage",
    "coverage-aided",
];

/// Runs `rins results`.
pub fn run(a: &Args) -> Result<()> {
    let set = if a.small {
        results::SMALL
    } else {
        results::BOOK
    };
    if let Some(bad) = a
        .only
        .iter()
        .flatten()
        .find(|t| !TABLES.contains(&t.as_str()))
    {
        return Err(anyhow!("--only {bad:?}: one of {}", TABLES.join(", ")));
    }
    let want = |t: &str| a.only.as_ref().is_none_or(|o| o.iter().any(|x| x == t));
    let (date, commit) = (results::today(), results::commit());
    let write = |name: &str, command: String, body: String| -> Result<()> {
        let p = a.out.join(name);
        let source = if name.contains("real-noise") {
            "Our simulator's runs on the real ADIS16405 bench noise."
        } else {
            "Our own simulator only."
        };
        let stamp = results::stamp(&command, source, &set, &date, &commit);
        write_file(&p, &(stamp + &body))?;
        println!("wrote {}", p.display());
        Ok(())
    };
    for sensor in ["nav440", "mtig"].into_iter().filter(|_| want("reproduce")) {
        let (cmd, body) = reproduce(sensor, &set)?;
        write(&format!("reproduce-{sensor}.md"), cmd, body)?;
    }
    for kind in [DriveKind::City, DriveKind::Highway]
        .into_iter()
        .filter(|_| want("outages"))
    {
        let (cmd, body) = outages(kind, &set)?;
        write(&format!("outages-{}.md", kind.name()), cmd, body)?;
    }
    if want("study") {
        let (cmd, body) = study(&["nav440", "mtig"], None, &set)?;
        write("study.md", cmd, body)?;
    }
    if want("coverage") {
        write(
            "coverage.md",
            "rins results --only coverage".into(),
            coverage()?,
        )?;
    }
    if want("coverage-aided") {
        write(
            "coverage-aided.md",
            "rins results --only coverage-aided".into(),
            coverage_aided(&set)?,
        )?;
    }
    if !want("study-real-noise") {
        return Ok(());
    }
    match real_noise() {
        Ok(real) => {
            let grades = ["adis16405", "adis16405+real"];
            let (cmd, body) = study(&grades, Some(real), &set)?;
            write("study-real-noise.md", cmd, body)?;
        }
        Err(e) => println!(
            "study-real-noise.md not generated (left as it was): {e:#}; set RINS_DATA to the shared data directory"
        ),
    }
    Ok(())
}

/// Runs `study` with a progress bar `name` that counts `total` steps.
fn counted<T>(
    name: &str,
    total: u64,
    study: impl FnOnce(&(dyn Fn() + Sync)) -> Result<T>,
) -> Result<T> {
    let pb = progress_bar(name);
    let done = std::sync::atomic::AtomicU64::new(0);
    let r = study(&|| {
        let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        pb.set_position(n * 1000 / total.max(1));
    });
    pb.finish_and_clear();
    r
}

/// The coverage study over its seeds (the same in every setting: the
/// whole study takes seconds).
fn coverage() -> Result<String> {
    let seeds: Vec<u64> = (0..rins::coverage::SEEDS).collect();
    let rows = counted("coverage", 4 * seeds.len() as u64, |done| {
        rins::coverage::study(&seeds, done)
    })?;
    Ok(rins::coverage::table(&rows))
}

/// The aided coverage study over the setting's drives.
fn coverage_aided(set: &Setting) -> Result<String> {
    let seeds: Vec<u64> = (1..=set.coverage_drives).collect();
    let rows = counted("coverage (aided)", seeds.len() as u64, |done| {
        rins::coverage::aided_study(&seeds, done)
    })?;
    Ok(rins::coverage::aided_table(&rows))
}

fn reproduce(sensor: &str, set: &Setting) -> Result<(String, String)> {
    let spec = hal_sim::sensor::resolve(sensor)?;
    let pb = progress_bar(&format!("reproduce {sensor}"));
    let rows = repro::reproduce(
        &spec,
        set.reproduce_runs,
        1,
        &repro::RATES_DPS,
        Shard::ALL,
        &|f| pb.set_position((f * 1000.0) as u64),
    )?;
    pb.finish_and_clear();
    let cmd = format!(
        "rins reproduce --sensor {sensor} --runs {}",
        set.reproduce_runs
    );
    Ok((cmd, repro::markdown(&rows, sensor)))
}

fn outages(kind: DriveKind, set: &Setting) -> Result<(String, String)> {
    let imus = ["nav440", "icm42688"]
        .iter()
        .map(|n| Ok(hal_sim::sensor::resolve(n)?))
        .collect::<Result<Vec<_>>>()?;
    let pb = progress_bar(&format!("outages {}", kind.name()));
    let s = rins::outages::run(kind, &imus, 1, set.outage_drives, Shard::ALL, &|f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    let cmd = format!(
        "rins outages --drive {} --drives {}",
        kind.name(),
        set.outage_drives
    );
    Ok((cmd, s.markdown()))
}

fn study(names: &[&str], real: Option<Arc<RealNoise>>, set: &Setting) -> Result<(String, String)> {
    let grades = names
        .iter()
        .map(|n| rins::study::grade(n, real.as_ref()))
        .collect::<Result<Vec<_>, _>>()?;
    let pb = progress_bar("study");
    let s = rins::study::run(
        &grades,
        &rins::study::effects(),
        set.study_runs,
        set.study_nulls,
        1,
        &|f| pb.set_position((f * 1000.0) as u64),
    )?;
    pb.finish_and_clear();
    let real_flag = if real.is_some() { " --real-noise" } else { "" };
    let cmd = format!(
        "rins study --sensor {}{real_flag} --runs {} --nulls {}",
        names.join(","),
        set.study_runs,
        set.study_nulls
    );
    Ok((cmd, rins::study::markdown(&s)))
}

/// The ADIS16405 bench hours, from the shared data directory.
fn real_noise() -> Result<Arc<RealNoise>> {
    let p = super::shared_data().join("adis16405_static/adis_16405_imu1_f32le_1000000x6.bin");
    if !Path::new(&p).is_file() {
        return Err(anyhow!("{} not found", p.display()));
    }
    Ok(Arc::new(RealNoise::adis16405(&p)?))
}
