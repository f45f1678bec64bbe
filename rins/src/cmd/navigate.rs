//! `rins navigate`: strapdown navigation of a recording (trajectory-v1),
//! its errors against a static base, plots.

use super::{read_recording, write_file};
use anyhow::{bail, Context, Result};
use core_nav::calib::GyroCalibration;
use rins::calibrate;
use rins::nav::{self, NavOptions};
use rins::progress_bar;
use rins::report;
use std::path::{Path, PathBuf};

/// `rins navigate`.
#[derive(clap::Args)]
pub struct Args {
    /// The recording directory.
    pub rec: PathBuf,
    /// Use readings the sensor cannot have given (beyond its full scale,
    /// lone spikes, stuck runs) as they are, instead of excluding them.
    #[arg(long)]
    pub keep_implausible: bool,
    /// Gyro calibration (rins-calibration/1, from `rins calibrate --json`).
    /// Not with --gnss: the aided filter estimates the gyro errors itself.
    #[arg(long, conflicts_with = "gnss")]
    pub calibration: Option<PathBuf>,
    /// Output directory: trajectory.csv and plots.
    #[arg(long)]
    pub out: PathBuf,
    /// Start navigating at this time, s (default: the first sample). With
    /// --gnss the filter starts at rest there: a moment the vehicle stands.
    #[arg(long, default_value_t = 0.0)]
    pub start_s: f64,
    /// Stop at this time, s.
    #[arg(long)]
    pub end_s: Option<f64>,
    /// Navigate in f32, as the MCU does.
    #[arg(long)]
    pub f32: bool,
    /// Hold the height (long static runs: the vertical channel diverges).
    /// Not with --gnss: the fixes' heights hold it.
    #[arg(long, conflicts_with = "gnss")]
    pub hold_height: bool,
    /// Start from the base attitude in meta.toml instead of aligning on
    /// the still start (levelling; gyrocompassing where the gyros resolve
    /// the earth's rate). Without it, each of level and heading comes from
    /// meta.toml where its stated sigma is the smaller.
    #[arg(long, conflicts_with = "gnss")]
    pub attitude_from_meta: bool,
    /// Also write the summary as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Aid with the recording's GNSS fixes (`gnss.csv`) and zero-velocity
    /// updates: the error-state Kalman filter; trajectory.csv gets the
    /// filter's 1-sigma columns.
    #[arg(long)]
    pub gnss: bool,
    /// No zero-velocity updates (with --gnss).
    #[arg(long, requires = "gnss")]
    pub no_zupt: bool,
    /// Learn the ride's process noise from the fixes (with --gnss): a copy
    /// of the filter run 10 s without fixes, its error against the next
    /// fix; every noise term scaled up where it runs outside its sigma,
    /// never below the sensor file's
    #[arg(long, requires = "gnss")]
    pub learn_noise: bool,
    /// The height's process noise (with --gnss): `learn` adds the ride's
    /// vertical velocity random walk that 10-s shadows of the filter show
    /// against the fixes in a first pass, where significant; `file` keeps
    /// the sensor file's alone
    #[arg(long, value_parser = ["learn", "file"], default_value = "learn")]
    pub vertical_noise: String,
    /// The sensor profile the filter's noise model comes from (default:
    /// the one named by the recording's `[imu] model`).
    /// A shipped profile's name or a sensor file (`rins-sensor/2`): its
    /// noise, and with --gnss its antenna lever arm (over meta.toml's).
    /// Its mounting is not applied again: `rins import` wrote the samples
    /// in the base frame. Without --gnss: the alignment's sigmas.
    #[arg(long = "sensor", alias = "imu-profile")]
    pub sensor: Option<String>,
    /// Cut a GNSS outage into the run, START:LENGTH in s (repeatable): the
    /// fixes inside are withheld from the filter and kept as the
    /// reference its errors are measured against.
    #[arg(long = "gnss-outage", value_name = "START:LEN", requires = "gnss")]
    pub gnss_outages: Vec<String>,
    /// The least horizontal 1-sigma a fix is taken with by solution type
    /// (gnss.csv's quality column), m: RTK fixed, RTK float, DGNSS,
    /// single point (vertical: twice it).
    #[arg(
        long,
        value_name = "FIXED,FLOAT,DGNSS,SINGLE",
        value_delimiter = ',',
        requires = "gnss"
    )]
    pub gnss_floor_m: Option<Vec<f64>>,
    /// The innovation gate, sigmas (a fix component farther off is
    /// rejected and counted).
    #[arg(long, default_value_t = rins::aided::GATE_SIGMA, requires = "gnss")]
    pub gate_sigma: f64,
    /// Use only the fixes' positions (not their velocity).
    #[arg(long, requires = "gnss")]
    pub gnss_position_only: bool,
    /// How late the IMU's clock runs behind the receiver's, s (known in
    /// advance): a fix at the receiver's t is taken at the IMU's t + this.
    /// Default 0; given, a run whose fixes point at the clocks says so
    /// but keeps it
    #[arg(long, allow_negative_numbers = true, requires = "gnss")]
    pub time_offset_s: Option<f64>,
    /// Estimate the IMU-to-GNSS time offset (a pre-pass over +-0.5 s,
    /// around --time-offset-s) and navigate with it. With
    /// --estimate-lever-arm: the two estimated together, each sigma
    /// including what the other absorbs
    #[arg(long, requires = "gnss")]
    pub estimate_time_offset: bool,
    /// Estimate the antenna's lever arm in b (a pre-pass along each axis,
    /// within 3 m of the sensor file's or meta.toml's) and navigate with
    /// it; an axis the motion does not turn about is kept as given.
    /// Refused when the fixes fit no arm (their NIS per dof above 1.5 at
    /// the best: a lost run), unless with --estimate-time-offset
    #[arg(long, requires = "gnss")]
    pub estimate_lever_arm: bool,
    /// Navigate with the given antenna arm and clock even when the fixes
    /// refute them. Without it, a run whose fixes sit farther off than
    /// their sigmas allow, its clocks cleared, and whose arm the fixes put
    /// more than 3 sigma from the given one navigates again with theirs;
    /// one whose fixes point at its clocks, with the clock and arm found
    /// together (said). Not with --estimate-time-offset (its runs look no
    /// further)
    #[arg(
        long,
        requires = "gnss",
        conflicts_with_all = ["estimate_lever_arm", "estimate_time_offset"]
    )]
    pub keep_given_arm: bool,
    /// The base is a land vehicle (`car`): it does not slide sideways
    /// (beyond its tyres' slip in turns) or leave the road, and the
    /// recording's odometer.csv (if any) is its speed. Its forward axis in
    /// b, the IMU's distance ahead of its rear axle, that axle's slip and
    /// the odometer's scale are estimated from the first straight driving
    /// with fixes on.
    #[arg(long, value_name = "KIND", value_parser = ["car"], requires = "gnss")]
    pub vehicle: Option<String>,
}

