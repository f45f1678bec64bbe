//! The aided navigator, one IMU sample at a time: the strapdown
//! mechanization of the spinning sensor ([`crate::strapdown`]), the
//! error-state Kalman filter ([`crate::eskf`]), GNSS fixes with the antenna
//! lever arm through the table angle, zero-velocity updates when the
//! vehicle stands still, closed loop. `no_std`, no heap, generic over the
//! float: the board runs it in f32, the host (`rins navigate --gnss`) in
//! f32 or f64, the same code.
//!
//! Frames: `s` the sensor (on the table), `b` the vehicle (the table's
//! base), `n` local NED. The table turns `s` about its axis `k` by the
//! encoder angle `theta`: `c_s_b = rot(k, theta)`, `c_b_n = c_s_n c_s_b^T`.
//!
//! **Zero velocity** is detected from the IMU with the table's own rotation
//! removed, by a SHOE-type test (Skog et al., "Zero-velocity detection: an
//! algorithm evaluation", IEEE T-BME 2010): over the last [`ZUPT_WINDOW`]
//! samples, the spread about their means of the base's rotation `w =
//! c_s_b (w_is_s - theta_dot k)` and of the specific force, each over its
//! per-sample noise (the sensor's white noise over the sample interval and
//! its quantisation: [`ZuptNoise`]), per degree of freedom:
//! `S = (sum |f_k - f_mean|^2 / sigma_f^2 + sum |w_k - w_mean|^2 /
//! sigma_w^2) / (6 W - 6)`, about 1 for a still ideal sensor; and the
//! mean rotation `|w_mean|` (a turn is smooth). Still is `S` under a
//! threshold learnt from the run's own still start (navigation starts at
//! rest) and `|w_mean|` under [`ZUPT_MEAN_GYRO_RADPS`] (or 1.5 times the
//! start's own, the gyro bias not yet estimated): the first
//! [`ZUPT_START_EVALS`] evaluations find the median `S` of the parked
//! vehicle (idle vibration, a hand's tremor; the median, not the largest:
//! a table spinning up at power-up shakes the first windows) and the
//! threshold is [`ZUPT_MARGIN`] times it, at least the noise's own 99.9 % bound and at
//! most what [`ZUPT_CAP_GYRO_RADPS`] and [`ZUPT_CAP_ACCEL_MPS2`] give (a
//! start that was not still must not teach it to call motion still). No
//! update is made while it learns. Each evaluation's statistic and verdict are
//! reported ([`AidedStep::still`], [`AidedNav::zupt_threshold`]). The
//! detector is evaluated, and the update made, every [`ZUPT_EVERY`]
//! samples (consecutive zero-velocity measurements 10 ms apart are not
//! independent; one every 0.1 s keeps the filter honest and the step
//! cheap); an evaluation that falls on a step that took a fix is made on
//! the next step, so that how the fixes' epochs fall against the sample
//! count never thins the updates.
//!
//! **Zero rotation**: a still base does not turn, so the gyros, the
//! table's rate (the encoder's) taken out, read the earth's rate; once per
//! still window (windows that do not overlap: independent measurements)
//! their mean is an update of the gyro biases and scale/misalignment
//! ([`crate::eskf::Eskf::update_rate`]). On a spinning table this is what
//! holds the gyro along the axis, whose bias and scale error times the
//! table's rate turn the heading while the vehicle waits (0.9 deg/s on an
//! ICM-42688-P: 8 deg in a 10 s stop, which linearised updates then
//! spread into the level and the accelerometer biases when it drives
//! off), and it parts a bias across the axis, which tilts the level by
//! `bias / rate` in the sensor's frame, from an accelerometer bias that
//! the fixes cannot tell from that tilt.
//!
//! **GNSS fixes** come as a receiver gives them ([`GnssFix`]: latitude and
//! longitude in 1e-7 deg, height and velocity in mm, mm/s): the position
//! offset from the origin is formed from the integer difference (exact),
//! then scaled in f64 (correctly rounded on both the board's soft-float and
//! the host, so both get the same bits), then rounded once into `T`. A fix
//! is held until the next [`AidedNav::step`], which uses it after the
//! prediction to that sample (the caller hands it over before the sample
//! nearest its time). A second fix before a step replaces the first and is
//! counted ([`AidedCounts::fixes_replaced`]).

use crate::attitude::quat_to_dcm;
use crate::earth::{earth_rate_n, transport_rate_n, GeoPoint};
use crate::eskf::{Eskf, EskfConfig, FilterError, InitialSigma, Workspace, I_V, N};
use crate::real::Real;
use crate::strapdown::{ImuSample, Strapdown, StrapdownConfig};
use crate::table::{q_s_b, Axis, TableAngle};
use crate::NavError;
use nalgebra::{Matrix3, Quaternion, Vector3};

/// Samples the zero-velocity detector looks back over (0.5 s at 100 Hz).
pub const ZUPT_WINDOW: usize = 50;
/// Detector evaluations that learn the threshold from the still start
/// (3 s at 100 Hz: a parked car's or a held device's first seconds).
pub const ZUPT_START_EVALS: u32 = 30;
const START_EVALS: usize = ZUPT_START_EVALS as usize;
/// The threshold over the still start's largest statistic (the statistic
/// is a variance ratio: 3 is 1.7 times the amplitude).
pub const ZUPT_MARGIN: f64 = 3.0;
/// The most a still base may turn, rad/s (3 deg/s: a car idling, a hand
/// holding), and its specific force spread, m/s^2: the threshold's cap.
pub const ZUPT_CAP_GYRO_RADPS: f64 = 0.052;
/// See [`ZUPT_CAP_GYRO_RADPS`].
pub const ZUPT_CAP_ACCEL_MPS2: f64 = 0.3;
/// The mean rotation under which the base may be still, rad/s (0.5
/// deg/s: a car's slowest turns are faster).
pub const ZUPT_MEAN_GYRO_RADPS: f64 = 0.0087;
/// The statistic's 99.9 % bound for a still ideal sensor: a chi-square of
/// `6 W - 6` degrees of freedom per degree of freedom, `1 + 3.09
/// sqrt(2 / (6 W - 6))` (its normal approximation).
const ZUPT_NOISE_BOUND: f64 = 1.0 + 3.09 * 0.082_479;
/// Zero-velocity measurement 1-sigma at most, m/s (a window the detector
/// calls still whose own force wanders more is not quite still).
pub const ZUPT_SIGMA_MPS: f64 = 0.02;
/// Zero-velocity measurement 1-sigma at least, m/s: a parked vehicle's
/// rocking and a stance's sway slower than the detector's window, which
/// its force's wander over the window cannot show.
pub const ZUPT_FLOOR_MPS: f64 = 0.002;
/// The zero-rotation update's 1-sigma floor, rad/s: the earth's rate
/// lagging half a window behind a turning table in the window's mean
/// (`|w_ie| sin(rate T / 2)`, 1e-5 rad/s at 30 deg/s) and a parked
/// vehicle settling on its suspension, taken as 1e-4 rad/s (20 deg/h).
pub const ZARU_FLOOR_RADPS: f64 = 1e-4;
/// The detector runs, and a zero-velocity update is made, every this many
/// samples.
pub const ZUPT_EVERY: u32 = 10;
/// Predictions the filter gathers into one covariance propagation (0.1 s
/// at 100 Hz): the mechanization runs every sample, `P` every tenth (its
/// dense 36 x 36 products are most of the filter's cost; the error
/// dynamics change little in 0.1 s). A fix or zero-velocity update
/// propagates what is pending first.
pub const PREDICT_BATCH: u32 = 10;

/// Navigation states kept for fixes applied at their time of validity
/// (one a sample: 0.64 s at 100 Hz, beyond a receiver's and a link's
/// latency).
pub const HISTORY: usize = 64;

/// The share of a fix's reported variance the filter takes as correlated
/// over a minute (the rest white): automotive receivers' errors are half
/// multipath and atmosphere. hal-sim's receiver is built the same way, so
/// on simulated runs the NEES tests the filter's algebra and tuning, not
/// this assumption.
pub const GNSS_CORR_SHARE: f64 = 0.5;

/// A navigator told to size its receiver from its fixes
/// ([`AidedConfig::receiver_from_fixes`]) does so from this many: their
/// stated sigmas' medians, one fix that states too little or too much
/// never deciding it (0.16 s of a 100 Hz receiver... 16 s of a 1 Hz one).
pub const SIZE_FIXES: usize = 16;

/// The correlated GNSS error's 1-sigma (horizontal, vertical, m) for a
/// receiver whose fixes state `median_h_m` and `median_v_m` (their
/// medians): its share [`GNSS_CORR_SHARE`] of their variance, so that an
/// RTK receiver's centimetres and a phone's metres each get their own.
pub fn gnss_corr_sigma_m(median_h_m: f64, median_v_m: f64) -> [f64; 2] {
    let k = libm::sqrt(GNSS_CORR_SHARE);
    [k * median_h_m, k * median_v_m]
}

/// A fix's white 1-sigma, m, given its stated 1-sigma `sigma_m` and the
/// correlated error state's `corr_m`: the rest of the fix's variance,
/// `sqrt(sigma^2 - corr^2)`, so a fix enters with the variance its
/// receiver states (an RTK float fix among fixed ones keeps its
/// decimetres; the correlated state is sized on the median fix), and
/// never below its [`GNSS_CORR_SHARE`]-complement, `sqrt(1 - share)`
/// sigma (a fix better than the median).
pub fn white_sigma_m(sigma_m: f64, corr_m: f64) -> f64 {
    let floor = (1.0 - GNSS_CORR_SHARE) * sigma_m * sigma_m;
    libm::sqrt((sigma_m * sigma_m - corr_m * corr_m).max(floor))
}

/// Consecutive fixes whose position the gate refused, agreeing among
/// themselves, after which the navigator re-initialises its position and
/// velocity from the last ([`AidedCounts::reinits`]): three fixes (3 s at
/// 1 Hz) tell a lost filter from one bad fix.
pub const REINIT_FIXES: usize = 3;

