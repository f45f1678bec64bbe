//! One mechanization step, f32 and f64, on the host (spinning table at
//! 100 deg/s, so the quaternion update does real work). For scale: the
//! numba-compiled Python peer pyins integrates ~0.8 us per step on this
//! machine kind. Instruction counts for the MCU come from the QEMU run.

use core_nav::attitude::Euler;
use core_nav::earth::{earth_rate_n, normal_gravity, GeoPoint};
use core_nav::real::Real;
use core_nav::strapdown::{ImuSample, Strapdown, StrapdownConfig};
use core_nav::table::{q_s_b, Axis};
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use nalgebra::Vector3;

const N: usize = 1000;

fn samples<T: Real>() -> Vec<ImuSample<T>> {
    let lat = 30.0_f64.to_radians();
    let (s, c) = (lat.sin(), lat.cos());
    let g = normal_gravity(s * s, 0.0);
    let w_ie_n = earth_rate_n(s, c);
    let rate = 100.0_f64.to_radians();
    (0..=N)
        .map(|k| {
            let t = k as f64 * 0.01;
            let q = q_s_b(Axis::Z, rate * t).conjugate(); // q_b_s with b = n
            let w = core_nav::attitude::rotate(&q, &w_ie_n) + Vector3::z() * rate;
            let f = core_nav::attitude::rotate(&q, &Vector3::new(0.0, 0.0, -g));
            ImuSample {
                t_us: k as u64 * 10_000,
                w_is_s: w.map(T::lit),
                f_s: f.map(T::lit),
            }
        })
        .collect()
}

fn bench_type<T: Real>(c: &mut Criterion, name: &str) {
    let data = samples::<T>();
    let origin = GeoPoint::from_deg(30.0, 0.0, 0.0);
    let q0 = core_nav::attitude::euler_to_quat(&Euler::<T>::default());
    c.bench_function(name, |b| {
        b.iter_batched(
            || {
                Strapdown::new(
                    StrapdownConfig::default(),
                    origin,
                    Vector3::zeros(),
                    q0,
                    &data[0],
                )
                .unwrap()
            },
            |mut nav| {
                for s in &data[1..] {
                    black_box(nav.step(black_box(s)).is_ok());
                }
                nav
            },
            criterion::BatchSize::SmallInput,
        )
    });
}

fn steps(c: &mut Criterion) {
    bench_type::<f32>(c, "strapdown_step_x1000_f32");
    bench_type::<f64>(c, "strapdown_step_x1000_f64");
}

criterion_group!(benches, steps);
criterion_main!(benches);
