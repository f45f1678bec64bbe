//! An effect hidden in a real run (issue 33's injection harness): the
//! bundled real stepper-table run (MPU-6050 on a stepper shaft, MIT; its
//! first 300 s) with one effect of datasheet size added, computed from
//! the run's own encoder reads (their finite differences: the motion as
//! the encoder saw it, steps and all, not diagnose's own track) and
//! re-quantised to the sensor's own print lattice, so the copy looks like
//! the original. diagnose's change between the copy and the untouched run
//! must be the injected size within 35 % + 3 sigma.

use hal_sim::catalogue::EffectId;
use nalgebra::Vector3;
use recording::Recording;
use rins::diagnose::{run, Diagnosis, Options};

fn real() -> Recording {
    Recording::read(&rins_tests::data::bundled("mpu6050_stepper_roll_slow_300s")).unwrap()
}

/// The encoder's rate and acceleration at `t` (rad/s, rad/s^2): the
/// reads' differences, linear between the intervals' midpoints.
fn encoder_motion(rec: &Recording, t: f64) -> (f64, f64) {
    let mid: Vec<(f64, f64)> = rec
        .table
        .windows(2)
        .map(|w| (0.5 * (w[0].t_s + w[1].t_s), w[0].rate_to(&w[1])))
        .collect();
    let i = mid.partition_point(|m| m.0 <= t).clamp(1, mid.len() - 1);
    let ((t0, w0), (t1, w1)) = (mid[i - 1], mid[i]);
    let a = (w1 - w0) / (t1 - t0);
    (w0 + a * (t - t0), a)
}

/// `rec` with a lever arm `r` (m, sensor frame) added to its specific
/// force, rounded to each channel's print lattice.
fn with_lever(rec: &Recording, r: Vector3<f64>) -> Recording {
    let k = rec.meta.axis.unit::<f64>();
    let mut out = rec.clone();
    let lattice: Vec<f64> = (3..6)
        .map(|ch| {
            let x: Vec<f64> = rec.imu.iter().map(|s| s.channel(ch)).collect();
            recording::plausible::lattice(&x).expect("the MPU-6050's print lattice")
        })
        .collect();
    for s in &mut out.imu {
        let (w, a) = encoder_motion(rec, s.t_s);
        let add = k.cross(&r) * a + k.cross(&k.cross(&r)) * w * w;
        for i in 0..3 {
            let q = lattice[i];
            s.accel_mps2[i] = ((s.accel_mps2[i] + add[i]) / q).round() * q;
        }
    }
    out
}

fn lever(d: &Diagnosis, name: &str) -> (f64, f64) {
    d.findings
        .iter()
        .filter(|f| f.effect == EffectId::LeverArm)
        .flat_map(|f| f.parameters.iter())
        .find(|p| p.name == name)
        .map_or((0.0, 0.0), |p| (p.value, p.sigma.unwrap_or(0.0)))
}

#[test]
fn a_lever_arm_hidden_in_the_real_stepper_run_is_found_at_its_size() {
    let rec = real();
    let base = run(&rec, "untouched", &Options::default()).unwrap();
    // 2 cm off the roll axis (x), along y and along z: radial both.
    for (name, r) in [
        ("lever_y_m", Vector3::new(0.0, 0.02, 0.0)),
        ("lever_z_m", Vector3::new(0.0, 0.0, 0.02)),
    ] {
        let d = run(&with_lever(&rec, r), "lever", &Options::default()).unwrap();
        let ((v1, s1), (v0, s0)) = (lever(&d, name), lever(&base, name));
        let change = v1 - v0;
        let sigma = s1.hypot(s0);
        println!(
            "{name}: untouched {:.2} +- {:.2} mm, with 20 mm hidden {:.2} +- {:.2} mm: change {:.2} mm",
            v0 * 1e3,
            s0 * 1e3,
            v1 * 1e3,
            s1 * 1e3,
            change * 1e3
        );
        let true_r = r.norm();
        assert!(
            (change - true_r).abs() <= 0.35 * true_r + 3.0 * sigma,
            "{name}: change {} mm against 20 mm",
            change * 1e3
        );
    }
}