/// The most a still window's zero velocity may disagree with the filter's
/// own velocity: the hypothesis's NIS over three degrees of freedom
/// (`v^T (P_v + R)^-1 v`, `R` the update's own variance), chi-square(3)'s
/// 1e-6 tail. The spread test alone calls a smooth pull-away from a stop
/// still (a steady push has no spread); a filter that knows it moves at
/// 1.5 m/s +- 6 mm/s is not parked.
pub const STILL_VELOCITY_NIS: f64 = 30.66;

/// The slack of the agreement test, in sigmas of the two fixes' combined
/// horizontal error.
pub const REINIT_AGREE_SIGMA: f64 = 3.0;

/// The velocity sigma a re-initialisation from position-only fixes falls
/// back to when their positions give no velocity, m/s (a car's speed).
pub const REINIT_NO_VEL_SIGMA_MPS: f64 = 30.0;

/// The largest acceleration a vehicle's position-only fixes may show and
/// still agree among themselves, m/s^2 (hard braking).
pub const REINIT_MAX_ACCEL_MPS2: f64 = 8.0;

/// A receiver's fix in its own integer units (the u-blox NAV-PVT style the
/// command link carries): WGS-84 position of the antenna, NED velocity,
/// the receiver's 1-sigma accuracies.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GnssFix {
    /// Latitude, 1e-7 deg.
    pub lat_e7: i32,
    /// Longitude, 1e-7 deg.
    pub lon_e7: i32,
    /// Height above the ellipsoid, mm.
    pub height_mm: i32,
    /// Velocity north, east, down, mm/s (ignored in a position-only fix).
    pub v_n_mmps: [i32; 3],
    /// Horizontal position 1-sigma, mm.
    pub sigma_h_mm: u32,
    /// Vertical position 1-sigma, mm.
    pub sigma_v_mm: u32,
    /// Velocity 1-sigma (each axis), mm/s; 0: a position-only fix (no
    /// velocity measured).
    pub sigma_vel_mmps: u32,
}

impl GnssFix {
    /// Whether the fix measured velocity.
    pub fn has_velocity(&self) -> bool {
        self.sigma_vel_mmps > 0
    }
}

impl GnssFix {
    /// From SI values (host side: `gnss.csv`), rounded to the receiver's
    /// units (1e-7 deg is 11 mm, far below a fix's metres). Non-finite or
    /// out-of-range values saturate (the filter then refuses or gates the
    /// fix: counted).
    #[allow(clippy::too_many_arguments)]
    pub fn from_si(
        lat_deg: f64,
        lon_deg: f64,
        height_m: f64,
        v_n_mps: [f64; 3],
        sigma_h_m: f64,
        sigma_v_m: f64,
        sigma_vel_mps: f64,
    ) -> Self {
        let i = |x: f64| libm::round(x) as i32;
        let u = |x: f64| libm::round(x) as u32;
        Self {
            lat_e7: i(lat_deg * 1e7),
            lon_e7: i(lon_deg * 1e7),
            height_mm: i(height_m * 1e3),
            v_n_mmps: v_n_mps.map(|v| i(v * 1e3)),
            sigma_h_mm: u(sigma_h_m * 1e3),
            sigma_v_mm: u(sigma_v_m * 1e3),
            sigma_vel_mmps: u(sigma_vel_mps * 1e3),
        }
    }
}

/// The navigation origin in a receiver's units (so a fix's offset from it
/// is an exact integer difference).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OriginE7 {
    /// Latitude, 1e-7 deg.
    pub lat_e7: i32,
    /// Longitude, 1e-7 deg.
    pub lon_e7: i32,
    /// Height above the ellipsoid, mm.
    pub height_mm: i32,
}

impl OriginE7 {
    /// From degrees and metres, rounded to 1e-7 deg and 1 mm.
    pub fn from_deg(lat_deg: f64, lon_deg: f64, height_m: f64) -> Self {
        let f = GnssFix::from_si(lat_deg, lon_deg, height_m, [0.0; 3], 0.0, 0.0, 0.0);
        Self {
            lat_e7: f.lat_e7,
            lon_e7: f.lon_e7,
            height_mm: f.height_mm,
        }
    }

    /// The origin as a geodetic point (rad, m).
    pub fn point(&self) -> GeoPoint {
        GeoPoint::from_deg(
            f64::from(self.lat_e7) * 1e-7,
            f64::from(self.lon_e7) * 1e-7,
            f64::from(self.height_mm) * 1e-3,
        )
    }
}

/// How to aid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AidedConfig {
    /// The filter's noise model.
    pub eskf: EskfConfig,
    /// The filter's initial 1-sigma.
    pub initial: InitialSigma,
    /// The table axis in `s`.
    pub axis: Axis,
    /// Antenna position from the table's centre, in `b`, m.
    pub antenna_b_m: [f64; 3],
    /// Make zero-velocity updates.
    pub zupt: bool,
    /// The detector's per-sample noise.
    pub zupt_noise: ZuptNoise,
    /// How long before its time of validity a fix's velocity was valid,
    /// horizontal (north, east) and vertical, s (>= 0; 0: a Doppler
    /// velocity at the epoch). A receiver that forms its velocity from its
    /// positions or filters it reports a mean over the past: the fix's
    /// velocity is compared with the stored state that long before its
    /// position's time. Within the [`HISTORY`] (beyond it, the oldest
    /// stored state is taken).
    pub velocity_lag_s: [f64; 2],
    /// Size the receiver's correlated error (`eskf.gnss_corr_sigma_m`,
    /// the configuration's until then) from the first [`SIZE_FIXES`]
    /// fixes' stated sigmas ([`gnss_corr_sigma_m`] of their medians): a
    /// board knows its receiver only by its fixes. A correlated state
    /// sized for metres beside centimetre fixes takes an outage's error
    /// as the receiver's (0.4 m for minutes after a 60 s outage on a
    /// simulated drive with 2 cm fixes). The host sizes it from all the
    /// fixes before it starts, and sets this false.
    pub receiver_from_fixes: bool,
}

/// The per-sample noise the zero-velocity detector measures against: the
/// sensor's white noise over its sample interval and its quantisation
/// (`sqrt(N^2 / dt + lsb^2 / 12)`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZuptNoise {
    /// Specific force, 1-sigma per sample and axis, m/s^2.
    pub sigma_f_mps2: f64,
    /// Rotation rate, 1-sigma per sample and axis, rad/s.
    pub sigma_w_radps: f64,
    /// The table rate's error averaged over a window, 1-sigma, rad/s
    /// ([`table_rate_sigma_radps`]; 0 without a table).
    pub sigma_table_rate_radps: f64,
}

/// The table rate's 1-sigma error averaged over the detector's window
/// (rad/s), the encoder's angle read with 1-sigma `read_sigma_rad` (a
/// quantum `q`'s is `q / sqrt(12)`) and the IMU sampled at `rate_hz`: the
/// window's mean rate is its two ends' angle difference over its length,
/// `sqrt(2) sigma / T`.
pub fn table_rate_sigma_radps(read_sigma_rad: f64, rate_hz: f64) -> f64 {
    let t = ZUPT_WINDOW as f64 / rate_hz;
    core::f64::consts::SQRT_2 * read_sigma_rad / t
}

/// What the navigator has counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AidedCounts {
    /// Samples the mechanization refused (non-finite, gaps).
    pub steps_refused: u32,
    /// Zero-velocity updates made.
    pub zupts: u32,
    /// Zero-rotation updates made (one per still window).
    pub zarus: u32,
    /// Fixes used (at least one component).
    pub fixes_used: u32,
    /// Fixes replaced by a newer one before a step could use them.
    pub fixes_replaced: u32,
    /// Corrections the mechanization refused.
    pub corrections_refused: u32,
    /// Re-initialisations of position and velocity from fixes the gate
    /// refused [`REINIT_FIXES`] times in a row while they agreed among
    /// themselves.
    pub reinits: u32,
    /// Re-initialisations of the vertical channel alone: the refused
    /// fixes' heights, while their horizontal positions were taken (a
    /// MEMS's unaided vertical channel lost in an outage).
    pub height_reinits: u32,
    /// Windows the detector called still that the filter's own velocity
    /// refuted ([`STILL_VELOCITY_NIS`]): no zero-velocity or zero-rotation
    /// update made.
    pub still_refuted: u32,
}

/// The aided navigator's solution at a sample ([`AidedNav::solution`]):
/// the base's attitude, position and velocity and their 1-sigma.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Solution<T: Real> {
    /// The sample's time, µs.
    pub t_us: u64,
    /// The base's attitude `q_b_n` (the table's turn taken out).
    pub q_b_n: Quaternion<T>,
    /// Roll, pitch, heading of `b` in `n` (ZYX), rad.
    pub euler: crate::attitude::Euler<T>,
    /// Position offsets from the origin, north, east, down (curvilinear,
    /// as [`crate::strapdown::NavState::p_n`]), m.
    pub p_n: Vector3<T>,
    /// Velocity, NED, m/s.
    pub v_n: Vector3<T>,
    /// Position 1-sigma, north, east, down, m.
    pub sigma_p_m: [T; 3],
    /// Velocity 1-sigma, NED, m/s.
    pub sigma_v_mps: [T; 3],
    /// Roll, pitch, heading 1-sigma, rad
    /// ([`crate::attitude::euler_sigma`]).
    pub sigma_euler_rad: [T; 3],
}

/// What one step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AidedStep<T: Real> {
    /// A fix was processed at this sample: its position update's NIS and
    /// the components used.
    pub fix: Option<(T, u8)>,
    /// The velocity update of the fix processed at the sample before: its
    /// NIS and components used (a fix's two updates take two samples: see
    /// [`AidedNav::step`]).
    pub fix_velocity: Option<(T, u8)>,
    /// The fix processed at this sample had both horizontal components
    /// taken by the gate (false without a fix).
    pub fix_horizontal_taken: bool,
    /// The detector said still (evaluated every [`ZUPT_EVERY`] samples; the
    /// last verdict).
    pub still: bool,
    /// A zero-velocity update was made at this sample.
    pub zupt: bool,
    /// A zero-rotation update was made at this sample.
    pub zaru: bool,
}