/// `--start-s`, `--end-s` and the outages inside the recording's span,
/// the end after the start.
fn check_span(a: &Args, rec: &recording::Recording) -> Result<()> {
    let (Some(first), Some(last)) = (rec.imu.first(), rec.imu.last()) else {
        bail!("{}: imu.csv has no samples", a.rec.display());
    };
    let (t0, t1) = (first.t_s, last.t_s);
    if a.start_s >= t1 {
        bail!(
            "--start-s {} is at or after the recording's last sample ({t1} s)",
            a.start_s
        );
    }
    if let Some(end) = a.end_s {
        if end <= a.start_s.max(t0) {
            bail!(
                "--end-s {end} is not after the start ({} s: --start-s or the first sample)",
                a.start_s.max(t0)
            );
        }
    }
    if !a.gnss && a.vertical_noise != "learn" {
        bail!("--vertical-noise needs --gnss (an unaided run has no filter to add it to)");
    }
    for o in &a.gnss_outages {
        let (start, len) = hal_sim::drive::parse_outage(o).map_err(|e| anyhow::anyhow!(e))?;
        let last = a.end_s.map_or(t1, |e| e.min(t1));
        if start + len > last {
            bail!(
                "--gnss-outage {o} ends at {} s, past the run's last sample ({last} s: --end-s or the recording's)",
                start + len
            );
        }
        if start < a.start_s {
            bail!("--gnss-outage {o} starts before --start-s {}", a.start_s);
        }
    }
    Ok(())
}

