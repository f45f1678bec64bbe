//! Aided navigation of a moving-base recording (`rins navigate REC
//! --gnss`): the recording's samples, encoder track and GNSS fixes through
//! core-nav's aided navigator ([`core_nav::aided::AidedNav`]: the strapdown
//! mechanization of the spinning sensor, the error-state Kalman filter,
//! GNSS position and velocity with the antenna lever arm through the table
//! angle, zero-velocity updates; the same code the board runs). Output:
//! trajectory-v1 rows plus the filter's 1-sigma, the fixes' NIS and, on
//! simulated runs, the NEES against `truth.csv`.
//!
//! The table angle and rate come from the encoder (hal-sim's
//! [`recording::track::EncoderTrack`]).

use anyhow::Result;
use core_nav::aided::AidedConfig;
use core_nav::eskf::{EskfConfig, InitialSigma};
use core_nav::real::Real;
use core_nav::table::Axis;
use hal_sim::imu::ImuSpec;
use recording::moving::GnssRow;
use recording::Recording;

use crate::nav::TrajRow;

pub mod align;
pub mod curvature;
pub mod fixvel;
pub mod joint;
pub mod learn;
pub mod lever;
pub mod offset;
pub mod pipeline;
mod plots;
pub mod span;
mod summary;
pub mod vehicle;
pub mod vertical;

/// The host's error state: the board's `N` and five of its own (a car's
/// mounting yaw and pitch, its odometer's scale, the IMU's distance ahead
/// of its rear axle, its rear axle's slip per lateral acceleration:
/// [`vehicle`]). A run that
/// uses none leaves them at zero variance and uncorrelated, so its other
/// states' arithmetic is the board's, term for term.
pub const HOST_M: usize = core_nav::eskf::N + 5;
/// The aided navigator the host runs.
pub type HostNav<T> = core_nav::aided::AidedNav<T, HOST_M>;
pub use plots::{fixes_en, fixless, plots};
pub use summary::{chi2_95_bounds, summary, AidedSummary, OutageError};

pub use core_nav::aided::{GNSS_CORR_SHARE, ZUPT_SIGMA_MPS, ZUPT_WINDOW};

/// How to aid.
#[derive(Clone, Debug)]
pub struct AidedOptions {
    /// The sensor profile the filter's noise model comes from.
    pub profile: ImuSpec,
    /// Use zero-velocity updates.
    pub zupt: bool,
    /// Innovation gate, sigmas.
    pub gate_sigma: f64,
    /// Mechanization and filter in f32, as on the board (else f64).
    pub f32: bool,
    /// GNSS outages cut in: (start s, length s) on the IMU's clock; the
    /// fixes inside (at their stamps plus `time_offset_s`) are withheld
    /// from the filter (and kept as the reference).
    pub outages: Vec<(f64, f64)>,
    /// The least 1-sigma a fix is taken with, by solution type.
    pub floor: ReceiverFloor,
    /// Use the fixes' velocity (else position only).
    pub gnss_velocity: bool,
    /// How late the IMU's clock runs behind the receiver's, s: a fix at
    /// the receiver's `t` is taken at the IMU's `t + offset`
    /// ([`offset::estimate`] finds it).
    pub time_offset_s: f64,
    /// The vehicle's constraints ([`vehicle`]), when the base is one.
    pub vehicle: Option<vehicle::Vehicle>,
    /// The antenna's position from the IMU in `b`, m, over the
    /// recording's (`None`: the recording's; [`lever::estimate`] finds
    /// it).
    pub lever_b_m: Option<[f64; 3]>,
    /// Learn the ride's process noise from the fixes ([`learn`]), never
    /// below the sensor file's (off unless asked: `--learn-noise`).
    pub learn_noise: bool,
    /// Learn the ride's vertical noise from the fixes in a first pass and
    /// add it ([`vertical`]; on unless `--vertical-noise file`).
    pub vertical_learn: bool,
    /// The covariance of the errors of `time_offset_s` (s) and
    /// `lever_b_m` (`b`, m) when they were estimated (`None`: given, taken
    /// as exact). The filter holds them; the trajectory's position sigmas
    /// carry what they move the IMU's position by (Schmidt's consider:
    /// [`pipeline::Consider`]).
    pub consider: Option<[[f64; 4]; 4]>,
}

