//! The ride's noise, learnt from the fixes (`navigate --gnss
//! --learn-noise`): a sensor file's noise is the sensor's on a bench;
//! a car's engine and road, a hand's tremor or a roof's vibration add
//! error it cannot know, and a filter given the bench's noise is sure of
//! a state it does not have: an outage ends far outside its sigma, and
//! the fixes after it land outside its gate.
//!
//! The method is covariance matching (Mehra 1972; for INS/GNSS Mohamed
//! and Schwarz 1999; the process-noise scale factor of Ding, Wang, Rizos
//! and Kinlyside 2007, J. Navigation 60(3)) taken over an outage's
//! horizon: every [`HORIZON_S`] while fixes arrive, a copy of the
//! navigator (a *shadow*) goes on without fixes, as through an outage;
//! when it has run [`HORIZON_S`], the next fix is its innovation, over the
//! horizon's drift. Over the last few such returns the drift's spread
//! less the fixes' own variance, against the drift the shadow predicted,
//! `alpha = (sum v^2 - sum r) / sum h P h^T`. Where `alpha` is above 1 by
//! more than its chi-square spread, every process noise term the sensor
//! file gives (gyro and accelerometer white noise and bias instability)
//! is scaled up; where below, back down, never below the file's. The
//! innovations of fixes 0.1 s apart cannot tell it (with a receiver's
//! centimetres they are the receiver's own spread: on the real walk such a
//! factor ran away to its bound); the horizon's are what an outage does.
//! Between fixes nothing is learnt: an outage keeps what was learnt
//! before it.
//!
//! What it cannot tell apart: fixes whose stated sigmas are too small
//! read the same as a rough ride (the summary says so with the factor).

use crate::aided::HostNav;
use core_nav::aided::GnssFix;
use core_nav::eskf::{EskfConfig, Innovations};
use core_nav::real::Real;
use core_nav::strapdown::ImuSample;
use core_nav::table::TableAngle;
use serde::Serialize;

/// A shadow's run without fixes, s: the shortest outage the book's
/// tables cut.
pub const HORIZON_S: f64 = 10.0;
/// Shadow returns a re-tuning needs.
pub const RETURNS: usize = 4;
/// The largest factor on the process noise's variance (10x its density).
pub const MAX_FACTOR: f64 = 100.0;
/// `alpha` says something when this many of its chi-square sigmas from 1
/// (either way: a test that let it down at any distance and up only at
/// three sigmas would pull a right factor down).
const SIGNIFICANT: f64 = 2.0;
/// The largest change of the factor at one re-tuning (either way).
const STEP_MAX: f64 = 2.0;
/// A shadow's return is three components (north, east, down), each
/// independent.
const COMPONENTS_PER_INDEPENDENT: f64 = 1.0;
/// The least components in a window to learn from.
const MIN_COMPONENTS: u32 = 6;

/// What was learnt over a run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LearnReport {
    /// The sensor file's gyro angle random walk, deg/sqrt(h).
    pub gyro_arw_file_deg_rth: f64,
    /// The sensor file's accelerometer velocity random walk,
    /// m/s/sqrt(h).
    pub accel_vrw_file_mps_rth: f64,
    /// The factor on every process noise term's variance at the end (1:
    /// the file's).
    pub factor_end: f64,
    /// The largest factor used.
    pub factor_max: f64,
    /// Each re-tuning: (time s, factor).
    pub history: Vec<(f64, f64)>,
    /// Shadow returns seen (their innovations over [`HORIZON_S`]).
    pub returns: u32,
}

impl LearnReport {
    /// The factor in use at `t_s` (1 before the first re-tuning).
    pub fn factor_at(&self, t_s: f64) -> f64 {
        self.history
            .iter()
            .take_while(|(t, _)| *t <= t_s)
            .last()
            .map_or(1.0, |(_, f)| *f)
    }
}

