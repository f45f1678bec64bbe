//! The table under its motor and servo, and the encoder counter through the
//! mock drivers.

use core_nav::scheme::{Limits, Profile, Scheme};
use core_nav::table::{CounterUnwrapper, QuadratureCounter};
use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;
use hal_sim::bench::{Bench, BenchConfig};
use hal_sim::drivers::{SimDir, SimEncoder, SimPwm};
use hal_sim::imu::ImuSpec;
use hal_sim::world::{MotorParams, Servo, Table};
use num_complex::Complex64;

#[test]
fn commanded_30_dps_settles_and_holds_with_the_predicted_cogging_ripple() {
    let m = MotorParams {
        ripple: vec![],
        cogging: vec![(24.0, 2e-3, 0.3)],
        ..MotorParams::default()
    };
    let rate = 30f64.to_radians();
    let profile = Profile::new(Scheme::Continuous { rate }, Limits::default()).unwrap();
    let mut table = Table::new(m.clone());
    let mut servo = Servo::for_motor(&m);
    let dt = 1e-3;
    let (mut t, mut samples) = (0.0, vec![]);
    let mut settled_at = None;
    while t < 12.0 {
        let r = profile.at(t);
        let v = servo.update(&r, &table.kin, dt);
        table.step(dt, v, 0.0);
        t += dt;
        if settled_at.is_none() && t > 0.3 && (table.kin.rate / rate - 1.0).abs() < 0.02 {
            settled_at = Some(t);
        }
        if t > 4.0 {
            samples.push((table.kin.theta, table.kin.rate));
        }
    }
    // Linear closed-loop prediction (continuous time; the 1 kHz loop adds
    // 0.5 ms of delay, 0.4 deg of phase at 2 Hz): rate ripple amplitude
    //   T_cog / |J jW + b + Kt^2/R + (Kt/R)(kp + ki/(jW))(1 + k_a/(jW))|
    // at W = 24 x rate.
    let w = 24.0 * rate;
    let jw = Complex64::new(0.0, w);
    let (kt, r_w) = (m.kt, m.resistance);
    let z = jw * m.inertia
        + m.viscous
        + kt * kt / r_w
        + (kt / r_w) * (servo.ctrl.kp + servo.ctrl.ki / jw) * (1.0 + servo.ctrl.k_angle / jw);
    let predicted = 2e-3 / z.norm();
    // Measured: least-squares sinusoid at the cogging phase 24 theta.
    let (mut ss, mut sc, mut n) = (0.0, 0.0, 0.0);
    let mean = samples.iter().map(|s| s.1).sum::<f64>() / samples.len() as f64;
    for (th, wr) in &samples {
        ss += (wr - mean) * (24.0 * th).sin();
        sc += (wr - mean) * (24.0 * th).cos();
        n += 1.0;
    }
    let measured = 2.0 * (ss * ss + sc * sc).sqrt() / n;
    println!(
        "settled (2 %) after {:.3} s; mean {:.5} deg/s; ripple {:.4} deg/s, predicted {:.4} deg/s",
        settled_at.unwrap_or(f64::NAN),
        mean.to_degrees(),
        measured.to_degrees(),
        predicted.to_degrees()
    );
    assert!(settled_at.is_some_and(|t| t < 1.0), "did not settle");
    // The angle loop removes any mean rate error: 0.01 % over 8 s.
    assert!(
        (mean / rate - 1.0).abs() < 1e-4,
        "mean {}",
        mean.to_degrees()
    );
    // The model's linearisation: 5 % (the cogging phase follows the actual,
    // not the reference, angle; second-order terms of the ripple itself).
    assert!(
        (measured / predicted - 1.0).abs() < 0.05,
        "{measured} vs {predicted}"
    );
}

#[test]
fn wrapping_counter_unwraps_across_many_revolutions() {
    let bench = Bench::new(BenchConfig::new(ImuSpec::ideal())).shared();
    let mut pwm = SimPwm(bench.clone());
    let mut dir = SimDir(bench.clone());
    let mut enc = SimEncoder(bench.clone());
    let mut unwrap = CounterUnwrapper::new();
    let max = pwm.max_duty_cycle();
    pwm.set_duty_cycle(max / 4).unwrap();
    dir.set_high().unwrap();
    let mut t_ns = 0;
    let mut turns_seen: f64 = 0.0;
    for k in 0..10_000 {
        if k == 5_000 {
            dir.set_low().unwrap(); // and back
        }
        t_ns += 20_000_000; // 50 Hz reads
        bench.borrow_mut().advance_to(t_ns);
        let c = unwrap.update(enc.read_count().unwrap());
        let b = bench.borrow();
        let truth = b.encoder.count(b.table.kin.theta);
        assert_eq!(c, truth, "read {k}");
        turns_seen = turns_seen.max(b.table.kin.theta / core::f64::consts::TAU);
    }
    println!("unwrapped up to {turns_seen:.0} turns and back");
    assert!(turns_seen > 500.0);
}
