//! The board's peripherals (Adafruit Feather STM32F405 Express, or any
//! STM32F405/F407 board with a 12 MHz crystal): every pin in one place.
//!
//! | signal | pin (Feather label) | peripheral |
//! | --- | --- | --- |
//! | IMU SCK / MISO / MOSI | PA5 / PA6 / PA7 (A1 / A2 / A3) | SPI1 (AF5), mode 0, the rig's clock (5.25 MHz), medium speed |
//! | IMU chip select | PA4 (A0) | GPIO, active low |
//! | IMU INT1 (data-ready) | PC4 (A4) | EXTI4, rising edge |
//! | encoder A / B | PB6 / PB7 (SCL / SDA) | TIM4 quadrature (AF2, 16-bit counter) |
//! | motor PWM | PB8 (D9) | TIM10 CH1 (AF3), the rig's frequency (20 kHz) |
//! | motor direction | PC6 (D6) | GPIO (high = positive rotation) |
//! | telemetry TX / RX | PB10 / PB11 (TX / RX) | USART3 (AF7), 921,600 baud |
//!
//! Checked against the Feather's own schematic (the header's nets) by
//! `firmware::pins` and its test: every pin here is on the header, no
//! two signals share a pin or a timer. (PA8, TIM1 CH1, is on no net of
//! the Feather.) The rig's values come from `sensors/rig.toml`
//! (`crate::rig`).

pub use super::common::*;

use crate::faults::Fault;
use crate::icm42688::{Config, Icm42688};
use crate::record::{Flash, FlashError, Sector, F405_SECTORS};
use crate::tasks::{Encoder, Motor, Tuning, Watchdog};
use embedded_hal::delay::DelayNs;
use embedded_hal_02::Qei as _;
use embedded_hal_bus::spi::ExclusiveDevice;
use stm32f4xx_hal::gpio::{Output, PushPull, Speed, PA4, PC6};
use stm32f4xx_hal::pac::{self, FLASH, SPI1, TIM10, TIM4};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::rcc::{Config as RccConfig, Enable};
use stm32f4xx_hal::spi::{Mode, Phase, Polarity, Spi};
use stm32f4xx_hal::timer::PwmChannel;

/// Crystal, Hz.
pub const HSE_HZ: u32 = crate::clocks::HSE_HZ;
/// System clock, Hz (through the PLL from HSE, or HSI as a fallback).
pub const SYSCLK_HZ: u32 = 168_000_000;
/// APB1 (USART3), Hz: SYSCLK / 4 (APB1's timers, TIM2-5, at twice it).
pub const APB1_HZ: u32 = 42_000_000;
/// The journal's sectors.
pub const JOURNAL: [Sector; 2] = F405_SECTORS;
/// The 64-bit clock's counter at boot.
const CLOCK_START: u32 = 0;

/// The IMU's SPI device: the bus, chip select, and a real delay.
type ImuSpi = ExclusiveDevice<Spi<SPI1>, PA4<Output<PushPull>>, CycleDelay>;

/// A busy-wait delay (the IMU's start-up, before the scheduler runs) at
/// the system clock's MHz.
pub struct CycleDelay(u32);
impl DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        cortex_m::asm::delay((u64::from(ns) * u64::from(self.0) / 1_000) as u32);
    }
}

/// RCC's start-up flags (RM0090 7.3.1, 7.3.2) for `crate::clocks`.
struct Rcc<'a>(&'a pac::RCC);

impl crate::ports::ClockControl for Rcc<'_> {
    fn hse_on(&mut self, on: bool) {
        self.0.cr().modify(|_, w| w.hseon().bit(on));
    }
    fn hse_ready(&mut self) -> bool {
        self.0.cr().read().hserdy().bit_is_set()
    }
    fn pll_configure(&mut self, src: crate::ports::ClockSource) {
        // SAFETY: the PLL is off (PLLCFGR is written only then); its
        // reserved bits kept (`crate::clocks::pllcfgr`).
        self.0
            .pllcfgr()
            .modify(|r, w| unsafe { w.bits(crate::clocks::pllcfgr(r.bits(), src)) });
    }
    fn pll_on(&mut self, on: bool) {
        self.0.cr().modify(|_, w| w.pllon().bit(on));
    }
    fn pll_ready(&mut self) -> bool {
        self.0.cr().read().pllrdy().bit_is_set()
    }
}

