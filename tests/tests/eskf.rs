//! The aided filter (`core_nav::eskf`) against independent references: the
//! textbook block Kalman update (matrix inverse, `P - K S K^T`), a scalar
//! closed form, the mechanization itself for its error dynamics, and the
//! f64 twin for the f32 board filter.

use core_nav::attitude::{quat_to_dcm, rotvec_to_quat, skew};
use core_nav::earth::{earth_rate_n, GeoPoint};
use core_nav::eskf::{
    Eskf, EskfConfig, InitialSigma, WarmupDrift, I_BA, I_BG, I_GP, I_M, I_P, I_PHI, I_V, N,
};
use core_nav::site::Site;
use core_nav::strapdown::{ImuSample, Strapdown, StrapdownConfig};
use nalgebra::{DMatrix, DVector, Matrix3, Quaternion, Rotation3, Vector3};

fn cfg() -> EskfConfig {
    EskfConfig {
        gyro_arw: 0.003f64.to_radians() / 60.0_f64.sqrt() * 60.0, // 0.18 deg/sqrt(h)-class
        accel_vrw: 0.0006,
        gyro_bias_init_sigma: 10f64.to_radians() / 3600.0,
        gyro_bias_sigma: 10f64.to_radians() / 3600.0,
        gyro_bias_tau_s: 300.0,
        accel_bias_init_sigma: 0.01,
        accel_bias_sigma: 0.01,
        accel_bias_tau_s: 300.0,
        gate_sigma: 1e6,
        gyro_scale_sigma: 3e-3,
        gyro_misalignment_sigma: 1e-3,
        warmup: WarmupDrift::NONE,
        accel_scale_sigma: 3e-3,
        accel_misalignment_sigma: 1e-3,
        gnss_corr_sigma_m: [1.0, 2.0],
        gnss_corr_tau_s: 60.0,
    }
}

fn init() -> InitialSigma {
    InitialSigma {
        position_m: 3.0,
        velocity_mps: 0.3,
        level_rad: 0.01,
        heading_rad: 0.1,
    }
}

/// A filter with some cross-covariance: a few predicts on a moving,
/// turning state.
fn warmed() -> Eskf<f64> {
    warmed_m::<N>()
}

/// The textbook block update of `f0` with rows `h` (3 x N), innovation
/// `z` and per-row sigmas: `(dx, P+, NIS)` by nalgebra's dense inverse,
/// independent of the filter's scalar Joseph path.
fn block_update(
    f0: &Eskf<f64>,
    h: &DMatrix<f64>,
    z: &Vector3<f64>,
    sig: &Vector3<f64>,
) -> (DVector<f64>, DMatrix<f64>, f64) {
    let p = DMatrix::from_fn(N, N, |r, c| f0.p[(r, c)]);
    let r = DMatrix::from_diagonal(&DVector::from_iterator(3, sig.iter().map(|s| s * s)));
    let s = h * &p * h.transpose() + &r;
    let s_inv = s.clone().try_inverse().unwrap();
    let k = &p * h.transpose() * &s_inv;
    let zv = DVector::from_iterator(3, z.iter().copied());
    let nis = (zv.transpose() * &s_inv * &zv)[(0, 0)];
    (&k * &zv, &p - &k * &s * k.transpose(), nis)
}

/// `f` (updated from `f0`) equals the block update's `dx` and `P+` to
/// 1e-9 relative (f64 rounding over a well-conditioned 3 x 3 inverse).
fn assert_matches(f: &Eskf<f64>, f0: &Eskf<f64>, dx: &DVector<f64>, p_post: &DMatrix<f64>) {
    for i in 0..N {
        assert!(
            (f.dx[i] - dx[i]).abs() <= 1e-9 * (1.0 + dx[i].abs()),
            "dx {i}"
        );
        for j in 0..N {
            let (a, b) = (f.p[(i, j)], p_post[(i, j)]);
            assert!(
                (a - b).abs() <= 1e-9 * (f0.p[(i, i)] * f0.p[(j, j)]).sqrt(),
                "P {i} {j}: {a} vs {b}"
            );
        }
    }
}

