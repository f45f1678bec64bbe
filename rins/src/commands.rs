//! The processing commands: calibrate, navigate, allan, reproduce, demo.

use crate::{progress_bar, read_recording, write_file};
use anyhow::{anyhow, bail, Context, Result};
use core_nav::calib::{Checks, GyroCalibration, PhaseAccumulator};
use core_nav::scheme::Scheme;
use core_nav::table::{Axis, EncoderScale, TableAngle};
use hal_sim::imu::ImuSpec;
use hal_sim::recording::Recording;
use hal_sim::sim::{simulate, SimConfig};
use rins::calibrate::{self, Method};
use rins::nav::{self, NavOptions, StaticErrors, TrajRow};
use rins::{allan as allan_mod, report, reproduce as repro};
use std::io::Read;
use std::path::PathBuf;

/// `rins calibrate`.
#[derive(clap::Args)]
pub struct CalibrateArgs {
    /// The recording directory.
    pub rec: PathBuf,
    /// Write the calibration (rins-calibration/1) here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Method.
    #[arg(long, value_enum, default_value = "auto")]
    pub method: Method,
    /// Use data from this time on, s.
    #[arg(long, default_value_t = 0.0)]
    pub from_s: f64,
    /// Use data up to this time, s (default: 120 s, the power-up calibration).
    #[arg(long, default_value_t = 120.0)]
    pub to_s: f64,
    /// The commanded table rate, deg/s: steady phases must reach it within 2 %.
    #[arg(long)]
    pub rate_dps: Option<f64>,
}