/// The process noise a run's filter started from (the sensor file's,
/// through `sensor::filter::filter_config`), every term in SI: what a
/// peer filter is given to compare equals (`tools/pyins-peer`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ProcessNoise {
    /// Gyro white noise (angle random walk), rad/sqrt(s).
    pub gyro_white_rad_rts: f64,
    /// Accelerometer white noise (velocity random walk), m/s/sqrt(s).
    pub accel_white_mps_rts: f64,
    /// Gyro bias at the start, 1-sigma, rad/s.
    pub gyro_bias_init_radps: f64,
    /// Accelerometer bias at the start, 1-sigma, m/s^2.
    pub accel_bias_init_mps2: f64,
    /// Gyro bias random walk in run (the instability's), rad/s/sqrt(s).
    pub gyro_bias_walk_radps_rts: f64,
    /// Accelerometer bias random walk in run, m/s^2/sqrt(s).
    pub accel_bias_walk_mps2_rts: f64,
    /// The warm-up's time constant, s: its drift adds a random walk of
    /// density `sigma^2 / tau e^(-t / tau)` (variance per s) to each bias
    /// at `t` s from the start.
    pub warmup_tau_s: f64,
    /// The gyro biases' drift over the warm-up, 1-sigma, rad/s.
    pub warmup_gyro_bias_radps: f64,
    /// The accelerometer biases', m/s^2.
    pub warmup_accel_bias_mps2: f64,
    /// The gyro scales', 1.
    pub warmup_gyro_scale: f64,
    /// Gyro scale error, 1-sigma, 1.
    pub gyro_scale: f64,
    /// Gyro axis misalignment, 1-sigma, rad.
    pub gyro_misalignment_rad: f64,
    /// Accelerometer scale error, 1-sigma, 1.
    pub accel_scale: f64,
    /// Accelerometer axis misalignment, 1-sigma, rad.
    pub accel_misalignment_rad: f64,
}

impl From<&EskfConfig> for ProcessNoise {
    fn from(c: &EskfConfig) -> Self {
        let walk = |sigma: f64, tau: f64| {
            if tau > 0.0 {
                (2.0 * sigma * sigma / tau).sqrt()
            } else {
                0.0
            }
        };
        Self {
            gyro_white_rad_rts: c.gyro_arw,
            accel_white_mps_rts: c.accel_vrw,
            gyro_bias_init_radps: c.gyro_bias_init_sigma,
            accel_bias_init_mps2: c.accel_bias_init_sigma,
            gyro_bias_walk_radps_rts: walk(c.gyro_bias_sigma, c.gyro_bias_tau_s),
            accel_bias_walk_mps2_rts: walk(c.accel_bias_sigma, c.accel_bias_tau_s),
            warmup_tau_s: c.warmup.tau_s,
            warmup_gyro_bias_radps: c.warmup.gyro_bias,
            warmup_accel_bias_mps2: c.warmup.accel_bias,
            warmup_gyro_scale: c.warmup.gyro_scale,
            gyro_scale: c.gyro_scale_sigma,
            gyro_misalignment_rad: c.gyro_misalignment_sigma,
            accel_scale: c.accel_scale_sigma,
            accel_misalignment_rad: c.accel_misalignment_sigma,
        }
    }
}

/// The learner's state through a run.
#[derive(Clone, Debug)]
pub struct NoiseLearner<T: Real> {
    file: EskfConfig,
    factor: f64,
    shadow: Option<(f64, Box<HostNav<T>>)>,
    window: Vec<Innovations<f64>>,
    /// What was done.
    pub report: LearnReport,
}

impl<T: Real> NoiseLearner<T> {
    /// Starting from the sensor file's noise model `file`.
    pub fn new(file: EskfConfig) -> Self {
        Self {
            file,
            factor: 1.0,
            shadow: None,
            window: vec![],
            report: LearnReport {
                gyro_arw_file_deg_rth: file.gyro_arw.to_degrees() * 60.0,
                accel_vrw_file_mps_rth: file.accel_vrw * 60.0,
                factor_end: 1.0,
                factor_max: 1.0,
                history: vec![],
                returns: 0,
            },
        }
    }

    /// After the main navigator's step at `t_s` on `sample` (the table at
    /// `table`, turning at `rate` rad/s): the shadow steps too; `fix` is
    /// the fix the main one was handed before this step, if any, with its
    /// time of validity (µs, the mechanization's clock). A shadow
    /// that has run [`HORIZON_S`] takes it as its return; a new shadow
    /// starts from the main one after a fix.
    pub fn after_step(
        &mut self,
        an: &mut HostNav<T>,
        t_s: f64,
        sample: &ImuSample<T>,
        table: &TableAngle<T>,
        rate: T,
        fix: Option<&(GnssFix, u64)>,
    ) {
        if let Some((t0, sh)) = self.shadow.as_mut() {
            let due = t_s - *t0 >= HORIZON_S;
            if let (true, Some(f)) = (due, fix) {
                sh.kf.take_seen();
                // At its own time, as the main navigator took it.
                crate::aided::pipeline::hand_over(sh, &f.0, f.1);
                let seen = sh.step(sample, table, rate).map(|_| sh.kf.take_seen());
                self.shadow = None;
                if let Ok(seen) = seen {
                    self.returned(an, t_s, seen);
                }
            } else if t_s - *t0 > HORIZON_S + 2.0 || sh.step(sample, table, rate).is_err() {
                self.shadow = None;
            }
        }
        if self.shadow.is_none() && fix.is_some() {
            self.shadow = Some((t_s, Box::new(an.clone())));
        }
    }