#[test]
fn sequential_joseph_update_equals_the_textbook_block_update() {
    // GNSS position with a 1 m lever arm, then velocity: the block form
    // K = P H^T (H P H^T + R)^-1, P+ = P - K S K^T computed here with
    // nalgebra's dynamic inverse, independent of the filter's scalar
    // Joseph path. Agreement to 1e-9 relative (f64 rounding over a 15x15
    // inverse of a well-conditioned S).
    let f0 = warmed();
    let l_n = Vector3::new(0.4, -0.8, -0.5);
    let z = Vector3::new(1.2, -0.7, 2.1);
    let sig = Vector3::new(1.5, 1.5, 3.0);
    let mut f = f0.clone();
    let rep = f.update_position(&z, &l_n, &sig).unwrap();
    assert_eq!(rep.used, 3);
    // Block reference.
    let mut h = DMatrix::zeros(3, N);
    let lx = -skew(&l_n);
    for i in 0..3 {
        h[(i, I_P + i)] = 1.0;
        h[(i, I_GP + i)] = 1.0;
        for j in 0..3 {
            h[(i, I_PHI + j)] = lx[(i, j)];
        }
    }
    let (dx, p_post, nis) = block_update(&f0, &h, &z, &sig);
    assert_matches(&f, &f0, &dx, &p_post);
    assert!(
        (rep.nis - nis).abs() < 1e-9 * nis,
        "NIS {} vs {nis}",
        rep.nis
    );
}

#[test]
fn a_zero_rotation_update_equals_the_textbook_block_update() {
    // A still base on a table turning at 0.5 rad/s about z: the gyros'
    // mean error `dbg + dM w_s` against the block form with nalgebra's
    // inverse (as above), to the same 1e-9 relative.
    let f0 = warmed();
    let w_s = Vector3::new(1e-4, -2e-4, 0.5);
    let z = Vector3::new(2e-4, -1e-4, 3e-3);
    let sig = Vector3::new(1e-4, 1e-4, 3e-4);
    let mut f = f0.clone();
    let rep = f.update_rate(&z, &w_s, &sig).unwrap();
    assert_eq!(rep.used, 3);
    let mut h = DMatrix::zeros(3, N);
    for i in 0..3 {
        h[(i, I_BG + i)] = 1.0;
        for j in 0..3 {
            h[(i, I_M + 3 * i + j)] = w_s[j];
        }
    }
    let (dx, p_post, _) = block_update(&f0, &h, &z, &sig);
    assert_matches(&f, &f0, &dx, &p_post);
}

#[test]
fn the_warm_up_drift_adds_its_whole_spread_and_then_stops() {
    // Density sigma^2 / tau e^(-t / tau): over [0, t] it adds sigma^2 (1
    // - e^(-t / tau)) to each bias variance (the closed-form integral),
    // nothing after the warm-up. No other process noise, no dynamics
    // (a still, unrotated sensor with no force): the bias variance moves
    // by the warm-up alone. Midpoint rule over 0.1 s steps of a 60 s time
    // constant: relative error below (dt / tau)^2 / 24, 1e-7.
    let (tau, sg, sa) = (60.0, 1e-3, 2e-2);
    let c = EskfConfig {
        gyro_bias_tau_s: 0.0,
        accel_bias_tau_s: 0.0,
        warmup: WarmupDrift {
            tau_s: tau,
            gyro_bias: sg,
            accel_bias: sa,
            gyro_scale: 0.0,
        },
        ..cfg()
    };
    let mut f = Eskf::<f64>::new(c, &init());
    let (g0, a0) = (f.p[(I_BG, I_BG)], f.p[(I_BA, I_BA)]);
    let mut t = 0.0;
    for until in [60.0, 600.0, 1200.0] {
        while t < until - 1e-9 {
            let z = Vector3::zeros();
            f.predict(&Matrix3::identity(), &z, &z, &z, &z, 0.1);
            f.propagate();
            t += 0.1;
        }
        let share = 1.0 - (-t / tau).exp();
        let (dg, da) = (f.p[(I_BG, I_BG)] - g0, f.p[(I_BA, I_BA)] - a0);
        assert!((dg / (sg * sg * share) - 1.0).abs() < 1e-6, "{t} s: {dg}");
        assert!((da / (sa * sa * share) - 1.0).abs() < 1e-6, "{t} s: {da}");
    }
}

