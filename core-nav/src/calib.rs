//! Power-up calibration of the gyro errors that table rotation excites
//! (the paper's Sec. 3, and better).
//!
//! The gyro model (paper Eq. 29-32): `w_meas = (I + M) w_true + b + n`.
//! Rotation about the table axis `k` at rate `r` excites the column `M k`
//! (installation errors of the other two axes and the scale factor of the
//! `k` axis) through `M k r`; MEMS gyros add a rate-squared term and a
//! different scale for the two directions. Every method here is the same
//! least-squares problem on **phases**: a stretch of data at one table rate
//! (0 for static), reduced to its mean gyro output over whole table turns
//! (the horizontal earth rate averages out over a turn). Per gyro axis `i`:
//!
//! ```text
//! mean_i - r k_i = b_i + e_i + m_i r + q_i r^2 + a_i |r|
//! ```
//!
//! `e_i` is the earth rate the phase sees in `s` (static: `c_n_s w_ie_n`;
//! whole turns: only its component along `k`), known from the latitude and
//! the base attitude, or ignored (the paper). Which unknowns are solved for
//! depends on the phases:
//!
//! - the paper: static + one rate, earth ignored -> `b, m`;
//! - earth-aware: the same with `e` subtracted;
//! - reciprocating: `+r` and `-r`, no static phase -> `b, m`;
//! - multi-rate: several rates (and directions) -> `b, m, q` (and `a`).
//!
//! The predicted 1-sigma errors come from the white noise measured in the
//! phases themselves (`ARW = sd(w) sqrt(dt)`), propagated through the same
//! least squares; for the paper's method they reduce to its Eq. 35 / 36:
//! `sigma_b = ARW / sqrt(T_static)`, `sigma_m = ARW sqrt(1/T_rot +
//! 1/T_static) / r`.
//!
//! Phases are accumulated sample by sample in fixed-size state (no heap), so
//! the firmware runs the same code; checks refuse a phase that is not static
//! or a rate that was not reached, with the reason.

use crate::real::Real;
use crate::table::{Axis, TableAngle};
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};

/// Most one-second blocks a static phase checks for bumps (a static phase
/// of up to 128 s is checked whole; longer ones in their first 128 s).
pub const MAX_BLOCKS: usize = 128;
/// A turn counts as whole within this angle (encoder quantisation and the
/// servo's end error of a move), rad: 0.1 deg leaves 3e-4 of a turn's
/// earth rate unaveraged, below 0.01 deg/h.
pub const TURN_TOLERANCE_RAD: f64 = 0.1 * core::f64::consts::PI / 180.0;

/// Most phases in one calibration.
pub const MAX_PHASES: usize = 8;

/// Why a calibration refused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CalibError {
    /// The static phase moved: the table turned (rad).
    TableMoved {
        /// Encoder angle change during the phase, rad.
        angle_rad: f64,
    },
    /// The static phase moved: a block mean of the gyro left the phase mean
    /// by more than the allowed amount (rad/s): a bump, a vehicle moving.
    NotStatic {
        /// Largest block deviation, rad/s.
        deviation_radps: f64,
        /// Allowed, rad/s.
        allowed_radps: f64,
    },
    /// The accelerometer norm is not g within [`Checks::max_norm_error`] (m/s^2).
    NotLevelOrMoving {
        /// Mean specific-force norm, m/s^2.
        norm_mps2: f64,
    },
    /// The measured table rate differs from the command by more than 2 %.
    RateNotReached {
        /// Measured (encoder), rad/s.
        measured_radps: f64,
        /// Commanded, rad/s.
        commanded_radps: f64,
    },
    /// A rotating phase holds less than one whole turn.
    NotAWholeTurn,
    /// Too few samples or phases for the unknowns asked for.
    NotEnoughData,
    /// The phases' rates do not separate the unknowns (singular).
    Degenerate,
    /// A sample was not finite.
    NonFinite,
}