/// Runs `rins calibrate`.
pub fn calibrate(a: &CalibrateArgs) -> Result<()> {
    let rec = read_recording(&a.rec)?;
    let r = calibrate::calibrate(
        &rec,
        (a.from_s, a.to_s),
        a.method,
        a.rate_dps.map(f64::to_radians),
    )
    .with_context(|| format!("calibrating {}", a.rec.display()))?;
    print!("{}", calibrate::report(&r));
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string_pretty(&calibrate::to_json(&r))?)?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// `rins navigate`.
#[derive(clap::Args)]
pub struct NavigateArgs {
    /// The recording directory.
    pub rec: PathBuf,
    /// Gyro calibration (rins-calibration/1, from `rins calibrate --json`).
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// Output directory: trajectory.csv and plots.
    #[arg(long)]
    pub out: PathBuf,
    /// Start navigating at this time, s (default: the first sample).
    #[arg(long, default_value_t = 0.0)]
    pub start_s: f64,
    /// Stop at this time, s.
    #[arg(long)]
    pub end_s: Option<f64>,
    /// Navigate in f32, as the MCU does.
    #[arg(long)]
    pub f32: bool,
    /// Hold the height (long static runs: the vertical channel diverges).
    #[arg(long)]
    pub hold_height: bool,
    /// Also write the summary as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

fn load_calibration(p: &PathBuf) -> Result<GyroCalibration> {
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", p.display()))?;
    calibrate::from_json(&v).with_context(|| format!("{}", p.display()))
}

/// Runs `rins navigate`.
pub fn navigate(a: &NavigateArgs) -> Result<()> {
    let rec = read_recording(&a.rec)?;
    let calibration = a.calibration.as_ref().map(load_calibration).transpose()?;
    if let Some(c) = &calibration {
        if c.axis != rec.meta.axis {
            bail!(
                "the calibration is for table axis {:?}, the recording turns about {:?}",
                c.axis,
                rec.meta.axis
            );
        }
    }
    let opt = NavOptions {
        start_s: a.start_s,
        end_s: a.end_s,
        calibration,
        f32: a.f32,
        hold_height: a.hold_height,
        gimbals: None,
    };
    let pb = progress_bar("navigate");
    let rows = nav::navigate(&rec, &opt, &mut |f| pb.set_position((f * 1000.0) as u64))?;
    pb.finish_and_clear();
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    write_file(&a.out.join("trajectory.csv"), &nav::trajectory_csv(&rows))?;
    let m = &rec.meta;
    let base = [m.roll_deg, m.pitch_deg, m.heading_deg];
    for (name, svg) in report::nav_charts(&[("run", &rows)], base) {
        write_file(&a.out.join(&name), &svg)?;
    }
    let e = nav::static_errors(&rows, base);
    let faults = rows.last().map_or(0, |r| r.faults);
    println!(
        "{} samples navigated ({} refused) -> {}",
        rows.len(),
        faults,
        a.out.display()
    );
    println!("errors against a static base (the recording's attitude, the start point):");
    println!("  {}", nav::summary(&e));
    println!("  final horizontal position error {:.2} m", e.h_pos_end_m);
    if let Some(p) = &a.json {
        write_file(
            p,
            &serde_json::to_string_pretty(
                &serde_json::json!({"errors": e, "refused_steps": faults}),
            )?,
        )?;
    }
    Ok(())
}

/// `rins allan`.
#[derive(clap::Args)]
pub struct AllanArgs {
    /// The recording directory.
    pub rec: PathBuf,
    /// Write the rins-allan/1 JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the plot (SVG) here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// Runs `rins allan`.
pub fn allan(a: &AllanArgs) -> Result<()> {
    let mut rec = read_recording(&a.rec)?;
    // Allan deviation characterises a still sensor: when the table turned,
    // use the longest static stretch and say so.
    let moved = rec
        .table
        .windows(2)
        .any(|w| (w[1].angle_rad - w[0].angle_rad).abs() > 1e-9);
    if moved {
        let segs = calibrate::segments(&rec, 10.0, 0.5);
        let longest = segs
            .iter()
            .filter(|s| s.rate_radps == 0.0)
            .max_by(|a, b| (a.t1_s - a.t0_s).total_cmp(&(b.t1_s - b.t0_s)));
        let Some(s) = longest else {
            bail!(
                "{}: the table turns throughout; Allan deviation needs a still sensor",
                a.rec.display()
            );
        };
        println!(
            "the table turns in this recording: using its longest still stretch, {:.1}-{:.1} s",
            s.t0_s, s.t1_s
        );
        let (t0, t1) = (s.t0_s, s.t1_s);
        rec.imu.retain(|r| r.t_s >= t0 && r.t_s <= t1);
    }
    if rec.imu.len() < 100 {
        bail!(
            "{}: {} IMU samples are too few for an Allan deviation",
            a.rec.display(),
            rec.imu.len()
        );
    }
    let pb = progress_bar("allan");
    let chs = allan_mod::compute(&rec);
    pb.finish_and_clear();
    print!("{}", allan_mod::report(&chs));
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string(&allan_mod::to_json(&chs))?)?;
        println!("wrote {}", p.display());
    }
    if let Some(p) = &a.plot {
        write_file(p, &allan_mod::svg(&chs, &a.rec.display().to_string()))?;
        println!("wrote {}", p.display());
    }
    Ok(())
}

/// `rins reproduce`.
#[derive(clap::Args)]
pub struct ReproduceArgs {
    /// IMU: mtig or nav440.
    #[arg(long)]
    pub imu: String,
    /// Monte Carlo runs per mode and rate.
    #[arg(long, default_value_t = 5)]
    pub runs: usize,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the rins-reproduce/1 JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the plots (SVG) into this directory.
    #[arg(long)]
    pub plots: Option<PathBuf>,
}

