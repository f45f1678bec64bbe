//! `rins simulate`.

use super::{parse_effect, AxisArg, SchemeArg, SiteArgs};
use rins::progress_bar;

use anyhow::{anyhow, bail, Context, Result};
use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig, EFFECTS};
use hal_sim::world::Site;
use std::path::PathBuf;

/// Flags of `rins simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Error-free, noise-free IMU and a perfect table (exact profile, exact
    /// encoder angles, no quantisation or latency).
    #[arg(long)]
    pub ideal: bool,
    /// The sensor: a shipped profile's name (ideal, mtig, nav440,
    /// adis16405, icm42688, icm42605) or a sensor file (`rins-sensor/2`).
    /// Not with --ideal (which is a sensor of its own).
    #[arg(
        long = "sensor",
        alias = "imu",
        default_value = "icm42688",
        conflicts_with = "ideal"
    )]
    pub sensor: String,
    /// Rotation scheme after the static phase.
    #[arg(long, value_enum, default_value = "continuous")]
    pub scheme: SchemeArg,
    /// Table axis (the sensor axis it nominally coincides with).
    #[arg(long, value_enum, default_value = "z")]
    pub axis: AxisArg,
    /// Table rate, deg/s (the cruise rate of moves for reciprocating /
    /// indexed; default 30; a still table has none); multirate takes
    /// 1-4 signed rates in turn: --rate-dps 30,60,90,-90.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub rate_dps: Vec<f64>,
    /// Run length, s.
    #[arg(long, default_value_t = 120.0)]
    pub duration_s: f64,
    /// Still phase before the scheme starts (calibration's static part), s.
    #[arg(long, default_value_t = 0.0)]
    pub static_s: f64,
    /// Site and base.
    #[command(flatten)]
    pub site: SiteArgs,
    /// Gravity at the site, m/s^2 (default: WGS-84 normal gravity).
    #[arg(long)]
    pub gravity_mps2: Option<f64>,
    /// Whole turns each way (reciprocating; default 1), at each rate
    /// (multirate; default 4).
    #[arg(long)]
    pub turns: Option<u32>,
    /// Positions (indexed only): 2 or 4 (default 4).
    #[arg(long)]
    pub positions: Option<u8>,
    /// Dwell at each position (indexed) or after each rate (multirate),
    /// s (default 10).
    #[arg(long)]
    pub dwell_s: Option<f64>,
    /// A physical effect, NAME=VALUE (repeatable); `--list-effects` shows them.
    #[arg(long = "effect", value_name = "NAME=VALUE")]
    pub effects: Vec<String>,
    /// Seed: the same seed gives bit-identical output.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// List the effects and exit (alone: it makes no recording).
    #[arg(long, exclusive = true)]
    pub list_effects: bool,
    /// Put the table on a vehicle: a seeded `city` or `highway` drive
    /// (starts, stops, turns, hills) with a 1 Hz GNSS receiver; the
    /// recording adds `gnss.csv` and `truth.csv` (recording-v1, "Moving base
    /// and GNSS"). `--heading-deg` is the vehicle's heading at the start.
    #[arg(long, value_name = "KIND")]
    pub drive: Option<String>,
    /// A GNSS outage, START:LEN in seconds (repeatable).
    #[arg(long = "gnss-outage", value_name = "START:LEN", requires = "drive")]
    pub gnss_outages: Vec<String>,
    /// Longitude of the start, deg (moving base).
    #[arg(long, default_value_t = 114.35, requires = "drive")]
    pub lon_deg: f64,
    /// The receiver's fix rate, Hz (1-20).
    #[arg(long, default_value_t = 1.0, requires = "drive")]
    pub gnss_rate_hz: f64,
    /// The receiver's position 1-sigma per axis, horizontal and vertical,
    /// m (H,V; half white, half a 60 s random drift; 0.02,0.04 for RTK).
    #[arg(
        long,
        value_name = "H,V",
        value_delimiter = ',',
        default_values_t = [1.5, 3.0],
        requires = "drive"
    )]
    pub gnss_sigma_m: Vec<f64>,
    /// The fixes stamped this early on the IMU's clock, s (a logger that
    /// stamps the IMU late; `navigate --estimate-time-offset` finds it).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_hyphen_values = true,
        requires = "drive"
    )]
    pub gnss_early_s: f64,
    /// The IMU's base mounted in the vehicle: roll, pitch, yaw, deg (ZYX;
    /// the recording's b is then not the vehicle: `navigate --vehicle
    /// car` finds it).
    #[arg(
        long,
        value_name = "R,P,Y",
        value_delimiter = ',',
        allow_hyphen_values = true,
        requires = "drive"
    )]
    pub mounting_deg: Vec<f64>,
    /// The IMU's distance ahead of the car's rear axle, m (the axle's
    /// centre follows the road and slides out of turns by its tyres' slip;
    /// in a turn the IMU moves sideways at the yaw rate times this more,
    /// as on a real car; 0: at the axle).
    #[arg(long, default_value_t = 0.0, requires = "drive")]
    pub imu_ahead_m: f64,
    /// Re-simulate this recording's own run (its sample times, encoder
    /// reads, temperatures, site and base) with the sensor of `--sim-model`:
    /// its twin. The scheme, site, sensor and drive flags are refused with
    /// it (the recording gives them); --seed and --out apply.
    #[arg(long, value_name = "REC", requires = "sim_model", conflicts_with_all = [
        "ideal", "effects", "list_effects", "sensor", "scheme", "axis", "rate_dps",
        "duration_s", "static_s", "lat_deg", "height_m", "heading_deg", "pitch_deg",
        "roll_deg", "gravity_mps2", "turns", "positions", "dwell_s", "drive",
        "gnss_outages", "lon_deg", "mounting_deg", "imu_ahead_m", "gnss_rate_hz",
        "gnss_sigma_m", "gnss_early_s",
    ])]
    pub like: Option<PathBuf>,
    /// The sensor model for `--like` (`rins-sim-model/1` TOML, as `rins
    /// diagnose --sim-model` writes it).
    #[arg(long, value_name = "M.toml", requires = "like")]
    pub sim_model: Option<PathBuf>,
    /// Output directory (must not hold a recording yet).
    #[arg(long, required_unless_present = "list_effects")]
    pub out: Option<PathBuf>,
}

