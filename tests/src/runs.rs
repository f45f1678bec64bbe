//! Simulated runs that several scenario tests diagnose.

use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::SimConfig;

/// A NAV440 reduced to bias, scale, misalignment and white noise (with its
/// wandering gyro bias when `wander`) and its temperature behaviour,
/// reciprocating two turns each way at 60 deg/s about `axis` after 30 s
/// still, `duration_s` long: the background on which one hidden effect at
/// a time is diagnosed.
pub fn reduced_nav440(axis: Axis, wander: bool, seed: u64, duration_s: f64) -> SimConfig {
    let mut s = ImuSpec::ideal();
    let nav = ImuSpec::nav440();
    s.gyro.bias = nav.gyro.bias;
    s.gyro.scale = nav.gyro.scale;
    s.gyro.misalignment = nav.gyro.misalignment;
    s.gyro.white = nav.gyro.white;
    if wander {
        s.gyro.bias_instability = nav.gyro.bias_instability;
        s.gyro.bi_tau_s = nav.gyro.bi_tau_s;
    }
    s.accel.bias = nav.accel.bias;
    s.accel.scale = nav.accel.scale;
    s.accel.white = nav.accel.white;
    s.temp = nav.temp;
    let mut c = SimConfig::new(s, axis, duration_s);
    c.scheme = Scheme::Reciprocating {
        rate: 60f64.to_radians(),
        turns: 2,
    };
    c.static_s = 30.0;
    c.seed = seed;
    c
}