impl core::fmt::Display for CalibError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Self::TableMoved { angle_rad } => write!(f, "static phase: the table turned by {:.3} deg", angle_rad.to_degrees()),
            Self::NotStatic { deviation_radps, allowed_radps } => write!(
                f,
                "static phase: gyro moved by {:.4} deg/s in a 1 s block (allowed {:.4} deg/s): bumped or moving",
                deviation_radps.to_degrees(),
                allowed_radps.to_degrees()
            ),
            Self::NotLevelOrMoving { norm_mps2 } => write!(f, "static phase: specific force {norm_mps2:.4} m/s^2 is not g"),
            Self::RateNotReached { measured_radps, commanded_radps } => write!(
                f,
                "table rate {:.3} deg/s, commanded {:.3} deg/s",
                measured_radps.to_degrees(),
                commanded_radps.to_degrees()
            ),
            Self::NotAWholeTurn => write!(f, "rotating phase shorter than one whole turn"),
            Self::NotEnoughData => write!(f, "not enough data for the unknowns"),
            Self::Degenerate => write!(f, "phase rates do not separate the unknowns"),
            Self::NonFinite => write!(f, "non-finite sample"),
        }
    }
}

/// Sums of one stretch (f64: sums of 10^4..10^5 samples).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Sums {
    n: u64,
    w: Vector3<f64>,
    w2: Vector3<f64>,
    f: Vector3<f64>,
    t_first_us: u64,
    t_last_us: u64,
    angle_first: f64,
    angle_last: f64,
    /// Sums of cos and sin of the absolute table angle.
    cos: f64,
    sin: f64,
    /// First and last gyro samples (for the endpoint rates).
    w_first: Vector3<f64>,
    w_last: Vector3<f64>,
}

impl Sums {
    fn add(
        &mut self,
        t_us: u64,
        w: &Vector3<f64>,
        f: &Vector3<f64>,
        angle: f64,
        (sn, cs): (f64, f64),
    ) {
        self.cos += cs;
        self.sin += sn;
        if self.n == 0 {
            self.t_first_us = t_us;
            self.angle_first = angle;
            self.w_first = *w;
        }
        self.w_last = *w;
        self.n += 1;
        self.w += w;
        self.w2 += w.component_mul(w);
        self.f += f;
        self.t_last_us = t_us;
        self.angle_last = angle;
    }
}

/// A phase being accumulated: one table rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseAccumulator {
    /// Commanded rate, rad/s (0 = static).
    pub commanded_radps: f64,
    /// Table axis.
    pub axis: Axis,
    total: Sums,
    /// Sums up to the last whole-turn crossing (rotating phases).
    at_turn: Sums,
    turns_done: i64,
    start_angle: Option<TableAngle<f64>>,
    /// Per-block sums of `w - w_first` and its square, f32 (relative to the
    /// first sample, so the variance does not cancel: 3 KiB instead of 12).
    blocks: [Vector3<f32>; MAX_BLOCKS],
    blocks2: [Vector3<f32>; MAX_BLOCKS],
    block_n: [u32; MAX_BLOCKS],
    block_len_us: u64,
}

impl PhaseAccumulator {
    /// A phase at `commanded_radps` (0 for static) about `axis`.
    pub fn new(commanded_radps: f64, axis: Axis) -> Self {
        Self {
            commanded_radps,
            axis,
            total: Sums::default(),
            at_turn: Sums::default(),
            turns_done: 0,
            start_angle: None,
            blocks: [Vector3::zeros(); MAX_BLOCKS],
            blocks2: [Vector3::zeros(); MAX_BLOCKS],
            block_n: [0; MAX_BLOCKS],
            block_len_us: 1_000_000,
        }
    }

    /// Starts again in place, as [`Self::new`] would (no 4 KiB value on a
    /// board's stack).
    pub fn reset(&mut self, commanded_radps: f64, axis: Axis) {
        self.commanded_radps = commanded_radps;
        self.axis = axis;
        self.total = Sums::default();
        self.at_turn = Sums::default();
        self.turns_done = 0;
        self.start_angle = None;
        self.blocks.fill(Vector3::zeros());
        self.blocks2.fill(Vector3::zeros());
        self.block_n.fill(0);
        self.block_len_us = 1_000_000;
    }