/// The still start's alignment, with the sensor profile for its sigmas
/// when one is known (`--sensor`, or the recording's `[imu] model`);
/// `None`, and the reason said, when the start cannot be aligned on
/// (navigation then starts from meta.toml's attitude, as the trajectory
/// format says).
fn align_or_say(rec: &recording::Recording, a: &Args) -> Option<rins::align::StaticAlignment> {
    let profile = rins::aided::any_profile(rec, a.sensor.as_deref()).ok();
    match rins::align::align(rec, a.start_s, profile.as_ref()) {
        Ok(al) => Some(al),
        Err(e) => {
            println!("no alignment ({e}): start attitude from meta.toml");
            None
        }
    }
}

/// The alignment in words, beside meta.toml's attitude.
fn alignment_text(al: &rins::align::StaticAlignment, meta_rph: [f64; 3]) -> String {
    let sig = |s: f64| {
        if s.is_finite() {
            format!("+- {s:.3}")
        } else {
            "+- unknown (the sensor's bias or noise is not known: --sensor)".into()
        }
    };
    let [r, p, h] = al.euler_deg;
    let [sr, sp, sh] = al.sigma_deg;
    let mut o = format!(
        "alignment over {:.0}-{:.0} s ({}): roll {r:.3} {} deg, pitch {p:.3} {} deg, heading {h:.2} {}\n",
        al.window_s[0],
        al.window_s[1],
        match (al.turns, al.swing_deg) {
            (t, _) if t >= 1.0 => format!("{t:.0} whole table turns"),
            // Under an encoder count of a common table's: still.
            (_, s) if s < 0.1 => "the table still".into(),
            (_, s) => format!("the table swinging over {s:.0} deg, under a whole turn"),
        },
        sig(sr),
        sig(sp),
        if al.gyrocompassed {
            format!("{} deg (gyrocompass)", sig(sh))
        } else {
            "deg (meta.toml's)".into()
        },
    );
    if let Some(n) = &al.heading_note {
        o += &format!("  {n}\n");
    }
    let d = |a: f64, b: f64| (a - b + 540.0).rem_euclid(360.0) - 180.0;
    o += &format!(
        "  against meta.toml's attitude: roll {:+.3}, pitch {:+.3}, heading {:+.2} deg\n",
        d(r, meta_rph[0]),
        d(p, meta_rph[1]),
        d(h, meta_rph[2])
    );
    o
}

fn load_calibration(p: &Path) -> Result<GyroCalibration> {
    let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", p.display()))?;
    calibrate::from_json(&v).with_context(|| format!("{}", p.display()))
}