#[test]
fn a_position_fix_on_a_diagonal_prior_is_the_scalar_closed_form() {
    // Prior variance a, measurement variance r: posterior a r / (a + r),
    // gain a / (a + r) (any textbook). The receiver's correlated error is
    // switched off here (its sigma 0) so the position is the only state
    // the fix sees.
    let mut f = Eskf::<f64>::new(
        EskfConfig {
            gnss_corr_sigma_m: [0.0, 0.0],
            ..cfg()
        },
        &init(),
    );
    let a = 9.0;
    let r = 2.25;
    let rep = f
        .update_position(
            &Vector3::new(1.0, 2.0, -1.0),
            &Vector3::zeros(),
            &Vector3::repeat(1.5),
        )
        .unwrap();
    for i in 0..3 {
        assert!((f.p[(I_P + i, I_P + i)] - a * r / (a + r)).abs() < 1e-12);
    }
    assert!((f.dx[I_P] - a / (a + r)).abs() < 1e-12);
    assert!((f.dx[I_P + 1] - 2.0 * a / (a + r)).abs() < 1e-12);
    assert!((rep.nis - (1.0 + 4.0 + 1.0) / (a + r)).abs() < 1e-12);
}

#[test]
fn the_error_dynamics_follow_the_mechanization() {
    // A static base with the table turning at 30 deg/s about z: the truth
    // stays at rest. A second mechanization starts with an attitude error
    // and integrates samples carrying a gyro and an accelerometer bias; its
    // error after 20 s (truth minus estimate) against the filter's own
    // transition of the initial error. Both come from different code: the
    // nonlinear strapdown and the linear model F. Tolerance: 3 % of the
    // error (the linear model leaves out gravity and transport-rate error
    // terms, second order in a 1 mrad / 0.2 deg/h error over 20 s).
    let site = Site::new(30.0, 20.0);
    let origin: GeoPoint = site.origin;
    let k = Vector3::z();
    let rate = 30f64.to_radians();
    let bg = Vector3::new(2e-5, -1e-5, 3e-5); // rad/s in s
    let ba = Vector3::new(2e-3, -1e-3, 1.5e-3); // m/s^2 in s
    let phi0 = Vector3::new(1e-3, -0.5e-3, 2e-3);
    let sample = |t_us: u64, biased: bool| {
        let t = t_us as f64 * 1e-6;
        let c_s_n =
            *Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(k), rate * t).matrix();
        let (w, f) = site.ideal_imu(&c_s_n.transpose(), &(k * rate));
        let (w, f) = if biased { (w + bg, f + ba) } else { (w, f) };
        ImuSample::<f64> {
            t_us,
            w_is_s: w,
            f_s: f,
        }
    };
    let scfg = StrapdownConfig {
        gravity_mps2: Some(site.gravity_mps2),
        ..StrapdownConfig::default()
    };
    let q0 = Quaternion::identity();
    let mut truth = Strapdown::new(scfg, origin, Vector3::zeros(), q0, &sample(0, false)).unwrap();
    // Estimate: c_s_n,est = (I - [phi0 x]) c_s_n,true.
    let q_est = rotvec_to_quat(&(-phi0)) * q0;
    let mut est = Strapdown::new(scfg, origin, Vector3::zeros(), q_est, &sample(0, true)).unwrap();
    let mut f = Eskf::<f64>::new(cfg(), &init());
    f.dx[I_PHI] = phi0.x;
    f.dx[I_PHI + 1] = phi0.y;
    f.dx[I_PHI + 2] = phi0.z;
    for i in 0..3 {
        // Bias errors are truth minus estimate; the estimate is 0.
        f.dx[I_BG + i] = bg[i];
        f.dx[I_BA + i] = ba[i];
    }
    let w_ie = earth_rate_n(libm::sin(origin.lat_rad), libm::cos(origin.lat_rad));
    for s in 1..=2000u64 {
        let t_us = s * 10_000;
        let st = *est.state();
        let c = quat_to_dcm(&st.q_s_n);
        let f_n = c * sample(t_us, true).f_s;
        f.predict(
            &c,
            &f_n,
            &w_ie,
            &Vector3::zeros(),
            &sample(t_us, true).w_is_s,
            0.01,
        );
        truth.step(&sample(t_us, false)).unwrap();
        est.step(&sample(t_us, true)).unwrap();
    }
    let (t, e) = (truth.state(), est.state());
    let dv = t.v_n - e.v_n;
    let dp = t.p_n - e.p_n;
    // Attitude error: c_true c_est^T = I + [phi x].
    let m: Matrix3<f64> = quat_to_dcm(&t.q_s_n) * quat_to_dcm(&e.q_s_n).transpose();
    let phi = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    ) * 0.5;
    for i in 0..3 {
        let (lin_v, lin_p, lin_phi) = (f.dx[I_V + i], f.dx[I_P + i], f.dx[I_PHI + i]);
        println!(
            "axis {i}: dv {:.4e} vs {lin_v:.4e}, dp {:.4e} vs {lin_p:.4e}, phi {:.4e} vs {lin_phi:.4e}",
            dv[i], dp[i], phi[i]
        );
        assert!((dv[i] - lin_v).abs() < 0.03 * dv.norm() + 1e-4, "dv {i}");
        assert!((dp[i] - lin_p).abs() < 0.03 * dp.norm() + 1e-3, "dp {i}");
        assert!(
            (phi[i] - lin_phi).abs() < 0.03 * phi.norm() + 1e-6,
            "phi {i}"
        );
    }
}

