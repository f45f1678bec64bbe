//! The QEMU build's peripherals (`qemu-system-arm -M netduinoplus2
//! -icount shift=0`): what QEMU 7.2 models (USART3, TIM2-5, EXTI, NVIC,
//! SysTick) is the board's code (`bsp::common`); what it lacks is
//! replaced here and said so:
//!
//! - the IMU and the encoder: a replay (`target/qemu/current.bin`, made by
//!   `rins qemu-replay` and its host twin), read through semihosting;
//! - the IMU's data-ready line: TIM2 at 1 kHz pending EXTI4 from the end
//!   of `init` on (the sensors powered from reset, as on the board);
//! - the motor's PWM, the watchdog and the flash: a duty kept, feeds
//!   counted, a flash model in RAM (the journal's host tests cut its
//!   writes) that holds, at boot, the journal the replay's configuration
//!   left nearly full (`crate::replay::stored_journal`), so `init` moves it
//!   and erases both sectors, each putting the datasheet's worst time
//!   ([`crate::record::ERASE_WORST_US`]) on the firmware's clock (TIM5);
//!   the host's commands,
//!   sent again through the USART, change nothing;
//! - the clock set-up: none (no RCC model; TIM5's input is QEMU's 1 GHz);
//! - the cycle counter: SysTick, which under `-icount shift=0` counts
//!   instructions (one per ns of virtual time; 5.95 a count at the model's
//!   168 MHz).
//!
//! At the replay's end navigation prints the QEMU test's report (the
//! budgets, the stack's peak, the link, the outcome against the host's)
//! and exits with its result.

pub use super::common::*;

mod profile;
mod report;

use crate::record::{Flash, FlashError, Sector};
use crate::replay::{
    decode, decode_outcome, record_body, Event, Header, Sensors, HEADER, RECORD_HEAD, RECORD_MAX,
    TRAILER,
};
use crate::tasks::{Encoder, Imu, LinkTask, Motor, NavTask, Tuning, Watchdog};
use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use cortex_m::interrupt::Mutex;
use cortex_m_semihosting::{debug, hprintln, syscall};
use stm32f4xx_hal::pac;

/// QEMU's timer input clock (its STM32F405 model's TIM2-5: 1 GHz).
pub const TIMER_HZ: u32 = 1_000_000_000;
/// The 64-bit clock's counter at boot: 1.5 s below the u32 wrap after the
/// boot's two erases, so every replay crosses it.
pub const CLOCK_START: u32 = u32::MAX - 1_500_000 - 2 * crate::record::ERASE_WORST_US;
/// The journal's model (the host twin's too): two 2 KiB sectors of RAM.
pub const JOURNAL: [Sector; 2] = crate::record::MODEL_SECTORS;
/// The replay the runner put in place.
const REPLAY: &[u8] = b"target/qemu/current.bin\0";
/// Navigation runs that get the stress's extra work: 100 of them, while
/// navigating (150 s in: navigation then sends the tick no commands).
const STRESS: core::ops::Range<u32> = 15_000..15_100;
/// The stress: 4,000,000 instructions (4 ms of virtual time: what the
/// board's worst navigation run, a propagation and a fix, takes on the
/// chip at 1.25 cycles per instruction and 168 MHz), beyond the tick's 1 ms.
const STRESS_LOOPS: u32 = 1_000_000;

static DONE: AtomicBool = AtomicBool::new(false);
/// The flash model's erases.
static ERASES: AtomicU32 = AtomicU32::new(0);
static EDGES: AtomicU32 = AtomicU32::new(0);
static HW_COUNT: AtomicU32 = AtomicU32::new(0);
static NAV_RUNS: AtomicU32 = AtomicU32::new(0);
static STRESSED: AtomicU32 = AtomicU32::new(0);
static FEEDS: AtomicU32 = AtomicU32::new(0);
static TRAILER_BYTES: Mutex<RefCell<Option<[u8; TRAILER]>>> = Mutex::new(RefCell::new(None));