/// Runs `rins navigate`.
pub fn run(a: &Args) -> Result<()> {
    let rec = super::plausible(
        read_recording(&a.rec)?,
        a.sensor.as_deref(),
        a.keep_implausible,
    );
    rec.require_accel("rins navigate")
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    check_span(a, &rec)?;
    if a.gnss {
        return run_aided(a, &rec);
    }
    if rec.moving.is_some() {
        bail!(
            "{} is a moving-base recording (meta.toml [base] moving = true): errors against a static base mean nothing there; navigate it with --gnss",
            a.rec.display()
        );
    }
    let calibration = a
        .calibration
        .as_ref()
        .map(|p| load_calibration(p))
        .transpose()?;
    if let Some(c) = &calibration {
        if c.axis != rec.meta.axis {
            bail!(
                "the calibration is for table axis {:?}, the recording turns about {:?}",
                c.axis,
                rec.meta.axis
            );
        }
    }
    let aligned = match a.attitude_from_meta {
        true => None,
        false => align_or_say(&rec, a),
    };
    let m = &rec.meta;
    let meta_rph = [m.roll_deg, m.pitch_deg, m.heading_deg];
    let picked = aligned.as_ref().map(|al| rins::align::pick(al, m));
    let start_rph = picked.as_ref().map_or(meta_rph, |p| p.euler_deg);
    let opt = NavOptions {
        start_s: a.start_s,
        end_s: a.end_s,
        calibration,
        f32: a.f32,
        hold_height: a.hold_height,
        base: Some(core_nav::attitude::Euler::from_deg(
            start_rph[0],
            start_rph[1],
            start_rph[2],
        )),
        gimbals: None,
    };
    let pb = progress_bar("navigate");
    let rows = nav::navigate(&rec, &opt, &mut |f| pb.set_position((f * 1000.0) as u64))?;
    pb.finish_and_clear();
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    write_file(&a.out.join("trajectory.csv"), &nav::trajectory_csv(&rows))?;
    for chart in report::nav_charts(&[("run", &rows)], start_rph) {
        chart.write(&a.out)?;
    }
    let e = nav::static_errors(&rows, start_rph);
    let faults = rows.last().map_or(0, |r| r.faults);
    println!(
        "{} samples navigated ({} refused) -> {}",
        rows.len(),
        faults,
        a.out.display()
    );
    match &aligned {
        Some(al) => {
            print!("{}", alignment_text(al, meta_rph));
            if let Some(p) = &picked {
                if p.level_refuted_sigmas.is_some() || p.heading_refuted_sigmas.is_some() {
                    println!("warning: meta.toml's stated attitude is refuted by the alignment:");
                }
                println!("{}", p.why);
            }
        }
        None if a.attitude_from_meta => {
            println!("start attitude: meta.toml's (--attitude-from-meta)")
        }
        None => {}
    }
    println!("errors against the still base: the start point, and the start attitude for the attitude's drift:");
    println!("  {}", nav::summary(&e));
    println!("  final horizontal position error {:.2} m", e.h_pos_end_m);
    if let Some(p) = &a.json {
        write_file(
            p,
            &serde_json::to_string_pretty(
                &serde_json::json!({"errors": e, "refused_steps": faults, "alignment": aligned, "start_attitude": picked}),
            )?,
        )?;
    }
    Ok(())
}

/// The lever-arm estimate, one line: each component with its 1-sigma
/// (or unresolved), and the fixes' NIS before and after.
/// What a run's symptom points at, one hypothesis at a time: the clocks
/// (unless `--estimate-time-offset` ran), then, when they are cleared,
/// the antenna's arm (unless `--estimate-lever-arm` ran).
fn symptom_hints(
    rec: &recording::Recording,
    opt: &rins::aided::AidedOptions,
    summary: &rins::aided::AidedSummary,
    run: &rins::aided::AidedRun,
    offset_done: bool,
    lever_done: bool,
) -> (
    Option<rins::aided::offset::OffsetHint>,
    Option<rins::aided::lever::LeverHint>,
) {
    if offset_done {
        return (None, None);
    }
    let pb = progress_bar("time offset");
    let hint = rins::aided::offset::hint(rec, opt, summary, run, &mut |f| {
        pb.set_position((f * 1000.0) as u64)
    });
    pb.finish_and_clear();
    if lever_done || hint.as_ref().is_some_and(|h| h.recommended) {
        return (hint, None);
    }
    if hint.is_none() && !resolves_arm(rec) {
        return (None, None);
    }
    let pb = progress_bar("lever arm");
    let l = rins::aided::lever::LeverHint::find(rec, opt, &mut |f| {
        pb.set_position((f * 1000.0) as u64)
    });
    pb.finish_and_clear();
    (hint, Some(l))
}

