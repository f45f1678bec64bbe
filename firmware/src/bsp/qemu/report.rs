//! The QEMU test's report, printed by navigation at the replay's end: the
//! tasks' budgets (the lines CI requires), the stack's peak, the link, the
//! 64-bit clock across the u32 wrap, the outcome against the host twin's
//! bit for bit, and the instruction counts per function.

use super as hw;
use super::Harness;
use crate::replay::{outcome, Outcome};
use crate::tasks::NavTask;
use core::sync::atomic::Ordering;
use cortex_m_semihosting::{debug, hprintln};

/// The tick's budget: 20 % of its 1 ms at 168 MHz and 1.25 cycles an
/// instruction.
const TICK_BUDGET: u32 = 26_880;
/// Navigation's: 50 % of its 10 ms at 1.5 cycles an instruction.
const NAV_BUDGET: u32 = 560_000;
/// The stack's, at boot and in the tasks.
const STACK_BUDGET: u32 = 16_384;

fn bits(o: &Outcome) -> (u8, [u32; 6]) {
    let mut b = [0u32; 6];
    for (d, v) in b.iter_mut().zip(o.p_n.iter().chain(o.v_n.iter())) {
        *d = v.to_bits();
    }
    (o.mode, b)
}

/// Prints the report (`stack`: the peak the tasks reached; init's is
/// kept apart, since idle paints the stack again) and exits QEMU
/// with its result.
#[inline(never)]
pub fn report(nav: &mut NavTask<'static>, h: &Harness, host: Option<Outcome>, stack: u32) -> ! {
    let s = &hw::STATS;
    let l = |a: &core::sync::atomic::AtomicU32| a.load(Ordering::Relaxed);
    let name = if nav.nav.config().aided.is_some() {
        "drive"
    } else {
        "static"
    };
    let ticks = l(&s.progress.tick);
    let now = hw::clock_now();
    hprintln!(
        "{}: data-ready edges {}, ticks {}, samples dropped {}, duplicated {}",
        name,
        h.edges,
        ticks,
        l(&s.dropped),
        l(&s.duplicated)
    );
    hprintln!(
        "tick: worst {} instructions, overruns {}",
        l(&s.tick_worst),
        l(&s.tick_overruns)
    );
    hprintln!(
        "nav: worst {} instructions, overruns {}",
        l(&s.nav_worst),
        l(&s.nav_overruns)
    );
    hprintln!("link task: worst {} instructions", l(&s.link_worst));
    hprintln!(
        "uart: worst {} instructions (a byte in and one out)",
        l(&s.uart_worst)
    );
    hprintln!(
        "{}: stress: {} navigation runs with {} more instructions each (4 ms at QEMU's 1 ns an instruction, four tick periods): ticks {} of {} data-ready edges",
        name, h.stressed, h.stress_instructions, ticks, h.edges
    );
    let init_stack = hw::STATS.init_stack_bytes.load(Ordering::Relaxed);
    let peak = stack.max(init_stack);
    hprintln!(
        "stack peak: {} bytes (init {}, the tasks {})",
        peak,
        init_stack,
        stack
    );
    hprintln!(
        "{}: overrun probe: a tick stalled past the next data-ready edge, {} overrun counted",
        name,
        h.probe_overruns
    );
    hprintln!(
        "link: {} bytes received through the USART, {} lost",
        l(&s.rx_bytes),
        l(&s.rx_lost)
    );
    hprintln!(
        "{}: telemetry lost in the task queues {}, watchdog feeds {}",
        name,
        l(&s.out_lost),
        h.feeds
    );
    hprintln!(
        "clock: started at {:#010x}, now {:#010x} (wrapped: {})",
        h.clock_start,
        now,
        now < h.clock_start
    );
    let fixes_late = nav.nav.fixes_late;
    if let Some(a) = nav.nav.aided() {
        let c = a.counts;
        hprintln!(
            "{}: GNSS fixes used {} (late {}), zero-velocity updates {}, zero-rotation updates {}, still windows refuted {}, gate rejections {}, refused {}",
            name,
            c.fixes_used,
            fixes_late,
            c.zupts,
            c.zarus,
            c.still_refuted,
            a.kf.rejected,
            a.kf.refused
        );
    }
    let got = outcome(&nav.nav);
    let want = host.unwrap_or_default();
    hprintln!("{}: QEMU p_n {:?} v_n {:?}", name, got.p_n, got.v_n);
    hprintln!("{}: host p_n {:?} v_n {:?}", name, want.p_n, want.v_n);
    super::profile::profile(&nav.nav);
    let checks = [
        ("reached navigation", got.mode == 3),
        (
            "bit-identical to the host twin",
            host.is_some() && bits(&got) == bits(&want),
        ),
        (
            "every data-ready edge ticked (the stress never delayed the tick)",
            ticks == h.edges && h.stressed > 0,
        ),
        (
            "tick within its budget, no overrun",
            l(&s.tick_worst) <= TICK_BUDGET && l(&s.tick_overruns) == 0,
        ),
        (
            "navigation within its budget, no overrun",
            l(&s.nav_worst) <= NAV_BUDGET && l(&s.nav_overruns) == 0,
        ),
        (
            "stack within 16 KiB, init's and the tasks'",
            peak <= STACK_BUDGET,
        ),
        (
            "commands and fixes through the USART, none lost",
            l(&s.rx_bytes) > 0 && l(&s.rx_lost) == 0,
        ),
        ("the 64-bit clock crossed the u32 wrap", now < h.clock_start),
        (
            "a boot that erased twice (4 s), the sensors on from reset: navigating at the end",
            h.erases == 2 && outcome(&nav.nav).mode == 3,
        ),
        (
            "a tick stalled past the next edge is one overrun counted",
            h.probe_overruns == 1,
        ),
    ];
    let passed = checks.iter().filter(|c| c.1).count();
    for (check, ok) in checks {
        hprintln!(
            "{}: {} ... {}",
            name,
            check,
            if ok { "ok" } else { "FAILED" }
        );
    }
    hprintln!("{} passed, {} failed", passed, checks.len() - passed);
    debug::exit(if passed == checks.len() {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::wfi();
    }
}
