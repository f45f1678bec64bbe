//! The IMU error model: one equation per triad, every term switchable with a
//! magnitude.
//!
//! For each triad (gyro `x = w_is_s`, rad/s; accelerometer `x = f_s`, m/s^2),
//! per axis `i`, with `dT` the temperature change since turn-on:
//!
//! ```text
//! y = Q( sat( (I + diag(s + s_T dT) + M) x + K2 x^2 + K3 x^3 + (a/2)|x|
//!             + b0 + b_T dT + b_GM(t) + b_RW(t) + G f   (G: gyros only)
//!             + n ) )
//! ```
//!
//! `s` scale-factor error, `M` misalignment / installation (off-diagonal),
//! `K2, K3` scale nonlinearity, `a` scale asymmetry (positive and negative
//! rates see scales differing by `a`), `b0` turn-on bias, `b_T, s_T`
//! temperature coefficients, `b_GM` first-order Gauss-Markov bias
//! instability (`sigma`, `tau`), `b_RW` rate random walk, `G`
//! g-sensitivity, `n` white noise of density `N` (per-sample `N/sqrt(dt)`;
//! ARW / VRW), `sat` full-scale saturation, `Q` quantisation to the LSB.
//! Sample-time jitter and latency act on when `x` is taken (see
//! [`crate::sim`]).

use crate::rng::Rng;
pub use ::sensor::file::ImuSpec;
pub use ::sensor::spec::{TempSpec, TriadSpec};
use nalgebra::{Matrix3, Vector3};

pub use ::sensor::spec::FLICKER_BANK;
use ::sensor::spec::{FLICKER_SIGMA, FLICKER_TAUS};

/// One triad's realised (turn-on) error values and noise state.
#[derive(Clone, Debug, PartialEq)]
pub struct TriadModel {
    /// Turn-on bias, unit.
    pub bias: Vector3<f64>,
    /// Scale-factor errors.
    pub scale: Vector3<f64>,
    /// Misalignment (zero diagonal), rad.
    pub misalignment: Matrix3<f64>,
    /// K2 per axis, 1/unit.
    pub k2: Vector3<f64>,
    /// K3 per axis, 1/unit^2.
    pub k3: Vector3<f64>,
    /// Scale asymmetry per axis.
    pub asymmetry: Vector3<f64>,
    /// Bias temperature coefficients, unit/degC.
    pub temp_bias: Vector3<f64>,
    /// Scale temperature coefficients, 1/degC.
    pub temp_scale: Vector3<f64>,
    /// Noise and drift magnitudes from the spec.
    pub spec: TriadSpec,
    /// Gauss-Markov bias state (sum of the bank in flicker mode), unit.
    pub gm: Vector3<f64>,
    /// The bank's individual states (flicker mode).
    pub gm_bank: [Vector3<f64>; FLICKER_BANK],
    /// Random-walk bias state, unit.
    pub rw: Vector3<f64>,
    /// White noise density per axis, unit x sqrt(s) (the spec's `white` on
    /// every axis unless set per axis, e.g. by a fitted twin).
    pub white: Vector3<f64>,
    /// Gauss-Markov bias sigma per axis, unit.
    pub bias_instability: Vector3<f64>,
    /// Gauss-Markov correlation time per axis, s (0: no process).
    pub bi_tau_s: Vector3<f64>,
    /// Rate random walk per axis, unit/sqrt(s).
    pub rrw: Vector3<f64>,
    /// The bias processes' step coefficients, made from the fields above.
    drift_steps: DriftSteps,
}

/// A Gauss-Markov step per axis: (exp(-dt / tau), driving sigma in unit).
type DriftStep = (Vector3<f64>, Vector3<f64>);
/// The key a set of steps was made for: (dt s, sigma, tau s, flicker).
type DriftKey = (f64, Vector3<f64>, Vector3<f64>, bool);

