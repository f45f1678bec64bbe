//! Recordings survive write -> read -> write byte for byte, and the bench's
//! injected faults show up physically where a driver or estimator would see
//! them.

use core_nav::scheme::Scheme;
use core_nav::table::{Axis, CounterUnwrapper, QuadratureCounter};
use embedded_hal::digital::OutputPin;
use embedded_hal::pwm::SetDutyCycle;
use hal_sim::bench::{Bench, BenchConfig};
use hal_sim::drivers::{SimDir, SimEncoder, SimPwm};
use hal_sim::imu::ImuSpec;
use hal_sim::sim::{simulate, SimConfig};
use hal_sim::world::Bump;
use nalgebra::Vector3;
use recording::Recording;

fn tmp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("rins-{name}-{}", std::process::id()))
}

#[test]
fn write_read_write_is_identical() {
    let mut cfg = SimConfig::new(ImuSpec::mtig(), Axis::X, 30.0);
    cfg.scheme = Scheme::Reciprocating {
        rate: 1.0,
        turns: 1,
    };
    cfg.base_deg = [0.3, -1.1, 123.4];
    let rec = simulate(&cfg, &mut |_| {}).unwrap();
    let (a, b) = (tmp("rt-a"), tmp("rt-b"));
    rec.write(&a).unwrap();
    let back = Recording::read(&a).unwrap();
    assert_eq!(back, rec, "read gives back what was written");
    back.write(&b).unwrap();
    for f in ["meta.toml", "imu.csv", "table.csv"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
    // A recording is never rewritten in place.
    assert!(rec.write(&a).is_err());
    for d in [a, b] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn a_bump_during_the_static_phase_shows_in_gyro_and_accel() {
    let mut cfg = SimConfig::new(ImuSpec::ideal(), Axis::Z, 10.0);
    cfg.ideal = true;
    cfg.bump = Some(Bump {
        t_s: 4.0,
        duration_s: 0.5,
        rate_b: Vector3::new(0.1, 0.0, 0.0),
        accel_b: Vector3::new(0.0, 0.5, 0.0),
    });
    let rec = simulate(&cfg, &mut |_| {}).unwrap();
    let peak = |from: f64, to: f64| {
        rec.imu
            .iter()
            .filter(|r| r.t_s >= from && r.t_s < to)
            .fold((0.0_f64, 0.0_f64), |(g, a), r| {
                (g.max(r.gyro_radps[0].abs()), a.max(r.accel_mps2[1].abs()))
            })
    };
    let (g_quiet, a_quiet) = peak(0.0, 4.0);
    let (g_bump, a_bump) = peak(4.0, 4.5);
    assert!(g_quiet < 1e-4 && a_quiet < 1e-9, "{g_quiet} {a_quiet}");
    assert!(
        (g_bump - 0.1).abs() < 1e-3 && (a_bump - 0.5).abs() < 1e-2,
        "{g_bump} {a_bump}"
    );
}

#[test]
fn stall_glitch_and_missed_counts_reach_the_encoder() {
    let bench = Bench::new(BenchConfig::new(ImuSpec::ideal())).shared();
    let (mut pwm, mut dir, mut enc) = (
        SimPwm(bench.clone()),
        SimDir(bench.clone()),
        SimEncoder(bench.clone()),
    );
    pwm.set_duty_cycle(100).unwrap();
    dir.set_high().unwrap();
    let mut unwrap = CounterUnwrapper::new();
    let mut read = |t_ms: u64| {
        bench.borrow_mut().advance_to(t_ms * 1_000_000);
        unwrap.update(enc.read_count().unwrap())
    };
    let c0 = read(1_000);
    let c1 = read(1_020);
    assert!(c1 - c0 > 100, "turning: {}", c1 - c0);
    // Glitch: 500 spurious counts appear at once.
    bench.borrow_mut().faults.encoder_offset_counts = 500;
    let c2 = read(1_040);
    assert!(c2 - c1 > (c1 - c0) + 400, "glitch jump {}", c2 - c1);
    bench.borrow_mut().faults.encoder_offset_counts = 0;
    let c2 = read(1_060);
    // Missed counts: the counter freezes although the table turns.
    bench.borrow_mut().faults.encoder_frozen = true;
    let c3 = read(1_080);
    let c4 = read(1_100);
    assert_eq!(c3, c4);
    assert!(bench.borrow().table.kin.rate > 1.0);
    bench.borrow_mut().faults.encoder_frozen = false;
    // Stall: the table stops although the motor is driven.
    bench.borrow_mut().faults.motor_stall = true;
    read(1_200);
    assert_eq!(bench.borrow().table.kin.rate, 0.0);
    let c5 = read(1_220);
    let c6 = read(1_240);
    assert_eq!(c5, c6);
    assert!(c5 > c2);
}