/// [`AidedOptions::consider`] from an estimated offset's 1-sigma (s) and
/// an estimated arm's covariance (`b`, m^2), each found alone (`None`:
/// given, exact); `None` when neither was estimated.
pub fn consider_of(
    offset_sigma_s: Option<f64>,
    arm_m2: Option<[[f64; 3]; 3]>,
) -> Option<[[f64; 4]; 4]> {
    if offset_sigma_s.is_none() && arm_m2.is_none() {
        return None;
    }
    let arm = arm_m2.unwrap_or([[0.0; 3]; 3]);
    Some(std::array::from_fn(|r| {
        std::array::from_fn(|c| match (r, c) {
            (0, 0) => offset_sigma_s.map_or(0.0, |s| s * s),
            (0, _) | (_, 0) => 0.0,
            _ => arm[r - 1][c - 1],
        })
    }))
}

/// The innovation gate the CLI and the tools use unless told, sigmas.
pub const GATE_SIGMA: f64 = 6.0;

impl AidedOptions {
    /// The options every tool starts from: `profile`'s noise model,
    /// zero-velocity updates, the [`GATE_SIGMA`] gate, f64, no outages,
    /// the default receiver floors, the fixes' velocity, no time offset.
    /// A caller changes what differs (`AidedOptions { f32: true,
    /// ..AidedOptions::new(p) }`).
    pub fn new(profile: ImuSpec) -> Self {
        Self {
            profile,
            zupt: true,
            gate_sigma: GATE_SIGMA,
            f32: false,
            outages: vec![],
            floor: ReceiverFloor::default(),
            gnss_velocity: true,
            time_offset_s: 0.0,
            vehicle: None,
            lever_b_m: None,
            learn_noise: false,
            vertical_learn: true,
            consider: None,
        }
    }
}

impl AidedOptions {
    /// What the estimators (the arm's, the time offset's, the two's) run
    /// each of their many trial runs with: `self` without the vertical
    /// ride noise's passes ([`vertical`]), which would cost several runs
    /// each; they compare the fixes' fit between trials, which the
    /// height's added noise would not order differently.
    pub fn for_trials(&self) -> Self {
        Self {
            vertical_learn: false,
            ..self.clone()
        }
    }
}

/// The least horizontal 1-sigma (m) a fix of each solution type is taken
/// with (vertical: twice it): receivers report cm-level sigmas even while
/// their carrier solution is float. A fix without a solution type is
/// taken as reported.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReceiverFloor {
    /// Carrier phase, ambiguities fixed.
    pub rtk_fixed_m: f64,
    /// Carrier phase, ambiguities float.
    pub rtk_float_m: f64,
    /// Code differential, SBAS, PPP.
    pub dgnss_m: f64,
    /// Single point.
    pub single_m: f64,
}

impl Default for ReceiverFloor {
    /// Typical accuracies of each solution type (RTKLIB manual and
    /// u-blox F9/X20 specifications: RTK fixed 1-2 cm, float decimetres,
    /// DGNSS/SBAS about half a metre, single point 1.5 m).
    fn default() -> Self {
        Self {
            rtk_fixed_m: 0.02,
            rtk_float_m: 0.3,
            dgnss_m: 0.5,
            single_m: 1.5,
        }
    }
}

impl ReceiverFloor {
    /// `row` with its sigmas raised to the floor of its solution type.
    pub fn apply(&self, row: &GnssRow) -> GnssRow {
        use recording::moving::Solution as S;
        let h = match row.quality {
            None => return *row,
            Some(S::RtkFixed) => self.rtk_fixed_m,
            Some(S::RtkFloat) => self.rtk_float_m,
            Some(S::Dgnss | S::Sbas | S::Ppp) => self.dgnss_m,
            Some(S::Single) => self.single_m,
        };
        GnssRow {
            sigma_h_m: row.sigma_h_m.max(h),
            sigma_v_m: row.sigma_v_m.max(2.0 * h),
            ..*row
        }
    }
}

/// One output row: trajectory-v1 and the filter's 1-sigma.
#[derive(Clone, Copy, Debug, Default)]
pub struct AidedRow {
    /// The trajectory-v1 columns.
    pub traj: TrajRow,
    /// Position 1-sigma, north, east, down, m.
    pub sigma_p_m: [f64; 3],
    /// Velocity 1-sigma, m/s.
    pub sigma_v_mps: [f64; 3],
    /// Attitude 1-sigma of roll, pitch and heading, deg (the filter's
    /// rotation error about north, east and down taken through the Euler
    /// angles' Jacobian: `core_nav::attitude::euler_sigma`).
    pub sigma_att_deg: [f64; 3],
    /// A GNSS fix was processed at this sample (taken or refused).
    pub fix: bool,
    /// The fix processed here had its horizontal position taken: the gate
    /// rejected neither north nor east.
    pub fix_taken: bool,
    /// The zero-velocity detector said still (evaluated every tenth
    /// sample; the verdict holds in between).
    pub still: bool,
    /// A zero-velocity update was applied at this sample.
    pub zupt: bool,
    /// The filter's gyro bias estimate, x, y, z of the sensor frame `s`,
    /// rad/s (subtracted from each sample).
    pub gyro_bias_radps: [f64; 3],
    /// The filter's accelerometer bias estimate in `s`, m/s^2.
    pub accel_bias_mps2: [f64; 3],
}