/// [`TriadModel::drift_steps`]' memo: derived from the model's fields, so
/// not part of its identity (any two compare equal).
#[derive(Clone, Debug, Default)]
struct DriftSteps(Option<(DriftKey, [DriftStep; FLICKER_BANK])>);

impl PartialEq for DriftSteps {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl TriadModel {
    /// Draws the turn-on values of `spec` from `rng`.
    pub fn realise(spec: &TriadSpec, rng: &mut Rng) -> Self {
        let mut m = Matrix3::zeros();
        for r in 0..3 {
            for c in 0..3 {
                let z = rng.normal();
                if r != c {
                    m[(r, c)] = spec.misalignment * z;
                }
            }
        }
        let mut gm_bank = [Vector3::zeros(); FLICKER_BANK];
        let gm = if spec.flicker {
            for b in gm_bank.iter_mut() {
                *b = rng.normal3() * (spec.bias_instability * FLICKER_SIGMA);
            }
            gm_bank.iter().sum()
        } else {
            rng.normal3() * spec.bias_instability
        };
        Self {
            gm_bank,
            bias: rng.normal3() * spec.bias,
            scale: rng.normal3() * spec.scale,
            misalignment: m,
            k2: Vector3::repeat(spec.k2),
            k3: Vector3::repeat(spec.k3),
            asymmetry: Vector3::repeat(spec.asymmetry),
            temp_bias: rng.normal3() * spec.temp_bias,
            temp_scale: rng.normal3() * spec.temp_scale,
            spec: *spec,
            gm,
            rw: Vector3::zeros(),
            white: Vector3::repeat(spec.white),
            bias_instability: Vector3::repeat(spec.bias_instability),
            bi_tau_s: Vector3::repeat(spec.bi_tau_s),
            rrw: Vector3::repeat(spec.rrw),
            drift_steps: DriftSteps::default(),
        }
    }

    /// Advances the bias processes by `dt` s (each axis with its own
    /// magnitudes; an axis without a process keeps its state).
    pub fn advance(&mut self, dt: f64, rng: &mut Rng) {
        let any_gm = (0..3).any(|i| self.bias_instability[i] > 0.0 && self.bi_tau_s[i] > 0.0);
        if any_gm {
            let steps = self.drift_steps(dt);
            if self.spec.flicker {
                let mut sum = Vector3::zeros();
                for (b, (phi, q)) in self.gm_bank.iter_mut().zip(steps) {
                    *b = b.component_mul(&phi) + rng.normal3().component_mul(&q);
                    sum += *b;
                }
                self.gm = sum;
            } else {
                let (phi, q) = steps[0];
                self.gm = self.gm.component_mul(&phi) + rng.normal3().component_mul(&q);
            }
        }
        if self.rrw.iter().any(|r| *r > 0.0) {
            self.rw += rng.normal3().component_mul(&(self.rrw * dt.sqrt()));
        }
    }

    /// Per Gauss-Markov process (the flicker bank's, or the one in its
    /// first slot): exp(-dt / tau) per axis (1 where there is no process)
    /// and the driving sigma that keeps the stationary sigma. Made once
    /// per `dt` and set of magnitudes (a run's samples share them).
    fn drift_steps(&mut self, dt: f64) -> [DriftStep; FLICKER_BANK] {
        let key = (dt, self.bias_instability, self.bi_tau_s, self.spec.flicker);
        if let Some((k, steps)) = &self.drift_steps.0 {
            if *k == key {
                return *steps;
            }
        }
        let has = |i: usize| self.bias_instability[i] > 0.0 && self.bi_tau_s[i] > 0.0;
        let step = |tau_rel: f64, sigma: &Vector3<f64>| {
            let phi = Vector3::from_fn(|i, _| {
                if has(i) {
                    (-dt / (self.bi_tau_s[i] * tau_rel)).exp()
                } else {
                    1.0
                }
            });
            let q = Vector3::from_fn(|i, _| {
                if has(i) {
                    sigma[i] * (1.0 - phi[i] * phi[i]).sqrt()
                } else {
                    0.0
                }
            });
            (phi, q)
        };
        let steps = if self.spec.flicker {
            let sigma = self.bias_instability * FLICKER_SIGMA;
            FLICKER_TAUS.map(|rel| step(rel, &sigma))
        } else {
            [step(1.0, &self.bias_instability); FLICKER_BANK]
        };
        self.drift_steps = DriftSteps(Some((key, steps)));
        steps
    }