/// The clock tree started with every wait bounded (`crate::clocks`),
/// then set by the HAL for the crystal (its own waits then return at once:
/// the same parts just started); without the crystal, the PLL from HSI
/// by its registers (the HAL's HSI set-up links panic paths), or HSI's 16
/// MHz alone (the reset state). Returns the HAL's clocks, the plan that
/// ran, and its status.
fn start_clocks(
    rcc: pac::RCC,
) -> (
    stm32f4xx_hal::rcc::Rcc,
    crate::clocks::Plan,
    Result<(), Fault>,
) {
    use crate::clocks::Plan;
    let mut plan = crate::clocks::plan(&mut Rcc(&rcc), crate::clocks::START_POLLS);
    if let Plan::Hsi168(f) = plan {
        if !hsi_pll(&rcc) {
            plan = Plan::Hsi16(f);
        }
    }
    let rcc = match plan {
        Plan::Hse168 => rcc.freeze(
            RccConfig::hse(HSE_HZ.Hz())
                .sysclk(SYSCLK_HZ.Hz())
                .pclk1(APB1_HZ.Hz()),
        ),
        // (The HAL's record then says 16 MHz: the SPI it sets up runs at
        // 84 MHz / 4 = 21 MHz (it divides 16 MHz for 5.25: /4), inside the
        // ICM-42688-P's 24 MHz, for the IMU's start only; the PWM at 210
        // kHz. The board is stopped: the motor's duty stays 0.)
        Plan::Hsi168(_) | Plan::Hsi16(_) => rcc.constrain(),
    };
    (rcc, plan, plan.status())
}

/// The system from the PLL (configured from HSI by `crate::clocks::plan`,
/// left off): on, locked, flash at 5 wait states (RM0090 table 10, 168 MHz
/// at 2.7-3.6 V), AHB /1, APB1 /4, APB2 /2, then switched to it; every
/// wait bounded. `false`: it did not take (the system stays on HSI).
fn hsi_pll(rcc: &pac::RCC) -> bool {
    let polls = crate::clocks::START_POLLS;
    rcc.cr().modify(|_, w| w.pllon().set_bit());
    if !(0..polls).any(|_| rcc.cr().read().pllrdy().bit_is_set()) {
        rcc.cr().modify(|_, w| w.pllon().clear_bit());
        return false;
    }
    // SAFETY: ACR's LATENCY (2:0) 5 with the prefetch (8) and both caches
    // (9, 10) on; CFGR's HPRE (7:4) 0, PPRE1 (12:10) 0b101, PPRE2 (15:13)
    // 0b100, then SW (1:0) 0b10: documented values.
    unsafe {
        (*pac::FLASH::ptr())
            .acr()
            .modify(|r, w| w.bits((r.bits() & !0b111) | 5 | (1 << 8) | (1 << 9) | (1 << 10)));
        rcc.cfgr()
            .modify(|r, w| w.bits((r.bits() & !0xFCF0) | (0b101 << 10) | (0b100 << 13)));
        rcc.cfgr().modify(|r, w| w.bits((r.bits() & !0b11) | 0b10));
    }
    if (0..polls).any(|_| (rcc.cfgr().read().bits() >> 2) & 0b11 == 0b10) {
        return true;
    }
    // It did not take: back to HSI (SW 0) with the prescalers at 1, the
    // PLL off, as `Board::new` then assumes.
    // SAFETY: SW (1:0) 0, HPRE/PPRE1/PPRE2 0: the reset's values.
    unsafe {
        rcc.cfgr()
            .modify(|r, w| w.bits(r.bits() & !(0xFCF0 | 0b11)))
    };
    let _ = (0..polls).any(|_| (rcc.cfgr().read().bits() >> 2) & 0b11 == 0);
    rcc.cr().modify(|_, w| w.pllon().clear_bit());
    false
}

/// The IMU (absent when it did not come up: the tick never runs).
pub struct BoardImu(Option<Icm42688<ImuSpi>>);
impl crate::tasks::Imu for BoardImu {
    fn read(&mut self) -> crate::tasks::Reading {
        self.0.as_mut().ok_or(crate::tasks::BusError)?.read()
    }
}