    /// Adds one sample: time (µs), gyro (rad/s) and accel (m/s^2) in `s`,
    /// and the table angle at that time.
    ///
    /// # Errors
    /// [`CalibError::NonFinite`].
    pub fn push<T: Real>(
        &mut self,
        t_us: u64,
        w: &Vector3<T>,
        f: &Vector3<T>,
        angle: TableAngle<T>,
    ) -> Result<(), CalibError> {
        let w = w.map(|x| x.to_f64());
        let f = f.map(|x| x.to_f64());
        if !(w.iter().all(|x| x.is_finite()) && f.iter().all(|x| x.is_finite())) {
            return Err(CalibError::NonFinite);
        }
        let angle64 = TableAngle::<f64> {
            turns: angle.turns,
            rad: angle.rad.to_f64(),
        };
        let start = *self.start_angle.get_or_insert(angle64);
        let rel = angle64.minus(&start);
        self.total
            .add(t_us, &w, &f, rel, crate::real::sin_cos(angle64.rad));
        // Whole-turn bookkeeping: snapshot the sums each time |rel| passes
        // another full turn.
        let turns =
            libm::floor((libm::fabs(rel) + TURN_TOLERANCE_RAD) / core::f64::consts::TAU) as i64;
        if turns > self.turns_done {
            self.turns_done = turns;
            self.at_turn = self.total;
        }
        // 1 s blocks for the static check.
        let k = t_us
            .saturating_sub(self.total.t_first_us)
            .checked_div(self.block_len_us)
            .map_or(usize::MAX, |k| usize::try_from(k).unwrap_or(usize::MAX));
        if let (Some(b), Some(b2), Some(n)) = (
            self.blocks.get_mut(k),
            self.blocks2.get_mut(k),
            self.block_n.get_mut(k),
        ) {
            let d = (w - self.total.w_first).map(|x| x as f32);
            *b += d;
            *b2 += d.component_mul(&d);
            *n += 1;
        }
        Ok(())
    }

    /// Samples so far.
    pub fn samples(&self) -> u64 {
        self.total.n
    }

    /// Length so far, s.
    pub fn duration_s(&self) -> f64 {
        (self.total.t_last_us.saturating_sub(self.total.t_first_us)) as f64 * 1e-6
    }

    /// Whole turns so far.
    pub fn whole_turns(&self) -> i64 {
        self.turns_done
    }

    /// The used sums: everything for static, up to the last whole turn for
    /// rotating phases.
    fn used(&self) -> &Sums {
        if self.commanded_radps == 0.0 {
            &self.total
        } else {
            &self.at_turn
        }
    }

    /// Mean table rate over the used samples, rad/s, as the gyro mean sees
    /// it: the n samples' sum of rates times dt is the angle turned plus half
    /// the endpoint rates times dt (the trapezoid rule read backwards; exact
    /// for a constant rate and for a move that starts and ends at rest). The
    /// endpoint rates are the gyro's table-axis readings (their errors enter
    /// at 1/n).
    pub fn measured_rate(&self) -> f64 {
        let s = self.used();
        if s.n < 2 {
            return 0.0;
        }
        let dt = (s.t_last_us.saturating_sub(s.t_first_us)) as f64 * 1e-6 / (s.n - 1) as f64;
        let k = self.axis.unit::<f64>();
        let ends = 0.5 * (k.dot(&s.w_first) + k.dot(&s.w_last)) * dt;
        (s.angle_last - s.angle_first + ends) / (s.n as f64 * dt)
    }

    /// White-noise density of each gyro axis from the sample spread,
    /// rad/sqrt(s), for a sample period `dt_s` (static phases; rotating
    /// phases carry the modulated earth rate in x/y, tiny next to MEMS noise).
    pub fn arw(&self, dt_s: f64) -> Vector3<f64> {
        let s = self.used();
        let n = s.n.max(2) as f64;
        let mean = s.w / n;
        let var = (s.w2 / n - mean.component_mul(&mean)).map(|v| v.max(0.0)) * (n / (n - 1.0));
        var.map(|v| libm::sqrt(v * dt_s))
    }

