//! The board's RTIC 2 app: the peripherals wired to the program in
//! `crate::tasks`, with the tasks and priorities it names, on `bsp::hw`:
//! the board's peripherals (`bsp::board`), or with the `qemu` feature the
//! sensors QEMU lacks replayed, the clock set-up skipped (QEMU has no RCC
//! model) and the QEMU test's harness (`bsp::qemu`; its data-ready
//! stand-in, TIM2 at priority 5, and its probes exist only there). The
//! USART, the timers, the interrupts, the tasks and their priorities are
//! the same code in both (`bsp::common`).

#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true)]
mod app {
    use crate::bsp::hw;
    use crate::record::Journal;
    use crate::tasks::{Boot, LinkTask, NavTask, Program, Queues, Stats, TickTask, UartEnds};
    use core::sync::atomic::Ordering;
    use stm32f4xx_hal::pac::{self, Interrupt};

    #[shared]
    struct Shared {
        /// USART3 (its interrupt enables are touched by the link task).
        usart: pac::USART3,
        /// The motor (the link task turns it off when the IMU is silent).
        motor: hw::BoardMotor,
    }

    #[local]
    struct Local {
        tick: &'static mut TickTask<'static>,
        nav: &'static mut NavTask<'static>,
        link: &'static mut LinkTask<'static>,
        uart: &'static mut UartEnds<'static>,
        imu: hw::BoardImu,
        encoder: hw::BoardEncoder,
        flash: hw::BoardFlash,
        wdg: hw::BoardWatchdog,
        clock_tick: crate::clock::Clock64,
        clock_link: crate::clock::Clock64,
        tim3: pac::TIM3,
        #[cfg(feature = "qemu")]
        tim2: pac::TIM2,
    }

    /// Builds the program into its static (`slot`) in a frame of its own,
    /// gone when it returns: `main`, which `idle` runs on, keeps only
    /// references to the tasks (their 33 KiB built by value there would be
    /// stack the tasks could never use).
    #[inline(never)]
    fn boot(
        slot: &'static mut core::mem::MaybeUninit<Program<'static>>,
        queues: &'static mut Queues,
        journal: Journal,
        boot: Boot,
    ) -> &'static mut Program<'static> {
        match Program::new(slot, queues, journal, boot) {
            Ok(p) => p,
            Err(_) => hw::halt("the configuration is out of the table's limits"),
        }
    }

    #[init(local = [queues: Queues = Queues::new(), program: core::mem::MaybeUninit<Program<'static>> = core::mem::MaybeUninit::uninit()])]
    fn init(cx: init::Context) -> (Shared, Local) {
        hw::paint_stack();
        let mut core = cx.core;
        let dp = cx.device;
        let reset = hw::reset_cause(&dp.RCC);
        let resets = hw::reset_verdict(reset);
        hw::freeze_for_debugger(&dp.DBGMCU);
        hw::start_cycle_counter(&mut core.DCB, &mut core.DWT, core.SYST);
        let board = hw::Board::new(dp);
        let mut flash = board.flash;
        // The only erases: here, before the tick starts (up to 4 s: the
        // watchdog runs at its boot period, `hw::BoardWatchdog`).
        let journal = match Journal::open(&mut flash, hw::JOURNAL) {
            Ok(j) => j,
            Err(_) => Journal::blank(hw::JOURNAL),
        };
        // The boot's time is the end of the erases (the IMU's silence is
        // timed from the link task's first run, `tasks::Window`).
        let start = hw::clock_start(&board.tim5);
        let boot = Boot {
            now_us: u64::from(start),
            reset,
            imu: board.imu_status,
            tuning: hw::tuning(),
            clock: board.clock_status,
            resets,
        };
        let program = self::boot(cx.local.program, cx.local.queues, journal, boot);
        let Program {
            tick,
            nav,
            link,
            uart,
        } = program;
        let mut wdg = board.wdg;
        wdg.run_period();
        hw::rx_ready();
        hw::enable_interrupts(link.sensors());
        (
            Shared {
                usart: board.usart,
                motor: board.motor,
            },
            Local {
                tick,
                nav,
                link,
                uart,
                imu: board.imu,
                encoder: board.encoder,
                flash,
                wdg,
                clock_tick: crate::clock::Clock64::new(start),
                clock_link: crate::clock::Clock64::new(start),
                tim3: board.tim3,
                #[cfg(feature = "qemu")]
                tim2: board.tim2,
            },
        )
    }

