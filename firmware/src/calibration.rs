//! The power-up calibration (the paper's section 3, earth-aware: the
//! solver is `core_nav::calib`): still for `static_s` (the gyro biases),
//! the table spun up to the scheme's rate (refused after
//! `spinup_timeout_s`), rotating for `rotate_s` (whole turns), then solved
//! and checked for plausibility. A bump, a table that will not reach its
//! rate or an implausible result restarts it with a reported reason.

use crate::control::NavInput;
use core_nav::attitude::Euler;
use core_nav::calib::{
    solve, CalibError, Checks, GyroCalibration, Phase, PhaseAccumulator, Unknowns,
};
use core_nav::site::Site;
use core_nav::table::Axis;
use nalgebra::Vector3;
use protocol::CalStatus;

/// The calibration's durations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalConfig {
    /// The still phase, s (the paper's 60 s, or from the Allan curve).
    pub static_s: f64,
    /// The rotating phase, s.
    pub rotate_s: f64,
    /// The rate must be reached within this, s.
    pub spinup_timeout_s: f64,
    /// The rate must hold this long before the rotating phase, s.
    pub settle_s: f64,
    /// The navigation period, s (the accumulator's sample interval).
    pub period_s: f64,
}

impl Default for CalConfig {
    fn default() -> Self {
        Self {
            static_s: 60.0,
            rotate_s: 60.0,
            spinup_timeout_s: 10.0,
            settle_s: 2.0,
            period_s: 0.01,
        }
    }
}

/// Where the calibration is (each since µs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CalPhase {
    /// Still, measuring the biases.
    Static(u64),
    /// Spinning up.
    SpinUp(u64),
    /// Rotating.
    Rotate(u64),
}

/// What one input did.
// The accepted calibration is the large variant; no heap on the board.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CalStep {
    /// Nothing to do.
    Continue,
    /// The still phase is done: start the table.
    StartTable,
    /// Refused: the table to stop, the calibration restarted.
    Refused(CalibError),
    /// Accepted.
    Accepted(GyroCalibration),
}

/// The calibration in progress.
pub struct PowerUp {
    cfg: CalConfig,
    phase: CalPhase,
    acc: PhaseAccumulator,
    still: Option<Phase>,
    /// No input yet: the still phase starts at the first.
    fresh: bool,
}

/// Bias under 5 deg/s and `M k` under 5 %: plausible for a MEMS gyro.
fn plausible(c: &GyroCalibration) -> bool {
    c.bias.amax() <= 5f64.to_radians() && c.m_k.amax() <= 0.05
}

impl PowerUp {
    /// A calibration starting still at `t_us`.
    pub fn new(cfg: CalConfig, t_us: u64) -> Self {
        Self {
            cfg,
            phase: CalPhase::Static(t_us),
            acc: PhaseAccumulator::new(0.0, Axis::Z),
            still: None,
            fresh: true,
        }
    }

    /// Starts again, still, in place.
    pub fn restart(&mut self, t_us: u64) {
        self.phase = CalPhase::Static(t_us);
        self.acc.reset(0.0, Axis::Z);
        self.still = None;
        self.fresh = true;
    }

    /// Where it is.
    pub fn phase(&self) -> CalPhase {
        self.phase
    }

    /// One navigation period's input; `site`, `base` and `rate` (the
    /// scheme's, rad/s) are the configuration's.
    pub fn input(&mut self, x: &NavInput, site: &Site, base: &Euler<f64>, rate: f64) -> CalStep {
        let t = x.t_us;
        let w = Vector3::from(x.mean.gyro_radps);
        let f = Vector3::from(x.mean.accel_mps2);
        let since = |t0: u64| t.saturating_sub(t0) as f64 * 1e-6;
        if core::mem::take(&mut self.fresh) {
            self.phase = CalPhase::Static(t);
        }
        match self.phase {
            CalPhase::Static(t0) => {
                // The still phase counts only while the table is at rest
                // (after a refusal it may still be coasting down).
                if x.table_moved {
                    self.restart(t);
                    self.fresh = false;
                    return CalStep::Continue;
                }
                if self.acc.push(t, &w, &f, x.angle).is_err() {
                    return CalStep::Refused(CalibError::NonFinite);
                }
                if since(t0) < self.cfg.static_s {
                    return CalStep::Continue;
                }
                match self.acc.finish(&checks(site), self.cfg.period_s) {
                    Ok(p) => {
                        self.still = Some(p);
                        self.phase = CalPhase::SpinUp(t);
                        CalStep::StartTable
                    }
                    Err(e) => CalStep::Refused(e),
                }
            }
            CalPhase::SpinUp(t0) => {
                if since(t0) > self.cfg.spinup_timeout_s {
                    return CalStep::Refused(CalibError::RateNotReached {
                        measured_radps: f64::from(x.table_rate_radps),
                        commanded_radps: rate,
                    });
                }
                if x.rate_ok_since
                    .is_some_and(|s| since(s) >= self.cfg.settle_s)
                {
                    self.acc.reset(rate, Axis::Z);
                    self.phase = CalPhase::Rotate(t);
                }
                CalStep::Continue
            }
            CalPhase::Rotate(t0) => {
                if self.acc.push(t, &w, &f, x.angle).is_err() {
                    return CalStep::Refused(CalibError::NonFinite);
                }
                if since(t0) < self.cfg.rotate_s {
                    return CalStep::Continue;
                }
                self.solve(site, base)
            }
        }
    }

