//! The same run on another clock is the same run (issue 46's metamorphic
//! checks on real data nobody here made): the car minute (comma2k19) with
//! every stamp on the IMU's clock moved and the fixes' offset told so
//! gives the same errors and trajectory; the real stepper run with both
//! clocks moved gives the same diagnosis. A tool that reads absolute time
//! where it should read elapsed time fails here.

use recording::Recording;
use rins::aided::{navigate, summary, AidedOptions};
use rins::import::comma::{import, CommaInput};

/// Not a whole number of samples, blocks or seconds: 1000.0137 s.
const DT_S: f64 = 1000.0137;

/// Every stamp on the IMU's clock moved by `dt` s: the samples, the
/// table, the reference pose and the odometer (the fixes keep the
/// receiver's clock).
fn shift_imu_clock(rec: &mut Recording, dt: f64) {
    rec.imu.iter_mut().for_each(|r| r.t_s += dt);
    rec.table.iter_mut().for_each(|r| r.t_s += dt);
    if let Some(m) = rec.moving.as_mut() {
        m.truth.iter_mut().flatten().for_each(|r| r.t_s += dt);
        m.odometer.iter_mut().flatten().for_each(|r| r.t_s += dt);
    }
}

#[test]
fn the_car_minute_on_a_moved_imu_clock_with_the_offset_told_is_the_same_drive() {
    // The car minute with a 15 s outage, the fixes on the IMU's clock
    // (the import puts them there: comma_real). Moved by DT_S: the outage
    // on the IMU's clock moves with it, the fixes' offset grows by DT_S. The
    // filter sees the same numbers bar the stamps' rounding (1e-13 s at
    // 1000 s): every figure the summary prints, and each row's position,
    // agree to a micrometre.
    let input = CommaInput {
        dir: rins_tests::data::bundled("comma2k19_rav4_highway_60s"),
        fix_sigma_h_m: Some(2.0),
        sensor: hal_sim::sensor::resolve("icm42605").unwrap(),
    };
    let (rec, _) = import(&input).unwrap();
    let opt = |dt: f64| AidedOptions {
        outages: vec![(20.0 + dt, 15.0)],
        time_offset_s: dt,
        ..AidedOptions::new(input.sensor.clone())
    };
    let base_run = navigate(&rec, &opt(0.0), &mut |_| {}).unwrap();
    let base = summary(&rec, &base_run);
    let mut moved = rec.clone();
    shift_imu_clock(&mut moved, DT_S);
    let run = navigate(&moved, &opt(DT_S), &mut |_| {}).unwrap();
    let again = summary(&moved, &run);
    print!("{}{}", base.text(), again.text());
    let close = |a: Option<f64>, b: Option<f64>, what: &str| {
        let (a, b) = (a.unwrap(), b.unwrap());
        assert!((a - b).abs() < 1e-6, "{what}: {a} against {b}");
    };
    close(
        base.h_rms_with_gnss_m,
        again.h_rms_with_gnss_m,
        "rms with GNSS",
    );
    close(base.nis_mean_per_dof, again.nis_mean_per_dof, "NIS");
    close(base.nees_mean_per_dof, again.nees_mean_per_dof, "NEES");
    assert_eq!(base.outages.len(), again.outages.len());
    for (x, y) in base.outages.iter().zip(&again.outages) {
        assert!((x.start_s + DT_S - y.start_s).abs() < 1e-6, "{x:?} {y:?}");
        close(x.end_error_m, y.end_error_m, "outage end");
        assert!((x.end_sigma_m - y.end_sigma_m).abs() < 1e-6, "{x:?} {y:?}");
    }
    assert_eq!(base_run.reinits, run.reinits);
    assert_eq!(base_run.rows.len(), run.rows.len());
    for (a, b) in base_run.rows.iter().zip(&run.rows) {
        assert!((a.traj.t_s + DT_S - b.traj.t_s).abs() < 1e-6);
        for i in 0..3 {
            assert!(
                (a.traj.ned_m[i] - b.traj.ned_m[i]).abs() < 1e-6,
                "t {} s: {:?} against {:?}",
                a.traj.t_s,
                a.traj.ned_m,
                b.traj.ned_m
            );
        }
    }
}

#[test]
fn the_real_stepper_run_on_a_moved_clock_gives_the_same_diagnosis() {
    // The bundled real stepper run (300 s, MPU-6050) with the IMU's and
    // the encoder's stamps moved together by DT_S: the same effects named,
    // each parameter within a hundredth of its sigma (the stamps'
    // rounding is 1e-13 s). Before: 32 intervals of exactly 2.5 periods
    // were gaps or not with the rounding (`recording::segments`), and
    // near-equal knots of the encoder's track swapped: another effect
    // named, the untracked motion's peak at 13 Hz instead of 49.
    let p = rins_tests::data::bundled("mpu6050_stepper_roll_slow_300s");
    let rec = Recording::read(&p).unwrap();
    let mut moved = rec.clone();
    shift_imu_clock(&mut moved, DT_S);
    let o = rins::diagnose::Options::default();
    let a = rins::diagnose::run(&rec, "stepper", &o).unwrap();
    let b = rins::diagnose::run(&moved, "stepper, moved", &o).unwrap();
    let names = |d: &diagnose::Diagnosis| -> Vec<String> {
        d.findings
            .iter()
            .map(|f| f.effect.as_str().to_string())
            .collect()
    };
    println!("{:?}", names(&a));
    assert!(!a.findings.is_empty(), "the real run shows effects");
    assert_eq!(names(&a), names(&b));
    for (fa, fb) in a.findings.iter().zip(&b.findings) {
        for (pa, pb) in fa.parameters.iter().zip(&fb.parameters) {
            let s = pa.sigma.unwrap_or(pa.value.abs() * 1e-3).max(1e-12);
            assert!(
                (pa.value - pb.value).abs() < 0.01 * s,
                "{} {}: {} against {} (sigma {s})",
                fa.effect,
                pa.name,
                pa.value,
                pb.value
            );
        }
    }
}