#[test]
fn the_f32_board_filter_follows_its_f64_twin() {
    // The same predicts and updates in f32 and f64: sigmas within 1e-3
    // relative, the corrections within 1e-3 of their size (f32 keeps ~7
    // digits; a 15x15 Joseph update loses at most ~2 of them with these
    // conditionings).
    let mut a = Eskf::<f64>::new(cfg(), &init());
    let mut b = Eskf::<f32>::new(cfg(), &init());
    let w_ie = earth_rate_n(0.5f64, 0.866);
    for k in 0..600 {
        let c = *Rotation3::from_euler_angles(
            0.01,
            -0.02,
            std::f64::consts::FRAC_PI_6 * 0.01 * k as f64,
        )
        .matrix();
        let f_n = Vector3::new(0.3 * (k as f64 * 0.01).sin(), 0.1, -9.8);
        let w = Vector3::new(0.001, -0.002, 0.52);
        a.predict(&c, &f_n, &w_ie, &Vector3::zeros(), &w, 0.01);
        b.predict(
            &c.cast(),
            &f_n.cast(),
            &w_ie.cast(),
            &Vector3::zeros(),
            &w.cast(),
            0.01,
        );
        if k % 100 == 99 {
            let z = Vector3::new(0.5, -0.4, 0.9);
            let l = Vector3::new(0.3, 0.0, -0.2);
            let s = Vector3::new(1.5, 1.5, 3.0);
            a.update_position(&z, &l, &s).unwrap();
            b.update_position(&z.cast(), &l.cast(), &s.cast()).unwrap();
            let zv = Vector3::new(0.02, -0.01, 0.0);
            a.update_velocity(&zv, &Vector3::repeat(0.05)).unwrap();
            b.update_velocity(&zv.cast(), &Vector3::repeat(0.05f32))
                .unwrap();
            let (pa, va, fa) = a.take_correction();
            let (pb, vb, fb) = b.take_correction();
            for (x, y) in [(pa, pb), (va, vb), (fa, fb)] {
                assert!((x - y.cast::<f64>()).norm() <= 1e-3 * x.norm() + 1e-9);
            }
        }
    }
    for i in 0..N {
        let (x, y) = (a.sigma(i), f64::from(b.sigma(i)));
        assert!((x - y).abs() <= 1e-3 * x, "sigma {i}: {x} vs {y}");
    }
}