    /// A shadow's return `seen` at `t_s`: into the window; a re-tuning
    /// once it holds [`RETURNS`].
    fn returned(&mut self, an: &mut HostNav<T>, t_s: f64, seen: Innovations<T>) {
        self.report.returns += 1;
        self.window.push(Innovations {
            n: seen.n,
            v2: seen.v2.to_f64(),
            hph: seen.hph.to_f64(),
            r: seen.r.to_f64(),
        });
        if self.window.len() < RETURNS {
            return;
        }
        let Some(alpha) = alpha(self.window.iter()) else {
            self.window.remove(0);
            return;
        };
        self.window.clear();
        // Half the step in log (the predicted drift follows the noise
        // through the filter's own dynamics: a whole step overshoots), at
        // most a factor of STEP_MAX each time.
        let step = alpha.sqrt().clamp(1.0 / STEP_MAX, STEP_MAX);
        let factor = (self.factor * step).clamp(1.0, MAX_FACTOR);
        if factor == self.factor || an.kf.set_config(scaled(&self.file, factor)).is_err() {
            return;
        }
        self.factor = factor;
        self.report.factor_end = factor;
        self.report.factor_max = self.report.factor_max.max(factor);
        self.report.history.push((t_s, factor));
    }
}

/// `file` with every process noise term's variance times `factor`: the
/// white noises and the bias instabilities (the warm-up's drift, a
/// deterministic rise, is kept).
pub fn scaled(file: &EskfConfig, factor: f64) -> EskfConfig {
    let r = factor.sqrt();
    EskfConfig {
        gyro_arw: file.gyro_arw * r,
        accel_vrw: file.accel_vrw * r,
        gyro_bias_sigma: file.gyro_bias_sigma * r,
        accel_bias_sigma: file.accel_bias_sigma * r,
        ..*file
    }
}

/// The window's `alpha` (module docs) where it says something: more than
/// [`SIGNIFICANT`] of its chi-square sigmas from 1; `None` with too few
/// components or within that spread.
fn alpha<'a>(window: impl Iterator<Item = &'a Innovations<f64>>) -> Option<f64> {
    let mut sum = Innovations::<f64>::default();
    for i in window {
        sum.n += i.n;
        sum.v2 += i.v2;
        sum.hph += i.hph;
        sum.r += i.r;
    }
    if sum.n < MIN_COMPONENTS || sum.hph <= 0.0 {
        return None;
    }
    let alpha = (sum.v2 - sum.r) / sum.hph;
    // The chi-square spread of the innovations' mean square, as a share
    // of the predicted, over the independent components.
    let independent = (f64::from(sum.n) / COMPONENTS_PER_INDEPENDENT).max(1.0);
    let spread = (2.0 / independent).sqrt() * (sum.hph + sum.r) / sum.hph;
    ((alpha - 1.0).abs() > SIGNIFICANT * spread).then_some(alpha.max(0.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window(v2: f64, hph: f64, r: f64, n: u32) -> Vec<Innovations<f64>> {
        vec![Innovations { n, v2, hph, r }]
    }

    #[test]
    fn alpha_matches_its_closed_form_and_stays_quiet_within_its_spread() {
        // 400 components whose squares sum to what the filter predicts
        // (hph + r): alpha 1, nothing said.
        assert_eq!(alpha(window(400.0, 300.0, 100.0, 400).iter()), None);
        // Twice the predicted state part: (900 - 100) / 300.
        let a = alpha(window(900.0, 300.0, 100.0, 400).iter()).unwrap();
        assert!((a - 800.0 / 300.0).abs() < 1e-12);
        // Too few components: nothing.
        assert_eq!(alpha(window(900.0, 300.0, 100.0, 3).iter()), None);
        // Below 1 beyond its spread: said (the factor may come back down).
        let a = alpha(window(200.0, 300.0, 100.0, 400).iter()).unwrap();
        assert!((a - 1.0 / 3.0).abs() < 1e-12);
        // Below 1 within it (0.9, spread 0.094): nothing.
        assert_eq!(alpha(window(370.0, 300.0, 100.0, 400).iter()), None);
    }
}