    /// Checks the phase (see [`Checks`]) and reduces it.
    ///
    /// # Errors
    /// The first failed check.
    pub fn finish(&self, checks: &Checks, dt_s: f64) -> Result<Phase, CalibError> {
        let s = self.used();
        if s.n < 10 {
            return Err(if self.commanded_radps != 0.0 && self.total.n >= 10 {
                CalibError::NotAWholeTurn
            } else {
                CalibError::NotEnoughData
            });
        }
        let n = s.n as f64;
        let mean_w = s.w / n;
        let mean_f = s.f / n;
        let rate = self.measured_rate();
        if self.commanded_radps == 0.0 {
            let moved = libm::fabs(self.total.angle_last - self.total.angle_first);
            if moved > checks.max_static_angle_rad {
                return Err(CalibError::TableMoved { angle_rad: moved });
            }
            let g = checks.gravity_mps2;
            let norm = mean_f.norm();
            if g > 0.0 && libm::fabs(norm / g - 1.0) > checks.max_norm_error {
                return Err(CalibError::NotLevelOrMoving { norm_mps2: norm });
            }
            // Block means against the phase mean: white noise gives
            // ARW / sqrt(1 s) per block; allow 6 sigma plus the drift
            // allowance (bias instability over a minute).
            let arw = self.arw(dt_s);
            let mut worst: f64 = 0.0;
            let mut allowed_at_worst = 0.0;
            for (b, cnt) in self.blocks.iter().zip(self.block_n.iter()) {
                if *cnt < 10 {
                    continue;
                }
                let bm = b.map(f64::from) / f64::from(*cnt) + self.total.w_first;
                let sigma = arw / libm::sqrt(f64::from(*cnt) * dt_s);
                for i in 0..3 {
                    let (d, sg) = match (bm.get(i), mean_w.get(i), sigma.get(i)) {
                        (Some(a), Some(m), Some(s)) => (libm::fabs(a - m), *s),
                        _ => continue,
                    };
                    let allowed = 6.0 * sg + checks.static_drift_radps;
                    if d - allowed > worst - allowed_at_worst {
                        worst = d;
                        allowed_at_worst = allowed;
                    }
                }
            }
            if worst > allowed_at_worst && allowed_at_worst > 0.0 {
                return Err(CalibError::NotStatic {
                    deviation_radps: worst,
                    allowed_radps: allowed_at_worst,
                });
            }
            // A shake that comes back averages out of a block mean but not
            // out of its spread: each block's rms about its mean against
            // the median block's (robust: only a few blocks are bumped).
            // 2x the median rms is far outside the chi-square spread of a
            // 100-sample block (+-10 %).
            let mut rms = [0.0f64; MAX_BLOCKS];
            let mut used = 0;
            for ((b, b2), cnt) in self
                .blocks
                .iter()
                .zip(self.blocks2.iter())
                .zip(self.block_n.iter())
            {
                if *cnt < 10 {
                    continue;
                }
                let c = f64::from(*cnt);
                let m = b.map(f64::from) / c;
                let v = (b2.map(f64::from) / c - m.component_mul(&m)).map(|x| x.max(0.0));
                if let Some(slot) = rms.get_mut(used) {
                    *slot = libm::sqrt(v.max());
                    used += 1;
                }
            }
            if let Some(sorted) = rms.get_mut(..used) {
                insertion_sort(sorted);
                let median = sorted.get(used / 2).copied().unwrap_or(0.0);
                let top = sorted.last().copied().unwrap_or(0.0);
                if used >= 5 && top > 2.0 * median + checks.static_drift_radps {
                    return Err(CalibError::NotStatic {
                        deviation_radps: top,
                        allowed_radps: 2.0 * median + checks.static_drift_radps,
                    });
                }
            }
        } else {
            if self.turns_done < 1 {
                return Err(CalibError::NotAWholeTurn);
            }
            if libm::fabs(rate / self.commanded_radps - 1.0) > checks.max_rate_error {
                return Err(CalibError::RateNotReached {
                    measured_radps: rate,
                    commanded_radps: self.commanded_radps,
                });
            }
        }
        Ok(Phase {
            rate_radps: if self.commanded_radps == 0.0 {
                0.0
            } else {
                rate
            },
            mean_w,
            arw: self.arw(dt_s),
            duration_s: (s.t_last_us.saturating_sub(s.t_first_us)) as f64 * 1e-6 + dt_s,
            mean_cos: s.cos / n,
            mean_sin: s.sin / n,
        })
    }
}

/// Thresholds of the data checks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checks {
    /// Largest table motion accepted in a static phase, rad.
    pub max_static_angle_rad: f64,
    /// Allowance for genuine bias drift in the static block test, rad/s.
    pub static_drift_radps: f64,
    /// Largest relative error of the table rate, dimensionless.
    pub max_rate_error: f64,
    /// Gravity at the site, m/s^2 (0 disables the norm check).
    pub gravity_mps2: f64,
    /// Largest relative error of the static specific-force norm against g:
    /// an uncalibrated MEMS accelerometer is off by its offset and scale
    /// (the ICM-42688-P: 20 mg and 0.5 %, 1 sigma; level, both on the
    /// axis along g): 3.5 sigma of them, so 8 % (5 % refused one board in
    /// 70, found by the coverage study); motion is caught by the block
    /// tests, an accelerating base by this one.
    pub max_norm_error: f64,
}

impl Default for Checks {
    fn default() -> Self {
        Self {
            max_static_angle_rad: 0.05f64.to_radians(),
            static_drift_radps: 0.02f64.to_radians(),
            max_rate_error: 0.02,
            gravity_mps2: 0.0,
            max_norm_error: 0.08,
        }
    }
}