#[test]
fn sparse_propagation_equals_the_dense_product() {
    // The filter skips the error dynamics' zeros; here the dense product
    // Phi P Phi^T, Phi = I + F T + (F T)^2 / 2, from the filter's own F
    // with nalgebra's dense multiply. No process noise (white noise zero,
    // no Gauss-Markov), so P' is the product alone. 1e-12 relative: f64
    // rounding, the same terms summed in another order.
    let mut c = cfg();
    c.gyro_arw = 0.0;
    c.accel_vrw = 0.0;
    c.gyro_bias_tau_s = 0.0;
    c.accel_bias_tau_s = 0.0;
    c.gnss_corr_tau_s = 0.0;
    let mut f = Eskf::<f64>::new(c, &init());
    f.p = warmed().p;
    let rot = *Rotation3::from_euler_angles(0.1, -0.05, 0.7).matrix();
    let (f_n, w_ie) = (Vector3::new(0.5, -0.3, -9.8), earth_rate_n(0.5f64, 0.866));
    let (w_en, w) = (
        Vector3::new(1e-6, -2e-6, 0.0),
        Vector3::new(0.01, 0.02, 0.5),
    );
    let ft = f.system(&rot, &f_n, &w_ie, &w_en, &w) * 0.1;
    let phi = nalgebra::SMatrix::<f64, N, N>::identity() + ft + ft * ft * 0.5;
    let want = phi * f.p * phi.transpose();
    f.predict(&rot, &f_n, &w_ie, &w_en, &w, 0.1);
    let scale = want.amax();
    assert!(
        (f.p - want).amax() <= 1e-12 * scale,
        "{}",
        (f.p - want).amax() / scale
    );
}

#[test]
fn batched_propagation_follows_propagation_every_sample() {
    // The board propagates P every tenth sample from the system's
    // integrals (core_nav::aided::PREDICT_BATCH); the reference propagates
    // every sample. A table turning at 30 deg/s on a car turning and
    // braking, 60 s with a fix every second: sigmas within 1 % (the
    // dropped commutator terms; 1 % is a tenth of what would move a NEES
    // test) and the corrections within 1 % of their size.
    let mut a = Eskf::<f64>::new(cfg(), &init());
    let mut b = Eskf::<f64>::new(cfg(), &init());
    b.batch = 10;
    let w_ie = earth_rate_n(0.5f64, 0.866);
    for k in 0..6000 {
        let t = k as f64 * 0.01;
        let c = *Rotation3::from_euler_angles(0.02, -0.03, 30f64.to_radians() * t).matrix();
        let f_n = Vector3::new(2.0 * (0.3 * t).sin(), 1.5 * (0.2 * t).cos(), -9.8);
        let w = Vector3::new(0.01 * (0.5 * t).sin(), -0.02, 30f64.to_radians() + 0.1);
        let w_en = Vector3::new(2e-6, -1e-6, 0.0);
        a.predict(&c, &f_n, &w_ie, &w_en, &w, 0.01);
        b.predict(&c, &f_n, &w_ie, &w_en, &w, 0.01);
        if k % 100 == 57 {
            let z = Vector3::new(0.5, -0.4, 0.9);
            let l = Vector3::new(1.0, 0.0, -0.8);
            let s = Vector3::new(1.5, 1.5, 3.0);
            a.update_position(&z, &l, &s).unwrap();
            b.update_position(&z, &l, &s).unwrap();
            let (pa, va, fa) = a.take_correction();
            let (pb, vb, fb) = b.take_correction();
            for (x, y) in [(pa, pb), (va, vb), (fa, fb)] {
                assert!((x - y).norm() <= 1e-2 * x.norm() + 1e-9, "{x} vs {y}");
            }
        }
    }
    b.propagate();
    for i in 0..N {
        let (x, y) = (a.sigma(i), b.sigma(i));
        assert!((x - y).abs() <= 1e-2 * x, "sigma {i}: {x} vs {y}");
    }
}

