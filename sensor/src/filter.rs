//! The filter's noise model from a sensor's error budget (no_std): the
//! one derivation the host's aided navigation (`rins navigate --gnss`)
//! and the board's build (firmware's build.rs, from its sensor file) both
//! use.

use crate::spec::{TempSpec, TriadSpec, G0};
use core_nav::aided::{gnss_corr_sigma_m, ZuptNoise};
use core_nav::eskf::{EskfConfig, WarmupDrift};

/// The filter's noise model from a sensor profile (its datasheet
/// figures): white noise as given; each bias starts at its turn-on and
/// instability 1-sigma, and moves in run as a Gauss-Markov process with
/// the instability's correlation time whose process noise holds the
/// instability (`2 sigma^2 / tau`) and the rate random walk; the warm-up
/// adds the temperature coefficients times its rise to the biases and the
/// gyro scales ([`WarmupDrift`]: a random walk that fades with the
/// warm-up's time constant). The turn-on bias is
/// constant in a run: taken as process noise (as before), it let the
/// ICM-42688-P's 0.5 deg/s turn-on bias grow the bias sigma by 0.1 deg/s
/// per 100 s outage and made the filter pessimistic (NEES 0.65 per degree
/// of freedom).
pub fn filter_config(
    gyro: &TriadSpec,
    accel: &TriadSpec,
    temp: &TempSpec,
    gate_sigma: f64,
) -> EskfConfig {
    let warm = temp;
    // The bias state holds the turn-on bias, constant in a run, and the
    // in-run motion on top: it does not decay (a Gauss-Markov decay would
    // make the filter forget the turn-on bias: after a few correlation
    // times it took the bias as known, and on a spinning table the level,
    // which a bias across the table axis tilts by bias / rate in the
    // sensor's frame, with it: level NEES 16 per degree of freedom on
    // the ICM-42688-P); the in-run motion is its random walk, the density
    // the Gauss-Markov process has at its correlation time.
    let in_run = |bi: f64, tau: f64, rrw: f64| {
        let tau = if tau > 0.0 { tau } else { 3600.0 };
        let q = 2.0 * bi * bi / tau + rrw * rrw;
        (libm::sqrt(q * BIAS_HOLD_S / 2.0), BIAS_HOLD_S)
    };
    let g = gyro;
    let a = accel;
    let (gs, gt) = in_run(g.bias_instability, g.bi_tau_s, g.rrw);
    let (as_, at) = in_run(a.bias_instability, a.bi_tau_s, a.rrw);
    EskfConfig {
        gyro_arw: g.white.max(1e-6),
        accel_vrw: a.white.max(1e-5),
        gyro_bias_init_sigma: libm::hypot(g.bias, g.bias_instability),
        gyro_bias_sigma: gs.max(1e-7),
        gyro_bias_tau_s: gt,
        accel_bias_init_sigma: libm::hypot(a.bias, a.bias_instability),
        accel_bias_sigma: as_.max(1e-6),
        accel_bias_tau_s: at,
        gate_sigma,
        gyro_scale_sigma: g.scale.max(1e-5),
        gyro_misalignment_sigma: g.misalignment.max(1e-5),
        accel_scale_sigma: a.scale.max(1e-5),
        accel_misalignment_sigma: a.misalignment.max(1e-5),
        warmup: WarmupDrift {
            tau_s: warm.warmup_tau_s.max(1.0),
            gyro_bias: g.temp_bias * warm.warmup_c,
            accel_bias: a.temp_bias * warm.warmup_c,
            gyro_scale: g.temp_scale * warm.warmup_c,
        },
        // A 1.5 m (3 m vertical) automotive receiver's, hal-sim's default,
        // until a navigator sizes it from its fixes.
        gnss_corr_sigma_m: gnss_corr_sigma_m(1.5, 3.0),
        gnss_corr_tau_s: 60.0,
    }
}

/// The bias states' correlation time in the filter, s: long enough that
/// they do not decay over any run (a random walk of the same density).
pub const BIAS_HOLD_S: f64 = 1e7;

/// The zero-velocity detector's per-sample noise for a sensor sampled at
/// `rate_hz`: white noise over the interval and quantisation, at least
/// 0.1 mg and 0.001 deg/s (an ideal sensor's zero would make every
/// window moving).
pub fn zupt_noise(gyro: &TriadSpec, accel: &TriadSpec, rate_hz: f64) -> ZuptNoise {
    let per = |white: f64, lsb: f64, floor: f64| {
        libm::sqrt(white * white * rate_hz + lsb * lsb / 12.0).max(floor)
    };
    ZuptNoise {
        sigma_f_mps2: per(accel.white, accel.lsb, 1e-4 * G0),
        sigma_w_radps: per(gyro.white, gyro.lsb, 1e-3 * crate::spec::DEG),
        sigma_table_rate_radps: 0.0,
    }
}