/// The sensor's white gyro noise in a phase, rad/sqrt(s) per axis: the
/// phase's spread when still; turning, the table's own axis takes the RMS
/// of the two across it (that axis reads the table's rate, whose ripple,
/// a stepper's or a reversal's, spreads its samples without reaching the
/// phase's mean against the encoder's: not the sensor's noise).
pub fn sensor_noise(p: &Phase, axis: Axis) -> Vector3<f64> {
    if crate::table::is_still(p.rate_radps) {
        return p.arw;
    }
    let k = axis.unit::<f64>();
    let across = p.arw - k * k.dot(&p.arw);
    let rms = libm::sqrt(0.5 * across.norm_squared());
    across + k * rms
}

/// A reduced phase.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Phase {
    /// Measured table rate, rad/s (0 static).
    pub rate_radps: f64,
    /// Mean gyro over the used part, rad/s, in `s`.
    pub mean_w: Vector3<f64>,
    /// Measured white-noise density per axis, rad/sqrt(s).
    pub arw: Vector3<f64>,
    /// Length, s.
    pub duration_s: f64,
    /// Mean of cos(theta) over the phase (theta the absolute table angle).
    pub mean_cos: f64,
    /// Mean of sin(theta) over the phase.
    pub mean_sin: f64,
}

/// What the calibration knows about the earth rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum EarthModel {
    /// Ignore it (the paper: "the earth rotation rate can be ignored").
    Ignore,
    /// Known: `w_ie_n` (rad/s), the base attitude `c_b_n`, the table axis.
    Known {
        /// Earth rate in `n`, rad/s.
        w_ie_n: Vector3<f64>,
        /// Base attitude.
        c_b_n: Matrix3<f64>,
        /// Table axis.
        axis: Axis,
    },
}

impl EarthModel {
    /// The earth rate a phase sees in `s` on average: with `c_b_s(theta) v
    /// = v cos(theta) - (k x v) sin(theta) + k (k.v)(1 - cos(theta))`
    /// (Rodrigues), its time average is `k (k.v) + mean(cos) (v - k (k.v)) -
    /// mean(sin) (k x v)`. This covers a static phase, whole turns at a
    /// uniform rate (means 0: only the `k` component stays) and moves with
    /// ramps, which spend unequal time at different angles.
    pub fn seen(&self, p: &Phase) -> Vector3<f64> {
        match *self {
            EarthModel::Ignore => Vector3::zeros(),
            EarthModel::Known {
                w_ie_n,
                c_b_n,
                axis,
            } => {
                let k = axis.unit::<f64>();
                let v = c_b_n.transpose() * w_ie_n;
                let par = k * k.dot(&v);
                par + (v - par) * p.mean_cos - k.cross(&v) * p.mean_sin
            }
        }
    }
}

/// Which unknowns to solve for, per gyro axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Unknowns {
    /// Rate-squared term `q`.
    pub quadratic: bool,
    /// Direction asymmetry `a` (needs both directions).
    pub asymmetry: bool,
}

/// The result: corrections for the gyro and their predicted errors.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct GyroCalibration {
    /// Bias, rad/s.
    pub bias: Vector3<f64>,
    /// Column `M k` (installation errors and the `k` axis scale error).
    pub m_k: Vector3<f64>,
    /// Rate-squared coefficient per axis, 1/(rad/s).
    pub q: Vector3<f64>,
    /// Direction asymmetry per axis.
    pub a: Vector3<f64>,
    /// Predicted 1-sigma errors of `bias`, `m_k`, `q`, `a`.
    pub sigma_bias: Vector3<f64>,
    /// See `sigma_bias`.
    pub sigma_m_k: Vector3<f64>,
    /// See `sigma_bias`.
    pub sigma_q: Vector3<f64>,
    /// See `sigma_bias`.
    pub sigma_a: Vector3<f64>,
    /// Table axis.
    pub axis: Axis,
    /// A second calibrated column for a tri-axial table (the outer gimbal's
    /// axis and its `M k2`), from a rotation about that axis.
    pub second: Option<(Axis, Vector3<f64>)>,
}

