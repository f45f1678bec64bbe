//! rins firmware (RTIC 2, STM32F405).
//!
//! This is the first skeleton: the scheduler runs a 100 Hz navigation task
//! that integrates a level, static sample through `core-nav` in f32 and logs
//! the state every 10 s over defmt. The IMU driver, encoder, table control,
//! calibration and telemetry arrive with the firmware issue; the clock tree
//! is left at reset (HSI 16 MHz) until then.

#![cfg_attr(target_os = "none", no_std, no_main)]

/// On the host there is nothing to run: the logic is the `firmware` library,
/// tested through `hal-sim` in `tests/`.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("the rins firmware runs on the STM32F405: build it with `cargo fw`");
}

#[cfg(target_os = "none")]
use defmt_rtt as _;
#[cfg(target_os = "none")]
use panic_probe as _;

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [USART1])]
mod app {
    use core_nav::earth::GeoPoint;
    use core_nav::strapdown::{ImuSample, Strapdown, StrapdownConfig};
    use nalgebra::{Quaternion, Vector3};
    use rtic_monotonics::systick::prelude::*;

    /// HSI after reset, Hz.
    const SYSCLK_HZ: u32 = 16_000_000;
    /// IMU period, µs (100 Hz).
    const IMU_PERIOD_US: u64 = 10_000;

    systick_monotonic!(Mono, 10_000);

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        nav: Option<Strapdown<f32>>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        Mono::start(cx.core.SYST, SYSCLK_HZ);
        let first = level_sample(0);
        let nav = Strapdown::new(
            StrapdownConfig::default(),
            GeoPoint::from_deg(30.53, 114.36, 20.0),
            Vector3::zeros(),
            Quaternion::identity(),
            &first,
        )
        .ok();
        if nav.is_none() {
            defmt::error!("navigation could not start");
        }
        if nav_task::spawn().is_err() {
            defmt::error!("nav task already running");
        }
        (Shared {}, Local { nav })
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// A level, static, north-facing IMU at the default site (gyro bias-free,
    /// earth rate neglected): a placeholder source until the IMU driver lands.
    fn level_sample(t_us: u64) -> ImuSample<f32> {
        ImuSample {
            t_us,
            w_is_s: Vector3::zeros(),
            f_s: Vector3::new(0.0, 0.0, -9.7936),
        }
    }

    #[task(local = [nav, k: u64 = 0, faults: u32 = 0], priority = 1)]
    async fn nav_task(cx: nav_task::Context) {
        let mut next = Mono::now();
        loop {
            *cx.local.k += 1;
            let t_us = *cx.local.k * IMU_PERIOD_US;
            if let Some(nav) = cx.local.nav.as_mut() {
                match nav.step(&level_sample(t_us)) {
                    Ok(s) => {
                        if cx.local.k.is_multiple_of(1000) {
                            defmt::info!(
                                "t={}s N={}m E={}m D={}m faults={}",
                                t_us / 1_000_000,
                                s.p_n.x,
                                s.p_n.y,
                                s.p_n.z,
                                *cx.local.faults
                            );
                        }
                    }
                    Err(_) => *cx.local.faults += 1,
                }
            }
            next += 10u32.millis();
            Mono::delay_until(next).await;
        }
    }
}
