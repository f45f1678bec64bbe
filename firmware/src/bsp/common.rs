//! The peripherals both builds share (the board and QEMU run the same
//! code here): TIM5 as the 64-bit clock's counter, TIM3 pacing the link
//! task, USART3 by interrupt, EXTI4 for the IMU's data-ready, the stack's
//! paint. Register-level (the PAC): QEMU has no RCC, so the HAL's
//! drivers, which need frozen clocks, are for the board's own file.

use crate::tasks::{Stats, UartEnds};
use stm32f4xx_hal::pac::{self, Interrupt, NVIC};

/// Every task's counters.
pub static STATS: Stats = Stats {
    progress: crate::watchdog::Progress {
        tick: core::sync::atomic::AtomicU32::new(0),
        nav: core::sync::atomic::AtomicU32::new(0),
        link: core::sync::atomic::AtomicU32::new(0),
    },
    tick_worst: core::sync::atomic::AtomicU32::new(0),
    tick_overruns: core::sync::atomic::AtomicU32::new(0),
    nav_worst: core::sync::atomic::AtomicU32::new(0),
    nav_overruns: core::sync::atomic::AtomicU32::new(0),
    link_worst: core::sync::atomic::AtomicU32::new(0),
    uart_worst: core::sync::atomic::AtomicU32::new(0),
    dropped: core::sync::atomic::AtomicU32::new(0),
    duplicated: core::sync::atomic::AtomicU32::new(0),
    rx_bytes: core::sync::atomic::AtomicU32::new(0),
    rx_lost: core::sync::atomic::AtomicU32::new(0),
    rx_line: [const { core::sync::atomic::AtomicU32::new(0) }; 3],
    out_lost: core::sync::atomic::AtomicU32::new(0),
    last_sample_us: core::sync::atomic::AtomicU32::new(0),
    samples: core::sync::atomic::AtomicU32::new(0),
    init_stack_bytes: core::sync::atomic::AtomicU32::new(0),
    stack_bytes: core::sync::atomic::AtomicU32::new(0),
};

/// The peripherals set up, as `init` hands them to the tasks: the timers
/// and the USART both builds share, and each build's IMU, encoder, motor,
/// flash and watchdog (`bsp::board`: the chip's; `bsp::qemu`: the
/// replay's and RAM's).
pub struct Parts<Imu, Enc, Mot, Fl, Wdg> {
    /// The 64-bit clock's counter.
    pub tim5: pac::TIM5,
    /// The link task's timer.
    pub tim3: pac::TIM3,
    /// The QEMU build's data-ready stand-in.
    #[cfg(feature = "qemu")]
    pub tim2: pac::TIM2,
    /// The telemetry UART (the Feather's TX/RX pins; QEMU's third `-serial`).
    pub usart: pac::USART3,
    /// The motor.
    pub motor: Mot,
    /// The IMU.
    pub imu: Imu,
    /// The encoder.
    pub encoder: Enc,
    /// The flash journal's sectors.
    pub flash: Fl,
    /// The watchdog (not started).
    pub wdg: Wdg,
    /// Whether the IMU came up (`Err`: a stopped board that reports).
    pub imu_status: Result<(), crate::faults::Fault>,
    /// How the clock tree started (`crate::clocks`; `Err`: a
    /// fallback, reported).
    pub clock_status: Result<(), crate::faults::Fault>,
}

/// The telemetry link's baud rate.
pub const BAUD: u32 = 921_600;
/// The word the stack is painted with.
const PAINT: u32 = 0x5AC4_5AC4;
extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

fn stack_top() -> u32 {
    // Only the linker script's symbol's address is taken.
    core::ptr::addr_of!(_stack_start) as u32
}

/// The bottom of the stack: flip-link puts the stack at the start of RAM
/// (below `.data` and `.bss`), so an overflow faults instead of
/// overwriting statics; it defines `_stack_end` there.
fn stack_bottom() -> u32 {
    // Only the linker script's symbol's address is taken.
    core::ptr::addr_of!(_stack_end) as u32
}