#[test]
fn bad_measurements_are_refused_and_counted() {
    let mut f = Eskf::<f32>::new(cfg(), &init());
    let p0 = f.p;
    assert!(f
        .update_position(
            &Vector3::new(f32::NAN, 0.0, 0.0),
            &Vector3::zeros(),
            &Vector3::repeat(1.0)
        )
        .is_err());
    assert!(f
        .update_velocity(&Vector3::zeros(), &Vector3::new(0.1, 0.0, 0.1))
        .is_err());
    assert_eq!(f.refused, 2);
    assert_eq!(f.p, p0);
    // The gate: a 1 km jump with 1.5 m sigma is rejected, counted, unused.
    let mut g = Eskf::<f64>::new(
        EskfConfig {
            gate_sigma: 5.0,
            ..cfg()
        },
        &init(),
    );
    let rep = g
        .update_position(
            &Vector3::new(1000.0, 0.0, 0.0),
            &Vector3::zeros(),
            &Vector3::repeat(1.5),
        )
        .unwrap();
    assert_eq!((rep.used, rep.rejected, g.rejected), (2, 1, 1));
    assert_eq!(g.dx[I_P], 0.0);
}

/// A few predicts on a moving, turning state, on a filter with `M`
/// states.
fn warmed_m<const M: usize>() -> Eskf<f64, M> {
    let mut f = Eskf::<f64, M>::new(cfg(), &init());
    let w_ie = earth_rate_n(0.5f64, 0.866);
    for k in 0..50 {
        let c = *Rotation3::from_euler_angles(0.1, -0.05, 0.02 * k as f64).matrix();
        f.predict(
            &c,
            &Vector3::new(0.5, -0.3, -9.8),
            &w_ie,
            &Vector3::new(1e-6, -2e-6, 0.0),
            &Vector3::new(0.0, 0.0, 0.5),
            0.1,
        );
    }
    f
}

#[test]
fn a_host_s_unused_states_leave_the_board_s_arithmetic_bit_for_bit() {
    // The host runs N + 3 states; a run that uses none of them must be the
    // board's N-state filter to the bit (the tables CI checks to the digit
    // come from the host).
    let mut a = warmed();
    let mut b = warmed_m::<{ N + 3 }>();
    let z = Vector3::new(0.3, -0.2, 0.5);
    let l = Vector3::new(0.1, 0.2, -0.3);
    let s = Vector3::new(0.5, 0.5, 1.0);
    a.update_position(&z, &l, &s).unwrap();
    b.update_position(&z, &l, &s).unwrap();
    a.update_velocity(&(z * 0.1), &(s * 0.1)).unwrap();
    b.update_velocity(&(z * 0.1), &(s * 0.1)).unwrap();
    for i in 0..N {
        assert_eq!(a.dx[i].to_bits(), b.dx[i].to_bits(), "dx {i}");
        for j in 0..N {
            assert_eq!(a.p[(i, j)].to_bits(), b.p[(i, j)].to_bits(), "P {i} {j}");
        }
    }
    for i in N..N + 3 {
        assert_eq!((b.dx[i], b.p[(i, i)]), (0.0, 0.0));
    }
}