/// The sensor `name` names, refused when it does not know its noise (a
/// simulation without noise is not that sensor); its other unknown terms
/// are simulated as absent, and said.
fn sensor_to_simulate(name: &str) -> Result<ImuSpec> {
    let imu = hal_sim::sensor::resolve(name)?;
    imu.require(&hal_sim::sensor::terms::NOISE, "rins simulate")?;
    if !imu.unknown.is_empty() {
        println!(
            "sensor {name}: unknown in its file, simulated as absent: {}",
            imu.unknown.join(", ")
        );
    }
    Ok(imu)
}

impl Args {
    /// The rotation scheme; a scheme's option given to another scheme is
    /// refused, not ignored.
    fn rotation(&self) -> Result<Scheme> {
        use core_nav::scheme::MAX_RATES;
        let multirate = matches!(self.scheme, SchemeArg::Multirate);
        let (reciprocating, indexed) = (
            matches!(self.scheme, SchemeArg::Reciprocating),
            matches!(self.scheme, SchemeArg::Indexed),
        );
        if !self.rate_dps.is_empty() && matches!(self.scheme, SchemeArg::Still) {
            bail!("--rate-dps does not apply to --scheme still: the table does not turn");
        }
        match (multirate, self.rate_dps.len()) {
            (true, n) if !(1..=MAX_RATES).contains(&n) => bail!(
                "--scheme multirate takes 1 to {MAX_RATES} rates (--rate-dps 30,60,90); {n} given"
            ),
            (false, n) if n > 1 => bail!(
                "--scheme {} takes one --rate-dps; several are for --scheme multirate",
                self.scheme.name()
            ),
            _ => {}
        }
        let rate = self.rate_dps.first().copied().unwrap_or(30.0).to_radians();
        for (given, name, applies, what) in [
            (
                self.turns.is_some(),
                "--turns",
                reciprocating || multirate,
                "reciprocating and multirate",
            ),
            (self.positions.is_some(), "--positions", indexed, "indexed"),
            (
                self.dwell_s.is_some(),
                "--dwell-s",
                indexed || multirate,
                "indexed and multirate",
            ),
        ] {
            if given && !applies {
                bail!(
                    "{name} does not apply to --scheme {}: it is for {what}",
                    self.scheme.name()
                );
            }
        }
        Ok(match self.scheme {
            SchemeArg::Still => Scheme::Still,
            SchemeArg::Continuous => Scheme::Continuous { rate },
            SchemeArg::Reciprocating => Scheme::Reciprocating {
                rate: rate.abs(),
                turns: self.turns.unwrap_or(1),
            },
            SchemeArg::Indexed => Scheme::Indexed {
                rate: rate.abs(),
                positions: self.positions.unwrap_or(4),
                dwell_s: self.dwell_s.unwrap_or(10.0),
            },
            SchemeArg::Multirate => {
                let mut rates = [0.0; MAX_RATES];
                for (r, d) in rates.iter_mut().zip(&self.rate_dps) {
                    *r = d.to_radians();
                }
                Scheme::Rates {
                    rates,
                    count: self.rate_dps.len() as u8,
                    turns: self.turns.unwrap_or(4),
                    dwell_s: self.dwell_s.unwrap_or(10.0),
                }
            }
        })
    }