/// The aided navigator.
#[derive(Clone, Debug)]
pub struct AidedNav<T: Real, const M: usize = N> {
    nav: Strapdown<T>,
    /// The filter (its covariance, estimates and counters).
    pub kf: Eskf<T, M>,
    cfg: AidedConfig,
    origin: OriginE7,
    lever_b: Vector3<T>,
    /// The last samples' rotation and specific force, a ring.
    window: [Seen<T>; ZUPT_WINDOW],
    /// The detector's threshold (learnt from the still start), the
    /// start's largest statistic and mean rotation so far, the mean
    /// rotation's limit.
    zupt_gamma: T,
    start_stats: [T; START_EVALS],
    start_rots: [T; START_EVALS],
    rot_limit: T,
    evals: u32,
    head: usize,
    filled: usize,
    steps: u32,
    still: bool,
    /// A detector evaluation is due (deferred past a step that took a fix).
    zupt_due: bool,
    /// The step of the last zero-rotation update (its windows do not
    /// overlap: each is an independent measurement).
    zaru_at: u32,
    /// The fix handed over, and its time of validity when it has one
    /// (two fields, not one `Option` of a pair: a pair's `None` is not all
    /// zeros, and a board's blank static belongs in `.bss`).
    pending: Option<GnssFix>,
    pending_at: Option<u64>,
    /// The last fix's velocity update, for the next sample: its
    /// innovation less the velocity its position update corrected (m/s,
    /// `n`), its 1-sigma (m/s), and whether one waits.
    vel_next_z: Vector3<T>,
    vel_next_sigma: Vector3<T>,
    vel_next: bool,
    /// A zero-velocity update waits for the next sample (decided with a
    /// zero-rotation update, made a sample after it: its measurement, the
    /// velocity then, is fresh; the zero-rotation's window mean would not
    /// be after a correction of the gyro bias).
    zupt_next: bool,
    /// The fixes the gate refused in a row (the last [`REINIT_FIXES`]).
    refused_fixes: [RefusedFix<T>; REINIT_FIXES],
    refused_run: usize,
    /// The last [`HISTORY`] states (a ring, by sample).
    past: [Past<T>; HISTORY],
    /// Every velocity correction fed back so far, summed (m/s, `n`): a
    /// stored state's velocity plus what was added since is the state's
    /// velocity then as the filter now has it.
    dv_sum: Vector3<T>,
    /// Every position correction fed back so far, summed (m, `n`): as
    /// `dv_sum`, for a fix handed after other corrections were made
    /// since its time of validity (the board's fixes wait out a horizon
    /// longer than their interval).
    dp_sum: Vector3<T>,
    past_head: usize,
    /// The first fixes' stated sigmas (horizontal, vertical, mm) while
    /// the receiver is sized from them, and how many.
    fix_sigmas: [[u32; 2]; SIZE_FIXES],
    fix_sigmas_n: usize,
    /// What has been counted.
    pub counts: AidedCounts,
}

/// A fix whose position the gate refused: its time of validity (µs), the
/// antenna's position and velocity in `n` (m, m/s), its horizontal sigma
/// (m).
#[derive(Clone, Copy, Debug, Default)]
struct RefusedFix<T: Real> {
    t_us: u64,
    p_n: Vector3<T>,
    /// Zero for a position-only fix.
    v_n: Vector3<T>,
    sigma_h: T,
    has_vel: bool,
    /// Its horizontal position was refused too (else its height alone).
    horizontal: bool,
}

impl RefusedFix<f32> {
    const BLANK: Self = Self {
        t_us: 0,
        p_n: crate::real::zeros_f32(),
        v_n: crate::real::zeros_f32(),
        sigma_h: 0.0,
        has_vel: false,
        horizontal: false,
    };
}

/// The median of the first `n` of `v` (the upper one of an even count).
/// An insertion sort of at most [`START_EVALS`] values: core's sorts can
/// panic on an inconsistent order (NaN), and a board has no panic path.
fn median<T: Real>(v: &[T; START_EVALS], n: usize) -> T {
    let mut w = *v;
    let n = n.min(START_EVALS);
    for i in 1..n {
        let mut j = i;
        while j > 0 {
            match (w.get(j - 1).copied(), w.get(j).copied()) {
                (Some(a), Some(b)) if b < a => w.swap(j - 1, j),
                _ => break,
            }
            j -= 1;
        }
    }
    w.get(n / 2).copied().unwrap_or(T::zero())
}

/// Two fixes with velocity agree: `b` where `a`, moved at their mean
/// velocity, says, within [`REINIT_AGREE_SIGMA`] of their combined
/// horizontal sigma plus their velocities' own disagreement over the
/// interval.
fn agree<T: Real>(a: &RefusedFix<T>, b: &RefusedFix<T>) -> bool {
    let dt = T::lit(b.t_us.saturating_sub(a.t_us) as f64 * 1e-6);
    let d = b.p_n - a.p_n - (a.v_n + b.v_n) * (T::lit(0.5) * dt);
    let dv = (b.v_n - a.v_n).xy().norm() * dt;
    let tol =
        T::lit(REINIT_AGREE_SIGMA) * (a.sigma_h * a.sigma_h + b.sigma_h * b.sigma_h).sqrt_cr();
    d.xy().norm() <= tol + dv
}

/// Three position-only fixes agree: the velocity change their positions
/// imply is within [`REINIT_AGREE_SIGMA`] of what their sigmas allow plus
/// what [`REINIT_MAX_ACCEL_MPS2`] allows over the intervals.
fn agree_positions<T: Real>(a: &RefusedFix<T>, b: &RefusedFix<T>, c: &RefusedFix<T>) -> bool {
    let dt1 = b.t_us.saturating_sub(a.t_us) as f64 * 1e-6;
    let dt2 = c.t_us.saturating_sub(b.t_us) as f64 * 1e-6;
    if dt1 <= 0.0 || dt2 <= 0.0 {
        return false;
    }
    let v1 = (b.p_n - a.p_n) / T::lit(dt1);
    let v2 = (c.p_n - b.p_n) / T::lit(dt2);
    let (sa, sb, sc) = (a.sigma_h.to_f64(), b.sigma_h.to_f64(), c.sigma_h.to_f64());
    let s = libm::sqrt(
        (sa / dt1) * (sa / dt1)
            + (sb * (1.0 / dt1 + 1.0 / dt2)) * (sb * (1.0 / dt1 + 1.0 / dt2))
            + (sc / dt2) * (sc / dt2),
    );
    let tol = REINIT_AGREE_SIGMA * s + REINIT_MAX_ACCEL_MPS2 * 0.5 * (dt1 + dt2);
    (v2 - v1).xy().norm().to_f64() <= tol
}

/// One sample as the zero-velocity detector keeps it: the rotation with
/// the table's removed and the specific force, in the base's frame and in
/// the sensor's (rad/s, m/s^2); in the sensor's frame the gyros as read,
/// not corrected, with the table's rate (rad/s) apart: a window's mean is
/// corrected with the estimate in force when it is used, not with the
/// several in force while it filled.
#[derive(Clone, Copy, Debug, Default)]
struct Seen<T: Real> {
    w_b: Vector3<T>,
    f_b: Vector3<T>,
    w_s: Vector3<T>,
    f_s: Vector3<T>,
    table_rate: T,
}

impl Seen<f32> {
    const BLANK: Self = Self {
        w_b: crate::real::zeros_f32(),
        f_b: crate::real::zeros_f32(),
        w_s: crate::real::zeros_f32(),
        f_s: crate::real::zeros_f32(),
        table_rate: 0.0,
    };
}

/// A stored navigation state: what a fix's innovation needs at its time
/// of validity.
#[derive(Clone, Copy, Debug)]
struct Past<T: Real> {
    t_us: u64,
    p_n: Vector3<T>,
    v_n: Vector3<T>,
    c_b_n: Matrix3<T>,
    w_ib_b: Vector3<T>,
    /// [`AidedNav`]'s sum of velocity corrections when it was stored.
    dv_sum: Vector3<T>,
    /// Its sum of position corrections then.
    dp_sum: Vector3<T>,
}

impl Past<f32> {
    const BLANK: Self = Self {
        t_us: 0,
        p_n: crate::real::zeros_f32(),
        v_n: crate::real::zeros_f32(),
        c_b_n: crate::real::zeros_f32(),
        w_ib_b: crate::real::zeros_f32(),
        dv_sum: crate::real::zeros_f32(),
        dp_sum: crate::real::zeros_f32(),
    };
}

impl AidedConfig {
    /// All zeros (a blank navigator's, until its restart).
    pub const ZERO: Self = Self {
        eskf: EskfConfig {
            gyro_arw: 0.0,
            accel_vrw: 0.0,
            gyro_bias_init_sigma: 0.0,
            gyro_bias_sigma: 0.0,
            gyro_bias_tau_s: 0.0,
            accel_bias_init_sigma: 0.0,
            accel_bias_sigma: 0.0,
            accel_bias_tau_s: 0.0,
            gate_sigma: 0.0,
            gyro_scale_sigma: 0.0,
            gyro_misalignment_sigma: 0.0,
            warmup: crate::eskf::WarmupDrift::NONE,
            accel_scale_sigma: 0.0,
            accel_misalignment_sigma: 0.0,
            gnss_corr_sigma_m: [0.0; 2],
            gnss_corr_tau_s: 0.0,
        },
        initial: InitialSigma {
            position_m: 0.0,
            velocity_mps: 0.0,
            level_rad: 0.0,
            heading_rad: 0.0,
        },
        axis: Axis::X,
        antenna_b_m: [0.0; 3],
        zupt: false,
        zupt_noise: ZuptNoise {
            sigma_f_mps2: 0.0,
            sigma_w_radps: 0.0,
            sigma_table_rate_radps: 0.0,
        },
        velocity_lag_s: [0.0; 2],
        receiver_from_fixes: false,
    };
}