#[test]
fn a_host_state_started_as_a_function_of_the_others_is_their_combination() {
    // x_a = r . dx + w: its variance r P r^T + sw^2, its covariance P r;
    // a measurement of x_a - r . dx (the white part alone) with sigma sm
    // then gives the scalar closed form for w and changes nothing else's
    // covariance beyond what that part explains.
    let mut f = warmed_m::<{ N + 1 }>();
    let mut r = nalgebra::SVector::<f64, { N + 1 }>::zeros();
    r[I_V + 1] = 0.8;
    r[I_PHI + 2] = 12.0;
    let sw = 0.01;
    let p0 = f.p;
    f.set_aux_as(0, &r, sw, 0.0).unwrap();
    let pr = p0 * r;
    let var = r.dot(&pr) + sw * sw;
    // Tolerance: a few ulps of P's largest products.
    assert!(
        (f.p[(N, N)] - var).abs() < 1e-12 * var,
        "{} {var}",
        f.p[(N, N)]
    );
    for j in 0..N {
        assert!((f.p[(N, j)] - pr[j]).abs() < 1e-15 + 1e-12 * pr[j].abs());
        assert_eq!(f.p[(N, j)], f.p[(j, N)]);
    }
    // h = e_a - r: measures w alone. Posterior of w: sw^2 sm^2 / (sw^2 +
    // sm^2), read as Var(x_a - r dx) = h P h^T.
    let mut h = -r;
    h[N] = 1.0;
    let sm = 0.02;
    f.update_scalar(&h, 0.005, sm * sm).unwrap();
    let post = (h.transpose() * f.p * h)[(0, 0)];
    let closed = sw * sw * sm * sm / (sw * sw + sm * sm);
    assert!((post - closed).abs() < 1e-9 * closed, "{post} {closed}");
    // And the correction is handed over once.
    let d = f.take_aux();
    assert!(d[0] != 0.0 && d[1..].iter().all(|x| *x == 0.0), "{d:?}");
    assert_eq!(f.take_aux()[0], 0.0);
    // Out of range or bad: refused.
    assert!(f.set_aux(1, 0.1, 0.0).is_err());
    assert!(f.set_aux(0, f64::NAN, 0.0).is_err());
}

#[test]
fn sizing_the_receiver_afresh_scales_its_states_as_a_change_of_unit() {
    // `size_gnss_corr` against `S P S` with the diagonal `S` computed here:
    // each correlated-error state's variance brought down to the new prior
    // (never up), its correlations kept, the covariance still positive
    // semi-definite, its estimate scaled with it.
    let mut f = warmed();
    f.update_position(
        &Vector3::new(0.4, -0.3, 0.8),
        &Vector3::zeros(),
        &Vector3::new(0.02, 0.02, 0.04),
    )
    .unwrap();
    let _ = f.take_correction();
    let (p0, b0) = (f.p, f.gnss_bias);
    assert!(b0.norm() > 0.01, "{b0}");
    let sigma = [0.014, 0.028];
    f.size_gnss_corr(sigma);
    assert_eq!(f.config().gnss_corr_sigma_m, sigma);
    let mut s = DVector::from_element(N, 1.0);
    for (k, sg) in [sigma[0], sigma[0], sigma[1]].into_iter().enumerate() {
        let var = p0[(I_GP + k, I_GP + k)];
        assert!(var > sg * sg, "the prior was the larger: {var}");
        s[I_GP + k] = sg / var.sqrt();
    }
    let want = DMatrix::from_fn(N, N, |r, c| s[r] * p0[(r, c)] * s[c]);
    let got = DMatrix::from_fn(N, N, |r, c| f.p[(r, c)]);
    assert!((&got - &want).amax() < 1e-15, "{}", (&got - &want).amax());
    let corr = |p: &DMatrix<f64>, i: usize, j: usize| p[(i, j)] / (p[(i, i)] * p[(j, j)]).sqrt();
    for j in [I_P, I_P + 1, I_P + 2] {
        assert!(
            (corr(&got, I_GP, j) - corr(&DMatrix::from_fn(N, N, |r, c| p0[(r, c)]), I_GP, j)).abs()
                < 1e-12
        );
    }
    let min_eig = got.symmetric_eigenvalues().min();
    assert!(min_eig > -1e-12, "{min_eig}");
    for k in 0..3 {
        assert!((f.gnss_bias[k] - s[I_GP + k] * b0[k]).abs() < 1e-15);
    }
    // A larger prior changes nothing but the configuration.
    let p1 = f.p;
    f.size_gnss_corr([5.0, 10.0]);
    assert_eq!(f.p, p1);
}