    /// The receiver these flags describe (its outages aside).
    fn receiver(&self) -> Result<hal_sim::drive::GnssSpec> {
        if !(1.0..=20.0).contains(&self.gnss_rate_hz) {
            bail!(
                "--gnss-rate-hz {}: a receiver fixes at 1-20 Hz",
                self.gnss_rate_hz
            );
        }
        let [h, v] = self.gnss_sigma_m[..] else {
            bail!(
                "--gnss-sigma-m takes H,V: two values, not {}",
                self.gnss_sigma_m.len()
            );
        };
        if !(h > 0.0 && v > 0.0 && h <= 100.0 && v <= 100.0) {
            bail!("--gnss-sigma-m {h},{v}: each in (0, 100] m");
        }
        if !(self.gnss_early_s.is_finite() && self.gnss_early_s.abs() <= 5.0) {
            bail!("--gnss-early-s {}: within 5 s", self.gnss_early_s);
        }
        Ok(hal_sim::drive::GnssSpec {
            rate_hz: self.gnss_rate_hz,
            sigma_h_m: h,
            sigma_v_m: v,
            stamp_early_s: self.gnss_early_s,
            ..hal_sim::drive::GnssSpec::default()
        })
    }

    /// The simulation these flags describe.
    pub fn config(&self) -> Result<SimConfig> {
        let axis = match self.axis {
            AxisArg::X => Axis::X,
            AxisArg::Y => Axis::Y,
            AxisArg::Z => Axis::Z,
        };
        let imu = if self.ideal {
            ImuSpec::ideal()
        } else {
            sensor_to_simulate(&self.sensor)?
        };
        let scheme = self.rotation()?;
        if !(-90.0..=90.0).contains(&self.site.lat_deg) {
            return Err(anyhow!(
                "--lat-deg {} is outside [-90, 90]",
                self.site.lat_deg
            ));
        }
        let mut c = SimConfig::new(imu, axis, self.duration_s);
        c.ideal = self.ideal;
        c.scheme = scheme;
        c.static_s = self.static_s;
        c.site = Site::new(self.site.lat_deg, self.site.height_m);
        if let Some(g) = self.gravity_mps2 {
            if !(9.0..=10.5).contains(&g) {
                return Err(anyhow!("--gravity-mps2 {g} is not an earthly gravity"));
            }
            c.site.gravity_mps2 = g;
        }
        c.base_deg = self.site.base_deg();
        c.seed = self.seed;
        if let Some(kind) = &self.drive {
            let kind = hal_sim::drive::DriveKind::parse(kind)
                .ok_or_else(|| anyhow!("--drive {kind:?}: expected city or highway"))?;
            let mut gnss = self.receiver()?;
            for o in &self.gnss_outages {
                let (start, len) = hal_sim::drive::parse_outage(o).map_err(|e| anyhow!(e))?;
                if start + len > self.duration_s {
                    return Err(anyhow!(
                        "--gnss-outage {o} ends at {} s, past the run's end: --duration-s is {} s",
                        start + len,
                        self.duration_s
                    ));
                }
                gnss.outages.push((start, len));
            }
            if self.site.pitch_deg != 0.0 || self.site.roll_deg != 0.0 {
                return Err(anyhow!(
                    "--pitch-deg / --roll-deg do not apply to a drive: the road sets them"
                ));
            }
            if !self.imu_ahead_m.is_finite() || self.imu_ahead_m.abs() > 10.0 {
                return Err(anyhow!(
                    "--imu-ahead-m {}: a car's IMU is within 10 m of its rear axle",
                    self.imu_ahead_m
                ));
            }
            c.drive = Some(hal_sim::sim::DriveSpec {
                kind,
                gnss,
                longitude_deg: self.lon_deg,
                imu_ahead_m: self.imu_ahead_m,
                mounting_deg: match self.mounting_deg.as_slice() {
                    [] => [0.0; 3],
                    [r, p, y] => [*r, *p, *y],
                    m => {
                        return Err(anyhow!(
                            "--mounting-deg takes R,P,Y: three values, not {}",
                            m.len()
                        ))
                    }
                },
            });
        }
        for e in &self.effects {
            let (name, v) = parse_effect(e)?;
            c.set_effect(&name, v).map_err(|m| anyhow!(m))?;
        }
        Ok(c)
    }
}