/// The encoder.
pub struct BoardEncoder(Qei<TIM4>);
impl Encoder for BoardEncoder {
    fn count(&mut self) -> u16 {
        self.0.count() // TIM4: a 16-bit counter
    }
}

/// The motor: PWM duty and direction.
pub struct BoardMotor {
    pwm: PwmChannel<TIM10, 0>,
    dir: PC6<Output<PushPull>>,
}
impl Motor for BoardMotor {
    fn set(&mut self, duty: f32) {
        let max = self.pwm.get_max_duty();
        self.pwm
            .set_duty((duty.abs().min(1.0) * f32::from(max)) as u16);
        if duty >= 0.0 {
            self.dir.set_high();
        } else {
            self.dir.set_low();
        }
    }
}

/// The independent watchdog (RM0090 21), by its registers: started at the
/// top of `init` at [`crate::watchdog::BOOT`]'s period (the boot's
/// erases), set to [`crate::watchdog::RUN`]'s when the tasks start. (The
/// HAL's driver picks its own prescaler and reload for a period asked at
/// the typical LSI: /256 and 12, 71-196 ms over the LSI's range.)
pub struct BoardWatchdog(pac::IWDG);

/// IWDG_KR's keys: reload, register access, start (RM0090 21.4.1).
const IWDG_RELOAD: u16 = 0xAAAA;
const IWDG_ACCESS: u16 = 0x5555;
const IWDG_START: u16 = 0xCCCC;

impl BoardWatchdog {
    /// Started with the boot's period (the LSI starts with it).
    fn start(iwdg: pac::IWDG) -> Self {
        // SAFETY: the documented key.
        iwdg.kr().write(|w| unsafe { w.bits(IWDG_START) });
        let mut w = Self(iwdg);
        w.set(crate::watchdog::BOOT);
        w
    }
    /// A new period: PR and RLR written once the last update is through
    /// (SR's PVU and RVU, a few LSI periods; bounded: a write that cannot
    /// go through keeps the period that is running), then a feed.
    fn set(&mut self, s: crate::watchdog::Iwdg) {
        let idle = |w: &Self| w.0.sr().read().bits() & 0b11 == 0;
        let _ = (0..crate::clocks::START_POLLS).any(|_| idle(self));
        // SAFETY: the access key, then PR (0-6) and RLR (12 bits), in range
        // by `Iwdg::valid` (a host test).
        unsafe {
            self.0.kr().write(|w| w.bits(IWDG_ACCESS));
            self.0.pr().write(|w| w.bits(u16::from(s.pr) & 0b111));
            self.0.rlr().write(|w| w.bits(s.rlr & 0x0FFF));
        }
        let _ = (0..crate::clocks::START_POLLS).any(|_| idle(self));
        self.feed();
    }
    /// The tasks start: the run period.
    pub fn run_period(&mut self) {
        self.set(crate::watchdog::RUN);
    }
}
impl Watchdog for BoardWatchdog {
    fn feed(&mut self) {
        // SAFETY: the documented key.
        self.0.kr().write(|w| unsafe { w.bits(IWDG_RELOAD) });
    }
}

/// The flash controller (RM0090 3.6), with the PAC directly: the HAL's
/// `unlocked()` asserts that the unlock took (a panic path); here a flash
/// that stays locked, or any error flag, is a value.
pub struct BoardFlash(FLASH);

const KEY1: u32 = 0x4567_0123;
const KEY2: u32 = 0xCDEF_89AB;
/// SR error bits: OPERR, WRPERR, PGAERR, PGPERR, PGSERR.
const ERRORS: u32 = 0b1111_0010;