impl AidedNav<f32> {
    /// A navigator not yet started: all zeros in a `const`, a board's
    /// static in `.bss` (no flash for its initial value), started in place
    /// with [`Self::restart`] (never a 12 KiB value on a stack). Not a
    /// navigator until then.
    pub const BLANK: Self = Self {
        nav: Strapdown::BLANK,
        kf: Eskf::blank(AidedConfig::ZERO.eskf, 0),
        cfg: AidedConfig::ZERO,
        origin: OriginE7 {
            lat_e7: 0,
            lon_e7: 0,
            height_mm: 0,
        },
        lever_b: crate::real::zeros_f32(),
        window: [Seen::BLANK; ZUPT_WINDOW],
        zupt_gamma: 0.0,
        start_stats: [0.0; START_EVALS],
        start_rots: [0.0; START_EVALS],
        rot_limit: 0.0,
        evals: 0,
        head: 0,
        filled: 0,
        steps: 0,
        still: false,
        zupt_due: false,
        zaru_at: 0,
        pending: None,
        pending_at: None,
        vel_next_z: Vector3::new(0.0, 0.0, 0.0),
        vel_next_sigma: Vector3::new(0.0, 0.0, 0.0),
        vel_next: false,
        zupt_next: false,
        refused_fixes: [RefusedFix::BLANK; REINIT_FIXES],
        refused_run: 0,
        past: [Past::BLANK; HISTORY],
        dv_sum: crate::real::zeros_f32(),
        dp_sum: crate::real::zeros_f32(),
        past_head: 0,
        fix_sigmas: [[0; 2]; SIZE_FIXES],
        fix_sigmas_n: 0,
        counts: AidedCounts {
            steps_refused: 0,
            zupts: 0,
            zarus: 0,
            fixes_used: 0,
            fixes_replaced: 0,
            corrections_refused: 0,
            reinits: 0,
            height_reinits: 0,
            still_refuted: 0,
        },
    };
}

impl<T: Real> Default for Past<T> {
    fn default() -> Self {
        Self {
            t_us: u64::MAX,
            p_n: Vector3::zeros(),
            v_n: Vector3::zeros(),
            c_b_n: Matrix3::identity(),
            w_ib_b: Vector3::zeros(),
            dv_sum: Vector3::zeros(),
            dp_sum: Vector3::zeros(),
        }
    }
}

/// Why a fix with a time of validity was not taken.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FixAge {
    /// Older than the stored states.
    TooOld,
    /// Later than the next sample.
    FromTheFuture,
}

/// The table's rotation `c_s_b` (rad in, DCM out).
fn c_s_b<T: Real>(axis: Axis, angle: &TableAngle<T>) -> Matrix3<T> {
    quat_to_dcm(&q_s_b(axis, angle.rad))
}

impl<T: Real, const M: usize> AidedNav<T, M> {
    /// Starts at `origin` at rest, the vehicle's attitude `q_b_n` (`b` to
    /// `n`), the table at `table`, with the first raw sample.
    ///
    /// # Errors
    /// What [`Strapdown::new`] refuses.
    pub fn new(
        strapdown: StrapdownConfig,
        origin: OriginE7,
        q_b_n: &Quaternion<T>,
        table: &TableAngle<T>,
        first: &ImuSample<T>,
        cfg: AidedConfig,
    ) -> Result<Self, NavError> {
        let q_s_n = q_b_n * q_s_b(cfg.axis, table.rad);
        let nav = Strapdown::new(strapdown, origin.point(), Vector3::zeros(), q_s_n, first)?;
        let mut kf = Eskf::new(cfg.eskf, &cfg.initial);
        kf.batch = PREDICT_BATCH;
        Ok(Self {
            nav,
            kf,
            cfg,
            origin,
            lever_b: Vector3::from(cfg.antenna_b_m).map(T::lit),
            window: [Seen::default(); ZUPT_WINDOW],
            zupt_gamma: T::zero(),
            start_stats: [T::zero(); START_EVALS],
            start_rots: [T::zero(); START_EVALS],
            rot_limit: T::zero(),
            evals: 0,
            head: 0,
            filled: 0,
            steps: 0,
            still: false,
            zupt_due: false,
            zaru_at: 0,
            pending: None,
            pending_at: None,
            vel_next_z: Vector3::zeros(),
            vel_next_sigma: Vector3::zeros(),
            vel_next: false,
            zupt_next: false,
            refused_fixes: [RefusedFix::default(); REINIT_FIXES],
            refused_run: 0,
            past: [Past::default(); HISTORY],
            dv_sum: Vector3::zeros(),
            dp_sum: Vector3::zeros(),
            past_head: 0,
            fix_sigmas: [[0; 2]; SIZE_FIXES],
            fix_sigmas_n: 0,
            counts: AidedCounts::default(),
        })
    }

    /// Starts again in place, as [`Self::new`] would (on a board the
    /// navigator is a static of 12 KiB: no copy of it is built on the
    /// stack).
    ///
    /// # Errors
    /// What [`Strapdown::new`] refuses (the navigator is left as it was).
    #[inline(never)]
    pub fn restart(
        &mut self,
        strapdown: StrapdownConfig,
        origin: OriginE7,
        q_b_n: &Quaternion<T>,
        table: &TableAngle<T>,
        first: &ImuSample<T>,
        cfg: AidedConfig,
    ) -> Result<(), NavError> {
        let q_s_n = q_b_n * q_s_b(cfg.axis, table.rad);
        self.nav = Strapdown::new(strapdown, origin.point(), Vector3::zeros(), q_s_n, first)?;
        self.kf.reset(cfg.eskf, &cfg.initial);
        self.kf.batch = PREDICT_BATCH;
        self.cfg = cfg;
        self.origin = origin;
        self.lever_b = Vector3::from(cfg.antenna_b_m).map(T::lit);
        self.window.fill(Seen::default());
        self.head = 0;
        self.filled = 0;
        self.steps = 0;
        self.still = false;
        self.zupt_due = false;
        self.zaru_at = 0;
        self.zupt_gamma = T::zero();
        self.start_stats.fill(T::zero());
        self.start_rots.fill(T::zero());
        self.rot_limit = T::zero();
        self.evals = 0;
        self.pending = None;
        self.pending_at = None;
        self.vel_next = false;
        self.zupt_next = false;
        self.refused_fixes.fill(RefusedFix::default());
        self.refused_run = 0;
        self.past.fill(Past::default());
        self.dv_sum = Vector3::zeros();
        self.dp_sum = Vector3::zeros();
        self.past_head = 0;
        self.fix_sigmas_n = 0;
        self.counts = AidedCounts::default();
        Ok(())
    }

    /// Starts a vehicle that is already moving: the velocity set to
    /// `v_n` (m/s, NED; the fixes' at the start) and its 1-sigma to
    /// `sigma_mps` (m/s, each axis), uncorrelated (the navigator starts
    /// at rest otherwise).
    pub fn start_moving(&mut self, v_n: &Vector3<T>, sigma_mps: T) {
        let dv = v_n - self.nav.state().v_n;
        if self
            .nav
            .correct(&Vector3::zeros(), &dv, &Vector3::zeros())
            .is_err()
        {
            self.counts.corrections_refused = self.counts.corrections_refused.saturating_add(1);
        }
        for i in crate::eskf::I_V..crate::eskf::I_V + 3 {
            for j in 0..M {
                for idx in [(i, j), (j, i)] {
                    if let Some(x) = self.kf.p.get_mut(idx) {
                        *x = T::zero();
                    }
                }
            }
            if let Some(x) = self.kf.p.get_mut((i, i)) {
                *x = sigma_mps * sigma_mps;
            }
        }
    }

    /// The base's rotation at the last sample, the table's and the
    /// estimated errors taken out, rad/s in `b`.
    pub fn w_ib_b(&self) -> Vector3<T> {
        let last = (self.past_head + HISTORY - 1) % HISTORY;
        self.past
            .get(last)
            .map_or_else(Vector3::zeros, |p| p.w_ib_b)
    }

    /// The mechanization (its state: position offsets, velocity, `q_s_n`).
    pub fn nav(&self) -> &Strapdown<T> {
        &self.nav
    }

    /// The vehicle's attitude `c_b_n` with the table at `table`.
    pub fn c_b_n(&self, table: &TableAngle<T>) -> Matrix3<T> {
        quat_to_dcm(&self.nav.state().q_s_n) * c_s_b(self.cfg.axis, table).transpose()
    }

    /// The navigator's own solution with the table at `table`: what the
    /// CLI writes and the board sends, from one place.
    pub fn solution(&self, table: &TableAngle<T>) -> Solution<T> {
        let st = self.nav.state();
        let q_b_n = crate::table::q_b_n(&st.q_s_n, self.cfg.axis, table.rad);
        let euler = crate::attitude::quat_to_euler(&q_b_n);
        let sig = |i: usize| [self.kf.sigma(i), self.kf.sigma(i + 1), self.kf.sigma(i + 2)];
        let p_phi = Matrix3::from_fn(|r, c| {
            self.kf
                .p
                .get((crate::eskf::I_PHI + r, crate::eskf::I_PHI + c))
                .copied()
                .unwrap_or_else(T::zero)
        });
        Solution {
            t_us: st.t_us,
            q_b_n,
            euler,
            p_n: st.p_n,
            v_n: st.v_n,
            sigma_p_m: sig(crate::eskf::I_P),
            sigma_v_mps: sig(crate::eskf::I_V),
            sigma_euler_rad: crate::attitude::euler_sigma(&euler, &p_phi),
        }
    }