/// A navigation run.
#[derive(Clone, Debug, Default)]
pub struct AidedRun {
    /// One row per IMU sample.
    pub rows: Vec<AidedRow>,
    /// Per GNSS fix used: (time s, NIS, components used).
    pub nis: Vec<(f64, f64, u8)>,
    /// Components the gate rejected, updates refused, fixes not used.
    pub rejected: u32,
    /// See `rejected`.
    pub refused: u32,
    /// Zero-velocity updates made.
    pub zupts: u32,
    /// Zero-rotation updates made (one per still window).
    pub zarus: u32,
    /// Still windows the filter's own velocity refuted (no update made).
    pub still_refuted: u32,
    /// Re-initialisations of position and velocity from fixes the gate
    /// kept refusing while they agreed among themselves.
    pub reinits: u32,
    /// Re-initialisations of the height alone (its fixes' heights
    /// refused while their horizontal positions were taken).
    pub height_reinits: u32,
    /// Steps the mechanization refused (non-finite samples, gaps).
    pub faults: u32,
    /// Normalised estimation error squared against `truth.csv` (simulated
    /// runs), once a second: (time s, NEES, degrees of freedom: north,
    /// east, the three velocities and the attitude's three angles).
    pub nees: Vec<(f64, f64, usize)>,
    /// The attitude's own NEES (3 degrees of freedom) at the same seconds:
    /// (time s, NEES).
    pub nees_attitude: Vec<(f64, f64)>,
    /// The NEES a user computes from trajectory.csv alone, at the same
    /// seconds: the nine errors (north, east, down, the three velocities,
    /// roll, pitch, heading) over their sigma columns, squared and summed
    /// (a diagonal covariance: the columns carry no correlations).
    pub nees_diag: Vec<(f64, f64)>,
    /// The alignment, when the start attitude was not given.
    pub aligned: Option<align::Alignment>,
    /// Where the start attitude and its sigmas came from.
    pub start: pipeline::StartAttitude,
    /// The outages cut in: (start s, length s).
    pub outages_cut: Vec<(f64, f64)>,
    /// Each re-initialisation: (time s, the horizontal jump it made, m:
    /// the position after it less the one the step before would have
    /// reached at its velocity).
    pub reinit_at: Vec<(f64, f64)>,
    /// What the vehicle's constraints did (`--vehicle`).
    pub vehicle: Option<vehicle::VehicleReport>,
    /// The vehicle was moving at the start: its velocity from the fixes
    /// (and no zero-velocity updates).
    pub moving_start: Option<align::MovingStart>,
    /// The receiver's clock less the IMU's, s, the filter was given (the
    /// fixes' stamps plus it are their times on the IMU's clock): the
    /// summary measures against the fixes at those times.
    pub time_offset_s: f64,
    /// The ride's noise learnt from the fixes (`None`: not learnt).
    pub learnt: Option<learn::LearnReport>,
    /// The ride's vertical noise ([`vertical`]; `None`: not asked).
    pub vertical: Option<vertical::VerticalReport>,
    /// The process noise the filter started from (the sensor file's).
    pub process_noise: learn::ProcessNoise,
    /// When the fixes' velocity was valid, found from their positions
    /// (`None`: too few fixes with a velocity).
    pub velocity_lag: Option<fixvel::VelocityLag>,
    /// The largest 1-sigma the estimated clock and arm added to the
    /// position, north, east, down, m ([`pipeline::Consider`]; `None`:
    /// both given).
    pub considered_m: Option<[f64; 3]>,
}

/// The fixes the filter gets: each at its time on the IMU's clock
/// (shifted by the time offset), those outside the outages cut in (times
/// on the IMU's clock, as the trajectory's), its sigmas
/// raised to its solution type's floor, without velocity when the options
/// say so.
fn prepared_fixes(fixes: &[GnssRow], opt: &AidedOptions) -> Vec<GnssRow> {
    fixes
        .iter()
        .map(|f| {
            let mut f = opt.floor.apply(f);
            f.t_s += opt.time_offset_s;
            if !opt.gnss_velocity {
                f.v_n_mps = [f64::NAN; 3];
                f.sigma_vel_mps = f64::NAN;
            }
            f
        })
        .filter(|f| {
            !opt.outages
                .iter()
                .any(|(a, l)| f.t_s >= *a && f.t_s < a + l)
        })
        .collect()
}