impl BoardFlash {
    fn wait(&self) {
        while self.0.sr().read().bsy().bit_is_set() {}
    }
    fn check(&self) -> Result<(), FlashError> {
        let sr = self.0.sr().read().bits() & ERRORS;
        // SAFETY: writing ones to the error flags only clears them.
        self.0.sr().write(|w| unsafe { w.bits(ERRORS) });
        if sr == 0 {
            Ok(())
        } else {
            Err(FlashError::Controller(sr))
        }
    }
    fn unlocked<R>(
        &mut self,
        f: impl FnOnce(&Self) -> Result<R, FlashError>,
    ) -> Result<R, FlashError> {
        self.wait();
        if self.0.cr().read().lock().bit_is_set() {
            // SAFETY: the documented unlock keys.
            self.0.keyr().write(|w| unsafe { w.key().bits(KEY1) });
            self.0.keyr().write(|w| unsafe { w.key().bits(KEY2) });
        }
        if self.0.cr().read().lock().bit_is_set() {
            return Err(FlashError::Controller(0));
        }
        let _ = self.check();
        let r = f(self);
        self.0
            .cr()
            .modify(|_, w| w.pg().clear_bit().ser().clear_bit().lock().set_bit());
        r
    }
}

fn in_journal(addr: u32, len: usize) -> bool {
    JOURNAL
        .iter()
        .any(|s| addr >= s.base && addr as usize + len <= (s.base + s.len) as usize)
}

impl Flash for BoardFlash {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), FlashError> {
        if !in_journal(addr, buf.len()) {
            return Err(FlashError::OutOfRange);
        }
        for (i, b) in buf.iter_mut().enumerate() {
            // SAFETY: inside the journal's sectors (checked).
            *b = unsafe { core::ptr::read_volatile((addr as usize + i) as *const u8) };
        }
        Ok(())
    }

    fn program_word(&mut self, addr: u32, word: u32) -> Result<(), FlashError> {
        if !in_journal(addr, 4) || !addr.is_multiple_of(4) {
            return Err(FlashError::OutOfRange);
        }
        self.unlocked(|f| {
            // SAFETY: PSIZE 2 (x32), PG set.
            f.0.cr()
                .modify(|_, w| unsafe { w.psize().bits(2).ser().clear_bit().pg().set_bit() });
            // SAFETY: an erased, aligned word of the journal (checked).
            unsafe { core::ptr::write_volatile(addr as *mut u32, word) };
            f.wait();
            f.check()
        })
    }

    fn erase(&mut self, s: Sector) -> Result<(), FlashError> {
        if !JOURNAL.contains(&s) {
            return Err(FlashError::OutOfRange);
        }
        self.unlocked(|f| {
            // SAFETY: SNB takes the sector number (0-11 on the F405).
            f.0.cr().modify(|_, w| unsafe {
                w.psize()
                    .bits(2)
                    .snb()
                    .bits(s.number)
                    .ser()
                    .set_bit()
                    .pg()
                    .clear_bit()
            });
            f.0.cr().modify(|_, w| w.strt().set_bit());
            f.wait();
            f.check()
        })
    }
}

/// The board's peripherals, set up.
pub type Board = Parts<BoardImu, BoardEncoder, BoardMotor, BoardFlash, BoardWatchdog>;