impl GyroCalibration {
    /// Corrects a gyro sample (rad/s, in `s`): removes the bias, the
    /// nonlinear terms at the measured table-axis rate, and inverts
    /// `I + M` restricted to column `k` (Sherman-Morrison, exact), or to
    /// columns `k` and `k2` with a second axis (3x3 inverse, exact).
    pub fn apply<T: Real>(&self, w: &Vector3<T>) -> Vector3<T> {
        let k = self.axis.unit::<f64>();
        let w = w.map(|x| x.to_f64());
        let r = k.dot(&w);
        let y = w - self.bias - self.q * (r * r) - self.a * libm::fabs(r);
        let x = match self.second {
            None => y - self.m_k * (k.dot(&y) / (1.0 + k.dot(&self.m_k))),
            Some((axis2, m2)) => {
                let i_m = Matrix3::identity()
                    + self.m_k * k.transpose()
                    + m2 * axis2.unit::<f64>().transpose();
                i_m.try_inverse().map_or(y, |inv| inv * y)
            }
        };
        x.map(T::lit)
    }
}

/// Solves the phases' least squares (see the module docs).
///
/// # Errors
/// [`CalibError::NotEnoughData`] with fewer phases than unknowns,
/// [`CalibError::Degenerate`] when the rates do not separate them.
pub fn solve(
    phases: &[Phase],
    earth: &EarthModel,
    unknowns: Unknowns,
    axis: Axis,
) -> Result<GyroCalibration, CalibError> {
    let inv = design_inverse(phases, unknowns)?;
    let row = |r: f64| design_row(r, unknowns);
    let mut out = GyroCalibration {
        axis,
        ..GyroCalibration::default()
    };
    for i in 0..3 {
        // Weighted by the phase length (variance ARW^2 / T).
        let mut rhs = Vector4::<f64>::zeros();
        let mut arw2 = 0.0;
        for p in phases {
            let h = row(p.rate_radps);
            let w = p.duration_s;
            // The gyro also sees the true table rate r k.
            let k_i = axis.unit::<f64>().get(i).copied().unwrap_or(0.0);
            let y = p.mean_w.get(i).copied().unwrap_or(0.0)
                - earth.seen(p).get(i).copied().unwrap_or(0.0)
                - p.rate_radps * k_i;
            rhs += h * (w * y);
            arw2 += sensor_noise(p, axis).get(i).map_or(0.0, |a| a * a) * p.duration_s;
        }
        let total_t: f64 = phases.iter().map(|p| p.duration_s).sum();
        let arw2 = arw2 / total_t.max(1e-9);
        let x = inv * rhs;
        // Covariance: ARW^2 (H^T W H)^-1 with W = T (white noise, variance ARW^2/T).
        let var = inv.diagonal() * arw2;
        let sd = var.map(|v| libm::sqrt(v.max(0.0)));
        let set = |v: &mut Vector3<f64>, val: f64| {
            if let Some(e) = v.get_mut(i) {
                *e = val;
            }
        };
        set(&mut out.bias, x.x);
        set(&mut out.m_k, x.y);
        set(&mut out.q, if unknowns.quadratic { x.z } else { 0.0 });
        set(&mut out.a, if unknowns.asymmetry { x.w } else { 0.0 });
        set(&mut out.sigma_bias, sd.x);
        set(&mut out.sigma_m_k, sd.y);
        set(
            &mut out.sigma_q,
            if unknowns.quadratic { sd.z } else { 0.0 },
        );
        set(
            &mut out.sigma_a,
            if unknowns.asymmetry { sd.w } else { 0.0 },
        );
    }
    Ok(out)
}

/// One row of the phases' design: `[1, r, r^2, |r|]` with the unknowns
/// not solved for at 0.
fn design_row(r: f64, unknowns: Unknowns) -> Vector4<f64> {
    Vector4::new(
        1.0,
        r,
        if unknowns.quadratic { r * r } else { 0.0 },
        if unknowns.asymmetry {
            libm::fabs(r)
        } else {
            0.0
        },
    )
}

/// `(H^T W H)^-1` of the phases' design (weights their lengths), the same
/// for every gyro axis; unknowns not solved for held at zero by a unit
/// diagonal.
fn design_inverse(phases: &[Phase], unknowns: Unknowns) -> Result<Matrix4<f64>, CalibError> {
    let cols = 2 + usize::from(unknowns.quadratic) + usize::from(unknowns.asymmetry);
    if phases.len() < cols || phases.len() > MAX_PHASES {
        return Err(CalibError::NotEnoughData);
    }
    let mut n = Matrix4::from_diagonal(&Vector4::new(
        0.0,
        0.0,
        if unknowns.quadratic { 0.0 } else { 1.0 },
        if unknowns.asymmetry { 0.0 } else { 1.0 },
    ));
    for p in phases {
        let h = design_row(p.rate_radps, unknowns);
        n += h * h.transpose() * p.duration_s;
    }
    let inv = n.try_inverse().ok_or(CalibError::Degenerate)?;
    // Conditioning guard: a singular design shows as a huge inverse.
    if !inv.iter().all(|x| x.is_finite()) || inv.norm() * n.norm() > 1e14 {
        return Err(CalibError::Degenerate);
    }
    Ok(inv)
}