    /// Measurements of the base's velocity along unit vectors of `b`
    /// (a vehicle's constraints and odometer, [`crate::vehicle`]) at the
    /// current sample, the table at `table`: each `(e_b, value m/s,
    /// 1-sigma m/s)`, a scalar update through the gate, then the
    /// correction fed back. Made between [`Self::step`]s by a host; the
    /// board does not call it.
    ///
    /// # Errors
    /// A non-finite value or a sigma not positive (counted by the filter;
    /// the measurements before it are kept).
    pub fn update_base_velocity(
        &mut self,
        table: &TableAngle<T>,
        m: &[crate::vehicle::BaseVelocity<T>],
    ) -> Result<crate::eskf::UpdateReport<T>, FilterError> {
        let c_b_n = self.c_b_n(table);
        let v_n = self.nav.state().v_n;
        let mut rep = crate::eskf::UpdateReport::default();
        let mut err = None;
        for (i, bv) in m.iter().enumerate() {
            let (h, z) = bv.row::<M>(&c_b_n, &v_n);
            match self.kf.update_scalar(&h, z, bv.sigma_mps * bv.sigma_mps) {
                Ok(Some(nis)) => {
                    rep.nis += nis;
                    rep.used += 1;
                }
                Ok(None) => {
                    rep.rejected += 1;
                    rep.rejected_mask |= 1u8.checked_shl(i as u32).unwrap_or(0);
                }
                Err(e) => {
                    err = Some(e);
                    break;
                }
            }
        }
        let (dp, dv, phi) = self.kf.take_correction();
        if self.vel_next {
            self.vel_next_z -= dv;
        }
        self.feed_back(&dp, &dv, &phi);
        err.map_or(Ok(rep), Err)
    }

    /// Hands a fix over; the next [`Self::step`] uses it as valid at that
    /// step.
    pub fn gnss(&mut self, fix: &GnssFix) {
        self.pending_at = None;
        if self.pending.replace(*fix).is_some() {
            self.counts.fixes_replaced = self.counts.fixes_replaced.saturating_add(1);
        }
    }

    /// Hands over a fix valid at `t_valid_us` (the mechanization's clock),
    /// in the past: the next [`Self::step`] forms its innovation from the
    /// state stored for the sample nearest that time and corrects the
    /// present state with it (the error state changes little over the
    /// latency: position by the velocity error times it).
    ///
    /// # Errors
    /// A time older than the stored states, or after the next sample.
    pub fn gnss_at(&mut self, fix: &GnssFix, t_valid_us: u64) -> Result<(), FixAge> {
        // The next step's state is stored before the fix is used: a time
        // up to one sample interval ahead is in the stored states by then.
        let now = self.nav.state().t_us;
        // Saturating: a time near u64::MAX (a malformed log) is refused,
        // never an overflow.
        let half = self.half_period_us();
        if t_valid_us > now.saturating_add(half.saturating_mul(2)) {
            return Err(FixAge::FromTheFuture);
        }
        let oldest = self
            .past
            .iter()
            .map(|p| p.t_us)
            .filter(|t| *t != u64::MAX)
            .min()
            .unwrap_or(now);
        if t_valid_us.saturating_add(half) < oldest {
            return Err(FixAge::TooOld);
        }
        self.pending_at = Some(t_valid_us);
        if self.pending.replace(*fix).is_some() {
            self.counts.fixes_replaced = self.counts.fixes_replaced.saturating_add(1);
        }
        Ok(())
    }

    /// Half the last sample interval, µs (how far from a stored state a
    /// time of validity may be).
    fn half_period_us(&self) -> u64 {
        let a = self.past.get(self.past_head.wrapping_sub(1) % HISTORY);
        let b = self.past.get(self.past_head.wrapping_sub(2) % HISTORY);
        match (a, b) {
            (Some(a), Some(b)) if a.t_us != u64::MAX && b.t_us != u64::MAX => {
                a.t_us.saturating_sub(b.t_us) / 2
            }
            _ => 0,
        }
    }

    /// The stored state nearest `t_us`, carried to `t_us` so that its
    /// antenna moves as the fix's did: its position by its velocity and
    /// the antenna's turn about it, `(v_n + c_b_n (w_ib_b x l_b)) dt`,
    /// attitude and velocity as stored (a fix between two samples is
    /// compared with the track where it was taken, not up to half a
    /// sample off: 7 mm at a walk's 1.5 m/s and 100 Hz, a third of an RTK
    /// fix's sigma). Its position and velocity carry the corrections fed
    /// back since it was stored (`dp_sum`, `dv_sum`): a fix handed after
    /// others were used is compared with the state then as the filter now
    /// has it, and no correction is counted twice (its attitude is as
    /// stored: a correction since turns the antenna's arm by milliradians,
    /// millimetres).
    fn past_at(&self, t_us: u64) -> Option<Past<T>> {
        let p = self
            .past
            .iter()
            .filter(|p| p.t_us != u64::MAX)
            .min_by_key(|p| p.t_us.abs_diff(t_us))
            .copied()?;
        let dt_s = T::lit((t_us as f64 - p.t_us as f64) * 1e-6);
        let v_antenna = p.v_n + p.c_b_n * p.w_ib_b.cross(&self.lever_b);
        Some(Past {
            t_us,
            p_n: p.p_n + v_antenna * dt_s + (self.dp_sum - p.dp_sum),
            v_n: p.v_n + (self.dv_sum - p.dv_sum),
            dv_sum: self.dv_sum,
            dp_sum: self.dp_sum,
            ..p
        })
    }

    /// The antenna's velocity a fix's velocity is compared with (m/s, `n`):
    /// the stored state's ([`Self::past_at`], the corrections since
    /// included) at the fix's time less the receiver's velocity lag
    /// ([`AidedConfig::velocity_lag_s`]), horizontal and vertical each at
    /// its own; `at`'s where the lag is 0.
    fn fix_velocity_reference(&self, at: &Past<T>) -> Vector3<T> {
        let antenna = |p: &Past<T>| p.v_n + p.c_b_n * p.w_ib_b.cross(&self.lever_b);
        let back = |lag_s: f64| {
            // Saturating: a negative or NaN lag is 0.
            let us = (lag_s * 1e6) as u64;
            match us {
                0 => antenna(at),
                _ => self
                    .past_at(at.t_us.saturating_sub(us))
                    .map_or_else(|| antenna(at), |p| antenna(&p)),
            }
        };
        let [lag_h, lag_v] = self.cfg.velocity_lag_s;
        let h = back(lag_h);
        let v = back(lag_v);
        Vector3::new(h.x, h.y, v.z)
    }

    /// The fix's antenna position as offsets from the origin in the
    /// mechanization's coordinates (north, east, down, m).
    pub fn fix_position_n(&self, fix: &GnssFix) -> Vector3<T> {
        let e = self.nav.earth();
        let rad_per_e7 = core::f64::consts::PI / 180.0 * 1e-7;
        let dlat = i64::from(fix.lat_e7) - i64::from(self.origin.lat_e7);
        // The shorter way round in longitude (3.6e9 e7 units a turn).
        let dlon = (i64::from(fix.lon_e7) - i64::from(self.origin.lon_e7) + 1_800_000_000)
            .rem_euclid(3_600_000_000)
            - 1_800_000_000;
        let dh = i64::from(fix.height_mm) - i64::from(self.origin.height_mm);
        Vector3::new(
            T::lit(dlat as f64 * rad_per_e7 * e.rm_h0.to_f64()),
            T::lit(dlon as f64 * rad_per_e7 * e.rn_h0_cos.to_f64()),
            T::lit(-(dh as f64) * 1e-3),
        )
    }

    /// One IMU sample (raw: the filter's bias, scale and misalignment
    /// estimates are taken out here) with the table at `table` turning at
    /// `table_rate` (rad/s about its axis): mechanization, prediction, the
    /// pending fix, the zero-velocity update, the correction fed back.
    ///
    /// # Errors
    /// What [`Strapdown::step`] refuses (counted; the filter is not
    /// advanced and a pending fix waits for the next sample).
    pub fn step(
        &mut self,
        raw: &ImuSample<T>,
        table: &TableAngle<T>,
        table_rate: T,
    ) -> Result<AidedStep<T>, NavError> {
        self.step_opt(raw, table, table_rate, None)
    }

    /// [`Self::step`] with the filter's workspace passed in (a board's
    /// static: no 10 KiB of scratch on its stack).
    ///
    /// # Errors
    /// As [`Self::step`].
    pub fn step_in(
        &mut self,
        raw: &ImuSample<T>,
        table: &TableAngle<T>,
        table_rate: T,
        ws: &mut Workspace<T, M>,
    ) -> Result<AidedStep<T>, NavError> {
        self.step_opt(raw, table, table_rate, Some(ws))
    }

