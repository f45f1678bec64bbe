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
use panic_probe as _;

/// The defmt logger over RTT (SEGGER's protocol: a control block probe-rs
/// finds by its id, one up channel, non-blocking: bytes that do not fit
/// are dropped), written here instead of taken from `defmt-rtt`, which
/// panics when the logger is taken reentrantly: a panic path on the
/// board. Here a frame started inside another is dropped and counted
/// (`NESTED`). Interrupts are masked from a frame's start to its end, so
/// the only nesting is a `Format` implementation that logs.
#[cfg(target_os = "none")]
mod logger {
    use core::cell::UnsafeCell;
    use core::sync::atomic::{AtomicU32, Ordering};

    /// The up channel's buffer, bytes.
    const SIZE: usize = 1024;

    #[repr(C)]
    struct Channel {
        name: *const u8,
        buffer: *mut u8,
        size: u32,
        write: AtomicU32,
        read: AtomicU32,
        flags: AtomicU32,
    }

    /// SEGGER's RTT control block (layout fixed by the protocol).
    #[repr(C)]
    pub struct Header {
        id: [u8; 16],
        max_up_channels: u32,
        max_down_channels: u32,
        up: Channel,
    }

    // SAFETY: the pointers are to statics; the host reads the block, the
    // target writes `write` (atomic) and the buffer below it.
    unsafe impl Sync for Header {}

    struct Buffer(UnsafeCell<[u8; SIZE]>);
    // SAFETY: written only inside a frame, with interrupts masked.
    unsafe impl Sync for Buffer {}
    static BUFFER: Buffer = Buffer(UnsafeCell::new([0; SIZE]));
    static NAME: [u8; 6] = *b"defmt\0";

    /// Non-blocking, trim: write what fits.
    const MODE_TRIM: u32 = 1;

    #[no_mangle]
    static _SEGGER_RTT: Header = Header {
        id: *b"SEGGER RTT\0\0\0\0\0\0",
        max_up_channels: 1,
        max_down_channels: 0,
        up: Channel {
            name: NAME.as_ptr(),
            buffer: BUFFER.0.get().cast::<u8>(),
            size: SIZE as u32,
            write: AtomicU32::new(0),
            read: AtomicU32::new(0),
            flags: AtomicU32::new(MODE_TRIM),
        },
    };

    /// Frames dropped because they started inside another.
    pub static NESTED: AtomicU32 = AtomicU32::new(0);
    /// Bytes dropped because the host had not read the buffer.
    pub static OVERFLOW: AtomicU32 = AtomicU32::new(0);

    struct State {
        depth: u32,
        /// Interrupts were enabled when the frame started.
        enable: bool,
        encoder: defmt::Encoder,
    }
    struct Shared(UnsafeCell<State>);
    // SAFETY: touched only with interrupts masked (acquire to release).
    unsafe impl Sync for Shared {}
    static STATE: Shared = Shared(UnsafeCell::new(State {
        depth: 0,
        enable: false,
        encoder: defmt::Encoder::new(),
    }));

    fn write_all(bytes: &[u8]) {
        let ch = &_SEGGER_RTT.up;
        let mut w = ch.write.load(Ordering::Relaxed) as usize % SIZE;
        let r = ch.read.load(Ordering::Relaxed) as usize;
        for (i, b) in bytes.iter().enumerate() {
            let next = (w + 1) % SIZE;
            if next == r {
                let left = u32::try_from(bytes.len() - i).unwrap_or(u32::MAX);
                OVERFLOW.fetch_add(left, Ordering::Relaxed);
                break;
            }
            // SAFETY: w < SIZE (reduced above); interrupts are masked.
            unsafe { BUFFER.0.get().cast::<u8>().add(w).write_volatile(*b) };
            w = next;
        }
        ch.write.store(w as u32, Ordering::Release);
    }

    #[defmt::global_logger]
    struct Logger;

