//! `rins qemu-replay`: the QEMU test's input stream ([`rins::qemu_replay`]).

use super::{read_recording, write_file};
use anyhow::{Context, Result};
use std::path::PathBuf;

/// `rins qemu-replay`.
#[derive(clap::Args)]
pub struct Args {
    /// The recording to replay (from `rins simulate`).
    pub rec: PathBuf,
    /// Output: the binary replay stream for the QEMU build.
    pub out: PathBuf,
    /// Encoder counts per revolution (the board's).
    #[arg(long, default_value_t = 16_384)]
    pub counts_per_rev: u32,
}

/// Runs `rins qemu-replay`.
pub fn run(a: &Args) -> Result<()> {
    let rec = read_recording(&a.rec)?;
    rec.require_accel("rins qemu-replay")
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let r = rins::qemu_replay::build(&rec, a.counts_per_rev)?;
    write_file(&a.out, "")?;
    std::fs::write(&a.out, &r.bytes).with_context(|| format!("writing {}", a.out.display()))?;
    println!(
        "{} events ({} configuration commands) -> {}; the board's host twin fills its trailer: cargo run -p rins-tests --bin board-twin -- {}",
        r.events,
        r.commands,
        a.out.display(),
        a.out.display()
    );
    Ok(())
}