    #[inline(never)]
    fn step_opt(
        &mut self,
        raw: &ImuSample<T>,
        table: &TableAngle<T>,
        table_rate: T,
        mut ws: Option<&mut Workspace<T, M>>,
    ) -> Result<AidedStep<T>, NavError> {
        let s = ImuSample {
            t_us: raw.t_us,
            w_is_s: self.kf.correct_gyro(&raw.w_is_s),
            f_s: self.kf.correct_accel(&raw.f_s),
        };
        let t_prev = self.nav.state().t_us;
        if let Err(e) = self.nav.step(&s) {
            self.counts.steps_refused = self.counts.steps_refused.saturating_add(1);
            return Err(e);
        }
        let st = *self.nav.state();
        let e = self.nav.earth_here();
        let c_s_n = quat_to_dcm(&st.q_s_n);
        let w_ie = earth_rate_n(e.sin_lat, e.cos_lat);
        let w_en = transport_rate_n(&st.v_n, e.r_m, e.r_n, e.height_m, e.sin_lat / e.cos_lat);
        let dt = T::lit(st.t_us.saturating_sub(t_prev) as f64 * 1e-6);
        self.kf.predict_opt(
            &c_s_n,
            &(c_s_n * s.f_s),
            &w_ie,
            &w_en,
            &s.w_is_s,
            dt,
            ws.as_deref_mut(),
        );

        // The base's rotation and specific force, the table's removed.
        let csb = c_s_b(self.cfg.axis, table);
        let k = self.cfg.axis.unit::<T>();
        let w_ib_b = csb * (s.w_is_s - k * table_rate);
        if let Some(slot) = self.window.get_mut(self.head) {
            *slot = Seen {
                w_b: w_ib_b,
                f_b: csb * s.f_s,
                w_s: raw.w_is_s - k * table_rate,
                f_s: s.f_s,
                table_rate,
            };
        }
        self.head = (self.head + 1) % ZUPT_WINDOW;
        self.filled = (self.filled + 1).min(ZUPT_WINDOW);
        self.steps = self.steps.wrapping_add(1);

        let c_b_n = c_s_n * csb.transpose();
        let here = Past {
            t_us: st.t_us,
            p_n: st.p_n,
            v_n: st.v_n,
            c_b_n,
            w_ib_b,
            dv_sum: self.dv_sum,
            dp_sum: self.dp_sum,
        };
        if let Some(slot) = self.past.get_mut(self.past_head) {
            *slot = here;
        }
        self.past_head = (self.past_head + 1) % HISTORY;

        let mut out = AidedStep::default();
        let mut corrected = false;
        let mut vel_set = false;
        if self.vel_next {
            // The last fix's velocity, one sample after its position: the
            // two updates of one fix never share a sample with each other
            // (each is a propagation and three scalar updates; together
            // they made a board's worst sample). A new fix waits a sample.
            out.fix_velocity = self.velocity_next(ws.as_deref_mut());
            corrected = true;
        } else if self.zupt_next {
            // Likewise the zero-velocity update decided with the last
            // zero-rotation update.
            self.zupt_next = false;
            out.zupt = self.zero_velocity(&st.v_n, dt, ws.as_deref_mut());
            corrected = true;
        } else if let Some(fix) = self.pending.take() {
            let at = self.pending_at.take();
            let then = at.and_then(|t| self.past_at(t)).unwrap_or(here);
            let (nis, used, horizontal) = self.use_fix(&fix, &then, ws.as_deref_mut());
            out.fix = Some((nis, used));
            out.fix_horizontal_taken = horizontal;
            vel_set = self.vel_next;
            corrected = true;
        }
        // Not in a step that took a fix: its velocity update measured the
        // same thing, and the two together would double the step's worst
        // case on a board (a propagation and nine scalar updates).
        if self.steps.is_multiple_of(ZUPT_EVERY) {
            self.zupt_due = true;
        }
        if self.cfg.zupt && self.zupt_due && !corrected {
            self.zupt_due = false;
            self.still = self.filled == ZUPT_WINDOW && self.is_still();
            if self.still
                && self.evals > ZUPT_START_EVALS
                && !self.velocity_allows_still(&st.v_n, dt)
            {
                self.still = false;
                self.counts.still_refuted = self.counts.still_refuted.saturating_add(1);
            }
            if self.still && self.evals > ZUPT_START_EVALS {
                if self.steps.wrapping_sub(self.zaru_at) >= ZUPT_WINDOW as u32 {
                    self.zaru_at = self.steps;
                    let w_ie_s = c_s_n.transpose() * w_ie;
                    if self.zero_rotation(&w_ie_s, ws).is_ok() {
                        self.counts.zarus = self.counts.zarus.saturating_add(1);
                        out.zaru = true;
                    }
                    self.zupt_next = true;
                } else {
                    out.zupt = self.zero_velocity(&st.v_n, dt, ws);
                }
                corrected = true;
            }
        }
        out.still = self.still;
        if corrected {
            let (dp, dv, phi) = self.kf.take_correction();
            // The velocity update waiting for the next sample measures
            // against the state before this correction: what the position
            // update changed is taken out of its innovation (sequential
            // updates, the error state closed-loop in between).
            if vel_set {
                self.vel_next_z -= dv;
            }
            self.feed_back(&dp, &dv, &phi);
        }
        Ok(out)
    }

    /// Hands a correction to the mechanization (position m, velocity m/s,
    /// attitude rad, `n`), its velocity summed for the stored states
    /// (refused: counted, nothing summed).
    fn feed_back(&mut self, dp: &Vector3<T>, dv: &Vector3<T>, phi: &Vector3<T>) {
        if self.nav.correct(dp, dv, phi).is_err() {
            self.counts.corrections_refused = self.counts.corrections_refused.saturating_add(1);
        } else {
            self.dv_sum += dv;
            self.dp_sum += dp;
        }
    }

    /// A zero-velocity update against the velocity `v_n` (m/s, `n`) over a
    /// sample interval `dt` (s); whether it was made.
    #[inline(never)]
    fn zero_velocity(&mut self, v_n: &Vector3<T>, dt: T, ws: Option<&mut Workspace<T, M>>) -> bool {
        let sigma = Vector3::repeat(self.zupt_sigma(dt));
        let ok = self.kf.update_velocity_opt(&(-v_n), &sigma, ws).is_ok();
        if ok {
            self.counts.zupts = self.counts.zupts.saturating_add(1);
        }
        ok
    }

    /// Whether zero velocity is within [`STILL_VELOCITY_NIS`] of the
    /// filter's velocity `v_n` (m/s, `n`) and its covariance, with the
    /// zero-velocity update's own variance over samples `dt` s apart.
    fn velocity_allows_still(&self, v_n: &Vector3<T>, dt: T) -> bool {
        let r = self.zupt_sigma(dt);
        let s = self.kf.p.fixed_view::<3, 3>(I_V, I_V).into_owned()
            + Matrix3::from_diagonal_element(r * r);
        match s.cholesky() {
            Some(c) => v_n.dot(&c.solve(v_n)) <= T::lit(STILL_VELOCITY_NIS),
            None => false,
        }
    }

    /// The last fix's velocity update, waiting since the sample before:
    /// its NIS and components used.
    #[inline(never)]
    fn velocity_next(&mut self, ws: Option<&mut Workspace<T, M>>) -> Option<(T, u8)> {
        self.vel_next = false;
        let r = self
            .kf
            .update_velocity_opt(&self.vel_next_z, &self.vel_next_sigma, ws);
        r.ok().map(|r| (r.nis, r.used))
    }

    /// Position and velocity updates from `fix` against the state `at` its
    /// time of validity (antenna at `c_b_n l_b`, its velocity
    /// `v + c_b_n (w_ib_b x l_b)`); the white share of the
    /// reported variance is the measurement's, the rest the filter's
    /// correlated-error state. Returns (NIS, components used, both
    /// horizontal components taken).
    fn use_fix(
        &mut self,
        fix: &GnssFix,
        at: &Past<T>,
        mut ws: Option<&mut Workspace<T, M>>,
    ) -> (T, u8, bool) {
        self.size_receiver(fix);
        let l_n = at.c_b_n * self.lever_b;
        let zp = self.fix_position_n(fix) - (at.p_n + l_n);
        let v_ant = self.fix_velocity_reference(at);
        let v_fix = Vector3::from(fix.v_n_mmps).map(|v| T::lit(f64::from(v) * 1e-3));
        let zv = v_fix - v_ant;
        let [gh, gv] = self.kf.config().gnss_corr_sigma_m;
        let sp = Vector3::new(
            white_sigma_m(f64::from(fix.sigma_h_mm) * 1e-3, gh),
            white_sigma_m(f64::from(fix.sigma_h_mm) * 1e-3, gh),
            white_sigma_m(f64::from(fix.sigma_v_mm) * 1e-3, gv),
        )
        .map(T::lit);
        let sv = Vector3::repeat(T::lit(f64::from(fix.sigma_vel_mmps) * 1e-3));
        let (mut nis, mut used) = (T::zero(), 0u8);
        let mut add = |r: Result<crate::eskf::UpdateReport<T>, FilterError>| {
            if let Ok(r) = r {
                nis += r.nis;
                used += r.used;
            }
        };
        let rp = self
            .kf
            .update_position_opt(&zp, &l_n, &sp, ws.as_deref_mut());
        let refused = matches!(rp, Ok(r) if r.rejected > 0);
        let horizontal = matches!(rp, Ok(r) if r.rejected_mask & 0b011 == 0);
        add(rp);
        if fix.has_velocity() {
            (self.vel_next_z, self.vel_next_sigma, self.vel_next) = (zv, sv, true);
        }
        let _ = ws;
        if used > 0 || self.vel_next {
            self.counts.fixes_used = self.counts.fixes_used.saturating_add(1);
        }
        let sigma_h = T::lit(f64::from(fix.sigma_h_mm) * 1e-3);
        let seen = RefusedFix {
            t_us: at.t_us,
            p_n: zp + at.p_n + l_n,
            v_n: v_fix,
            sigma_h,
            has_vel: fix.has_velocity(),
            horizontal: !horizontal,
        };
        if self.lost_after(refused, seen) {
            let sigma_v = T::lit(f64::from(fix.sigma_v_mm) * 1e-3);
            let sp_all = Vector3::new(sigma_h, sigma_h, sigma_v);
            // A position-only fix: the velocity from the refused fixes'
            // own positions (the last two, over their interval), with
            // their combined sigma over it.
            let (zv, sv) = match fix.has_velocity() {
                true => (zv, T::lit(f64::from(fix.sigma_vel_mmps) * 1e-3)),
                false => self.refused_velocity().map_or(
                    (Vector3::zeros(), T::lit(REINIT_NO_VEL_SIGMA_MPS)),
                    |(v, s)| (v - v_ant, s),
                ),
            };
            // Only the height lost (every refused fix's horizontal
            // position taken): the vertical channel alone starts again;
            // the horizontal keeps its state and correlations.
            let height_only = !self.refused_fixes.iter().any(|f| f.horizontal);
            let axes = [!height_only, !height_only, true];
            self.kf.reinit_axes(&zp, &zv, &sp_all, sv, axes);
            // The re-initialisation took the fix's velocity.
            self.vel_next = false;
            let c = &mut self.counts;
            if height_only {
                c.height_reinits = c.height_reinits.saturating_add(1);
            } else {
                c.reinits = c.reinits.saturating_add(1);
            }
            self.refused_run = 0;
        }
        (nis, used, horizontal)
    }

