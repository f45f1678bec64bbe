//! rins firmware (RTIC 2, STM32F405): wires the board's peripherals to the
//! logic in the `firmware` library (`App`), which is tested on the host.
//!
//! Tasks: a 1 kHz tick (IMU read, rate loop, encoder at 50 Hz, watchdog at
//! 10 Hz, PWM + direction); `idle` drains telemetry to the UART, reads
//! commands and writes the calibration record to flash (an erase blocks for
//! about a second: never in the control loop). At power-up `init` reads the
//! last record back: the board reports it and, once the power-up
//! calibration is accepted, its change from it.

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

/// The board: every pin in one place (Adafruit Feather STM32F405 Express,
/// or any STM32F405/F407 board with a 12 MHz crystal).
///
/// | signal | pin | peripheral |
/// | --- | --- | --- |
/// | IMU SCK / MISO / MOSI | PA5 / PA6 / PA7 | SPI1, mode 0, 8 MHz |
/// | IMU chip select | PA4 | GPIO, active low |
/// | encoder A / B | PB6 / PB7 | TIM4 quadrature (16-bit counter) |
/// | motor PWM | PA8 | TIM1 CH1, 20 kHz |
/// | motor direction | PC6 | GPIO (high = positive rotation) |
/// | telemetry TX / RX | PA9 / PA10 | USART1, 921,600 baud |
#[cfg(target_os = "none")]
mod board {
    /// Crystal, Hz.
    pub const HSE_HZ: u32 = 12_000_000;
    /// System clock, Hz.
    pub const SYSCLK_HZ: u32 = 168_000_000;
    /// Telemetry baud rate.
    pub const BAUD: u32 = 921_600;
    /// Flash sector holding the calibration record (sector 11: 0x080E_0000,
    /// 128 KiB; the program must stay below it).
    pub const CAL_SECTOR: u8 = 11;
    /// Its offset from the start of flash.
    pub const CAL_OFFSET: usize = 0xE_0000;
}

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [USART2])]
mod app {
    use crate::board;
    use embedded_hal::delay::DelayNs;
    use embedded_hal_02::Qei as _;
    use embedded_hal_bus::spi::ExclusiveDevice;
    use firmware::app::{App, AppConfig, CAL_RECORD};
    use firmware::icm42688::{Config, Icm42688};
    use rtic_monotonics::systick::prelude::*;
    use stm32f4xx_hal::flash::FlashExt;
    use stm32f4xx_hal::gpio::{Output, PushPull, PA4, PC6};
    use stm32f4xx_hal::pac::{FLASH, SPI1, TIM1, TIM4, USART1};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::qei::Qei;
    use stm32f4xx_hal::rcc::Config as RccConfig;
    use stm32f4xx_hal::serial::{Rx, Tx};
    use stm32f4xx_hal::spi::{Mode, Phase, Polarity, Spi};
    use stm32f4xx_hal::timer::PwmChannel;
    use stm32f4xx_hal::watchdog::IndependentWatchdog;

    systick_monotonic!(Mono, 1_000);

    /// The IMU's SPI device: the bus, chip select, and a real delay (with
    /// `NoDelay` a transaction holding a delay operation panics: a panic
    /// path on the board).
    type ImuSpi = ExclusiveDevice<Spi<SPI1>, PA4<Output<PushPull>>, CycleDelay>;

    /// A busy-wait delay (the IMU's start-up, before the scheduler runs;
    /// SPI delay operations, which the driver does not issue).
    pub struct CycleDelay;
    impl DelayNs for CycleDelay {
        fn delay_ns(&mut self, ns: u32) {
            cortex_m::asm::delay(
                (u64::from(ns) * u64::from(board::SYSCLK_HZ / 1_000_000) / 1_000) as u32,
            );
        }
    }