    /// The deterministic part of the output for truth `x` at temperature
    /// change `dt_c` (no noise, saturation or quantisation), plus `extra`
    /// bias (g-sensitivity).
    pub fn apply(&self, x: &Vector3<f64>, dt_c: f64, extra: &Vector3<f64>) -> Vector3<f64> {
        let scale = self.scale + self.temp_scale * dt_c;
        let lin = x + scale.component_mul(x) + self.misalignment * x;
        let nl = self.k2.component_mul(&x.component_mul(x))
            + self.k3.component_mul(&x.map(|v| v * v * v))
            + (self.asymmetry * 0.5).component_mul(&x.abs());
        lin + nl + self.bias + self.temp_bias * dt_c + self.gm + self.rw + extra
    }

    /// Noise, saturation and quantisation on top of [`Self::apply`]'s value,
    /// for a sample interval `dt` s.
    pub fn finish(&self, y: Vector3<f64>, dt: f64, rng: &mut Rng) -> Vector3<f64> {
        let s = &self.spec;
        // Drawn even at zero density, so the stream stays aligned across
        // configurations.
        let y = y + rng.normal3().component_mul(&(self.white / dt.sqrt()));
        y.map(|v| {
            let v = if s.full_scale > 0.0 {
                v.clamp(-s.full_scale, s.full_scale)
            } else {
                v
            };
            if s.lsb > 0.0 {
                round(v / s.lsb) * s.lsb
            } else {
                v
            }
        })
    }
}

/// `x.round()` (half away from zero) without the library call that x86-64's
/// baseline instruction set needs for it (no rounding instruction before
/// SSE4.1): the truncating conversion, exact below 2^52, where every
/// float above is whole already.
fn round(x: f64) -> f64 {
    if x.is_nan() || x.abs() >= 4_503_599_627_370_496.0 {
        return x; // whole, infinite or NaN
    }
    let t = x as i64 as f64; // towards zero: x's sign, or zero
                             // Without a branch (a quantised noisy reading's fraction is a coin
                             // toss the processor would guess wrong half the time); the sign from
                             // x, so -0.3 rounds to -0 as f64::round does.
    let up = f64::from(u8::from((x - t).abs() >= 0.5));
    (t.abs() + up).copysign(x)
}

/// A realised IMU: both triads, g-sensitivity, temperature, random streams.
#[derive(Clone, Debug)]
pub struct ImuModel {
    /// The spec it was drawn from.
    pub spec: ImuSpec,
    /// Gyro triad.
    pub gyro: TriadModel,
    /// Accelerometer triad.
    pub accel: TriadModel,
    /// Gyro g-sensitivity, rad/s per m/s^2.
    pub g_sens: Matrix3<f64>,
    /// White noise: its own stream, so the same seed gives the same white
    /// noise whatever other terms are switched on (common random numbers:
    /// a run and its noise-floor twin differ only by the other terms).
    white: Rng,
    /// Bias processes (Gauss-Markov, random walk).
    drift: Rng,
}

impl ImuModel {
    /// Draws the turn-on errors of `spec` with `seed`.
    pub fn new(spec: ImuSpec, seed: u64) -> Self {
        let mut turn_on = Rng::new(seed, 1);
        let gyro = TriadModel::realise(&spec.gyro, &mut turn_on);
        let accel = TriadModel::realise(&spec.accel, &mut turn_on);
        let g_sens = Matrix3::from_fn(|_, _| turn_on.normal() * spec.g_sensitivity);
        Self {
            spec,
            gyro,
            accel,
            g_sens,
            white: Rng::new(seed, 2),
            drift: Rng::new(seed, 4),
        }
    }

