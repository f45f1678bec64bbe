//! Dual-axis 8- and 16-position sequences on a simulated tri-axial table:
//! exact with an ideal IMU (kinematics, the two-column calibration and the
//! gimbal attitude agree), and usable on a NAV440 once both gimbal axes are
//! calibrated (measured against continuous rotation in the book).

use hal_sim::imu::ImuSpec;
use rins::reproduce::{mean, run_one, Plan};

#[test]
fn dual_axis_sequences_navigate_an_ideal_imu_exactly() {
    for positions in [8, 16] {
        let e = run_one(&ImuSpec::ideal(), Plan::DualAxis { positions }, 30.0, 1).unwrap();
        println!("dual-{positions}, ideal IMU: {}", rins::nav::summary(&e));
        // Exact to the encoder-free kinematics: centimetres and arcseconds.
        assert!(
            e.h_pos_rms_m < 0.05 && e.roll_rms_deg < 0.001 && e.pitch_rms_deg < 0.001,
            "{e:?}"
        );
    }
}

#[test]
fn dual_axis_on_nav440_stays_within_twice_continuous_rotation() {
    let spec = ImuSpec::nav440();
    let runs = |plan| {
        mean(
            &(0..3)
                .map(|s| run_one(&spec, plan, 30.0, 40 + s).unwrap())
                .collect::<Vec<_>>(),
        )
    };
    let (best, dual) = (runs(Plan::Best), runs(Plan::DualAxis { positions: 16 }));
    println!(
        "30 deg/s, NAV440: continuous {:.0} m, dual-16 {:.0} m",
        best.h_pos_rms_m, dual.h_pos_rms_m
    );
    assert!(dual.h_pos_rms_m < 2.0 * best.h_pos_rms_m);
}