    /// Stops for good at initialisation, in the safe state: the PWM duty is
    /// already 0 (motor off) and the watchdog not yet started, so the board
    /// stays halted with the reason in the log instead of panicking.
    fn halt(why: &str) -> ! {
        defmt::error!("halted at init: {=str}", why);
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[shared]
    struct Shared {
        app: App,
    }

    #[local]
    struct Local {
        imu: Option<Icm42688<ImuSpi>>,
        wdg: IndependentWatchdog,
        qei: Qei<TIM4>,
        pwm: PwmChannel<TIM1, 0>,
        dir: PC6<Output<PushPull>>,
        tx: Tx<USART1>,
        rx: Rx<USART1>,
        flash: FLASH,
        /// The calibration record now in flash (read at power-up).
        written: Option<[u8; CAL_RECORD]>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let mut rcc = dp
            .RCC
            .freeze(RccConfig::hse(board::HSE_HZ.Hz()).sysclk(board::SYSCLK_HZ.Hz()));
        Mono::start(cx.core.SYST, board::SYSCLK_HZ);
        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);

        let mode = Mode {
            polarity: Polarity::IdleLow,
            phase: Phase::CaptureOnFirstTransition,
        };
        let spi = dp.SPI1.spi(
            (Some(gpioa.pa5), Some(gpioa.pa6), Some(gpioa.pa7)),
            mode,
            8.MHz(),
            &mut rcc,
        );
        let cs = gpioa
            .pa4
            .into_push_pull_output_in_state(stm32f4xx_hal::gpio::PinState::High);
        // Safe state if the IMU does not come up: no IMU, no navigation,
        // the motor never runs; the reason is counted and sent (below).
        let mut imu_failed: Option<bool> = None;
        let imu = match ExclusiveDevice::new(spi, cs, CycleDelay) {
            Ok(dev) => {
                let mut imu = Icm42688::new(dev);
                match imu.init(Config::default(), &mut CycleDelay) {
                    Ok(()) => Some(imu),
                    Err(e) => {
                        let wrong = matches!(e, firmware::icm42688::Error::WrongDevice(_));
                        defmt::error!("IMU init failed (wrong WHO_AM_I: {})", wrong);
                        imu_failed = Some(wrong);
                        None
                    }
                }
            }
            Err(_) => {
                imu_failed = Some(false);
                None
            }
        };
        let qei = Qei::new(dp.TIM4, (gpiob.pb6, gpiob.pb7), &mut rcc);
        let (_, (ch1, ..)) = dp.TIM1.pwm_hz(20.kHz(), &mut rcc);
        let mut pwm = ch1.with(gpioa.pa8);
        pwm.set_duty(0);
        pwm.enable();
        let dir = gpioc.pc6.into_push_pull_output();
        let serial = dp
            .USART1
            .serial((gpioa.pa9, gpioa.pa10), board::BAUD.bps(), &mut rcc);
        let (tx, rx) = match serial {
            Ok(s) => s.split(),
            // A board that cannot talk is broken: safe state, no panic path.
            Err(_) => halt("USART1 configuration failed"),
        };
        let mut app = match App::new(AppConfig::default()) {
            Ok(a) => a,
            // A build error (the host tests build this configuration).
            Err(_) => halt("default configuration out of range"),
        };
        if let Some(wrong_device) = imu_failed {
            app.on_imu_init_failed(0, wrong_device);
        }
        // The record the last power-up stored: reported, kept to report
        // the new calibration's change from it; the board still calibrates.
        let mut written = None;
        let stored = dp
            .FLASH
            .read()
            .get(board::CAL_OFFSET..board::CAL_OFFSET + CAL_RECORD)
            .and_then(|b| <[u8; CAL_RECORD]>::try_from(b).ok());
        if let Some(rec) = stored {
            if app.restore(&rec) {
                defmt::info!("calibration record found in flash");
                written = Some(rec);
            }
        }
        // The hardware watchdog: the tick task feeds it every 1 ms; if the
        // scheduler stalls for 100 ms the chip resets (motor PWM off at reset).
        let mut wdg = IndependentWatchdog::new(dp.IWDG);
        wdg.start(stm32f4xx_hal::prelude::_fugit_ExtU32::millis(100u32));
        if imu.is_some() && tick::spawn().is_err() {
            defmt::error!("tick already running");
        }
        (
            Shared { app },
            Local {
                imu,
                wdg,
                qei,
                pwm,
                dir,
                tx,
                rx,
                flash: dp.FLASH,
                written,
            },
        )
    }

