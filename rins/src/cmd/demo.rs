//! `rins demo`: the main job ([`rins::demo`]): the board's run simulated,
//! calibrated and navigated against a conventional twin; a table and plots.

use anyhow::Result;
use rins::{calibrate, demo, progress_bar};
use std::path::PathBuf;

/// `rins demo`.
#[derive(clap::Args)]
pub struct Args {
    /// Output directory (recordings, trajectories, plots).
    #[arg(long, default_value = "out/demo")]
    pub out: PathBuf,
    /// Table rate, deg/s.
    #[arg(long, default_value_t = 30.0)]
    pub rate_dps: f64,
    /// Seed.
    #[arg(long, default_value_t = 7)]
    pub seed: u64,
}

/// What `--out` holds before the demo writes: nothing, a previous demo's
/// output (replaced, and said so), or something else (refused).
fn check_out(out: &std::path::Path) -> Result<()> {
    let Ok(mut entries) = std::fs::read_dir(out) else {
        return Ok(());
    };
    if entries.next().is_none() {
        return Ok(());
    }
    if out.join("trajectory_rotary.csv").exists() && out.join("recording_rotary").exists() {
        println!(
            "  replacing the previous demo's output in {}",
            out.display()
        );
        return Ok(());
    }
    anyhow::bail!(
        "{} exists and is not a previous demo's output: give another --out",
        out.display()
    )
}

/// Runs `rins demo`.
pub fn run(a: &Args) -> Result<()> {
    check_out(&a.out)?;
    println!("rins demo: the board's IMU (TDK ICM-42688-P) on a z table at 30.53 N");
    println!(
        "  power-up: {} s still + {} s at {} deg/s (calibration), then {} min of navigation",
        demo::STATIC_S,
        demo::NAV_START_S - demo::STATIC_S,
        a.rate_dps,
        (demo::DURATION_S - demo::NAV_START_S) / 60.0
    );
    let pb = progress_bar("demo");
    let d = demo::run(a.rate_dps, a.seed, &mut |f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    print!("{}", calibrate::report(&d.calibration));
    println!();
    print!("{}", d.table());
    let files = d.write(&a.out)?;
    println!(
        "{} plots (SVG and PNG), trajectories, calibration and both recordings in {}",
        files
            .iter()
            .filter(|f| f.extension().is_some_and(|e| e == "png"))
            .count(),
        a.out.display()
    );
    Ok(())
}