    fn solve(&self, site: &Site, base: &Euler<f64>) -> CalStep {
        let rot = match self.acc.finish(&checks(site), self.cfg.period_s) {
            Ok(p) => p,
            Err(e) => return CalStep::Refused(e),
        };
        let Some(st) = self.still else {
            return CalStep::Refused(CalibError::NotEnoughData);
        };
        let earth = site.earth_model(base, Axis::Z);
        let unknowns = Unknowns {
            quadratic: false,
            asymmetry: false,
        };
        match solve(&[st, rot], &earth, unknowns, Axis::Z) {
            Ok(c) if plausible(&c) => CalStep::Accepted(c),
            Ok(_) => CalStep::Refused(CalibError::Degenerate),
            Err(e) => CalStep::Refused(e),
        }
    }
}

fn checks(site: &Site) -> Checks {
    Checks {
        gravity_mps2: site.gravity_mps2,
        ..Checks::default()
    }
}

/// The status a refusal is reported with.
pub fn refusal_status(e: &CalibError) -> CalStatus {
    match e {
        CalibError::TableMoved { .. } => CalStatus::TableMoved,
        CalibError::NotStatic { .. } => CalStatus::NotStatic,
        CalibError::NotLevelOrMoving { .. } => CalStatus::NotLevelOrMoving,
        CalibError::RateNotReached { .. } => CalStatus::RateNotReached,
        CalibError::NotAWholeTurn => CalStatus::NotAWholeTurn,
        CalibError::NotEnoughData => CalStatus::NotEnoughData,
        CalibError::Degenerate => CalStatus::Degenerate,
        CalibError::NonFinite => CalStatus::NonFinite,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::icm42688::Sample;
    use core_nav::table::{q_s_b, TableAngle};
    use nalgebra::UnitQuaternion;

    /// 30 deg/s.
    const RATE: f64 = core::f64::consts::FRAC_PI_6;
    const BIAS: [f64; 3] = [0.01, -0.02, 0.005];
    const M_K: [f64; 3] = [1e-3, -2e-3, 5e-3];

    /// A noise-free navigation input at `t_us`: the table at `theta`
    /// turning at `rate` on a level base facing north at `site`, the gyros
    /// reading `(I + M) w + b` (`M`'s only column the table axis's).
    fn input(site: &Site, t_us: u64, theta: f64, rate: f64, settled: Option<u64>) -> NavInput {
        let c_s_b = UnitQuaternion::from_quaternion(q_s_b(Axis::Z, theta)).to_rotation_matrix();
        let (w, f) = site.ideal_imu(&c_s_b.matrix().transpose(), &(Vector3::z() * rate));
        let g = w + Vector3::from(BIAS) + Vector3::from(M_K) * w.z;
        let f32x3 = |v: Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
        NavInput {
            t_us,
            mean: Sample {
                gyro_radps: f32x3(g),
                accel_mps2: f32x3(f),
                temp_c: 25.0,
            },
            angle: TableAngle::from_rad_f64(theta),
            table_rate_radps: rate as f32,
            encoder_seen: true,
            table_moved: rate != 0.0,
            rate_ok_since: settled,
            stopped: None,
        }
    }

    #[test]
    fn a_noise_free_power_up_recovers_the_bias_and_the_table_axis_column() {
        let site = Site::new(-33.9, 40.0);
        let base = Euler::default();
        let mut cal = PowerUp::new(CalConfig::default(), 0);
        let mut t = 0u64;
        // Still until the still phase asks for the table.
        loop {
            t += 10_000;
            match cal.input(&input(&site, t, 0.0, 0.0, None), &site, &base, RATE) {
                CalStep::Continue => {}
                CalStep::StartTable => break,
                other => panic!("{other:?}"),
            }
        }
        assert!((59_000_000..=61_000_000).contains(&t), "{t}");
        // The table at its rate at once, settled from the start.
        let t0 = t;
        let result = loop {
            t += 10_000;
            let theta = RATE * (t - t0) as f64 * 1e-6;
            match cal.input(&input(&site, t, theta, RATE, Some(t0)), &site, &base, RATE) {
                CalStep::Continue => {}
                CalStep::Accepted(c) => break c,
                other => panic!("{other:?}"),
            }
            assert!(t - t0 < 100_000_000, "no result after 100 s");
        };
        // The inputs are f32 (7 significant digits of a 0.52 rad/s rate:
        // 3e-8 rad/s), the solver f64: 1e-6 leaves a factor 30.
        for i in 0..3 {
            assert!((result.bias[i] - BIAS[i]).abs() < 1e-6, "{:?}", result.bias);
            assert!((result.m_k[i] - M_K[i]).abs() < 1e-5, "{:?}", result.m_k);
        }
    }

    #[test]
    fn a_bump_while_still_restarts_the_still_phase() {
        let site = Site::new(45.0, 0.0);
        let base = Euler::default();
        let mut cal = PowerUp::new(CalConfig::default(), 0);
        for k in 1..=3000u64 {
            cal.input(
                &input(&site, k * 10_000, 0.0, 0.0, None),
                &site,
                &base,
                RATE,
            );
        }
        // The table moved at 30 s: the still phase starts again there.
        let mut bumped = input(&site, 30_010_000, 0.0, 0.0, None);
        bumped.table_moved = true;
        cal.input(&bumped, &site, &base, RATE);
        assert_eq!(cal.phase(), CalPhase::Static(30_010_000));
    }
}
