//! `--ideal` recordings match the recording spec's formulas to 1e-9 rad/s
//! and 1e-9 m/s^2, for table axes x, y and z and a non-zero heading. The
//! expected values are computed here from the spec's text with nalgebra's
//! `Rotation3` and a separately written normal gravity, and the recording
//! goes through the writer and reader first.

use core_nav::scheme::Scheme;
use core_nav::table::Axis;
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig};
use hal_sim::world::Site;
use nalgebra::{Rotation3, Vector3};
use recording::Recording;

const OMEGA_E: f64 = 7.292_115e-5;

fn gravity(lat: f64, h: f64) -> f64 {
    let s2 = lat.sin().powi(2);
    let g0 = 9.780_325_335_9 * (1.0 + 0.001_931_852_652_41 * s2)
        / (1.0 - 0.006_694_379_990_14 * s2).sqrt();
    let a = 6_378_137.0;
    let f = 1.0 / 298.257_223_563;
    g0 * (1.0 - 2.0 / a * (1.0 + f + 0.003_449_786_506_84 - 2.0 * f * s2) * h
        + 3.0 * h * h / (a * a))
}

/// Continuous scheme: still for `t0` s, then accelerate at `acc` to `rate`.
fn kinematics(t: f64, t0: f64, rate: f64, acc: f64) -> (f64, f64) {
    let tau = t - t0;
    if tau <= 0.0 {
        return (0.0, 0.0);
    }
    let t_r = rate / acc;
    if tau < t_r {
        (0.5 * acc * tau * tau, acc * tau)
    } else {
        (0.5 * rate * t_r + rate * (tau - t_r), rate)
    }
}

#[test]
fn ideal_recording_follows_the_spec_formulas() {
    let dir = std::env::temp_dir().join(format!("rins-ideal-{}", std::process::id()));
    for (i, (axis, k)) in [
        (Axis::X, Vector3::x()),
        (Axis::Y, Vector3::y()),
        (Axis::Z, Vector3::z()),
    ]
    .into_iter()
    .enumerate()
    {
        let (lat_deg, h, heading, pitch, roll) = (47.3, 410.0, 37.5, 1.2, -2.1);
        let rate = 75f64.to_radians();
        let mut cfg = SimConfig::new(ImuSpec::ideal(), axis, 20.0);
        cfg.ideal = true;
        cfg.scheme = Scheme::Continuous { rate };
        cfg.static_s = 2.0;
        cfg.site = Site::new(lat_deg, h);
        cfg.base_deg = [roll, pitch, heading];
        let rec = simulate(&cfg, &mut |_| {}).unwrap();
        let d = dir.join(format!("{i}"));
        rec.write(&d).unwrap();
        let rec = Recording::read(&d).unwrap();

        let lat = f64::to_radians(lat_deg);
        let g = gravity(lat, h);
        assert!((rec.meta.gravity_mps2.unwrap() - g).abs() < 1e-9);
        let c_b_n = Rotation3::from_euler_angles(
            roll.to_radians(),
            pitch.to_radians(),
            heading.to_radians(),
        );
        let w_ie_n = Vector3::new(OMEGA_E * lat.cos(), 0.0, -OMEGA_E * lat.sin());
        let acc = cfg.limits.max_accel;
        let (mut wmax, mut fmax, mut amax) = (0.0_f64, 0.0_f64, 0.0_f64);
        for r in &rec.imu {
            let (theta, theta_dot) = kinematics(r.t_s, 2.0, rate, acc);
            // c_s_b = exp(theta [k x]); c_b_s = its transpose.
            let c_b_s =
                Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(k), theta).inverse();
            let c_n_s = c_b_s * c_b_n.inverse();
            let w = c_n_s * w_ie_n + k * theta_dot;
            let f = c_n_s * Vector3::new(0.0, 0.0, -g);
            wmax = wmax.max((Vector3::from(r.gyro_radps) - w).amax());
            fmax = fmax.max((Vector3::from(r.accel_mps2) - f).amax());
        }
        for r in &rec.table {
            let (theta, _) = kinematics(r.t_s, 2.0, rate, acc);
            amax = amax.max((r.angle_rad - theta).abs());
        }
        println!("axis {axis:?}: max |gyro err| {wmax:.2e} rad/s, |accel err| {fmax:.2e} m/s^2, |angle err| {amax:.2e} rad");
        assert!(wmax < 1e-9 && fmax < 1e-9, "axis {axis:?}: {wmax} {fmax}");
        // Angles: 1e-9 rad relative to up to 26 rad.
        assert!(amax < 1e-9, "axis {axis:?}: angle {amax}");
        assert_eq!(rec.imu.len(), 2001);
        assert_eq!(rec.table.len(), 1001);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