    // SAFETY: defmt's contract: acquire, writes, release, in that order;
    // the state is only touched with interrupts masked.
    unsafe impl defmt::Logger for Logger {
        fn acquire() {
            let enable = cortex_m::register::primask::read().is_active();
            cortex_m::interrupt::disable();
            // SAFETY: interrupts are masked.
            let st = unsafe { &mut *STATE.0.get() };
            st.depth += 1;
            if st.depth > 1 {
                NESTED.fetch_add(1, Ordering::Relaxed);
                return;
            }
            st.enable = enable;
            st.encoder.start_frame(write_all);
        }

        unsafe fn flush() {}

        unsafe fn release() {
            // SAFETY: interrupts are masked since `acquire`.
            let st = unsafe { &mut *STATE.0.get() };
            if st.depth > 1 {
                st.depth -= 1;
                return;
            }
            st.encoder.end_frame(write_all);
            st.depth = 0;
            if st.enable {
                // SAFETY: they were enabled when the frame started.
                unsafe { cortex_m::interrupt::enable() };
            }
        }

        unsafe fn write(bytes: &[u8]) {
            // SAFETY: interrupts are masked since `acquire`.
            let st = unsafe { &mut *STATE.0.get() };
            if st.depth == 1 {
                st.encoder.write(bytes, write_all);
            }
        }
    }
}

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
    /// The start of flash.
    pub const FLASH_BASE: usize = 0x0800_0000;
}

/// The calibration record's store: erase its sector and program it byte by
/// byte (RM0090 3.6, x8 parallelism: any supply voltage), with the PAC
/// directly. The HAL's `unlocked()` asserts that the unlock took (a panic
/// path on the board); here a flash that stays locked, or any error flag
/// the controller raises, is a value.
#[cfg(target_os = "none")]
mod store {
    use stm32f4xx_hal::pac::FLASH;

    /// Why a store failed.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
    pub enum StoreError {
        /// The unlock sequence did not clear LOCK.
        Locked,
        /// The controller's status flags after an operation (SR bits
        /// 4-7: write protection, programming alignment, parallelism,
        /// sequence; bit 1: operation).
        Status(u32),
        /// The record does not fit in the sector at that offset.
        OutOfRange,
    }

    const KEY1: u32 = 0x4567_0123;
    const KEY2: u32 = 0xCDEF_89AB;
    /// SR error bits: OPERR, WRPERR, PGAERR, PGPERR, PGSERR.
    const ERRORS: u32 = 0b1111_0010;

    fn wait(flash: &FLASH) {
        while flash.sr().read().bsy().bit_is_set() {}
    }

    fn check(flash: &FLASH) -> Result<(), StoreError> {
        let sr = flash.sr().read().bits() & ERRORS;
        // Clear them for the next operation (write 1 to clear).
        // SAFETY: writing ones to the error flags only clears them.
        flash.sr().write(|w| unsafe { w.bits(ERRORS) });
        if sr == 0 {
            Ok(())
        } else {
            Err(StoreError::Status(sr))
        }
    }

    /// Erases `sector` and programs `data` at `offset` from the start of
    /// flash; locks the flash again whatever happens.
    pub fn store(flash: &FLASH, sector: u8, offset: usize, data: &[u8]) -> Result<(), StoreError> {
        // Sector 11 spans 0xE_0000..0x10_0000 (128 KiB).
        if sector != super::board::CAL_SECTOR
            || offset < 0xE_0000
            || offset + data.len() > 0x10_0000
        {
            return Err(StoreError::OutOfRange);
        }
        wait(flash);
        if flash.cr().read().lock().bit_is_set() {
            // SAFETY: the documented unlock keys.
            flash.keyr().write(|w| unsafe { w.key().bits(KEY1) });
            flash.keyr().write(|w| unsafe { w.key().bits(KEY2) });
        }
        if flash.cr().read().lock().bit_is_set() {
            return Err(StoreError::Locked);
        }
        let r = erase_and_program(flash, sector, offset, data);
        flash
            .cr()
            .modify(|_, w| w.pg().clear_bit().ser().clear_bit().lock().set_bit());
        r
    }