/// The fixes' median horizontal 1-sigma at or below which the antenna's
/// arm is checked on every run, m: RTK fixes (centimetres) resolve it to
/// millimetres, and an arm a few centimetres wrong costs metres in an
/// outage without always raising the fixes' NIS to a symptom (the
/// bundled walk, its author's arm 9 cm off: 2.2 m against 0.34 m at the
/// end of 10 s outages, NIS per component 1.2 on its 20 s set).
const ARM_CHECK_SIGMA_M: f64 = 0.1;

/// The recording's fixes are precise enough to check the arm
/// ([`ARM_CHECK_SIGMA_M`]).
fn resolves_arm(rec: &recording::Recording) -> bool {
    let mut h: Vec<f64> = rec
        .moving
        .as_ref()
        .and_then(|m| m.gnss.as_ref())
        .map(|f| f.iter().map(|f| f.sigma_h_m).collect())
        .unwrap_or_default();
    core_nav::stats::median(&mut h) <= ARM_CHECK_SIGMA_M
}

fn lever_line(e: &rins::aided::lever::LeverEstimate) -> String {
    let parts: Vec<String> = (0..3)
        .map(|i| match e.sigma_m[i] {
            Some(s) => format!("{:+.3} +- {s:.3}", e.b_m[i]),
            None => format!("{:+.3} (unresolved: as given)", e.b_m[i]),
        })
        .collect();
    format!(
        "antenna lever arm in b: {} m (given {:?}; the fixes' NIS per dof {:.3} -> {:.3})",
        parts.join(", "),
        e.given_b_m,
        e.nis_per_dof[0],
        e.nis_per_dof[1]
    )
}

/// The sensor file's antenna lever arm over meta.toml's, said when they
/// differ.
fn antenna_from_sensor(rec: &mut recording::Recording, profile: &hal_sim::imu::ImuSpec) {
    let Some(lever) = profile.mounting.antenna_b_m else {
        return;
    };
    if let Some(g) = rec.moving.as_mut().and_then(|m| m.gnss_meta.as_mut()) {
        if g.antenna_b_m != lever {
            println!(
                "antenna lever arm {lever:?} m from the sensor file (meta.toml says {:?})",
                g.antenna_b_m
            );
            g.antenna_b_m = lever;
        }
    }
}

/// `--gnss-floor-m`: the floors by solution type; refused when no fix
/// states its type (gnss.csv without a quality column: every fix keeps
/// its own sigma, the floors would change nothing).
fn receiver_floor(
    given: Option<&[f64]>,
    rec: &recording::Recording,
) -> Result<rins::aided::ReceiverFloor> {
    let Some(v) = given else {
        return Ok(rins::aided::ReceiverFloor::default());
    };
    let &[rtk_fixed_m, rtk_float_m, dgnss_m, single_m] = v else {
        bail!(
            "--gnss-floor-m takes four values (RTK fixed, RTK float, DGNSS, single point, m, comma-separated), got {}",
            v.len()
        );
    };
    let typed = rec
        .moving
        .as_ref()
        .and_then(|m| m.gnss.as_ref())
        .is_some_and(|g| g.iter().any(|f| f.quality.is_some()));
    if !typed {
        bail!("--gnss-floor-m: no fix in gnss.csv states its solution type (no quality column), so no floor applies: each fix keeps its own sigma_h_m");
    }
    Ok(rins::aided::ReceiverFloor {
        rtk_fixed_m,
        rtk_float_m,
        dgnss_m,
        single_m,
    })
}

