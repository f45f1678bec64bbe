//! `rins`: the host command line of the rotary MEMS INS.

use anyhow::{anyhow, bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use hal_sim::recording::Recording;
use rins::progress_bar;
use std::path::Path;

mod commands;
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
    /// Calibrate the gyro errors that table rotation excites, from a recording.
    Calibrate(commands::CalibrateArgs),
    /// Navigate a recording: trajectory.csv (rins-trajectory/1) and plots.
    Navigate(commands::NavigateArgs),
    /// Allan deviation of the six channels, noise fit, JSON and plot.
    Allan(commands::AllanArgs),
    /// The paper's experiment in simulation, beside our best and the noise floor.
    Reproduce(commands::ReproduceArgs),
    /// Find the physics a recording shows that the nominal model left out.
    Diagnose(commands::DiagnoseArgs),
    /// The blind study of `diagnose`: hidden effects at several magnitudes, nulls.
    Study(commands::StudyArgs),
    /// Build the QEMU test's input: a recording replayed through the board's logic on the host.
    QemuReplay(commands::QemuReplayArgs),
    /// Decode the board's telemetry (a serial port or a captured file) into a recording.
    Record(commands::RecordArgs),
    /// The main job: the board's run simulated, calibrated and navigated
    /// against a conventional twin; a short table and plots.
    Demo(commands::DemoArgs),
}

fn main() -> Result<()> {
    // Like any Unix filter: a closed pipe (`rins allan ... | head`) ends the
    // process quietly instead of a failed print.
    #[cfg(unix)]
    // SAFETY: restoring the default action of one signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    match cli.command {
        Command::Simulate(a) => simulate::run(&a),
        Command::Calibrate(a) => commands::calibrate(&a),
        Command::Navigate(a) => commands::navigate(&a),
        Command::Allan(a) => commands::allan(&a),
        Command::Reproduce(a) => commands::reproduce(&a),
        Command::Demo(a) => commands::demo(&a),
        Command::Record(a) => commands::record(&a),
        Command::QemuReplay(a) => commands::qemu_replay(&a),
        Command::Diagnose(a) => commands::diagnose(&a),
        Command::Study(a) => commands::study(&a),
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

/// Writes text to a file, naming it on failure.
pub fn write_file(p: &Path, text: &str) -> Result<()> {
    if let Some(d) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).with_context(|| format!("creating {}", d.display()))?;
    }
    std::fs::write(p, text).with_context(|| format!("writing {}", p.display()))
}
