//! `rins`: the host command line of the rotary MEMS INS.

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

mod simulate;

/// rins: rotary MEMS inertial navigation (simulate, calibrate, navigate, ...).
#[derive(Parser)]
#[command(name = "rins", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
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
    /// No rotation.
    Still,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a rotary IMU run and write it as a recording (rins-recording/1).
    Simulate(simulate::Args),
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Simulate(a) => simulate::run(&a),
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

/// A progress bar for a job measured in fractions.
pub fn progress_bar(what: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(1000);
    pb.set_style(
        indicatif::ProgressStyle::with_template("{msg:>12} [{bar:40}] {percent:>3}% {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

/// Where a path points, for messages.
pub fn shown(p: &std::path::Path) -> String {
    PathBuf::from(p).display().to_string()
}
