//! `rins record`: the board's telemetry (a serial port or a captured file)
//! decoded into a recording, with the link's losses counted and the
//! board's calibration frames kept (`calibration.json` in the recording).

use super::{write_file, SiteArgs};
use anyhow::{anyhow, bail, Context, Result};
use rins::progress_bar;
use std::path::PathBuf;

/// `rins record`.
#[derive(clap::Args)]
pub struct Args {
    /// Serial port of the board's telemetry UART (e.g. /dev/ttyUSB0).
    #[arg(
        long,
        conflicts_with = "from_file",
        required_unless_present = "from_file"
    )]
    pub port: Option<String>,
    /// Baud rate of a serial --port (default 921600; a socket has none).
    #[arg(long, conflicts_with = "from_file")]
    pub baud: Option<u32>,
    /// Record this long from the port, s.
    #[arg(long, default_value_t = 600.0, conflicts_with = "from_file")]
    pub duration_s: f64,
    /// Decode a captured byte stream instead of a port.
    #[arg(long)]
    pub from_file: Option<PathBuf>,
    /// Output recording directory.
    #[arg(long)]
    pub out: PathBuf,
    /// Site and base (the board does not send them).
    #[command(flatten)]
    pub site: SiteArgs,
    /// Also write the link statistics as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Configure the board first for this recording's site, base, scheme
    /// and aided mode (the commands `rins command` sends; each acknowledged).
    #[arg(long, conflicts_with = "from_file")]
    pub like: Option<PathBuf>,
    /// Relay GNSS fixes to the board, each with its time of validity on
    /// the board's clock. FILE: a recording-v1 `gnss.csv` (with `--like`,
    /// its times are the recording's and the board's first IMU frame is the
    /// recording's first sample; without, they are the board's). PORT (any
    /// other value: a serial device, or `unix:PATH`): a live u-blox
    /// receiver's UBX-NAV-PVT, its UTC epoch put on the board's clock
    /// through the host's UTC clock (keep it synchronised: NTP).
    #[arg(long, conflicts_with = "from_file", value_name = "FILE|PORT")]
    pub gnss: Option<String>,
    /// The live receiver's baud rate (`--gnss PORT` on a serial device,
    /// default 38400; a USB receiver ignores it).
    #[arg(long, requires = "gnss", conflicts_with = "from_file")]
    pub gnss_baud: Option<u32>,
    /// Send each fix of a `--gnss FILE` this long after its time of
    /// validity (a receiver's latency), ms (default 150; a live receiver
    /// has its own).
    #[arg(long, requires = "gnss", conflicts_with = "from_file")]
    pub latency_ms: Option<f64>,
}

/// Runs `rins record`.
pub fn run(a: &Args) -> Result<()> {
    let meta = recording::Meta {
        description: Some("rins record: board telemetry".into()),
        latitude_deg: a.site.lat_deg,
        height_m: a.site.height_m,
        heading_deg: a.site.heading_deg,
        pitch_deg: a.site.pitch_deg,
        roll_deg: a.site.roll_deg,
        heading_sigma_deg: None,
        level_sigma_deg: None,
        imu_model: Some("TDK ICM-42688-P (board)".into()),
        ..recording::Meta::default()
    };
    let bytes: Vec<u8> = if let Some(f) = &a.from_file {
        std::fs::read(f).with_context(|| format!("reading {}", f.display()))?
    } else {
        let port = a
            .port
            .as_deref()
            .ok_or_else(|| anyhow!("--port or --from-file"))?;
        record_port(a, port)?
    };
    let d = rins::record::decode(bytes, meta);
    println!("{}", rins::record::link_report(&d));
    if d.recording.imu.is_empty() {
        bail!("no IMU frame in the stream");
    }
    d.recording.write(&a.out).map_err(|e| anyhow!("{e}"))?;
    println!("wrote {}", a.out.display());
    match rins::record::calibration_json(&d, d.recording.meta.axis) {
        Some(c) => {
            let p = a.out.join("calibration.json");
            write_file(&p, &serde_json::to_string_pretty(&c)?)?;
            println!(
                "wrote {} ({} calibration frames{})",
                p.display(),
                d.calibrations.len(),
                if d.calibration_changes.is_empty() {
                    ""
                } else {
                    ", with the change from the stored record"
                }
            );
        }
        None => println!("no calibration frame in the stream"),
    }
    if let Some(p) = &a.json {
        write_file(
            p,
            &serde_json::to_string_pretty(&rins::record::link_json(&d))?,
        )?;
    }
    Ok(())
}