impl Board {
    /// Clocks, pins and peripherals; the IMU initialised.
    pub fn new(dp: pac::Peripherals) -> Self {
        // First: a boot that hangs anywhere after this is reset.
        let wdg = BoardWatchdog::start(dp.IWDG);
        let (mut rcc, plan, clock_status) = start_clocks(dp.RCC);
        // The clocks the plan runs (APB1's timers at twice APB1 when it is
        // divided), not the HAL's record.
        let (sysclk, apb1) = match plan {
            crate::clocks::Plan::Hsi16(_) => (16_000_000, 16_000_000),
            _ => (SYSCLK_HZ, plan.apb1_hz()),
        };
        let timer = if apb1 < sysclk { 2 * apb1 } else { apb1 };
        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);
        pac::TIM5::enable(&mut rcc);
        pac::TIM3::enable(&mut rcc);
        pac::USART3::enable(&mut rcc);
        pac::SYSCFG::enable(&mut rcc);
        let _tx = gpiob.pb10.into_alternate::<7>();
        let _rx = gpiob.pb11.into_alternate::<7>();
        pac::DMA1::enable(&mut rcc);
        start_usart(&dp.USART3, apb1, false);
        start_rx_dma(&dp.DMA1);
        start_clock(&dp.TIM5, timer, CLOCK_START);
        start_tim3(&dp.TIM3, timer, 100);
        // The IMU's INT1 on PC4: EXTI4 from port C, rising edge.
        let _int1 = gpioc.pc4.into_pull_down_input();
        // SAFETY: EXTICR2 bits 3:0 select line 4's port (2 = C); RTSR bit
        // 4. The line's mask (IMR) is set by `enable_interrupts`, only
        // when the IMU came up.
        unsafe {
            dp.SYSCFG
                .exticr2()
                .modify(|r, w| w.bits((r.bits() & !0xF) | 2));
            dp.EXTI.rtsr().modify(|r, w| w.bits(r.bits() | (1 << 4)));
        }
        let mode = Mode {
            polarity: Polarity::IdleLow,
            phase: Phase::CaptureOnFirstTransition,
        };
        // Asked exactly a divided clock, the HAL takes that divisor
        // (`crate::rig::spi_clock`); SCK and MOSI at medium speed (25 MHz
        // at 50 pF by the datasheet; the reset's low speed is rated 2 MHz).
        let sck = gpioa.pa5.into_alternate::<5>().speed(Speed::Medium);
        let mosi = gpioa.pa7.into_alternate::<5>().speed(Speed::Medium);
        let spi = dp.SPI1.spi(
            (Some(sck), Some(gpioa.pa6), Some(mosi)),
            mode,
            crate::rig::IMU_SPI_HZ.Hz(),
            &mut rcc,
        );
        let cs = gpioa
            .pa4
            .into_push_pull_output_in_state(stm32f4xx_hal::gpio::PinState::High);
        let (imu, imu_status) = match ExclusiveDevice::new(spi, cs, CycleDelay(sysclk / 1_000_000))
        {
            Ok(dev) => {
                let mut imu = Icm42688::new(dev);
                match imu.init(Config::default(), &mut CycleDelay(sysclk / 1_000_000)) {
                    Ok(()) => (Some(imu), Ok(())),
                    Err(crate::icm42688::Error::WrongDevice(_)) => (None, Err(Fault::WrongDevice)),
                    Err(_) => (None, Err(Fault::ImuInitFailed)),
                }
            }
            Err(_) => (None, Err(Fault::ImuInitFailed)),
        };
        let qei = Qei::new(dp.TIM4, (gpiob.pb6, gpiob.pb7), &mut rcc);
        let (_, (ch1, ..)) = dp.TIM10.pwm_hz(crate::rig::RIG.pwm_hz.Hz(), &mut rcc);
        let mut pwm = ch1.with(gpiob.pb8);
        pwm.set_duty(0);
        pwm.enable();
        let dir = gpioc.pc6.into_push_pull_output();
        Self {
            tim5: dp.TIM5,
            tim3: dp.TIM3,
            usart: dp.USART3,
            motor: BoardMotor { pwm, dir },
            imu: BoardImu(imu),
            encoder: BoardEncoder(qei),
            flash: BoardFlash(dp.FLASH),
            wdg,
            imu_status,
            clock_status,
        }
    }
}

/// The clock's counter at boot.
pub fn clock_start(_tim5: &pac::TIM5) -> u32 {
    clock_now()
}

/// The compiled-in tuning: the ICM-42688-P's filter noise model.
pub fn tuning() -> Tuning {
    crate::tuning::board()
}

/// Turns DWT's cycle counter on (the tasks' worst cases).
pub fn start_cycle_counter(
    dcb: &mut cortex_m::peripheral::DCB,
    dwt: &mut cortex_m::peripheral::DWT,
    _syst: cortex_m::peripheral::SYST,
) {
    dcb.enable_trace();
    dwt.enable_cycle_counter();
}

/// CPU cycles now.
pub fn cycles() -> u32 {
    cortex_m::peripheral::DWT::cycle_count()
}

/// Cycles since `c0`.
pub fn since(c0: u32) -> u32 {
    cycles().wrapping_sub(c0)
}

/// Stops for good at initialisation, in the safe state (the PWM duty 0):
/// the board stays halted with the reason in the log instead of
/// panicking. The watchdog runs from the top of `init` and cannot be
/// stopped: it is fed here (a halt, not a reset loop).
pub fn halt(why: &str) -> ! {
    defmt::error!("halted at init: {=str}", why);
    loop {
        // SAFETY: IWDG_KR's reload key; no other code runs.
        unsafe { (*pac::IWDG::ptr()).kr().write(|w| w.bits(IWDG_RELOAD)) };
        // 10 ms at 168 MHz (16 MHz from HSI: 105 ms), inside the boot
        // period's shortest 5.6 s.
        cortex_m::asm::delay(SYSCLK_HZ / 100);
    }
}

