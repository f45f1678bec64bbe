//! The moving base: hal-sim's vehicle (its kinematics integrated on its
//! own, `hal_sim::drive`) against core-nav's mechanization fed with the
//! ideal sensor on the spinning table. Two independent integrations of the
//! same motion: one of the plan's speed and heading into latitude and
//! longitude, one of the sensor's rates and specific forces through the
//! strapdown equations.

use core_nav::attitude::{dcm_to_quat, quat_to_dcm};
use core_nav::earth::GeoPoint;
use core_nav::strapdown::{ImuSample, Strapdown, StrapdownConfig};
use hal_sim::drive::{Drive, DriveKind, Vehicle};
use nalgebra::{Rotation3, Vector3};

fn ideal_run(kind: DriveKind, duration_s: f64, table_dps: f64) -> (f64, f64, f64) {
    ideal_run_mounted(kind, duration_s, table_dps, [0.0; 3])
}

fn ideal_run_mounted(
    kind: DriveKind,
    duration_s: f64,
    table_dps: f64,
    mounting_deg: [f64; 3],
) -> (f64, f64, f64) {
    let origin = GeoPoint::from_deg(30.53, 114.35, 20.0);
    let drive = Drive::plan(kind, duration_s, 7);
    let mut veh = Vehicle::new(drive, origin, 30.0, hal_sim::drive::mounting(mounting_deg));
    let rate = table_dps.to_radians();
    let sample = |v: &hal_sim::drive::VehicleState| {
        let (w_b, f_b) = v.ideal_b();
        let theta = rate * v.t_s;
        let c_b_s = Rotation3::from_axis_angle(&Vector3::z_axis(), theta)
            .matrix()
            .transpose();
        ImuSample::<f64> {
            t_us: (v.t_s * 1e6).round() as u64,
            w_is_s: c_b_s * w_b + Vector3::z() * rate,
            f_s: c_b_s * f_b,
        }
    };
    let s0 = *veh.state();
    let mut nav = Strapdown::new(
        StrapdownConfig::default(),
        s0.pos,
        s0.v_n,
        dcm_to_quat(&s0.c_b_n()),
        &sample(&s0),
    )
    .unwrap();
    let n = (duration_s * 100.0) as usize;
    let (mut worst_p, mut worst_v, mut worst_att) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..n {
        for _ in 0..10 {
            veh.step(1e-3);
        }
        let v = *veh.state();
        nav.step(&sample(&v)).unwrap();
        let st = nav.state();
        let p_nav = nav.earth().point_at(&st.p_n);
        let dp = origin.ned_to(&p_nav) - origin.ned_to(&v.pos);
        worst_p = worst_p.max(Vector3::new(dp.x, dp.y, 0.0).norm());
        worst_v = worst_v.max((st.v_n - v.v_n).norm());
        // Base attitude: c_b_n = c_s_n c_b_s^T.
        let theta = rate * v.t_s;
        let c_s_b = *Rotation3::from_axis_angle(&Vector3::z_axis(), theta).matrix();
        let c_b_n_nav = quat_to_dcm(&st.q_s_n) * c_s_b.transpose();
        let m = c_b_n_nav * v.c_b_n().transpose();
        let ang = ((m.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos();
        worst_att = worst_att.max(ang);
    }
    (worst_p, worst_v, worst_att)
}

#[test]
fn a_city_drive_mechanized_from_its_ideal_sensor_follows_the_vehicle() {
    // 300 s of city driving (stops, 8-14 m/s, right-angle turns, hills)
    // with the table at 30 deg/s. Tolerances from the two integrations'
    // own errors: the mechanization's third-order attitude and trapezoid
    // velocity at 100 Hz on accelerations that change within 0.8 s edges,
    // the vehicle's midpoint rule at 1 kHz, the body's bounce on its
    // suspension near 1.5 Hz; measured 1.2e-3 m, 7.6e-5 m/s, 2.5e-7 rad;
    // bounded at 0.01 m, 1e-3 m/s, 1e-6 rad (horizontal).
    let (p, v, a) = ideal_run(DriveKind::City, 300.0, 30.0);
    println!("city: worst horizontal {p:.2e} m, velocity {v:.2e} m/s, attitude {a:.2e} rad");
    assert!(p < 0.01 && v < 1e-3 && a < 1e-6);
}

#[test]
fn a_highway_drive_without_the_table_follows_the_vehicle() {
    let (p, v, a) = ideal_run(DriveKind::Highway, 300.0, 0.0);
    println!("highway: worst horizontal {p:.2e} m, velocity {v:.2e} m/s, attitude {a:.2e} rad");
    assert!(p < 0.01 && v < 1e-3 && a < 1e-6);
}

#[test]
fn a_base_mounted_askew_in_the_vehicle_still_follows_it() {
    // The base yawed 185 deg, rolled 180 deg (upside down) and pitched 3
    // deg in the car, as the held-back drive's: its ideal sensor's rates
    // and forces, mechanized from the base's attitude, follow the vehicle
    // to the same tolerances as the base aligned with it (the rotation is
    // constant, so nothing of the integration changes).
    let (p, v, a) = ideal_run_mounted(DriveKind::City, 300.0, 30.0, [180.0, 3.0, 185.0]);
    println!("mounted: worst horizontal {p:.2e} m, velocity {v:.2e} m/s, attitude {a:.2e} rad");
    assert!(p < 0.01 && v < 1e-3 && a < 1e-6);
}