/// Runs `rins reproduce`.
pub fn reproduce(a: &ReproduceArgs) -> Result<()> {
    if !["mtig", "nav440"].contains(&a.imu.as_str()) {
        bail!(
            "--imu must be mtig or nav440 (the paper's sensors), got {:?}",
            a.imu
        );
    }
    if a.runs == 0 {
        bail!("--runs must be at least 1");
    }
    let spec = ImuSpec::by_name(&a.imu).ok_or_else(|| anyhow!("unknown imu"))?;
    let pb = progress_bar("reproduce");
    let rows = repro::reproduce(&spec, a.runs, a.seed, &repro::RATES_DPS, &mut |f| {
        pb.set_position((f * 1000.0) as u64)
    })?;
    pb.finish_and_clear();
    println!(
        "{} ({} runs per cell): RMS over 5 min of navigation",
        a.imu, a.runs
    );
    println!(
        "{:<15} {:>6} {:>12} {:>10} {:>9} {:>9} {:>10}",
        "mode", "deg/s", "pos [m]", "vel [m/s]", "roll [d]", "pitch [d]", "hdg [d]"
    );
    for r in &rows {
        println!(
            "{:<15} {:>6} {:>12.1} {:>10.3} {:>9.4} {:>9.4} {:>10.4}",
            r.mode,
            r.rate_dps,
            r.h_pos_rms_m,
            r.h_vel_rms_mps,
            r.roll_rms_deg,
            r.pitch_rms_deg,
            r.heading_rms_deg
        );
    }
    println!("\nmean over all rates (paper's figures beside ours):");
    println!(
        "{:<15} {:>12} {:>10} {:>14} {:>12}",
        "mode", "pos [m]", "vel [m/s]", "paper pos [m]", "paper vel"
    );
    for mode in [
        "conventional",
        "rotary-partial",
        "rotary-full",
        "rotary-best",
        "noise-floor",
    ] {
        if let Some((p, v)) = repro::mode_mean(&rows, mode) {
            let paper = repro::PAPER
                .iter()
                .find(|(i, m, _, _)| *i == a.imu && *m == mode);
            let (pp, pv) = paper.map_or(("-".to_string(), "-".to_string()), |(_, _, p, v)| {
                (format!("{p:.1}"), format!("{v:.1}"))
            });
            let note = if mode == "conventional" {
                "   (paper: several km after 5 min)"
            } else {
                ""
            };
            println!("{mode:<15} {p:>12.1} {v:>10.3} {pp:>14} {pv:>12}{note}");
        }
    }
    if let (Some((conv, _)), Some((best, _)), Some((floor, _))) = (
        repro::mode_mean(&rows, "conventional"),
        repro::mode_mean(&rows, "rotary-best"),
        repro::mode_mean(&rows, "noise-floor"),
    ) {
        println!(
            "\nrotary-best is {:.1}x better than conventional and {:.2}x the noise floor",
            conv / best,
            best / floor
        );
    }
    if let Some(p) = &a.json {
        let v = serde_json::json!({"format": "rins-reproduce/1", "imu": a.imu, "rows": rows});
        write_file(p, &serde_json::to_string_pretty(&v)?)?;
        println!("wrote {}", p.display());
    }
    if let Some(d) = &a.plots {
        for (name, svg) in report::reproduce_charts(&rows, &a.imu) {
            write_file(&d.join(&name), &svg)?;
        }
        println!("plots in {}", d.display());
    }
    Ok(())
}

