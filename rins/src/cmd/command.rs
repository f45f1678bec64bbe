//! `rins command`: one command to a board, answered by its `Ack`.

use anyhow::Result;
use protocol::{Command, SchemeKind};

/// `rins command`.
#[derive(clap::Args)]
pub struct Args {
    /// The board's port (a serial device, or `unix:PATH` for the QEMU build).
    #[arg(long)]
    pub port: String,
    /// Baud rate of a serial --port (default 921600; a socket has none).
    #[arg(long)]
    pub baud: Option<u32>,
    /// Print the answer as JSON.
    #[arg(long)]
    pub json: bool,
    /// The command.
    #[command(subcommand)]
    pub what: What,
}

/// The commands.
#[derive(clap::Subcommand)]
pub enum What {
    /// Start the table (after a stop or a fault).
    Start,
    /// Stop the table (motor off).
    Stop,
    /// Run the power-up calibration again.
    Recalibrate,
    /// The rotation scheme (stored).
    Scheme {
        /// still, continuous, reciprocating, indexed.
        kind: String,
        /// deg/s.
        #[arg(long, default_value_t = 30.0)]
        rate_dps: f32,
        /// Turns (reciprocating) or positions (indexed: 2 or 4).
        #[arg(long, default_value_t = 0)]
        count: u8,
    },
    /// The site (stored): latitude (deg, north positive) and height (m).
    Site {
        /// deg.
        #[arg(long, allow_negative_numbers = true)]
        lat_deg: f64,
        /// m above the ellipsoid.
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        height_m: f64,
    },
    /// The base's attitude (stored), deg.
    Base {
        /// deg.
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        roll_deg: f32,
        /// deg.
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        pitch_deg: f32,
        /// deg.
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        heading_deg: f32,
    },
    /// Aided navigation on or off (stored), the origin at the site and
    /// this longitude.
    Aided {
        /// on or off.
        on: String,
        /// deg, east positive.
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        lon_deg: f64,
    },
}

fn command(w: &What) -> Result<Command> {
    let e7 = |d: f64| (d * 1e7).round() as i32;
    Ok(match w {
        What::Start => Command::Start {},
        What::Stop => Command::Stop {},
        What::Recalibrate => Command::Recalibrate {},
        What::Scheme {
            kind,
            rate_dps,
            count,
        } => Command::SetScheme {
            kind: match kind.as_str() {
                "still" => SchemeKind::Still,
                "continuous" => SchemeKind::Continuous,
                "reciprocating" => SchemeKind::Reciprocating,
                "indexed" => SchemeKind::Indexed,
                k => anyhow::bail!("scheme {k:?}: still, continuous, reciprocating or indexed"),
            },
            rate_dps: *rate_dps,
            count: *count,
        },
        What::Site { lat_deg, height_m } => Command::SetSite {
            lat_e7: e7(*lat_deg),
            height_mm: (height_m * 1e3).round() as i32,
        },
        What::Base {
            roll_deg,
            pitch_deg,
            heading_deg,
        } => Command::SetBase {
            roll_deg: *roll_deg,
            pitch_deg: *pitch_deg,
            heading_deg: *heading_deg,
        },
        What::Aided { on, lon_deg } => Command::SetAided {
            on: match on.as_str() {
                "on" => 1,
                "off" => 0,
                o => anyhow::bail!("aided {o:?}: on or off"),
            },
            lon_e7: e7(*lon_deg),
        },
    })
}

/// Runs `rins command`.
pub fn run(a: &Args) -> Result<()> {
    let c = command(&a.what)?;
    if let Err(s) = c.check() {
        anyhow::bail!("the board would refuse {c:?}: {s:?}");
    }
    let mut s = rins::link::Session::new(rins::link::open(
        &a.port,
        a.baud,
        rins::link::BOARD_BAUD,
        "--baud",
    )?);
    s.wait_for_board(std::time::Duration::from_secs(30), &mut |_| {})?;
    let status = s.command(&c, &mut |_| {})?;
    if a.json {
        println!(
            "{}",
            serde_json::json!({"command": format!("{c:?}"), "status": format!("{status:?}"), "code": status.code()})
        );
    } else {
        println!("{c:?}: {status:?}");
    }
    if status != protocol::Status::Accepted {
        anyhow::bail!("refused: {status:?}");
    }
    Ok(())
}
