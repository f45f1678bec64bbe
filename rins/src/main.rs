//! `rins`: the host command line of the rotary MEMS INS.

use anyhow::Result;
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

mod cmd;

/// rins: rotary MEMS inertial navigation (simulate, calibrate, navigate, ...).
#[derive(Parser)]
#[command(name = "rins", version, about)]
struct Cli {
    /// Worker threads of every parallel part (studies, Monte Carlo runs,
    /// diagnose's channels, twins); default: the machine's cores.
    #[arg(long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Tool,
}

#[derive(Subcommand)]
enum Tool {
    /// Simulate a rotary IMU run and write it as a recording (rins-recording/1).
    Simulate(cmd::simulate::Args),
    /// Calibrate the gyro errors that table rotation excites, from a recording.
    Calibrate(cmd::calibrate::Args),
    /// Navigate a recording: trajectory.csv (rins-trajectory/1) and plots.
    Navigate(cmd::navigate::Args),
    /// Import a real log as a recording: any IMU CSV, an RTKLIB solution
    /// with an IMU CSV, KF-GINS files.
    Import(cmd::import::Args),
    /// Allan deviation of the six channels, noise fit, JSON and plot.
    Allan(cmd::allan::Args),
    /// The paper's experiment in simulation, beside our best and the noise floor.
    Reproduce(cmd::reproduce::Args),
    /// Find the physics a recording shows that the nominal model left out.
    Diagnose(cmd::diagnose::Args),
    /// The blind study of `diagnose`: hidden effects at several magnitudes, nulls.
    Study(cmd::study::Args),
    /// The aided rotary INS through GNSS outages: Monte Carlo of simulated
    /// drives, rotary against conventional, per sensor.
    Outages(cmd::outages::Args),
    /// Regenerate the book's result tables (reproduce, outages, study) from
    /// their runs, stamped with the date and commit.
    Results(cmd::results::Args),
    /// Put the shards of a study (`--shard K/N --json`) back together:
    /// the tables one run gives, bit for bit.
    Merge(cmd::merge::Args),
    /// Build the QEMU test's input: a recording replayed through the board's logic on the host.
    QemuReplay(cmd::qemu_replay::Args),
    /// Decode the board's telemetry (a serial port or a captured file) into a recording.
    Record(cmd::record::Args),
    /// Send one command to a board (start, stop, scheme, site, base, aided, recalibrate).
    Command(cmd::command::Args),
    /// The main job: the board's run simulated, calibrated and navigated
    /// against a conventional twin; a short table and plots.
    Demo(cmd::demo::Args),
}

/// Every command and subcommand takes negative numbers as values (a
/// southern latitude, a negative pitch or rate): `--lat-deg -33.9`, not an
/// unknown flag `-3`.
fn signed(cmd: clap::Command) -> clap::Command {
    cmd.allow_negative_numbers(true).mut_subcommands(signed)
}

/// Help fits 80 columns whatever the terminal (a narrower one wraps it
/// narrower still).
pub const HELP_COLUMNS: usize = 80;

fn main() -> Result<()> {
    // Like any Unix filter: a closed pipe (`rins allan ... | head`) ends the
    // process quietly instead of a failed print.
    #[cfg(unix)]
    // SAFETY: restoring the default action of one signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    rins::memory::keep_freed_memory();
    let cli = match Cli::from_arg_matches(
        &signed(Cli::command().max_term_width(HELP_COLUMNS)).get_matches(),
    ) {
        Ok(c) => c,
        Err(e) => e.exit(),
    };
    let threads = cli.threads.unwrap_or_else(cmd::cores).max(1);
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()?;
    match cli.command {
        Tool::Simulate(a) => cmd::simulate::run(&a),
        Tool::Calibrate(a) => cmd::calibrate::run(&a),
        Tool::Navigate(a) => cmd::navigate::run(&a),
        Tool::Import(a) => cmd::import::run(&a),
        Tool::Allan(a) => cmd::allan::run(&a),
        Tool::Reproduce(a) => cmd::reproduce::run(&a),
        Tool::Demo(a) => cmd::demo::run(&a),
        Tool::Record(a) => cmd::record::run(&a),
        Tool::Command(a) => cmd::command::run(&a),
        Tool::QemuReplay(a) => cmd::qemu_replay::run(&a),
        Tool::Diagnose(a) => cmd::diagnose::run(&a),
        Tool::Study(a) => cmd::study::run(&a),
        Tool::Outages(a) => cmd::outages::run(&a),
        Tool::Results(a) => cmd::results::run(&a),
        Tool::Merge(a) => cmd::merge::run(&a),
    }
}