/// `rins demo`.
#[derive(clap::Args)]
pub struct DemoArgs {
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

/// Earth-aware bias from the first `t_s` seconds of a static recording.
fn static_bias(rec: &Recording, t_s: f64) -> Result<GyroCalibration> {
    let mut acc = PhaseAccumulator::new(0.0, rec.meta.axis);
    let angle = TableAngle::from_rad_f64(rec.table.first().map_or(0.0, |r| r.angle_rad));
    for r in rec.imu.iter().take_while(|r| r.t_s < t_s) {
        acc.push(
            (r.t_s * 1e6).round() as u64,
            &r.gyro_radps.into(),
            &r.accel_mps2.into(),
            angle,
        )
        .map_err(|e| anyhow!("{e}"))?;
    }
    let checks = Checks {
        gravity_mps2: calibrate::checks_of(rec).gravity_mps2,
        ..Checks::default()
    };
    let p = acc
        .finish(&checks, 1.0 / rec.meta.imu_rate_hz)
        .map_err(|e| anyhow!("{e}"))?;
    Ok(GyroCalibration {
        bias: p.mean_w - calibrate::earth_of(rec).seen(&p),
        axis: rec.meta.axis,
        ..GyroCalibration::default()
    })
}

/// Runs `rins demo`.
pub fn demo(a: &DemoArgs) -> Result<()> {
    let spec = ImuSpec::icm42688();
    println!(
        "rins demo: the board's IMU ({}) on a z table at 30.53 N",
        spec.model
    );
    println!(
        "  power-up: 60 s still + 60 s at {} deg/s (calibration), then 5 min of navigation",
        a.rate_dps
    );
    let pb = progress_bar("demo");
    let mut cfg = SimConfig::new(spec, Axis::Z, 420.0);
    cfg.scheme = Scheme::Continuous {
        rate: a.rate_dps.to_radians(),
    };
    cfg.static_s = 60.0;
    cfg.seed = a.seed;
    let rot =
        simulate(&cfg, &mut |f| pb.set_position((f * 300.0) as u64)).map_err(|e| anyhow!(e))?;
    let mut twin = cfg.clone();
    twin.scheme = Scheme::Still;
    let conv = simulate(&twin, &mut |f| pb.set_position(300 + (f * 300.0) as u64))
        .map_err(|e| anyhow!(e))?;
    pb.set_position(600);
    let cal = calibrate::calibrate(
        &rot,
        (0.0, 120.0),
        Method::Earth,
        Some(a.rate_dps.to_radians()),
    )?;
    let conv_cal = static_bias(&conv, 60.0)?;
    let run = |rec: &Recording, c: GyroCalibration| -> Result<Vec<TrajRow>> {
        let o = NavOptions {
            start_s: 120.0,
            end_s: Some(420.0),
            calibration: Some(c),
            f32: true,
            hold_height: false,
            gimbals: None,
        };
        nav::navigate(rec, &o, &mut |_| {})
    };
    let rows_rot = run(&rot, cal.gyro)?;
    let rows_conv = run(&conv, conv_cal)?;
    pb.finish_and_clear();
    print!("{}", calibrate::report(&cal));
    let base = [0.0, 0.0, 0.0];
    let (er, ec): (StaticErrors, StaticErrors) = (
        nav::static_errors(&rows_rot, base),
        nav::static_errors(&rows_conv, base),
    );
    println!("\n5 min of navigation (f32, as on the MCU), errors:");
    println!(
        "{:<14} {:>12} {:>12} {:>10} {:>10} {:>10}",
        "", "final pos", "RMS pos", "RMS vel", "RMS tilt", "RMS hdg"
    );
    for (name, e) in [("conventional", &ec), ("rotary", &er)] {
        println!(
            "{name:<14} {:>10.1} m {:>10.1} m {:>6.3} m/s {:>6.4} deg {:>6.4} deg",
            e.h_pos_end_m,
            e.h_pos_rms_m,
            e.h_vel_rms_mps,
            e.roll_rms_deg.hypot(e.pitch_rms_deg),
            e.heading_rms_deg
        );
    }
    println!(
        "rotation cuts the final position error {:.1}x",
        ec.h_pos_end_m / er.h_pos_end_m.max(1e-9)
    );
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    for (name, svg) in
        report::nav_charts(&[("conventional", &rows_conv), ("rotary", &rows_rot)], base)
    {
        write_file(&a.out.join(&name), &svg)?;
    }
    write_file(
        &a.out.join("trajectory_rotary.csv"),
        &nav::trajectory_csv(&rows_rot),
    )?;
    write_file(
        &a.out.join("trajectory_conventional.csv"),
        &nav::trajectory_csv(&rows_conv),
    )?;
    write_file(
        &a.out.join("calibration.json"),
        &serde_json::to_string_pretty(&calibrate::to_json(&cal))?,
    )?;
    for (dir, rec) in [
        ("recording_rotary", &rot),
        ("recording_conventional", &conv),
    ] {
        let d = a.out.join(dir);
        if d.exists() {
            std::fs::remove_dir_all(&d).with_context(|| format!("replacing {}", d.display()))?;
        }
        rec.write(&d).map_err(|e| anyhow!("{e}"))?;
    }
    println!(
        "plots, trajectories, calibration and both recordings in {}",
        a.out.display()
    );
    Ok(())
}

/// `rins record`.
#[derive(clap::Args)]
pub struct RecordArgs {
    /// Serial port of the board's telemetry UART (e.g. /dev/ttyUSB0).
    #[arg(
        long,
        conflicts_with = "from_file",
        required_unless_present = "from_file"
    )]
    pub port: Option<String>,
    /// Baud rate.
    #[arg(long, default_value_t = 921_600)]
    pub baud: u32,
    /// Record this long from the port, s.
    #[arg(long, default_value_t = 600.0)]
    pub duration_s: f64,
    /// Decode a captured byte stream instead of a port.
    #[arg(long)]
    pub from_file: Option<PathBuf>,
    /// Output recording directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Site latitude, deg (the board does not send it).
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
    /// Also write the link statistics as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Runs `rins record`.