/// Records from a port: configures the board (`--like`), relays fixes
/// (`--gnss`), until `--duration-s` or the port closes.
fn record_port(a: &Args, port: &str) -> Result<Vec<u8>> {
    let mut s = rins::link::Session::new(rins::link::open(
        port,
        a.baud,
        rins::link::BOARD_BAUD,
        "--baud",
    )?);
    let like = a
        .like
        .as_ref()
        .map(|p| super::read_recording(p))
        .transpose()?;
    let mut relay = match &a.gnss {
        Some(g) if std::path::Path::new(g).is_file() => {
            if let Some(b) = a.gnss_baud {
                bail!("--gnss-baud {b} with --gnss {g}: a file has no baud rate");
            }
            let p = std::path::Path::new(g);
            let text =
                std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            let rows = recording::moving::parse_gnss(&text, p).map_err(|e| anyhow!("{e}"))?;
            let t0 = like
                .as_ref()
                .and_then(|r| r.imu.first())
                .map(|r| (r.t_s * 1e6).round() as i64);
            Relay::File(rins::link::Relay::new(
                rows,
                t0,
                (a.latency_ms.unwrap_or(150.0) * 1e3) as u64,
            ))
        }
        Some(port) => {
            if let Some(l) = a.latency_ms {
                bail!("--latency-ms {l} with the live receiver {port}: its fixes are relayed as they arrive (--latency-ms delays a --gnss FILE's)");
            }
            Relay::Live(rins::link::LiveRelay::spawn(rins::link::open(
                port,
                a.gnss_baud,
                38_400,
                "--gnss-baud",
            )?))
        }
        None => Relay::None,
    };
    let mut frames: Vec<protocol::Telemetry> = vec![];
    if let Some(rec) = &like {
        let rate = rec
            .table
            .windows(2)
            .rev()
            .find(|w| w[1].angle_rad != w[0].angle_rad)
            .map_or(30f64.to_radians(), |w| w[0].rate_to(&w[1]));
        let rate = (rate.to_degrees() * 10.0).round().to_radians() / 10.0;
        s.wait_for_board(std::time::Duration::from_secs(30), &mut |t| frames.push(*t))?;
        for c in rins::link::config_commands(rec, rate) {
            let st = s.command(&c, &mut |t| frames.push(*t))?;
            if st != protocol::Status::Accepted {
                bail!("the board refused {c:?}: {st:?}");
            }
        }
        println!(
            "configured the board like {}",
            a.like
                .as_ref()
                .map_or(String::new(), |p| p.display().to_string())
        );
    }
    // The board's first frames may have come while it was configured (a
    // configuration is acknowledged once stored): the relay takes the
    // board's clock from the first of them.
    for t in &frames {
        for c in relay.due(t) {
            s.send(&c)?;
        }
    }
    let pb = progress_bar("record");
    let start = std::time::Instant::now();
    while start.elapsed().as_secs_f64() < a.duration_s && !s.closed {
        for t in s.pump()? {
            for c in relay.due(&t) {
                s.send(&c)?;
            }
        }
        pb.set_position((start.elapsed().as_secs_f64() / a.duration_s * 1000.0) as u64);
    }
    pb.finish_and_clear();
    relay.report();
    Ok(std::mem::take(&mut s.bytes))
}

/// Where the fixes relayed to the board come from.
enum Relay {
    None,
    File(rins::link::Relay),
    Live(rins::link::LiveRelay),
}

impl Relay {
    fn due(&mut self, t: &protocol::Telemetry) -> Vec<protocol::Command> {
        match self {
            Self::None => vec![],
            Self::File(r) => r.due(t),
            Self::Live(r) => r.due(t),
        }
    }

    fn report(&self) {
        match self {
            Self::None => {}
            Self::File(r) => println!("relayed {} GNSS fixes ({} not sent)", r.sent, r.left()),
            Self::Live(r) => {
                let bad = r.bad_frames.load(std::sync::atomic::Ordering::Relaxed);
                println!(
                    "relayed {} GNSS fixes from the receiver; not relayed: {:?}; {bad} receiver frames with a bad checksum",
                    r.sent, r.skipped
                );
                if r.skipped
                    .iter()
                    .any(|(w, _)| *w == rins::link::Skip::ClockMismatch)
                {
                    println!("  (the receiver's epochs and this host's UTC clock disagree by more than 2 s: synchronise the host's clock, NTP)");
                }
            }
        }
    }
}
