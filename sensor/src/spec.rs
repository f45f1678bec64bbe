//! A sensor's error budget in SI (no_std): one triad's terms, the
//! temperature's behaviour, the mounting on its base. What a sensor file
//! (`rins-sensor/2`, [`crate::file`]) holds, read into these; the
//! simulator (hal-sim) realises them, the filter ([`crate::filter`]) takes
//! its noise model from them.

use nalgebra::Matrix3;

pub(crate) const DEG: f64 = core::f64::consts::PI / 180.0;
/// Standard gravity, m/s^2 (the `g` of datasheets' mg and ug).
pub const G0: f64 = 9.806_65;
/// A first-order Gauss-Markov process's Allan deviation peaks at 0.62 of
/// its sigma (at 1.89 tau): a datasheet's or `rins allan`'s bias
/// instability (the Allan floor) is this fraction of the process's sigma.
pub const ALLAN_PEAK_PER_GM_SIGMA: f64 = 0.62;

/// Gauss-Markov processes in the flicker approximation.
pub const FLICKER_BANK: usize = 4;
/// Their correlation times relative to `bi_tau_s` (a decade apart).
pub const FLICKER_TAUS: [f64; FLICKER_BANK] = [0.03, 0.3, 3.0, 30.0];
/// Their common sigma relative to `bias_instability`, chosen so the Allan
/// floor between the extreme taus equals 0.62 x `bias_instability`, the
/// peak of a single process (checked in `tests/statistics.rs`).
pub const FLICKER_SIGMA: f64 = 0.78;

/// Magnitudes of one triad's error terms (SI; random terms as 1 sigma).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct TriadSpec {
    /// Turn-on bias, 1 sigma, unit (rad/s or m/s^2).
    pub bias: f64,
    /// Scale-factor error, 1 sigma, dimensionless.
    pub scale: f64,
    /// Misalignment, each off-diagonal entry 1 sigma, rad.
    pub misalignment: f64,
    /// Second-order scale nonlinearity K2 (all axes), 1/unit.
    pub k2: f64,
    /// Third-order scale nonlinearity K3 (all axes), 1/unit^2.
    pub k3: f64,
    /// Scale asymmetry (positive minus negative scale), dimensionless.
    pub asymmetry: f64,
    /// White-noise density (ARW in rad/sqrt(s), VRW in m/s/sqrt(s)).
    pub white: f64,
    /// Bias instability: Gauss-Markov sigma, unit.
    pub bias_instability: f64,
    /// Gauss-Markov correlation time, s.
    pub bi_tau_s: f64,
    /// Flicker approximation: the bias instability is a bank of
    /// Gauss-Markov processes ([`FLICKER_BANK`]) a decade apart around
    /// `bi_tau_s`, so the Allan deviation has a flat floor instead of one
    /// GM bump.
    pub flicker: bool,
    /// Rate random walk, unit/sqrt(s).
    pub rrw: f64,
    /// Bias temperature coefficient, 1 sigma, unit/degC.
    pub temp_bias: f64,
    /// Scale temperature coefficient, 1 sigma, 1/degC.
    pub temp_scale: f64,
    /// Output resolution, unit (0: none).
    pub lsb: f64,
    /// Full scale, unit (0: none).
    pub full_scale: f64,
}

impl TriadSpec {
    /// The slow part of the bias this file states (the Gauss-Markov
    /// process or the flicker bank, the rate random walk, the temperature
    /// coefficient), the processes the simulator realises: what a
    /// calibration's sigma must add to its white noise.
    pub fn bias_drift(&self) -> core_nav::calib::BiasDrift {
        let mut gauss_markov = [(0.0, 0.0); FLICKER_BANK];
        if self.bias_instability > 0.0 && self.bi_tau_s > 0.0 {
            if self.flicker {
                for (g, rel) in gauss_markov.iter_mut().zip(FLICKER_TAUS) {
                    *g = (self.bias_instability * FLICKER_SIGMA, self.bi_tau_s * rel);
                }
            } else if let Some(g) = gauss_markov.first_mut() {
                *g = (self.bias_instability, self.bi_tau_s);
            }
        }
        core_nav::calib::BiasDrift {
            gauss_markov,
            rrw: self.rrw,
            temp_bias: self.temp_bias,
        }
    }
}

/// Temperature of the sensor: warm-up from ambient.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TempSpec {
    /// Ambient (turn-on) temperature, degC.
    pub ambient_c: f64,
    /// Self-heating rise at the end of warm-up, degC.
    pub warmup_c: f64,
    /// Warm-up time constant, s.
    pub warmup_tau_s: f64,
    /// Temperature output resolution, degC.
    pub lsb_c: f64,
}

impl Default for TempSpec {
    fn default() -> Self {
        Self {
            ambient_c: 25.0,
            warmup_c: 6.0,
            warmup_tau_s: 600.0,
            lsb_c: 0.01,
        }
    }
}

/// How the IMU sits on its base: `C_s^b` and the antenna.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Mounting {
    /// ZYX Euler angles of the IMU's axes `s` in the base `b`, deg (roll,
    /// pitch, yaw: `C_s^b = Rz(yaw) Ry(pitch) Rx(roll)`, as `[base]` gives
    /// `b` in `n`). Zero: `s` = `b`.
    pub imu_to_base_deg: [f64; 3],
    /// The GNSS antenna's position from the IMU, in `b`, m (`None`: the
    /// recording's `[gnss] antenna_b_m`).
    pub antenna_b_m: Option<[f64; 3]>,
}

impl Mounting {
    /// Whether `s` = `b`.
    pub fn is_identity(&self) -> bool {
        self.imu_to_base_deg == [0.0; 3]
    }

    /// `C_s^b`.
    pub fn c_s_b(&self) -> Matrix3<f64> {
        let [r, p, y] = self.imu_to_base_deg;
        let e = core_nav::attitude::Euler::<f64>::from_deg(r, p, y);
        core_nav::attitude::quat_to_dcm(&core_nav::attitude::euler_to_quat(&e))
    }
}