    /// Starts the bias processes from their stationary distribution (each
    /// axis's Gauss-Markov state drawn with its sigma; flicker banks
    /// likewise), after their magnitudes were set per axis.
    pub fn start_drift(&mut self) {
        for t in [&mut self.gyro, &mut self.accel] {
            if t.spec.flicker {
                let sigma = t.bias_instability * FLICKER_SIGMA;
                for b in t.gm_bank.iter_mut() {
                    *b = self.drift.normal3().component_mul(&sigma);
                }
                t.gm = t.gm_bank.iter().sum();
            } else {
                t.gm = self.drift.normal3().component_mul(&t.bias_instability);
            }
            t.rw = Vector3::zeros();
        }
    }

    /// Sensor temperature `t_s` s after turn-on, degC (warm-up curve).
    pub fn temperature_c(&self, t_s: f64) -> f64 {
        let t = &self.spec.temp;
        t.ambient_c + t.warmup_c * (1.0 - (-t_s.max(0.0) / t.warmup_tau_s.max(1e-9)).exp())
    }

    /// One output sample from the truth `(w_is_s, f_s)` at temperature
    /// `temp_c`; `dt` s since the previous sample (advances the bias
    /// processes). Returns `(gyro rad/s, accel m/s^2)`.
    pub fn measure(
        &mut self,
        w: &Vector3<f64>,
        f: &Vector3<f64>,
        temp_c: f64,
        dt: f64,
    ) -> (Vector3<f64>, Vector3<f64>) {
        self.gyro.advance(dt, &mut self.drift);
        self.accel.advance(dt, &mut self.drift);
        let dt_c = temp_c - self.spec.temp.ambient_c;
        let g = self.gyro.apply(w, dt_c, &(self.g_sens * f));
        let a = self.accel.apply(f, dt_c, &Vector3::zeros());
        (
            self.gyro.finish(g, dt, &mut self.white),
            self.accel.finish(a, dt, &mut self.white),
        )
    }

    /// The gyro's bias now, rad/s in `s`: what it reads at rest beyond
    /// white noise and rounding (turn-on bias, temperature, Gauss-Markov
    /// and random-walk states, g-sensitivity to `f` m/s^2 in `s`) at
    /// `temp_c` degC. The truth a calibration's bias is checked against.
    pub fn gyro_bias_now(&self, f: &Vector3<f64>, temp_c: f64) -> Vector3<f64> {
        let dt_c = temp_c - self.spec.temp.ambient_c;
        self.gyro.apply(&Vector3::zeros(), dt_c, &(self.g_sens * f))
    }

    /// The temperature output (quantised), degC.
    pub fn temp_output_c(&self, temp_c: f64) -> f64 {
        let l = self.spec.temp.lsb_c;
        if l > 0.0 {
            round(temp_c / l) * l
        } else {
            temp_c
        }
    }
}

#[cfg(test)]
mod tests {
    use super::round;

    #[test]
    fn round_is_f64_round_bit_for_bit() {
        let mut edges = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            -2.5,
            0.499_999_999_999_999_94,
            -0.499_999_999_999_999_94,
            4_503_599_627_370_495.5,
            4_503_599_627_370_497.0,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
        ];
        // A spread of magnitudes and fractions, both signs.
        let mut x = 1e-6;
        while x < 1e17 {
            edges.extend([x, -x, x + 0.5, -(x + 0.5)]);
            x *= 1.37;
        }
        for x in edges {
            assert_eq!(round(x).to_bits(), x.round().to_bits(), "{x}");
        }
        assert!(round(f64::NAN).is_nan());
    }
}
