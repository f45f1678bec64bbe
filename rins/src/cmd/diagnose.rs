//! `rins diagnose`: the physics a recording shows that the nominal model
//! left out ([`rins::diagnose`]).

use super::{read_recording, write_file};
use anyhow::{anyhow, bail, Context, Result};
use rins::progress_bar;
use std::path::PathBuf;

/// `rins diagnose`.
#[derive(clap::Args)]
pub struct Args {
    /// The recording directory.
    pub rec: PathBuf,
    /// Use readings the sensor cannot have given (beyond its full scale,
    /// lone spikes, stuck runs) as they are, instead of excluding them.
    #[arg(long)]
    pub keep_implausible: bool,
    /// The nominal model (TOML: `earth_rate = true|false`, `[known.<effect
    /// id>]` tables of parameters the model already has); default: the
    /// spec's (gravity, earth rate, table motion, bias, scale,
    /// misalignment, white noise).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Write the rins-diagnose/1 JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the plots (SVG and PNG) into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Block length of the regression, s.
    #[arg(long, default_value_t = 0.2)]
    pub block_s: f64,
    /// Write the re-simulated run here: the same recording with the IMU
    /// samples the fitted model predicts (nominal terms and every finding,
    /// no noise), to compare or to diagnose again.
    #[arg(long)]
    pub resim: Option<PathBuf>,
    /// Write the fitted model as a simulator model here (`rins-sim-model/1`
    /// TOML: nominal terms, every finding, the noise per channel; `rins
    /// simulate --like REC --sim-model M.toml` runs it), and judge the
    /// recording against its twin with and without each finding.
    #[arg(long, value_name = "M.toml")]
    pub sim_model: Option<PathBuf>,
    /// First seed of the twins drawn for `--sim-model` (the seed, as in
    /// every command; only with `--sim-model`: the diagnosis itself draws
    /// nothing).
    #[arg(
        long = "seed",
        alias = "twin-seed",
        default_value_t = 1,
        requires = "sim_model"
    )]
    pub seed: u64,
    /// Write a sensor file (rins-sensor/2) with what the run measured of
    /// the sensor (its noise, full scale and resolution where the data show
    /// them; the findings: g-sensitivity, scale nonlinearity and asymmetry,
    /// temperature coefficients, latency) on top of --sensor; the rest
    /// from --sensor or unknown.
    #[arg(long)]
    pub sensor_out: Option<PathBuf>,
    /// The sensor the file starts from (a shipped name or a file; default:
    /// the recording's `[imu] model` when it names a shipped one).
    #[arg(long, requires = "sensor_out")]
    pub sensor: Option<String>,
}

/// Runs `rins diagnose`.
pub fn run(a: &Args) -> Result<()> {
    let rec = super::plausible(
        read_recording(&a.rec)?,
        a.sensor.as_deref(),
        a.keep_implausible,
    );
    let mut opts = rins::diagnose::Options::default();
    if let Some(m) = &a.model {
        let text =
            std::fs::read_to_string(m).with_context(|| format!("reading {}", m.display()))?;
        opts.model =
            rins::diagnose::Model::from_toml(&text).map_err(|e| anyhow!("{}: {e}", m.display()))?;
    }
    if !(a.block_s.is_finite() && a.block_s > 0.0) {
        bail!("--block-s must be a positive number of seconds");
    }
    opts.block_s = a.block_s;
    let pb = progress_bar("diagnose");
    let name = a.rec.display().to_string();
    let d = rins::diagnose::run(&rec, &name, &opts).map_err(|e| anyhow!("{name}: {e}"))?;
    pb.finish_and_clear();
    print!("{}", rins::diagnose::show::text(&d, &name));
    if let Some(dir) = &a.plots {
        for p in rins::diagnose::show::plots(&d, dir)
            .with_context(|| format!("writing plots to {}", dir.display()))?
        {
            println!("wrote {}", p.display());
        }
    }
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string_pretty(&d.to_json())?)?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &a.sensor_out {
        let base = super::base_sensor(a.sensor.as_deref(), &rec)?;
        write_file(
            p,
            &rins::diagnose::sensor_out::sensor_file(&d, &rec, base, &name),
        )?;
        println!(
            "wrote {} (rins-sensor/2: the noise and the terms the findings measured; the rest the base's or unknown)",
            p.display()
        );
    }
    if let Some(mp) = &a.sim_model {
        let pb = progress_bar("twin");
        let source = format!("rins diagnose {name}");
        let r = rins::diagnose::twin::report(&d, &rec, &opts.model, &source, a.seed)
            .map_err(|e| anyhow!("{name}: the twin: {e}"))?;
        pb.finish_and_clear();
        write_file(mp, &r.model.to_toml().map_err(|e| anyhow!("{e}"))?)?;
        print!("{}", rins::diagnose::twin::text(&r));
        println!("wrote {}", mp.display());
        if let Some(dir) = &a.plots {
            for p in rins::diagnose::twin::plots(&r, dir)
                .with_context(|| format!("writing plots to {}", dir.display()))?
            {
                println!("wrote {}", p.display());
            }
        }
    }
    if let Some(dir) = &a.resim {
        d.resimulated(&rec)
            .write(dir)
            .map_err(|e| anyhow!("writing {}: {e}", dir.display()))?;
        println!("wrote {} (the re-simulated run)", dir.display());
    }
    Ok(())
}
