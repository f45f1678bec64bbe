//! Instruction counts per function on the state a replay ended in
//! (`name: N instructions`), interrupts masked: what a navigation run and
//! a tick are made of. `core-nav step` is the budget CI checks (<= 3,000).

use super as hw;
use crate::navigation::Navigator;
use crate::protocol::{Telemetry, MAX_FRAME};
use core_nav::calib::PhaseAccumulator;
use core_nav::control::{MotorModel, RateController};
use core_nav::scheme::Reference;
use core_nav::table::{Axis, TableAngle};
use cortex_m_semihosting::hprintln;
use nalgebra::Vector3;

fn count<R>(f: impl FnOnce() -> R) -> u32 {
    cortex_m::interrupt::free(|_| {
        let c0 = hw::cycles();
        let r = f();
        let n = hw::since(c0);
        core::hint::black_box(r);
        n
    })
}

fn mean(n: u32, mut f: impl FnMut(u32)) -> u32 {
    let total: u64 = (0..n).map(|i| u64::from(count(|| f(i)))).sum();
    (total / u64::from(n.max(1))) as u32
}

/// Prints the counts.
#[inline(never)]
pub fn profile(nav: &Navigator<'_>) {
    let Some(x) = nav.last_input().copied() else {
        return;
    };
    let sample = |i: u32| {
        let mut s = nav.imu_sample(x.t_us + 10_000 * u64::from(i + 1), &x.mean);
        s.w_is_s.x += 1e-4 * i as f32;
        s
    };
    let samples: [core_nav::strapdown::ImuSample<f32>; 10] =
        core::array::from_fn(|i| sample(i as u32));
    let at = |i: u32| {
        samples
            .get(i as usize)
            .copied()
            .unwrap_or_else(|| sample(i))
    };
    let angle = |i: u32| TableAngle::<f32>::from_counts(i64::from(i) * 27, 16_384);
    if let Some(n) = nav.nav() {
        let mut n = n.clone();
        let c = mean(10, |i| {
            core::hint::black_box(n.step(&at(i)).is_ok());
        });
        hprintln!("core-nav step: {} instructions", c);
    }
    if let Some(a) = nav.aided() {
        let st = *a.nav().state();
        let c_s_n = core_nav::attitude::quat_to_dcm(&st.q_s_n);
        let w_ie = Vector3::new(6.3e-5f32, 0.0, -3.7e-5);
        let w_en = Vector3::new(1e-6f32, -2e-6, 0.0);
        let mut kf = a.kf.clone();
        kf.batch = u32::MAX;
        let c = mean(10, |i| {
            let s = at(i);
            kf.predict(&c_s_n, &(c_s_n * s.f_s), &w_ie, &w_en, &s.w_is_s, 0.01);
        });
        hprintln!(
            "filter predict (every sample: the system's integrals): {} instructions",
            c
        );
        let c = count(|| kf.propagate());
        hprintln!(
            "filter propagate (every {} samples): {} instructions",
            core_nav::aided::PREDICT_BATCH,
            c
        );
        let z = Vector3::new(0.3f32, -0.2, 0.5);
        let sig = Vector3::new(1.0f32, 1.0, 2.0);
        let c = count(|| {
            kf.update_position(&z, &Vector3::new(1.0, 0.0, -0.8), &sig)
                .is_ok()
        });
        hprintln!(
            "filter GNSS position update (3 components): {} instructions",
            c
        );
        let c = count(|| kf.update_velocity(&(z * 0.1), &(sig * 0.05)).is_ok());
        hprintln!(
            "filter GNSS velocity update (3 components): {} instructions",
            c
        );
        let mut an = a.clone();
        let c = mean(10, |i| {
            core::hint::black_box(an.step(&at(i), &angle(i), 0.52).is_ok());
        });
        hprintln!("aided step (mechanization, filter, detector; mean of 10 with one propagation): {} instructions", c);
    }
    let mut ctrl = RateController::<f32>::new(MotorModel::default(), 25.0);
    let r = Reference {
        angle: 1.0,
        rate: 0.52,
        accel: 0.0,
    };
    let c = mean(10, |i| {
        core::hint::black_box(ctrl.update(&r, 1e-3 * i as f32, 0.51, 1e-3));
    });
    hprintln!("rate loop: {} instructions", c);
    let c = mean(10, |i| {
        let mut f = [0u8; MAX_FRAME];
        let t = Telemetry::Nav {
            t_us: x.t_us + u64::from(i),
            q_b_n: [1.0, 0.0, 0.0, 0.0],
            v_n: [0.1 * i as f32, 0.2, 0.3],
            p_n: [1.0, 2.0, 3.0],
        };
        core::hint::black_box(t.to_frame(i as u16, &mut f).is_ok());
    });
    hprintln!("telemetry framing (a Nav frame): {} instructions", c);
    let mut acc = PhaseAccumulator::new(0.52, Axis::Z);
    let c = mean(10, |i| {
        let s = at(i);
        core::hint::black_box(
            acc.push(x.t_us + 10_000 * u64::from(i), &s.w_is_s, &s.f_s, angle(i))
                .is_ok(),
        );
    });
    hprintln!("calibration step (phase accumulator): {} instructions", c);
}