/// How each phase's mean moves the solution: `[b, m, q, a]` change by
/// `gains[j]` per unit change of phase `j`'s mean on any axis (the same
/// least squares as [`solve`]; unused slots zero). The bias's gains sum
/// to 1 and every other unknown's to 0, so a bias common to all phases
/// moves only the bias.
///
/// # Errors
/// As [`solve`].
pub fn gains(
    phases: &[Phase],
    unknowns: Unknowns,
) -> Result<[Vector4<f64>; MAX_PHASES], CalibError> {
    let inv = design_inverse(phases, unknowns)?;
    let mut g = [Vector4::zeros(); MAX_PHASES];
    for (gj, p) in g.iter_mut().zip(phases) {
        *gj = inv * design_row(p.rate_radps, unknowns) * p.duration_s;
    }
    Ok(g)
}

/// The slow part of one gyro axis's bias, rad/s, for the calibration's
/// predicted sigma: what moves the bias between phases besides white
/// noise (a sensor file states it; the calibration cannot measure it).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct BiasDrift {
    /// First-order Gauss-Markov processes: (stationary sigma rad/s,
    /// correlation time s); unused slots (0, 0).
    pub gauss_markov: [(f64, f64); 4],
    /// Rate random walk, rad/s/sqrt(s).
    pub rrw: f64,
    /// Bias temperature coefficient (1 sigma of the unit's), rad/s/degC.
    pub temp_bias: f64,
}

/// Where and how warm a phase was: its start and length, s, and its mean
/// sensor temperature, degC (`None`: not recorded).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseSpan {
    /// Start, s.
    pub t0_s: f64,
    /// Length, s.
    pub duration_s: f64,
    /// Mean temperature, degC.
    pub temp_c: Option<f64>,
}

impl BiasDrift {
    /// The covariance of the bias's means over two phases, (rad/s)^2:
    /// each Gauss-Markov process's and the random walk's double integral
    /// in closed form, and the temperature coefficient times both mean
    /// temperatures (relative to any reference: the unknowns other than
    /// the bias see differences only).
    pub fn mean_covariance(&self, a: &PhaseSpan, b: &PhaseSpan) -> f64 {
        let (t1, t2) = (a.duration_s.max(1e-9), b.duration_s.max(1e-9));
        // With G'' = k: the double integral of k(t - s) over s in a, t in b.
        let over = |g: &dyn Fn(f64) -> f64| {
            let d = b.t0_s - a.t0_s;
            g(d + t2) - g(d + t2 - t1) - g(d) + g(d - t1)
        };
        let mut c = 0.0;
        for &(sigma, tau) in &self.gauss_markov {
            if sigma > 0.0 && tau > 0.0 {
                let g = |u: f64| {
                    let u = libm::fabs(u);
                    tau * tau * (libm::exp(-u / tau) - 1.0) + tau * u
                };
                c += sigma * sigma * over(&g) / (t1 * t2);
            }
        }
        if self.rrw > 0.0 {
            // min(s, t) = (s + t - |s - t|) / 2; |u| = H'' with H = |u|^3/6.
            let h = |u: f64| libm::fabs(u * u * u) / 6.0;
            let mid = (a.t0_s + t1 / 2.0 + b.t0_s + t2 / 2.0) / 2.0;
            c += self.rrw * self.rrw * (mid - over(&h) / (2.0 * t1 * t2));
        }
        if let (Some(ta), Some(tb)) = (a.temp_c, b.temp_c) {
            c += self.temp_bias * self.temp_bias * ta * tb;
        }
        c
    }

