//! `rins diagnose`, first version: hidden effects are named on a white-noise
//! background, and a white-noise-only run gives no finding.

use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig};

fn run(effect: Option<(&str, f64)>, seed: u64) -> Vec<String> {
    // The nominal model's terms (bias, scale, misalignment) plus white noise.
    let mut s = ImuSpec::ideal();
    let nav = ImuSpec::nav440();
    s.gyro.bias = nav.gyro.bias;
    s.gyro.scale = nav.gyro.scale;
    s.gyro.misalignment = nav.gyro.misalignment;
    s.gyro.white = nav.gyro.white;
    s.accel.bias = nav.accel.bias;
    s.accel.white = nav.accel.white;
    let mut c = SimConfig::new(s, Axis::Z, 400.0);
    c.scheme = Scheme::Reciprocating {
        rate: 60f64.to_radians(),
        turns: 2,
    };
    c.seed = seed;
    if let Some((name, v)) = effect {
        c.set_effect(name, v).unwrap();
    }
    let rec = simulate(&c, &mut |_| {}).unwrap();
    let report = rins::diagnose::diagnose(&rec, "test");
    report["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["effect"].as_str().unwrap().to_string())
        .collect()
}

#[test]
fn hidden_effects_are_named_first() {
    for (name, v) in [
        ("lever_arm", 0.05),
        ("time_offset", 0.005),
        ("gyro_scale_nonlinearity", 0.01),
    ] {
        let found = run(Some((name, v)), 3);
        println!("{name}: {found:?}");
        assert_eq!(
            found.first().map(String::as_str),
            Some(name),
            "{name}: {found:?}"
        );
    }
}

#[test]
fn white_noise_only_gives_no_finding() {
    for seed in [1, 2] {
        let found = run(None, seed);
        println!("null {seed}: {found:?}");
        assert!(found.is_empty(), "{found:?}");
    }
}