/// The antenna's lever arm the filter takes, `b`, m: the options' or the
/// recording's (meta.toml's `[gnss] antenna_b_m`), else none.
pub fn lever_b_m(rec: &Recording, opt: &AidedOptions) -> [f64; 3] {
    let given = rec.moving.as_ref().and_then(|m| m.gnss_meta);
    opt.lever_b_m
        .or(given.map(|g| g.antenna_b_m))
        .unwrap_or([0.0; 3])
}

/// The correlated GNSS error's 1-sigma (horizontal, vertical, m): its
/// share [`GNSS_CORR_SHARE`] of the fixes' median (floored) variance, so
/// that an RTK receiver's centimetres and a phone's metres each get their
/// own (hal-sim's receiver, 1.5 m and 3 m, gives the 1.06 m and 2.12 m
/// the board's tuning holds).
pub fn gnss_corr_sigma(fixes: &[GnssRow]) -> [f64; 2] {
    let median = |mut v: Vec<f64>| match core_nav::stats::median(&mut v) {
        m if m.is_finite() => m,
        _ => 1.0,
    };
    let h = median(fixes.iter().map(|f| f.sigma_h_m).collect());
    let v = median(fixes.iter().map(|f| f.sigma_v_m).collect());
    core_nav::aided::gnss_corr_sigma_m(h, v)
}

/// The sensor profile for the filter: `name` (one of hal-sim's profiles)
/// or the one the recording's `[imu] model` names.
///
/// # Errors
/// An unknown name, or a recording whose model names no known profile.
pub fn profile(rec: &Recording, name: Option<&str>) -> Result<ImuSpec> {
    let p = any_profile(rec, name)?;
    p.require(
        &hal_sim::sensor::terms::FILTER,
        "the aided filter's noise model",
    )?;
    Ok(p)
}

/// [`profile`] whatever it knows (its unknown terms listed in it): for
/// the alignment's sigmas and the plausibility check, which say what they
/// cannot tell.
///
/// # Errors
/// As [`profile`], but for unknown terms.
pub fn any_profile(rec: &Recording, name: Option<&str>) -> Result<ImuSpec> {
    match name {
        Some(name) => Ok(hal_sim::sensor::resolve(name)?),
        None => rec
            .meta
            .imu_model
            .as_deref()
            .and_then(ImuSpec::by_model)
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "the recording's [imu] model names no known profile: give --sensor NAME|FILE ({})",
                    ImuSpec::NAMES.join(", ")
                )
            }),
    }
}

/// The filter's noise model from a sensor profile: the sensor crate's
/// ([`sensor::filter::filter_config`]), the one derivation the board's
/// build uses too.
pub fn filter_config(p: &ImuSpec, gate_sigma: f64) -> EskfConfig {
    sensor::filter::filter_config(&p.gyro, &p.accel, &p.temp, gate_sigma)
}

pub use sensor::filter::BIAS_HOLD_S;