    /// The 1-sigma error the drift adds to each unknown `[b, m, q, a]`
    /// (quadrature with the white noise's), from the phases' [`gains`]:
    /// `sqrt(sum_jk g_j g_k C_jk)`. The bias's entry is the error against
    /// the bias at turn-on; against the bias over the calibration (what
    /// the calibration reports) it is 0.
    pub fn sigma(&self, gains: &[Vector4<f64>], spans: &[PhaseSpan]) -> Vector4<f64> {
        let mut var = Vector4::<f64>::zeros();
        for (gj, sj) in gains.iter().zip(spans) {
            for (gk, sk) in gains.iter().zip(spans) {
                var += gj.component_mul(gk) * self.mean_covariance(sj, sk);
            }
        }
        var.map(|v| libm::sqrt(v.max(0.0)))
    }
}

/// The averaging time at which an Allan curve is lowest, s: the static
/// time that balances noise (falling as 1/sqrt(T)) against bias
/// instability (the paper's Sec. 4 trade-off, made automatic), limited to
/// `[min_s, max_s]`.
pub fn best_averaging_time(
    points: &[crate::allan::AdevPoint],
    min_s: f64,
    max_s: f64,
) -> Option<f64> {
    points
        .iter()
        .filter(|p| p.tau_s >= min_s && p.tau_s <= max_s && p.adev.is_finite())
        .min_by(|a, b| {
            a.adev
                .partial_cmp(&b.adev)
                .unwrap_or(core::cmp::Ordering::Equal)
        })
        .map(|p| p.tau_s)
}

/// Sorts a short slice (at most [`MAX_BLOCKS`] values) in place by
/// `total_cmp`. Not `sort_unstable`: its pattern-defeating quicksort is
/// ~8 KiB of firmware flash for 128 numbers sorted once at power-up.
fn insertion_sort(v: &mut [f64]) {
    for i in 1..v.len() {
        let mut j = i;
        while j > 0 {
            let (Some(a), Some(b)) = (v.get(j - 1).copied(), v.get(j).copied()) else {
                break;
            };
            if a.total_cmp(&b).is_le() {
                break;
            }
            v.swap(j - 1, j);
            j -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::insertion_sort;

    #[test]
    fn insertion_sort_agrees_with_the_standard_sort() {
        // A deterministic sequence with repeats, negatives and zeros.
        let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
        for n in [0usize, 1, 2, 7, 128] {
            let mut v = [0.0f64; 128];
            for x in v.iter_mut().take(n) {
                s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                *x = ((s >> 40) % 50) as f64 - 25.0;
            }
            let mut w = v;
            insertion_sort(&mut v[..n]);
            w[..n].sort_unstable_by(f64::total_cmp);
            assert_eq!(v, w);
        }
    }

    /// The closed forms against a brute-force double sum of each
    /// process's covariance function (the definition), on overlapping,
    /// adjacent and separated phases of unequal length.
    #[test]
    fn the_drifts_phase_covariance_is_its_double_integral() {
        use super::{BiasDrift, PhaseSpan};
        let span = |t0_s: f64, duration_s: f64| PhaseSpan {
            t0_s,
            duration_s,
            temp_c: None,
        };
        let brute = |a: &PhaseSpan, b: &PhaseSpan, k: &dyn Fn(f64, f64) -> f64| {
            let n = 600;
            let (da, db) = (a.duration_s / n as f64, b.duration_s / n as f64);
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    sum += k(
                        a.t0_s + (i as f64 + 0.5) * da,
                        b.t0_s + (j as f64 + 0.5) * db,
                    );
                }
            }
            sum / (n * n) as f64
        };
        let gm = BiasDrift {
            gauss_markov: [(2.0, 37.0), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0)],
            ..BiasDrift::default()
        };
        let rw = BiasDrift {
            rrw: 0.3,
            ..BiasDrift::default()
        };
        let pairs = [
            (span(10.0, 60.0), span(10.0, 60.0)),
            (span(0.0, 60.0), span(60.0, 45.0)),
            (span(5.0, 20.0), span(100.0, 80.0)),
            (span(100.0, 80.0), span(5.0, 20.0)),
            (span(0.0, 50.0), span(30.0, 50.0)),
        ];
        for (a, b) in pairs {
            let g = brute(&a, &b, &|s, t| 4.0 * (-(s - t).abs() / 37.0).exp());
            let r = brute(&a, &b, &|s: f64, t: f64| 0.09 * s.min(t));
            // The midpoint sum's error is below 1e-4 of these values.
            assert!(
                (gm.mean_covariance(&a, &b) - g).abs() < 1e-4 * g,
                "{a:?} {b:?}"
            );
            assert!(
                (rw.mean_covariance(&a, &b) - r).abs() < 1e-4 * r,
                "{a:?} {b:?}"
            );
        }
    }
}
