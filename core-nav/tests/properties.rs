//! Round trips and invariants of the attitude toolkit (proptest).

use core_nav::attitude::*;
use core_nav::real::{sin_cos, wrap_pi};
use core_nav::table::{q_b_n, q_s_b, Axis, TableAngle};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use proptest::prelude::*;

fn unit_quat() -> impl Strategy<Value = Quaternion<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
        .prop_filter("non-zero", |(a, b, c, d)| {
            a * a + b * b + c * c + d * d > 1e-3
        })
        .prop_map(|(a, b, c, d)| Quaternion::new(a, b, c, d).normalize())
}

fn same_rotation(a: &Quaternion<f64>, b: &Quaternion<f64>) -> f64 {
    // q and -q are the same rotation.
    (a - b).norm().min((a + b).norm())
}

proptest! {
    #[test]
    fn quat_dcm_round_trip(q in unit_quat()) {
        let back = dcm_to_quat(&quat_to_dcm(&q));
        prop_assert!(same_rotation(&q, &back) < 1e-14);
        // The DCM is orthonormal with determinant +1.
        let c = quat_to_dcm(&q);
        prop_assert!((c * c.transpose() - nalgebra::Matrix3::identity()).norm() < 1e-14);
        prop_assert!((c.determinant() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn dcm_agrees_with_nalgebra(q in unit_quat()) {
        // Independent implementation: nalgebra's UnitQuaternion rotation matrix.
        let c = quat_to_dcm(&q);
        let n = UnitQuaternion::from_quaternion(q).to_rotation_matrix();
        prop_assert!((c - n.matrix()).norm() < 1e-14);
        let v = Vector3::new(0.3, -1.2, 2.0);
        prop_assert!((rotate(&q, &v) - n * v).norm() < 1e-14);
    }

    #[test]
    fn euler_round_trip(r in -3.1..3.1f64, p in -1.55..1.55f64, h in -3.1..3.1f64) {
        let e = Euler { roll: r, pitch: p, heading: h };
        let back = quat_to_euler(&euler_to_quat(&e));
        // Near gimbal lock (|pitch| -> 90 deg) roll and heading lose
        // precision as eps / cos(pitch): cos(1.55) = 0.021 -> ~1e-13.
        prop_assert!((wrap_pi(back.roll - r)).abs() < 1e-12);
        prop_assert!((back.pitch - p).abs() < 1e-12);
        prop_assert!((wrap_pi(back.heading - h)).abs() < 1e-12);
        // Against nalgebra's own ZYX convention.
        let n = UnitQuaternion::from_euler_angles(r, p, h);
        prop_assert!(same_rotation(&euler_to_quat(&e), n.quaternion()) < 1e-14);
    }

    #[test]
    fn rotvec_round_trip(x in -1.8..1.8f64, y in -1.8..1.8f64, z in -1.8..1.8f64) {
        let phi = Vector3::new(x, y, z);
        prop_assume!(phi.norm() < 3.1);
        let q = rotvec_to_quat(&phi);
        prop_assert!((q.norm() - 1.0).abs() < 1e-15);
        prop_assert!((quat_to_rotvec(&q) - phi).norm() < 1e-13);
        // nalgebra's exponential as the independent check.
        let n = UnitQuaternion::from_scaled_axis(phi);
        prop_assert!(same_rotation(&q, n.quaternion()) < 1e-15);
    }

    #[test]
    fn sin_cos_f32_close_to_f64(x in -6.3..6.3f64) {
        let (s, c) = sin_cos(x as f32);
        // 2 ulp of 1 in f32 plus the argument's own rounding (|x| ulp/2).
        let tol = 2.4e-7 + x.abs() * 6e-8;
        prop_assert!((f64::from(s) - libm::sin(f64::from(x as f32))).abs() < tol);
        prop_assert!((f64::from(c) - libm::cos(f64::from(x as f32))).abs() < tol);
    }

    #[test]
    fn body_attitude_undoes_the_table(q in unit_quat(), theta in -50.0..50.0f64) {
        for axis in [Axis::X, Axis::Y, Axis::Z] {
            let q_s_n = q * q_s_b(axis, theta);
            prop_assert!(same_rotation(&q_b_n(&q_s_n, axis, theta), &q) < 1e-13);
        }
    }

    #[test]
    fn table_angle_round_trip(a in -1.0e4..1.0e4f64, d in -10.0..10.0f64) {
        let t = TableAngle::<f64>::from_rad_f64(a);
        prop_assert!(t.rad >= 0.0 && t.rad < core::f64::consts::TAU);
        prop_assert!((t.to_rad_f64() - a).abs() < 1e-11);
        let u = t.plus(d);
        prop_assert!((u.minus(&t) - d).abs() < 1e-11);
    }
}