/// Paints the unused stack (from its bottom to 256 bytes below where
/// `init` is) so that [`stack_peak`] can read back how deep it ever went.
pub fn paint_stack() {
    let sp = cortex_m::register::msp::read();
    let mut a = stack_bottom();
    while a + 256 < sp {
        // SAFETY: between the bottom of RAM and the live stack: unused.
        unsafe { core::ptr::write_volatile(a as *mut u32, PAINT) };
        a += 4;
    }
}

/// When idle starts: keeps the init's peak (it builds the tasks' state,
/// once, with interrupts off) and paints again, so [`stack_peak`] is the
/// tasks' own. Safe to run while tasks preempt: a task's frames lie below
/// idle's, and idle does not run while they are live.
pub fn repaint_after_init() {
    // The init's peak, sent in every health frame.
    STATS
        .init_stack_bytes
        .store(stack_peak(), core::sync::atomic::Ordering::Relaxed);
    paint_stack();
}

/// The deepest the stack has been since [`paint_stack`], bytes.
pub fn stack_peak() -> u32 {
    let mut a = stack_bottom();
    // SAFETY: reads within the stack's region.
    while a < stack_top() && unsafe { core::ptr::read_volatile(a as *const u32) } == PAINT {
        a += 4;
    }
    stack_top().saturating_sub(a)
}

/// TIM5 as a free-running 32-bit counter at 1 MHz from `start` (the
/// clock's 64-bit extension is `crate::clock::Clock64`).
pub fn start_clock(tim5: &pac::TIM5, timer_hz: u32, start: u32) {
    // SAFETY: plain register writes (prescaler, reload, counter, enable).
    unsafe {
        tim5.psc().write(|w| w.bits(timer_hz / 1_000_000 - 1));
        tim5.arr().write(|w| w.bits(u32::MAX));
        tim5.egr().write(|w| w.bits(1));
        tim5.cnt().write(|w| w.bits(start));
        tim5.cr1().write(|w| w.bits(1));
    }
}

/// TIM5's counter now, µs.
pub fn clock_now() -> u32 {
    // SAFETY: a read of a counter register no task writes after init.
    unsafe { (*pac::TIM5::ptr()).cnt().read().bits() }
}

/// A general-purpose timer's update interrupt at `hz`.
macro_rules! periodic {
    ($name:ident, $tim:ty) => {
        /// Starts the timer's update interrupt at `hz` from `timer_hz`.
        pub fn $name(t: &$tim, timer_hz: u32, hz: u32) {
            // 1 MHz ticks, `1e6 / hz` of them a period.
            // SAFETY: plain register writes.
            unsafe {
                t.psc().write(|w| w.bits(timer_hz / 1_000_000 - 1));
                t.arr().write(|w| w.bits(1_000_000 / hz - 1));
                t.egr().write(|w| w.bits(1));
                t.sr().write(|w| w.bits(0));
                t.dier().write(|w| w.bits(1));
                t.cr1().write(|w| w.bits(1));
            }
        }
    };
}
periodic!(start_tim3, pac::TIM3);
// TIM2 drives the QEMU build's data-ready stand-in.
#[cfg(feature = "qemu")]
periodic!(start_tim2, pac::TIM2);

/// Clears TIM3's update flag.
pub fn clear_tim3(t: &pac::TIM3) {
    // SAFETY: writing 0 clears the flags.
    t.sr().write(|w| unsafe { w.bits(0) });
}

/// Clears TIM2's update flag.
#[cfg(feature = "qemu")]
pub fn clear_tim2(t: &pac::TIM2) {
    // SAFETY: writing 0 clears the flags.
    t.sr().write(|w| unsafe { w.bits(0) });
}

/// USART3: 8N1 at [`BAUD`] from `apb1_hz`; received bytes by the receive
/// interrupt (`rx_irq`: the QEMU build, into [`crate::uart_rx::SoftDma`])
/// or by DMA (the board's `start_rx_dma`). The transmit interrupt is
/// turned on when bytes are queued.
pub fn start_usart(u: &pac::USART3, apb1_hz: u32, rx_irq: bool) {
    // BRR = f / baud in 1/16ths (oversampling by 16): 42 MHz gives 45.57,
    // written 46 (913,043 baud: 0.9 % slow, `crate::clocks::baud`).
    let brr = ((apb1_hz + BAUD / 2) / BAUD) as u16;
    let rxneie = if rx_irq { 1 << 5 } else { 0 };
    // SAFETY: plain register writes (BRR; CR1: UE, RXNEIE, TE, RE; CR3:
    // DMAR, the receive DMA request, when the interrupt does not take
    // the bytes).
    unsafe {
        u.brr().write(|w| w.bits(brr));
        // (DMAR with EIE: the receive DMA's line errors interrupt.)
        u.cr3()
            .write(|w| w.bits(if rx_irq { 0 } else { (1 << 6) | 1 }));
        u.cr1()
            .write(|w| w.bits((1 << 13) | rxneie | (1 << 3) | (1 << 2)));
    }
}