fn fail(msg: &str) -> ! {
    hprintln!("{}", msg);
    hprintln!("0 passed, 1 failed");
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Stops at init (a replay that cannot be read).
pub fn halt(why: &str) -> ! {
    fail(why)
}

fn read(fd: usize, buf: &mut [u8]) -> bool {
    // SYS_READ returns the number of bytes NOT read.
    // SAFETY: the buffer is valid for its length for the call.
    let left = unsafe { syscall!(READ, fd, buf.as_mut_ptr(), buf.len()) };
    left == 0
}

/// The replayed IMU: each read takes the events up to its tick.
pub struct BoardImu {
    fd: usize,
    left: u32,
    sensors: Sensors,
    reads: u64,
}

impl BoardImu {
    fn next(&mut self) -> Option<Event> {
        if self.left == 0 {
            return None;
        }
        self.left -= 1;
        let mut r = [0u8; RECORD_MAX];
        let head = r.get_mut(..RECORD_HEAD).is_some_and(|b| read(self.fd, b));
        let body = r.first().copied().and_then(record_body).unwrap_or(0);
        let ok = head
            && r.get_mut(RECORD_HEAD..RECORD_HEAD + body)
                .is_some_and(|b| read(self.fd, b));
        if !ok {
            fail("the replay ends early or holds a bad record");
        }
        decode(&r)
    }
}

impl Imu for BoardImu {
    fn read(&mut self) -> crate::tasks::Reading {
        let i = self.reads;
        self.reads += 1;
        let mut s = self.sensors;
        let more = s.advance(i, &mut || self.next(), &mut |_e| {});
        self.sensors = s;
        HW_COUNT.store(
            u32::from(crate::tasks::Encoder::count(&mut self.sensors)),
            Ordering::Relaxed,
        );
        if !more {
            let mut t = [0u8; TRAILER];
            if !read(self.fd, &mut t) {
                fail("the replay has no trailer");
            }
            cortex_m::interrupt::free(|cs| *TRAILER_BYTES.borrow(cs).borrow_mut() = Some(t));
            DONE.store(true, Ordering::Relaxed);
        }
        self.sensors.read()
    }
}

/// The replayed encoder (the IMU's read takes its events).
pub struct BoardEncoder;
impl Encoder for BoardEncoder {
    fn count(&mut self) -> u16 {
        HW_COUNT.load(Ordering::Relaxed) as u16
    }
}

/// The motor's duty, kept.
pub struct BoardMotor(pub f32);
impl Motor for BoardMotor {
    fn set(&mut self, duty: f32) {
        self.0 = duty;
    }
}

/// No IWDG in QEMU: feeds counted.
pub struct BoardWatchdog;
impl BoardWatchdog {
    /// Nothing to start.
    pub fn run_period(&mut self) {}
}
impl Watchdog for BoardWatchdog {
    fn feed(&mut self) {
        FEEDS.fetch_add(1, Ordering::Relaxed);
    }
}

/// NOR flash in RAM (bits only go 1 to 0 when programmed).
pub struct BoardFlash(&'static mut [u8; 4096]);
impl Flash for BoardFlash {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), FlashError> {
        let a = addr as usize;
        buf.copy_from_slice(self.0.get(a..a + buf.len()).ok_or(FlashError::OutOfRange)?);
        Ok(())
    }
    fn program_word(&mut self, addr: u32, word: u32) -> Result<(), FlashError> {
        let a = addr as usize;
        let d = self.0.get_mut(a..a + 4).ok_or(FlashError::OutOfRange)?;
        for (x, w) in d.iter_mut().zip(word.to_le_bytes()) {
            *x &= w;
        }
        Ok(())
    }
    fn erase(&mut self, s: Sector) -> Result<(), FlashError> {
        let a = s.base as usize;
        self.0
            .get_mut(a..a + s.len as usize)
            .ok_or(FlashError::OutOfRange)?
            .fill(0xFF);
        // The board's sector takes up to 2 s: put on the clock the
        // firmware reads (TIM5's µs, started before the journal opens).
        // (A busy wait of 2 s of virtual time is 2e9 instructions, minutes
        // of the host's time for each replay.)
        // SAFETY: TIM5's counter, which only this build's init and the
        // clock's reads touch.
        unsafe {
            (*pac::TIM5::ptr())
                .cnt()
                .modify(|r, w| w.bits(r.bits().wrapping_add(crate::record::ERASE_WORST_US)))
        };
        ERASES.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }
}

/// The QEMU board's peripherals.
pub type Board = Parts<BoardImu, BoardEncoder, BoardMotor, BoardFlash, BoardWatchdog>;

static TUNING: Mutex<RefCell<Option<Tuning>>> = Mutex::new(RefCell::new(None));

impl Board {
    /// The replay opened, the timers and the USART started.
    pub fn new(dp: pac::Peripherals) -> Self {
        // SAFETY: a NUL-terminated path; mode 1 = "rb".
        let fd = unsafe { syscall!(OPEN, REPLAY.as_ptr(), 1, REPLAY.len() - 1) };
        if fd == usize::MAX {
            fail("cannot open target/qemu/current.bin (the runner puts the replay there)");
        }
        let mut h = [0u8; HEADER];
        let Some(header) = (if read(fd, &mut h) {
            Header::decode(&h)
        } else {
            None
        }) else {
            fail("bad replay header");
        };
        let t = crate::replay::tuning(&header, crate::tuning::board());
        cortex_m::interrupt::free(|cs| *TUNING.borrow(cs).borrow_mut() = Some(t));
        let mut flash = BoardFlash(match cortex_m::singleton!(: [u8; 4096] = [0xFF; 4096]) {
            Some(m) => m,
            None => fail("the flash model is taken twice"),
        });
        store_configuration(&mut flash, header.commands, t);
        start_usart(&dp.USART3, 42_000_000, true);
        start_clock(&dp.TIM5, TIMER_HZ, CLOCK_START);
        start_tim3(&dp.TIM3, TIMER_HZ, 100);
        start_tim2(&dp.TIM2, TIMER_HZ, 1_000);
        Self {
            tim5: dp.TIM5,
            tim3: dp.TIM3,
            tim2: dp.TIM2,
            usart: dp.USART3,
            motor: BoardMotor(0.0),
            imu: BoardImu {
                fd,
                left: header.records,
                sensors: Sensors::default(),
                reads: 0,
            },
            encoder: BoardEncoder,
            flash,
            wdg: BoardWatchdog,
            imu_status: Ok(()),
            // QEMU has no RCC model: no clock set-up to time out.
            clock_status: Ok(()),
        }
    }
}

/// The journal the replay's configuration commands (its first
/// `commands` records) left, nearly full, into the flash model
/// (`crate::replay::stored_journal`), read through a second handle on the
/// replay.
fn store_configuration(flash: &mut BoardFlash, commands: u32, t: Tuning) {
    // SAFETY: a NUL-terminated path; mode 1 = "rb".
    let fd = unsafe { syscall!(OPEN, REPLAY.as_ptr(), 1, REPLAY.len() - 1) };
    let mut h = [0u8; HEADER];
    if fd == usize::MAX || !read(fd, &mut h) {
        fail("cannot read the replay's commands");
    }
    let mut left = commands;
    let cmds = core::iter::from_fn(|| {
        while left > 0 {
            left -= 1;
            let mut r = [0u8; RECORD_MAX];
            let head = r.get_mut(..RECORD_HEAD).is_some_and(|b| read(fd, b));
            let body = r.first().copied().and_then(record_body).unwrap_or(0);
            let ok = head
                && r.get_mut(RECORD_HEAD..RECORD_HEAD + body)
                    .is_some_and(|b| read(fd, b));
            if !ok {
                fail("the replay's commands end early");
            }
            if let Some(Event::Command { len, payload }) = decode(&r) {
                let c = payload
                    .get(..usize::from(len))
                    .and_then(|p| protocol::Command::decode(p).ok());
                if let Some((_, c)) = c {
                    return Some(c);
                }
            }
        }
        None
    });
    if crate::replay::stored_journal(flash, JOURNAL, cmds, t.control.limits).is_err() {
        fail("the flash model refused the stored journal");
    }
    // SAFETY: the handle opened above.
    unsafe { syscall!(CLOSE, fd) };
}

/// The clock's counter at boot.
pub fn clock_start(_tim5: &pac::TIM5) -> u32 {
    clock_now()
}

/// The replay's tuning.
pub fn tuning() -> Tuning {
    cortex_m::interrupt::free(|cs| *TUNING.borrow(cs).borrow()).unwrap_or_else(crate::tuning::board)
}

/// SysTick free-running over its 24 bits at the core clock.
pub fn start_cycle_counter(
    _dcb: &mut cortex_m::peripheral::DCB,
    _dwt: &mut cortex_m::peripheral::DWT,
    mut syst: cortex_m::peripheral::SYST,
) {
    syst.set_clock_source(cortex_m::peripheral::syst::SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    syst.enable_counter();
}

/// SysTick now.
pub fn cycles() -> u32 {
    cortex_m::peripheral::SYST::get_current()
}

/// Instructions since `c0` (SysTick counts down; 1,000 instructions are
/// 168 counts under `-icount shift=0` at the model's 168 MHz).
pub fn since(c0: u32) -> u32 {
    let counts = c0.wrapping_sub(cycles()) & 0x00FF_FFFF;
    (u64::from(counts) * 1_000 / 168) as u32
}

/// Whether the replay has ended.
pub fn replay_done() -> bool {
    DONE.load(Ordering::Relaxed)
}

/// The stress: for [`STRESS`] navigation runs, [`STRESS_LOOPS`] more
/// instructions of work; says whether this run had it.
pub fn stress() -> bool {
    let n = NAV_RUNS.fetch_add(1, Ordering::Relaxed);
    if !STRESS.contains(&n) {
        return false;
    }
    for _ in 0..STRESS_LOOPS {
        // Four instructions a turn: the nop, the add, the compare, the branch.
        cortex_m::asm::nop();
    }
    STRESSED.fetch_add(1, Ordering::Relaxed);
    true
}

/// Whether the data-ready stand-in may fire: while the replay runs, and
/// during the overrun probe after it.
pub fn sensors_on() -> bool {
    !DONE.load(Ordering::Relaxed)
        || matches!(PROBE.load(Ordering::Relaxed), PROBE_ARMED | PROBE_RUNNING)
}

/// The overrun probe's phases: off; armed (the next tick stalls); running
/// (the ticks after the stall, skipped: the replay is over); draining (no
/// more edges; a tick still pending is skipped too).
const PROBE_OFF: u32 = 0;
const PROBE_ARMED: u32 = 1;
const PROBE_RUNNING: u32 = 2;
const PROBE_DRAINING: u32 = 3;
static PROBE: AtomicU32 = AtomicU32::new(PROBE_OFF);
/// Ticks seen while the probe runs.
static PROBE_TICKS: AtomicU32 = AtomicU32::new(0);
/// The stall: 1,000,000 turns of a `nop` loop (two to four instructions a
/// turn: 2-4 ms of virtual time), so the next data-ready edge (1 ms) comes
/// while the tick still runs, whatever a turn costs.
const PROBE_LOOPS: u32 = 1_000_000;

/// In the tick, during the probe: the armed tick stalls past the next
/// edge (it must count one overrun); the ticks after it do nothing (the
/// replay is over). `false` otherwise: the tick runs.
pub fn overrun_probe() -> bool {
    match PROBE.load(Ordering::Relaxed) {
        PROBE_ARMED => {
            for _ in 0..PROBE_LOOPS {
                cortex_m::asm::nop();
            }
            PROBE.store(PROBE_RUNNING, Ordering::Relaxed);
            PROBE_TICKS.fetch_add(1, Ordering::Relaxed);
            true
        }
        PROBE_RUNNING | PROBE_DRAINING => {
            PROBE_TICKS.fetch_add(1, Ordering::Relaxed);
            true
        }
        _ => false,
    }
}

/// After the replay: one tick stalled past the next data-ready edge;
/// returns the overruns it made counted (the tick's own counter is left as
/// the replay had it, so the budget line is the replay's).
fn probe_overruns() -> u32 {
    let before = firmware_stats_overruns();
    PROBE.store(PROBE_ARMED, Ordering::Relaxed);
    // Wait (in navigation, below the tick) for the stalled tick and two
    // more; 10 ms of virtual time at most.
    let start = EDGES.load(Ordering::Relaxed);
    while PROBE_TICKS.load(Ordering::Relaxed) < 3
        && EDGES.load(Ordering::Relaxed).wrapping_sub(start) < 10
    {
        cortex_m::asm::wfi();
    }
    // No more edges; a tick pended before this runs now (above this task)
    // and is skipped.
    PROBE.store(PROBE_DRAINING, Ordering::Relaxed);
    cortex_m::asm::wfi();
    let counted = firmware_stats_overruns().wrapping_sub(before);

    STATS.tick_overruns.store(before, Ordering::Relaxed);
    counted
}

fn firmware_stats_overruns() -> u32 {
    STATS.tick_overruns.load(Ordering::Relaxed)
}

/// One data-ready edge made.
pub fn count_edge() {
    EDGES.fetch_add(1, Ordering::Relaxed);
}

/// Nothing after a link run: the sensors run from reset.
pub fn after_link(_: &mut LinkTask<'static>) {}

/// At the replay's end: the report, and QEMU's exit with its result.
pub fn after_nav(nav: &mut NavTask<'static>) {
    if !DONE.load(Ordering::Relaxed) {
        return;
    }
    let edges = EDGES.load(Ordering::Relaxed);
    // The peak before the probe and the report (whose printing and
    // profiling are not the board's).
    let stack = stack_peak();
    let probe_overruns = probe_overruns();
    let harness = Harness {
        edges,
        stressed: STRESSED.load(Ordering::Relaxed),
        stress_instructions: STRESS_LOOPS * 4,
        feeds: FEEDS.load(Ordering::Relaxed),
        clock_start: CLOCK_START,
        probe_overruns,
        erases: ERASES.load(Ordering::Relaxed),
    };
    let host = cortex_m::interrupt::free(|cs| *TRAILER_BYTES.borrow(cs).borrow())
        .map(|t| decode_outcome(&t));
    report::report(nav, &harness, host, stack);
}

/// The QEMU harness's own counts.
pub struct Harness {
    /// Data-ready edges made.
    pub edges: u32,
    /// Navigation runs stressed.
    pub stressed: u32,
    /// The stress's extra instructions a run.
    pub stress_instructions: u32,
    /// Watchdog feeds.
    pub feeds: u32,
    /// The clock's counter at boot.
    pub clock_start: u32,
    /// The flash model's erases (the boot's).
    pub erases: u32,
    /// Overruns counted when one tick was stalled past the next edge
    /// after the replay (one expected).
    pub probe_overruns: u32,
}

/// The receive ring where QEMU's USART interrupt writes (QEMU 7.2 models
/// no DMA on the STM32F405): the same ring reader as the board's.
static RX_SOFT: crate::uart_rx::SoftDma = crate::uart_rx::SoftDma::new();

/// The receive ring (the USART interrupt's).
pub fn rx() -> &'static crate::uart_rx::SoftDma {
    &RX_SOFT
}

/// The USART interrupt writes the ring.
pub fn rx_soft() -> Option<&'static crate::uart_rx::SoftDma> {
    Some(&RX_SOFT)
}

/// No DMA runs under QEMU.
pub fn rx_dma_event() {}

/// No DMA runs under QEMU.
pub fn rx_ready() {}