    /// Keeps `fix`'s stated sigmas while the receiver is sized from its
    /// fixes ([`AidedConfig::receiver_from_fixes`]); at the
    /// [`SIZE_FIXES`]-th, sizes the correlated error from their medians
    /// ([`Eskf::size_gnss_corr`]).
    fn size_receiver(&mut self, fix: &GnssFix) {
        if !self.cfg.receiver_from_fixes || self.fix_sigmas_n >= SIZE_FIXES {
            return;
        }
        if let Some(slot) = self.fix_sigmas.get_mut(self.fix_sigmas_n) {
            *slot = [fix.sigma_h_mm, fix.sigma_v_mm];
        }
        self.fix_sigmas_n += 1;
        if self.fix_sigmas_n < SIZE_FIXES {
            return;
        }
        let mut h = self.fix_sigmas.map(|x| x[0]);
        let mut v = self.fix_sigmas.map(|x| x[1]);
        h.sort_unstable();
        v.sort_unstable();
        // The upper middle of an even count, as the zero-velocity
        // detector's median.
        let mid =
            |w: &[u32; SIZE_FIXES]| f64::from(w.get(SIZE_FIXES / 2).copied().unwrap_or(0)) * 1e-3;
        let (mh, mv) = (mid(&h), mid(&v));
        // A receiver that states no error: the configuration's kept.
        if mh > 0.0 && mv > 0.0 {
            self.kf.size_gnss_corr(gnss_corr_sigma_m(mh, mv));
        }
    }

    /// The velocity the last two refused fixes' positions imply (m/s, `n`)
    /// and its 1-sigma (their combined horizontal sigma over the interval).
    fn refused_velocity(&self) -> Option<(Vector3<T>, T)> {
        let k = self.refused_run;
        let at = |i: usize| self.refused_fixes.get((k + i) % REINIT_FIXES).copied();
        let (a, b) = (at(REINIT_FIXES - 2)?, at(REINIT_FIXES - 1)?);
        let dt = T::lit(b.t_us.checked_sub(a.t_us).filter(|d| *d > 0)? as f64 * 1e-6);
        let s = (a.sigma_h * a.sigma_h + b.sigma_h * b.sigma_h).sqrt_cr() / dt;
        Some(((b.p_n - a.p_n) / dt, s))
    }

    /// Keeps the run of fixes the gate refused; true when it holds
    /// [`REINIT_FIXES`] fixes that agree among themselves: each one's
    /// horizontal position where the one before, moved at the mean of
    /// their two velocities, says it should be, within
    /// [`REINIT_AGREE_SIGMA`] of their combined horizontal sigma plus
    /// their velocities' own disagreement over the interval.
    fn lost_after(&mut self, refused: bool, seen: RefusedFix<T>) -> bool {
        if !refused {
            self.refused_run = 0;
            return false;
        }
        if let Some(slot) = self.refused_fixes.get_mut(self.refused_run % REINIT_FIXES) {
            *slot = seen;
        }
        self.refused_run = self.refused_run.saturating_add(1);
        if self.refused_run < REINIT_FIXES {
            return false;
        }
        let k = self.refused_run;
        let at = |i: usize| self.refused_fixes.get((k + i) % REINIT_FIXES).copied();
        let pairs = (0..REINIT_FIXES - 1).all(|i| match (at(i), at(i + 1)) {
            (Some(a), Some(b)) if a.has_vel && b.has_vel => agree(&a, &b),
            (Some(_), Some(_)) => true,
            _ => false,
        });
        let triples =
            (0..REINIT_FIXES.saturating_sub(2)).all(|i| match (at(i), at(i + 1), at(i + 2)) {
                (Some(a), Some(b), Some(c)) if !(a.has_vel && b.has_vel && c.has_vel) => {
                    agree_positions(&a, &b, &c)
                }
                (Some(_), Some(_), Some(_)) => true,
                _ => false,
            });
        pairs && triples
    }

    /// The zero-rotation update on the still window: the gyros' mean in
    /// `s`, corrected with the estimate in force now, with the table's
    /// rate taken out (the window holds both: a mean of samples each
    /// corrected when it came mixes the estimates the window saw, and the
    /// fixes move them while it fills) against the earth's rate `w_ie_s`
    /// (rad/s, `s`), each axis's
    /// 1-sigma the mean's own (the window's scatter over `sqrt(W)`: a
    /// shaking base's), the white noise's, the table rate's along its axis
    /// and [`ZARU_FLOOR_RADPS`], in quadrature.
    #[inline(never)]
    fn zero_rotation(
        &mut self,
        w_ie_s: &Vector3<T>,
        ws: Option<&mut Workspace<T, M>>,
    ) -> Result<crate::eskf::UpdateReport<T>, FilterError> {
        let n = T::lit(ZUPT_WINDOW as f64);
        let (read, rate) = self
            .window
            .iter()
            .fold((Vector3::zeros(), T::zero()), |a: (Vector3<T>, T), x| {
                (a.0 + x.w_s, a.1 + x.table_rate)
            });
        let (read, rate) = (read / n, rate / n);
        let scatter = self
            .window
            .iter()
            .fold(Vector3::zeros(), |a: Vector3<T>, x| {
                a + (x.w_s - read).component_mul(&(x.w_s - read))
            });
        let zn = &self.cfg.zupt_noise;
        let k = self.cfg.axis.unit::<T>();
        // The window's mean rate with the table's, corrected with the
        // estimate in force now (the correction is linear in the rate).
        let w_s = self.kf.correct_gyro(&(read + k * rate));
        let white = T::lit(zn.sigma_w_radps * zn.sigma_w_radps / ZUPT_WINDOW as f64);
        let floor = T::lit(ZARU_FLOOR_RADPS * ZARU_FLOOR_RADPS);
        let enc = T::lit(zn.sigma_table_rate_radps * zn.sigma_table_rate_radps);
        let mean_var = (scatter / (n * (n - T::one()))).map(|v| v.max(white));
        let var = mean_var + k.component_mul(&k) * enc;
        let sigma = var.map(|v| (v + floor).sqrt_cr());
        self.kf
            .update_rate_opt(&(w_s - k * rate - w_ie_s), &w_s, &sigma, ws)
    }

    /// The zero-velocity update's 1-sigma, m/s: the velocity the window's
    /// own specific force wanders by about its mean (a rocking base's,
    /// rms per axis, over samples `dt_s` apart, in whichever of the
    /// base's and the sensor's frames it is smaller: as the detector's
    /// spreads) and [`ZUPT_FLOOR_MPS`] in quadrature, at most
    /// [`ZUPT_SIGMA_MPS`].
    fn zupt_sigma(&self, dt_s: T) -> T {
        let n = T::lit(ZUPT_WINDOW as f64);
        let (mb, ms) = self.window.iter().fold(
            (Vector3::zeros(), Vector3::zeros()),
            |a: (Vector3<T>, Vector3<T>), x| (a.0 + x.f_b, a.1 + x.f_s),
        );
        let (mb, ms) = (mb / n, ms / n);
        // In time order (the ring's oldest first), the running velocity
        // change about the mean force, and its sums for the spread.
        let (mut vb, mut vs) = (Vector3::<T>::zeros(), Vector3::<T>::zeros());
        let (mut sb, mut ss, mut qb, mut qs) = (vb, vs, T::zero(), T::zero());
        for i in 0..ZUPT_WINDOW {
            if let Some(x) = self.window.get((self.head + i) % ZUPT_WINDOW) {
                vb += (x.f_b - mb) * dt_s;
                vs += (x.f_s - ms) * dt_s;
                sb += vb;
                ss += vs;
                qb += vb.norm_squared();
                qs += vs.norm_squared();
            }
        }
        let spread = |q: T, s: Vector3<T>| (q / n - s.norm_squared() / (n * n)) / T::lit(3.0);
        let var = spread(qb, sb).min(spread(qs, ss)).max(T::zero());
        let floor = T::lit(ZUPT_FLOOR_MPS * ZUPT_FLOOR_MPS);
        (var + floor).sqrt_cr().min(T::lit(ZUPT_SIGMA_MPS))
    }

    /// The detector's statistic on the window (see the module: about 1
    /// for a still ideal sensor) and its mean rotation, rad/s. The spreads
    /// are taken in the base's frame and in the sensor's, and the smaller
    /// counts: on a still base a bias across a spinning table turns in the
    /// base's frame and is fixed in the sensor's, gravity across a tilted
    /// table axis the other way round; a moving base shakes in both.
    fn statistic(&self) -> (T, T) {
        let n = T::lit(ZUPT_WINDOW as f64);
        let sum = self
            .window
            .iter()
            .fold(Seen::default(), |a: Seen<T>, x| Seen {
                w_b: a.w_b + x.w_b,
                f_b: a.f_b + x.f_b,
                w_s: a.w_s + x.w_s,
                f_s: a.f_s + x.f_s,
                table_rate: a.table_rate + x.table_rate,
            });
        let m = Seen {
            w_b: sum.w_b / n,
            f_b: sum.f_b / n,
            w_s: sum.w_s / n,
            f_s: sum.f_s / n,
            table_rate: sum.table_rate / n,
        };
        let zn = &self.cfg.zupt_noise;
        let (vf, vw) = (
            T::lit(zn.sigma_f_mps2 * zn.sigma_f_mps2),
            T::lit(zn.sigma_w_radps * zn.sigma_w_radps),
        );
        let (sb, ss) = self.window.iter().fold((T::zero(), T::zero()), |a, x| {
            (
                a.0 + (x.f_b - m.f_b).norm_squared() / vf + (x.w_b - m.w_b).norm_squared() / vw,
                a.1 + (x.f_s - m.f_s).norm_squared() / vf + (x.w_s - m.w_s).norm_squared() / vw,
            )
        });
        (
            sb.min(ss) / T::lit(6.0 * ZUPT_WINDOW as f64 - 6.0),
            m.w_b.norm(),
        )
    }

