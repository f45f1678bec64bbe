//! The firmware's QEMU build (`cargo qemu`; `qemu-system-arm -M
//! netduinoplus2 -icount shift=0`): the scheduler paces a recording's IMU
//! samples at 100 Hz of virtual time (encoder reads at 50 Hz come with
//! them), read through semihosting from `target/qemu/replay.bin` (made by
//! `rins qemu-replay`), through the same `App` as the board. It counts the
//! instructions of each navigation step (SysTick under `-icount shift=0`
//! counts instructions, run to run identical), compares its final state
//! with the host's run of the same stream bit for bit, prints
//! `N passed, M failed` and exits with the result. No clock setup: QEMU
//! has no RCC model.

#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!("the QEMU build runs under qemu-system-arm: `cargo qemu`");
}

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    cortex_m_semihosting::hprintln!("panic");
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [USART2])]
mod app {
    use cortex_m_semihosting::{debug, hprintln, syscall};
    use firmware::app::{App, Mode};
    use firmware::replay::{
        decode, decode_outcome, outcome, step, Event, Header, HEADER, RECORD, TRAILER,
    };
    use rtic_monotonics::systick::prelude::*;

    systick_monotonic!(Mono, 1_000);
    /// The SysTick clock QEMU's STM32F405 model runs, Hz.
    const SYSCLK_HZ: u32 = 168_000_000;
    /// SysTick reload for the 1 kHz monotonic.
    const RELOAD: u32 = SYSCLK_HZ / 1_000;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        fd: usize,
    }

    fn read(fd: usize, buf: &mut [u8]) -> bool {
        // SYS_READ returns the number of bytes NOT read.
        // SAFETY: the buffer is valid for its length for the call.
        let left = unsafe { syscall!(READ, fd, buf.as_mut_ptr(), buf.len()) };
        left == 0
    }

    /// 1,000 NOPs in a function of their own (the block would push other
    /// code's PC-relative fixups out of range); the call adds ~3 instructions.
    #[inline(never)]
    fn nops() {
        // SAFETY: NOPs only.
        unsafe {
            core::arch::asm!(
                ".rept 1000",
                "nop",
                ".endr",
                options(nomem, nostack, preserves_flags)
            )
        };
    }

    fn fail(msg: &str) -> ! {
        hprintln!("{}", msg);
        hprintln!("0 passed, 1 failed");
        debug::exit(debug::EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        Mono::start(cx.core.SYST, SYSCLK_HZ);
        let path = b"target/qemu/replay.bin\0";
        // SAFETY: a NUL-terminated path; mode 1 = "rb".
        let fd = unsafe { syscall!(OPEN, path.as_ptr(), 1, path.len() - 1) };
        if fd == usize::MAX {
            fail("cannot open target/qemu/replay.bin (run `rins qemu-replay` first)");
        }
        if replay::spawn().is_err() {
            fail("replay already running");
        }
        (Shared {}, Local { fd })
    }

    #[task(priority = 1, local = [fd])]
    async fn replay(cx: replay::Context) {
        let fd = *cx.local.fd;
        let mut h = [0u8; HEADER];
        let Some(header) = (if read(fd, &mut h) {
            Header::decode(&h)
        } else {
            None
        }) else {
            fail("bad replay header");
        };
        let Ok(mut app) = App::new(header.config()) else {
            fail("bad configuration")
        };
        let mut next = Mono::now();
        let (mut nav_steps, mut nav_instr, mut nav_min, mut nav_max) = (0u64, 0u64, u32::MAX, 0u32);
        let mut r = [0u8; RECORD];
        for _ in 0..header.records {
            if !read(fd, &mut r) {
                fail("replay stream ends early");
            }
            let Some(e) = decode(&r) else {
                fail("bad record")
            };
            let imu = matches!(e, Event::Imu { .. });
            if imu {
                // 100 Hz of virtual time per IMU sample.
                next += rtic_monotonics::fugit::ExtU32::millis(10u32);
                Mono::delay_until(next).await;
            }
            let navigating = app.mode == Mode::Navigating;
            let c0 = cortex_m::peripheral::SYST::get_current();
            step(&mut app, &e);
            let c1 = cortex_m::peripheral::SYST::get_current();
            if imu && navigating {
                // SysTick counts down; a wrap adds one reload.
                let d = if c0 >= c1 { c0 - c1 } else { c0 + RELOAD - c1 };
                nav_steps += 1;
                nav_instr += u64::from(d);
                nav_min = nav_min.min(d);
                nav_max = nav_max.max(d);
            }
        }
        // Instructions per SysTick count: time 1,000 NOPs (unrolled by the
        // assembler, no loop overhead). Under -icount shift=0 an instruction
        // is 1 ns of virtual time and SysTick runs at the model's 168 MHz:
        // about 5.95 instructions per count.
        let k0 = cortex_m::peripheral::SYST::get_current();
        nops();
        let k1 = cortex_m::peripheral::SYST::get_current();
        let k = if k0 >= k1 { k0 - k1 } else { k0 + RELOAD - k1 };
        let per_count = 1000.0 / f64::from(k.max(1));
        let mut t = [0u8; TRAILER];
        if !read(fd, &mut t) {
            fail("no trailer");
        }
        let want = decode_outcome(&t);
        let got = outcome(&app);
        let bits = |o: &firmware::replay::Outcome| {
            let mut b = [0u32; 6];
            for (d, v) in b.iter_mut().zip(o.p_n.iter().chain(o.v_n.iter())) {
                *d = v.to_bits();
            }
            (o.mode, b)
        };
        let instr = |c: f64| (c * per_count) as u64;
        hprintln!(
            "navigation steps {}: instructions per IMU sample while navigating (strapdown step, rate loop, telemetry framing): mean {} min {} max {} ({:.2} instructions per SysTick count)",
            nav_steps,
            instr(nav_instr as f64 / nav_steps.max(1) as f64),
            instr(f64::from(nav_min)),
            instr(f64::from(nav_max)),
            per_count
        );
        hprintln!("QEMU p_n {:?} v_n {:?}", got.p_n, got.v_n);
        hprintln!("host p_n {:?} v_n {:?}", want.p_n, want.v_n);
        let checks = [
            ("reached navigation", got.mode == 3),
            ("bit-identical to the host", bits(&got) == bits(&want)),
        ];
        let passed = checks.iter().filter(|c| c.1).count();
        for (name, ok) in checks {
            hprintln!("{} ... {}", name, if ok { "ok" } else { "FAILED" });
        }
        hprintln!("{} passed, {} failed", passed, checks.len() - passed);
        debug::exit(if passed == checks.len() {
            debug::EXIT_SUCCESS
        } else {
            debug::EXIT_FAILURE
        });
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }
}