pub fn record(a: &RecordArgs) -> Result<()> {
    let meta = hal_sim::recording::Meta {
        description: Some("rins record: board telemetry".into()),
        latitude_deg: a.lat_deg,
        height_m: a.height_m,
        heading_deg: a.heading_deg,
        pitch_deg: a.pitch_deg,
        roll_deg: a.roll_deg,
        imu_model: Some("TDK ICM-42688-P (board)".into()),
        ..hal_sim::recording::Meta::default()
    };
    let bytes: Vec<u8> = if let Some(f) = &a.from_file {
        std::fs::read(f).with_context(|| format!("reading {}", f.display()))?
    } else {
        let port = a
            .port
            .as_deref()
            .ok_or_else(|| anyhow!("--port or --from-file"))?;
        let mut p = serialport::new(port, a.baud)
            .timeout(std::time::Duration::from_millis(200))
            .open()
            .with_context(|| format!("opening {port}"))?;
        let pb = progress_bar("record");
        let start = std::time::Instant::now();
        let mut all = vec![];
        let mut buf = [0u8; 4096];
        while start.elapsed().as_secs_f64() < a.duration_s {
            match p.read(&mut buf) {
                Ok(n) => all.extend_from_slice(&buf[..n]),
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                Err(e) => return Err(e).with_context(|| format!("reading {port}")),
            }
            pb.set_position((start.elapsed().as_secs_f64() / a.duration_s * 1000.0) as u64);
        }
        pb.finish_and_clear();
        all
    };
    let d = rins::record::decode(bytes, meta);
    println!("{}", rins::record::link_report(&d));
    if d.recording.imu.is_empty() {
        bail!("no IMU frame in the stream");
    }
    d.recording.write(&a.out).map_err(|e| anyhow!("{e}"))?;
    println!("wrote {}", a.out.display());
    if let Some(p) = &a.json {
        let s = &d.stats;
        let v = serde_json::json!({"frames": s.frames, "lost": s.lost, "corrupt": s.corrupt, "overflow": s.overflow, "out_of_order": d.out_of_order,
            "imu_samples": d.recording.imu.len(), "encoder_reads": d.recording.table.len(), "faults": d.faults});
        write_file(p, &serde_json::to_string_pretty(&v)?)?;
    }
    Ok(())
}

/// `rins qemu-replay`.
#[derive(clap::Args)]
pub struct QemuReplayArgs {
    /// The recording to replay (from `rins simulate`).
    pub rec: PathBuf,
    /// Output: the binary replay stream for the QEMU build.
    pub out: PathBuf,
    /// Encoder counts per revolution (the board's).
    #[arg(long, default_value_t = 16_384)]
    pub counts_per_rev: u32,
}