    fn erase_and_program(
        flash: &FLASH,
        sector: u8,
        offset: usize,
        data: &[u8],
    ) -> Result<(), StoreError> {
        let _ = check(flash);
        // SAFETY: SNB takes the sector number (0-11 on the F405).
        flash.cr().modify(|_, w| unsafe {
            w.psize()
                .bits(0)
                .snb()
                .bits(sector)
                .ser()
                .set_bit()
                .pg()
                .clear_bit()
        });
        flash.cr().modify(|_, w| w.strt().set_bit());
        wait(flash);
        check(flash)?;
        flash
            .cr()
            .modify(|_, w| unsafe { w.ser().clear_bit().psize().bits(0).pg().set_bit() });
        for (i, b) in data.iter().enumerate() {
            let addr = (super::board::FLASH_BASE + offset + i) as *mut u8;
            // SAFETY: inside the erased sector (checked above); PG set, x8.
            unsafe { core::ptr::write_volatile(addr, *b) };
            wait(flash);
            check(flash)?;
        }
        Ok(())
    }
}

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [USART2])]
mod app {
    use crate::board;
    use core::sync::atomic::{AtomicU32, Ordering};
    use embedded_hal::delay::DelayNs;
    use embedded_hal_02::Qei as _;
    use embedded_hal_bus::spi::ExclusiveDevice;
    use firmware::app::{App, AppConfig, CAL_RECORD};
    use firmware::icm42688::{Config, Icm42688};
    use stm32f4xx_hal::flash::FlashExt;
    use stm32f4xx_hal::gpio::{Output, PushPull, PA4, PC6};
    use stm32f4xx_hal::pac::{FLASH, SPI1, TIM1, TIM2, TIM4, USART1};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::qei::Qei;
    use stm32f4xx_hal::rcc::Config as RccConfig;
    use stm32f4xx_hal::serial::{Rx, Tx};
    use stm32f4xx_hal::spi::{Mode, Phase, Polarity, Spi};
    use stm32f4xx_hal::timer::{CounterHz, Event as TimerEvent, Flag as TimerFlag, PwmChannel};
    use stm32f4xx_hal::watchdog::IndependentWatchdog;

    /// The board's clock: 1 ms ticks of the TIM2 task, which the idle
    /// task reads too (commands and telemetry on one time base).
    static TICK_MS: AtomicU32 = AtomicU32::new(0);

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
        /// The 1 kHz tick's timer.
        timer: CounterHz<TIM2>,
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
        // The 1 kHz tick: TIM2's update interrupt runs the `tick` task
        // (a hardware task: no async executor, whose resumed-future check
        // and timer-queue assertion are panic paths on the board).
        let mut timer = dp.TIM2.counter_hz(&mut rcc);
        if imu.is_some() {
            if timer.start(1.kHz()).is_err() {
                defmt::error!("TIM2 refused 1 kHz: no tick");
            } else {
                timer.listen(TimerEvent::Update);
            }
        }
        (
            Shared { app },
            Local {
                timer,
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

    /// 1 kHz (TIM2's update): the IMU, the rate loop, the encoder at 50
    /// Hz, the watchdog. The board's clock is the tick count (1 ms each).
    #[task(binds = TIM2, priority = 2, shared = [app], local = [timer, imu, wdg, qei, pwm, dir, k: u32 = 0])]
    fn tick(mut cx: tick::Context) {
        cx.local.timer.clear_flags(TimerFlag::Update);
        {
            cx.local.wdg.feed();
            *cx.local.k = cx.local.k.wrapping_add(1);
            TICK_MS.store(*cx.local.k, Ordering::Relaxed);
            let t_us = u64::from(*cx.local.k) * 1_000;
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
                let t_us = u64::from(TICK_MS.load(Ordering::Relaxed)) * 1_000;
                cx.shared.app.lock(|app| app.on_rx(t_us, &[b]));
            }
            if let Some(rec) = stored {
                if *cx.local.written != Some(rec) {
                    match crate::store::store(
                        cx.local.flash,
                        board::CAL_SECTOR,
                        board::CAL_OFFSET,
                        &rec,
                    ) {
                        Ok(()) => defmt::info!("calibration stored in flash"),
                        Err(e) => defmt::error!("calibration: flash write failed: {}", e),
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