    /// The threshold's cap: the statistic of a base shaking with a spread
    /// of [`ZUPT_CAP_GYRO_RADPS`] and [`ZUPT_CAP_ACCEL_MPS2`].
    fn zupt_cap(&self) -> f64 {
        let zn = &self.cfg.zupt_noise;
        let w = ZUPT_WINDOW as f64;
        let (a, g) = (
            ZUPT_CAP_ACCEL_MPS2 / zn.sigma_f_mps2,
            ZUPT_CAP_GYRO_RADPS / zn.sigma_w_radps,
        );
        w * (a * a + g * g) / (6.0 * w - 6.0)
    }

    /// The detector's verdict on the window: while the still start lasts
    /// it learns the thresholds (and says still); after, the statistic
    /// and the mean rotation under them.
    fn is_still(&mut self) -> bool {
        let (stat, rot) = self.statistic();
        if !(stat.is_finite() && rot.is_finite()) {
            return false;
        }
        self.evals = self.evals.saturating_add(1);
        if self.evals <= ZUPT_START_EVALS {
            let k = (self.evals - 1) as usize;
            if let (Some(a), Some(b)) = (self.start_stats.get_mut(k), self.start_rots.get_mut(k)) {
                (*a, *b) = (stat, rot);
            }
            let (gamma, rot) = (
                median(&self.start_stats, k + 1),
                median(&self.start_rots, k + 1),
            );
            self.zupt_gamma = (T::lit(ZUPT_MARGIN) * gamma)
                .max(T::lit(ZUPT_NOISE_BOUND))
                .min(T::lit(self.zupt_cap()));
            self.rot_limit = (T::lit(1.5) * rot)
                .max(T::lit(ZUPT_MEAN_GYRO_RADPS))
                .min(T::lit(ZUPT_CAP_GYRO_RADPS));
            return true;
        }
        stat <= self.zupt_gamma && rot <= self.rot_limit
    }

    /// The zero-velocity detector's threshold (learnt from the still
    /// start; 0 before its first evaluation).
    pub fn zupt_threshold(&self) -> T {
        self.zupt_gamma
    }
}

#[cfg(test)]
mod tests {
    use super::{median, white_sigma_m, AidedNav, Past, GNSS_CORR_SHARE, START_EVALS};
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn a_still_window_the_filter_s_velocity_refutes_is_not_still() {
        // Zero velocity against the filter's velocity and its 1 cm/s
        // sigma per axis, with the update's own 2 mm/s floor (an empty
        // window wanders by nothing): its NIS is v^2 / (1e-4 + 4e-6), so
        // chi-square(3)'s 1e-6 tail (30.66) falls at 5.65 cm/s along one
        // axis, and in the closed form 5 cm/s is still, 6 cm/s is not.
        let mut a = AidedNav::BLANK;
        for i in 0..3 {
            a.kf.p[(super::I_V + i, super::I_V + i)] = 1e-4;
        }
        let dt = 0.01;
        assert!(a.velocity_allows_still(&Vector3::new(0.05, 0.0, 0.0), dt));
        assert!(a.velocity_allows_still(&Vector3::new(0.0, -0.05, 0.0), dt));
        assert!(!a.velocity_allows_still(&Vector3::new(0.06, 0.0, 0.0), dt));
        assert!(!a.velocity_allows_still(&Vector3::new(0.0, 0.0, -0.06), dt));
        // A velocity the filter is unsure of is no refutation.
        for i in 0..3 {
            a.kf.p[(super::I_V + i, super::I_V + i)] = 1.0;
        }
        assert!(a.velocity_allows_still(&Vector3::new(0.5, 0.0, 0.0), dt));
    }

    #[test]
    fn a_fix_between_two_samples_meets_the_track_where_it_was_taken() {
        // Two stored states 10 ms apart on a track at 1.5 m/s north: a fix
        // valid 4 ms after the first is compared with the position 6 mm on
        // (the nearest state's, carried by its velocity), not 6 mm short.
        let mut a = AidedNav::BLANK;
        let at = |t_us: u64, north_m: f32| Past {
            t_us,
            p_n: Vector3::new(north_m, 0.0, 0.0),
            v_n: Vector3::new(1.5, 0.0, 0.0),
            c_b_n: Matrix3::identity(),
            w_ib_b: Vector3::zeros(),
            dv_sum: Vector3::zeros(),
            dp_sum: Vector3::zeros(),
        };
        a.past.fill(Past {
            t_us: u64::MAX,
            ..at(0, 0.0)
        });
        a.past[0] = at(10_000, 1.0);
        a.past[1] = at(20_000, 1.015);
        let p = a.past_at(14_000).unwrap();
        assert_eq!(p.t_us, 14_000);
        // f32: 1 + 0.006 to a few ulps of 1.
        assert!((p.p_n.x - 1.006).abs() < 1e-6, "{}", p.p_n.x);
        let p = a.past_at(17_000).unwrap();
        assert!((p.p_n.x - 1.0105).abs() < 1e-6, "{}", p.p_n.x);
        // An antenna 1 m ahead turning at 2 rad/s about down moves east
        // at 2 m/s about the IMU: 4 ms on, 8 mm east of the stored state
        // (the attitude kept: its own turn over 4 ms is second order).
        a.lever_b = Vector3::new(1.0, 0.0, 0.0);
        a.past[0].w_ib_b = Vector3::new(0.0, 0.0, 2.0);
        let p = a.past_at(14_000).unwrap();
        assert!((p.p_n.y - 0.008).abs() < 1e-6, "{}", p.p_n.y);
        assert!((p.p_n.x - 1.006).abs() < 1e-6, "{}", p.p_n.x);
        // Corrections fed back since (another fix's update, 0.2 m south
        // and 0.05 m/s north): the state then as the filter now has it.
        a.dp_sum = Vector3::new(-0.2, 0.0, 0.0);
        a.dv_sum = Vector3::new(0.05, 0.0, 0.0);
        let p = a.past_at(14_000).unwrap();
        assert!((p.p_n.x - 0.806).abs() < 1e-6, "{}", p.p_n.x);
        assert!((p.v_n.x - 1.55).abs() < 1e-6, "{}", p.v_n.x);
        // Stored after them: nothing added.
        a.past[0].dp_sum = a.dp_sum;
        a.past[0].dv_sum = a.dv_sum;
        let p = a.past_at(14_000).unwrap();
        assert!((p.p_n.x - 1.006).abs() < 1e-6, "{}", p.p_n.x);
    }

    #[test]
    fn a_lagging_velocity_is_compared_with_the_state_it_describes() {
        // A track speeding up north at 2 m/s^2 and climbing at 1 m/s^2,
        // stored every 10 ms: a receiver whose horizontal velocity is
        // 0.13 s old and vertical 0.3 s old is compared with the states
        // then (the fix's time 0.5 s), not the velocity at its tag.
        let mut a = AidedNav::BLANK;
        for (k, p) in a.past.iter_mut().enumerate() {
            let t = k as f32 * 0.01;
            *p = Past {
                t_us: k as u64 * 10_000,
                p_n: Vector3::zeros(),
                v_n: Vector3::new(2.0 * t, 0.0, -t),
                c_b_n: Matrix3::identity(),
                w_ib_b: Vector3::zeros(),
                dv_sum: Vector3::zeros(),
                dp_sum: Vector3::zeros(),
            };
        }
        let at = a.past_at(500_000).unwrap();
        assert_eq!(a.fix_velocity_reference(&at), at.v_n);
        a.cfg.velocity_lag_s = [0.13, 0.3];
        let v = a.fix_velocity_reference(&at);
        // 2 (0.5 - 0.13) north, -(0.5 - 0.3) down, to f32's ulps.
        assert!((v.x - 0.74).abs() < 1e-6 && (v.z + 0.2).abs() < 1e-6, "{v}");
        // A correction of 0.1 m/s north and 0.05 up made since (a fix's
        // update in between): the states then as the filter now has them.
        a.dv_sum = Vector3::new(0.1, 0.0, -0.05);
        let v = a.fix_velocity_reference(&at);
        assert!(
            (v.x - 0.84).abs() < 1e-6 && (v.z + 0.25).abs() < 1e-6,
            "{v}"
        );
    }

    #[test]
    fn a_fix_enters_with_the_variance_its_receiver_states() {
        // White plus correlated is the stated variance: an RTK float fix
        // (0.3 m) beside a correlated state sized on fixed ones (14 mm).
        let (s, c) = (0.3, 0.014);
        let w = white_sigma_m(s, c);
        assert!((w * w + c * c - s * s).abs() < 1e-15);
        // The median fix: the share's complement, as before.
        let c = (GNSS_CORR_SHARE * 0.02f64 * 0.02).sqrt();
        let w = white_sigma_m(0.02, c);
        assert!((w - ((1.0 - GNSS_CORR_SHARE) * 0.02f64 * 0.02).sqrt()).abs() < 1e-15);
        // A fix better than the median: never below the complement.
        let w = white_sigma_m(0.01, 0.1);
        assert!((w - (1.0 - GNSS_CORR_SHARE).sqrt() * 0.01).abs() < 1e-15);
    }

    #[test]
    fn the_median_of_the_still_start_ignores_its_spin_up() {
        let mut v = [0.0f64; START_EVALS];
        v[..5].copy_from_slice(&[900.0, 2.0, 1.0, 3.0, 2.5]);
        assert_eq!(median(&v, 5), 2.5);
        assert_eq!(median(&v, 1), 900.0);
        // Even counts take the upper middle.
        assert_eq!(median(&v, 4), 3.0);
    }
}