    /// 1 kHz: the IMU, the rate loop, the encoder at 50 Hz, the watchdog.
    #[task(priority = 2, shared = [app], local = [imu, wdg, qei, pwm, dir, k: u32 = 0])]
    async fn tick(mut cx: tick::Context) {
        let mut next = Mono::now();
        loop {
            // Two fugit versions: name the trait (toolchain notes).
            next += rtic_monotonics::fugit::ExtU32::millis(1u32);
            Mono::delay_until(next).await;
            cx.local.wdg.feed();
            let t_us = u64::from(Mono::now().duration_since_epoch().as_millis()) * 1_000;
            *cx.local.k = cx.local.k.wrapping_add(1);
            let k = *cx.local.k;
            let sample = cx.local.imu.as_mut().map(|imu| imu.read_si());
            let encoder = k.is_multiple_of(20).then(|| cx.local.qei.count()); // TIM4: a 16-bit counter
            let duty = cx.shared.app.lock(|app| {
                match sample {
                    Some(Ok((raw, s))) => app.on_imu(t_us, &raw, &s),
                    _ => app.on_imu_error(t_us),
                }
                if let Some(hw) = encoder {
                    app.on_encoder(t_us, hw);
                }
                if k.is_multiple_of(100) {
                    app.check_watchdog(t_us);
                }
                app.duty()
            });
            let max = cx.local.pwm.get_max_duty();
            cx.local.pwm.set_duty((duty.abs() * f32::from(max)) as u16);
            if duty >= 0.0 {
                cx.local.dir.set_high();
            } else {
                cx.local.dir.set_low();
            }
        }
    }

    /// Telemetry out, commands in, the calibration record to flash.
    #[idle(shared = [app], local = [tx, rx, flash, written])]
    fn idle(mut cx: idle::Context) -> ! {
        let mut frames = [[0u8; firmware::telemetry::MAX_FRAME]; 8];
        let mut lens = [0usize; 8];
        loop {
            let mut n = 0;
            let stored = cx.shared.app.lock(|app| {
                app.drain(|f| {
                    if let (Some(dst), Some(len)) = (frames.get_mut(n), lens.get_mut(n)) {
                        let m = f.len().min(dst.len());
                        if let (Some(d), Some(s)) = (dst.get_mut(..m), f.get(..m)) {
                            d.copy_from_slice(s);
                        }
                        *len = m;
                        n += 1;
                    }
                });
                app.stored
            });
            for (f, len) in frames.iter().zip(lens.iter()).take(n) {
                for b in f.get(..*len).unwrap_or(&[]) {
                    if nb::block!(cx.local.tx.write(*b)).is_err() {
                        defmt::warn!("uart write");
                    }
                }
            }
            while let Ok(b) = cx.local.rx.read() {
                let t_us = u64::from(Mono::now().duration_since_epoch().as_millis()) * 1_000;
                cx.shared.app.lock(|app| app.on_rx(t_us, &[b]));
            }
            if let Some(rec) = stored {
                if *cx.local.written != Some(rec) {
                    let mut fl = cx.local.flash.unlocked();
                    let ok = fl.erase(board::CAL_SECTOR).is_ok()
                        && fl.program(board::CAL_OFFSET, rec.iter()).is_ok();
                    if ok {
                        defmt::info!("calibration stored in flash");
                    } else {
                        defmt::error!("calibration: flash write failed");
                    }
                    *cx.local.written = Some(rec);
                }
            }
            if n == 0 {
                cortex_m::asm::wfi();
            }
        }
    }
}