/// The USART's interrupt: with the receive interrupt on (the QEMU build)
/// every received byte into `soft` (with the overrun flag: a byte lost
/// before it); the next queued byte out while the transmitter is empty,
/// the transmit interrupt off when the queue is. Returns the bytes sent.
/// With the DMA receiving (the board: `soft` is `None`) DR is never read
/// here: that would take the DMA's byte.
pub fn usart_service(
    u: &mut pac::USART3,
    q: &mut UartEnds<'static>,
    soft: Option<&crate::uart_rx::SoftDma>,
    stats: &Stats,
) -> u32 {
    let sr = u.sr().read().bits();
    let rx_irq = u.cr1().read().bits() & (1 << 5) != 0;
    if let Some(soft) = soft.filter(|_| rx_irq && sr & ((1 << 5) | (1 << 3)) != 0) {
        // Reading SR then DR clears RXNE and the error flags.
        let b = (u.dr().read().bits() & 0xFF) as u8;
        if sr & (1 << 3) != 0 {
            stats
                .rx_lost
                .fetch_add(1, core::sync::atomic::Ordering::Relaxed);
        }
        crate::uart_rx::count_line_errors(u32::from(sr), &stats.rx_line);
        soft.write(b);
    }
    // The DMA receives: the error interrupt (EIE) counts and turns itself
    // off until the link task sees SR clear (`rearm_line_errors`).
    if soft.is_none()
        && u.cr3().read().bits() & 1 != 0
        && crate::uart_rx::count_line_errors(u32::from(sr), &stats.rx_line)
    {
        // SAFETY: EIE off, the rest of CR3 kept.
        u.cr3().modify(|r, w| unsafe { w.bits(r.bits() & !1) });
    }
    if u.cr1().read().bits() & (1 << 7) == 0 {
        return 0;
    }
    let mut sent = 0;
    // While the data register is empty: on the chip that is one byte (two
    // when the shift register is idle too), the next when TXE interrupts
    // again; QEMU sends each byte at once and drains the queue here.
    while u.sr().read().bits() & (1 << 7) != 0 {
        match q.next_tx() {
            // SAFETY: a byte into the data register.
            Some(b) => {
                u.dr().write(|w| unsafe { w.bits(u16::from(b)) });
                sent += 1;
            }
            None => {
                // SAFETY: TXEIE off, the rest of CR1 kept.
                u.cr1()
                    .modify(|r, w| unsafe { w.bits(r.bits() & !(1 << 7)) });
                return sent;
            }
        }
    }
    sent
}

/// The link task's run: the USART's error interrupt on again once SR
/// shows no line error (`crate::uart_rx::count_line_errors`), where the
/// DMA receives.
pub fn rearm_line_errors(u: &mut pac::USART3) {
    // SR is read only while EIE is off: a read of SR followed by the DMA's
    // read of DR clears the flags, and would hide an error the interrupt
    // has not counted yet.
    let cr3 = u.cr3().read().bits();
    let (dma, eie) = (cr3 & (1 << 6) != 0, cr3 & 1 != 0);
    if dma && !eie && crate::uart_rx::line_clear(u32::from(u.sr().read().bits())) {
        // SAFETY: EIE on, the rest of CR3 kept.
        u.cr3().modify(|r, w| unsafe { w.bits(r.bits() | 1) });
    }
}