/// Runs `rins qemu-replay`: the recording as the board's input stream, run
/// through the board's logic on the host; the host's outcome goes in the
/// trailer for the QEMU build to compare with, bit for bit.
pub fn qemu_replay(a: &QemuReplayArgs) -> Result<()> {
    use firmware::replay::{encode, encode_outcome, outcome, step, Event, Header, HEADER, RECORD};
    let rec = read_recording(&a.rec)?;
    let m = &rec.meta;
    let rate = match rec
        .table
        .windows(2)
        .rev()
        .find(|w| w[1].angle_rad != w[0].angle_rad)
    {
        Some(w) => w[0].rate_to(&w[1]),
        None => bail!("the table never turns: the board's calibration needs rotation"),
    };
    let mut header = Header {
        records: 0,
        lat_deg: m.latitude_deg,
        height_m: m.height_m,
        base_deg: [m.roll_deg, m.pitch_deg, m.heading_deg],
        rate_radps: (rate.to_degrees() * 10.0).round().to_radians() / 10.0,
        counts_per_rev: a.counts_per_rev,
    };
    let cfg = header.config();
    let mut events: Vec<Event> = rec
        .imu
        .iter()
        .map(|r| Event::Imu {
            t_us: (r.t_s * 1e6).round() as u64,
            gyro: r.gyro_radps.map(|x| x as f32),
            accel: r.accel_mps2.map(|x| x as f32),
            temp: r.temp_c.unwrap_or(25.0) as f32,
        })
        .chain(rec.table.iter().map(|r| Event::Encoder {
            t_us: (r.t_s * 1e6).round() as u64,
            hw: EncoderScale::hw_count(
                EncoderScale::new(a.counts_per_rev).count_nearest(r.angle_rad),
            ),
        }))
        .collect();
    // Encoder before IMU at the same time (the board reads it first).
    events.sort_by_key(|e| match e {
        Event::Imu { t_us, .. } => (*t_us, 1),
        Event::Encoder { t_us, .. } => (*t_us, 0),
    });
    let mut app = firmware::app::App::new(cfg).map_err(|e| anyhow!("{e:?}"))?;
    let mut bytes = Vec::with_capacity(HEADER + events.len() * RECORD + 32);
    header.records = events.len() as u32;
    bytes.extend_from_slice(&header.encode());
    for e in &events {
        step(&mut app, e);
        bytes.extend_from_slice(&encode(e));
    }
    let o = outcome(&app);
    bytes.extend_from_slice(&encode_outcome(&o));
    write_file(&a.out, "")?;
    std::fs::write(&a.out, &bytes).with_context(|| format!("writing {}", a.out.display()))?;
    println!(
        "{} events -> {}; host: mode {:?}, p_n {:?} m, v_n {:?} m/s",
        events.len(),
        a.out.display(),
        app.mode,
        o.p_n,
        o.v_n
    );
    if o.mode != 3 {
        bail!("the board's logic did not reach navigation on this recording (mode {:?}, last refusal {:?})", app.mode, app.last_refusal);
    }
    Ok(())
}

/// `rins diagnose`.
#[derive(clap::Args)]
pub struct DiagnoseArgs {
    /// The recording directory.
    pub rec: PathBuf,
    /// The nominal model (TOML: `earth_rate = true|false`, `[known.<effect
    /// id>]` tables of parameters the model already has); default: the
    /// spec's (gravity, earth rate, table motion, bias, scale,
    /// misalignment, white noise).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Write the rins-diagnose/1 JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the plots (SVG) into this directory.
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
}

/// Runs `rins diagnose`.
pub fn diagnose(a: &DiagnoseArgs) -> Result<()> {
    let rec = read_recording(&a.rec)?;
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
    if let Some(dir) = &a.resim {
        d.resimulated(&rec)
            .write(dir)
            .map_err(|e| anyhow!("writing {}: {e}", dir.display()))?;
        println!("wrote {} (the re-simulated run)", dir.display());
    }
    Ok(())
}

/// `rins study`.
#[derive(clap::Args)]
pub struct StudyArgs {
    /// Seeds per cell.
    #[arg(long, default_value_t = 10)]
    pub runs: usize,
    /// Null runs per grade.
    #[arg(long, default_value_t = 100)]
    pub nulls: usize,
    /// Sensor grades (nav440, mtig, adis16405, icm42688).
    #[arg(long, value_delimiter = ',', default_value = "nav440,mtig")]
    pub grades: Vec<String>,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Threads (default: the machine's cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Write the JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the Markdown table here.
    #[arg(long)]
    pub markdown: Option<PathBuf>,
}

/// Runs `rins study`.
pub fn study(a: &StudyArgs) -> Result<()> {
    let pb = progress_bar("study");
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let grades: Vec<&str> = a.grades.iter().map(String::as_str).collect();
    let s = rins::study::run(
        &grades,
        &rins::study::effects(),
        a.runs,
        a.nulls,
        a.seed,
        threads,
        &|f| pb.set_position((f * 1000.0) as u64),
    )
    .map_err(|e| anyhow!(e))?;
    pb.finish_and_clear();
    let md = rins::study::markdown(&s);
    print!("{md}");
    if let Some(p) = &a.json {
        write_file(p, &serde_json::to_string_pretty(&s)?)?;
    }
    if let Some(p) = &a.markdown {
        write_file(p, &md)?;
    }
    Ok(())
}