/// After each link run: the stack's peak to the log once a minute (a
/// probe reads it; the QEMU build prints it).
pub fn after_link(_: &mut crate::tasks::LinkTask<'static>) {
    static RUNS: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);
    if RUNS
        .fetch_add(1, core::sync::atomic::Ordering::Relaxed)
        .is_multiple_of(6_000)
    {
        // Read before the log takes its critical section: the scan of the
        // stack is long, the masked log frame must stay short (the UART).
        let peak = stack_peak();
        STATS
            .stack_bytes
            .store(peak, core::sync::atomic::Ordering::Relaxed);
        defmt::info!("stack peak: {=u32} bytes", peak);
    }
}

/// The receive ring's length, bytes: 22 ms at 921,600 baud, twice the
/// link task's period (the book's firmware chapter has the margins).
const RX_LEN: u32 = 2048;

/// The receive ring DMA1 stream 1 writes (circular, a byte at a time).
static mut RX_RING: [u8; RX_LEN as usize] = [0; RX_LEN as usize];

/// Half rings the stream has completed (its interrupt counts them).
static RX_HALVES: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

/// DMA1 stream 1's flags in LISR / LIFCR: FEIF1 (6), DMEIF1 (8), TEIF1
/// (9), HTIF1 (10), TCIF1 (11) (RM0090 10.5.1).
const S1_FLAGS: u32 = 0b1111_0100_0000;

/// USART3's data register (RM0090 table 1 and 30.6.2), the stream's
/// source.
const USART3_DR: u32 = 0x4000_4804;

/// The stream's last restart after a transfer error: the count, where the
/// writer stopped, where it went on from (`crate::ports::Restart`).
static RX_RESTARTS: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);
static RX_STOPPED_AT: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);
static RX_FROM: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

/// Starts USART3's receive DMA: DMA1 stream 1, channel 4 (RM0090 table
/// 42), peripheral to memory, bytes, circular over [`RX_RING`], the
/// half-transfer and transfer-complete interrupts counting its halves, a
/// transfer error's too (the stream is started again).
fn start_rx_dma(dma: &pac::DMA1) {
    let s = dma.st(1);
    // SAFETY: the stream is off while it is set up; USART3's DR.
    unsafe {
        s.cr().write(|w| w.bits(0));
        while s.cr().read().bits() & 1 != 0 {}
        s.par().write(|w| w.bits(USART3_DR));
    }
    restart_rx_dma(dma);
}

/// The stream (off) set up from the ring's start and enabled: M0AR and
/// NDTR written anew (a transfer error leaves them where it stopped).
fn restart_rx_dma(dma: &pac::dma2::RegisterBlock) {
    let s = dma.st(1);
    let ring = core::ptr::addr_of_mut!(RX_RING) as u32;
    // SAFETY: the stream is off (EN reads 0: a transfer error clears it,
    // `start_rx_dma` waits for it); the address of a static the stream
    // alone writes, its length.
    unsafe {
        dma.lifcr().write(|w| w.bits(S1_FLAGS));
        s.m0ar().write(|w| w.bits(ring));
        s.ndtr().write(|w| w.bits(RX_LEN));
        // CHSEL 4 (27:25), PL high (17:16 = 2), MINC (10), CIRC (8),
        // DIR peripheral to memory (7:6 = 0), TCIE (4), HTIE (3),
        // TEIE (2), EN (0). FIFO off (direct mode, FCR's reset value).
        s.cr().write(|w| {
            w.bits(
                (4 << 25) | (2 << 16) | (1 << 10) | (1 << 8) | (1 << 4) | (1 << 3) | (1 << 2) | 1,
            )
        });
    }
}