    /// USART3 (priority 4, the top): a byte out (and, under QEMU, a byte
    /// in: the board's DMA receives). Nothing may hold it off for more than
    /// a byte (11 µs at 921,600 baud): no task takes a lock at this
    /// priority for longer than a register write.
    #[task(binds = USART3, priority = 4, shared = [usart], local = [uart])]
    fn uart(mut cx: uart::Context) {
        let c0 = hw::cycles();
        let uart = cx.local.uart;
        let sent = cx
            .shared
            .usart
            .lock(|u| hw::usart_service(u, uart, hw::rx_soft(), &hw::STATS));
        // The chip's case: a byte each way at most (QEMU's transmitter
        // takes the whole queue in one run).
        if sent <= 1 {
            Stats::worst(&hw::STATS.uart_worst, hw::since(c0));
        }
    }

    /// The receive DMA's half-ring events (priority 4; the board's DMA1
    /// stream 1, never under QEMU): counted for the link task's reader.
    #[task(binds = DMA1_STREAM1, priority = 4)]
    fn rx_dma(_: rx_dma::Context) {
        hw::rx_dma_event();
    }

    /// The control tick (priority 3): the IMU's data-ready edge (EXTI4 on
    /// PC4, the IMU's INT1).
    #[task(binds = EXTI4, priority = 3, shared = [motor], local = [tick, imu, encoder, clock_tick])]
    fn tick(mut cx: tick::Context) {
        let c0 = hw::cycles();
        hw::clear_data_ready();
        let now = cx.local.clock_tick.extend(hw::clock_now());
        // The QEMU build's overrun probe (after its replay) stalls here
        // past the next edge instead of running the tick.
        #[cfg(feature = "qemu")]
        let probe = hw::overrun_probe();
        #[cfg(not(feature = "qemu"))]
        let probe = false;
        if !probe {
            let (tick, imu, enc) = (cx.local.tick, cx.local.imu, cx.local.encoder);
            let pend = cx
                .shared
                .motor
                .lock(|m| tick.run(now, imu, enc, m, &hw::STATS));
            #[cfg(feature = "qemu")]
            let pend = pend || hw::replay_done();
            if pend {
                rtic::pend(Interrupt::SPI3);
            }
        }
        if hw::tick_pending() {
            hw::STATS.tick_overruns.fetch_add(1, Ordering::Relaxed);
        }
        if !probe {
            Stats::worst(&hw::STATS.tick_worst, hw::since(c0));
        }
    }

    /// Navigation (priority 2): pended by the tick (SPI3's vector, unused).
    #[task(binds = SPI3, priority = 2, local = [nav])]
    fn nav(cx: nav::Context) {
        let c0 = hw::cycles();
        cx.local.nav.run(&hw::STATS);
        // The QEMU build's stress adds work to some runs (not counted).
        #[cfg(feature = "qemu")]
        let stressed = hw::stress();
        #[cfg(not(feature = "qemu"))]
        let stressed = false;
        if !stressed {
            Stats::worst(&hw::STATS.nav_worst, hw::since(c0));
        }
        #[cfg(feature = "qemu")]
        hw::after_nav(cx.local.nav);
    }

    /// The link, the flash journal, supervision and the watchdog
    /// (priority 1, TIM3 at 100 Hz).
    #[task(binds = TIM3, priority = 1, shared = [usart, motor], local = [link, flash, wdg, tim3, clock_link])]
    fn link(mut cx: link::Context) {
        let c0 = hw::cycles();
        hw::clear_tim3(cx.local.tim3);
        let now = cx.local.clock_link.extend(hw::clock_now());
        let out = cx
            .local
            .link
            .run(now, hw::rx(), cx.local.flash, cx.local.wdg, &hw::STATS);
        if out.healthy {
            hw::reset_healthy();
        }
        if out.motor_off {
            cx.shared.motor.lock(|m| crate::tasks::Motor::set(m, 0.0));
        }
        cx.shared.usart.lock(|u| {
            hw::rearm_line_errors(u);
            if out.tx_pending {
                hw::listen_tx(u);
            }
        });
        hw::after_link(cx.local.link);
        Stats::worst(&hw::STATS.link_worst, hw::since(c0));
    }

    /// The QEMU build's stand-in for the IMU's data-ready line: 1 kHz from
    /// TIM2 (priority 5, as an edge on a pin would be). Not in the board's
    /// build.
    #[cfg(feature = "qemu")]
    #[task(binds = TIM2, priority = 5, local = [tim2])]
    fn data_ready(cx: data_ready::Context) {
        hw::clear_tim2(cx.local.tim2);
        if hw::sensors_on() {
            hw::count_edge();
            rtic::pend(Interrupt::EXTI4);
        }
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        hw::repaint_after_init();
        loop {
            // DBGMCU keeps the debug clocks running in sleep, so RTT and
            // the probe keep working (set in `init`).
            cortex_m::asm::wfi();
        }
    }
}
