//! The firmware's QEMU build (`cargo qemu`; `qemu-system-arm -M
//! netduinoplus2 -icount shift=0`): the scheduler paces a recording's IMU
//! samples at 100 Hz of virtual time (encoder reads at 50 Hz and GNSS fixes
//! come with them), read through semihosting from `target/qemu/replay.bin`
//! (a static-base run) and `target/qemu/drive.bin` (an aided drive with a
//! GNSS outage), both made by `rins qemu-replay`, through the same `App`
//! as the board. It counts the
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
        decode, decode_outcome, outcome, record_body, step, Event, Header, HEADER, RECORD_HEAD,
        RECORD_MAX, TRAILER, VERSION,
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
    struct Local {}

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

    /// The replays, in order: a static-base run (power-up calibration,
    /// then navigation) and a drive (the aided filter with GNSS fixes over
    /// the command link, through an outage). Both are made by `rins
    /// qemu-replay`; a missing one fails.
    const REPLAYS: [(&str, &[u8]); 2] = [
        ("static", b"target/qemu/replay.bin\0"),
        ("drive", b"target/qemu/drive.bin\0"),
    ];

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        Mono::start(cx.core.SYST, SYSCLK_HZ);
        if replay::spawn().is_err() {
            fail("replay already running");
        }
        (Shared {}, Local {})
    }

    /// SysTick counts between two reads (it counts down; a wrap adds one
    /// reload).
    fn elapsed(c0: u32, c1: u32) -> u32 {
        if c0 >= c1 {
            c0 - c1
        } else {
            c0 + RELOAD - c1
        }
    }

    /// Instructions `f` takes, interrupts masked (the scheduler's SysTick
    /// handler is not counted): SysTick counts at the model's 168 MHz,
    /// `per_count` instructions per count (at most one wrap, 1 ms: ~1e6
    /// instructions).
    fn count<R>(per_count: f64, f: impl FnOnce() -> R) -> u64 {
        cortex_m::interrupt::free(|_| {
            let c0 = cortex_m::peripheral::SYST::get_current();
            let r = f();
            let c1 = cortex_m::peripheral::SYST::get_current();
            core::hint::black_box(r);
            (f64::from(elapsed(c0, c1)) * per_count) as u64
        })
    }

    /// The mean of `count` over `n` successive calls of `f(i)`.
    fn mean(per_count: f64, n: u32, mut f: impl FnMut(u32)) -> u64 {
        let total: u64 = (0..n).map(|i| count(per_count, || f(i))).sum();
        total / u64::from(n.max(1))
    }

    /// Instruction counts per function, on the state a replay ended in
    /// and its last navigation sample, one per line (`name: N
    /// instructions`): what the navigation sample's total is made of.
    fn profile(app: &App, per_count: f64) {
        use core_nav::calib::PhaseAccumulator;
        use core_nav::control::{MotorModel, RateController};
        use core_nav::scheme::Reference;
        use core_nav::table::{Axis, TableAngle};
        use firmware::telemetry::{frame, Telemetry, MAX_FRAME, MAX_PAYLOAD};
        use nalgebra::Vector3;
        let Some((t_us, s)) = app.last_nav_sample() else {
            return;
        };
        let sample = |i: u32| {
            let mut x = app.imu_sample(t_us + 10_000 * u64::from(i + 1), &s);
            x.w_is_s.x += 1e-4 * i as f32;
            x
        };
        let angle = |i: u32| TableAngle::<f32>::from_counts(i64::from(i) * 27, 16_384);
        // The samples are made before the counts (the static run's
        // calibration is applied in f64: not the step's cost).
        let samples: [core_nav::strapdown::ImuSample<f32>; 10] =
            core::array::from_fn(|i| sample(i as u32));
        let at = |i: u32| {
            samples
                .get(i as usize)
                .copied()
                .unwrap_or_else(|| sample(i))
        };
        if let Some(nav) = app.nav() {
            let mut n = nav.clone();
            let c = mean(per_count, 10, |i| {
                let x = at(i);
                core::hint::black_box(n.step(&x).is_ok());
            });
            hprintln!("core-nav step: {} instructions", c);
        }
        if let Some(a) = app.aided() {
            let st = *a.nav().state();
            let c_s_n = core_nav::attitude::quat_to_dcm(&st.q_s_n);
            let w_ie = Vector3::new(6.3e-5f32, 0.0, -3.7e-5);
            let w_en = Vector3::new(1e-6f32, -2e-6, 0.0);
            let mut kf = a.kf.clone();
            kf.batch = u32::MAX;
            let c = mean(per_count, 10, |i| {
                let x = at(i);
                kf.predict(&c_s_n, &(c_s_n * x.f_s), &w_ie, &w_en, &x.w_is_s, 0.01);
            });
            hprintln!(
                "filter predict (every sample: the system's integrals): {} instructions",
                c
            );
            let c = count(per_count, || kf.propagate());
            hprintln!(
                "filter propagate (every {} samples): {} instructions",
                core_nav::aided::PREDICT_BATCH,
                c
            );
            let z = Vector3::new(0.3f32, -0.2, 0.5);
            let sig = Vector3::new(1.0f32, 1.0, 2.0);
            let c = count(per_count, || {
                kf.update_position(&z, &Vector3::new(1.0, 0.0, -0.8), &sig)
                    .is_ok()
            });
            hprintln!(
                "filter GNSS position update (3 components): {} instructions",
                c
            );
            let c = count(per_count, || {
                kf.update_velocity(&(z * 0.1), &(sig * 0.05)).is_ok()
            });
            hprintln!(
                "filter GNSS velocity update (3 components): {} instructions",
                c
            );
            let mut an = a.clone();
            let c = mean(per_count, 10, |i| {
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
        let c = mean(per_count, 10, |i| {
            core::hint::black_box(ctrl.update(&r, 1e-3 * i as f32, 0.51, 1e-3));
        });
        hprintln!("rate loop: {} instructions", c);
        let c = mean(per_count, 10, |i| {
            let mut p = [0u8; MAX_PAYLOAD];
            let mut f = [0u8; MAX_FRAME];
            let t = Telemetry::Nav {
                t_us: t_us + u64::from(i),
                q_b_n: [1.0, 0.0, 0.0, 0.0],
                v_n: [0.1 * i as f32, 0.2, 0.3],
                p_n: [1.0, 2.0, 3.0],
            };
            let n = t.payload(i as u16, &mut p).unwrap_or(0);
            core::hint::black_box(frame(p.get(..n).unwrap_or(&[]), &mut f).is_ok());
        });
        hprintln!("telemetry framing (a Nav frame): {} instructions", c);
        let mut acc = PhaseAccumulator::new(0.52, Axis::Z);
        let c = mean(per_count, 10, |i| {
            let x = at(i);
            core::hint::black_box(
                acc.push(t_us + 10_000 * u64::from(i), &x.w_is_s, &x.f_s, angle(i))
                    .is_ok(),
            );
        });
        hprintln!("calibration step (phase accumulator): {} instructions", c);
    }

    /// Runs one replay file; returns (checks passed, checks run).
    async fn run(name: &str, path: &[u8], per_count: f64) -> (usize, usize) {
        // SAFETY: a NUL-terminated path; mode 1 = "rb".
        let fd = unsafe { syscall!(OPEN, path.as_ptr(), 1, path.len() - 1) };
        if fd == usize::MAX {
            hprintln!(
                "{}: cannot open the replay (run `rins qemu-replay` first)",
                name
            );
            return (0, 1);
        }
        let mut h = [0u8; HEADER];
        let Some(header) = (if read(fd, &mut h) {
            Header::decode(&h)
        } else {
            None
        }) else {
            hprintln!("{}: bad replay header (version {} expected)", name, VERSION);
            return (0, 1);
        };
        let Ok(mut app) = App::new(header.config()) else {
            hprintln!("{}: the board refuses the configuration", name);
            return (0, 1);
        };
        let mut next = Mono::now();
        let (mut nav_steps, mut nav_instr, mut nav_min, mut nav_max) = (0u64, 0u64, u32::MAX, 0u32);
        let mut r = [0u8; RECORD_MAX];
        for _ in 0..header.records {
            let head_ok = r.get_mut(..RECORD_HEAD).is_some_and(|b| read(fd, b));
            let body = r.first().copied().and_then(record_body).unwrap_or(0);
            let body_ok = r
                .get_mut(RECORD_HEAD..RECORD_HEAD + body)
                .is_some_and(|b| body > 0 && read(fd, b));
            let e = if head_ok && body_ok { decode(&r) } else { None };
            let Some(e) = e else {
                hprintln!("{}: the stream ends early or holds a bad record", name);
                return (0, 1);
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
                let d = elapsed(c0, c1);
                nav_steps += 1;
                nav_instr += u64::from(d);
                nav_min = nav_min.min(d);
                nav_max = nav_max.max(d);
            }
        }
        let mut t = [0u8; TRAILER];
        if !read(fd, &mut t) {
            hprintln!("{}: no trailer", name);
            return (0, 1);
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
            "{}: navigation steps {}: instructions per IMU sample while navigating (all the board does with it): mean {} min {} max {}",
            name,
            nav_steps,
            instr(nav_instr as f64 / nav_steps.max(1) as f64),
            instr(f64::from(nav_min)),
            instr(f64::from(nav_max)),
        );
        if let Some(a) = app.aided() {
            let c = a.counts;
            hprintln!(
                "{}: GNSS fixes used {}, zero-velocity updates {}, gate rejections {}, refused {}",
                name,
                c.fixes_used,
                c.zupts,
                a.kf.rejected,
                a.kf.refused
            );
        }
        hprintln!("{}: QEMU p_n {:?} v_n {:?}", name, got.p_n, got.v_n);
        hprintln!("{}: host p_n {:?} v_n {:?}", name, want.p_n, want.v_n);
        let checks = [
            ("reached navigation", got.mode == 3),
            ("bit-identical to the host", bits(&got) == bits(&want)),
        ];
        profile(&app, per_count);
        let passed = checks.iter().filter(|c| c.1).count();
        for (check, ok) in checks {
            hprintln!(
                "{}: {} ... {}",
                name,
                check,
                if ok { "ok" } else { "FAILED" }
            );
        }
        (passed, checks.len())
    }

    #[task(priority = 1)]
    async fn replay(_: replay::Context) {
        // Instructions per SysTick count: time 1,000 NOPs (unrolled by the
        // assembler, no loop overhead). Under -icount shift=0 an
        // instruction is 1 ns of virtual time and SysTick runs at the
        // model's 168 MHz: about 5.95 instructions per count.
        let k0 = cortex_m::peripheral::SYST::get_current();
        nops();
        let k1 = cortex_m::peripheral::SYST::get_current();
        let per_count = 1000.0 / f64::from(elapsed(k0, k1).max(1));
        hprintln!("{:.2} instructions per SysTick count", per_count);
        let (mut passed, mut total) = (0, 0);
        for (name, path) in REPLAYS {
            let (p, n) = run(name, path, per_count).await;
            passed += p;
            total += n;
        }
        hprintln!("{} passed, {} failed", passed, total - passed);
        debug::exit(if passed == total {
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