/// DMA1 stream 1's interrupt: half rings counted; after a transfer error
/// (which turns the stream off) the stream starts again from the ring's
/// start, the half rings counted to the next whole ring, and the restart
/// told to the reader (`crate::uart_rx::RxRing::sync` counts the bytes it
/// had not read as lost).
pub fn rx_dma_event() {
    use core::sync::atomic::Ordering::{Relaxed, Release};
    // SAFETY: DMA1's flags; the stream's registers only this interrupt
    // and `start_rx_dma` (before it is unmasked) write.
    let dma = unsafe { &*pac::DMA1::ptr() };
    let lisr = dma.lisr().read().bits();
    // SAFETY: writing ones clears stream 1's flags only.
    dma.lifcr().write(|w| unsafe { w.bits(lisr & S1_FLAGS) });
    let halves = ((lisr >> 10) & 1) + ((lisr >> 11) & 1);
    RX_HALVES.fetch_add(halves, Release);
    if lisr & (1 << 9) != 0 {
        // Wait for EN to read 0 (RM0090 10.3.17), bounded.
        let _ = (0..crate::clocks::START_POLLS).any(|_| dma.st(1).cr().read().bits() & 1 == 0);
        let stopped = crate::uart_rx::RxRing::written(&BoardRx);
        let r = crate::uart_rx::restart_from(stopped, RX_LEN);
        RX_STOPPED_AT.store(r.stopped_at, Relaxed);
        RX_FROM.store(r.from, Relaxed);
        RX_HALVES.store(r.from / (RX_LEN / 2), Relaxed);
        RX_RESTARTS.fetch_add(1, Release);
        restart_rx_dma(dma);
    }
}

/// When `init` ends, before the stream's interrupt can run: its half-ring
/// events during `init` (up to 4 s of erases, 40 rings at the line's full
/// rate) have merged in the flags, so the count of halves is set from the
/// stream's position in the ring, as if it had not wrapped; a wrap during
/// `init` (TCIF) counts the older lap's bytes lost (at least).
pub fn rx_ready() {
    use core::sync::atomic::Ordering::{Relaxed, Release};
    // SAFETY: DMA1's flags and stream 1's counter; its interrupt is not
    // running yet (`init`).
    let dma = unsafe { &*pac::DMA1::ptr() };
    let half = |n: u32| u32::from(RX_LEN - n.clamp(1, RX_LEN) >= RX_LEN / 2);
    for _ in 0..4 {
        let n1 = dma.st(1).ndtr().read().bits() & 0xFFFF;
        let lisr = dma.lisr().read().bits();
        // SAFETY: writing ones clears stream 1's HT and TC flags only.
        dma.lifcr().write(|w| unsafe { w.bits(0b11 << 10) });
        let n2 = dma.st(1).ndtr().read().bits() & 0xFFFF;
        // The same half, no wrap between the reads: no event lost or
        // counted twice.
        if n2 <= n1 && half(n1) == half(n2) {
            if lisr & (1 << 11) != 0 {
                STATS.rx_lost.fetch_add(n2.min(RX_LEN), Relaxed);
            }
            RX_HALVES.store(half(n2), Release);
            return;
        }
    }
}

/// The receive ring as the link task reads it.
pub struct BoardRx;

impl crate::ports::RxDma for BoardRx {
    const LEN: u32 = RX_LEN;
    fn halves(&self) -> u32 {
        RX_HALVES.load(core::sync::atomic::Ordering::Acquire)
    }
    fn remaining(&self) -> u32 {
        // SAFETY: a read of the stream's counter.
        unsafe { (*pac::DMA1::ptr()).st(1).ndtr().read().bits() & 0xFFFF }
    }
    fn restarted(&self) -> crate::ports::Restart {
        use core::sync::atomic::Ordering::{Acquire, Relaxed};
        let count = RX_RESTARTS.load(Acquire);
        crate::ports::Restart {
            count,
            stopped_at: RX_STOPPED_AT.load(Relaxed),
            from: RX_FROM.load(Relaxed),
        }
    }
    fn byte(&self, i: u32) -> u8 {
        if i >= RX_LEN {
            return 0;
        }
        // SAFETY: inside the ring (checked); a volatile read of a byte the
        // DMA may be writing (a byte is written whole).
        unsafe {
            core::ptr::read_volatile(core::ptr::addr_of!(RX_RING).cast::<u8>().add(i as usize))
        }
    }
}

/// The receive ring (the DMA's).
pub fn rx() -> &'static BoardRx {
    &BoardRx
}

/// No software ring on the board: the DMA receives.
pub fn rx_soft() -> Option<&'static crate::uart_rx::SoftDma> {
    None
}