/// Turns the USART's transmit interrupt on (bytes are queued) and pends
/// it: QEMU's USART model raises its interrupt for received bytes only,
/// never for TXE, so the first byte is sent from a pended interrupt (on
/// the chip the pend is redundant: TXE interrupts by itself).
pub fn listen_tx(u: &mut pac::USART3) {
    // SAFETY: TXEIE on, the rest of CR1 kept.
    u.cr1()
        .modify(|r, w| unsafe { w.bits(r.bits() | (1 << 7)) });
    NVIC::pend(Interrupt::USART3);
}

/// Clears the data-ready line's EXTI flag (line 4).
pub fn clear_data_ready() {
    // SAFETY: writing 1 clears the pending bit of line 4 only.
    unsafe { (*pac::EXTI::ptr()).pr().write(|w| w.bits(1 << 4)) };
}

/// Unmasks the interrupts the tasks are bound to, the tick's only when the
/// IMU came up. RTIC's `main` has already unmasked every bound interrupt
/// in the NVIC before `init` (they run once `init` returns), so the NVIC
/// alone is no gate: without the IMU, EXTI4 is masked again in the NVIC
/// and the line's own mask (EXTI_IMR bit 4, which RTIC does not touch)
/// stays clear, so a floating INT1 can never run the tick.
pub fn enable_interrupts(imu: bool) {
    // SAFETY: the tasks bound to them are ready (init has returned their
    // state by the time RTIC enables interrupts globally); IMR bit 4 is
    // the data-ready line's alone.
    unsafe {
        NVIC::unmask(Interrupt::USART3);
        NVIC::unmask(Interrupt::DMA1_STREAM1);
        NVIC::unmask(Interrupt::SPI3);
        NVIC::unmask(Interrupt::TIM3);
        #[cfg(feature = "qemu")]
        NVIC::unmask(Interrupt::TIM2);
        let exti = &*pac::EXTI::ptr();
        if imu {
            exti.imr().modify(|r, w| w.bits(r.bits() | (1 << 4)));
            NVIC::unmask(Interrupt::EXTI4);
        } else {
            exti.imr().modify(|r, w| w.bits(r.bits() & !(1 << 4)));
            NVIC::mask(Interrupt::EXTI4);
        }
    }
}

/// Reads the reset cause and clears the flags (RCC_CSR, RMVF).
pub fn reset_cause(rcc: &pac::RCC) -> protocol_codes::ResetCause {
    let csr = rcc.csr().read().bits();
    // SAFETY: RMVF (bit 24) clears the flags; the LSI bits are kept.
    rcc.csr()
        .modify(|r, w| unsafe { w.bits(r.bits() | (1 << 24)) });
    protocol_codes::ResetCause::from_rcc_csr(csr)
}

/// The protocol's codes.
pub use crate::protocol::codes as protocol_codes;

/// The IWDG and the timers (not the motor's PWM) stop while a debugger halts the core, and the
/// debug clocks keep running in sleep (`wfi` in idle would stop RTT and
/// the probe otherwise): DBGMCU.
pub fn freeze_for_debugger(d: &pac::DBGMCU) {
    // SAFETY: DBGMCU is for the debugger only.
    unsafe {
        // CR: DBG_SLEEP, DBG_STOP, DBG_STANDBY.
        d.cr().modify(|r, w| w.bits(r.bits() | 0b111));
        // APB1_FZ: TIM2 (0), TIM3 (1), TIM4 (2), TIM5 (3), IWDG (12).
        d.apb1_fz()
            .modify(|r, w| w.bits(r.bits() | 0b1111 | (1 << 12)));
        // APB2_FZ: TIM10 (the motor's PWM) is left running: frozen, its
        // output would stay at whatever level it had (full power with the
        // probability of the duty; TIM1's outputs went off with MOE,
        // TIM10 has no such gate, RM0090 19.3); running, the motor keeps
        // its last duty while the core is halted.
    }
}

/// Whether a tick is pending again (it ran past the next data-ready).
pub fn tick_pending() -> bool {
    NVIC::is_pending(Interrupt::EXTI4)
}

/// The reset log (`crate::resets`) in RAM the startup code does not
/// zero (cortex-m-rt's `.uninit` section): what the last run left.
#[link_section = ".uninit.rins_reset_log"]
static mut RESET_LOG: core::mem::MaybeUninit<crate::resets::ResetLog> =
    core::mem::MaybeUninit::uninit();

