//! Alignment of a still base (`rins::align`, `rins navigate` without GNSS)
//! on simulated runs whose attitude the simulator knows: the level found
//! within its own 3 sigma, north found by gyrocompassing where the turning
//! table averages the gyro biases away and refused where it cannot, and a
//! tilt that `meta.toml` does not know found and navigated through.
//! Our own simulator only; the closed form of gyrocompassing is checked in
//! core-nav (`align::tests`).

use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig};
use recording::Recording;
use rins::align::align;
use rins::nav::{navigate, static_errors, NavOptions};

/// The board's ICM-42688-P on a z table at `lat_deg`, the base at `rph`
/// (deg), 60 s still then turning at 30 deg/s.
fn run(lat_deg: f64, rph: [f64; 3], seed: u64) -> Recording {
    let mut c = SimConfig::new(ImuSpec::icm42688(), Axis::Z, 240.0);
    c.scheme = Scheme::Continuous {
        rate: 30f64.to_radians(),
    };
    c.static_s = 60.0;
    c.site = core_nav::site::Site::new(lat_deg, 20.0);
    c.base_deg = rph;
    c.seed = seed;
    simulate(&c, &mut |_| {}).unwrap()
}

fn wrap(d: f64) -> f64 {
    (d + 540.0).rem_euclid(360.0) - 180.0
}

#[test]
fn the_level_and_north_come_out_within_their_sigma_on_a_turning_table() {
    // South and north, several headings: whole turns average the biases
    // across the axis away, so the level is good to the accelerometers'
    // noise and the heading to the gyros' (a few degrees in 48 s).
    let p = ImuSpec::icm42688();
    for (k, (lat, h)) in [(-33.9, 40.0), (30.5, 200.0), (51.5, 300.0)]
        .into_iter()
        .enumerate()
    {
        let rph = [0.0, 0.0, h];
        let rec = run(lat, rph, 10 + k as u64);
        let al = align(&rec, 120.0, Some(&p)).unwrap();
        println!("{lat} {h}: {:?} +- {:?}", al.euler_deg, al.sigma_deg);
        assert!(al.turns >= 1.0 && al.gyrocompassed, "{al:?}");
        let got = al.euler_deg.iter().zip(rph).zip(al.sigma_deg);
        for (i, ((got, want), sigma)) in got.enumerate() {
            let e = wrap(got - want).abs();
            assert!(e < 3.0 * sigma, "{lat} {h} axis {i}: {e} vs {sigma}");
        }
        assert!(al.sigma_deg[2] < 10.0);
    }
}

#[test]
fn a_still_table_cannot_gyrocompass_a_mems_gyro_and_says_so() {
    // The ICM-42688-P's 0.5 deg/s turn-on bias is 140 times the earth's
    // horizontal rate at 30 deg: on a still table the heading is
    // meta.toml's, with the reason; the level absorbs the accelerometer
    // bias, within its sigma (the turn-on bias over g).
    let rec = run(30.5, [0.0, 0.0, 0.0], 3);
    let al = align(&rec, 0.0, Some(&ImuSpec::icm42688())).unwrap();
    assert_eq!(al.turns, 0.0);
    assert!(!al.gyrocompassed && al.sigma_deg[2].is_nan());
    assert!(al
        .heading_note
        .as_deref()
        .unwrap()
        .contains("do not resolve"));
    assert!(al.euler_deg[0].abs() < 3.0 * al.sigma_deg[0], "{al:?}");
    // Without a sensor profile the bias is unknown: no heading either.
    let al = align(&rec, 0.0, None).unwrap();
    assert!(!al.gyrocompassed && al.sigma_deg[0].is_nan());
}

#[test]
fn a_tilt_meta_toml_does_not_know_is_found_and_navigated_through() {
    // The case: the base tilted 0.3 / -0.2 deg, meta.toml level.
    // Aligned, the level is found within 3 sigma and the 3 minutes after
    // the calibration end far closer than from meta.toml's level.
    let truth = [-0.2, 0.3, 0.0];
    let mut rec = run(30.5, truth, 5);
    rec.meta.roll_deg = 0.0;
    rec.meta.pitch_deg = 0.0;
    let al = align(&rec, 120.0, Some(&ImuSpec::icm42688())).unwrap();
    let level = al.euler_deg.iter().zip(truth).zip(al.sigma_deg).take(2);
    for ((got, want), sigma) in level {
        assert!((got - want).abs() < 3.0 * sigma, "{al:?}");
    }
    // The power-up calibration, as on the board and in `rins navigate
    // --calibration` (the meta.toml level is what it is given too).
    let cal = rins::calibrate::calibrate(&rec, (0.0, 120.0), rins::calibrate::Method::Auto, None)
        .unwrap()
        .gyro;
    let nav = |base: Option<core_nav::attitude::Euler<f64>>| {
        let o = NavOptions {
            start_s: 120.0,
            base,
            calibration: Some(cal),
            ..NavOptions::default()
        };
        let rows = navigate(&rec, &o, &mut |_| {}).unwrap();
        static_errors(&rows, truth).h_pos_end_m
    };
    let [r, p, h] = al.euler_deg;
    let aligned = nav(Some(core_nav::attitude::Euler::from_deg(r, p, h)));
    let given = nav(None);
    println!("final error: aligned {aligned:.0} m, meta.toml's level {given:.0} m");
    assert!(aligned * 2.0 < given, "{aligned} vs {given}");
}
