//! The command line: one module per command, each holding its arguments
//! (clap) and a short `run`; the work is in the `rins` library.

pub mod allan;
pub mod calibrate;
pub mod command;
pub mod demo;
pub mod diagnose;
pub mod import;
pub mod merge;
pub mod navigate;
pub mod outages;
pub mod qemu_replay;
pub mod record;
pub mod reproduce;
pub mod results;
pub mod simulate;
pub mod study;

use anyhow::{anyhow, bail, Context, Result};
use clap::ValueEnum;
use recording::Recording;
use std::path::Path;

/// The shared data directory: `$RINS_DATA`, default `../shared/data`.
pub fn shared_data() -> std::path::PathBuf {
    std::env::var_os("RINS_DATA").map_or_else(
        || std::path::PathBuf::from("../shared/data"),
        std::path::PathBuf::from,
    )
}

/// The machine's cores (1 when unknown): the default thread count.
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
}

/// Table axis.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum AxisArg {
    /// Sensor x.
    X,
    /// Sensor y.
    Y,
    /// Sensor z.
    Z,
}

/// Rotation scheme.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SchemeArg {
    /// One way at --rate-dps.
    Continuous,
    /// --turns whole turns forward, then back.
    Reciprocating,
    /// --positions positions with --dwell-s dwell.
    Indexed,
    /// --turns whole turns at each --rate-dps in turn, --dwell-s after
    /// each (the phases of a multi-rate calibration).
    Multirate,
    /// No rotation (`none`: the conventional twin of a rotary run).
    #[value(alias = "none")]
    Still,
}

impl SchemeArg {
    /// The name `--scheme` takes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Continuous => "continuous",
            Self::Reciprocating => "reciprocating",
            Self::Indexed => "indexed",
            Self::Multirate => "multirate",
            Self::Still => "still",
        }
    }
}

/// Where the run is and how the base sits (`rins simulate`, `rins record`).
#[derive(clap::Args, Clone, Copy, Debug)]
pub struct SiteArgs {
    /// Site latitude, deg.
    #[arg(long, default_value_t = 30.53)]
    pub lat_deg: f64,
    /// Site height, m.
    #[arg(long, default_value_t = 20.0)]
    pub height_m: f64,
    /// Base heading, deg.
    #[arg(long, default_value_t = 0.0)]
    pub heading_deg: f64,
    /// Base pitch, deg.
    #[arg(long, default_value_t = 0.0)]
    pub pitch_deg: f64,
    /// Base roll, deg.
    #[arg(long, default_value_t = 0.0)]
    pub roll_deg: f64,
}

impl SiteArgs {
    /// Roll, pitch, heading, deg.
    pub fn base_deg(&self) -> [f64; 3] {
        [self.roll_deg, self.pitch_deg, self.heading_deg]
    }
}

/// Parses `NAME=VALUE`.
pub fn parse_effect(s: &str) -> Result<(String, f64)> {
    let Some((name, value)) = s.split_once('=') else {
        bail!("--effect takes NAME=VALUE, got {s:?}");
    };
    let v: f64 = value
        .trim()
        .parse()
        .with_context(|| format!("--effect {name}: {value:?} is not a number"))?;
    Ok((name.trim().to_string(), v))
}

/// Reads a recording with a progress message.
pub fn read_recording(p: &Path) -> Result<Recording> {
    Recording::read(p).map_err(|e| anyhow!("{e}"))
}

/// The readings of `rec` its sensor cannot have given
/// ([`recording::plausible`]: beyond the full scale of `sensor`, or of
/// the profile the recording's `[imu] model` names; spikes; stuck runs),
/// said with their time and row, and excluded (each replaced by its
/// channel's last plausible reading) unless `keep`.
pub fn plausible(rec: Recording, sensor: Option<&str>, keep: bool) -> Recording {
    let profile = rins::aided::any_profile(&rec, sensor).ok();
    let fs = profile
        .filter(|p| {
            p.unknown_of(&[
                hal_sim::sensor::terms::GYRO_FULL_SCALE,
                hal_sim::sensor::terms::ACCEL_FULL_SCALE,
            ])
            .is_empty()
        })
        .map(|p| (p.gyro.full_scale, p.accel.full_scale));
    let bad = recording::plausible::check(&rec, fs);
    if bad.is_empty() {
        return rec;
    }
    println!(
        "{} implausible readings in imu.csv{}:",
        bad.len(),
        if fs.is_some() {
            ""
        } else {
            " (full scale not checked: no sensor profile, or its full scale unknown)"
        }
    );
    for b in bad.iter().take(3) {
        println!("  {b}");
    }
    if bad.len() > 3 {
        println!("  ... and {} more", bad.len() - 3);
    }
    if keep {
        println!("  used as they are (--keep-implausible)");
        return rec;
    }
    let (out, n) = recording::plausible::excluded(&rec, &bad);
    println!("  excluded: {n} readings replaced by their channel's last plausible one (--keep-implausible uses them)");
    out
}

/// Writes text to a file, naming it on failure.
pub fn write_file(p: &Path, text: &str) -> Result<()> {
    if let Some(d) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
    }
    std::fs::write(p, text).with_context(|| format!("writing {}", p.display()))
}

/// `--shard` refused without `--json` (a shard's runs are what `rins
/// merge` reads) and with the outputs only a whole run makes (`tables`:
/// `--markdown`, `--plots`, each given or not).
pub fn shard_needs_json(
    shard: rins::shard::Shard,
    json: Option<&Path>,
    tables: &[(&str, bool)],
) -> Result<()> {
    if shard.n <= 1 {
        return Ok(());
    }
    if json.is_none() {
        anyhow::bail!("--shard needs --json: the shard's runs are what `rins merge` reads");
    }
    if let Some((flag, _)) = tables.iter().find(|(_, given)| *given) {
        anyhow::bail!("{flag} with --shard: a shard makes no table or plot; `rins merge` of all the shards does (give it {flag})");
    }
    Ok(())
}

/// Writes shard `shard`'s output `out` as JSON to `json` and says so,
/// with `what` it ran (e.g. "12 runs").
pub fn write_shard<T: serde::Serialize>(
    out: &T,
    shard: rins::shard::Shard,
    json: Option<&Path>,
    what: &str,
) -> Result<()> {
    if let Some(p) = json {
        write_file(p, &serde_json::to_string_pretty(out)?)?;
        println!(
            "wrote {}: shard {}/{}, {what}; `rins merge` makes the tables",
            p.display(),
            shard.k,
            shard.n
        );
    }
    Ok(())
}

/// The sensor a `--sensor-out` file starts from: `name` (a shipped name
/// or a file), else the shipped one the recording's `[imu] model` names
/// (in any case), else none; with its shipped name when it is one.
pub fn base_sensor(name: Option<&str>, rec: &Recording) -> Result<Option<rins::sensor_file::Base>> {
    let shipped = |s: hal_sim::imu::ImuSpec| {
        let n = hal_sim::sensor::names()
            .into_iter()
            .find(|n| *n == s.name)
            .map(String::from);
        (s, n)
    };
    Ok(match name {
        Some(n) if hal_sim::sensor::names().contains(&n) => {
            Some(shipped(hal_sim::sensor::resolve(n)?))
        }
        Some(n) => Some((hal_sim::sensor::resolve(n)?, None)),
        None => rec
            .meta
            .imu_model
            .as_deref()
            .and_then(hal_sim::imu::ImuSpec::by_model)
            .map(shipped),
    })
}