/// Runs `rins simulate`.
pub fn run(a: &Args) -> Result<()> {
    if a.list_effects {
        println!("{:<26} {:<18} what", "effect", "unit");
        for e in EFFECTS {
            println!("{:<26} {:<18} {}", e.name, e.unit, e.help);
        }
        return Ok(());
    }
    let out = a
        .out
        .as_ref()
        .ok_or_else(|| anyhow!("--out DIR is required"))?;
    if out.join("meta.toml").exists() {
        bail!(
            "{} holds a recording already (a recording is never rewritten in place): give another --out",
            out.display()
        );
    }
    if let (Some(like), Some(mp)) = (&a.like, &a.sim_model) {
        let rec = super::read_recording(like)?;
        let text =
            std::fs::read_to_string(mp).with_context(|| format!("reading {}", mp.display()))?;
        let model = hal_sim::twin::SimModel::from_toml(&text)
            .map_err(|e| anyhow!("{}: {e}", mp.display()))?;
        let twin = hal_sim::twin::simulate_like(&rec, &model, a.seed)
            .map_err(|e| anyhow!("{}: {e}", like.display()))?;
        twin.write(out)
            .with_context(|| format!("writing {}", out.display()))?;
        println!(
            "wrote {}: the twin of {} ({} IMU samples, {} encoder reads, seed {})",
            out.display(),
            like.display(),
            twin.imu.len(),
            twin.table.len(),
            a.seed
        );
        return Ok(());
    }
    let cfg = a.config()?;
    let pb = progress_bar("simulate");
    let rec =
        simulate(&cfg, &mut |f| pb.set_position((f * 1000.0) as u64)).map_err(|m| anyhow!(m))?;
    pb.finish_and_clear();
    rec.write(out)
        .with_context(|| format!("writing {}", out.display()))?;
    println!(
        "wrote {}: {} IMU samples, {} encoder reads, {:.1} s",
        out.display(),
        rec.imu.len(),
        rec.table.len(),
        a.duration_s
    );
    Ok(())
}