/// Navigates `rec` with its GNSS fixes.
///
/// # Errors
/// Not a moving-base recording, no `gnss.csv`, no encoder reads, a start
/// the mechanization refuses.
pub fn navigate(
    rec: &Recording,
    opt: &AidedOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<AidedRun> {
    if opt.f32 {
        navigate_t::<f32>(rec, opt, progress)
    } else {
        navigate_t::<f64>(rec, opt, progress)
    }
}

/// [`navigate`] with the mechanization and the filter in `T` (f32 as on
/// the board); the bookkeeping (fixes, truth, output) in f64: the
/// [`pipeline`].
fn navigate_t<T: Real>(
    rec: &Recording,
    opt: &AidedOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<AidedRun> {
    pipeline::run::<T>(rec, opt, progress)
}

/// The horizontal jump (m) between the last two rows: the last one's
/// position less where the one before would have reached at its velocity.
/// The nine errors of `row` against the truth over its own sigma
/// columns, squared and summed (the angles wrapped to +-180 deg).
fn diagonal_nees(row: &AidedRow, tr: &recording::moving::TruthRow) -> f64 {
    let wrap = |d: f64| (d + 180.0).rem_euclid(360.0) - 180.0;
    let t = &row.traj;
    (0..3)
        .map(|i| {
            let p = (tr.p_n_m[i] - t.ned_m[i]) / row.sigma_p_m[i];
            let v = (tr.v_n_mps[i] - t.v_mps[i]) / row.sigma_v_mps[i];
            let a = wrap(tr.euler_deg[i] - t.rph_deg[i]) / row.sigma_att_deg[i];
            p * p + v * v + a * a
        })
        .sum()
}

fn reinit_jump_m(rows: &[AidedRow]) -> f64 {
    match rows {
        [.., a, b] => {
            let dt = b.traj.t_s - a.traj.t_s;
            let d = |i: usize| b.traj.ned_m[i] - (a.traj.ned_m[i] + a.traj.v_mps[i] * dt);
            d(0).hypot(d(1))
        }
        _ => 0.0,
    }
}

/// The aided navigator's settings for a sensor profile, table axis and
/// antenna lever arm (`b`, m), the IMU sampled at `rate_hz`, the encoder's
/// read 1-sigma `encoder_read_sigma_rad` (rad; 0 without a table).
pub fn aided_config(
    axis: Axis,
    antenna_b_m: [f64; 3],
    opt: &AidedOptions,
    rate_hz: f64,
    encoder_read_sigma_rad: f64,
) -> AidedConfig {
    let mut zupt_noise = zupt_noise(&opt.profile, rate_hz);
    zupt_noise.sigma_table_rate_radps =
        core_nav::aided::table_rate_sigma_radps(encoder_read_sigma_rad, rate_hz);
    AidedConfig {
        eskf: filter_config(&opt.profile, opt.gate_sigma),
        initial: INITIAL_SIGMA,
        axis,
        antenna_b_m,
        zupt: opt.zupt,
        zupt_noise,
        velocity_lag_s: [0.0; 2],
        // As the board: `navigate` sizes it from all the fixes instead
        // (`pipeline::start`).
        receiver_from_fixes: true,
    }
}

/// The zero-velocity detector's per-sample noise for a sensor sampled at
/// `rate_hz` ([`sensor::filter::zupt_noise`]).
pub fn zupt_noise(p: &ImuSpec, rate_hz: f64) -> core_nav::aided::ZuptNoise {
    sensor::filter::zupt_noise(&p.gyro, &p.accel, rate_hz)
}

/// The filter's initial 1-sigma: the start's position from the first fix
/// (1 m), at rest (0.05 m/s), the attitude from a level and a compass
/// (0.5 deg level, 2 deg heading).
pub const INITIAL_SIGMA: InitialSigma = InitialSigma {
    position_m: 1.0,
    velocity_mps: 0.05,
    level_rad: 0.5 * core::f64::consts::PI / 180.0,
    heading_rad: 2.0 * core::f64::consts::PI / 180.0,
};

/// trajectory.csv with the filter's sigmas and its sensor bias estimates
/// (in the sensor frame `s`) as extra columns (trajectory-v1 allows extra
/// columns named with their units).
pub fn trajectory_csv(rows: &[AidedRow]) -> String {
    let mut s = String::with_capacity(rows.len() * 200);
    s.push_str("t_s,north_m,east_m,down_m,vn_mps,ve_mps,vd_mps,roll_deg,pitch_deg,heading_deg,sigma_north_m,sigma_east_m,sigma_down_m,sigma_vn_mps,sigma_ve_mps,sigma_vd_mps,sigma_roll_deg,sigma_pitch_deg,sigma_heading_deg,gnss_fix,still,zupt,gyro_bias_x_radps,gyro_bias_y_radps,gyro_bias_z_radps,accel_bias_x_mps2,accel_bias_y_mps2,accel_bias_z_mps2\n");
    for r in rows {
        let t = &r.traj;
        let [n, e, d] = t.ned_m;
        let [vn, ve, vd] = t.v_mps;
        let [ro, pi, he] = t.rph_deg;
        let [sn, se, sd] = r.sigma_p_m;
        let [svn, sve, svd] = r.sigma_v_mps;
        let [sr, sp, sh] = r.sigma_att_deg;
        let [gx, gy, gz] = r.gyro_bias_radps;
        let [ax, ay, az] = r.accel_bias_mps2;
        s.push_str(&format!(
            "{:.3},{n:.4},{e:.4},{d:.4},{vn:.5},{ve:.5},{vd:.5},{ro:.6},{pi:.6},{he:.6},{sn:.4},{se:.4},{sd:.4},{svn:.5},{sve:.5},{svd:.5},{sr:.6},{sp:.6},{sh:.6},{},{},{},{gx:.7},{gy:.7},{gz:.7},{ax:.6},{ay:.6},{az:.6}\n",
            t.t_s,
            u8::from(r.fix),
            u8::from(r.still),
            u8::from(r.zupt)
        ));
    }
    s
}