/// The run navigated again with `theirs`, kept only when the fixes agree
/// with it better over the whole run (their NIS per component falls;
/// the pre-passes measured that on their own runs): `Err` says why not.
fn again_if_better(
    rec: &recording::Recording,
    theirs: &rins::aided::AidedOptions,
    before: &rins::aided::AidedSummary,
    what: &str,
) -> Result<std::result::Result<(rins::aided::AidedRun, rins::aided::AidedSummary), String>> {
    let pb = progress_bar(&format!("navigate --gnss, {what}"));
    let again = rins::aided::navigate(rec, theirs, &mut |f| pb.set_position((f * 1000.0) as u64))?;
    pb.finish_and_clear();
    let s = rins::aided::summary(rec, &again);
    let nis = |s: &rins::aided::AidedSummary| s.nis_mean_per_dof.unwrap_or(f64::INFINITY);
    Ok(if nis(&s) < nis(before) {
        Ok((again, s))
    } else {
        Err(format!(
            "with it the fixes' NIS per component was {:.2}, not below this run's {:.2}",
            nis(&s),
            nis(before)
        ))
    })
}

/// `rins navigate --gnss`.
fn run_aided(a: &Args, rec: &recording::Recording) -> Result<()> {
    let mut rec = rins::aided::span::cut(rec, a.start_s, a.end_s)?;
    let profile = rins::aided::profile(&rec, a.sensor.as_deref())?;
    antenna_from_sensor(&mut rec, &profile);
    let rec = &rec;
    let (Some(first), Some(last)) = (rec.imu.first(), rec.imu.last()) else {
        bail!("no IMU sample between --start-s and --end-s");
    };
    let truth = rec.moving.as_ref().and_then(|m| m.truth.as_deref());
    if let Some(truth) = truth {
        recording::moving::truth_overlap(truth, first.t_s, last.t_s, &a.rec.join("truth.csv"))
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    let mut opt = aided_options(a, rec, profile)?;
    let asked = asked_estimates(a, rec, &mut opt)?;
    let pb = progress_bar("navigate --gnss");
    let run = rins::aided::navigate(rec, &opt, &mut |f| pb.set_position((f * 1000.0) as u64))?;
    pb.finish_and_clear();
    let summary = rins::aided::summary(rec, &run);
    let (run, summary, hints) = follow_hints(a, rec, &opt, &asked, (run, summary))?;
    report(a, rec, &run, &summary, &asked, &hints)
}

/// `navigate --gnss`'s options from the flags (the estimates' not yet).
fn aided_options(
    a: &Args,
    rec: &recording::Recording,
    profile: hal_sim::imu::ImuSpec,
) -> Result<rins::aided::AidedOptions> {
    Ok(rins::aided::AidedOptions {
        profile,
        zupt: !a.no_zupt,
        gate_sigma: a.gate_sigma,
        f32: a.f32,
        outages: a
            .gnss_outages
            .iter()
            .map(|o| hal_sim::drive::parse_outage(o).map_err(|e| anyhow::anyhow!(e)))
            .collect::<Result<_>>()?,
        floor: receiver_floor(a.gnss_floor_m.as_deref(), rec)?,
        gnss_velocity: !a.gnss_position_only,
        time_offset_s: a.time_offset_s.unwrap_or(0.0),
        vehicle: a
            .vehicle
            .as_deref()
            .and_then(rins::aided::vehicle::Vehicle::parse),
        lever_b_m: None,
        learn_noise: a.learn_noise,
        vertical_learn: a.vertical_noise == "learn",
        consider: None,
    })
}

/// What the flags asked estimated before the run.
struct Asked {
    lever: Option<rins::aided::lever::LeverEstimate>,
    offset: Option<rins::aided::offset::OffsetEstimate>,
    joint: Option<rins::aided::joint::JointEstimate>,
}

/// `--estimate-lever-arm`, `--estimate-time-offset` and the two
/// together: each printed and put into `opt`.
fn asked_estimates(
    a: &Args,
    rec: &recording::Recording,
    opt: &mut rins::aided::AidedOptions,
) -> Result<Asked> {
    let mut asked = Asked {
        lever: None,
        offset: None,
        joint: None,
    };
    if a.estimate_lever_arm {
        let pb = progress_bar("lever arm");
        let e =
            rins::aided::lever::estimate(rec, opt, &mut |f| pb.set_position((f * 1000.0) as u64))?;
        // With --estimate-time-offset the joint estimate refines it.
        if !a.estimate_time_offset {
            e.fits().context("--estimate-lever-arm: no arm found")?;
        }
        pb.finish_and_clear();
        println!("{}", lever_line(&e));
        opt.lever_b_m = Some(e.b_m);
        opt.consider = rins::aided::consider_of(None, e.covariance_m2);
        asked.lever = Some(e);
    }
    if a.estimate_time_offset {
        let pb = progress_bar("time offset");
        let e = rins::aided::offset::estimate(rec, opt, 0.5, 0.02, &mut |f| {
            pb.set_position((f * 1000.0) as u64)
        })?;
        pb.finish_and_clear();
        println!(
            "IMU-to-GNSS time offset: {:+.3} s +- {:.3} s (the IMU late; from the fixes' NIS over +-0.5 s)",
            e.offset_s, e.sigma_s
        );
        opt.time_offset_s = e.offset_s;
        let arm = asked.lever.as_ref().and_then(|l| l.covariance_m2);
        opt.consider = rins::aided::consider_of(Some(e.sigma_s), arm);
        asked.offset = Some(e);
    }
    if let (Some(o), Some(l)) = (&asked.offset, &asked.lever) {
        let pb = progress_bar("offset and arm together");
        let e = rins::aided::joint::estimate(rec, opt, o, l, &mut |f| {
            pb.set_position((f * 1000.0) as u64)
        })?;
        pb.finish_and_clear();
        print!("{}", e.text());
        opt.time_offset_s = e.offset_s;
        opt.lever_b_m = Some(e.lever_b_m);
        opt.consider = Some(e.covariance);
        asked.joint = Some(e);
    }
    Ok(asked)
}

/// What a finished run's symptoms led to.
struct Hints {
    clocks: Option<rins::aided::offset::OffsetHint>,
    lever: Option<rins::aided::lever::LeverHint>,
    /// The arm's pre-pass found no arm at the run's clock, and that was
    /// the clocks' symptom (said in their line, not again).
    arm_lost: bool,
}

type Navigated = (rins::aided::AidedRun, rins::aided::AidedSummary);

/// The symptoms' hypotheses, one at a time (the clocks, then the arm),
/// and the run again with what they find where the flags leave it open.
fn follow_hints(
    a: &Args,
    rec: &recording::Recording,
    opt: &rins::aided::AidedOptions,
    asked: &Asked,
    mut now: Navigated,
) -> Result<(rins::aided::AidedRun, rins::aided::AidedSummary, Hints)> {
    let (lever_done, offset_done) = (asked.lever.is_some(), asked.offset.is_some());
    let (mut clocks, mut lever) = symptom_hints(rec, opt, &now.1, &now.0, offset_done, lever_done);
    // The recording's clock and arm were the run's: what the clocks'
    // symptom (or an arm fitting at no point of this clock) finds is
    // navigated with.
    let open = a.time_offset_s.is_none() && !a.keep_given_arm && !lever_done && !offset_done;
    let lost = lever
        .as_ref()
        .and_then(|l| l.error.clone())
        .filter(|_| open && clocks.is_none());
    if let Some(why) = &lost {
        let pb = progress_bar("time offset");
        let symptom = format!("the antenna arm's pre-pass at this run's clock: {why}");
        clocks = Some(rins::aided::offset::hint_because(
            rec,
            opt,
            symptom,
            &mut |f| pb.set_position((f * 1000.0) as u64),
        ));
        pb.finish_and_clear();
    }
    if let Some(h) = clocks.as_mut().filter(|_| open) {
        take_clock(rec, opt, h, &mut now)?;
    }
    let refuted = lever
        .as_ref()
        .filter(|l| l.recommended && !a.keep_given_arm)
        .and_then(|l| l.estimate.as_ref().map(|e| e.b_m));
    if let (Some(b), Some(l)) = (refuted, lever.as_mut()) {
        let theirs = rins::aided::AidedOptions {
            lever_b_m: Some(b),
            consider: rins::aided::consider_of(
                None,
                l.estimate.as_ref().and_then(|e| e.covariance_m2),
            ),
            ..opt.clone()
        };
        match again_if_better(rec, &theirs, &now.1, "the fixes' arm")? {
            Ok(better) => (now, l.applied) = (better, true),
            Err(why) => l.kept_given_because = Some(why),
        }
    }
    let hints = Hints {
        clocks,
        lever,
        arm_lost: lost.is_some(),
    };
    Ok((now.0, now.1, hints))
}

/// A clock the fixes point at: found with the arm
/// ([`rins::aided::joint::for_hint`]), or alone where the two are not
/// found together (an arm the fixes do not resolve, a car's), and the
/// run again with it, kept when the fixes agree with it better.
fn take_clock(
    rec: &recording::Recording,
    opt: &rins::aided::AidedOptions,
    h: &mut rins::aided::offset::OffsetHint,
    now: &mut Navigated,
) -> Result<()> {
    let pb = progress_bar("offset and arm together");
    rins::aided::joint::for_hint(rec, opt, h, &mut |f| pb.set_position((f * 1000.0) as u64));
    pb.finish_and_clear();
    let found = match (&h.together, &h.estimate) {
        (Some(j), _) => Some((j.offset_s, Some(j.lever_b_m), Some(j.covariance))),
        (None, Some(e)) if h.recommended => Some((
            e.offset_s,
            opt.lever_b_m,
            rins::aided::consider_of(Some(e.sigma_s), None),
        )),
        _ => None,
    };
    let Some((time_offset_s, lever_b_m, consider)) = found else {
        return Ok(());
    };
    let theirs = rins::aided::AidedOptions {
        time_offset_s,
        lever_b_m,
        consider,
        ..opt.clone()
    };
    match again_if_better(rec, &theirs, &now.1, "the clock found")? {
        Ok(better) => (*now, h.applied) = (better, true),
        Err(why) => h.kept_given_because = Some(why),
    }
    Ok(())
}

/// The trajectory, the summary with the hints, the plots and `--json`.
fn report(
    a: &Args,
    rec: &recording::Recording,
    run: &rins::aided::AidedRun,
    summary: &rins::aided::AidedSummary,
    asked: &Asked,
    hints: &Hints,
) -> Result<()> {
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    write_file(
        &a.out.join("trajectory.csv"),
        &rins::aided::trajectory_csv(&run.rows),
    )?;
    print!("{}", summary.text());
    if hints.lever.as_ref().is_some_and(|l| l.applied) {
        println!("the run with the given antenna arm, before:");
    } else if hints.clocks.as_ref().is_some_and(|h| h.applied) {
        println!("the run with the recording's clock and arm, before:");
    }
    let lever = hints.lever.as_ref().filter(|_| !hints.arm_lost);
    for text in [
        hints.clocks.as_ref().map(|h| h.text()),
        lever.map(|l| l.text()),
    ]
    .into_iter()
    .flatten()
    {
        print!("{text}");
    }
    println!("wrote {}", a.out.join("trajectory.csv").display());
    let plots = rins::aided::plots(rec, run, &a.out)?;
    println!(
        "wrote {} plots in {} (map, position_error, consistency)",
        plots.len(),
        a.out.display()
    );
    let Some(p) = &a.json else {
        return Ok(());
    };
    let mut j = summary.json();
    if let Some(m) = j.as_object_mut() {
        m.insert(
            "time_offset_hint".into(),
            serde_json::to_value(&hints.clocks)?,
        );
        m.insert("lever_arm_hint".into(), serde_json::to_value(&hints.lever)?);
        if let Some(e) = &asked.offset {
            m.insert("time_offset".into(), serde_json::to_value(e)?);
        }
        if let Some(e) = &asked.lever {
            m.insert("lever_arm".into(), serde_json::to_value(e)?);
        }
        if let Some(e) = &asked.joint {
            m.insert("offset_and_lever_arm".into(), serde_json::to_value(e)?);
        }
    }
    write_file(p, &serde_json::to_string_pretty(&j)?)
}