/// Reads, changes and writes back the reset log. Volatile: the RAM holds
/// what the last run wrote (or noise after a power-on, which the log's
/// check word refuses); every bit pattern is a value of its `u32` fields.
fn with_reset_log<R>(f: impl FnOnce(&mut crate::resets::ResetLog) -> R) -> R {
    let p = core::ptr::addr_of_mut!(RESET_LOG).cast::<crate::resets::ResetLog>();
    // SAFETY: called from `init` (interrupts off), from the link task (the
    // only task that touches it) and from the HardFault handler, which
    // resets the chip and never returns to the task it preempted.
    unsafe {
        let mut log = core::ptr::read_volatile(p);
        let r = f(&mut log);
        core::ptr::write_volatile(p, log);
        r
    }
}

/// At boot: this reset counted, and the verdict (resets in a row, safe
/// mode, a HardFault's registers).
pub fn reset_verdict(cause: protocol_codes::ResetCause) -> crate::resets::BootVerdict {
    with_reset_log(|l| l.boot(cause))
}

/// The board ran healthily: the row of resets is over.
pub fn reset_healthy() {
    with_reset_log(crate::resets::ResetLog::healthy);
}

// The HardFault's entry, before any Rust code pushes a word: with
// flip-link a stack overflow faults below RAM, where the exception's own
// stacking already failed; the handler's first push would fault again at
// priority -1 and lock the core up (the F4 does not reset on lock-up). So
// when MSP is within `HARD_FAULT_ROOM` of the stack's bottom (flip-link's
// `_stack_end`), MSP is set back to the stack's top first (what was there
// is not needed: the handler resets the chip), and a frame below the
// bottom is passed as none. Then `rins_hard_fault` with the frame (from
// MSP or PSP, as EXC_RETURN says) in r0.
core::arch::global_asm!(
    ".section .HardFaultTrampoline, \"ax\"",
    ".global HardFault",
    ".type HardFault,%function",
    ".thumb_func",
    "HardFault:",
    "mov r0, lr",
    "movs r1, #4",
    "tst r0, r1",
    "bne 1f",
    "mrs r0, MSP",
    "b 2f",
    "1:",
    "mrs r0, PSP",
    "2:",
    "ldr r1, =_stack_end",
    "ldr r3, ={room}",
    "add r3, r1",
    "mrs r2, MSP",
    "cmp r2, r3",
    "bhs 4f",
    "ldr r2, =_stack_start",
    "msr MSP, r2",
    "cmp r0, r1",
    "bhs 4f",
    "movs r0, #0",
    "4:",
    "b rins_hard_fault",
    ".ltorg",
    ".size HardFault, . - HardFault",
    room = const HARD_FAULT_ROOM,
);

/// The stack the HardFault handler needs, bytes (its frame and the reset
/// log's read-modify-write, with room to spare): MSP closer than this to
/// the stack's bottom is moved to its top before the handler runs.
const HARD_FAULT_ROOM: u32 = 512;

/// A HardFault: its registers kept for the next boot's report, then a
/// reset (`SYSRESETREQ`: the next boot reads "software" and the log's
/// fault). `frame` is null after a stack overflow (the exception's
/// stacking failed): PC and LR are then 0 and CFSR tells the stacking
/// error (STKERR, bit 12).
#[unsafe(no_mangle)]
unsafe extern "C" fn rins_hard_fault(frame: *const cortex_m_rt::ExceptionFrame) -> ! {
    // SAFETY: SCB's fault status and address registers are read-only
    // status here (ARMv7-M B3.2.15-B3.2.18); `frame` is null or the
    // exception's frame in the stack (the trampoline checked it).
    let (scb, ef) = unsafe { (&*cortex_m::peripheral::SCB::PTR, frame.as_ref()) };
    let regs = crate::resets::FaultRegs {
        cfsr: scb.cfsr.read(),
        hfsr: scb.hfsr.read(),
        mmfar: scb.mmfar.read(),
        bfar: scb.bfar.read(),
        pc: ef.map_or(0, |f| f.pc()),
        lr: ef.map_or(0, |f| f.lr()),
    };
    with_reset_log(|l| l.hard_fault(regs));
    cortex_m::peripheral::SCB::sys_reset()
}
